#include "app/program_registry.hpp"

#include "app/program_parts.hpp"  // generated: every module's and part's register_*.hpp (cmake/TwillParts.cmake)

namespace twill {

void register_program(Registry& registry) {
  // One call per module or part folder; a new part adds its call to its category's group
  // (docs/extending.md).

  // discretization
  register_catmull_clark_kl(registry);
  register_triangle_shell(registry);

  // optimizer
  register_optimizers(registry);

  // experiment
  register_experiments(registry);

  // effect
  register_effects(registry);
  register_hysteresis(registry);
  register_poisson(registry);
  register_rate_dependence(registry);
  register_bending_anisotropy(registry);

  // stage
  register_fit_stages(registry);
}

}  // namespace twill
