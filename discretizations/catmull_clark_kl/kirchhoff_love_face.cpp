#include "discretizations/catmull_clark_kl/kirchhoff_love_face.hpp"

#include <cassert>
#include <cmath>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace twill {
namespace {

using Eigen::Matrix3d;
using JetRows = Eigen::Matrix<double, 5, 3, Eigen::RowMajor>;  // jet y as (row r, component c)

/// Largest projection space (FaceBilinear).
constexpr int kMaxModes = 4;
/// Fibre rows (Ẽ11, Ẽ22) of every mode, stacked: row 2a + i is mode a, fibre i.
constexpr int kMaxModeRows = 2 * kMaxModes;
using ModeRows = Eigen::Matrix<double, Eigen::Dynamic, 48, 0, kMaxModeRows, 48>;
using ModeColumns = Eigen::Matrix<double, 48, Eigen::Dynamic, 0, 48, kMaxModeRows>;
using ModeMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxModeRows, kMaxModeRows>;

/// What one Gauss point of the face keeps between the passes over the face.
struct PointWork {
  SurfaceJet y;
  StrainJacobian J;  ///< ∂s/∂y of the covariant strains s = (ε, κ)
  Vector6 e;         ///< orthotropic (e_m, e_b) the law sees (fibre rows projected)
  Vector6 gamma;     ///< ∂E_face/∂e at this point, after the projection's chain rule [J]
  Matrix6 d2W;       ///< w dA ∂²W/∂e² at the point [J]
  double wA = 0;     ///< Gauss weight × area element [m²]
  /// ψ_a(p), the projection space's basis at this point, orthonormal in the face's quadrature
  /// inner product ⟨f, g⟩ = Σ_p w dA f_p g_p [1/m].
  std::array<double, kMaxModes> psi{};
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

/// The same as one row of 48 local entries.
Eigen::Matrix<double, 1, 48> to_local_row(const JetBasis& Dt, const Eigen::Ref<const Vector15>& v) {
  const FaceCoordinates local = to_local(Dt, v);
  return Eigen::Map<const Eigen::Matrix<double, 1, 48>>(local.data());
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

/// Raw mode a of the projection space at face parameters (u, v), centred on the face.
double raw_mode(int a, const Eigen::Vector2d& uv) {
  const double u = uv.x() - 0.5, v = uv.y() - 0.5;
  switch (a) {
    case 0: return 1.0;
    case 1: return u;
    case 2: return v;
    default: return u * v;
  }
}

/// ψ_a at every point: modified Gram–Schmidt of the raw modes in ⟨·, ·⟩, so that the L²
/// projection is ē_p = Σ_a ψ_a(p) ⟨ψ_a, e⟩ = Σ_q Π_pq e_q with Π_pq = w_q dA_q Σ_a ψ_a(p) ψ_a(q).
void orthonormal_modes(int modes, const FaceQuadrature& face, PointWork* work) {
  const int n = face.points_per_face;
  auto dot = [&](int a, int b) {
    double sum = 0.0;
    for (int p = 0; p < n; ++p) sum += work[p].wA * work[p].psi[a] * work[p].psi[b];
    return sum;
  };
  for (int a = 0; a < modes; ++a) {
    for (int p = 0; p < n; ++p) work[p].psi[a] = raw_mode(a, face.gauss_uv[p]);
    for (int b = 0; b < a; ++b) {
      const double along = dot(a, b);
      for (int p = 0; p < n; ++p) work[p].psi[a] -= along * work[p].psi[b];
    }
    // A face rule with one point per direction cannot hold the linear modes (validated).
    const double norm2 = dot(a, a);
    assert(norm2 > 0.0);
    const double scale = 1.0 / std::sqrt(norm2);
    for (int p = 0; p < n; ++p) work[p].psi[a] *= scale;
  }
}

/// The projection applied to per-point fibre rows, in place: rows(p) is a 2 × m block, and
/// after the call rows(p) = Σ_a c_a(p) Σ_q ψ_a(q) ω_q(·) rows(q), with (c, ω) = (ψ, w dA) for
/// the strains themselves (`adjoint` false) and (w dA ψ, 1) for their chain rule, i.e. the
/// weights ∂E/∂ê_p pulled back to ∂E/∂e_q = Σ_p Π_pq ∂E/∂ê_p (`adjoint` true).
template <typename RowsOf>
void project_rows(int modes, int n, const PointWork* work, bool adjoint, RowsOf rows) {
  // Fixed-size for the energy path (one column), dynamic for the parameter Jacobian.
  using Block = Eigen::Matrix<double, 2, std::decay_t<decltype(rows(0))>::ColsAtCompileTime>;
  std::array<Block, kMaxModes> moment;
  for (int a = 0; a < modes; ++a) {
    moment[static_cast<std::size_t>(a)].setZero(2, rows(0).cols());
    for (int q = 0; q < n; ++q)
      moment[static_cast<std::size_t>(a)] += (adjoint ? 1.0 : work[q].wA) * work[q].psi[a] * rows(q);
  }
  for (int p = 0; p < n; ++p) {
    auto row = rows(p);
    row.setZero();
    for (int a = 0; a < modes; ++a)
      row += (adjoint ? work[p].wA : 1.0) * work[p].psi[a] * moment[static_cast<std::size_t>(a)];
  }
}

/// Strains of every point, with the fibre-strain projection of (Ẽ11, Ẽ22) applied to e.
void prepare_points(const FaceQuadrature& face, const FaceCoordinates& X, bool derivatives,
                    PointWork* work) {
  const int n = face.points_per_face;
  for (int p = 0; p < n; ++p) {
    PointWork& w = work[p];
    const ReferencePoint& ref = face.reference[p];
    w.y = face_jet(face.jet_basis[p], X);
    const Vector6 s = shell_strains(w.y, ref.A, ref.B, derivatives ? &w.J : nullptr);
    w.e << ref.T * s.head<3>(), ref.T * s.tail<3>();
    w.wA = ref.weight_area;
  }
  const int modes = projection_modes(face.fibre_strain);
  if (modes == 0) return;
  orthonormal_modes(modes, face, work);
  project_rows(modes, n, work, false, [&](int p) { return work[p].e.head<2>(); });
}

/// ∂E/∂s = blockdiag(T, T)ᵀ γ: orthotropic weights back to covariant ones.
Vector6 covariant_weights(const Matrix3d& T, const Vector6& gamma) {
  Vector6 g;
  g << T.transpose() * gamma.head<3>(), T.transpose() * gamma.tail<3>();
  return g;
}

/// Adds the Hessian blocks of one point: Dᵀ H_ab D per component pair from the jet Hessian Hy.
void add_point_blocks(const JetBasis& Dt, const Matrix15& Hy, FaceHessianBlocks& hessian) {
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      // H_ab(r, s) = Hy(3r + a, 3s + b): the (a, b) component coupling of jet rows r, s.
      const Eigen::Matrix<double, 5, 5> Hab =
          Eigen::Map<const Eigen::Matrix<double, 5, 5>, 0, Eigen::Stride<45, 3>>(Hy.data() + 15 * b + a);
      add_block(Dt, Hab, a == b, hessian[static_cast<std::size_t>(face_block_index(a, b))]);
    }
}

/// The projection's coupling terms of the local Hessian (docs/catmull_clark_kl.md §12). With
/// Q̃_p = ∂e_p/∂x without its fibre rows, G_q the fibre rows of ∂e_q/∂x and H_p = w dA ∂²W_p:
/// ∂ê_p(11, 22)/∂x = Σ_a ψ_a(p) Ũ_a with Ũ_a = Σ_q w_q dA_q ψ_a(q) G_q, and the Gauss–Newton
/// part Σ_p (Q̃_p + [Σ_a ψ_a Ũ_a; 0])ᵀ H_p (…) gains C Ũ + Ũᵀ Cᵀ + Ũᵀ M Ũ with
/// C_a = Σ_p ψ_a(p) Q̃_pᵀ H_p[:, 0:2] and M_ab = Σ_p ψ_a(p) ψ_b(p) H_p[0:2, 0:2].
struct ProjectionCoupling {
  ModeRows U;
  ModeColumns C;
  ModeMatrix M;

