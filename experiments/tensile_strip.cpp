#include "experiments/tensile_strip.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <stdexcept>

#include "core/constrained_dofs.hpp"

namespace twill {

bool TensileSetup::validate(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(width_mm > 0)) return fail("width_mm must be > 0, got " + std::to_string(width_mm));
  if (!(gauge_length_mm > 0))
    return fail("gauge_length_mm must be > 0, got " + std::to_string(gauge_length_mm));
  if (cells_across < 1) return fail("cells_across must be ≥ 1, got " + std::to_string(cells_across));
  if (cells_along < 1) return fail("cells_along must be ≥ 1, got " + std::to_string(cells_along));
  if (!std::isfinite(angle_deg)) return fail("angle_deg must be finite");
  return true;
}

StripSpec TensileSetup::strip() const {
  StripSpec s;
  s.length_m = 1e-3 * gauge_length_mm;
  s.width_m = 1e-3 * width_mm;
  s.cells_across = cells_across;
  s.cells_along = cells_along;
  s.angle_deg = angle_deg;
  return s;
}

namespace {

const TensileSetup& checked(const TensileSetup& setup) {
  std::string error;
  if (!setup.validate(&error)) throw std::invalid_argument("tensile setup: " + error);
  return setup;
}

std::vector<int> held_dofs(const Discretization& d, bool planar) {
  std::vector<int> nodes = d.clamped_nodes(StripEnd::Start, false);
  const std::vector<int> end = d.clamped_nodes(StripEnd::End, false);
  nodes.insert(nodes.end(), end.begin(), end.end());
  std::vector<int> dofs = ConstrainedDofs::node_dofs(nodes);
  if (planar)
    for (int n = 0; n < d.num_nodes(); ++n) dofs.push_back(3 * n + 2);
  std::sort(dofs.begin(), dofs.end());
  dofs.erase(std::unique(dofs.begin(), dofs.end()), dofs.end());
  return dofs;
}

SparseMatrix make_lateral_probe(const Discretization& d) {
  const StripSpec& s = d.strip();
  return d.point_evaluation({Eigen::Vector2d(0.5 * s.length_m, -0.5 * s.width_m),
                             Eigen::Vector2d(0.5 * s.length_m, 0.5 * s.width_m)});
}

}  // namespace

TensileExperiment::TensileExperiment(const TensileSetup& setup, const DiscretizationFactory& factory,
                                     const MaterialParameters& parameters,
                                     const EquilibriumOptions& solver)
    : setup_(checked(setup)),
      factory_(factory),
      discretization_(factory(setup.strip(), parameters)),
      moving_nodes_(discretization_->clamped_nodes(StripEnd::End, false)),
      fixed_dofs_(held_dofs(*discretization_, setup.planar)),
      lateral_probe_(make_lateral_probe(*discretization_)),
      solver_(*discretization_, fixed_dofs_, solver) {}

void TensileExperiment::set_parameters(const MaterialParameters& parameters) {
  discretization_->set_parameters(parameters);
  if (angle_plus_) angle_plus_->set_parameters(parameters);
  if (angle_minus_) angle_minus_->set_parameters(parameters);
}

void TensileExperiment::set_angle_sensitivity(bool on) {
  angle_plus_.reset();
  angle_minus_.reset();
  if (!on) return;
  auto turned_by = [&](double offset_deg) {
    StripSpec turned = setup_.strip();
    turned.angle_deg += offset_deg;
    std::unique_ptr<Discretization> d = factory_(turned, discretization_->parameters());
    if (d->num_dofs() != discretization_->num_dofs())
      throw std::logic_error("angle sensitivity: the turned mesh has other dofs");
    return d;
  };
  angle_plus_ = turned_by(kAngleStepDeg);
  angle_minus_ = turned_by(-kAngleStepDeg);
}

void TensileExperiment::add_angle_derivative(const EquilibriumSolver& solver, const Eigen::VectorXd& q,
                                             const std::vector<std::pair<int, double>>& clamp_x,
                                             TensilePoint* p) const {
  Eigen::VectorXd plus, minus;
  angle_plus_->energy(q, &plus, nullptr);
  angle_minus_->energy(q, &minus, nullptr);
  const Eigen::MatrixXd dg_dangle = (plus - minus) / (2 * kAngleStepDeg);
  const EquilibriumSensitivity sensitivity(solver, dg_dangle);
  p->dforce_dangle = sensitivity.reaction_derivative(clamp_x)[0];
  if (keep_states_) p->dq_dangle = sensitivity.position_derivatives().col(0);
}

double TensileExperiment::force_from_gradient(const Eigen::VectorXd& gradient) const {
  double force = 0;
  for (int n : moving_nodes_) force += gradient[3 * n];
  return force;
}

double TensileExperiment::lateral_strain(const Eigen::VectorXd& q) const {
  const Eigen::VectorXd p = lateral_probe_ * q;
  return (p.segment<3>(3) - p.segment<3>(0)).norm() / (1e-3 * setup_.width_mm) - 1.0;
}

