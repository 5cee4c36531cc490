#pragma once
// Linear (constant-strain) membrane triangle for the orthotropic law (docs/triangle_shell.md
// §2; docs/model.md §1–2).
//
// Reference triangle X0, X1, X2 in the plane (counter-clockwise), deformed x0, x1, x2 in R³.
// Deformation gradient F = Ds Dm⁻¹ (3×2), Ds = [x1−x0, x2−x0], Dm = [X1−X0, X2−X0]. Its
// action on the material directions, f_a = F d_a (a = 1 warp, 2 weft), is linear in the
// vertices: f_a = Σ_i β_ia x_i. The orthotropic Green strain Ẽ = Dᵀ E D with
// E = ½(FᵀF − I) and D = [d1 d2] orthonormal is then
//     e = (Ẽ11, Ẽ22, Ẽ12) = (½(f1·f1 − 1), ½(f2·f2 − 1), ½ f1·f2)
// and the membrane energy is W = τ Ā ψ(e) [J] with Ā the reference area.
#include <Eigen/Core>

#include "core/material_law.hpp"

namespace twill {

using Vector9 = Eigen::Matrix<double, 9, 1>;
using Matrix9 = Eigen::Matrix<double, 9, 9>;
/// ∂e/∂x: 3 strain components × 9 coordinates (x0 x1 x2 stacked).
using StrainJacobian = Eigen::Matrix<double, 3, 9>;

struct CstReference {
  double area = 0;  ///< Ā [m²]
  /// β (3 vertices × 2 directions) [1/m]: f_a = Σ_i β(i, a) x_i.
  Eigen::Matrix<double, 3, 2> beta = Eigen::Matrix<double, 3, 2>::Zero();
};

/// Precomputes the reference data; d1, d2 are the (unit, orthogonal) warp and weft
/// directions in the reference plane. The triangle must have positive area.
CstReference cst_reference(const Eigen::Vector2d& X0, const Eigen::Vector2d& X1,
                           const Eigen::Vector2d& X2, const Eigen::Vector2d& d1,
                           const Eigen::Vector2d& d2);

/// Orthotropic Green strain e of the deformed triangle, optionally ∂e/∂x (3 × 9).
Vector3 cst_strain(const CstReference& ref, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                   const Eigen::Vector3d& x2, StrainJacobian* jacobian = nullptr);

/// Membrane energy τĀψ(e) [J]; optional gradient (9) [N] and Hessian (9 × 9) [N/m], exact
/// (no projection: indefinite under compression, as the law is).
double cst_energy(const MaterialLaw& law, double thickness_m, const CstReference& ref,
                  const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                  Vector9* gradient = nullptr, Matrix9* hessian = nullptr);

/// ∂(gradient)/∂k for the flat parameters of `law` (9 × law.num_parameters()): the law's
/// columns τĀ (∂e/∂x)ᵀ ∂²ψ/∂e∂k, and the thickness column Ā (∂e/∂x)ᵀ ∂ψ/∂e (the membrane is
/// linear in τ). The density column is zero.
Eigen::Matrix<double, 9, Eigen::Dynamic> cst_gradient_parameter_jacobian(
    const MaterialLaw& law, double thickness_m, const CstReference& ref, const Eigen::Vector3d& x0,
    const Eigen::Vector3d& x1, const Eigen::Vector3d& x2);

}  // namespace twill
