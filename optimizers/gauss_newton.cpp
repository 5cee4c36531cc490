#include "optimizers/gauss_newton.hpp"

#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace twill {
namespace {

// Residuals, Jacobian, f = ‖r‖² and ∇f = 2Jᵀr at one point.
struct Linearization {
  Eigen::VectorXd x, r, gradient;
  Eigen::MatrixXd J;
  double value = 0.0;
};

Linearization linearize(CountedProblem& problem, Eigen::VectorXd x) {
  Linearization l;
  l.x = std::move(x);
  l.value = problem.residuals(l.x, &l.r, &l.J, &l.gradient);
  return l;
}

// argmin_h ‖r + J h‖² + λ ‖D h‖² over the free variables (others stay 0).
Eigen::VectorXd model_step(const Linearization& at, const std::vector<int>& free, double lambda) {
  const Eigen::MatrixXd J = at.J(Eigen::all, free);
  Eigen::VectorXd h_free;
  if (lambda > 0.0) {
    const Eigen::Index m = J.rows(), nf = J.cols();
    Eigen::VectorXd d2 = J.colwise().squaredNorm().transpose();
    const double floor = std::max(1e-12 * d2.maxCoeff(), std::numeric_limits<double>::min());
    d2 = d2.cwiseMax(floor);
    Eigen::MatrixXd augmented(m + nf, nf);
    augmented << J, Eigen::MatrixXd((lambda * d2).cwiseSqrt().asDiagonal());
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(m + nf);
    rhs.head(m) = -at.r;
    h_free = augmented.colPivHouseholderQr().solve(rhs);
  } else {
    h_free = J.colPivHouseholderQr().solve(-at.r);
  }
  Eigen::VectorXd h = Eigen::VectorXd::Zero(at.x.size());
  h(free) = h_free;
  return h;
}

// The damping at which the first step is at most options.max_first_step long (Euclidean, in x):
// λ₀ raised by kFirstStepDampingFactor until it is (‖h(λ)‖ falls as λ grows). The rule of
// BFGS's first step (bfgs.hpp) and Ipopt's (ipopt_optimizer.hpp): before any trial nothing says
// how far the linear model can be trusted, and a Jacobian with a nearly flat direction (a degree
// raise's new term that can merge with an old one, docs/fitting.md §3b) makes the undamped step
// thousands of units long. Later steps are governed by the gain ratio alone.
constexpr double kFirstStepDampingFactor = 2.0;  // at most 2x more damping than needed

double damping_for_first_step(const Linearization& at, const std::vector<int>& free, double lambda,
                              const GaussNewtonOptions& options) {
  if (options.max_first_step <= 0.0) return lambda;
  while (lambda < options.max_lambda && model_step(at, free, lambda).norm() > options.max_first_step)
    lambda *= kFirstStepDampingFactor;
  return std::min(lambda, options.max_lambda);
}

// Why a run stops inside a step.
struct Stop {
  OptimizerStatus status;
  std::string message;
};

// The model step over `free` (damped by `lambda`) with its blocked components dropped; where
// rank deficiency or a bound spoilt it, projected steepest descent scaled to the minimiser of
// ‖r + α J p‖², α = −gᵀp / (2 ‖J p‖²). *dphi0 = gᵀh.
Eigen::VectorXd descent_step(const Linearization& at, const std::vector<int>& free, double lambda,
                             const Eigen::VectorXd& lower, const Eigen::VectorXd& upper, double* dphi0) {
  const Eigen::VectorXd& g = at.gradient;
  Eigen::VectorXd h = model_step(at, free, lambda);
  drop_blocked_components(at.x, lower, upper, h);
  *dphi0 = g.dot(h);
  if (!(*dphi0 < 0.0)) {
    h = -g;
    drop_blocked_components(at.x, lower, upper, h);
    const double curvature = (at.J * h).squaredNorm();
    if (curvature > 0.0) h *= -g.dot(h) / (2.0 * curvature);
    *dphi0 = g.dot(h);
  }
  return h;
}

Stop no_descent(int k, double dphi0) {
  return {OptimizerStatus::stalled, fmt::format("no descent direction at iteration {} (g'h = {:.3g})", k, dphi0)};
}

Stop evaluation_limit(const GaussNewtonOptions& options) {
  return {OptimizerStatus::iteration_limit, fmt::format("max_evaluations = {} reached", options.max_evaluations)};
}

// Iteration k without damping: the Gauss–Newton step and a backtracking Armijo search from
// α = 1 (N&W Alg. 3.1) into *trial, recorded; or why the run stops.
std::optional<Stop> armijo_step(CountedProblem& problem, const Linearization& current, const std::vector<int>& free,
                                int k, const GaussNewtonOptions& options, Linearization* trial) {
  const Eigen::VectorXd& lower = problem.lower();
  const Eigen::VectorXd& upper = problem.upper();
  double dphi0 = 0;
  const Eigen::VectorXd h = descent_step(current, free, 0.0, lower, upper, &dphi0);
  if (!(dphi0 < 0.0)) return no_descent(k, dphi0);
  const double alpha_max = max_feasible_step(current.x, h, lower, upper);
  double alpha = std::min(1.0, alpha_max);
  int evaluations = 0;
  for (;;) {
    if (problem.evaluations() >= options.max_evaluations) return evaluation_limit(options);
    if (evaluations >= options.max_line_search_evaluations)
      return Stop{OptimizerStatus::line_search_failed,
                  fmt::format("no sufficient decrease within {} evaluations at iteration {} (last alpha {:.3g})",
                              evaluations, k, alpha)};
    *trial = linearize(problem, take_step(current.x, h, alpha, lower, upper));
    ++evaluations;
    if (std::isfinite(trial->value) && trial->value <= current.value + options.c1 * alpha * dphi0) break;
    // Minimiser of the quadratic through φ(0), φ'(0), φ(α) (N&W eq. 3.58), kept in
    // [0.1 α, 0.5 α] so the search neither stalls nor shrinks too fast.
    double next = 0.5 * alpha;
    const double curvature = trial->value - current.value - dphi0 * alpha;
    if (std::isfinite(trial->value) && curvature > 0.0)
      next = std::clamp(-dphi0 * alpha * alpha / (2.0 * curvature), 0.1 * alpha, 0.5 * alpha);
    alpha = next;
  }
  LineSearchRecord record;
  record.iteration = k;
  record.alpha = alpha;
  record.phi_0 = current.value;
  record.dphi_0 = dphi0;
  record.phi_alpha = trial->value;
  record.dphi_alpha = trial->gradient.dot(h);
  record.evaluations = evaluations;
  record.step_limited = alpha == alpha_max && alpha < 1.0;
  problem.record_line_search(record);
  return std::nullopt;
}

// Iteration k with Levenberg–Marquardt damping (Nielsen's update of *lambda, *nu): steps
// truncated at the box until one's gain ratio — the actual decrease over the predicted
// m(0) − m(h) = −(gᵀh + ‖J h‖²) for m(h) = ‖r + J h‖² — is positive, into *trial; or why the
// run stops.
std::optional<Stop> levenberg_marquardt_step(CountedProblem& problem, const Linearization& current,
                                             const std::vector<int>& free, int k, const GaussNewtonOptions& options,
                                             double* lambda, double* nu, Linearization* trial) {
  const Eigen::VectorXd& lower = problem.lower();
  const Eigen::VectorXd& upper = problem.upper();
  for (;;) {
    double dphi0 = 0;
    const Eigen::VectorXd h = descent_step(current, free, *lambda, lower, upper, &dphi0);
    if (!(dphi0 < 0.0)) return no_descent(k, dphi0);
    const double alpha = std::min(1.0, max_feasible_step(current.x, h, lower, upper));
    const Eigen::VectorXd step = alpha * h;
    const double predicted = -(current.gradient.dot(step) + (current.J * step).squaredNorm());
    *trial = linearize(problem, take_step(current.x, h, alpha, lower, upper));
    const double gain = (current.value - trial->value) / predicted;
    if (std::isfinite(trial->value) && predicted > 0.0 && gain > 0.0) {
      *lambda *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * gain - 1.0, 3));
      *nu = 2.0;
      return std::nullopt;
    }
    *lambda *= *nu;
    *nu *= 2.0;
    if (*lambda > options.max_lambda)
      return Stop{OptimizerStatus::stalled,
                  fmt::format("damping lambda = {:.3g} exceeded max_lambda = {:.3g} without a decrease at iteration {}",
                              *lambda, options.max_lambda, k)};
    if (problem.evaluations() >= options.max_evaluations) return evaluation_limit(options);
  }
}

}  // namespace

