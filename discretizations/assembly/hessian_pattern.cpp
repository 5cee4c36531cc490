#include "discretizations/assembly/hessian_pattern.hpp"

#include <algorithm>
#include <cassert>
#include <stdexcept>
#include <string>

namespace twill {

HessianPattern::HessianPattern(int num_nodes, const ElementNodes& elements) {
  // Nodes coupled to each node (sorted, unique): the pattern's block rows of its columns.
  std::vector<std::vector<int>> neighbours(static_cast<std::size_t>(num_nodes));
  for (int e = 0; e < elements.size(); ++e)
    for (int a : elements[e])
      for (int b : elements[e]) {
        if (a < 0 || a >= num_nodes || b < 0 || b >= num_nodes)
          throw std::logic_error("HessianPattern: element " + std::to_string(e) + " has node " +
                                 std::to_string(a < 0 || a >= num_nodes ? a : b) + " of " +
                                 std::to_string(num_nodes));
        neighbours[static_cast<std::size_t>(b)].push_back(a);
      }
  for (auto& list : neighbours) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  outer_.assign(static_cast<std::size_t>(3 * num_nodes + 1), 0);
  for (int b = 0; b < num_nodes; ++b)
    for (int s = 0; s < 3; ++s) {
      const auto column = static_cast<std::size_t>(3 * b + s);
      const auto& rows = neighbours[static_cast<std::size_t>(b)];
      outer_[column + 1] = outer_[column] + 3 * static_cast<int>(rows.size());
      for (int a : rows)
        for (int r = 0; r < 3; ++r) inner_.push_back(3 * a + r);
    }

  slot_start_.reserve(static_cast<std::size_t>(elements.size()) + 1);
  slot_start_.push_back(0);
  for (int e = 0; e < elements.size(); ++e) {
    const std::size_t m = elements[e].size();
    slot_start_.push_back(slot_start_.back() + m * m * 3);
  }
  slots_.resize(slot_start_.back());
  for (int e = 0; e < elements.size(); ++e) {
    const std::span<const int> nodes = elements[e];
    const std::size_t m = nodes.size();
    int* slots = slots_.data() + slot_start_[static_cast<std::size_t>(e)];
    for (std::size_t a = 0; a < m; ++a)
      for (std::size_t b = 0; b < m; ++b) {
        const auto& rows = neighbours[static_cast<std::size_t>(nodes[b])];
        const auto rank = std::lower_bound(rows.begin(), rows.end(), nodes[a]) - rows.begin();
        for (int s = 0; s < 3; ++s) {
          const int slot = outer_[static_cast<std::size_t>(3 * nodes[b] + s)] + 3 * static_cast<int>(rank);
          assert(inner_[static_cast<std::size_t>(slot)] == 3 * nodes[a]);
          slots[(a * m + b) * 3 + static_cast<std::size_t>(s)] = slot;
        }
      }
  }
}

double* HessianPattern::prepare(SparseMatrix* hessian) const {
  const int n = num_dofs();
  const std::size_t nnz = num_nonzeros();
  const bool same_pattern =
      hessian->rows() == n && hessian->cols() == n && hessian->isCompressed() &&
      static_cast<std::size_t>(hessian->nonZeros()) == nnz &&
      std::equal(outer_.begin(), outer_.end(), hessian->outerIndexPtr()) &&
      std::equal(inner_.begin(), inner_.end(), hessian->innerIndexPtr());
  if (!same_pattern) {
    hessian->resize(n, n);
    hessian->resizeNonZeros(static_cast<Eigen::Index>(nnz));
    std::copy(outer_.begin(), outer_.end(), hessian->outerIndexPtr());
    std::copy(inner_.begin(), inner_.end(), hessian->innerIndexPtr());
  }
  std::fill(hessian->valuePtr(), hessian->valuePtr() + nnz, 0.0);
  return hessian->valuePtr();
}

SparseMatrix HessianPattern::matrix() const {
  SparseMatrix out;
  prepare(&out);
  return out;
}

std::size_t HessianPattern::bytes() const {
  return (outer_.capacity() + inner_.capacity() + slots_.capacity()) * sizeof(int) +
         slot_start_.capacity() * sizeof(std::size_t);
}

}  // namespace twill
