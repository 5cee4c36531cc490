#include "discretizations/catmull_clark_kl/kirchhoff_love_kernel.hpp"

#include <Eigen/Geometry>
#include <cassert>

namespace twill {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Matrix3d skew(const Vector3d& v) {
  Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

/// blockdiag(T, T): covariant (ε, κ) → orthotropic (e_m, e_b).
Matrix6 block_transform(const Matrix3d& T) {
  Matrix6 Tb = Matrix6::Zero();
  Tb.topLeftCorner<3, 3>() = T;
  Tb.bottomRightCorner<3, 3>() = T;
  return Tb;
}

}  // namespace

Matrix3d covariant_to_orthotropic(const Vector3d& A1_contra, const Vector3d& A2_contra,
                                  const Vector3d& d1, const Vector3d& d2) {
  // Ẽ_ij = d_i·E·d_j = Σ_αβ ε_αβ c_iα c_jβ with c_iα = d_i·A^α; ε12 = ε21 appears twice.
  const double c11 = d1.dot(A1_contra), c12 = d1.dot(A2_contra);
  const double c21 = d2.dot(A1_contra), c22 = d2.dot(A2_contra);
  Matrix3d T;
  T << c11 * c11, c12 * c12, 2.0 * c11 * c12,  //
      c21 * c21, c22 * c22, 2.0 * c21 * c22,   //
      c11 * c21, c12 * c22, c11 * c22 + c12 * c21;
  return T;
}

ReferencePoint make_reference_point(const SurfaceJet& Y, double gauss_weight, const Vector3d& d1,
                                    const Vector3d& d2) {
  const Vector3d A1 = Y.segment<3>(0), A2 = Y.segment<3>(3);
  const Vector3d normal_area = A1.cross(A2);
  const Vector3d N = normal_area.normalized();
  ReferencePoint ref;
  ref.A << A1.dot(A1), A2.dot(A2), A1.dot(A2);
  ref.B << N.dot(Y.segment<3>(6)), N.dot(Y.segment<3>(9)), N.dot(Y.segment<3>(12));
  Eigen::Matrix2d metric;
  metric << ref.A(0), ref.A(2), ref.A(2), ref.A(1);
  const Eigen::Matrix2d inverse = metric.inverse();
  const Vector3d A1_contra = inverse(0, 0) * A1 + inverse(0, 1) * A2;
  const Vector3d A2_contra = inverse(1, 0) * A1 + inverse(1, 1) * A2;
  ref.T = covariant_to_orthotropic(A1_contra, A2_contra, d1, d2);
  ref.weight_area = gauss_weight * normal_area.norm();
  return ref;
}

Vector6 shell_strains(const SurfaceJet& y, const Vector3d& A, const Vector3d& B,
                      StrainJacobian* ds_dy) {
  const Vector3d a1 = y.segment<3>(0), a2 = y.segment<3>(3);
  const Vector3d m = a1.cross(a2);
  const double area = m.norm();
  const Vector3d n = m / area;
  Vector6 s;
  s << 0.5 * (a1.dot(a1) - A(0)), 0.5 * (a2.dot(a2) - A(1)), 0.5 * (a1.dot(a2) - A(2)),
      n.dot(y.segment<3>(6)) - B(0), n.dot(y.segment<3>(9)) - B(1), n.dot(y.segment<3>(12)) - B(2);
  if (ds_dy) {
    StrainJacobian& J = *ds_dy;
    J.setZero();
    J.block<1, 3>(0, 0) = a1.transpose();
    J.block<1, 3>(1, 3) = a2.transpose();
    J.block<1, 3>(2, 0) = 0.5 * a2.transpose();
    J.block<1, 3>(2, 3) = 0.5 * a1.transpose();
    for (int k = 0; k < 3; ++k) {
      // κ = n(m)·v with m = a1×a2: ∂κ/∂m = P v/|m| (P = I − nnᵀ), then dm = da1×a2 + a1×da2.
      const Vector3d v = y.segment<3>(6 + 3 * k);
      const Vector3d gm = (v - n * n.dot(v)) / area;
      J.block<1, 3>(3 + k, 0) = a2.cross(gm).transpose();
      J.block<1, 3>(3 + k, 3) = gm.cross(a1).transpose();
      J.block<1, 3>(3 + k, 6 + 3 * k) = n.transpose();
    }
  }
  return s;
}

Matrix15 shell_strain_hessian(const SurfaceJet& y, const Vector6& g) {
  const Vector3d a1 = y.segment<3>(0), a2 = y.segment<3>(3);
  const Vector3d m = a1.cross(a2);
  const double area = m.norm();
  const Vector3d n = m / area;
  const Matrix3d I = Matrix3d::Identity();
  Matrix15 H = Matrix15::Zero();

  // Membrane: ε is quadratic in (a1, a2).
  H.block<3, 3>(0, 0) += g(0) * I;
  H.block<3, 3>(3, 3) += g(1) * I;
  H.block<3, 3>(0, 3) += 0.5 * g(2) * I;
  H.block<3, 3>(3, 0) += 0.5 * g(2) * I;

  // Bending: Σ_k g_k ∂²(n·x,k)/∂a² is ∂²(n·V)/∂a² with V = Σ_k g_k x,k (linear in v).
  const Vector3d V = g(3) * y.segment<3>(6) + g(4) * y.segment<3>(9) + g(5) * y.segment<3>(12);
  const double nV = n.dot(V);
  // f(m) = V·m/|m|: ∇f = P V/|m|, ∇²f = (−V nᵀ − n Vᵀ − (n·V) I + 3 (n·V) n nᵀ)/|m|².
  const Vector3d gm = (V - n * nV) / area;
  const Matrix3d Hm =
      (-V * n.transpose() - n * V.transpose() - nV * I + 3.0 * nV * n * n.transpose()) /
      (area * area);
  Eigen::Matrix<double, 3, 6> Jm;  // ∂m/∂(a1, a2)
  Jm.leftCols<3>() = -skew(a2);
  Jm.rightCols<3>() = skew(a1);
  H.topLeftCorner<6, 6>() += Jm.transpose() * Hm * Jm;
  // ∂²m_k/∂a1_i∂a2_j = ε_kij, contracted with ∇f.
  H.block<3, 3>(0, 3) -= skew(gm);
  H.block<3, 3>(3, 0) += skew(gm);

  // Mixed (a, x,k): g_k (∂n/∂a)ᵀ with ∂n/∂a1 = −P[a2]×/|m|, ∂n/∂a2 = P[a1]×/|m|.
  const Matrix3d P = I - n * n.transpose();
  const Matrix3d dn_da1_T = skew(a2) * P / area;
  const Matrix3d dn_da2_T = -skew(a1) * P / area;
  for (int k = 0; k < 3; ++k) {
    const int c = 6 + 3 * k;
    H.block<3, 3>(0, c) += g(3 + k) * dn_da1_T;
    H.block<3, 3>(3, c) += g(3 + k) * dn_da2_T;
    H.block<3, 3>(c, 0) += g(3 + k) * dn_da1_T.transpose();
    H.block<3, 3>(c, 3) += g(3 + k) * dn_da2_T.transpose();
  }
  return H;
}

namespace {

/// W at orthotropic strains (e_m, ê_b) with the bending strain already scaled (ê_b = S e_b):
/// ∫ ψ(e_m − ξ ê_b) dξ by `rule`, with optional ∂W/∂(e_m, ê_b) and ∂²W/∂(e_m, ê_b)².
double integral_of_scaled(const MaterialLaw& law, double thickness_m, const GaussLegendreRule& rule,
                          const Vector6& e_hat, Vector6* gradient, Matrix6* hessian) {
  // ξ = h s with h = τ/2 and s the rule's nodes on [−1, 1]; dξ = h ds.
  const double h = 0.5 * thickness_m;
  const Vector3d em = e_hat.head<3>(), eb = e_hat.tail<3>();
  double W = 0.0;
  if (gradient) gradient->setZero();
  if (hessian) hessian->setZero();
  Vector3 dpsi;
  Matrix3 d2psi;
  for (int g = 0; g < rule.size(); ++g) {
    const double s = rule.nodes[static_cast<size_t>(g)];
    const double w = h * rule.weights[static_cast<size_t>(g)];
    const double xi = h * s;
    const double psi = law.energy_density(em - xi * eb, gradient ? &dpsi : nullptr,
                                          hessian ? &d2psi : nullptr);
    W += w * psi;
    if (gradient) {
      gradient->head<3>() += w * dpsi;
      gradient->tail<3>() -= w * xi * dpsi;
    }
    if (hessian) {
      hessian->topLeftCorner<3, 3>() += w * d2psi;
      hessian->topRightCorner<3, 3>() -= w * xi * d2psi;
      hessian->bottomRightCorner<3, 3>() += w * xi * xi * d2psi;
    }
  }
  if (hessian) hessian->bottomLeftCorner<3, 3>() = hessian->topRightCorner<3, 3>().transpose();
  return W;
}

/// The strain the integral sees, (e_m, S e_b), and the diagonal (1, 1, 1, s) of its Jacobian.
Vector6 bending_scaled(const MaterialLaw& law, const Vector6& e, Vector6* jacobian_diagonal) {
  const Vector3d& s = law.bending_scale().diagonal;
  Vector6 scaled;
  scaled << e.head<3>(), s.cwiseProduct(e.tail<3>());
  if (jacobian_diagonal) *jacobian_diagonal << 1.0, 1.0, 1.0, s;
  return scaled;
}

}  // namespace

double thickness_integral(const MaterialLaw& law, double thickness_m,
                          const GaussLegendreRule& rule, const Vector6& e, Vector6* gradient,
                          Matrix6* hessian) {
  Vector6 d;
  const double W = integral_of_scaled(law, thickness_m, rule, bending_scaled(law, e, &d), gradient, hessian);
  // Chain rule through ê = D e, D = diag(1, 1, 1, s): ∂W/∂e = D ∂W/∂ê, ∂²W/∂e² = D ∂²W/∂ê² D
  // (S = I multiplies by exact ones: the paper's model bit for bit).
  if (gradient) *gradient = d.cwiseProduct(*gradient);
  if (hessian) *hessian = d.asDiagonal() * (*hessian) * d.asDiagonal();
  return W;
}

void thickness_integral_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                           const GaussLegendreRule& rule, const Vector6& e,
                                           StrainParameterJacobian* dgradient_dk) {
  assert(dgradient_dk);
  const int num_k = law.num_parameters();
  dgradient_dk->setZero(6, num_k);
  const double h = 0.5 * thickness_m;
  const BendingScale& scale = law.bending_scale();
  const Vector6 e_hat = bending_scaled(law, e, nullptr);
  const Vector3d em = e_hat.head<3>(), eb = e_hat.tail<3>();
  // ∂ê_b/∂(b_w, b_f) = (∂s/∂b) ∘ e_b, one column per ratio.
  const Eigen::Matrix<double, 3, 2> deb_db = e.tail<3>().asDiagonal() * scale.derivative;
  Vector3 dpsi;
  Matrix3 d2psi;
  StrainParameterMatrix d2psi_de_dk;
  Vector3d d_grad_m_dh = Vector3d::Zero(), d_grad_b_dh = Vector3d::Zero();
  // ∂W/∂ê_b, and ∂²W/∂e_m∂ê_b and ∂²W/∂ê_b² applied to ∂ê_b/∂b (for the ratio columns).
  Vector3d grad_b = Vector3d::Zero();
  Eigen::Matrix<double, 3, 2> mixed_db = Eigen::Matrix<double, 3, 2>::Zero(), bending_db = mixed_db;
  for (int g = 0; g < rule.size(); ++g) {
    const double s = rule.nodes[static_cast<size_t>(g)];
    const double w = rule.weights[static_cast<size_t>(g)];
    const double xi = h * s;
    const Vector3d strain = em - xi * eb;
    law.energy_density(strain, &dpsi, &d2psi);
    law.parameter_derivatives(strain, nullptr, &d2psi_de_dk);
    // Law columns: ∂W/∂e_m = h Σ w ψ', ∂W/∂ê_b = −h² Σ w s ψ'.
    dgradient_dk->topRows<3>() += (h * w) * d2psi_de_dk;
    dgradient_dk->bottomRows<3>() -= (h * h * w * s) * d2psi_de_dk;
    // Thickness: differentiate those in h (ξ = h s moves with h: ∂Ẽ/∂h = −s ê_b).
    const Vector3d d2psi_eb = d2psi * eb;
    d_grad_m_dh += w * dpsi - (h * w * s) * d2psi_eb;
    d_grad_b_dh += -(2.0 * h * w * s) * dpsi + (h * h * w * s * s) * d2psi_eb;
    grad_b -= (h * w * xi) * dpsi;
    mixed_db -= (h * w * xi) * d2psi * deb_db;
    bending_db += (h * w * xi * xi) * d2psi * deb_db;
  }
  // The law leaves thickness and density columns zero (they do not enter ψ); dh/dτ = ½.
  dgradient_dk->col(FlatLayout::kThickness).head<3>() = 0.5 * d_grad_m_dh;
  dgradient_dk->col(FlatLayout::kThickness).tail<3>() = 0.5 * d_grad_b_dh;
  // Rows in ê_b so far: ∂W/∂e_b = S ∂W/∂ê_b.
  dgradient_dk->bottomRows<3>() = scale.diagonal.asDiagonal() * dgradient_dk->bottomRows<3>();
  // Ratio columns (zero from the law): ∂(∂W/∂e_m)/∂b = ∂²W/∂e_m∂ê_b ∂ê_b/∂b and
  // ∂(S ∂W/∂ê_b)/∂b = (∂s/∂b) ∘ ∂W/∂ê_b + S ∂²W/∂ê_b² ∂ê_b/∂b.
  for (int j = 0; j < FlatLayout::kBendingRatios; ++j) {
    auto column = dgradient_dk->col(law.layout().bending + j);
    column.head<3>() = mixed_db.col(j);
    column.tail<3>() = scale.derivative.col(j).cwiseProduct(grad_b) + scale.diagonal.cwiseProduct(bending_db.col(j));
  }
}