std::vector<OptionBinding<GaussNewtonOptions>> gauss_newton_option_bindings() {
  const OptionConstraint positive = [](OptionSpec& s) { s.greater_than(0.0); };
  auto bindings = common_option_bindings<GaussNewtonOptions>();
  bindings.push_back(enum_option<GaussNewtonOptions>(
      "damping", &GaussNewtonOptions::damping,
      {{"none", GaussNewtonDamping::none},
       {"levenberg-marquardt", GaussNewtonDamping::levenberg_marquardt}},
      "none: Gauss-Newton step + backtracking; levenberg-marquardt: adaptive damping (Nielsen)"));
  bindings.push_back(real_option<GaussNewtonOptions>(
      "initial_lambda", &GaussNewtonOptions::initial_lambda,
      "initial Levenberg-Marquardt damping, relative to diag(J'J)", positive));
  bindings.push_back(real_option<GaussNewtonOptions>(
      "max_first_step", &GaussNewtonOptions::max_first_step,
      "Levenberg-Marquardt: the damping is raised until the first step is at most this long in x (0: off)",
      [](OptionSpec& s) { s.at_least(0.0); }));
  bindings.push_back(real_option<GaussNewtonOptions>("max_lambda", &GaussNewtonOptions::max_lambda,
                                                     "stop (stalled) when the damping exceeds this",
                                                     positive));
  bindings.push_back(real_option<GaussNewtonOptions>(
      "c1", &GaussNewtonOptions::c1,
      "Armijo sufficient-decrease constant of the backtracking line search (damping none)",
      [](OptionSpec& s) { s.greater_than(0.0).less_than(1.0); }));
  bindings.push_back(integer_option<GaussNewtonOptions>(
      "max_line_search_evaluations", &GaussNewtonOptions::max_line_search_evaluations,
      "evaluations allowed per backtracking line search (damping none)",
      [](OptionSpec& s) { s.range(1, 1000); }));
  return bindings;
}

