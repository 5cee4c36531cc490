#include "fitting/fit_effects.hpp"

#include "core/input_error.hpp"
#include "effects/misalignment.hpp"

namespace twill {

bool is_angle_offset(const Effect& effect) {
  if (effect.per_run_parameters().size() != 1) return false;
  ExperimentInput probe;
  const std::vector<SetupChange> changes = effect.adjust_setup(Eigen::VectorXd::Ones(1), &probe);
  return changes.size() == 1 && changes[0].quantity == setup_quantity::kAngle && changes[0].gradient.size() == 1 &&
         changes[0].gradient[0] == 1.0;
}

std::shared_ptr<const Effect> angle_offset_effect(const FitContext& context) {
  for (const auto& e : context.effects)
    if (is_angle_offset(*e)) return e;
  const RegistryEntry& entry = context.registry().find_category(registry_category::kEffect)->at(Misalignment::kName);
  return context.registry().create<EffectFactories>(
      registry_category::kEffect,
      ComponentChoice{registry_category::kEffect, entry.name, default_options(entry.options, nullptr)});
}

void check_effects_data(const Dataset& dataset, const FitConfig& config, const Registry& registry) {
  for (size_t i = 0; i < config.effects.size(); ++i) {
    const auto effect = registry.create<EffectFactories>(registry_category::kEffect, config.effects[i]);
    const std::string missing = effect->missing_data(dataset);
    if (!missing.empty())
      throw InputError({"", 0, "effects[" + std::to_string(i) + "]"}, "effect '" + config.effects[i].name +
                                                                          "' cannot be fitted to dataset '" +
                                                                          dataset.name + "': " + missing);
  }
}

namespace {

// The offsets an angle-offset effect's model parameters are estimated from
// (docs/effects/misalignment.md, "Which offsets the spread is estimated from"): the validation
// strips' alone when there are enough of them — off the material axes a cut moves the force to
// first order and each strip's offset is its own — else those and the fit runs' (where the
// misalignment effect-fit turned them: nearly even in Δθ and put in a gauge, weak evidence).
std::vector<Eigen::VectorXd> spread_evidence(FitContext& context, const std::string& effect,
                                             const std::vector<FitCurve>& validation) {
  std::vector<Eigen::VectorXd> offsets;
  for (const FitCurve& c : validation) offsets.push_back(Eigen::VectorXd::Constant(1, c.delta_theta_deg));
  if (validation.size() >= kValidationStripsForASpread) {
    context.note("effect " + effect + ": estimated from the " + std::to_string(validation.size()) +
                 " validation offsets alone (fit-run offsets are second order in the forces near an axis "
                 "and relative to their test's gauge)");
    return offsets;
  }
  int turned_fit_runs = 0;
  for (const RunData& d : context.fit_runs)
    if (d.strip_angle_deg) {
      offsets.push_back(Eigen::VectorXd::Constant(1, FitContext::strip_offset(d)));
      ++turned_fit_runs;
    }
  context.note("effect " + effect + ": estimated from the " + std::to_string(validation.size()) +
               " validation offsets and " + std::to_string(turned_fit_runs) +
               " fit-run offsets (misalignment effect-fit)");
  return offsets;
}

}  // namespace

std::vector<ComponentChoice> estimate_effects(FitContext& context, const std::vector<FitCurve>& validation) {
  std::vector<ComponentChoice> fitted_effects;
  for (size_t i = 0; i < context.effects.size(); ++i) {
    ComponentChoice fitted = context.params.effects.at(i);  // as the effect-fit stages left it
    if (is_angle_offset(*context.effects[i]) && !validation.empty()) {
      fitted.options = context.effects[i]->estimated_from_runs(spread_evidence(context, fitted.name, validation),
                                                               fitted.options);
    } else {
      context.note("effect " + fitted.name + ": parameters " +
                   (fitted == context.config().effects[i] ? "as configured (no stage fitted them)"
                                                          : "as the effect-fit stage left them"));
    }
    fitted_effects.push_back(fitted);
  }
  return fitted_effects;
}

}  // namespace twill