Eigen::VectorXd TensileExperiment::lateral_strain_gradient(const Eigen::VectorXd& q) const {
  // s = |p_top − p_bottom| / W − 1  ⇒  ∂s/∂q = Pᵀ [−u; u] / W with u the unit chord.
  const Eigen::VectorXd p = lateral_probe_ * q;
  const Eigen::Vector3d chord = p.segment<3>(3) - p.segment<3>(0);
  const Eigen::Vector3d u = chord / chord.norm();
  Eigen::VectorXd w(6);
  w << -u, u;
  return lateral_probe_.transpose() * (w / (1e-3 * setup_.width_mm));
}

std::vector<Eigen::Vector3d> TensileExperiment::material_strain_samples(const Eigen::VectorXd& q,
                                                                       int samples_across) const {
  const StripSpec& s = discretization_->strip();
  const int nx = std::max(2, static_cast<int>(std::lround(samples_across * s.length_m / s.width_m)));
  const int ny = std::max(2, samples_across);
  const double h = 1e-3 * std::min(s.length_m / s.cells_along, s.width_m / s.cells_across);
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      // Cell-centred samples: never on the boundary, so ±h stays inside the strip.
      const Eigen::Vector2d c((i + 0.5) * s.length_m / nx, (j + 0.5) * s.width_m / ny - 0.5 * s.width_m);
      for (const Eigen::Vector2d& d : {Eigen::Vector2d(h, 0), Eigen::Vector2d(-h, 0),
                                       Eigen::Vector2d(0, h), Eigen::Vector2d(0, -h)})
        points.push_back(c + d);
    }
  const Eigen::VectorXd x = discretization_->point_evaluation(points) * q;
  const double theta = setup_.angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d d2(std::cos(theta), std::sin(theta)), d1(-std::sin(theta), std::cos(theta));
  std::vector<Eigen::Vector3d> samples(points.size() / 4);
  for (size_t k = 0; k < samples.size(); ++k) {
    Eigen::Matrix<double, 3, 2> F;
    F.col(0) = (x.segment<3>(3 * (4 * k)) - x.segment<3>(3 * (4 * k + 1))) / (2 * h);
    F.col(1) = (x.segment<3>(3 * (4 * k + 2)) - x.segment<3>(3 * (4 * k + 3))) / (2 * h);
    const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
    samples[k] = Eigen::Vector3d(std::abs(d1.dot(E * d1)), std::abs(d2.dot(E * d2)), std::abs(d1.dot(E * d2)));
  }
  return samples;
}

void TensileExperiment::set_sensitivity_parameters(const std::vector<int>& flat_indices) {
  const int flat = discretization_->parameters().flat_size();
  for (int p : flat_indices)
    if (p < 0 || p >= flat)
      throw std::invalid_argument("tensile sensitivity: parameter index " + std::to_string(p) +
                                  " outside [0, " + std::to_string(flat) + ")");
  sensitivity_parameters_ = flat_indices;
}

TensilePoint TensileExperiment::measure(const EquilibriumSolver& solver, double extension_mm,
                                        const Eigen::VectorXd& q, const EquilibriumSummary& summary) const {
  TensilePoint p;
  p.extension_mm = extension_mm;
  p.force_N = force_from_gradient(solver.gradient());
  p.lateral_strain = lateral_strain(q);
  p.solve = summary;
  std::vector<std::pair<int, double>> clamp_x;
  clamp_x.reserve(moving_nodes_.size());
  for (int n : moving_nodes_) clamp_x.emplace_back(3 * n, 1.0);
  if (angle_plus_) add_angle_derivative(solver, q, clamp_x, &p);
  if (!sensitivity_parameters_.empty()) {
    const EquilibriumSensitivity sens(solver, q, sensitivity_parameters_);
    p.dforce_dk = sens.reaction_derivative(clamp_x);
    p.dlateral_strain_dk = sens.observable_derivative(lateral_strain_gradient(q));
    if (keep_states_) p.dq_dk = sens.position_derivatives();
  }
  if (keep_states_) p.q = q;
  return p;
}

