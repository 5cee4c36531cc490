#pragma once
// Scatter of one element's local derivative blocks into the global arrays, written once for
// every discretisation and every derivative (∂Ψ/∂q, ∂²Ψ/∂q², the columns of ∂(∂Ψ/∂q)/∂k).
//
// An element has m nodes (ElementNodes); its local blocks are read through an accessor, so
// that every kernel keeps its own layout (node-major 3a + r, the Catmull–Clark face's
// component-major 16 c + k and upper component blocks, a scaled angle Hessian) without a copy:
//   nodal:   local(k, c)        node k, component c            → target[3 nodes[k] + c]
//   hessian: local(a, r, b, s)  row 3 n_a + r, column 3 n_b + s → values[slots[(a m + b) 3 + s] + r]
// Each entry is added in the loop order below (node, then component; a, b, s, r), so a node
// that appears twice in an element receives its two contributions in a fixed order.
#include <Eigen/Core>
#include <span>

namespace twill {

/// target[3 nodes[k] + c] += local(k, c) for every node k of the element and c = 0, 1, 2:
/// a gradient, or one column of ∂(∂Ψ/∂q)/∂k (target = that column's data).
template <class Local>
inline void scatter_nodal(double* target, std::span<const int> nodes, const Local& local) {
  const int m = static_cast<int>(nodes.size());
  for (int k = 0; k < m; ++k)
    for (int c = 0; c < 3; ++c) target[3 * nodes[static_cast<std::size_t>(k)] + c] += local(k, c);
}

/// Adds the element's (3m × 3m) Hessian block through its slot table (hessian_pattern.hpp).
template <class Local>
inline void scatter_hessian(double* values, const int* slots, int m, const Local& local) {
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b)
      for (int s = 0; s < 3; ++s) {
        double* column = values + slots[(a * m + b) * 3 + s];
        for (int r = 0; r < 3; ++r) column[r] += local(a, r, b, s);
      }
}

/// Accessors for node-major local arrays (entry 3 k + c): a vector for scatter_nodal, a
/// matrix for scatter_hessian.
template <class Vector>
inline auto node_major(const Eigen::MatrixBase<Vector>& v) {
  return [&v](int k, int c) { return v(3 * k + c); };
}
template <class Matrix>
inline auto node_major_blocks(const Eigen::MatrixBase<Matrix>& H) {
  return [&H](int a, int r, int b, int s) { return H(3 * a + r, 3 * b + s); };
}

}  // namespace twill
