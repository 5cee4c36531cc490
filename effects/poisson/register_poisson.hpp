#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "poisson" in the effect category.
void register_poisson(Registry& registry);
}  // namespace twill
