#pragma once
// Dense BFGS (Nocedal & Wright, Numerical Optimization, 2nd ed., 2006, Alg. 6.1)
// with the strong Wolfe line search of strong_wolfe_line_search.hpp.
//
// - Inverse-Hessian update N&W eq. 6.17: H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ, ρ = 1/yᵀs.
// - Before the first update H is rescaled to (yᵀs / yᵀy) I (N&W eq. 6.20); the very first step
//   (H = I, no curvature known) starts the line search at α = min(1, 1/‖p‖₂), so that the first
//   trial moves x by at most one unit.
// - Safeguard: the update is skipped when yᵀs ≤ ε ‖s‖ ‖y‖ (ε = update_skip_threshold). Strong
//   Wolfe steps always have yᵀs > 0 (they satisfy N&W eq. 6.7), so skips happen only at
//   bound-limited steps or in round-off.
// - If a direction is not a descent direction (round-off) or its line search fails, H is reset
//   to the latest (yᵀs / yᵀy) I and the iteration is retried once; a second failure ends the
//   run with status line_search_failed.
// - Bounds are handled by rejection, not projection: a step never leaves the box. Variables
//   at a bound whose gradient pushes outward are held, and the others move along the
//   quasi-Newton step of the reduced model, p_F = −[(H⁻¹)_FF]⁻¹ g_F (a Schur complement of H;
//   plain H_FF g_F would converge only linearly along the bound). Components of p that would
//   still push through a touched bound are dropped, and the line search's largest step α_max
//   is the distance to the box along p. A step that reaches α_max while φ
//   still decreases is accepted without the curvature condition (LineSearchRecord::
//   step_limited) and lands on the bound. This is a simple active-set scheme, adequate for a
//   few active bounds; a fit with many active bounds should reparametrise or use ipopt / nlopt.
//
// Cost per iteration: one value+gradient evaluation per line-search trial (usually one).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"
#include "optimizers/strong_wolfe_line_search.hpp"

namespace twill {

struct BfgsOptions : OptimizerOptions {
  double c1 = 1e-4;  ///< sufficient decrease (N&W eq. 3.7a)
  double c2 = 0.9;   ///< curvature (N&W eq. 3.7b); 0.9 is N&W's choice for quasi-Newton
  int max_line_search_evaluations = 20;
  double update_skip_threshold = 1e-8;  ///< ε of the skip test yᵀs ≤ ε ‖s‖ ‖y‖

  /// Ceres IsValid style: false with the violated constraint (e.g. "c1 < c2") in `error`.
  bool validate(std::string* error) const;
  LineSearchOptions line_search() const;
};

/// The option bindings (common options first): schema, validation and registration.
std::vector<OptionBinding<BfgsOptions>> bfgs_option_bindings();

/// N&W eq. 6.17 on the n × n inverse Hessian H. Returns false and leaves H unchanged when
/// yᵀs ≤ epsilon ‖s‖ ‖y‖.
bool bfgs_update(Eigen::MatrixXd& H, const Eigen::VectorXd& s, const Eigen::VectorXd& y,
                 double epsilon);

class Bfgs : public Optimizer {
 public:
  /// Throws InputError when options.validate() fails.
  explicit Bfgs(BfgsOptions options = {});

  std::string name() const override { return "bfgs"; }
  Options resolved_options() const override;
  const BfgsOptions& options() const { return options_; }

 protected:
  void run(CountedProblem& problem, Eigen::VectorXd x, OptimizerResult& result) const override;

 private:
  BfgsOptions options_;
};

}  // namespace twill
