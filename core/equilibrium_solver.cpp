#include "core/equilibrium_solver.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <stdexcept>
#include <utility>

namespace twill {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double max_abs(const Eigen::VectorXd& v) {
  return v.size() > 0 ? v.lpNorm<Eigen::Infinity>() : 0.0;
}

// Diagonal of the rest positions' bounding box; 1 m when the rest state is a single point
// (the decrement test then compares λ² with F × 1 m).
double bounding_box_diagonal(const Eigen::VectorXd& rest) {
  const Eigen::Index nodes = rest.size() / 3;
  if (nodes == 0) return 1.0;
  const auto points = Eigen::Map<const Eigen::Matrix3Xd>(rest.data(), 3, nodes);
  const double diagonal = (points.rowwise().maxCoeff() - points.rowwise().minCoeff()).norm();
  return diagonal > 0 && std::isfinite(diagonal) ? diagonal : 1.0;
}

}  // namespace

bool EquilibriumOptions::validate(std::string* error) const {
  std::string message;
  const auto check = [&](bool ok, const char* field, const char* constraint, auto value) {
    if (!ok && message.empty())
      message = fmt::format("{} must be {} (got {})", field, constraint, value);
  };
  // Written as !(x > 0) etc. where a NaN must fail too.
  check(gradient_tolerance > 0, "gradient_tolerance", "> 0", gradient_tolerance);
  check(force_floor_N > 0, "force_floor_N", "> 0", force_floor_N);
  check(decrement_tolerance > 0, "decrement_tolerance", "> 0", decrement_tolerance);
  check(length_scale_m >= 0, "length_scale_m", ">= 0 (0 = automatic)", length_scale_m);
  check(max_newton_iterations >= 1, "max_newton_iterations", ">= 1", max_newton_iterations);
  check(armijo_c1 > 0 && armijo_c1 < 0.5, "armijo_c1", "in (0, 0.5)", armijo_c1);
  check(backtrack_factor > 0 && backtrack_factor < 1, "backtrack_factor", "in (0, 1)",
        backtrack_factor);
  check(max_backtracks >= 1, "max_backtracks", ">= 1", max_backtracks);
  check(energy_roundoff >= 0, "energy_roundoff", ">= 0", energy_roundoff);
  check(stall_window >= 1, "stall_window", ">= 1", stall_window);
  check(stall_energy_fraction >= 0, "stall_energy_fraction", ">= 0", stall_energy_fraction);
  check(stall_gradient_fraction >= 0 && stall_gradient_fraction <= 1, "stall_gradient_fraction",
        "in [0, 1]", stall_gradient_fraction);
  check(backward_euler_steps >= 1, "backward_euler_steps", ">= 1", backward_euler_steps);
  check(max_fallbacks >= 0, "max_fallbacks", ">= 0", max_fallbacks);
  check(initial_time_step_s >= 0 && std::isfinite(initial_time_step_s), "initial_time_step_s",
        "finite and >= 0 (0 = automatic)", initial_time_step_s);
  check(time_step_growth > 1 && std::isfinite(time_step_growth), "time_step_growth",
        "finite and > 1", time_step_growth);
  check(max_time_step_reductions >= 1, "max_time_step_reductions", ">= 1",
        max_time_step_reductions);
  check(max_saddle_escapes >= 0, "max_saddle_escapes", ">= 0", max_saddle_escapes);
  if (message.empty()) {
    std::string inner;
    if (!linear_solver.validate(&inner)) message = "linear_solver." + inner;
  }
  if (error) *error = message;
  return message.empty();
}

const char* to_string(EquilibriumStatus status) {
  switch (status) {
    case EquilibriumStatus::kConverged:
      return "converged";
    case EquilibriumStatus::kMaxIterations:
      return "max_iterations";
    case EquilibriumStatus::kFallbackLimit:
      return "fallback_limit";
    case EquilibriumStatus::kFallbackFailed:
      return "fallback_failed";
    case EquilibriumStatus::kIndefiniteStationary:
      return "indefinite_stationary";
    case EquilibriumStatus::kNonFinite:
      return "non_finite";
  }
  return "unknown";
}

namespace {
SparseCholeskyOptions checked_linear_solver_options(const EquilibriumOptions& options) {
  std::string error;
  if (!options.validate(&error)) throw std::invalid_argument("EquilibriumOptions: " + error);
  return options.linear_solver;
}
}  // namespace

EquilibriumSolver::EquilibriumSolver(const Discretization& discretization,
                                     std::vector<int> fixed_dofs, const EquilibriumOptions& options)
    : discretization_(discretization),
      options_(options),
      dofs_(discretization.num_dofs(), std::move(fixed_dofs)),
      cholesky_(checked_linear_solver_options(options)) {
  length_scale_m_ = options_.length_scale_m > 0
                        ? options_.length_scale_m
                        : bounding_box_diagonal(discretization_.rest_positions());
}

