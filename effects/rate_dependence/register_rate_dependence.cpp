#include "effects/rate_dependence/register_rate_dependence.hpp"

#include "effects/rate_dependence/rate_dependence.hpp"

namespace twill {

void register_rate_dependence(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add_bound<RateDependence>(RateDependence::kName,
                                 "viscoelastic overstress: a Maxwell branch per deformation mode, force depends on speed",
                                 rate_dependence_bindings());
}

}  // namespace twill
