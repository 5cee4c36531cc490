#include "discretizations/triangle_shell/hinge_bending.hpp"

#include <Eigen/Dense>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "discretizations/triangle_shell/strip_triangulation.hpp"

namespace twill {
namespace {

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

}  // namespace

MaterialParameters bending_parameters(const MaterialLaw& law, BendingParameterChain* chain) {
  const MaterialParameters& p = law.parameters();
  const BendingScale& scale = law.bending_scale();
  // Each stiffness with the entry (i, j) of C it sits in: (0,0) a11, (0,1) a12, (1,1) a22,
  // (2,2) 2 G12; the order of the first four bending columns.
  struct Entry {
    double MaterialParameters::*field;
    int flat, i, j;
  };
  const std::array<Entry, 4> entries = {{{&MaterialParameters::a11_Pa, FlatLayout::kA11, 0, 0},
                                         {&MaterialParameters::a12_Pa, FlatLayout::kA12, 0, 1},
                                         {&MaterialParameters::a22_Pa, FlatLayout::kA22, 1, 1},
                                         {&MaterialParameters::G12_Pa, FlatLayout::kG12, 2, 2}}};
  MaterialParameters out = p;
  // The ratios are in the stiffnesses now: 1, so that nothing applies them twice.
  out.bending_warp_ratio = out.bending_weft_ratio = 1.0;
  if (chain) chain->setZero(kBendingParameters, law.num_parameters());
  for (size_t r = 0; r < entries.size(); ++r) {
    const Entry& e = entries[r];
    out.*e.field = scale.stiffness_factor(e.i, e.j) * p.*e.field;
    if (!chain) continue;
    const auto row = static_cast<Eigen::Index>(r);
    (*chain)(row, e.flat) = scale.stiffness_factor(e.i, e.j);
    chain->row(row).segment<FlatLayout::kBendingRatios>(law.layout().bending) =
        p.*e.field * scale.stiffness_factor_derivative(e.i, e.j);
  }
  if (chain) (*chain)(kBendingParameters - 1, FlatLayout::kThickness) = 1.0;
  return out;
}

double dihedral_angle(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                      const Eigen::Vector3d& x2, const Eigen::Vector3d& x3, Vector12* gradient,
                      Matrix12* hessian) {
  const Eigen::Vector3d e = x1 - x0, f = x2 - x0, g = x3 - x0;
  const double l = e.norm();
  const Eigen::Vector3d eh = e / l;
  const Eigen::Vector3d nA = e.cross(f), nB = g.cross(e);
  const double theta = std::atan2(nA.cross(nB).dot(eh), nA.dot(nB));
  if (!gradient && !hessian) return theta;

  const double nA2 = nA.squaredNorm(), nB2 = nB.squaredNorm();
  const Eigen::Vector3d wA = nA / nA2, wB = nB / nB2;
  // ∂θ/∂x_i = cA[i] wA + cB[i] wB (Bridson et al. 2003 in cotangent-free form).
  const std::array<double, 4> cA = {(x1 - x2).dot(eh), (x2 - x0).dot(eh), -l, 0.0};
  const std::array<double, 4> cB = {(x1 - x3).dot(eh), (x3 - x0).dot(eh), 0.0, -l};
  if (gradient)
    for (int i = 0; i < 4; ++i)
      gradient->segment<3>(3 * i) =
          cA[static_cast<size_t>(i)] * wA + cB[static_cast<size_t>(i)] * wB;
  if (!hessian) return theta;

  // ∂(n/|n|²)/∂n = (I − 2 n̂ n̂ᵀ)/|n|².
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d MA = (I - 2.0 * nA * nA.transpose() / nA2) / nA2;
  const Eigen::Matrix3d MB = (I - 2.0 * nB * nB.transpose() / nB2) / nB2;
  // ∂nA/∂x_j for nA = e × f, ∂nB/∂x_j for nB = g × e.
  const Eigen::Matrix3d ex = cross_matrix(e), fx = cross_matrix(f), gx = cross_matrix(g);
  const std::array<Eigen::Matrix3d, 4> dnA = {fx - ex, -fx, ex, Eigen::Matrix3d::Zero()};
  const std::array<Eigen::Matrix3d, 4> dnB = {ex - gx, gx, Eigen::Matrix3d::Zero(), -ex};
  // ∂(u·ê)/∂x via dê = P de, P = (I − ê êᵀ)/l, de = dx1 − dx0.
  const Eigen::Matrix3d P = (I - eh * eh.transpose()) / l;
  const Eigen::Vector3d z = Eigen::Vector3d::Zero();
  const Eigen::Vector3d p12 = P * (x1 - x2), p20 = P * (x2 - x0);
  const Eigen::Vector3d p13 = P * (x1 - x3), p30 = P * (x3 - x0);
  // dcA[i][j] = ∂cA[i]/∂x_j, likewise dcB.
  const std::array<std::array<Eigen::Vector3d, 4>, 4> dcA = {{
      {-p12, eh + p12, -eh, z},
      {-eh - p20, p20, eh, z},
      {eh, -eh, z, z},
      {z, z, z, z},
  }};
  const std::array<std::array<Eigen::Vector3d, 4>, 4> dcB = {{
      {-p13, eh + p13, z, -eh},
      {-eh - p30, p30, z, eh},
      {z, z, z, z},
      {eh, -eh, z, z},
  }};
  for (size_t i = 0; i < 4; ++i)
    for (size_t j = 0; j < 4; ++j) {
      hessian->block<3, 3>(3 * static_cast<int>(i), 3 * static_cast<int>(j)) =
          wA * dcA[i][j].transpose() + cA[i] * MA * dnA[j] + wB * dcB[i][j].transpose() +
          cB[i] * MB * dnB[j];
    }
  // The exact Hessian is symmetric; symmetrising removes round-off asymmetry only.
  *hessian = 0.5 * (*hessian + hessian->transpose()).eval();
  return theta;
}

HingeReference hinge_reference(const Eigen::Vector2d& X0, const Eigen::Vector2d& X1,
                               const Eigen::Vector2d& X2, const Eigen::Vector2d& X3) {
  auto cross2 = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() * b.y() - a.y() * b.x();
  };
  const Eigen::Vector2d e = X1 - X0;
  const double l = e.norm();
  const Eigen::Vector2d eh = e / l;
  const double twoA = cross2(e, X2 - X0);  // |nA| in the flat state (nA = +z |nA|)
  const double twoB = cross2(X3 - X0, e);
  assert(twoA > 0.0 && twoB > 0.0);
  HingeReference ref;
  ref.weight = l * l / ((0.5 * twoA + 0.5 * twoB) / 3.0);
  // ∂θ/∂z_i in the flat state: the z-components of dihedral_angle()'s gradient with
  // nA/|nA|² = ẑ/|nA|. For z_i = ½ X_iᵀ K X_i (a small uniform curvature), θ ≈ Σ c_i z_i.
  const std::array<double, 4> c = {
      (X1 - X2).dot(eh) / twoA + (X1 - X3).dot(eh) / twoB,
      (X2 - X0).dot(eh) / twoA + (X3 - X0).dot(eh) / twoB,
      -l / twoA,
      -l / twoB,
  };
  // Positions relative to X0: translation invariance (Σc_i = 0, Σc_i X_i = 0) makes the
  // origin irrelevant, and this choice keeps round-off small.
  const std::array<Eigen::Vector2d, 4> X = {Eigen::Vector2d::Zero(), X1 - X0, X2 - X0, X3 - X0};
  Eigen::Matrix2d mode = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < 4; ++i) mode += c[i] * 0.5 * X[i] * X[i].transpose();
  ref.mode << mode(0, 0), mode(1, 1), std::sqrt(2.0) * mode(0, 1);
  return ref;
}

