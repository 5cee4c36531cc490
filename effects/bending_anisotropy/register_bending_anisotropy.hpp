#pragma once
#include "core/registry.hpp"

namespace twill {
/// Registers "bending-anisotropy" in the effect category.
void register_bending_anisotropy(Registry& registry);
}  // namespace twill
