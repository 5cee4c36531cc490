#include "app/program_registry.hpp"

#include "discretizations/catmull_clark_kl/register_catmull_clark_kl.hpp"
#include "discretizations/triangle_shell/register_triangle_shell.hpp"
#include "effects/register_effects.hpp"
#include "experiments/register_experiments.hpp"
#include "fitting/fit_stage.hpp"
#include "optimizers/register_optimizers.hpp"

namespace twill {

void register_program(Registry& registry) {
  // ---- One call per module (core/registry.hpp says how to write one) ------------------------
  register_catmull_clark_kl(registry);
  register_triangle_shell(registry);
  register_optimizers(registry);
  register_experiments(registry);
  register_effects(registry);
  register_fit_stages(registry);
  // -------------------------------------------------------------------------------------------
}

}  // namespace twill
