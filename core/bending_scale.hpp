#pragma once
// The bending-strain scale of the law-side bending ratios (core/parameters.hpp:
// "bending.warp_ratio" b_w and "bending.weft_ratio" b_f; derivation in
// docs/effects/bending-anisotropy.md). Both shells apply it to the orthotropic bending strain
// e_b = (K̃11, K̃22, K̃12) [1/m] before the through-thickness integral of the law:
//
//     W(e_m, e_b) = ∫_{−τ/2}^{τ/2} ψ(e_m − ξ S e_b) dξ,   S = diag(s),
//     s = (√b_w, √b_f, (b_w b_f)^¼)                                              [1]
//
// At small curvature W = τψ(e_m) + τ³/24 e_bᵀ (S C S) e_b + …, C = ∂²ψ/∂Ẽ²(0): the bending
// stiffness C_ij is scaled by s_i s_j, i.e. warp bending by b_w, weft bending by b_f, the
// coupling a12 and twist (2 G12) by √(b_w b_f). The membrane (e_b = 0) is untouched.
// b_w = b_f = 1 gives S = I, the paper's model bit for bit.
#include <Eigen/Core>

#include "core/parameters.hpp"

namespace twill {

struct BendingScale {
  /// s = (s1, s2, s3): the diagonal of S, for (K̃11, K̃22, K̃12) [1].
  Eigen::Vector3d diagonal = Eigen::Vector3d::Ones();
  /// ∂s/∂(b_w, b_f) (3 × 2) [1].
  Eigen::Matrix<double, 3, 2> derivative = Eigen::Matrix<double, 3, 2>::Zero();

  /// s_i s_j: the factor on C_ij in the small-curvature bending energy (i, j ∈ {0, 1, 2}).
  double stiffness_factor(int i, int j) const { return diagonal[i] * diagonal[j]; }
  /// ∂(s_i s_j)/∂(b_w, b_f).
  Eigen::RowVector2d stiffness_factor_derivative(int i, int j) const {
    return diagonal[j] * derivative.row(i) + diagonal[i] * derivative.row(j);
  }
};

/// S of the ratios of `p`, with its derivative. Throws InputError naming the entry when a
/// ratio is not positive and finite (S needs its square root).
BendingScale bending_scale(const MaterialParameters& p);

}  // namespace twill
