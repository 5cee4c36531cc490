#include "experiments/cantilever.hpp"

#include <chrono>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "core/constrained_dofs.hpp"
#include "core/sensitivity.hpp"

namespace twill {

bool CantileverSetup::validate(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(width_mm > 0)) return fail("width_mm must be > 0, got " + std::to_string(width_mm));
  if (cells_across < 1) return fail("cells_across must be ≥ 1, got " + std::to_string(cells_across));
  if (cells_along < 2) return fail("cells_along must be ≥ 2, got " + std::to_string(cells_along));
  if (gravity_steps < 1) return fail("gravity_steps must be ≥ 1, got " + std::to_string(gravity_steps));
  if (!std::isfinite(angle_deg)) return fail("angle_deg must be finite");
  return true;
}

CantileverExperiment::CantileverExperiment(const CantileverSetup& setup, DiscretizationFactory factory,
                                           const MaterialParameters& parameters,
                                           const EquilibriumOptions& solver)
    : setup_(setup), factory_(std::move(factory)), parameters_(parameters), solver_options_(solver) {
  std::string error;
  if (!setup_.validate(&error)) throw std::invalid_argument("cantilever setup: " + error);
}

namespace {

/// The overhanging part of the strip: `overhang_mm` long, the setup's width, mesh and angle.
StripSpec overhang_strip(const CantileverSetup& setup, double overhang_mm) {
  StripSpec strip;
  strip.length_m = 1e-3 * overhang_mm;
  strip.width_m = 1e-3 * setup.width_mm;
  strip.cells_across = setup.cells_across;
  strip.cells_along = setup.cells_along;
  strip.angle_deg = setup.angle_deg;
  return strip;
}

bool same_strip(const StripSpec& a, const StripSpec& b) {
  return a.length_m == b.length_m && a.width_m == b.width_m && a.cells_across == b.cells_across &&
         a.cells_along == b.cells_along && a.angle_deg == b.angle_deg;
}

/// The start of a solve in *q, and the gravity steps from it. Warm: the previous equilibrium
/// (same mesh topology, at `last_overhang_mm` > 0) stretched along the strip to the new
/// overhang, the clamp at rest, gravity in one step — close to the new equilibrium during an
/// overhang search, where the thin strip's large rotation makes a cold Newton start from flat
/// slow (tens of damped steps). Cold: the flat strip, gravity in `gravity_steps`.
int start_state(const Discretization& d, double overhang_mm, double last_overhang_mm, int gravity_steps,
                Eigen::VectorXd* q) {
  if (q->size() != d.num_dofs() || !(last_overhang_mm > 0)) {
    *q = d.rest_positions();
    return gravity_steps;
  }
  const double s = overhang_mm / last_overhang_mm;
  for (int n = 0; n < d.num_nodes(); ++n) {
    (*q)[3 * n] *= s;
    (*q)[3 * n + 2] *= s;
  }
  for (int n : d.clamped_nodes(StripEnd::Start, true)) q->segment<3>(3 * n) = d.rest_positions().segment<3>(3 * n);
  return 1;
}

/// dθ/dk [°] of the chord angle θ = atan2(−z, x) at the tip (tip = P q): dθ = (z dx − x dz) /
/// (x² + z²), through the equilibrium's sensitivity (paper Eq. 6).
Eigen::VectorXd chord_angle_gradient(const EquilibriumSolver& solver, const Eigen::VectorXd& q,
                                     const std::vector<int>& parameters, const SparseMatrix& tip_probe,
                                     const Eigen::Vector3d& tip) {
  const EquilibriumSensitivity sens(solver, q, parameters);
  const double r2 = tip.x() * tip.x() + tip.z() * tip.z();
  const Eigen::Vector3d dtheta_dtip(tip.z() / r2, 0.0, -tip.x() / r2);
  const Eigen::VectorXd dtheta_dq = tip_probe.transpose() * dtheta_dtip;
  return sens.observable_derivative(dtheta_dq) * (180.0 / std::numbers::pi);
}

}  // namespace

