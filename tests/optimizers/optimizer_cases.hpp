#pragma once
// The optimiser configurations every optimiser test runs (one test matrix, PolyFEM style),
// taken from the registry: every registered optimiser at its defaults, and once more for each
// other value of each of its choice options (Gauss-Newton's damping, the NLopt algorithm,
// Ipopt's strategies). A newly registered optimiser or choice joins the matrix unedited.
#include <memory>
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"
#include "tests/support/program_registry.hpp"

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
    return create_registered<OptimizerFactories>(registry_category::kOptimizer, name, all);
  }
};

/// Settings a configuration needs to reach the matrix's accuracy, and whether it uses no
/// gradients (NLopt's names say so: LN_ / GN_ are derivative-free).
inline void tune(OptimizerCase& c, const std::string& setting) {
  // MMA's conservative approximations creep along the Rosenbrock valley: ~9000 evaluations,
  // and only the step test stops it (docs/optimizers.md).
  // CCSAQ is of the same family (conservative convex separable approximations).
  if (setting == "algorithm=LD_MMA" || setting == "algorithm=LD_CCSAQ")
    c.overrides.insert(c.overrides.end(), {"step_tolerance=1e-10", "max_evaluations=20000"});
  if (setting.rfind("algorithm=", 0) == 0 && setting.size() > 11 && setting[11] == 'N') {
    c.derivative_free = true;
    // Derivative-free: BOBYQA's trust region must shrink to ~1e-10 to pin x to 1e-6.
    c.overrides.insert(c.overrides.end(), {"step_tolerance=1e-10", "max_evaluations=20000"});
  }
}

inline std::vector<OptimizerCase> optimizer_cases() {
  std::vector<OptimizerCase> cases;
  for (const auto& entry : program_registry().find_category(registry_category::kOptimizer)->entries()) {
    OptimizerCase defaults{entry.name, entry.name, {}};
    for (const auto& spec : entry.options.options())
      if (spec.type == OptionType::String && !spec.allowed.empty())
        tune(defaults, spec.name + "=" + std::get<std::string>(spec.default_value));
    cases.push_back(defaults);
    for (const auto& spec : entry.options.options()) {
      if (spec.type != OptionType::String) continue;
      for (const auto& value : spec.allowed) {
        if (value == std::get<std::string>(spec.default_value)) continue;
        const std::string setting = spec.name + "=" + value;
        OptimizerCase c{entry.name + " " + setting, entry.name, {setting}};
        tune(c, setting);
        cases.push_back(c);
      }
    }
  }
  return cases;
}

}  // namespace twill::testing
