#include "optimizers/box_line_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace twill {
namespace {

// One evaluated trial, kept so the accepted one need not be evaluated again.
struct Trial {
  double alpha = 0.0;
  Eigen::VectorXd x, gradient;
  double value = 0.0;
};

}  // namespace

BoxLineSearch box_line_search(CountedProblem& problem, const Eigen::VectorXd& x, double f, double dphi0,
                              const Eigen::VectorXd& p, double alpha_initial, const LineSearchOptions& options,
                              int max_evaluations) {
  const Eigen::VectorXd& lower = problem.lower();
  const Eigen::VectorXd& upper = problem.upper();
  std::vector<Trial> trials;
  const LineFunction phi = [&](double alpha, double* dphi) {
    Trial t;
    t.alpha = alpha;
    t.x = take_step(x, p, alpha, lower, upper);
    t.value = problem.evaluate(t.x, &t.gradient);
    *dphi = std::isfinite(t.value) ? t.gradient.dot(p) : std::numeric_limits<double>::quiet_NaN();
    trials.push_back(t);
    return t.value;
  };
  LineSearchOptions budgeted = options;
  budgeted.max_evaluations = std::min(options.max_evaluations, max_evaluations - problem.evaluations());
  BoxLineSearch result;
  result.outcome = strong_wolfe_line_search(phi, {0.0, f, dphi0}, alpha_initial,
                                            max_feasible_step(x, p, lower, upper), budgeted);
  if (result.outcome.status == LineSearchOutcome::Status::failed) return result;
  const auto accepted = std::find_if(trials.begin(), trials.end(),
                                     [&](const Trial& t) { return t.alpha == result.outcome.accepted.alpha; });
  if (accepted == trials.end()) throw std::logic_error("line search: the accepted step was not among the trials");
  result.x = accepted->x;
  result.gradient = accepted->gradient;
  result.value = accepted->value;
  return result;
}

LineSearchRecord line_search_record(int k, double f, double dphi0, const LineSearchOutcome& outcome,
                                    int failed_attempt_evaluations) {
  LineSearchRecord record;
  record.iteration = k;
  record.alpha = outcome.accepted.alpha;
  record.phi_0 = f;
  record.dphi_0 = dphi0;
  record.phi_alpha = outcome.accepted.phi;
  record.dphi_alpha = outcome.accepted.dphi;
  record.evaluations = outcome.evaluations + failed_attempt_evaluations;
  record.step_limited = outcome.status == LineSearchOutcome::Status::step_limit;
  return record;
}

bool LineSearchIterate::start(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) {
  x = std::move(x0);
  f = problem.evaluate(x, &g);
  result.x = x;
  result.summary.final_value = f;
  if (!std::isfinite(f)) {
    result.status = OptimizerStatus::failed;
    result.message = "the objective is not finite at x0";
    return false;
  }
  gradient_norm = projected_gradient_norm(x, g, problem.lower(), problem.upper());
  problem.record_iteration(x, f, gradient_norm, 0.0);
  return true;
}

std::optional<std::string> LineSearchIterate::advance(CountedProblem& problem, const BoxLineSearch& search,
                                                      const OptimizerOptions& options) {
  const Eigen::VectorXd x_previous = x;
  const double f_previous = f;
  x = search.x;
  f = search.value;
  g = search.gradient;
  gradient_norm = projected_gradient_norm(x, g, problem.lower(), problem.upper());
  problem.record_iteration(x, f, gradient_norm, (x - x_previous).lpNorm<Eigen::Infinity>());
  return check_convergence(options, f_previous, f, x_previous, x, gradient_norm);
}

void LineSearchIterate::finish(OptimizerResult& result, OptimizerStatus status, std::string message) const {
  result.x = x;
  result.status = status;
  result.message = std::move(message);
  result.summary.final_value = f;
  result.summary.final_gradient_norm = gradient_norm;
}

}  // namespace twill
