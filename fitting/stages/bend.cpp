// Stage `bend` (paper §5.2 step 7): the thickness τ from the cantilever chord angles at the
// mean measured overhangs (config experiments.bend), with a ← a·τ0/τ so the tensile fits are
// unchanged (ParameterMap's thickness rescale); optionally the simulated overhang at 41.5°
// per test (the drape check of §6.4). Skipped, with a note, when the dataset has no bend test.
#include <fmt/format.h>

#include <cmath>
#include <stdexcept>

#include "core/input_limits.hpp"
#include "core/option_binding.hpp"
#include "experiments/cantilever.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct BendStageOptions {
  int cells_across = 4;
  int cells_along = 64;
  bool find_overhang = true;
  bool validate(std::string* error) const;
};

OptionBindings<BendStageOptions> bend_stage_bindings() {
  using S = BendStageOptions;
  return {integer_option<S>("cells_across", &S::cells_across, "cells across the 25 mm strip", at_least(1)),
          integer_option<S>("cells_along", &S::cells_along, "cells along the overhang", at_least(4)),
          bool_option<S>("find_overhang", &S::find_overhang, "also report the simulated overhang at 41.5 degrees")};
}

bool BendStageOptions::validate(std::string* error) const {
  return check_options(bend_stage_bindings(), *this, error);
}

class BendStage final : public FitStage {
 public:
  explicit BendStage(BendStageOptions options) : options_(options) {}
  std::string title() const override { return "bend"; }

  /// Checked even when the dataset has no bend test: the key is wrong either way.
  void check(const ProtocolCheck& check) const override {
    const std::string violation = mesh_size_violation(options_.cells_across, options_.cells_along);
    if (!violation.empty())
      throw InputError(check.locate(check.key + (options_.cells_across > options_.cells_along ? ".cells_across"
                                                                                                : ".cells_along")),
                       "the cantilever: " + violation);
  }

  void run(FitContext& context, FitReport& out) override {
    if (context.dataset().bend.empty()) {
      context.note("no bend test: bend stage skipped, the thickness stays at the dataset's");
      return;
    }
    const auto t = Clock::now();
    std::vector<std::shared_ptr<Predictor>> predictors;
    for (const BendTest& b : context.dataset().bend) predictors.push_back(experiment(context, b));
    ParameterMap::Options map_options;
    map_options.rescale_with_thickness = true;
    MaterialParameters& params = context.params;
    ParameterMap map(params, {"thickness_m"}, map_options);
    FitObjective objective(map, predictors);
    objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd& x) {
      context.say(1, fmt::format("  bend it {:3d}: eps {:.4e}, tau {:.4g} mm", it.iteration, it.value,
                                 1e3 * x[0] * params.thickness_m));
    });
    std::unique_ptr<Optimizer> optimizer = context.make_optimizer();
    const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
    if (!std::isfinite(r.summary.final_value))
      throw std::runtime_error("bend stage failed: " + r.message + " / " + objective.last_failure());
    params = map.parameters(r.x);
    objective.evaluate(r.x, nullptr);
    const FitStageRecord& rec =
        context.record_stage("bend", FitContext::resolution_text(options_.cells_across, options_.cells_along), 0,
                             mean_run_error(objective, predictors.size()), *optimizer, r, objective, t);
    context.say(0, fmt::format("bend: tau {:.4g} mm, error {:.2f} % ({}, {} its)", 1e3 * params.thickness_m,
                               100 * rec.avg_rel_error, rec.status, rec.iterations));
    for (size_t i = 0; i < context.dataset().bend.size(); ++i)
      out.bend.push_back(result(context, context.dataset().bend[i], objective.last_predictions()[i][0]));
  }

 private:
  CantileverSetup setup(const BendTest& b) const {
    CantileverSetup s;
    s.angle_deg = b.angle_deg;
    s.width_mm = b.width_mm;
    s.cells_across = options_.cells_across;
    s.cells_along = options_.cells_along;
    return s;
  }

  /// A bend test's experiment at the mean measured overhang (config experiments.bend),
  /// predicting the measured chord angle.
  std::shared_ptr<Experiment> experiment(const FitContext& context, const BendTest& b) const {
    const CantileverSetup s = setup(b);
    ExperimentInput input =
        context.experiment_input(b.label, s.angle_deg, s.width_mm, s.cells_across, s.cells_along, context.params);
    input.schedule = {mean(b.overhang_mm)};
    input.measured = Eigen::VectorXd::Constant(1, b.chord_angle_deg);
    return context.registry().create<ExperimentFactories>(registry_category::kExperiment,
                                                          context.config().bend_experiment, input);
  }

  FitBend result(const FitContext& context, const BendTest& b, double chord_angle_deg) const {
    FitBend fb;
    fb.label = b.label;
    fb.angle_deg = b.angle_deg;
    fb.measured_overhang_mm = mean(b.overhang_mm);
    fb.chord_angle_deg = chord_angle_deg;
    if (options_.find_overhang) {
      CantileverExperiment e(setup(b), context.discretization(), context.params, context.solver());
      const OverhangSearchResult s = e.find_overhang(b.chord_angle_deg);
      if (s.converged) fb.overhang_mm = s.overhang_mm;
    }
    return fb;
  }

  BendStageOptions options_;
};

}  // namespace

void register_bend_stage(FitStageFactories& stages) {
  stages.add_bound<BendStage>("bend", "paper §5.2 step 7: the thickness from the cantilever chord angles",
                              bend_stage_bindings());
}

}  // namespace twill