HingeReference hinge_reference(const Eigen::Matrix<double, Eigen::Dynamic, 2>& xy, const Hinge& h) {
  const auto X = [&](size_t k) { return Eigen::Vector2d(xy.row(h.v[k]).transpose()); };
  return hinge_reference(X(0), X(1), X(2), X(3));
}

std::vector<std::string> calibration_cylinder_names() { return {"warp", "weft", "+45", "-45"}; }

HingeCalibration::HingeCalibration(std::vector<Eigen::Matrix3d> class_response, double angle_deg)
    : response_(std::move(class_response)) {
  const double t = angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d d2(std::cos(t), std::sin(t)), d1(-std::sin(t), std::cos(t));
  const double s = 1.0 / std::sqrt(2.0);
  const std::array<Eigen::Vector2d, 4> u = {d1, d2, s * (d1 + d2), s * (d1 - d2)};
  cylinder_response_.resize(kCalibrationCylinders, num_classes());
  for (int j = 0; j < kCalibrationCylinders; ++j) {
    const Eigen::Vector2d& uj = u[static_cast<size_t>(j)];
    const double u1 = uj.dot(d1), u2 = uj.dot(d2);
    cylinder_strain_.row(j) << u1 * u1, u2 * u2, u1 * u2;
    const Eigen::Vector3d k(uj.x() * uj.x(), uj.y() * uj.y(), std::sqrt(2.0) * uj.x() * uj.y());
    for (int c = 0; c < num_classes(); ++c)
      cylinder_response_(j, c) = k.dot(response_[static_cast<size_t>(c)] * k);
  }
}

