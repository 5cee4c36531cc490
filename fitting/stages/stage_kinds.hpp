#pragma once
// The stage kinds of fitting/stages/, one file each; register_fit_stages() (register_stages.cpp)
// calls every function here.
#include "fitting/fit_stage.hpp"

namespace twill {

void register_initial_guess_stage(FitStageFactories& stages);
void register_tensile_curve_stage(FitStageFactories& stages);
void register_strain_cutoff_stage(FitStageFactories& stages);
void register_resolution_ladder_stage(FitStageFactories& stages);
void register_bend_stage(FitStageFactories& stages);
void register_final_curves_stage(FitStageFactories& stages);
void register_validation_stage(FitStageFactories& stages);
void register_effect_fit_stage(FitStageFactories& stages);
void register_start_from_stage(FitStageFactories& stages);

}  // namespace twill