double EquilibriumSolver::evaluate(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                                   SparseMatrix* hessian, EquilibriumSummary* summary) const {
  ++summary->energy_evaluations;
  const double psi = discretization_.energy(q, gradient, hessian);
  if (hessian && !hessian->isCompressed()) hessian->makeCompressed();
  return psi;
}

void EquilibriumSolver::prepare_patterns() {
  if (patterns_ready_ && dofs_.same_pattern(hessian_)) return;
  dofs_.analyze(hessian_);
  dofs_.extract_free_free(hessian_, &k_ff_);
  dofs_.extract_free_fixed(hessian_, &k_fc_);
  k_shifted_ = k_ff_;
  cholesky_.analyze(k_ff_);
  patterns_ready_ = true;
  spdlog::debug(
      "EquilibriumSolver: {} dofs ({} free), nnz(K_ff) = {}, nnz(L) = {:.0f}, "
      "ordering {}, BLAS {}",
      dofs_.num_dofs(), dofs_.num_free(), k_ff_.nonZeros(), cholesky_.factor_nonzeros(),
      cholesky_.selected_ordering(), SparseCholesky::blas_library());
}

double EquilibriumSolver::force_scale() const {
  return std::max(max_abs(g_c_), options_.force_floor_N);
}

double EquilibriumSolver::automatic_time_step() const {
  const std::vector<int>& diagonal = dofs_.free_free_diagonal();
  std::vector<double> ratios;
  ratios.reserve(diagonal.size());
  double largest_stiffness = 0;
  for (size_t i = 0; i < diagonal.size(); ++i) {
    const double k_ii = k_ff_.valuePtr()[diagonal[i]];
    largest_stiffness = std::max(largest_stiffness, std::fabs(k_ii));
    if (k_ii > 0) ratios.push_back(mass_f_[static_cast<Eigen::Index>(i)] / k_ii);
  }
  if (!ratios.empty()) {
    const auto middle = ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2);
    std::nth_element(ratios.begin(), middle, ratios.end());
    return std::sqrt(*middle);
  }
  // No positive diagonal stiffness: make M/h² match the largest |K_ii| instead.
  if (largest_stiffness > 0 && mass_f_.size() > 0) {
    return std::sqrt(mass_f_.mean() / largest_stiffness);
  }
  return 1.0;
}

EquilibriumSolver::SearchResult EquilibriumSolver::line_search(
    Eigen::VectorXd* q, double* psi, double slope, double quadratic, RoundoffRule rule,
    bool trial_hessian, double* alpha, EquilibriumSummary* summary) {
  const double psi0 = *psi;
  const double gradient_norm0 = max_abs(g_f_);
  const double roundoff = options_.energy_roundoff * std::fabs(psi0);
  double step = 1.0;
  for (int attempt = 0; attempt <= options_.max_backtracks; ++attempt) {
    q_trial_ = *q;
    dofs_.add_to_free(step, direction_, &q_trial_);
    // The full step is evaluated with gradient and Hessian: Newton accepts it most of the
    // time, and then the next iteration needs both. Shorter steps are tried on Ψ alone.
    const bool full = attempt == 0;
    const double psi_trial = full ? evaluate(q_trial_, &trial_gradient_, trial_hessian ? &hessian_ : nullptr, summary)
                                  : evaluate(q_trial_, nullptr, nullptr, summary);
    if (full && trial_hessian) hessian_at_q_ = false;
    const double phi_trial = psi_trial + quadratic * step * step;
    bool accept = std::isfinite(phi_trial) && phi_trial <= psi0 + options_.armijo_c1 * step * slope;
    if (full && accept && !trial_gradient_.allFinite()) accept = false;
    if (!accept && full && rule != RoundoffRule::kArmijoOnly && std::isfinite(psi_trial) &&
        psi_trial - psi0 <= roundoff && trial_gradient_.allFinite()) {
      // Ψ cannot resolve the change any more; judge the step by the gradient instead.
      double trial_norm = 0;
      for (int dof : dofs_.free_dofs())
        trial_norm = std::max(trial_norm, std::fabs(trial_gradient_[dof]));
      accept = trial_norm < gradient_norm0;
      // Neither Ψ nor ‖g_f‖ improves and ‖g_f‖ already passes: nothing left to gain.
      if (!accept && rule == RoundoffRule::kByGradientOrFloor) return SearchResult::kRoundoffFloor;
    }
    if (!accept && !full && q_trial_ == *q) {
      // The step no longer changes q in double precision: shorter ones cannot either.
      ++summary->line_search_backtracks;
      return SearchResult::kFailed;
    }
    if (accept) {
      *q = q_trial_;
      *psi = psi_trial;
      if (full) {
        gradient_.swap(trial_gradient_);
        hessian_at_q_ = trial_hessian;
      } else {
        evaluate(*q, &gradient_, &hessian_, summary);
        hessian_at_q_ = true;
      }
      *alpha = step;
      return SearchResult::kAccepted;
    }
    ++summary->line_search_backtracks;
    step *= options_.backtrack_factor;
  }
  return SearchResult::kFailed;
}

