#pragma once
// Construction of an optimiser by its registered name from a name → value option map, and the
// catalogue of optimisers with their option schemas as plain data (for the registry and for
// documentation). Names: "bfgs", "gauss-newton", "ipopt", "nlopt".
#include <memory>
#include <string>
#include <vector>

#include "optimizers/optimizer.hpp"

namespace twill {

struct OptimizerInfo {
  std::string name;
  std::string description;                 ///< one line
  std::vector<OptionDescription> options;  ///< common options first, defaults filled in
};

/// Every optimiser this module provides, in a fixed order.
std::vector<OptimizerInfo> optimizer_catalogue();
std::vector<std::string> optimizer_names();

/// The optimiser `name` with defaults overridden by `options`. Throws InputError: an unknown
/// name (key "optimizer", listing the known names), an unknown option (key = the option,
/// listing the known options), a wrong type or a violated range or constraint.
std::unique_ptr<Optimizer> make_optimizer(const std::string& name,
                                          const OptionValues& options = {});

}  // namespace twill