double kirchhoff_love_cylinder_energy(const MaterialParameters& p, const Eigen::Vector3d& e,
                                      Eigen::Matrix<double, 1, 5>* derivative) {
  const double tau = p.thickness_m, c = tau * tau * tau / 24.0;
  // ẽᵀCẽ with C = ∂²ψ/∂ẽ²(0) = [[a11, a12, 0], [a12, a22, 0], [0, 0, 2 G12]]: ψ has
  // G12·Ẽ12² (not 2·G12·Ẽ12²), and ηj'(0) = 1 makes the curves drop out at zero strain.
  const double q = p.a11_Pa * e[0] * e[0] + 2.0 * p.a12_Pa * e[0] * e[1] +
                   p.a22_Pa * e[1] * e[1] + 2.0 * p.G12_Pa * e[2] * e[2];
  if (derivative)
    *derivative << c * e[0] * e[0], c * 2.0 * e[0] * e[1], c * e[1] * e[1], c * 2.0 * e[2] * e[2],
        3.0 * c / tau * q;
  return c * q;
}

Eigen::Vector4d HingeCalibration::kirchhoff_love_targets(
    const MaterialParameters& p, Eigen::Matrix<double, 4, 5>* derivative) const {
  Eigen::Vector4d t;
  for (int j = 0; j < kCalibrationCylinders; ++j) {
    Eigen::Matrix<double, 1, 5> row;
    t[j] = kirchhoff_love_cylinder_energy(p, cylinder_strain_.row(j).transpose(),
                                          derivative ? &row : nullptr);
    if (derivative) derivative->row(j) = row;
  }
  return t;
}

