#include "effects/bending_anisotropy/register_bending_anisotropy.hpp"

#include "effects/bending_anisotropy/bending_anisotropy.hpp"

namespace twill {

void register_bending_anisotropy(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add_bound<BendingAnisotropy>(BendingAnisotropy::kName,
                                    "a bending stiffness factor per direction (warp, weft) on the Kirchhoff-Love bending energy",
                                    bending_anisotropy_bindings());
}

}  // namespace twill
