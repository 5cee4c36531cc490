#pragma once
// Gauss–Newton on the least-squares form f(x) = Σ_i r_i(x)² = ‖r‖² (core/problem.hpp), ∇f = 2Jᵀr.
//
// The step h minimises the linearised model m(h) = ‖r + J h‖² (+ damping), computed by a
// column-pivoted QR of J (or of the damped augmented matrix), never by forming JᵀJ, so that
// the condition number is not squared (Nocedal & Wright, 2nd ed., §10.2–10.3).
//
// damping = none: h = argmin ‖r + J h‖² (a basic least-squares solution when J is rank
//   deficient), then a backtracking Armijo line search on φ(α) = f(x + α h), starting at α = 1,
//   trial steps from the safeguarded quadratic interpolation in [0.1 α, 0.5 α]
//   (N&W Alg. 3.1 with §3.5's interpolation).
// damping = levenberg-marquardt: h = argmin ‖r + J h‖² + λ ‖D h‖², D² = diag(JᵀJ) (Marquardt's
//   scaling: invariant to rescaling a parameter; diagonal entries below 1e-12 · max are raised
//   to that floor so that an unidentified parameter still gets a finite step). λ adapts with
//   Nielsen's rule (H. B. Nielsen, "Damping parameter in Marquardt's method", IMM-REP-1999-05,
//   DTU 1999; also Madsen, Nielsen & Tingleff, "Methods for non-linear least squares problems",
//   2004, §3.2): with gain ratio ρ = (f(x) − f(x+h)) / (m(0) − m(h)),
//   a step with ρ > 0 is accepted and λ ← λ · max(1/3, 1 − (2ρ − 1)³), ν ← 2; otherwise
//   λ ← λ ν, ν ← 2ν and the step is recomputed. λ above max_lambda ends the run (stalled).
//   λ₀ = initial_lambda; with max_first_step > 0 raised (before any trial) until the first
//   step is at most that long in x, the rule of BFGS's first step (bfgs.hpp) and Ipopt's. Off
//   by default: on a degree-3 recovery from a perturbed start (fixed degree) it led to another
//   local minimum (stiffness +1.3 %); the fit's degree raises switch it on (docs/fitting.md §3b).
//
// Bounds (both dampings) by rejection, like bfgs.hpp: variables at a bound whose gradient
// pushes outward are held fixed for the step (their columns are dropped from J), remaining
// blocked components are dropped, and the step is truncated at the box. If the result is not a
// descent direction, the projected steepest-descent direction scaled to its model minimiser is
// used instead.
//
// Cost: every trial point is evaluated with its Jacobian (in twill the Jacobian costs little
// once the residuals are computed, core/problem.hpp), so an accepted trial needs no second
// evaluation. Iterations count accepted steps; rejected LM trials count as evaluations only.
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"

namespace twill {

enum class GaussNewtonDamping { none, levenberg_marquardt };

struct GaussNewtonOptions : OptimizerOptions {
  GaussNewtonDamping damping = GaussNewtonDamping::levenberg_marquardt;
  double initial_lambda = 1e-3;  ///< λ₀ (relative: D is scaled by diag(JᵀJ))
  double max_lambda = 1e16;      ///< stalled when λ exceeds this
  double max_first_step = 0.0;   ///< LM: λ₀ raised until the first step is at most this long (0: off)
  double c1 = 1e-4;              ///< Armijo constant of the backtracking line search (none)
  int max_line_search_evaluations = 30;

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null).
  bool validate(std::string* error) const;
};

std::vector<OptionBinding<GaussNewtonOptions>> gauss_newton_option_bindings();

class GaussNewton : public Optimizer {
 public:
  /// Throws InputError when options.validate() fails.
  explicit GaussNewton(GaussNewtonOptions options = {});

  std::string name() const override { return "gauss-newton"; }
  Options resolved_options() const override;
  bool requires_residuals() const override { return true; }
  const GaussNewtonOptions& options() const { return options_; }

 protected:
  void run(CountedProblem& problem, Eigen::VectorXd x, OptimizerResult& result) const override;

 private:
  GaussNewtonOptions options_;
};

}  // namespace twill
