#include "discretizations/catmull_clark_kl/kirchhoff_love_face.hpp"

#include <cassert>
#include <vector>

namespace twill {
namespace {

using Eigen::Matrix3d;
using JetRows = Eigen::Matrix<double, 5, 3, Eigen::RowMajor>;  // jet y as (row r, component c)
using LocalRows2 = Eigen::Matrix<double, 2, 48>;

/// What one Gauss point of the face keeps between the passes over the face.
struct PointWork {
  SurfaceJet y;
  StrainJacobian J;  ///< ∂s/∂y of the covariant strains s = (ε, κ)
  Vector6 e;         ///< orthotropic (e_m, e_b) the law sees (projected for FaceMean)
  Vector6 gamma;     ///< ∂E_face/∂e at this point, after the projection's chain rule [J]
  Matrix6 d2W;       ///< w dA ∂²W/∂e² at the point [J]
  double omega = 0;  ///< w dA / face area: the point's weight in the face mean
};

/// Per-thread scratch, grown once: no allocation inside the Newton loop.
std::vector<PointWork>& workspace(int points) {
  thread_local std::vector<PointWork> work;
  if (static_cast<int>(work.size()) < points) work.resize(static_cast<std::size_t>(points));
  return work;
}

/// A jet-space vector v (15, index 3r + c) pulled back to the 48 local dofs: Dᵀ v per
/// component, returned as 16 × 3 (column-major = component-major local index 16 c + k).
FaceCoordinates to_local(const JetBasis& Dt, const Eigen::Ref<const Vector15>& v) {
  return Dt.lazyProduct(Eigen::Map<const JetRows>(v.data()));
}

/// K += Dᵀ H D for one component block, with Dt = Dᵀ (16 × 5) and H (5 × 5), written so that
/// the compiler vectorises over the rows i with each D entry broadcast once (Eigen's small
/// lazy products re-broadcast per packet, its GEMM path packs per call: both measured slower,
/// docs/catmull_clark_kl.md §10). `upper_only` (a diagonal block, H symmetric) fills i ≤ j.
void add_block(const JetBasis& Dt, const Eigen::Matrix<double, 5, 5>& H, bool upper_only,
               Matrix16& K) {
  double R[5][16];  // R = Dt H, column-major by hand
  for (int s = 0; s < 5; ++s) {
    const double h0 = H(0, s), h1 = H(1, s), h2 = H(2, s), h3 = H(3, s), h4 = H(4, s);
    for (int i = 0; i < 16; ++i)
      R[s][i] = Dt(i, 0) * h0 + Dt(i, 1) * h1 + Dt(i, 2) * h2 + Dt(i, 3) * h3 + Dt(i, 4) * h4;
  }
  for (int j = 0; j < 16; ++j) {
    const double d0 = Dt(j, 0), d1 = Dt(j, 1), d2 = Dt(j, 2), d3 = Dt(j, 3), d4 = Dt(j, 4);
    double* k = K.col(j).data();
    const int rows = upper_only ? j + 1 : 16;
    for (int i = 0; i < rows; ++i)
      k[i] += R[0][i] * d0 + R[1][i] * d1 + R[2][i] * d2 + R[3][i] * d3 + R[4][i] * d4;
  }
}

/// Strains of every point, with the FaceMean projection of (Ẽ11, Ẽ22) applied to e.
void prepare_points(const FaceQuadrature& face, const FaceCoordinates& X, bool derivatives,
                    std::vector<PointWork>& work) {
  const int n = face.points_per_face;
  double area = 0.0;
  for (int p = 0; p < n; ++p) area += face.reference[p].weight_area;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int p = 0; p < n; ++p) {
    PointWork& w = work[static_cast<std::size_t>(p)];
    const ReferencePoint& ref = face.reference[p];
    w.y = face_jet(face.jet_basis[p], X);
    const Vector6 s = shell_strains(w.y, ref.A, ref.B, derivatives ? &w.J : nullptr);
    w.e << ref.T * s.head<3>(), ref.T * s.tail<3>();
    w.omega = ref.weight_area / area;
    mean += w.omega * w.e.head<2>();
  }
  if (face.fibre_strain == FibreStrain::FaceMean)
    for (int p = 0; p < n; ++p) work[static_cast<std::size_t>(p)].e.head<2>() = mean;
}

/// ∂E/∂s = blockdiag(T, T)ᵀ γ: orthotropic weights back to covariant ones.
Vector6 covariant_weights(const Matrix3d& T, const Vector6& gamma) {
  Vector6 g;
  g << T.transpose() * gamma.head<3>(), T.transpose() * gamma.tail<3>();
  return g;
}

}  // namespace

