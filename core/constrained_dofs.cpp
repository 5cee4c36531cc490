#include "core/constrained_dofs.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace twill {

ConstrainedDofs::ConstrainedDofs(int num_dofs, std::vector<int> fixed_dofs) : num_dofs_(num_dofs) {
  if (num_dofs < 0) {
    throw std::invalid_argument("ConstrainedDofs: num_dofs must be >= 0 (got " +
                                std::to_string(num_dofs) + ")");
  }
  for (size_t k = 0; k < fixed_dofs.size(); ++k) {
    if (fixed_dofs[k] < 0 || fixed_dofs[k] >= num_dofs) {
      throw std::invalid_argument("ConstrainedDofs: fixed_dofs[" + std::to_string(k) +
                                  "] = " + std::to_string(fixed_dofs[k]) + " is outside [0, " +
                                  std::to_string(num_dofs) + ")");
    }
  }
  std::sort(fixed_dofs.begin(), fixed_dofs.end());
  fixed_dofs.erase(std::unique(fixed_dofs.begin(), fixed_dofs.end()), fixed_dofs.end());
  fixed_dofs_ = std::move(fixed_dofs);
  const auto n = static_cast<size_t>(num_dofs);
  free_index_.assign(n, -1);
  fixed_index_.assign(n, -1);
  for (size_t k = 0; k < fixed_dofs_.size(); ++k) {
    fixed_index_[static_cast<size_t>(fixed_dofs_[k])] = static_cast<int>(k);
  }
  free_dofs_.reserve(n - fixed_dofs_.size());
  for (int d = 0; d < num_dofs; ++d) {
    if (fixed_index_[static_cast<size_t>(d)] < 0) {
      free_index_[static_cast<size_t>(d)] = static_cast<int>(free_dofs_.size());
      free_dofs_.push_back(d);
    }
  }
}

std::vector<int> ConstrainedDofs::node_dofs(const std::vector<int>& nodes) {
  std::vector<int> dofs;
  dofs.reserve(3 * nodes.size());
  for (int node : nodes) {
    for (int a = 0; a < 3; ++a) dofs.push_back(3 * node + a);
  }
  return dofs;
}

void ConstrainedDofs::gather_free(const Eigen::VectorXd& full, Eigen::VectorXd* free) const {
  free->resize(num_free());
  for (size_t k = 0; k < free_dofs_.size(); ++k) {
    (*free)[static_cast<Eigen::Index>(k)] = full[free_dofs_[k]];
  }
}

void ConstrainedDofs::gather_fixed(const Eigen::VectorXd& full, Eigen::VectorXd* fixed) const {
  fixed->resize(num_fixed());
  for (size_t k = 0; k < fixed_dofs_.size(); ++k) {
    (*fixed)[static_cast<Eigen::Index>(k)] = full[fixed_dofs_[k]];
  }
}

void ConstrainedDofs::scatter_free(const Eigen::VectorXd& free, Eigen::VectorXd* full) const {
  for (size_t k = 0; k < free_dofs_.size(); ++k) {
    (*full)[free_dofs_[k]] = free[static_cast<Eigen::Index>(k)];
  }
}

void ConstrainedDofs::scatter_fixed(const Eigen::VectorXd& fixed, Eigen::VectorXd* full) const {
  for (size_t k = 0; k < fixed_dofs_.size(); ++k) {
    (*full)[fixed_dofs_[k]] = fixed[static_cast<Eigen::Index>(k)];
  }
}

void ConstrainedDofs::add_to_free(double alpha, const Eigen::VectorXd& free,
                                  Eigen::VectorXd* full) const {
  for (size_t k = 0; k < free_dofs_.size(); ++k) {
    (*full)[free_dofs_[k]] += alpha * free[static_cast<Eigen::Index>(k)];
  }
}

void ConstrainedDofs::gather_free_rows(const Eigen::MatrixXd& full, Eigen::MatrixXd* free) const {
  free->resize(num_free(), full.cols());
  for (size_t k = 0; k < free_dofs_.size(); ++k) {
    free->row(static_cast<Eigen::Index>(k)) = full.row(free_dofs_[k]);
  }
}

namespace {

// A CSC pattern of explicit zeros from its arrays.
ConstrainedDofs::SparseMatrix zero_pattern(int rows, int cols, const std::vector<int>& outer,
                                           const std::vector<int>& inner) {
  const std::vector<double> zeros(inner.size(), 0.0);
  return Eigen::Map<const ConstrainedDofs::SparseMatrix>(rows, cols, static_cast<Eigen::Index>(inner.size()), outer.data(), inner.data(),
                                        zeros.data());
}

// A CSC block under construction: its row indices, and for each entry the Hessian entry it is
// copied from (-1: an inserted zero).
struct BlockPattern {
  std::vector<int> outer, inner, source;
  void add(int row, int from) {
    inner.push_back(row);
    source.push_back(from);
  }
  int size() const { return static_cast<int>(inner.size()); }
};

}  // namespace