namespace {

// A class stiffness this far below zero (relative to the largest) counts as zero in an exact
// match (round-off of a 3 × 3 or 4 × 4 solve); anything more negative rejects the match.
constexpr double kNegativeStiffnessTolerance = 1e-12;
// Solves whose matrix is conditioned worse than this are skipped: the exact match's
// rows × classes system, and the least-squares normal equations (squared condition).
constexpr double kExactConditionFloor = 1e-10;
constexpr double kNormalConditionFloor = 1e-12;
// A later least-squares subset replaces the best only when its residual is smaller by more
// than round-off.
constexpr double kResidualTieFraction = 1e-12;

// (A k − t)_j / t_j per calibration cylinder (absolute where the target is zero).
Eigen::Vector4d relative_error_of(const Eigen::MatrixXd& A, const Eigen::Vector4d& t, const Eigen::VectorXd& k) {
  Eigen::Vector4d r = A * k - t;
  for (int j = 0; j < 4; ++j) r[j] = t[j] != 0.0 ? r[j] / t[j] : r[j];
  return r;
}

// 1. Exact matches: warp, weft and one of the two 45° cylinders (equal KL energies, by
//    orthotropic symmetry) for three classes; all four for four classes. Among exact
//    non-negative solutions the one with the smallest error on the remaining rows; `exact`
//    false when there is none.
HingeClassStiffness exact_match(const Eigen::MatrixXd& A, const Eigen::Vector4d& t, const Eigen::Matrix<double, 4, 5>& dt) {
  const auto n = static_cast<int>(A.cols());
  HingeClassStiffness best;
  double best_error = std::numeric_limits<double>::infinity();
  std::vector<std::vector<int>> row_sets;
  if (n == 3) row_sets = {{0, 1, 2}, {0, 1, 3}};
  if (n == 4) row_sets = {{0, 1, 2, 3}};
  for (const auto& rows : row_sets) {
    Eigen::MatrixXd AR(n, n);
    Eigen::MatrixXd dtR(n, 5);
    Eigen::VectorXd tR(n);
    for (int r = 0; r < n; ++r) {
      AR.row(r) = A.row(rows[static_cast<size_t>(r)]);
      tR[r] = t[rows[static_cast<size_t>(r)]];
      dtR.row(r) = dt.row(rows[static_cast<size_t>(r)]);
    }
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(AR);
    if (lu.rank() < n || lu.rcond() < kExactConditionFloor) continue;
    const Eigen::VectorXd k = lu.solve(tR);
    if ((k.array() < -kNegativeStiffnessTolerance * k.cwiseAbs().maxCoeff()).any()) continue;
    const Eigen::Vector4d err = relative_error_of(A, t, k);
    const double worst = err.cwiseAbs().maxCoeff();
    if (worst < best_error) {
      best_error = worst;
      best.stiffness = k.cwiseMax(0.0);
      best.derivative = lu.solve(dtR);
      best.exact = true;
      best.relative_error = err;
    }
  }
  return best;
}

// 2. Otherwise the pattern cannot separate these cylinders: non-negative least squares over
//    all four, by enumerating the active classes (n ≤ 4, at most 15 subsets). The fit is
//    unweighted (every row is an energy per area at unit curvature), so on a fixed subset k is
//    linear in the targets and ∂k = (A_Pᵀ A_P)⁻¹ A_Pᵀ ∂t.
HingeClassStiffness nonnegative_least_squares(const Eigen::MatrixXd& A, const Eigen::Vector4d& t,
                                              const Eigen::Matrix<double, 4, 5>& dt) {
  const auto n = static_cast<int>(A.cols());
  HingeClassStiffness best;
  double best_residual = std::numeric_limits<double>::infinity();
  for (int mask = 1; mask < (1 << n); ++mask) {
    std::vector<int> cols;
    for (int c = 0; c < n; ++c)
      if (mask & (1 << c)) cols.push_back(c);
    Eigen::MatrixXd AP(4, static_cast<Eigen::Index>(cols.size()));
    for (size_t c = 0; c < cols.size(); ++c) AP.col(static_cast<Eigen::Index>(c)) = A.col(cols[c]);
    const Eigen::MatrixXd M = AP.transpose() * AP;
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(M);
    if (lu.rank() < M.rows() || lu.rcond() < kNormalConditionFloor) continue;
    const Eigen::VectorXd kP = lu.solve(AP.transpose() * t);
    if ((kP.array() < 0.0).any()) continue;
    const double residual = (AP * kP - t).norm();
    if (residual < best_residual * (1.0 - kResidualTieFraction)) {
      best_residual = residual;
      const Eigen::MatrixXd dkP = lu.solve(AP.transpose() * dt);
      best.stiffness = Eigen::VectorXd::Zero(n);
      best.derivative = Eigen::Matrix<double, Eigen::Dynamic, 5>::Zero(n, 5);
      for (size_t c = 0; c < cols.size(); ++c) {
        best.stiffness[cols[c]] = kP[static_cast<Eigen::Index>(c)];
        best.derivative.row(cols[c]) = dkP.row(static_cast<Eigen::Index>(c));
      }
    }
  }
  if (!std::isfinite(best_residual))
    throw std::invalid_argument(
        "hinge calibration: no non-negative hinge stiffness fits the bending targets (are "
        "a11, a22 and a12 + G12 positive?)");
  best.exact = false;
  best.relative_error = relative_error_of(A, t, best.stiffness);
  return best;
}

// Unit mode up to sign (first clearly non-zero entry positive).
constexpr double kSignEntryFloor = 1e-8;
Eigen::Vector3d mode_direction(const Eigen::Vector3d& mode) {
  Eigen::Vector3d d = mode.normalized();
  for (int i = 0; i < 3; ++i)
    if (std::abs(d[i]) > kSignEntryFloor) {
      if (d[i] < 0) d = -d;
      break;
    }
  return d;
}

// Two unit mode directions closer than this are one class.
constexpr double kSameDirection = 1e-6;
// The central cells' bounds are shifted down by this fraction of a cell (half-open windows).
constexpr double kWindowShift = 1e-9;

// The hinge classes of a 4 × 4-cell patch of the unperturbed pattern: per class its mode
// direction, Σ g m mᵀ and count over the patch, and its hinges in the central 2 × 2 cells.
struct PatternClasses {
  std::vector<Eigen::Vector3d> directions;
  std::vector<Eigen::Matrix3d> patch_sum;
  std::vector<int> patch_count, central_count;