TensileCurve TensileExperiment::run(const std::vector<double>& extensions_mm,
                                    const EquilibriumObserver& observer) {
  const auto start = std::chrono::steady_clock::now();
  const Eigen::VectorXd& rest = discretization_->rest_positions();
  const double length_m = 1e-3 * setup_.gauge_length_mm;
  TensileCurve curve;

  // First guess: the affine stretch for the first extension (exact without clamps).
  Eigen::VectorXd q = rest;
  if (!extensions_mm.empty()) {
    const double stretch = 1e-3 * extensions_mm.front() / length_m;
    for (int n = 0; n < discretization_->num_nodes(); ++n) q[3 * n] = rest[3 * n] * (1.0 + stretch);
  }
  auto apply_step = [&](int step, Eigen::VectorXd* x) {
    const double u = 1e-3 * extensions_mm[static_cast<size_t>(step)];
    for (int n : moving_nodes_) (*x)[3 * n] = rest[3 * n] + u;
  };
  // Along the schedule the factor stays needed: the tangent predictor (docs/solver.md) is
  // exact only with the solution's factor; with the previous iterate's the equilibria move
  // within the solver's tolerance, and the misalignment fit's near-axis offsets (second order
  // in θ) feel that (test MisalignmentOffsetsOfTheFitRunsWithSpecimenScales: worst warp
  // offset error 0.017° → 0.163°). Warm-started points (run_from) are independent solves.
  solver_.set_solution_factor_needed(true);
  auto on_step = [&](int step, const Eigen::VectorXd& x, const EquilibriumSummary& summary) {
    curve.points.push_back(measure(solver_, extensions_mm[static_cast<size_t>(step)], x, summary));
    if (observer) observer(step, x, solver_);
  };
  const ContinuationSummary summary = solver_.solve_continuation(
      static_cast<int>(extensions_mm.size()), apply_step, &q, on_step);
  curve.completed = summary.completed;
  curve.message = summary.message;
  curve.newton_iterations = summary.total_newton_iterations;
  curve.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return curve;
}

EquilibriumSolver& TensileExperiment::use_solution_factor(EquilibriumSolver& solver) const {
  // measure() needs the factor at the solution only for derivatives (Eq. 6, dF/dθ); a point
  // retried from its predecessor (run_from) uses solver_ too and is set here again.
  solver.set_solution_factor_needed(angle_plus_ != nullptr || !sensitivity_parameters_.empty());
  return solver;
}

EquilibriumSolver& TensileExperiment::chunk_solver(size_t chunk) {
  if (chunk == 0) return solver_;
  while (chunk_solvers_.size() < chunk)
    chunk_solvers_.push_back(std::make_unique<EquilibriumSolver>(*discretization_, fixed_dofs_, solver_.options()));
  return *chunk_solvers_[chunk - 1];
}

TensileCurve TensileExperiment::run_from(const std::vector<double>& extensions_mm,
                                         const std::vector<Eigen::VectorXd>& initial_guesses) {
  if (initial_guesses.size() != extensions_mm.size())
    throw std::invalid_argument("run_from: " + std::to_string(initial_guesses.size()) +
                                " initial guesses for " + std::to_string(extensions_mm.size()) +
                                " extensions");
  const Eigen::VectorXd& rest = discretization_->rest_positions();
  for (size_t i = 0; i < initial_guesses.size(); ++i)
    if (initial_guesses[i].size() != rest.size())
      throw std::invalid_argument("run_from: initial guess " + std::to_string(i) + " has " +
                                  std::to_string(initial_guesses[i].size()) + " entries, expected " +
                                  std::to_string(rest.size()));
  const auto start = std::chrono::steady_clock::now();
  const size_t n = extensions_mm.size();
  auto with_schedule = [&](size_t i, Eigen::VectorXd x) {
    for (int dof : fixed_dofs_) x[dof] = rest[dof];  // held dofs at rest, then the moving clamp
    for (int node : moving_nodes_) x[3 * node] = rest[3 * node] + 1e-3 * extensions_mm[i];
    return x;
  };
  struct Solved {
    Eigen::VectorXd q;
    EquilibriumSummary summary;  ///< of the last attempt
    int newton_iterations = 0;   ///< over all attempts
    std::optional<TensilePoint> point;  ///< measured when converged
  };
  std::vector<Solved> solved(n);
  // One point from its own guess with the chunk's solver, measured while its factor is valid.
  auto solve_point = [&](EquilibriumSolver& solver, size_t i, const Eigen::VectorXd& guess) {
    Solved& s = solved[i];
    s.q = with_schedule(i, guess);
    s.summary = solver.solve(&s.q);
    s.newton_iterations += s.summary.newton_iterations;  // a retry adds to the first attempt
    if (s.summary.converged) s.point = measure(solver, extensions_mm[i], s.q, s.summary);
  };
  const size_t chunks = std::min(n, static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency())));
  for (size_t c = 0; c < chunks; ++c) use_solution_factor(chunk_solver(c));  // created here, not inside the tasks
  tbb::parallel_for(size_t{0}, chunks, [&](size_t c) {
    for (size_t i = c * n / chunks; i < (c + 1) * n / chunks; ++i) solve_point(chunk_solver(c), i, initial_guesses[i]);
  });
  // In schedule order: a point whose guess failed is retried from the previous equilibrium
  // (the predictor was off, e.g. a large optimiser step); the curve ends at the first failure.
  TensileCurve curve;
  curve.completed = true;
  for (size_t i = 0; i < n; ++i) {
    if (!solved[i].point && i > 0) solve_point(use_solution_factor(solver_), i, solved[i - 1].q);
    curve.newton_iterations += solved[i].newton_iterations;
    if (!solved[i].point) {
      curve.completed = false;
      curve.message = "extension " + std::to_string(extensions_mm[i]) + " mm: " + solved[i].summary.message;
      break;
    }
    curve.points.push_back(std::move(*solved[i].point));
  }
  curve.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return curve;
}

}  // namespace twill