double kirchhoff_love_point(const MaterialLaw& law, double thickness_m,
                            const GaussLegendreRule& rule, const ReferencePoint& reference,
                            const SurfaceJet& y, Vector15* gradient, Matrix15* hessian) {
  const bool derivatives = gradient || hessian;
  StrainJacobian ds_dy;
  const Vector6 s = shell_strains(y, reference.A, reference.B, derivatives ? &ds_dy : nullptr);
  const Matrix6 Tb = block_transform(reference.T);
  const Vector6 e = Tb * s;
  Vector6 dW_de;
  Matrix6 d2W_de2;
  const double W = thickness_integral(law, thickness_m, rule, e, derivatives ? &dW_de : nullptr,
                                      hessian ? &d2W_de2 : nullptr);
  if (!derivatives) return reference.weight_area * W;
  const Vector6 dE_ds = reference.weight_area * (Tb.transpose() * dW_de);
  if (gradient) *gradient = ds_dy.transpose() * dE_ds;
  if (hessian) {
    const Matrix6 d2E_ds2 = reference.weight_area * (Tb.transpose() * d2W_de2 * Tb);
    *hessian = ds_dy.transpose() * d2E_ds2 * ds_dy + shell_strain_hessian(y, dE_ds);
  }
  return reference.weight_area * W;
}