bool EquilibriumSolver::backward_euler(Eigen::VectorXd* q, double* psi, double* time_step_s,
                                       EquilibriumSummary* summary) {
  if (!hessian_at_q_) {
    *psi = evaluate(*q, &gradient_, &hessian_, summary);
    hessian_at_q_ = true;
  }
  for (int step = 0; step < options_.backward_euler_steps; ++step) {
    dofs_.gather_free(gradient_, &g_f_);
    dofs_.extract_free_free(hessian_, &k_ff_);
    if (*time_step_s <= 0) *time_step_s = automatic_time_step();
    if (max_abs(g_f_) == 0) {
      summary->message = "backward Euler: the gradient is zero, no motion from rest";
      return false;
    }
    bool stepped = false;
    for (int reduction = 0; reduction <= options_.max_time_step_reductions; ++reduction) {
      if (reduction > 0) *time_step_s *= 0.5;
      const double inverse_h2 = 1.0 / (*time_step_s * *time_step_s);
      if (!factorise_shifted(inverse_h2, summary)) continue;
      cholesky_.solve(g_f_, &direction_);
      direction_ = -direction_;
      const double slope = g_f_.dot(direction_);
      if (!(slope < 0) || !std::isfinite(slope)) continue;
      const double quadratic =
          0.5 * inverse_h2 * (mass_f_.array() * direction_.array().square()).sum();
      double alpha = 0;
      if (line_search(q, psi, slope, quadratic, RoundoffRule::kArmijoOnly, true, &alpha, summary) ==
          SearchResult::kAccepted) {
        ++summary->backward_euler_steps;
        stepped = true;
        *time_step_s = alpha == 1.0 ? *time_step_s * options_.time_step_growth
                                    : *time_step_s / options_.time_step_growth;
        break;
      }
      // k_ff_ still holds K_ff at q (the failed search only overwrote hessian_): retry with
      // a smaller h, which shortens the step towards a gradient step.
    }
    if (!stepped) {
      summary->message = fmt::format(
          "backward Euler: no acceptable step after {} time-step halvings (h = {:.3e} s)",
          options_.max_time_step_reductions, *time_step_s);
      return false;
    }
    spdlog::debug("EquilibriumSolver: backward-Euler step {}: Ψ = {:.12e} J, next h = {:.3e} s",
                  step + 1, *psi, *time_step_s);
  }
  summary->time_step_s = *time_step_s;
  return true;
}

bool EquilibriumSolver::factorise_shifted(double sigma, EquilibriumSummary* summary) {
  const std::vector<int>& diagonal = dofs_.free_free_diagonal();
  std::copy(k_ff_.valuePtr(), k_ff_.valuePtr() + k_ff_.nonZeros(), k_shifted_.valuePtr());
  for (size_t i = 0; i < diagonal.size(); ++i)
    k_shifted_.valuePtr()[diagonal[i]] += mass_f_[static_cast<Eigen::Index>(i)] * sigma;
  ++summary->factorizations;
  if (cholesky_.factorize(k_shifted_)) return true;
  ++summary->failed_factorizations;
  return false;
}

namespace {
// The saddle escape's constants (header comment, "Saddles").
// σ starts at this fraction of the largest Σ_j |K_ij| / m_i (far below any mode that matters)
// and is doubled until K_ff + σ M_f factorises, at most up to twice that bound (Gershgorin on
// M_f⁻¹K_ff, whose eigenvalues are the λ: every λ ≥ −max_i Σ_j |K_ij| / m_i, so beyond it the
// shifted matrix is positive definite and a failure there means something else is wrong).
constexpr double kShiftStartFraction = 1e-12;
// Bisections of σ between the last failure and the first success: σ within 2⁻⁸ of the
// bracket above −λ_min, so inverse iteration's ratio (λ₁ + σ)/(λ₂ + σ) is small.
constexpr int kShiftBisections = 8;
// Inverse iterations at most, and the change of λ relative to |λ| that ends them.
constexpr int kInverseIterations = 60;
constexpr double kModeTolerance = 1e-8;
// The first step's largest entry as a fraction of L; halved down to the shortest while Ψ does not
// fall (friction hidden at 20 %, seed 4: the warp strip's Ψ along its mode turned up beyond 5 µm
// of 90 mm), doubled up to L while it keeps falling.
constexpr double kEscapeFirstStep = 1e-4, kEscapeShortestStep = 1e-10;
constexpr unsigned kModeStartSeed = 20261207;  // any fixed seed: a reproducible start vector
}  // namespace