  explicit ProjectionCoupling(int modes)
      : U(ModeRows::Zero(2 * modes, 48)), C(ModeColumns::Zero(48, 2 * modes)),
        M(ModeMatrix::Zero(2 * modes, 2 * modes)) {}

  /// One point's share; Q its full ∂e/∂y (fibre rows still in), zeroed there on return.
  void add(const PointWork& w, const JetBasis& Dt, Eigen::Matrix<double, 6, 15>& Q) {
    const int modes = static_cast<int>(U.rows() / 2);
    Eigen::Matrix<double, 2, 48> G;
    for (int i = 0; i < 2; ++i) G.row(i) = to_local_row(Dt, Q.row(i).transpose());
    Q.topRows<2>().setZero();
    const Eigen::Matrix<double, 15, 2> QtH = Q.transpose() * w.d2W.leftCols<2>();
    Eigen::Matrix<double, 48, 2> QtH_local;
    for (int i = 0; i < 2; ++i) QtH_local.col(i) = to_local_row(Dt, QtH.col(i)).transpose();
    for (int a = 0; a < modes; ++a) {
      U.middleRows<2>(2 * a) += w.wA * w.psi[a] * G;
      C.middleCols<2>(2 * a) += w.psi[a] * QtH_local;
      for (int b = 0; b < modes; ++b)
        M.block<2, 2>(2 * a, 2 * b) += w.psi[a] * w.psi[b] * w.d2W.topLeftCorner<2, 2>();
    }
  }