  int find(const Eigen::Vector3d& d) const {
    for (size_t c = 0; c < directions.size(); ++c)
      if ((directions[c] - d).norm() < kSameDirection) return static_cast<int>(c);
    return -1;
  }
  size_t add(const Eigen::Vector3d& d) {
    directions.push_back(d);
    patch_sum.push_back(Eigen::Matrix3d::Zero());
    patch_count.push_back(0);
    central_count.push_back(0);
    return directions.size() - 1;
  }
};

PatternClasses pattern_classes(const StripTriangulation& tri) {
  const TrianglePattern base = tri.pattern == TrianglePattern::Irregular ? TrianglePattern::Alternating : tri.pattern;
  StripSpec patch_spec;
  patch_spec.cells_along = 4;
  patch_spec.cells_across = 4;
  patch_spec.length_m = 4.0 * tri.cell_length_m;
  patch_spec.width_m = 4.0 * tri.cell_width_m;
  const StripTriangulation patch = triangulate_strip(patch_spec, base, 0.0, 0);
  PatternClasses out;
  const double hx = tri.cell_length_m, hy = tri.cell_width_m;
  const double y0 = -0.5 * patch_spec.width_m;
  for (const Hinge& h : patch.hinges) {
    const HingeReference r = hinge_reference(patch.base_xy, h);
    const Eigen::Vector3d d = mode_direction(r.mode);
    const int found = out.find(d);
    const size_t cu = found < 0 ? out.add(d) : static_cast<size_t>(found);
    out.patch_sum[cu] += r.weight * r.mode * r.mode.transpose();
    ++out.patch_count[cu];
    // The central 2 × 2 cells (half-open, so each periodic hinge is counted once per period).
    const Eigen::Vector2d mid = 0.5 * (patch.base_xy.row(h.v[0]) + patch.base_xy.row(h.v[1])).transpose();
    const double s = kWindowShift;
    if (mid.x() >= hx * (1 - s) && mid.x() < hx * (3 - s) && mid.y() >= y0 + hy * (1 - s) &&
        mid.y() < y0 + hy * (3 - s))
      ++out.central_count[cu];
  }
  return out;
}

}  // namespace

HingeClassStiffness HingeCalibration::solve(const MaterialParameters& p) const {
  Eigen::Matrix<double, 4, 5> dt;
  const Eigen::Vector4d t = kirchhoff_love_targets(p, &dt);
  HingeClassStiffness exact = exact_match(cylinder_response_, t, dt);
  if (exact.exact) return exact;
  return nonnegative_least_squares(cylinder_response_, t, dt);
}

