#include "experiments/predictors.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/discretization.hpp"

namespace twill {

// Default of Experiment: no set-up sensitivities.
bool Experiment::predict_setup_derivatives(const MaterialParameters&, const std::vector<std::string>& quantities,
                                           Eigen::VectorXd*, Eigen::MatrixXd*, std::string*) {
  throw std::invalid_argument(label() + ": no derivative in the set-up quantity '" +
                              (quantities.empty() ? std::string() : quantities.front()) + "'");
}

namespace {

// The measured values must match the schedule, which is not empty; or be absent (simulation
// only: an empty schedule is then allowed, e.g. for the bend experiment's overhang search).
void check_measured(const std::string& label, size_t schedule, const Eigen::VectorXd& measured,
                    const char* what) {
  if (measured.size() != 0 && static_cast<Eigen::Index>(schedule) != measured.size())
    throw std::invalid_argument(label + ": " + std::to_string(schedule) + " " + what + " but " +
                                std::to_string(measured.size()) + " measured values");
  if (schedule == 0 && measured.size() != 0) throw std::invalid_argument(label + ": no " + std::string(what));
}

}  // namespace

TensilePredictor::TensilePredictor(std::string label, const TensileSetup& setup,
                                   const DiscretizationFactory& factory,
                                   const MaterialParameters& start,
                                   std::vector<double> extensions_mm,
                                   const Eigen::VectorXd& forces_N,
                                   const EquilibriumOptions& solver)
    : label_(std::move(label)),
      experiment_(setup, factory, start, solver),
      extensions_mm_(std::move(extensions_mm)),
      measured_(forces_N) {
  check_measured(label_, extensions_mm_.size(), measured_, "extensions");
}

void TensilePredictor::use_angle_sensitivity(bool on) {
  if (on == angle_sensitivity_on_) return;  // the turned meshes are built once, kept while on
  experiment_.set_angle_sensitivity(on);
  angle_sensitivity_on_ = on;
}

namespace {

// A warm start converges to the equilibrium nearest its guess, which far from the anchor need
// not be the one the loading path from the flat strip reaches: measured on a hysteresis fit
// from a baseline (15 bias/warp/weft runs, 8x12), Levenberg–Marquardt reached ε 6.1 from 469,
// then every trial near that point, and the point itself re-evaluated, came out near 1.3e4 —
// warm-started from an anchor a rejected trial had left on another branch. A value must not
// depend on the path the optimiser took to it, so a warm result that leaves the anchor's
// first-order prediction by more than this share of the run's largest |value| is solved again
// from the flat strip, and that solution kept. 5 %: well above what the first-order guess
// misses by over an accepted step (its error is second order in the step), far below a switch
// of branch (a factor there).
constexpr double kBranchTolerance = 0.05;

void read_curve(const TensileCurve& curve, bool force, Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                size_t columns) {
  const auto m = static_cast<Eigen::Index>(curve.points.size());
  values->resize(m);
  if (jacobian) jacobian->resize(m, static_cast<Eigen::Index>(columns));
  for (Eigen::Index i = 0; i < m; ++i) {
    const TensilePoint& p = curve.points[static_cast<size_t>(i)];
    (*values)[i] = force ? p.force_N : p.lateral_strain;
    if (jacobian) jacobian->row(i) = (force ? p.dforce_dk : p.dlateral_strain_dk).transpose();
  }
}

// The anchor's state moved to first order, q + ∂q/∂k Δk. With no free parameters (an
// effect-only stage: the curves held, the effect's parameters outside k's flat vector) the
// anchor kept no ∂q/∂k (0×0), and the guess is the anchor's state itself; the shapes are
// checked, not assumed — a 0-row product added to q reads past its end in a Release build.
Eigen::VectorXd first_order_guess(const Eigen::VectorXd& q, const Eigen::MatrixXd& dq_dk, const Eigen::VectorXd& dk) {
  if (dk.size() == 0 || dq_dk.rows() != q.size() || dq_dk.cols() != dk.size()) return q;
  return q + dq_dk * dk;
}

}  // namespace

// The curve at k: from the anchor's states moved to first order when there is an anchor (then
// checked: a failed or off-branch warm start is solved again from the flat strip), else along
// the loading schedule from the flat strip. Counts the failed attempts' solves.
TensileCurve TensilePredictor::solve_curve(const MaterialParameters& k, const Eigen::VectorXd& k_flat, bool force) {
  TensileCurve curve;
  const bool anchored = warm_start_ && anchor_q_.size() == extensions_mm_.size() &&
                        anchor_k_.size() == k_flat.size();
  Eigen::VectorXd dk;
  // Law entries outside the anchor's columns moved (none in a fit: the free set is fixed per stage).
  // Then Δk over the columns is no path the anchor's ∂q/∂k knows: after the bend stage's
  // thickness rescaling τ and every membrane stiffness change together (G12 by 29 % on
  // canvas) while the planar strip's membrane τ·k does not, so q + ∂q/∂G12 ΔG12 is far off and
  // the branch test, which extrapolates by the columns, sent the final bias curve back to a
  // continuation (13.6 s instead of a warm re-evaluation). The guess is then the anchor's state
  // itself and the branch test is skipped: a changed strip still converges from it, only
  // slower.
  // Only the law's entries count: the effects' block (the flat vector's last entries) never
  // reaches this strip (effects/effect_experiment.cpp), and an effect fit moves it at every
  // trial — counted, every such trial skipped the guess and the branch test (a rate fit ran on a
  // bias strip's other branch: docs/fitting.md §5, "Entries outside the anchor's columns").
  const bool outside_moved = anchored && moved_outside_columns(k_flat, FlatLayout(k).effects);
  if (anchored && !outside_moved) {
    // First-order predictor q_i + ∂q_i/∂k Δk over the anchor's columns.
    dk.resize(static_cast<Eigen::Index>(anchor_flat_.size()));
    for (size_t j = 0; j < anchor_flat_.size(); ++j)
      dk[static_cast<Eigen::Index>(j)] = k_flat[anchor_flat_[j]] - anchor_k_[anchor_flat_[j]];
  }
  if (anchored) {
    std::vector<Eigen::VectorXd> guesses(anchor_q_.size());
    for (size_t i = 0; i < anchor_q_.size(); ++i) guesses[i] = first_order_guess(anchor_q_[i], anchor_dq_[i], dk);
    curve = experiment_.run_from(extensions_mm_, guesses);
    if (!curve.completed) {
      // The warm start is only an acceleration: a first-order guess from a distant anchor (an
      // optimiser's rejected trial, or NLopt's restart at its best point after one) can leave
      // the basin. Whether a point is evaluable must not depend on the path to it, so retry
      // along the loading schedule from the flat strip.
      for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
      curve = experiment_.run(extensions_mm_);
    } else if (!outside_moved && left_the_anchors_branch(curve, force, dk)) {
      for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
      ++branch_retries_;
      curve = experiment_.run(extensions_mm_);
    }
  } else {
    curve = experiment_.run(extensions_mm_);
  }
  return curve;
}

// The evaluation just made becomes the anchor of the next warm start: k, the free columns, the
// values and Jacobian, and each point's state with its ∂q/∂k (moved out of `curve`).
void TensilePredictor::keep_anchor(const Eigen::VectorXd& k_flat, const std::vector<int>& flat,
                                   const Eigen::VectorXd& values, const Eigen::MatrixXd& jacobian, TensileCurve* curve) {
  anchor_k_ = k_flat;
  anchor_flat_ = flat;
  anchor_values_ = values;
  anchor_jacobian_ = jacobian;
  anchor_q_.resize(curve->points.size());
  anchor_dq_.resize(curve->points.size());
  for (size_t i = 0; i < curve->points.size(); ++i) {
    anchor_q_[i] = std::move(curve->points[i].q);
    anchor_dq_[i] = std::move(curve->points[i].dq_dk);
  }
}

bool TensilePredictor::predict(const MaterialParameters& k, const std::vector<int>& flat,
                               Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                               std::string* message) {
  use_angle_sensitivity(false);
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters(jacobian ? flat : std::vector<int>{});
  experiment_.set_keep_states(jacobian != nullptr && warm_start_);

  const Eigen::VectorXd k_flat = k.to_flat();
  const bool force = observable_ == StripObservable::Force;
  TensileCurve curve = solve_curve(k, k_flat, force);
  for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
  if (!curve.completed) {
    if (message) *message = curve.message;
    return false;
  }
  read_curve(curve, force, values, jacobian, flat.size());
  if (jacobian && warm_start_) keep_anchor(k_flat, flat, *values, *jacobian, &curve);
  last_curve_ = std::move(curve);
  return true;
}

bool TensilePredictor::moved_outside_columns(const Eigen::VectorXd& k_flat, int law_size) const {
  for (Eigen::Index i = 0; i < std::min<Eigen::Index>(law_size, k_flat.size()); ++i)
    if (k_flat[i] != anchor_k_[i] && std::find(anchor_flat_.begin(), anchor_flat_.end(), i) == anchor_flat_.end())
      return true;
  return false;
}

bool TensilePredictor::left_the_anchors_branch(const TensileCurve& warm, bool force, const Eigen::VectorXd& dk) const {
  if (anchor_values_.size() != static_cast<Eigen::Index>(warm.points.size()) || anchor_jacobian_.cols() != dk.size())
    return false;
  Eigen::VectorXd got;
  read_curve(warm, force, &got, nullptr, 0);
  const Eigen::VectorXd expected = anchor_values_ + anchor_jacobian_ * dk;
  const double scale = std::max(expected.cwiseAbs().maxCoeff(), got.cwiseAbs().maxCoeff());
  return scale > 0 && (got - expected).cwiseAbs().maxCoeff() > kBranchTolerance * scale;
}

ExperimentRun TensilePredictor::simulate(const MaterialParameters& k) {
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters({});
  experiment_.set_keep_states(false);
  use_angle_sensitivity(report_angle_derivative_);
  const TensileCurve curve = experiment_.run(
      extensions_mm_, [this](int, const Eigen::VectorXd& q, const EquilibriumSolver&) { last_q_ = q; });
  for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
  ExperimentRun run;
  run.completed = curve.completed;
  run.message = curve.message;
  run.newton_iterations = curve.newton_iterations;
  run.wall_time_s = curve.wall_time_s;
  run.values.resize(static_cast<Eigen::Index>(curve.points.size()));
  const bool force = observable_ == StripObservable::Force;
  std::vector<double> other, dforce_dangle;
  for (size_t i = 0; i < curve.points.size(); ++i) {
    const TensilePoint& p = curve.points[i];
    run.schedule.push_back(p.extension_mm);
    run.values[static_cast<Eigen::Index>(i)] = force ? p.force_N : p.lateral_strain;
    other.push_back(force ? p.lateral_strain : p.force_N);
    dforce_dangle.push_back(p.dforce_dangle);
  }
  run.extras.emplace_back(force ? "lateral_strain" : "force_N", std::move(other));
  if (report_angle_derivative_) run.extras.emplace_back(kAngleDerivativeColumn, std::move(dforce_dangle));
  return run;
}

bool TensilePredictor::predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                                 Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                                 std::string* message) {
  for (const std::string& q : quantities)
    if (q != setup_quantity::kAngle) return Experiment::predict_setup_derivatives(k, {q}, values, jacobian, message);
  const bool was = report_angle_derivative_;
  report_angle_derivative_ = true;
  const ExperimentRun run = simulate(k);
  report_angle_derivative_ = was;
  if (!run.completed) {
    if (message) *message = run.message;
    return false;
  }
  *values = run.values;
  const auto d_extra = std::find_if(run.extras.begin(), run.extras.end(),
                                    [](const auto& e) { return e.first == kAngleDerivativeColumn; });
  const std::vector<double>& d = d_extra->second;
  jacobian->resize(run.values.size(), static_cast<Eigen::Index>(quantities.size()));
  for (Eigen::Index c = 0; c < jacobian->cols(); ++c)
    jacobian->col(c) = Eigen::Map<const Eigen::VectorXd>(d.data(), static_cast<Eigen::Index>(d.size()));
  return true;
}