  void add_to(FaceHessianBlocks& hessian) const {
    const Eigen::Matrix<double, 48, 48> K =
        C * U + U.transpose() * C.transpose() + U.transpose() * (M * U);
    for (int a = 0; a < 3; ++a)
      for (int b = a; b < 3; ++b)
        hessian[static_cast<std::size_t>(face_block_index(a, b))] += K.block<16, 16>(16 * a, 16 * b);
  }
};

}  // namespace

int projection_modes(FibreStrain fibre_strain) {
  switch (fibre_strain) {
    case FibreStrain::Pointwise: return 0;
    case FibreStrain::FaceMean: return 1;
    case FibreStrain::FaceLinear: return 3;
    case FibreStrain::FaceBilinear: return 4;
  }
  return 0;
}

const std::array<std::pair<FibreStrain, const char*>, 4>& fibre_strain_names() {
  static const std::array<std::pair<FibreStrain, const char*>, 4> names{{
      {FibreStrain::Pointwise, "pointwise"},
      {FibreStrain::FaceMean, "face-mean"},
      {FibreStrain::FaceLinear, "face-linear"},
      {FibreStrain::FaceBilinear, "face-bilinear"},
  }};
  return names;
}

FibreStrain fibre_strain_from_name(const std::string& name) {
  std::string known;
  for (const auto& [value, text] : fibre_strain_names()) {
    if (name == text) return value;
    known += (known.empty() ? "" : ", ") + std::string(text);
  }
  throw std::invalid_argument("unknown fibre_strain '" + name + "' (known: " + known + ")");
}

const char* fibre_strain_name(FibreStrain fibre_strain) {
  for (const auto& [value, text] : fibre_strain_names())
    if (value == fibre_strain) return text;
  return "?";
}

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
  const int modes = projection_modes(face.fibre_strain);
  PointWork* work = workspace(n).data();
  prepare_points(face, X, derivatives, work);

