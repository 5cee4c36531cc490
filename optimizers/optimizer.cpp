#include "optimizers/optimizer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace twill {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_preconditions(const Optimizer& optimizer, const Problem& problem,
                         const CountedProblem& counted, const Eigen::VectorXd& x0) {
  const int n = counted.dimension();
  const std::string who = optimizer.name() + ": ";
  if (n < 1) throw std::invalid_argument(who + "the problem has dimension " + std::to_string(n));
  if (x0.size() != n)
    throw std::invalid_argument(who + "x0 has size " + std::to_string(x0.size()) +
                                " but the problem has dimension " + std::to_string(n));
  if (counted.lower().size() != n || counted.upper().size() != n)
    throw std::invalid_argument(who + "bounds must have the problem's dimension " +
                                std::to_string(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    const double l = counted.lower()[i], u = counted.upper()[i];
    if (std::isnan(l) || std::isnan(u) || l > u)
      throw std::invalid_argument(
          fmt::format("{}bounds[{}] are inconsistent: lower {}, upper {}", who, i, l, u));
    if (!std::isfinite(x0[i]))
      throw std::invalid_argument(fmt::format("{}x0[{}] is not finite", who, i));
    if (x0[i] < l || x0[i] > u)
      throw std::invalid_argument(
          fmt::format("{}x0[{}] = {} is outside its bounds [{}, {}]", who, i, x0[i], l, u));
  }
  if (optimizer.requires_residuals() && !problem.has_residuals())
    throw std::invalid_argument(who +
                                "needs the least-squares form (Problem::has_residuals() is false)");
}

}  // namespace

std::string to_string(OptimizerStatus status) {
  switch (status) {
    case OptimizerStatus::converged:
      return "converged";
    case OptimizerStatus::stalled:
      return "stalled";
    case OptimizerStatus::iteration_limit:
      return "iteration_limit";
    case OptimizerStatus::line_search_failed:
      return "line_search_failed";
    case OptimizerStatus::failed:
      return "failed";
  }
  return "unknown";
}

std::optional<OptimizerOptions::Stop> OptimizerOptions::iteration_stop(int k, double gradient_norm,
                                                                       int evaluations) const {
  if (gradient_norm <= gradient_tolerance)
    return Stop{OptimizerStatus::converged,
                fmt::format("gradient norm {:.3g} <= gradient_tolerance {:.3g}", gradient_norm,
                            gradient_tolerance)};
  if (k > max_iterations)
    return Stop{OptimizerStatus::iteration_limit, fmt::format("max_iterations = {} reached", max_iterations)};
  if (evaluations >= max_evaluations)
    return Stop{OptimizerStatus::iteration_limit, fmt::format("max_evaluations = {} reached", max_evaluations)};
  return std::nullopt;
}

bool OptimizerOptions::validate(std::string* error) const {
  return check_options(common_option_bindings<OptimizerOptions>(), *this, error);
}

CountedProblem::CountedProblem(Problem& problem, OptimizerSummary& summary)
    : problem_(problem),
      summary_(summary),
      dimension_(problem.dimension()),
      lower_(problem.lower_bounds()),
      upper_(problem.upper_bounds()),
      bounded_(lower_.array().isFinite().any() || upper_.array().isFinite().any()),
      best_value_(kNaN) {}

bool CountedProblem::has_best() const { return std::isfinite(best_value_); }

double CountedProblem::evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) {
  ++summary_.objective_evaluations;
  if (gradient) ++summary_.gradient_evaluations;
  double f = problem_.evaluate(x, gradient);
  if (gradient && std::isfinite(f)) {
    if (gradient->size() != dimension_)
      throw std::logic_error("Problem::evaluate returned a gradient of size " +
                             std::to_string(gradient->size()) + ", expected " +
                             std::to_string(dimension_));
    // A non-finite gradient is as unusable as a non-finite value.
    if (!gradient->allFinite()) f = kNaN;
  }
  note(x, f);
  return f;
}

double CountedProblem::residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r,
                                 Eigen::MatrixXd* jacobian, Eigen::VectorXd* gradient) {
  ++summary_.objective_evaluations;
  if (jacobian) ++summary_.gradient_evaluations;
  problem_.residuals(x, r, jacobian);
  double f = r->allFinite() ? r->squaredNorm() : kNaN;
  if (jacobian && std::isfinite(f)) {
    if (jacobian->rows() != r->size() || jacobian->cols() != dimension_)
      throw std::logic_error("Problem::residuals returned a " + std::to_string(jacobian->rows()) +
                             " x " + std::to_string(jacobian->cols()) + " Jacobian, expected " +
                             std::to_string(r->size()) + " x " + std::to_string(dimension_));
    if (!jacobian->allFinite()) f = kNaN;
  }
  if (gradient) {
    if (!jacobian) throw std::logic_error("CountedProblem::residuals: gradient needs the Jacobian");
    if (std::isfinite(f)) *gradient = 2.0 * jacobian->transpose() * (*r);
  }
  note(x, f);
  return f;
}

void CountedProblem::note(const Eigen::VectorXd& x, double value) {
  if (std::isfinite(value) && (!has_best() || value < best_value_)) {
    best_value_ = value;
    best_x_ = x;
  }
}

