#pragma once
// Registration of the experiments (experiment.hpp) in the program's registry.
#include "core/registry.hpp"

namespace twill {

/// Registers "tensile", "validation" and "bend" in the experiment category.
void register_experiments(Registry& registry);

}  // namespace twill
