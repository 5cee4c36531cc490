#include "effects/hysteresis/register_hysteresis.hpp"

#include "effects/hysteresis/hysteresis.hpp"

namespace twill {

void register_hysteresis(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add_bound<Hysteresis>(Hysteresis::kName,
                             "internal friction: Dahl friction per deformation mode, loading and unloading differ",
                             hysteresis_bindings());
}

}  // namespace twill
