#pragma once
// The optimiser configurations every optimiser test runs (one test matrix, PolyFEM style).
#include <string>
#include <vector>

#include "optimizers/option_schema.hpp"

namespace twill::testing {

struct OptimizerCase {
  std::string label;
  std::string name;  ///< registered name for make_optimizer
  OptionValues options;
  bool derivative_free = false;
};

inline std::vector<OptimizerCase> optimizer_cases() {
  return {
      {"bfgs", "bfgs", {}},
      {"gauss-newton (none)", "gauss-newton", {{"damping", std::string("none")}}},
      {"gauss-newton (LM)", "gauss-newton", {{"damping", std::string("levenberg-marquardt")}}},
      {"ipopt", "ipopt", {}},
      {"nlopt LD_LBFGS", "nlopt", {{"algorithm", std::string("LD_LBFGS")}}},
      {"nlopt LD_SLSQP", "nlopt", {{"algorithm", std::string("LD_SLSQP")}}},
      // MMA's conservative approximations creep along the Rosenbrock valley: ~9000 evaluations,
      // and only the step test stops it (docs/optimizers.md).
      {"nlopt LD_MMA",
       "nlopt",
       {{"algorithm", std::string("LD_MMA")},
        {"step_tolerance", 1e-10},
        {"max_evaluations", 20000}}},
      // Derivative-free: BOBYQA's trust region must shrink to ~1e-10 to pin x to 1e-6.
      {"nlopt LN_BOBYQA",
       "nlopt",
       {{"algorithm", std::string("LN_BOBYQA")},
        {"step_tolerance", 1e-10},
        {"max_evaluations", 20000}},
       true},
  };
}

}  // namespace twill::testing
