#pragma once
// Adapter to Ipopt (interior-point filter line search; Wächter & Biegler, Math. Prog. 106, 2006)
// through its TNLP interface, for Ipopt 3.11.
//
// - The problem has no constraints besides the bounds (given where finite; Ipopt's ±1e19
//   means "none") and no Hessian: hessian_approximation is always limited-memory (L-BFGS).
//   bound_relax_factor is 0, so Ipopt never evaluates outside the box (its default relaxes
//   bounds by 1e-8).
// - Tolerances: Ipopt's tol and dual_inf_tol are set to gradient_tolerance (its optimality
//   error is scaled, see Ipopt's documentation of tol), max_iter to max_iterations.
//   function_tolerance (relative change of f between iterations) is enforced from the
//   intermediate callback, which stops Ipopt (User_Requested_Stop, reported as converged).
//   max_evaluations is a hard cap: once reached, further evaluation requests are refused
//   (the callback returns false, Ipopt treats it as an evaluation error) and the next
//   intermediate callback stops Ipopt (reported as iteration_limit). step_tolerance is not used
//   (Ipopt has its own tiny-step test, reported as stalled).
// - Evaluations: Ipopt asks for f and ∇f in separate callbacks, often at the same x; the
//   adapter always evaluates both at once (cheap in twill, core/problem.hpp) and keeps the
//   last few in a cache keyed by x, so each x costs one evaluation.
// - Exceptions never cross into Ipopt: every callback catches everything and returns false
//   (and the next intermediate callback stops Ipopt); the run then ends with status failed and
//   the caught message. A non-finite value makes the callback return false, which Ipopt treats
//   as an evaluation error and answers by cutting the step.
// - Trace: Ipopt 3.11 does not hand the iterate to its intermediate callback, so the adapter
//   takes the x of the latest gradient request (Ipopt evaluates ∇f at the current iterate to
//   test convergence just before calling back) and reports the same projected-gradient norm
//   and step length as the other optimisers. The gradient test of gradient_tolerance is also
//   applied there, so "converged" means the same thing for every optimiser.
// - First step: Ipopt's L-BFGS starts from B0 = limited_memory_init_val·I (1 by default), so
//   its first step is the scaled gradient itself (up to 100 long after gradient-based
//   scaling). The adapter evaluates ∇f(x0) first and sets limited_memory_init_val so that this
//   step is at most 1 long in x, the rule of BFGS's first step (bfgs.hpp); later iterations
//   use Ipopt's own scalar1 update. Measured on the poplin bias (the #12 acceptance row).
// - Output: print_level 0 and no banner by default.
// - With bounds, Ipopt first moves x0 strictly inside the box (its bound_push), so the trace's
//   iteration 0 may differ slightly from x0.
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"

namespace twill {

struct IpoptOptions : OptimizerOptions {
  int print_level = 0;  ///< Ipopt's print_level, 0 (silent) … 12
  /// L-BFGS pairs kept. Ipopt's own default, 6, needed over 5000 evaluations on the 10-D
  /// quadratic of condition 1e6 (its line search does not enforce Wolfe curvature, so short
  /// memories recover slowly); 20 covers twill's usual parameter counts and took 231.
  int limited_memory_max_history = 20;
  std::string mu_strategy = "adaptive";               ///< barrier update: monotone | adaptive
  std::string nlp_scaling_method = "gradient-based";  ///< gradient-based | none

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null).
  bool validate(std::string* error) const;
};

std::vector<OptionBinding<IpoptOptions>> ipopt_option_bindings();

class IpoptOptimizer : public Optimizer {
 public:
  /// Throws InputError when options.validate() fails.
  explicit IpoptOptimizer(IpoptOptions options = {});

  std::string name() const override { return "ipopt"; }
  Options resolved_options() const override;
  const IpoptOptions& options() const { return options_; }

 protected:
  void run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const override;

 private:
  IpoptOptions options_;
};

}  // namespace twill