bool EquilibriumSolver::factorise_shifted_above_lowest_mode(EquilibriumSummary* s) {
  const std::vector<int>& diagonal = dofs_.free_free_diagonal();
  double stiffest = 0;
  for (size_t i = 0; i < diagonal.size(); ++i) {
    const Eigen::Index row = static_cast<Eigen::Index>(i);
    double absolute_row = 0;  // Σ_j |K_ij| (K_ff symmetric: its column i)
    for (SparseMatrix::InnerIterator it(k_ff_, row); it; ++it) absolute_row += std::fabs(it.value());
    stiffest = std::max(stiffest, absolute_row / mass_f_[row]);
  }
  if (!(stiffest > 0) || !std::isfinite(stiffest)) return false;  // K_ff = 0: no mode to follow
  double failed = 0, works = kShiftStartFraction * stiffest;
  while (!factorise_shifted(works, s)) {
    failed = works;
    works *= 2;
    if (!(works <= 2 * stiffest)) return false;
  }
  for (int i = 0; i < kShiftBisections; ++i) {
    const double middle = 0.5 * (failed + works);
    (factorise_shifted(middle, s) ? works : failed) = middle;
  }
  return factorise_shifted(works, s);  // the bisection's last trial may have failed
}

double EquilibriumSolver::lowest_mode(Eigen::VectorXd* v) const {
  std::mt19937 random(kModeStartSeed);
  v->resize(mass_f_.size());
  for (Eigen::Index i = 0; i < v->size(); ++i) (*v)[i] = static_cast<double>(random()) / random.max() - 0.5;
  Eigen::VectorXd next;
  double lambda = 0;
  for (int it = 0; it < kInverseIterations; ++it) {
    const Eigen::VectorXd weighted = mass_f_.cwiseProduct(*v);
    cholesky_.solve(weighted, &next);
    *v = next / std::sqrt(next.dot(mass_f_.cwiseProduct(next)));
    const double previous = lambda;
    lambda = v->dot(k_ff_ * *v);
    if (it > 0 && std::fabs(lambda - previous) <= kModeTolerance * std::fabs(lambda)) break;
  }
  return lambda;
}

bool EquilibriumSolver::step_along_mode(const Eigen::VectorXd& v, Eigen::VectorXd* q, double* psi,
                                        EquilibriumSummary* s) {
  const double sign = g_f_.dot(v) <= 0 ? 1.0 : -1.0;
  const double largest = max_abs(v);
  auto psi_at = [&](double alpha) {
    q_trial_ = *q;
    dofs_.add_to_free(sign * alpha, v, &q_trial_);
    const double trial = evaluate(q_trial_, nullptr, nullptr, s);
    return std::isfinite(trial) ? trial : std::numeric_limits<double>::infinity();
  };
  // Shorter until Ψ falls (the higher-order terms can win within microns), then longer while it
  // keeps falling.
  double alpha = kEscapeFirstStep * length_scale_m_ / largest, best_psi = psi_at(alpha);
  while (!(best_psi < *psi) && alpha * largest > kEscapeShortestStep * length_scale_m_)
    best_psi = psi_at(alpha /= 2);
  double best_alpha = alpha;
  for (alpha *= 2; best_psi < *psi && alpha * largest <= length_scale_m_; alpha *= 2) {
    const double trial = psi_at(alpha);
    if (!(trial < best_psi)) break;
    best_psi = trial, best_alpha = alpha;
  }
  if (!(best_psi < *psi - options_.energy_roundoff * std::fabs(*psi))) return false;
  dofs_.add_to_free(sign * best_alpha, v, q);
  *psi = evaluate(*q, &gradient_, &hessian_, s);
  hessian_at_q_ = true;
  return true;
}

bool EquilibriumSolver::escape_saddle(Eigen::VectorXd* q, double* psi, EquilibriumSummary* s) {
  if (!factorise_shifted_above_lowest_mode(s)) return false;
  Eigen::VectorXd mode;
  const double lambda = lowest_mode(&mode);
  if (!(lambda < 0) || !step_along_mode(mode, q, psi, s)) return false;
  ++s->saddle_escapes;
  spdlog::debug("EquilibriumSolver: saddle escape #{} along a mode of λ = {:.3e} 1/s², Ψ = {:.12e} J",
                s->saddle_escapes, lambda, *psi);
  return true;
}

