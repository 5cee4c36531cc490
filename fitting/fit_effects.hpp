#pragma once
// The fit's side of the model's effects (effects/effect.hpp, docs/effects.md): which effect
// turns a strip by its per-run value (the validation stage's angle offsets), the data each
// configured effect needs, and the effects' parameters after the fit.
#include <memory>
#include <vector>

#include "effects/effect.hpp"
#include "fitting/fit_context.hpp"

namespace twill {

/// Whether an effect's per-run parameter is the strip's angle offset (its set-up hook turns
/// the angle by its one per-run value).
bool is_angle_offset(const Effect& effect);

/// The configured angle-offset effect, or the registry's misalignment with its defaults: the
/// validation stage turns its strips through this effect's set-up hook (§7's Δθ).
std::shared_ptr<const Effect> angle_offset_effect(const FitContext& context);

/// A spread needs at least two strips cut alike (Misalignment::missing_data asks the same of the
/// fit runs): with fewer validation strips their offsets are pooled with the fit runs', and the
/// misalignment effect-fit is judged on the fit runs instead of the validation strips.
constexpr size_t kValidationStripsForASpread = 2;
/// Throws InputError (key effects[i]) when a configured effect cannot be fitted to the dataset.
void check_effects_data(const Dataset& dataset, const FitConfig& config, const Registry& registry);

/// The fitted model's effects: an angle-offset effect's model parameters estimated from the
/// validation offsets — alone when there are at least two, else pooled with the fit runs' (its
/// per-run values, where its effect-fit turned them); any other effect keeps the parameters its
/// effect-fit stage fitted (or, without one, its configured ones), which a note says.
std::vector<ComponentChoice> estimate_effects(FitContext& context, const std::vector<FitCurve>& validation);

}  // namespace twill