bool GaussNewtonOptions::validate(std::string* error) const {
  if (!check_options(gauss_newton_option_bindings(), *this, error)) return false;
  if (!(initial_lambda <= max_lambda)) {
    if (error)
      *error = fmt::format("initial_lambda = {} must not exceed max_lambda = {}", initial_lambda,
                           max_lambda);
    return false;
  }
  return true;
}

GaussNewton::GaussNewton(GaussNewtonOptions options) : options_(std::move(options)) {
  require_valid(options_, "gauss-newton");
}

Options GaussNewton::resolved_options() const {
  return options_of(gauss_newton_option_bindings(), options_);
}

void GaussNewton::run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const {
  const Eigen::VectorXd& lower = problem.lower();
  const Eigen::VectorXd& upper = problem.upper();
  const bool levenberg_marquardt = options_.damping == GaussNewtonDamping::levenberg_marquardt;

  Linearization current = linearize(problem, std::move(x0));
  result.x = current.x;
  result.summary.final_value = current.value;
  if (!std::isfinite(current.value)) {
    result.status = OptimizerStatus::failed;
    result.message = "the residuals are not finite at x0";
    return;
  }
  double gradient_norm = projected_gradient_norm(current.x, current.gradient, lower, upper);
  problem.record_iteration(current.x, current.value, gradient_norm, 0.0);

  auto finish = [&](OptimizerStatus status, std::string message) {
    result.x = current.x;
    result.status = status;
    result.message = std::move(message);
    result.summary.final_value = current.value;
    result.summary.final_gradient_norm = gradient_norm;
  };

  double lambda = options_.initial_lambda, nu = 2.0;
  for (int k = 1;; ++k) {
    if (const auto stop = options_.iteration_stop(k, gradient_norm, problem.evaluations()))
      return finish(stop->status, stop->message);
    const std::vector<int> free = free_variables(current.x, current.gradient, lower, upper);
    if (k == 1 && levenberg_marquardt) lambda = damping_for_first_step(current, free, lambda, options_);
    Linearization trial;
    const std::optional<Stop> stop =
        levenberg_marquardt ? levenberg_marquardt_step(problem, current, free, k, options_, &lambda, &nu, &trial)
                            : armijo_step(problem, current, free, k, options_, &trial);
    if (stop) return finish(stop->status, stop->message);

    const double step_length = (trial.x - current.x).lpNorm<Eigen::Infinity>();
    const Eigen::VectorXd x_previous = current.x;
    const double f_previous = current.value;
    current = std::move(trial);
    gradient_norm = projected_gradient_norm(current.x, current.gradient, lower, upper);
    problem.record_iteration(current.x, current.value, gradient_norm, step_length);
    if (auto reason = check_convergence(options_, f_previous, current.value, x_previous, current.x,
                                        gradient_norm))
      return finish(OptimizerStatus::converged, *reason);
  }
}

}  // namespace twill