  double energy = 0.0;
  Vector6 dW;
  Matrix6 d2W;
  for (int p = 0; p < n; ++p) {
    PointWork& w = work[p];
    energy += w.wA * thickness_integral(law, thickness_m, rule, w.e, derivatives ? &dW : nullptr,
                                        hessian ? &d2W : nullptr);
    if (!derivatives) continue;
    w.gamma = w.wA * dW;
    if (hessian) w.d2W = w.wA * d2W;
  }
  if (!derivatives) return energy;
  if (modes > 0) project_rows(modes, n, work, true, [&](int p) { return work[p].gamma.head<2>(); });

  if (gradient) gradient->setZero();
  if (hessian)
    for (Matrix16& block : *hessian) block.setZero();
  ProjectionCoupling coupling(hessian && modes > 0 ? modes : 0);
  for (int p = 0; p < n; ++p) {
    const PointWork& w = work[p];
    const ReferencePoint& ref = face.reference[p];
    const JetBasis& Dt = face.jet_basis[p];
    const Vector6 dE_ds = covariant_weights(ref.T, w.gamma);
    if (gradient) gradient->noalias() += to_local(Dt, w.J.transpose() * dE_ds);
    if (!hessian) continue;
    Eigen::Matrix<double, 6, 15> Q;  // ∂e/∂y at the point
    Q.topRows<3>().noalias() = ref.T.lazyProduct(w.J.topRows<3>());
    Q.bottomRows<3>().noalias() = ref.T.lazyProduct(w.J.bottomRows<3>());
    if (modes > 0) coupling.add(w, Dt, Q);  // the fibre rows come from the projection instead
    Matrix15 Hy = shell_strain_hessian(w.y, dE_ds);
    const Eigen::Matrix<double, 6, 15> HQ = w.d2W.lazyProduct(Q);
    Hy.noalias() += Q.transpose().lazyProduct(HQ);
    add_point_blocks(Dt, Hy, *hessian);
  }
  if (!hessian) return energy;
  // Diagonal component blocks were accumulated in their upper triangle only.
  for (int a = 0; a < 3; ++a) {
    Matrix16& block = (*hessian)[static_cast<std::size_t>(face_block_index(a, a))];
    block.triangularView<Eigen::StrictlyLower>() = block.transpose();
  }
  if (modes > 0) coupling.add_to(*hessian);
  return energy;
}

void kirchhoff_love_face_strains(const FaceQuadrature& face, const FaceCoordinates& X,
                                 Vector6* strains) {
  PointWork* work = workspace(face.points_per_face).data();
  prepare_points(face, X, false, work);
  for (int p = 0; p < face.points_per_face; ++p) strains[p] = work[p].e;
}

void kirchhoff_love_face_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                            const GaussLegendreRule& rule,
                                            const FaceQuadrature& face, const FaceCoordinates& X,
                                            FaceParameterJacobian* dgradient_dk) {
  assert(dgradient_dk);
  const int n = face.points_per_face;
  const int num_k = law.num_parameters();
  const int modes = projection_modes(face.fibre_strain);
  PointWork* work = workspace(n).data();
  prepare_points(face, X, true, work);
  thread_local std::vector<StrainParameterJacobian> dW;  // per point, w dA ∂(∂W/∂e)/∂k
  if (static_cast<int>(dW.size()) < n) dW.resize(static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) {
    StrainParameterJacobian& column = dW[static_cast<std::size_t>(p)];
    thickness_integral_parameter_jacobian(law, thickness_m, rule, work[p].e, &column);
    column *= work[p].wA;
  }
  // The strains do not depend on k; projected, the fibre rows follow the same chain rule.
  if (modes > 0)
    project_rows(modes, n, work, true,
                 [&](int p) { return dW[static_cast<std::size_t>(p)].topRows<2>(); });
  dgradient_dk->setZero(48, num_k);
  for (int p = 0; p < n; ++p) {
    const PointWork& w = work[p];
    const ReferencePoint& ref = face.reference[p];
    const StrainParameterJacobian& column = dW[static_cast<std::size_t>(p)];
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
