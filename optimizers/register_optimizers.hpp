#pragma once
// Registration of the optimisers ("bfgs", "gauss-newton", "ipopt", "nlopt") in the program's
// registry (core/registry.hpp): each is registered once, with its option bindings
// (core/option_binding.hpp) as its schema and its factory. Create them through the registry:
//
//   auto& optimizers = registry.category<OptimizerFactories>(registry_category::kOptimizer);
//   auto bfgs = optimizers.create_with_defaults("bfgs");
#include "core/registry.hpp"

namespace twill {

/// Registers every optimiser of this module in the registry's optimizer category.
void register_optimizers(Registry& registry);

}  // namespace twill
