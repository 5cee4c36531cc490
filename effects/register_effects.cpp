#include "effects/register_effects.hpp"

#include <memory>

#include "effects/misalignment.hpp"

namespace twill {

void register_effects(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add(Misalignment::kName, "strips cut at per-run angle offsets with a shared spread (paper §7's Δθ)",
           Misalignment::schema(), [](const Options& o) -> std::unique_ptr<Effect> {
             return std::make_unique<Misalignment>(o.get_double("spread_deg"));
           });
}

}  // namespace twill