std::string EquilibriumSolver::converged_with_previous_factor(EquilibriumSummary* summary) {
  dofs_.gather_free(gradient_, &g_f_);
  dofs_.gather_fixed(gradient_, &g_c_);
  const double gradient_norm = max_abs(g_f_);
  const double force = force_scale();
  if (!(gradient_norm <= options_.gradient_tolerance * force)) return {};
  cholesky_.solve(g_f_, &direction_);  // K̃: factorised at the iterate the full step left
  const double decrement = g_f_.dot(direction_);
  if (!(decrement >= 0 && decrement <= options_.decrement_tolerance * force * length_scale_m_)) return {};
  summary->newton_decrement_J = decrement;
  summary->decrement_from_previous_factor = true;
  dofs_.extract_free_fixed(hessian_, &k_fc_);  // the previous iterate's, as the factor
  predictor_factor_ = true;
  return fmt::format("converged: |g_f|inf = {:.3e} N <= {:.1e} x {:.3e} N, lambda^2 = {:.3e} J (previous "
                     "iterate's factor)",
                     gradient_norm, options_.gradient_tolerance, force, decrement);
}

namespace {

// The last stall_window + 1 Newton iterates' Ψ and ‖g_f‖∞, for the stall and round-off-floor
// tests of solve(); cleared after a fallback.
class IterateWindow {
 public:
  explicit IterateWindow(size_t size) : size_(size) {
    energy_.reserve(size + 1);
    gradient_.reserve(size + 1);
  }
  void push(double psi, double gradient_norm) {
    energy_.push_back(psi);
    gradient_.push_back(gradient_norm);
    if (energy_.size() > size_) {
      energy_.erase(energy_.begin());
      gradient_.erase(gradient_.begin());
    }
  }
  void clear() {
    energy_.clear();
    gradient_.clear();
  }
  bool full() const { return energy_.size() == size_; }
  double first_energy() const { return energy_.front(); }
  double first_gradient() const { return gradient_.front(); }

 private:
  size_t size_;
  std::vector<double> energy_, gradient_;
};

// The iterates' stall (the window's steps lowered Ψ by too little while ‖g_f‖∞ did not fall
// enough): its reason, empty when there is none or the window is not full yet.
std::string stall_reason(const EquilibriumOptions& options, const IterateWindow& window, double gradient_norm,
                         double psi) {
  if (!window.full()) return {};
  const double decrease = window.first_energy() - psi;
  if (decrease <= options.stall_energy_fraction * std::fabs(window.first_energy()) &&
      gradient_norm > options.stall_gradient_fraction * window.first_gradient()) {
    return fmt::format("stall: {} Newton steps lowered the energy by {:.3e} J", options.stall_window, decrease);
  }
  return {};
}

}  // namespace

EquilibriumSummary EquilibriumSolver::finish(EquilibriumStatus status, std::string message, double psi,
                                             Clock::time_point start, EquilibriumSummary* s) {
  s->status = status;
  s->converged = status == EquilibriumStatus::kConverged;
  s->energy_J = psi;
  if (gradient_.size() == dofs_.num_dofs()) {
    dofs_.gather_free(gradient_, &g_f_);
    dofs_.gather_fixed(gradient_, &g_c_);
    s->gradient_norm_N = max_abs(g_f_);
    s->force_scale_N = force_scale();
  }
  s->message = std::move(message);
  s->wall_time_s = seconds_since(start);
  spdlog::debug(
      "EquilibriumSolver: {} after {} Newton iterations, {} fallbacks ({} BE steps), "
      "{} factorisations, {:.3f} s: {}",
      to_string(status), s->newton_iterations, s->fallbacks, s->backward_euler_steps,
      s->factorizations, s->wall_time_s, s->message);
  return *s;
}

void EquilibriumSolver::prepare_free_masses() {
  const Eigen::VectorXd mass = discretization_.lumped_mass();
  if (mass.size() != dofs_.num_dofs()) {
    throw std::invalid_argument(
        fmt::format("EquilibriumSolver: lumped_mass() has {} entries, "
                    "expected {}",
                    mass.size(), dofs_.num_dofs()));
  }
  dofs_.gather_free(mass, &mass_f_);
  // Backward Euler needs M_f > 0 on every free dof: a massless dof borrows the mean mass,
  // and a massless model uses unit masses (h is then only a shift scale).
  const double positive_sum = (mass_f_.array() > 0).select(mass_f_, 0.0).sum();
  const auto positive_count = (mass_f_.array() > 0).count();
  const double fill =
      positive_count > 0 ? positive_sum / static_cast<double>(positive_count) : 1.0;
  for (Eigen::Index i = 0; i < mass_f_.size(); ++i) {
    if (!(mass_f_[i] > 0)) mass_f_[i] = fill;
  }
}