bool TensilePredictor::last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const {
  if (last_q_.size() == 0) return false;
  experiment_.discretization().surface_mesh(last_q_, V, F);
  return true;
}

CantileverPredictor::CantileverPredictor(std::string label, const CantileverSetup& setup,
                                         const DiscretizationFactory& factory,
                                         const MaterialParameters& start, double overhang_mm,
                                         double measured_angle_deg,
                                         const EquilibriumOptions& solver)
    : CantileverPredictor(std::move(label), setup, factory, start, std::vector<double>{overhang_mm},
                          Eigen::VectorXd::Constant(1, measured_angle_deg), solver) {}

CantileverPredictor::CantileverPredictor(std::string label, const CantileverSetup& setup,
                                         const DiscretizationFactory& factory,
                                         const MaterialParameters& start,
                                         std::vector<double> overhangs_mm,
                                         const Eigen::VectorXd& measured_angles_deg,
                                         const EquilibriumOptions& solver)
    : label_(std::move(label)),
      experiment_(setup, factory, start, solver),
      overhangs_mm_(std::move(overhangs_mm)),
      measured_(measured_angles_deg) {
  check_measured(label_, overhangs_mm_.size(), measured_, "overhangs");
  for (double overhang : overhangs_mm_)
    if (!(overhang > 0)) throw std::invalid_argument(label_ + ": overhang must be > 0 mm");
}

