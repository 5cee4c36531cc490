#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "catmull-clark-kl" in the discretization category.
void register_catmull_clark_kl(Registry& registry);
}  // namespace twill