HingeClasses classify_hinges(const StripTriangulation& tri) {
  const PatternClasses pattern = pattern_classes(tri);
  const size_t nc = pattern.directions.size();
  HingeClasses out;
  std::vector<Eigen::Matrix3d> mesh_sum(nc, Eigen::Matrix3d::Zero());
  std::vector<int> mesh_count(nc, 0);
  out.class_of_hinge.reserve(tri.hinges.size());
  for (const Hinge& h : tri.hinges) {
    const int c = pattern.find(mode_direction(hinge_reference(tri.base_xy, h).mode));
    if (c < 0) throw std::logic_error("classify_hinges: a hinge mode is not in the pattern");
    const HingeReference r = hinge_reference(tri.reference_xy, h);
    mesh_sum[static_cast<size_t>(c)] += r.weight * r.mode * r.mode.transpose();
    ++mesh_count[static_cast<size_t>(c)];
    out.class_of_hinge.push_back(c);
  }
  const double cell_area = tri.cell_length_m * tri.cell_width_m;
  for (size_t c = 0; c < nc; ++c) {
    // Hinges per cell: 4 central cells. The mean over the mesh's own hinges when it has any
    // (the homogenised response of a perturbed mesh), else over the patch.
    const double density = pattern.central_count[c] / (4.0 * cell_area);
    const Eigen::Matrix3d mean = mesh_count[c] > 0 ? Eigen::Matrix3d(mesh_sum[c] / mesh_count[c])
                                                   : Eigen::Matrix3d(pattern.patch_sum[c] / pattern.patch_count[c]);
    out.response.push_back(density * mean);
    out.hinges_per_cell.push_back(pattern.central_count[c] / 4);
    out.density.push_back(density);
  }
  return out;
}

namespace {

/// Warp d1 and weft d2 of a strip at angle_deg (core/discretization.hpp).
std::array<Eigen::Vector2d, 2> material_frame(double angle_deg) {
  const double t = angle_deg * std::numbers::pi / 180.0;
  return {Eigen::Vector2d(-std::sin(t), std::cos(t)), Eigen::Vector2d(std::cos(t), std::sin(t))};
}

/// (a11, a12 + G12, a22) and the map of ∂/∂P to ∂/∂(a11, a12, a22, G12, τ) columns.
Eigen::Vector3d plate_stiffnesses(const MaterialParameters& p) {
  return {p.a11_Pa, p.a12_Pa + p.G12_Pa, p.a22_Pa};
}

Eigen::Matrix<double, 1, 5> to_parameter_columns(const Eigen::Vector3d& d_dP, double d_dtau) {
  Eigen::Matrix<double, 1, 5> out;
  out << d_dP[0], d_dP[1], d_dP[2], d_dP[1], d_dtau;
  return out;
}

}  // namespace

Eigen::Vector3d directional_weights(const Eigen::Vector2d& n, double angle_deg) {
  const auto d = material_frame(angle_deg);
  const double n1 = n.dot(d[0]), n2 = n.dot(d[1]);
  return {n1 * n1 * n1 * n1, 2.0 * n1 * n1 * n2 * n2, n2 * n2 * n2 * n2};
}

