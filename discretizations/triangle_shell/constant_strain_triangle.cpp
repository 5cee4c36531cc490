#include "discretizations/triangle_shell/constant_strain_triangle.hpp"

#include <Eigen/LU>
#include <cassert>

namespace twill {

CstReference cst_reference(const Eigen::Vector2d& X0, const Eigen::Vector2d& X1,
                           const Eigen::Vector2d& X2, const Eigen::Vector2d& d1,
                           const Eigen::Vector2d& d2) {
  Eigen::Matrix2d Dm;
  Dm.col(0) = X1 - X0;
  Dm.col(1) = X2 - X0;
  CstReference ref;
  ref.area = 0.5 * Dm.determinant();
  assert(ref.area > 0.0);
  Eigen::Matrix2d D;
  D.col(0) = d1;
  D.col(1) = d2;
  // f_a = Ds Dm⁻¹ d_a = Σ_{k=1,2} (x_k − x0) B(k−1, a) with B = Dm⁻¹ D.
  const Eigen::Matrix2d B = Dm.inverse() * D;
  ref.beta.row(0) = -(B.row(0) + B.row(1));
  ref.beta.row(1) = B.row(0);
  ref.beta.row(2) = B.row(1);
  return ref;
}

namespace {

/// f1, f2 (deformed warp and weft vectors).
void material_directions(const CstReference& ref, const Eigen::Vector3d& x0,
                         const Eigen::Vector3d& x1, const Eigen::Vector3d& x2, Eigen::Vector3d& f1,
                         Eigen::Vector3d& f2) {
  f1 = ref.beta(0, 0) * x0 + ref.beta(1, 0) * x1 + ref.beta(2, 0) * x2;
  f2 = ref.beta(0, 1) * x0 + ref.beta(1, 1) * x1 + ref.beta(2, 1) * x2;
}

}  // namespace

Vector3 cst_strain(const CstReference& ref, const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                   const Eigen::Vector3d& x2, StrainJacobian* jacobian) {
  Eigen::Vector3d f1, f2;
  material_directions(ref, x0, x1, x2, f1, f2);
  if (jacobian) {
    for (int i = 0; i < 3; ++i) {
      const double b1 = ref.beta(i, 0), b2 = ref.beta(i, 1);
      jacobian->block<1, 3>(0, 3 * i) = b1 * f1.transpose();
      jacobian->block<1, 3>(1, 3 * i) = b2 * f2.transpose();
      jacobian->block<1, 3>(2, 3 * i) = 0.5 * (b1 * f2 + b2 * f1).transpose();
    }
  }
  return {0.5 * (f1.squaredNorm() - 1.0), 0.5 * (f2.squaredNorm() - 1.0), 0.5 * f1.dot(f2)};
}

double cst_energy(const MaterialLaw& law, double thickness_m, const CstReference& ref,
                  const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                  Vector9* gradient, Matrix9* hessian) {
  const bool derivatives = gradient || hessian;
  StrainJacobian J;
  const Vector3 e = cst_strain(ref, x0, x1, x2, derivatives ? &J : nullptr);
  Vector3 dpsi;
  Matrix3 d2psi;
  const double psi =
      law.energy_density(e, derivatives ? &dpsi : nullptr, hessian ? &d2psi : nullptr);
  const double scale = thickness_m * ref.area;
  if (gradient) *gradient = scale * J.transpose() * dpsi;
  if (hessian) {
    *hessian = scale * J.transpose() * d2psi * J;
    // Σ_a ∂ψ/∂e_a ∇²e_a: each ∇²e_a is (β-coefficient matrix) ⊗ I₃, since e_a is a
    // quadratic form in the vertices with scalar coefficients per vertex pair.
    Eigen::Matrix2d S;
    S << dpsi[0], 0.5 * dpsi[2], 0.5 * dpsi[2], dpsi[1];
    const Eigen::Matrix3d coeff = scale * ref.beta * S * ref.beta.transpose();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        hessian->block<3, 3>(3 * i, 3 * j).diagonal().array() += coeff(i, j);
  }
  return scale * psi;
}

Eigen::Matrix<double, 9, Eigen::Dynamic> cst_gradient_parameter_jacobian(
    const MaterialLaw& law, double thickness_m, const CstReference& ref, const Eigen::Vector3d& x0,
    const Eigen::Vector3d& x1, const Eigen::Vector3d& x2) {
  StrainJacobian J;
  const Vector3 e = cst_strain(ref, x0, x1, x2, &J);
  StrainParameterMatrix mixed;
  law.parameter_derivatives(e, nullptr, &mixed);
  Vector3 dpsi;
  law.energy_density(e, &dpsi, nullptr);
  Eigen::Matrix<double, 9, Eigen::Dynamic> out = (thickness_m * ref.area) * J.transpose() * mixed;
  out.col(FlatLayout::kThickness) += ref.area * J.transpose() * dpsi;
  return out;
}

}  // namespace twill