EquilibriumSolver::NewtonIterate EquilibriumSolver::newton_direction(double psi, EquilibriumSummary* s) {
  NewtonIterate it;
  dofs_.gather_free(gradient_, &g_f_);
  dofs_.gather_fixed(gradient_, &g_c_);
  it.gradient_norm = max_abs(g_f_);
  it.force = force_scale();
  it.small_gradient = it.gradient_norm <= options_.gradient_tolerance * it.force;
  dofs_.extract_free_free(hessian_, &k_ff_);
  ++s->factorizations;
  it.positive_definite = cholesky_.factorize(k_ff_);
  if (!it.positive_definite) {
    it.failed_column = cholesky_.failed_column();
    ++s->failed_factorizations;
    return it;
  }
  cholesky_.solve(g_f_, &direction_);
  direction_ = -direction_;
  it.slope = g_f_.dot(direction_);
  s->newton_decrement_J = -it.slope;
  it.small_decrement = -it.slope <= options_.decrement_tolerance * it.force * length_scale_m_;
  spdlog::debug(
      "EquilibriumSolver: iteration {}: Ψ = {:.15e} J, |g_f| = {:.3e} N "
      "(F = {:.3e} N), λ² = {:.3e} J",
      s->newton_iterations, psi, it.gradient_norm, it.force, -it.slope);
  return it;
}

EquilibriumSummary EquilibriumSolver::converged_at_floor(const Eigen::VectorXd& q, double* psi, const NewtonIterate& it,
                                                         const std::string& evidence, Clock::time_point start,
                                                         EquilibriumSummary* s) {
  // K_ff at q is factorised; make the Hessian (and K_fc) belong to q as well.
  if (!hessian_at_q_) {
    *psi = evaluate(q, &gradient_, &hessian_, s);
    hessian_at_q_ = true;
  }
  dofs_.extract_free_fixed(hessian_, &k_fc_);
  factor_at_solution_ = predictor_factor_ = true;
  s->at_roundoff_floor = true;
  return finish(EquilibriumStatus::kConverged,
                fmt::format("converged at the round-off floor: |g_f|inf = {:.3e} N <= {:.1e} "
                            "x {:.3e} N; lambda^2 = {:.3e} J > {:.1e} x F x L, but {}",
                            it.gradient_norm, options_.gradient_tolerance, it.force, -it.slope,
                            options_.decrement_tolerance, evidence),
                *psi, start, s);
}

std::optional<EquilibriumSummary> EquilibriumSolver::stop_at_iterate(const NewtonIterate& it, double psi,
                                                                     Clock::time_point start, EquilibriumSummary* s) {
  if (it.positive_definite && it.small_gradient && it.small_decrement) {
    dofs_.extract_free_fixed(hessian_, &k_fc_);
    factor_at_solution_ = predictor_factor_ = true;
    return finish(EquilibriumStatus::kConverged,
                  fmt::format("converged: |g_f|inf = {:.3e} N <= {:.1e} x {:.3e} N, "
                              "lambda^2 = {:.3e} J",
                              it.gradient_norm, options_.gradient_tolerance, it.force, -it.slope),
                  psi, start, s);
  }
  if (!it.positive_definite && it.small_gradient) {
    return finish(EquilibriumStatus::kIndefiniteStationary,
                  fmt::format("stationary point (|g_f|inf = {:.3e} N) where K_ff is not "
                              "positive definite (column {}): not a minimum ({} of {} saddle escapes taken)",
                              it.gradient_norm, it.failed_column, s->saddle_escapes,
                              options_.max_saddle_escapes),
                  psi, start, s);
  }
  if (s->newton_iterations >= options_.max_newton_iterations) {
    return finish(EquilibriumStatus::kMaxIterations,
                  fmt::format("{} Newton iterations without convergence (|g_f|inf = {:.3e} N, "
                              "F = {:.3e} N)",
                              s->newton_iterations, it.gradient_norm, it.force),
                  psi, start, s);
  }
  return std::nullopt;
}

EquilibriumSolver::StepOutcome EquilibriumSolver::newton_step(Eigen::VectorXd* q, double* psi, const NewtonIterate& it,
                                                              bool energy_flat, std::string stall,
                                                              Clock::time_point start, EquilibriumSummary* s) {
  StepOutcome out;
  std::string& reason = out.fallback_reason;
  if (!it.positive_definite) reason = fmt::format("K_ff not positive definite (column {})", it.failed_column);
  if (reason.empty() && !(it.slope < 0 && std::isfinite(it.slope)))
    reason = fmt::format("ascent direction (g_f.d = {:.3e})", it.slope);
  if (reason.empty() && it.small_gradient && energy_flat) {
    out.done = converged_at_floor(*q, psi, it,
                                  fmt::format("{} Newton steps changed Psi by less than {:.1e} x |Psi|",
                                              options_.stall_window, options_.energy_roundoff),
                                  start, s);
    return out;
  }
  if (reason.empty()) reason = std::move(stall);
  if (!reason.empty()) return out;
  double alpha = 0;
  const SearchResult result =
      line_search(q, psi, it.slope, 0.0, it.small_gradient ? RoundoffRule::kByGradientOrFloor : RoundoffRule::kByGradient,
                  solution_factor_needed_, &alpha, s);
  if (result == SearchResult::kAccepted) return out;
  if (result == SearchResult::kRoundoffFloor) {
    out.done = converged_at_floor(*q, psi, it,
                                  fmt::format("the Newton step changes neither Psi (by more than {:.1e} x |Psi|) "
                                              "nor |g_f|",
                                              options_.energy_roundoff),
                                  start, s);
    return out;
  }
  reason = "line search found no decrease";
  return out;
}