SurfaceJet face_jet(const JetBasis& Dt, const FaceCoordinates& X) {
  SurfaceJet y;
  Eigen::Map<JetRows>(y.data()) = Dt.transpose().lazyProduct(X);
  return y;
}

double kirchhoff_love_face(const MaterialLaw& law, double thickness_m,
                           const GaussLegendreRule& rule, const FaceQuadrature& face,
                           const FaceCoordinates& X, FaceCoordinates* gradient,
                           FaceHessianBlocks* hessian) {
  assert(face.points_per_face > 0 && face.points_per_face <= 256);
  const int n = face.points_per_face;
  const bool derivatives = gradient || hessian;
  const bool projected = face.fibre_strain == FibreStrain::FaceMean;
  std::vector<PointWork>& work = workspace(n);
  prepare_points(face, X, derivatives, work);

  double energy = 0.0;
  Eigen::Vector2d mean_weight = Eigen::Vector2d::Zero();  // Σ_p w dA ∂W/∂(Ẽ11, Ẽ22)
  Vector6 dW;
  Matrix6 d2W;
  for (int p = 0; p < n; ++p) {
    PointWork& w = work[static_cast<std::size_t>(p)];
    const double wA = face.reference[p].weight_area;
    energy += wA * thickness_integral(law, thickness_m, rule, w.e, derivatives ? &dW : nullptr,
                                      hessian ? &d2W : nullptr);
    if (!derivatives) continue;
    w.gamma = wA * dW;
    if (hessian) w.d2W = wA * d2W;
    mean_weight += w.gamma.head<2>();
  }
  if (!derivatives) return energy;
  // FaceMean: ē = Σ_q ω_q e_q(11, 22) enters every point, so ∂E/∂e_q(11, 22) = ω_q Σ_p γ_p.
  if (projected)
    for (int p = 0; p < n; ++p)
      work[static_cast<std::size_t>(p)].gamma.head<2>() = work[static_cast<std::size_t>(p)].omega * mean_weight;

  if (gradient) gradient->setZero();
  if (hessian)
    for (Matrix16& block : *hessian) block.setZero();
  // FaceMean coupling (docs/catmull_clark_kl.md §12): with ê_p = Q_p y_p + [Ū x; 0],
  // Σ_p ê_pᵀ H_p ê_p adds C Ū + Ūᵀ Cᵀ + Ūᵀ (Σ_p H_p[0:2, 0:2]) Ū to the local Hessian.
  Eigen::Matrix<double, 48, 2> C = Eigen::Matrix<double, 48, 2>::Zero();
  LocalRows2 U = LocalRows2::Zero();
  Eigen::Matrix2d H_mean = Eigen::Matrix2d::Zero();
  for (int p = 0; p < n; ++p) {
    const PointWork& w = work[static_cast<std::size_t>(p)];
    const ReferencePoint& ref = face.reference[p];
    const JetBasis& Dt = face.jet_basis[p];
    const Vector6 dE_ds = covariant_weights(ref.T, w.gamma);
    if (gradient) {
      const Vector15 gy = w.J.transpose() * dE_ds;
      gradient->noalias() += to_local(Dt, gy);
    }
    if (!hessian) continue;
    // Q = ∂e/∂y at the point (rows 11, 22 of the membrane part zeroed for FaceMean: they
    // come from the face mean instead).
    Eigen::Matrix<double, 6, 15> Q;
    Q.topRows<3>().noalias() = ref.T.lazyProduct(w.J.topRows<3>());
    Q.bottomRows<3>().noalias() = ref.T.lazyProduct(w.J.bottomRows<3>());
    if (projected) {
      for (int i = 0; i < 2; ++i)
        U.row(i) += w.omega * Eigen::Map<const Eigen::Matrix<double, 1, 48>>(
                                  to_local(Dt, Q.row(i).transpose()).data());
      Q.topRows<2>().setZero();
      const Eigen::Matrix<double, 15, 2> QtH = Q.transpose() * w.d2W.leftCols<2>();
      for (int i = 0; i < 2; ++i)
        C.col(i) += Eigen::Map<const Eigen::Matrix<double, 48, 1>>(to_local(Dt, QtH.col(i)).data());
      H_mean += w.d2W.topLeftCorner<2, 2>();
    }
    Matrix15 Hy = shell_strain_hessian(w.y, dE_ds);
    const Eigen::Matrix<double, 6, 15> HQ = w.d2W.lazyProduct(Q);
    Hy.noalias() += Q.transpose().lazyProduct(HQ);
    for (int a = 0; a < 3; ++a)
      for (int b = a; b < 3; ++b) {
        // H_ab(r, s) = Hy(3r + a, 3s + b): the (a, b) component coupling of jet rows r, s;
        // the block is Dᵀ H_ab D.
        const Eigen::Matrix<double, 5, 5> Hab =
            Eigen::Map<const Eigen::Matrix<double, 5, 5>, 0, Eigen::Stride<45, 3>>(Hy.data() + 15 * b + a);
        add_block(Dt, Hab, a == b, (*hessian)[static_cast<std::size_t>(face_block_index(a, b))]);
      }
  }
  // Diagonal component blocks were accumulated in their upper triangle only.
  if (hessian)
    for (int a = 0; a < 3; ++a) {
      Matrix16& block = (*hessian)[static_cast<std::size_t>(face_block_index(a, a))];
      block.triangularView<Eigen::StrictlyLower>() = block.transpose();
    }
  if (hessian && projected) {
    const Eigen::Matrix<double, 48, 48> K =
        C * U + U.transpose() * C.transpose() + U.transpose() * (H_mean * U);
    for (int a = 0; a < 3; ++a)
      for (int b = a; b < 3; ++b)
        (*hessian)[static_cast<std::size_t>(face_block_index(a, b))] += K.block<16, 16>(16 * a, 16 * b);
  }
  return energy;
}