void kirchhoff_love_point_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                             const GaussLegendreRule& rule,
                                             const ReferencePoint& reference, const SurfaceJet& y,
                                             JetParameterJacobian* dgradient_dk) {
  assert(dgradient_dk);
  StrainJacobian ds_dy;
  const Vector6 s = shell_strains(y, reference.A, reference.B, &ds_dy);
  const Matrix6 Tb = block_transform(reference.T);
  StrainParameterJacobian dW;
  thickness_integral_parameter_jacobian(law, thickness_m, rule, Tb * s, &dW);
  // The strains do not depend on k, so only ∂W/∂e moves: ∂g_y/∂k = (∂s/∂y)ᵀ w dA Tbᵀ ∂(∂W/∂e)/∂k.
  const Eigen::Matrix<double, 15, 6> chain =
      reference.weight_area * (ds_dy.transpose() * Tb.transpose());
  *dgradient_dk = chain * dW;
}

void orthotropic_strains(const ReferencePoint& reference, const SurfaceJet& y,
                         Eigen::Vector3d* membrane, Eigen::Vector3d* bending) {
  const Vector6 s = shell_strains(y, reference.A, reference.B, nullptr);
  if (membrane) *membrane = reference.T * s.head<3>();
  if (bending) *bending = reference.T * s.tail<3>();
}

}  // namespace twill