void CountedProblem::record_iteration(const Eigen::VectorXd& x, double value, double gradient_norm,
                                      double step_length) {
  IterationRecord record;
  record.iteration = static_cast<int>(summary_.trace.size());
  record.value = value;
  record.gradient_norm = gradient_norm;
  record.step_length = step_length;
  record.evaluations = summary_.objective_evaluations;
  summary_.trace.push_back(record);
  problem_.on_iteration(record, x);
}

void CountedProblem::record_line_search(const LineSearchRecord& record) {
  summary_.line_searches.push_back(record);
}

double projected_gradient_norm(const Eigen::VectorXd& x, const Eigen::VectorXd& gradient,
                               const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  if (gradient.size() != x.size() || lower.size() != x.size() || upper.size() != x.size())
    throw std::invalid_argument(fmt::format("projected_gradient_norm: x has {} entries, gradient {}, bounds {} / {}",
                                            x.size(), gradient.size(), lower.size(), upper.size()));
  double norm = 0.0;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double projected = std::clamp(x[i] - gradient[i], lower[i], upper[i]);
    norm = std::max(norm, std::abs(x[i] - projected));
  }
  return norm;
}

std::vector<int> free_variables(const Eigen::VectorXd& x, const Eigen::VectorXd& gradient,
                                const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                std::vector<int>* held) {
  std::vector<int> free;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const bool blocked = (x[i] <= lower[i] && gradient[i] > 0.0) || (x[i] >= upper[i] && gradient[i] < 0.0);
    if (!blocked)
      free.push_back(static_cast<int>(i));
    else if (held)
      held->push_back(static_cast<int>(i));
  }
  return free;
}

void drop_blocked_components(const Eigen::VectorXd& x, const Eigen::VectorXd& lower,
                             const Eigen::VectorXd& upper, Eigen::VectorXd& p) {
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if ((x[i] <= lower[i] && p[i] < 0.0) || (x[i] >= upper[i] && p[i] > 0.0)) p[i] = 0.0;
}

double max_feasible_step(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                         const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  double alpha = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (p[i] > 0.0 && std::isfinite(upper[i])) alpha = std::min(alpha, (upper[i] - x[i]) / p[i]);
    if (p[i] < 0.0 && std::isfinite(lower[i])) alpha = std::min(alpha, (lower[i] - x[i]) / p[i]);
  }
  return std::max(alpha, 0.0);
}

Eigen::VectorXd take_step(const Eigen::VectorXd& x, const Eigen::VectorXd& p, double alpha,
                          const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  Eigen::VectorXd y = x + alpha * p;
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    // x + α p with α = (u − x)/p lands on u only up to round-off; an iterate a few ulps
    // inside would make the next direction blocked by a step of 1e-17.
    const double scale = 1e-12 * (1.0 + std::abs(x[i]) + std::abs(alpha * p[i]));
    if (std::isfinite(lower[i]) && std::abs(y[i] - lower[i]) <= scale) y[i] = lower[i];
    if (std::isfinite(upper[i]) && std::abs(y[i] - upper[i]) <= scale) y[i] = upper[i];
    y[i] = std::clamp(y[i], lower[i], upper[i]);
  }
  return y;
}

std::optional<std::string> check_convergence(const OptimizerOptions& options, double f_prev,
                                             double f, const Eigen::VectorXd& x_prev,
                                             const Eigen::VectorXd& x, double gradient_norm) {
  if (gradient_norm <= options.gradient_tolerance)
    return fmt::format("gradient norm {:.3g} <= gradient_tolerance {:.3g}", gradient_norm,
                       options.gradient_tolerance);
  const double change = std::abs(f_prev - f);
  if (change <= options.function_tolerance * std::max(std::abs(f_prev), std::abs(f)))
    return fmt::format("relative function change {:.3g} <= function_tolerance {:.3g}",
                       change / std::max({std::abs(f_prev), std::abs(f), 1e-300}),
                       options.function_tolerance);
  const double step = (x - x_prev).lpNorm<Eigen::Infinity>();
  if (step <= options.step_tolerance * (x.lpNorm<Eigen::Infinity>() + options.step_tolerance))
    return fmt::format("step {:.3g} <= step_tolerance {:.3g} * (|x| + step_tolerance)", step,
                       options.step_tolerance);
  return std::nullopt;
}

OptimizerResult Optimizer::minimize(Problem& problem, Eigen::VectorXd x0) const {
  const auto start = std::chrono::steady_clock::now();
  OptimizerResult result;
  result.x = x0;
  result.summary.final_value = kNaN;
  result.summary.final_gradient_norm = kNaN;
  CountedProblem counted(problem, result.summary);
  check_preconditions(*this, problem, counted, x0);

  std::string thrown;
  try {
    run(counted, std::move(x0), result);
  } catch (const std::exception& e) {
    thrown = e.what();
    if (thrown.empty()) thrown = "an exception without a message";
  } catch (...) {
    thrown = "an exception not derived from std::exception";
  }
  if (!thrown.empty()) {
    result.status = OptimizerStatus::failed;
    result.message = "the problem threw: " + thrown;
    if (counted.has_best()) {
      result.x = counted.best_x();
      result.summary.final_value = counted.best_value();
    }
    result.summary.final_gradient_norm = kNaN;
  }
  result.summary.iterations = std::max(0, static_cast<int>(result.summary.trace.size()) - 1);
  result.summary.wall_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace twill
