#include "discretizations/catmull_clark_kl/register_catmull_clark_kl.hpp"

#include "core/discretization_registry.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"

namespace twill {

void register_catmull_clark_kl(Registry& registry) {
  registry.category<DiscretizationFactories>(registry_category::kDiscretization)
      .add_bound<CatmullClarkKL>("catmull-clark-kl",
                                 "Kirchhoff-Love thin shell on Catmull-Clark limit surfaces (OpenSubdiv)",
                                 catmull_clark_kl_option_bindings());
}

}  // namespace twill
