#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "triangle-shell" in the discretization category.
void register_triangle_shell(Registry& registry);
}  // namespace twill
