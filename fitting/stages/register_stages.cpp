#include "fitting/stages/stage_kinds.hpp"

namespace twill {

void register_fit_stages(Registry& registry) {
  FitStageFactories& stages = registry.category<FitStageFactories>(registry_category::kStage);
  register_initial_guess_stage(stages);
  register_tensile_curve_stage(stages);
  register_strain_cutoff_stage(stages);
  register_resolution_ladder_stage(stages);
  register_bend_stage(stages);
  register_final_curves_stage(stages);
  register_validation_stage(stages);
  register_effect_fit_stage(stages);
  register_start_from_stage(stages);
}

}  // namespace twill