void kirchhoff_love_face_strains(const FaceQuadrature& face, const FaceCoordinates& X,
                                 Vector6* strains) {
  std::vector<PointWork>& work = workspace(face.points_per_face);
  prepare_points(face, X, false, work);
  for (int p = 0; p < face.points_per_face; ++p) strains[p] = work[static_cast<std::size_t>(p)].e;
}

void kirchhoff_love_face_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                            const GaussLegendreRule& rule,
                                            const FaceQuadrature& face, const FaceCoordinates& X,
                                            FaceParameterJacobian* dgradient_dk) {
  assert(dgradient_dk);
  const int n = face.points_per_face;
  const int num_k = law.num_parameters();
  std::vector<PointWork>& work = workspace(n);
  prepare_points(face, X, true, work);
  thread_local std::vector<StrainParameterJacobian> dW;  // per point, w dA ∂(∂W/∂e)/∂k
  if (static_cast<int>(dW.size()) < n) dW.resize(static_cast<std::size_t>(n));
  Eigen::Matrix<double, 2, Eigen::Dynamic> mean_weight = Eigen::MatrixXd::Zero(2, num_k);
  for (int p = 0; p < n; ++p) {
    StrainParameterJacobian& column = dW[static_cast<std::size_t>(p)];
    thickness_integral_parameter_jacobian(law, thickness_m, rule, work[static_cast<std::size_t>(p)].e, &column);
    column *= face.reference[p].weight_area;
    mean_weight += column.topRows<2>();
  }
  dgradient_dk->setZero(48, num_k);
  for (int p = 0; p < n; ++p) {
    const PointWork& w = work[static_cast<std::size_t>(p)];
    const ReferencePoint& ref = face.reference[p];
    StrainParameterJacobian& column = dW[static_cast<std::size_t>(p)];
    // The strains do not depend on k; with FaceMean the (11, 22) rows come from the mean.
    if (face.fibre_strain == FibreStrain::FaceMean) column.topRows<2>() = w.omega * mean_weight;
    // Small products: lazy (Eigen's GEMM path would pack the operands on every call).
    thread_local StrainParameterJacobian dE_ds;
    thread_local JetParameterJacobian jet;
    dE_ds.resize(6, num_k);
    dE_ds.topRows<3>().noalias() = ref.T.transpose().lazyProduct(column.topRows<3>());
    dE_ds.bottomRows<3>().noalias() = ref.T.transpose().lazyProduct(column.bottomRows<3>());
    jet.noalias() = w.J.transpose().lazyProduct(dE_ds);
    for (int c = 0; c < 3; ++c) {
      // Rows 3r + c of the jet Jacobian: component c of jet row r.
      const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, 3>> Jc(
          jet.data() + c, 5, num_k, Eigen::Stride<Eigen::Dynamic, 3>(15, 3));
      dgradient_dk->middleRows<16>(16 * c).noalias() += face.jet_basis[p].lazyProduct(Jc);
    }
  }
}

}  // namespace twill
