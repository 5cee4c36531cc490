// Stage `bend` (paper §5.2 step 7): the thickness τ from the cantilever chord angles at the
// mean measured overhangs, with a ← a·τ0/τ so the tensile fits are unchanged (ParameterMap's
// thickness rescale); optionally the simulated overhang at 41.5° per test (the drape check of
// §6.4). The cantilever is the config's experiments.bend, with its own options (its cells:
// one place to set them); the fit gives it each test's angle and width. Skipped, with a note,
// when the dataset has no bend test.
#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

#include "core/option_binding.hpp"
#include "effects/effect_experiment.hpp"
#include "experiments/cantilever.hpp"
#include "experiments/predictors.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct BendStageOptions {
  bool find_overhang = true;
  bool fit_thickness = true;
  bool validate(std::string* error) const;
};

OptionBindings<BendStageOptions> bend_stage_bindings() {
  using S = BendStageOptions;
  return {bool_option<S>("find_overhang", &S::find_overhang,
                         "also report the simulated overhang at 41.5 degrees (the bend experiment's search)"),
          bool_option<S>("fit_thickness", &S::fit_thickness,
                         "fit the thickness (false: only the chord angles and overhangs at the current parameters, "
                         "e.g. after a start-from stage)")};
}

bool BendStageOptions::validate(std::string* error) const {
  return check_options(bend_stage_bindings(), *this, error);
}

class BendStage final : public FitStage {
 public:
  explicit BendStage(BendStageOptions options) : options_(options) {}
  std::string title() const override { return "bend"; }

  void run(FitContext& context, FitReport& out) override {
    if (context.dataset().bend.empty()) {
      context.note("no bend test: bend stage skipped, the thickness stays at the dataset's");
      return;
    }
    const auto t = Clock::now();
    std::vector<std::shared_ptr<Predictor>> predictors;
    for (const BendTest& b : context.dataset().bend) predictors.push_back(context.bend_experiment(b, context.params));
    ParameterMap::Options map_options;
    map_options.rescale_with_thickness = true;
    MaterialParameters& params = context.params;
    ParameterMap map(params, {"thickness_m"}, map_options);
    FitObjective objective(map, predictors);
    if (!options_.fit_thickness) return report_unfitted(context, objective, map, out);
    objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd& x) {
      context.say(1, fmt::format("  bend it {:3d}: eps {:.4e}, tau {:.4g} mm", it.iteration, it.value,
                                 1e3 * x[0] * params.thickness_m));
    });
    std::unique_ptr<Optimizer> optimizer = context.make_optimizer();
    const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
    if (!std::isfinite(r.summary.final_value))
      throw std::runtime_error("bend stage failed: " + r.message + " / " + objective.last_failure());
    const FitObjective& final_objective = evaluated_at(context, objective, map, r.x);
    params = map.parameters(r.x);
    const FitStageRecord& rec = context.record_stage("bend", resolution(predictors.front()), 0,
                                                     mean_run_error(final_objective, predictors.size()), *optimizer,
                                                     r, objective, t);
    context.say(0, fmt::format("bend: tau {:.4g} mm, error {:.2f} % ({}, {} its)", 1e3 * params.thickness_m,
                               100 * rec.avg_rel_error, rec.status, rec.iterations));
    for (size_t i = 0; i < context.dataset().bend.size(); ++i)
      out.bend.push_back(result(context, context.dataset().bend[i], final_objective.last_predictions()[i][0]));
  }

 private:
  /// The chord angles (and overhangs) at the current parameters, nothing fitted.
  void report_unfitted(FitContext& context, FitObjective& objective, ParameterMap& map, FitReport& out) {
    const FitObjective& at = evaluated_at(context, objective, map, map.initial_x());
    context.say(0, fmt::format("bend (thickness held at {:.4g} mm): error {:.2f} %", 1e3 * context.params.thickness_m,
                               100 * mean_run_error(at, context.dataset().bend.size())));
    for (size_t i = 0; i < context.dataset().bend.size(); ++i)
      out.bend.push_back(result(context, context.dataset().bend[i], at.last_predictions()[i][0]));
  }

  /// `objective` evaluated at the optimiser's final point x. Its predictors keep the states of
  /// their last trial, which may have failed: a re-evaluation that fails from there is tried
  /// once more on fresh experiments (from the flat strip), and a second failure is the stage's
  /// failure. Measured: poplin with Ipopt (2026-12-02, 30a817c) crashed here reading the empty
  /// predictions of such a failed re-evaluation.
  const FitObjective& evaluated_at(const FitContext& context, FitObjective& objective, ParameterMap& map,
                                   const Eigen::VectorXd& x) {
    if (std::isfinite(objective.evaluate(x, nullptr))) return objective;
    std::vector<std::shared_ptr<Predictor>> fresh;
    for (const BendTest& b : context.dataset().bend) fresh.push_back(context.bend_experiment(b, context.params));
    fresh_objective_ = std::make_unique<FitObjective>(map, fresh);
    if (!std::isfinite(fresh_objective_->evaluate(x, nullptr)))
      throw std::runtime_error("bend stage: the optimiser's final thickness could not be evaluated: " +
                               fresh_objective_->last_failure());
    return *fresh_objective_;
  }

  /// The cantilever of the bend experiment (null for another kind, which has no overhang search).
  static CantileverPredictor* cantilever(const std::shared_ptr<Predictor>& p) {
    auto* experiment = dynamic_cast<Experiment*>(p.get());
    return experiment ? dynamic_cast<CantileverPredictor*>(&innermost(*experiment)) : nullptr;
  }
  static std::string resolution(const std::shared_ptr<Predictor>& p) {
    CantileverPredictor* c = cantilever(p);
    return c ? FitContext::resolution_text(c->experiment().setup().cells_across, c->experiment().setup().cells_along)
             : "";
  }

  FitBend result(const FitContext& context, const BendTest& b, double chord_angle_deg) const {
    FitBend fb;
    fb.label = b.label;
    fb.angle_deg = b.angle_deg;
    fb.measured_overhang_mm = mean(b.overhang_mm);
    fb.chord_angle_deg = chord_angle_deg;
    if (!options_.find_overhang) return fb;
    // A fresh experiment at the final parameters (the fitted one's states are the last trial's).
    const std::shared_ptr<Predictor> fresh = context.bend_experiment(b, context.params);
    if (CantileverPredictor* c = cantilever(fresh)) {
      const OverhangSearchResult s = c->experiment().find_overhang(b.chord_angle_deg);
      if (s.converged) fb.overhang_mm = s.overhang_mm;
    }
    return fb;
  }

  BendStageOptions options_;
  std::unique_ptr<FitObjective> fresh_objective_;  ///< evaluated_at()'s second try
};

}  // namespace

void register_bend_stage(FitStageFactories& stages) {
  stages.add_bound<BendStage>("bend", "paper §5.2 step 7: the thickness from the cantilever chord angles",
                              bend_stage_bindings());
}

}  // namespace twill
