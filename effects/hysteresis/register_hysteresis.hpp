#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "hysteresis" in the effect category.
void register_hysteresis(Registry& registry);
}  // namespace twill
