#pragma once
// Registration of the effects (effect.hpp) in the program's registry.
#include "core/registry.hpp"

namespace twill {

/// Registers every effect of this module (today: misalignment) in the effect category.
void register_effects(Registry& registry);

}  // namespace twill