std::optional<EquilibriumSummary> EquilibriumSolver::fall_back(Eigen::VectorXd* q, double* psi, double* time_step,
                                                               const std::string& reason, Clock::time_point start,
                                                               EquilibriumSummary* s) {
  if (s->fallbacks >= options_.max_fallbacks) {
    return finish(EquilibriumStatus::kFallbackLimit,
                  fmt::format("failsafe needed ({}) but max_fallbacks = {} reached", reason, options_.max_fallbacks),
                  *psi, start, s);
  }
  ++s->fallbacks;
  s->last_fallback_reason = reason;
  spdlog::debug("EquilibriumSolver: backward-Euler failsafe #{}: {}", s->fallbacks, reason);
  if (!backward_euler(q, psi, time_step, s))
    return finish(EquilibriumStatus::kFallbackFailed, reason + "; " + s->message, *psi, start, s);
  return std::nullopt;
}

EquilibriumSummary EquilibriumSolver::solve(Eigen::VectorXd* q) {
  const auto start = Clock::now();
  if (q == nullptr || q->size() != dofs_.num_dofs()) {
    throw std::invalid_argument(
        fmt::format("EquilibriumSolver::solve: q must have {} entries", dofs_.num_dofs()));
  }
  EquilibriumSummary s;
  s.length_scale_m = length_scale_m_;
  factor_at_solution_ = false;
  predictor_factor_ = false;
  hessian_at_q_ = false;

  double psi = evaluate(*q, &gradient_, &hessian_, &s);
  s.initial_energy_J = psi;
  if (!std::isfinite(psi) || !gradient_.allFinite()) {
    return finish(EquilibriumStatus::kNonFinite, "energy or gradient is not finite at the initial guess", psi, start, &s);
  }
  prepare_patterns();
  hessian_at_q_ = true;
  prepare_free_masses();
  double time_step = options_.initial_time_step_s;
  IterateWindow window(static_cast<size_t>(options_.stall_window) + 1);

  for (;;) {
    if (!gradient_.allFinite() || !std::isfinite(psi)) {
      return finish(EquilibriumStatus::kNonFinite, "energy or gradient became non-finite", psi, start, &s);
    }
    if (!hessian_at_q_) {  // a full step taken without the Hessian (solution factor not needed)
      std::string converged = converged_with_previous_factor(&s);
      if (!converged.empty()) return finish(EquilibriumStatus::kConverged, std::move(converged), psi, start, &s);
      psi = evaluate(*q, &gradient_, &hessian_, &s);
      hessian_at_q_ = true;
    }
    const NewtonIterate it = newton_direction(psi, &s);
    window.push(psi, it.gradient_norm);
    if (!it.positive_definite && it.small_gradient && s.saddle_escapes < options_.max_saddle_escapes &&
        escape_saddle(q, &psi, &s)) {
      window.clear();
      continue;
    }
    if (auto done = stop_at_iterate(it, psi, start, &s)) return *done;
    const bool energy_flat =
        window.full() && std::fabs(window.first_energy() - psi) <= options_.energy_roundoff * std::fabs(psi);
    StepOutcome step =
        newton_step(q, &psi, it, energy_flat, stall_reason(options_, window, it.gradient_norm, psi), start, &s);
    if (step.done) return *step.done;
    if (step.fallback_reason.empty()) {
      ++s.newton_iterations;
      continue;
    }
    if (auto done = fall_back(q, &psi, &time_step, step.fallback_reason, start, &s)) return *done;
    window.clear();
  }
}

// The equilibria of the steps before (free and fixed dofs) and the tangent predictor's last
// responses, for the next step's prediction.
struct EquilibriumSolver::ContinuationHistory {
  Eigen::VectorXd previous, before_previous;
  Eigen::VectorXd fixed_now, fixed_previous, fixed_before;
  Eigen::MatrixXd response, previous_response;  // a_i and a_{i−1} of kTangent (free dofs)
  int equilibria = 0;
};

double EquilibriumSolver::step_ratio(ContinuationHistory& h) const {
  // ρ = ⟨Δc_i, Δc_{i−1}⟩ / ‖Δc_{i−1}‖²: how far this step goes relative to the last one.
  dofs_.gather_fixed(h.before_previous, &h.fixed_before);
  const Eigen::VectorXd last_move = h.fixed_previous - h.fixed_before;
  const double last_move2 = last_move.squaredNorm();
  return last_move2 > 0 ? last_move.dot(h.fixed_now - h.fixed_previous) / last_move2 : 1.0;
}

