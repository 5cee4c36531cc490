#pragma once
// The line search of the quasi-Newton methods (bfgs.hpp, lbfgs/lbfgs.hpp): the strong Wolfe
// search of strong_wolfe_line_search.hpp along a descent direction p on a CountedProblem,
// inside the box (α ≤ max_feasible_step(), points by take_step()) and within what is left of
// the run's evaluation budget; the record of an accepted step; and the iterate these methods
// carry from step to step.
#include <Eigen/Core>
#include <optional>
#include <string>

#include "optimizers/optimizer.hpp"
#include "optimizers/strong_wolfe_line_search.hpp"

namespace twill {

struct BoxLineSearch {
  LineSearchOutcome outcome;
  Eigen::VectorXd x, gradient;  ///< the accepted point and ∇f there (not set when it failed)
  double value = 0.0;           ///< f at x
};

/// Searches φ(α) = f(x + α p) from φ(0) = f, φ'(0) = dphi0 < 0, with the first trial at
/// min(alpha_initial, α_max), spending at most min(options.max_evaluations,
/// max_evaluations − problem.evaluations()) evaluations.
BoxLineSearch box_line_search(CountedProblem& problem, const Eigen::VectorXd& x, double f, double dphi0,
                              const Eigen::VectorXd& p, double alpha_initial, const LineSearchOptions& options,
                              int max_evaluations);

/// The LineSearchRecord of iteration k's accepted step; `failed_attempt_evaluations` are
/// those of a failed search before it in the same iteration (bfgs.hpp's retry).
LineSearchRecord line_search_record(int k, double f, double dphi0, const LineSearchOutcome& outcome,
                                    int failed_attempt_evaluations);

/// The current point of a line-search method: x, f(x), ∇f(x) and the projected-gradient norm.
struct LineSearchIterate {
  Eigen::VectorXd x, g;
  double f = 0.0;
  double gradient_norm = 0.0;

  /// Evaluates at x0 and records iteration 0. False, with `result` failed, when f(x0) is not finite.
  bool start(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result);
  /// Moves to the accepted point of `search`, records the iteration, and returns the
  /// convergence test it meets (check_convergence), if any.
  std::optional<std::string> advance(CountedProblem& problem, const BoxLineSearch& search,
                                     const OptimizerOptions& options);
  /// Ends the run here with `status` and `message`.
  void finish(OptimizerResult& result, OptimizerStatus status, std::string message) const;
};

}  // namespace twill