bool CantileverPredictor::predict(const MaterialParameters& k, const std::vector<int>& flat,
                                  Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                  std::string* message) {
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters(jacobian ? flat : std::vector<int>{});
  const auto m = static_cast<Eigen::Index>(overhangs_mm_.size());
  values->resize(m);
  if (jacobian) jacobian->resize(m, static_cast<Eigen::Index>(flat.size()));
  for (Eigen::Index i = 0; i < m; ++i) {
    const CantileverResult r = experiment_.solve(overhangs_mm_[static_cast<size_t>(i)]);
    ++solves_;
    if (!r.converged) {
      if (message) *message = r.message;
      experiment_.reset_warm_start();
      return false;
    }
    (*values)[i] = r.chord_angle_deg;
    if (jacobian) jacobian->row(i) = r.dchord_angle_dk.transpose();
  }
  return true;
}

ExperimentRun CantileverPredictor::simulate(const MaterialParameters& k) {
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters({});
  ExperimentRun run;
  std::vector<double> values, tip;
  for (double overhang : overhangs_mm_) {
    const CantileverResult r = experiment_.solve(overhang);
    ++solves_;
    run.newton_iterations += r.newton_iterations;
    run.wall_time_s += r.wall_time_s;
    if (!r.converged) {
      run.message = r.message;
      experiment_.reset_warm_start();
      break;
    }
    run.schedule.push_back(overhang);
    values.push_back(r.chord_angle_deg);
    tip.push_back(r.tip_deflection_mm);
  }
  run.completed = run.schedule.size() == overhangs_mm_.size();
  run.values = Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
  run.extras.emplace_back("tip_deflection_mm", std::move(tip));
  return run;
}

bool CantileverPredictor::last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const {
  if (!experiment_.last_discretization()) return false;
  experiment_.last_discretization()->surface_mesh(experiment_.last_positions(), V, F);
  return true;
}

}  // namespace twill
