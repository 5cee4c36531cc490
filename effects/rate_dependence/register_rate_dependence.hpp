#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "rate-dependence" in the effect category.
void register_rate_dependence(Registry& registry);
}  // namespace twill
