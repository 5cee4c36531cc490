#pragma once
// Construction of the optimisers by registered name ("bfgs", "gauss-newton", "ipopt",
// "nlopt"), their catalogue (name, one-line description, option schema as data), and their
// registration in the program's registry (core/registry.hpp).
#include <memory>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/registry.hpp"
#include "optimizers/optimizer.hpp"

namespace twill {

struct OptimizerInfo {
  std::string name;
  std::string description;  ///< one line
  OptionSchema options;     ///< common options first; defaults, ranges, docs
};

/// Every optimiser of this module, in a fixed order.
std::vector<OptimizerInfo> optimizer_catalogue();
std::vector<std::string> optimizer_names();

/// The optimiser `name` built from options resolved against its schema (a config's component
/// choice, or optimizer_options()). Throws InputError for an unknown name (key "optimizer",
/// listing the known names) or a violated cross-option constraint (e.g. c1 < c2), and
/// std::logic_error when `resolved` does not match the schema (a programming error).
std::unique_ptr<Optimizer> make_optimizer(const std::string& name, const Options& resolved);
/// The optimiser `name` with every option at its default.
std::unique_ptr<Optimizer> make_optimizer(const std::string& name);

/// The defaults of `name` with `--set`-style overrides applied ("c2=0.5",
/// "algorithm=LN_BOBYQA"), checked like a config file: an unknown key, a wrong type or an
/// out-of-range value throws InputError naming the key (config.hpp's apply_override).
Options optimizer_options(const std::string& name, const std::vector<std::string>& overrides = {});

/// Registers every optimiser in the registry's optimizer category.
void register_optimizers(Registry& registry);

}  // namespace twill