bool EquilibriumSolver::predict(ContinuationPredictor predictor, const Eigen::VectorXd& q, ContinuationHistory& h,
                                Eigen::VectorXd* guess) {
  if (predictor == ContinuationPredictor::kSecant && h.equilibria >= 2) {
    const double ratio = step_ratio(h);
    *guess = q;
    for (int dof : dofs_.free_dofs()) (*guess)[dof] = h.previous[dof] + ratio * (h.previous[dof] - h.before_previous[dof]);
    return true;
  }
  if (predictor == ContinuationPredictor::kTangent && h.equilibria >= 1 && predictor_factor_) {
    cholesky_.solve(Eigen::MatrixXd(-(k_fc_ * (h.fixed_now - h.fixed_previous))), &h.response);
    Eigen::VectorXd move = h.response.col(0);
    if (h.equilibria >= 2 && h.previous_response.size() == h.response.size()) {
      const double ratio = step_ratio(h);
      move += 0.5 * ratio * (h.response.col(0) - ratio * h.previous_response.col(0));
    }
    h.previous_response = h.response;
    *guess = q;
    dofs_.add_to_free(1.0, move, guess);
    return true;
  }
  return false;
}

ContinuationSummary EquilibriumSolver::solve_continuation(int num_steps,
                                                          const LoadStepFunction& apply_step,
                                                          Eigen::VectorXd* q,
                                                          const StepObserver& observer,
                                                          const ContinuationOptions& options) {
  const auto start = Clock::now();
  if (num_steps < 0) {
    throw std::invalid_argument(
        fmt::format("solve_continuation: num_steps must be >= 0 (got {})", num_steps));
  }
  if (!apply_step) throw std::invalid_argument("solve_continuation: apply_step is empty");
  if (q == nullptr || q->size() != dofs_.num_dofs()) {
    throw std::invalid_argument(
        fmt::format("solve_continuation: q must have {} entries", dofs_.num_dofs()));
  }
  ContinuationSummary summary;
  ContinuationHistory h;
  Eigen::VectorXd guess;
  for (int step = 0; step < num_steps; ++step) {
    apply_step(step, q);
    if (h.equilibria >= 1) {
      dofs_.gather_fixed(*q, &h.fixed_now);
      dofs_.gather_fixed(h.previous, &h.fixed_previous);
    }
    // The prediction is taken only where it lowers the energy of the plain start.
    if (predict(options.predictor, *q, h, &guess)) {
      const double psi_plain = discretization_.energy(*q, nullptr, nullptr);
      const double psi_guess = discretization_.energy(guess, nullptr, nullptr);
      if (std::isfinite(psi_guess) && (!(psi_guess >= psi_plain))) {
        *q = guess;
        ++summary.extrapolations_used;
      }
    }
    EquilibriumSummary result = solve(q);
    summary.total_newton_iterations += result.newton_iterations;
    summary.steps.push_back(result);
    if (!result.converged) {
      summary.failed_step = step;
      summary.message = fmt::format("step {} of {} did not converge ({}): {}", step, num_steps,
                                    to_string(result.status), result.message);
      break;
    }
    ++summary.steps_completed;
    if (observer) observer(step, *q, summary.steps.back());
    h.before_previous = h.previous;
    h.previous = *q;
    ++h.equilibria;
  }
  summary.completed = summary.steps_completed == num_steps;
  if (summary.completed) {
    summary.message = fmt::format("{} steps converged, {} Newton iterations in total", num_steps,
                                  summary.total_newton_iterations);
  }
  summary.wall_time_s = seconds_since(start);
  return summary;
}

const SparseCholesky& EquilibriumSolver::factorization() const {
  if (!factor_at_solution_) {
    throw std::logic_error(
        "EquilibriumSolver: no factorisation at a solution (the last solve "
        "did not converge, or none was run)");
  }
  return cholesky_;
}

void EquilibriumSolver::solve_free_free(const Eigen::MatrixXd& b, Eigen::MatrixXd* x,
                                        SolveReport* report) const {
  factorization().solve(b, x, report);
}

const EquilibriumSolver::SparseMatrix& EquilibriumSolver::free_free_hessian() const {
  factorization();
  return k_ff_;
}

const EquilibriumSolver::SparseMatrix& EquilibriumSolver::free_fixed_hessian() const {
  factorization();
  return k_fc_;
}

Eigen::VectorXd EquilibriumSolver::reaction() const {
  Eigen::VectorXd fixed;
  if (gradient_.size() == dofs_.num_dofs()) dofs_.gather_fixed(gradient_, &fixed);
  return fixed;
}

}  // namespace twill
