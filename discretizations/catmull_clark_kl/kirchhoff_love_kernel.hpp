#pragma once
// Per-quadrature-point Kirchhoff–Love kernel of the Catmull–Clark shell: strains of the
// mid-surface, the through-thickness integral of the material law, and their exact first and
// second derivatives (docs/model.md §1, §6; paper Eq. 2; derivation in
// docs/catmull_clark_kl.md §2–§4). Knows nothing of meshes: the assembly gathers the surface
// jet from control points and scatters the results back.
//
// Notation (θ¹, θ² = the face's (u, v); Greek indices 1, 2):
//   jet y = (a1, a2, x,11, x,22, x,12) ∈ R^15, a_α = ∂x/∂θ^α, x,αβ = ∂²x/∂θ^α∂θ^β  [m]
//   covariant strains s = (ε11, ε22, ε12, κ11, κ22, κ12) ∈ R^6 with
//     ε_αβ = ½(a_α·a_β − A_αβ),  κ_αβ = n·x,αβ − B_αβ,  n = a1×a2/|a1×a2|
//   orthotropic strains e = (e_m, e_b) ∈ R^6, e_m = T (ε11, ε22, ε12), e_b = T (κ11, κ22, κ12):
//     T maps covariant components to Ẽ = Dᵀ E D (Ẽ11, Ẽ22, Ẽ12) with E = ε_αβ A^α ⊗ A^β
//     (A^α: reference contravariant basis, D = [d1 d2]: warp, weft).
//   Through the thickness Ẽ(ξ) = e_m − ξ e_b, ξ ∈ [−τ/2, τ/2] along +n; the bending strain e_b
//   is [1/m], e_m and Ẽ are dimensionless.
//   W(e) = ∫ ψ(e_m − ξ S e_b) dξ  [J/m²], by Gauss–Legendre in ξ (exact for polynomial ψ of
//   degree ≤ 2 n_ξ − 1, e.g. StVK with n_ξ ≥ 2). S = diag(s) is the bending-strain scale of
//   the law-side bending ratios (law.bending_scale(), core/bending_scale.hpp): S = I is the
//   paper's model; otherwise warp and weft bending stiffness scale by b_w and b_f
//   (docs/effects/bending-anisotropy.md).
//   Point energy = w dA · W, with w dA = Gauss weight × |A1×A2| [m²].
#include <Eigen/Core>

#include "core/material_law.hpp"
#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"

namespace twill {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;
using SurfaceJet = Eigen::Matrix<double, 15, 1>;
using Vector15 = Eigen::Matrix<double, 15, 1>;
using Matrix15 = Eigen::Matrix<double, 15, 15>;
using StrainJacobian = Eigen::Matrix<double, 6, 15>;            ///< ∂s/∂y
using StrainParameterJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic>;  ///< ∂(∂W/∂e)/∂k
using JetParameterJacobian = Eigen::Matrix<double, 15, Eigen::Dynamic>;    ///< ∂(∂Ψ_p/∂y)/∂k

/// Reference (rest) data of one quadrature point, computed once per mesh.
struct ReferencePoint {
  Eigen::Vector3d A = Eigen::Vector3d::Zero();  ///< reference metric (A11, A22, A12) [m²]
  Eigen::Vector3d B = Eigen::Vector3d::Zero();  ///< reference curvature (B11, B22, B12) [m]
  Eigen::Matrix3d T = Eigen::Matrix3d::Zero();  ///< covariant → orthotropic map [1/m²]
  double weight_area = 0.0;                     ///< Gauss weight × |A1×A2| [m²]
};

/// The map T from covariant strain components (c11, c22, c12) (c12 = c21, counted twice in
/// the tensor) to orthotropic ones (Ẽ11, Ẽ22, Ẽ12), given the reference contravariant basis
/// A^1, A^2 and the material directions d1 (warp), d2 (weft), all in the reference frame.
Eigen::Matrix3d covariant_to_orthotropic(const Eigen::Vector3d& A1_contra,
                                         const Eigen::Vector3d& A2_contra,
                                         const Eigen::Vector3d& d1, const Eigen::Vector3d& d2);

/// Reference data from the rest jet Y and the Gauss weight of the point: A, B, T (directions
/// d1, d2) and weight × |A1×A2|.
ReferencePoint make_reference_point(const SurfaceJet& Y, double gauss_weight,
                                    const Eigen::Vector3d& d1, const Eigen::Vector3d& d2);

/// Covariant strains s(y) and, optionally, ∂s/∂y (6×15).
Vector6 shell_strains(const SurfaceJet& y, const Eigen::Vector3d& A, const Eigen::Vector3d& B,
                      StrainJacobian* ds_dy);

/// Σ_k g_k ∂²s_k/∂y² (15×15, symmetric): the exact curvature term of the Hessian, including
/// the second derivatives of the unit normal.
Matrix15 shell_strain_hessian(const SurfaceJet& y, const Vector6& g);

/// W(e) = ∫_{−τ/2}^{τ/2} ψ(e_m − ξ S e_b) dξ [J/m²] by the Gauss–Legendre rule `rule` (on
/// [−1, 1], scaled to the thickness), S = diag(law.bending_scale().diagonal). Optional ∂W/∂e
/// (6) and ∂²W/∂e² (6×6), in the unscaled e.
double thickness_integral(const MaterialLaw& law, double thickness_m,
                          const GaussLegendreRule& rule, const Vector6& e, Vector6* gradient,
                          Matrix6* hessian);

/// ∂(∂W/∂e)/∂k (6 × law.num_parameters(), flat layout of parameters.hpp): the thickness
/// column through the integration limits and weights, the law columns through ∂²ψ/∂e∂k, the
/// bending-ratio columns through S (∂S/∂b e_b moves the through-thickness strains and ∂S/∂b
/// scales ∂W/∂e_b); the density column is zero. Resized.
void thickness_integral_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                           const GaussLegendreRule& rule, const Vector6& e,
                                           StrainParameterJacobian* dgradient_dk);

/// Energy of one quadrature point, w dA · W(T s(y)) [J], with optional gradient (15) [N] and
/// Hessian (15×15) [N/m] in the jet y.
double kirchhoff_love_point(const MaterialLaw& law, double thickness_m,
                            const GaussLegendreRule& rule, const ReferencePoint& reference,
                            const SurfaceJet& y, Vector15* gradient, Matrix15* hessian);

/// ∂(∂(point energy)/∂y)/∂k (15 × num_parameters). Resized.
void kirchhoff_love_point_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                             const GaussLegendreRule& rule,
                                             const ReferencePoint& reference, const SurfaceJet& y,
                                             JetParameterJacobian* dgradient_dk);

/// Orthotropic membrane strain e_m and bending strain e_b [1/m] at a point.
void orthotropic_strains(const ReferencePoint& reference, const SurfaceJet& y,
                         Eigen::Vector3d* membrane, Eigen::Vector3d* bending);

}  // namespace twill