CantileverResult CantileverExperiment::solve(double overhang_mm) const {
  const auto start = std::chrono::steady_clock::now();
  CantileverResult result;
  result.overhang_mm = overhang_mm;
  if (!(overhang_mm > 0)) throw std::invalid_argument("cantilever overhang must be > 0 mm");

  const StripSpec strip = overhang_strip(setup_, overhang_mm);
  // The mesh precompute (patch tables, basis values) depends only on the strip: a solve at the
  // same overhang (every evaluation of a fit's bend stage) reuses it with the new material.
  if (last_discretization_ && same_strip(last_discretization_->strip(), strip))
    last_discretization_->set_parameters(parameters_);
  else
    last_discretization_ = factory_(strip, parameters_);
  Discretization& d = *last_discretization_;

  const std::vector<int> fixed = ConstrainedDofs::node_dofs(d.clamped_nodes(StripEnd::Start, true));
  EquilibriumSolver solver(d, fixed, solver_options_);
  const SparseMatrix tip_probe = d.point_evaluation({Eigen::Vector2d(strip.length_m, 0.0)});
  const int steps = start_state(d, overhang_mm, last_overhang_mm_, setup_.gravity_steps, &last_q_);
  auto apply_step = [&](int step, Eigen::VectorXd*) {
    const double fraction = static_cast<double>(step + 1) / steps;
    d.set_gravity(Eigen::Vector3d(0, 0, -kStandardGravity_m_s2 * fraction));
  };
  const ContinuationSummary summary = solver.solve_continuation(steps, apply_step, &last_q_);
  last_overhang_mm_ = summary.completed ? overhang_mm : 0.0;
  const Eigen::Vector3d tip = tip_probe * last_q_;
  result.converged = summary.completed;
  result.message = summary.message;
  result.newton_iterations = summary.total_newton_iterations;
  result.chord_angle_deg = std::atan2(-tip.z(), tip.x()) * 180.0 / std::numbers::pi;
  result.tip_deflection_mm = -1e3 * tip.z();
  if (result.converged && !sensitivity_parameters_.empty())
    result.dchord_angle_dk = chord_angle_gradient(solver, last_q_, sensitivity_parameters_, tip_probe, tip);
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

namespace {
/// Small-curvature bending stiffness S C S (C the law's Hessian at zero strain, S the
/// bending-strain scale of the bending ratios, core/bending_scale.hpp) in strip axes
/// (a, b ∈ {x, y}): a unit curvature K = s⊗t (symmetrised) has ẽ = (d1·K·d1, d2·K·d2, d1·K·d2).
double strip_bending_stiffness(const MaterialParameters& p, double angle_deg, const Eigen::Vector2d& s1,
                               const Eigen::Vector2d& s2) {
  const double t = angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d d2(std::cos(t), std::sin(t)), d1(-std::sin(t), std::cos(t));
  auto orthotropic = [&](const Eigen::Vector2d& a) {
    return Eigen::Vector3d((a.dot(d1)) * (a.dot(d1)), (a.dot(d2)) * (a.dot(d2)), (a.dot(d1)) * (a.dot(d2)));
  };
  Matrix3 H;
  Vector3 g;
  const MaterialLaw law(p);
  law.energy_density(Vector3::Zero(), &g, &H);
  const auto S = law.bending_scale().diagonal.asDiagonal();
  return orthotropic(s1).dot(S * H * S * orthotropic(s2));
}
}  // namespace

double CantileverExperiment::bending_rigidity_plate_Nm() const {
  const double tau = parameters_.thickness_m;
  return tau * tau * tau / 12.0 *
         strip_bending_stiffness(parameters_, setup_.angle_deg, Eigen::Vector2d::UnitX(), Eigen::Vector2d::UnitX());
}

double CantileverExperiment::bending_rigidity_free_Nm() const {
  const double tau = parameters_.thickness_m;
  const Eigen::Vector2d x = Eigen::Vector2d::UnitX(), y = Eigen::Vector2d::UnitY();
  const double cxx = strip_bending_stiffness(parameters_, setup_.angle_deg, x, x);
  const double cxy = strip_bending_stiffness(parameters_, setup_.angle_deg, x, y);
  const double cyy = strip_bending_stiffness(parameters_, setup_.angle_deg, y, y);
  return tau * tau * tau / 12.0 * (cxx - cxy * cxy / cyy);
}

double CantileverExperiment::peirce_overhang_mm(double rigidity_Nm) const {
  const double w = parameters_.density_kg_m2 * kStandardGravity_m_s2;
  return 2e3 * std::cbrt(rigidity_Nm / w);
}

OverhangSearchResult CantileverExperiment::find_overhang(double target_deg, double tolerance_deg) const {
  const auto start = std::chrono::steady_clock::now();
  OverhangSearchResult out;
  auto f = [&](double L, bool* ok) {
    const CantileverResult r = solve(L);
    ++out.evaluations;
    *ok = r.converged;
    if (!r.converged) out.message = "solve at overhang " + std::to_string(L) + " mm: " + r.message;
    return r.chord_angle_deg - target_deg;
  };
  auto finish = [&](double L, double residual, bool converged) {
    out.overhang_mm = L;
    out.chord_angle_deg = residual + target_deg;
    out.converged = converged;
    out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
  };

  // Bracket the root starting from Peirce's estimate (angle grows with L).
  bool ok = true;
  double a = peirce_overhang_mm(bending_rigidity_free_Nm());
  double fa = f(a, &ok);
  if (!ok) return finish(a, fa, false);
  if (std::abs(fa) <= tolerance_deg) return finish(a, fa, true);
  const double grow = fa < 0 ? 1.15 : 1.0 / 1.15;
  double b = a * grow, fb = f(b, &ok);
  for (int i = 0; ok && fa * fb > 0 && i < 30; ++i) {
    a = b;
    fa = fb;
    b = a * grow;
    fb = f(b, &ok);
  }
  if (!ok) return finish(b, fb, false);
  if (fa * fb > 0) {
    out.message = "could not bracket the target chord angle";
    return finish(b, fb, false);
  }
  // Illinois (modified regula falsi): superlinear, and it keeps the bracket.
  for (int i = 0; i < 60; ++i) {
    const double c = (a * fb - b * fa) / (fb - fa);
    const double fc = f(c, &ok);
    if (!ok) return finish(c, fc, false);
    if (std::abs(fc) <= tolerance_deg) return finish(c, fc, true);
    if (fc * fb < 0) {
      a = b;
      fa = fb;
    } else {
      fa *= 0.5;  // the retained end stays: halve its weight (Illinois)
    }
    b = c;
    fb = fc;
  }
  out.message = "overhang search did not reach the tolerance in 60 iterations";
  return finish(b, fb, false);
}

}  // namespace twill