DirectionalHingeModel::DirectionalHingeModel(const StripTriangulation& tri,
                                             const HingeClasses& classes, double angle_deg) {
  const size_t nc = classes.response.size();
  // Per class and stiffness component m: S_cm = n_c/A_cell · mean_{e∈c} g_e w_em ℓ_e ℓ_eᵀ
  // over the mesh's own hinges (the homogenisation of §4.3 with the per-hinge weight).
  std::vector<std::array<Eigen::Matrix3d, 3>> sum(
      nc, {Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero(), Eigen::Matrix3d::Zero()});
  std::vector<int> count(nc, 0);
  weights_.resize(static_cast<Eigen::Index>(tri.hinges.size()), 3);
  for (size_t h = 0; h < tri.hinges.size(); ++h) {
    const Hinge& hinge = tri.hinges[h];
    const auto X = [&](int k) {
      return Eigen::Vector2d(tri.reference_xy.row(hinge.v[static_cast<size_t>(k)]));
    };
    const Eigen::Vector2d t = (X(1) - X(0)).normalized();
    const Eigen::Vector3d w = directional_weights(Eigen::Vector2d(-t.y(), t.x()), angle_deg);
    weights_.row(static_cast<Eigen::Index>(h)) = w.transpose();
    const HingeReference r = hinge_reference(tri.reference_xy, hinge);
    const auto c = static_cast<size_t>(classes.class_of_hinge[h]);
    for (int m = 0; m < 3; ++m) sum[c][static_cast<size_t>(m)] += r.weight * w[m] * r.mode * r.mode.transpose();
    ++count[c];
  }
  const auto d = material_frame(angle_deg);
  const double s = 1.0 / std::sqrt(2.0);
  const std::array<Eigen::Vector2d, 4> u = {d[0], d[1], s * (d[0] + d[1]), s * (d[0] - d[1])};
  response_.setZero();
  for (int j = 0; j < kCalibrationCylinders; ++j) {
    const Eigen::Vector2d& uj = u[static_cast<size_t>(j)];
    // Unit cylinder u⊗u: vec(K) = (ux², uy², √2 ux uy); its KL weights are w(u).
    const Eigen::Vector3d k(uj.x() * uj.x(), uj.y() * uj.y(), std::sqrt(2.0) * uj.x() * uj.y());
    target_.row(j) = directional_weights(uj, angle_deg).transpose();
    for (size_t c = 0; c < nc; ++c) {
      if (count[c] == 0) continue;  // a class absent from a tiny mesh contributes nothing
      for (int m = 0; m < 3; ++m)
        response_(j, m) += classes.density[c] / count[c] * k.dot(sum[c][static_cast<size_t>(m)] * k);
    }
  }
}

HingeStiffness DirectionalHingeModel::solve(const MaterialParameters& p) const {
  const Eigen::Vector3d P = plate_stiffnesses(p);
  const double tau = p.thickness_m, c = tau * tau * tau / 72.0;  // k⁰_e = D(n_e)/6 = c w_e·P
  // Hinge / KL energy of cylinder j per unit λ: r_j = (τ³/72 R_j·P)/(τ³/24 s_j·P), free of τ.
  Eigen::Vector4d r;
  std::array<Eigen::Vector3d, 4> dr;  // ∂r_j/∂P
  for (int j = 0; j < kCalibrationCylinders; ++j) {
    const double a = response_.row(j).dot(P), b = 3.0 * target_.row(j).dot(P);
    if (!(b > 0.0))
      throw std::invalid_argument(
          "directional hinge stiffness: the plate has no positive bending stiffness along a "
          "calibration cylinder (is a12 + G12 > −√(a11 a22)?)");
    r[j] = a / b;
    dr[static_cast<size_t>(j)] = response_.row(j).transpose() / b -
                                 r[j] * 3.0 * target_.row(j).transpose() / b;
  }
  // λ minimises Σ_{j = warp, weft} (λ r_j − 1)²: λ = (r0 + r1)/(r0² + r1²).
  const double num = r[0] + r[1], den = r[0] * r[0] + r[1] * r[1];
  if (!(num > 0.0))
    throw std::invalid_argument(
        "directional hinge stiffness: no hinge responds to the warp and weft cylinders");
  HingeStiffness out;
  out.scale = num / den;
  const Eigen::Vector3d dlambda =
      (dr[0] + dr[1]) / den - num / (den * den) * 2.0 * (r[0] * dr[0] + r[1] * dr[1]);
  out.scale_derivative = to_parameter_columns(dlambda, 0.0);
  for (int j = 0; j < kCalibrationCylinders; ++j) out.relative_error[j] = out.scale * r[j] - 1.0;
  const Eigen::Index nh = weights_.rows();
  out.per_hinge.resize(nh);
  out.derivative.resize(nh, 5);
  for (Eigen::Index h = 0; h < nh; ++h) {
    const Eigen::Vector3d w = weights_.row(h).transpose();
    const double k0 = c * w.dot(P);
    out.per_hinge[h] = out.scale * k0;
    out.derivative.row(h) =
        to_parameter_columns(c * (w.dot(P) * dlambda + out.scale * w), 3.0 * out.per_hinge[h] / tau);
  }
  return out;
}

}  // namespace twill
