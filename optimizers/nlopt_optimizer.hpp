#pragma once
// Adapter to NLopt 2.7 (https://nlopt.readthedocs.io), the algorithm chosen by its NLopt name.
//
// Supported algorithms (supported_nlopt_algorithms()):
//   gradient-based   LD_LBFGS, LD_SLSQP, LD_MMA, LD_CCSAQ, LD_TNEWTON_PRECOND_RESTART, LD_VAR2
//   derivative-free  LN_BOBYQA, LN_COBYLA, LN_NELDERMEAD, LN_SBPLX
// Gradient-based (LD_) algorithms get value and gradient from every evaluation, even where
// NLopt asks for the value alone (SLSQP does); derivative-free (LN_) ones never ask for it; they
// need many more evaluations and reach the minimum only to the accuracy their trust region /
// simplex allows, so compare them with looser tolerances (docs/optimizers.md gives the measured
// accuracy).
//
// - Bounds are passed to NLopt as they are (±∞ where absent).
// - Tolerances: function_tolerance → ftol_rel, step_tolerance → xtol_rel, max_evaluations →
//   maxeval. gradient_tolerance is tested by the adapter at every gradient evaluation (NLopt
//   has no such test) and stops NLopt with status converged. NLopt has no iterations, so
//   max_iterations is not used (max_evaluations is the budget); the trace and the summary's
//   `iterations` count the evaluations that improved the best value so far.
//   NLopt's own ftol_rel / xtol_rel tests are reported as converged, as for the other
//   optimisers; with derivative-free or MMA-type algorithms they can trigger far from a
//   minimum on badly scaled problems (docs/optimizers.md lists measured cases).
// - Exceptions never cross into NLopt's C code: the objective wrapper catches everything,
//   remembers the message and throws nlopt::forced_stop, which NLopt's C++ wrapper turns into
//   a graceful stop; the run ends with status failed and the caught message.
// - A failed (non-finite) evaluation: NLopt has no protocol for rejecting a trial point, so the
//   adapter stops NLopt and restarts it from the best point inside a box of half-width
//   r = ½‖x_failed − x_best‖∞ around it (a trust region passed as bounds); a run that ends on
//   the box's edge continues with the box grown ×4. At most 20 restarts, all within
//   max_evaluations. (Measured need: LD_LBFGS's first step on a cloth fit jumps to the lower
//   stiffness bound, where the material is invalid.)
// - result.x is the best point evaluated; final_gradient_norm is NaN for derivative-free
//   algorithms (no gradient is ever computed).
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"

namespace twill {

/// The NLopt algorithm names this adapter accepts.
std::vector<std::string> supported_nlopt_algorithms();

struct NloptOptions : OptimizerOptions {
  std::string algorithm = "LD_LBFGS";  ///< one of supported_nlopt_algorithms()
  /// Initial step of derivative-free algorithms (trust-region radius / simplex size) in units
  /// of x; 0 lets NLopt choose (from the bounds, or |x0|).
  double initial_step = 0.0;
  /// Vector storage of LD_LBFGS, LD_VAR2, LD_TNEWTON: 0 lets NLopt choose.
  int vector_storage = 0;

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null).
  bool validate(std::string* error) const;
};

std::vector<OptionBinding<NloptOptions>> nlopt_option_bindings();

class NloptOptimizer : public Optimizer {
 public:
  /// Throws InputError when options.validate() fails (an unknown algorithm lists the
  /// supported ones).
  explicit NloptOptimizer(NloptOptions options = {});

  std::string name() const override { return "nlopt"; }
  Options resolved_options() const override;
  const NloptOptions& options() const { return options_; }

 protected:
  void run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const override;

 private:
  NloptOptions options_;
};

}  // namespace twill
