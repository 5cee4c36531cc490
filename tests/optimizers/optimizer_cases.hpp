#pragma once
// The optimiser configurations every optimiser test runs (one test matrix, PolyFEM style).
#include <memory>
#include <string>
#include <vector>

#include "optimizers/optimizer_factory.hpp"

namespace twill::testing {

struct OptimizerCase {
  std::string label;
  std::string name;                    ///< registered name
  std::vector<std::string> overrides;  ///< `--set`-style, e.g. "c2=0.5"
  bool derivative_free = false;

  /// The optimiser: its defaults with `overrides` and then `extra` applied.
  std::unique_ptr<Optimizer> make(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> all = overrides;
    all.insert(all.end(), extra.begin(), extra.end());
    return make_optimizer(name, optimizer_options(name, all));
  }
};

inline std::vector<OptimizerCase> optimizer_cases() {
  return {
      {"bfgs", "bfgs", {}},
      {"gauss-newton (none)", "gauss-newton", {"damping=none"}},
      {"gauss-newton (LM)", "gauss-newton", {"damping=levenberg-marquardt"}},
      {"ipopt", "ipopt", {}},
      {"nlopt LD_LBFGS", "nlopt", {"algorithm=LD_LBFGS"}},
      {"nlopt LD_SLSQP", "nlopt", {"algorithm=LD_SLSQP"}},
      // MMA's conservative approximations creep along the Rosenbrock valley: ~9000 evaluations,
      // and only the step test stops it (docs/optimizers.md).
      {"nlopt LD_MMA",
       "nlopt",
       {"algorithm=LD_MMA", "step_tolerance=1e-10", "max_evaluations=20000"}},
      // Derivative-free: BOBYQA's trust region must shrink to ~1e-10 to pin x to 1e-6.
      {"nlopt LN_BOBYQA",
       "nlopt",
       {"algorithm=LN_BOBYQA", "step_tolerance=1e-10", "max_evaluations=20000"},
       true},
  };
}

}  // namespace twill::testing
