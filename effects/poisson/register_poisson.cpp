#include "effects/poisson/register_poisson.hpp"

#include "effects/poisson/poisson.hpp"

namespace twill {

void register_poisson(Registry& registry) {
  registry.category<EffectFactories>(registry_category::kEffect)
      .add_bound<Poisson>(Poisson::kName, "a12 free as a ratio of min(a11, a22), identified from lateral strain",
                          poisson_bindings());
}

}  // namespace twill
