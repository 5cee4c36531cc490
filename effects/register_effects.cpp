#include "effects/register_effects.hpp"

#include <memory>

#include "effects/misalignment.hpp"

namespace twill {

void register_effects(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add_bound<Misalignment>(Misalignment::kName,
                               "strips cut at per-run angle offsets with a shared spread (paper §7's Δθ)",
                               misalignment_bindings());
}

}  // namespace twill