void ConstrainedDofs::analyze(const SparseMatrix& hessian) {
  if (hessian.rows() != num_dofs_ || hessian.cols() != num_dofs_) {
    throw std::invalid_argument("ConstrainedDofs::analyze: Hessian is " +
                                std::to_string(hessian.rows()) + " x " +
                                std::to_string(hessian.cols()) + ", expected " +
                                std::to_string(num_dofs_) + " x " + std::to_string(num_dofs_));
  }
  if (!hessian.isCompressed()) {
    throw std::invalid_argument("ConstrainedDofs::analyze: Hessian must be compressed");
  }
  const int* outer = hessian.outerIndexPtr();
  const int* inner = hessian.innerIndexPtr();
  hessian_outer_.assign(outer, outer + num_dofs_ + 1);
  hessian_inner_.assign(inner, inner + hessian.nonZeros());

  const int nf = num_free();
  const int nc = num_fixed();
  BlockPattern ff{std::vector<int>(static_cast<size_t>(nf) + 1, 0), {}, {}};
  BlockPattern fc{std::vector<int>(static_cast<size_t>(nc) + 1, 0), {}, {}};
  free_free_diagonal_.assign(static_cast<size_t>(nf), -1);
  for (int col = 0; col < num_dofs_; ++col) {
    const int jf = free_index(col);
    if (jf < 0) {
      for (int p = outer[col]; p < outer[col + 1]; ++p)
        if (const int row = free_index(inner[p]); row >= 0) fc.add(row, p);
      fc.outer[static_cast<size_t>(fixed_index(col)) + 1] = fc.size();
      continue;
    }
    // K_ff's column jf. free_index_ is increasing in the dof, so rows stay sorted within a
    // column; a missing diagonal is inserted (an explicit zero) at its sorted place.
    int& diagonal = free_free_diagonal_[static_cast<size_t>(jf)];
    for (int p = outer[col]; p < outer[col + 1]; ++p) {
      const int row = free_index(inner[p]);
      if (row < 0) continue;
      if (diagonal < 0 && row > jf) diagonal = ff.size(), ff.add(jf, -1);
      if (row == jf) diagonal = ff.size();
      ff.add(row, p);
    }
    if (diagonal < 0) diagonal = ff.size(), ff.add(jf, -1);
    ff.outer[static_cast<size_t>(jf) + 1] = ff.size();
  }
  free_free_source_ = std::move(ff.source);
  free_fixed_source_ = std::move(fc.source);
  free_free_pattern_ = zero_pattern(nf, nf, ff.outer, ff.inner);
  free_fixed_pattern_ = zero_pattern(nf, nc, fc.outer, fc.inner);
  analyzed_ = true;
}

bool ConstrainedDofs::same_pattern(const SparseMatrix& hessian) const {
  return analyzed_ && hessian.rows() == num_dofs_ && hessian.cols() == num_dofs_ &&
         hessian.isCompressed() &&
         static_cast<size_t>(hessian.nonZeros()) == hessian_inner_.size() &&
         std::equal(hessian_outer_.begin(), hessian_outer_.end(), hessian.outerIndexPtr()) &&
         std::equal(hessian_inner_.begin(), hessian_inner_.end(), hessian.innerIndexPtr());
}

void ConstrainedDofs::check_analyzed_shape(const SparseMatrix& hessian, const char* caller) const {
  if (!analyzed_) {
    throw std::logic_error(std::string("ConstrainedDofs::") + caller + ": call analyze() first");
  }
  if (hessian.rows() != num_dofs_ || hessian.cols() != num_dofs_ || !hessian.isCompressed() ||
      static_cast<size_t>(hessian.nonZeros()) != hessian_inner_.size()) {
    throw std::invalid_argument(std::string("ConstrainedDofs::") + caller +
                                ": the Hessian's pattern differs from the analysed one");
  }
}

namespace {
// Gives `block` the pattern of `pattern` unless it already has it (then no allocation).
void ensure_pattern(const Eigen::SparseMatrix<double>& pattern,
                    Eigen::SparseMatrix<double>* block) {
  if (block->rows() != pattern.rows() || block->cols() != pattern.cols() ||
      block->nonZeros() != pattern.nonZeros() || !block->isCompressed()) {
    *block = pattern;
  }
}
}  // namespace

void ConstrainedDofs::extract_free_free(const SparseMatrix& hessian, SparseMatrix* k_ff) const {
  check_analyzed_shape(hessian, "extract_free_free");
  ensure_pattern(free_free_pattern_, k_ff);
  const double* source = hessian.valuePtr();
  double* values = k_ff->valuePtr();
  for (size_t k = 0; k < free_free_source_.size(); ++k) {
    const int p = free_free_source_[k];
    values[k] = p >= 0 ? source[p] : 0.0;
  }
}

void ConstrainedDofs::extract_free_fixed(const SparseMatrix& hessian, SparseMatrix* k_fc) const {
  check_analyzed_shape(hessian, "extract_free_fixed");
  ensure_pattern(free_fixed_pattern_, k_fc);
  const double* source = hessian.valuePtr();
  double* values = k_fc->valuePtr();
  for (size_t k = 0; k < free_fixed_source_.size(); ++k) values[k] = source[free_fixed_source_[k]];
}

}  // namespace twill
