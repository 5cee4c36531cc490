// Stage `final-curves`: each fit run's curve at the final parameters (the report's fit table,
// Figs. 2–3), at the level its stage's last fit ran (`level: stage`; a stage the resolution
// ladder settled has shown that a finer level changes its membrane response by less than the
// ladder's tolerance, so simulating it there again costs a continuation per strip and tells
// nothing the ladder did not) or at the finest level any stage reached (`level: finest`). A run
// whose last predictor ran at its level is re-evaluated by it, warm-started from the states of
// its last evaluation (the parameters changed at most by later stages: the bend stage's τ
// rescaling leaves the planar strip's membrane unchanged, a finer bias refit moves G12 by a
// fraction of a percent, so the guesses are at or next to the equilibria); the others are
// simulated along their schedules (StripCurves), in parallel with those.
#include <tbb/parallel_invoke.h>

#include <map>

#include "core/option_binding.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"
#include "fitting/strip_curves.hpp"

namespace twill {
namespace {

// The values of `level`.
constexpr const char* kAtStageLevel = "stage";
constexpr const char* kAtFinestLevel = "finest";

struct FinalCurvesOptions {
  bool warm_start = true;
  std::string level = kAtStageLevel;
  bool validate(std::string* error) const;
};

OptionBindings<FinalCurvesOptions> final_curves_bindings() {
  using S = FinalCurvesOptions;
  return {bool_option<S>("warm_start", &S::warm_start,
                         "re-evaluate each run from the states of its stage's last fit when that ran at the "
                         "run's level (false: simulate every run along its schedule)"),
          choice_option<S>("level", &S::level, {kAtStageLevel, kAtFinestLevel},
                           "where each run is simulated: the level its stage's last fit ran (a stage the "
                           "resolution ladder settled stays there), or the finest level any stage reached")};
}

bool FinalCurvesOptions::validate(std::string* error) const {
  return check_options(final_curves_bindings(), *this, error);
}

class FinalCurves final : public FitStage {
 public:
  explicit FinalCurves(FinalCurvesOptions options) : options_(options) {}
  std::string title() const override { return "final curves"; }

  void run(FitContext& context, FitReport& out) override {
    const std::vector<int> levels = run_levels(context);
    const std::vector<std::optional<Eigen::VectorXd>> forces = final_forces(context, levels);
    for (size_t r = 0; r < context.fit_runs.size(); ++r) {
      const RunData& d = context.fit_runs[r];
      if (!forces[r]) {
        context.note("final curve of " + FitContext::run_label(d) + " did not converge");
        continue;
      }
      FitCurve c = FitContext::curve_record(d, "fit", d.specimen_scale * *forces[r]);
      c.delta_theta_deg = FitContext::strip_offset(d);
      c.specimen_scale = d.specimen_scale;
      const TensileSetup setup = context.setup_for(*d.test, levels[r]);
      c.resolution = FitContext::resolution_text(setup.cells_across, setup.cells_along);
      if (const CurveStage* stage = context.fitted_curve_at(d.test->angle_deg))
        c.degree = (context.params.*(stage->term->curve_member)).degree();
      out.fit.push_back(c);
    }
  }

 private:
  /// The level each fit run is simulated at (`level`).
  std::vector<int> run_levels(const FitContext& context) const {
    std::vector<int> levels;
    for (const RunData& d : context.fit_runs) {
      const auto last = context.last_predictor.find(&d);
      const bool at_stage = options_.level == kAtStageLevel && last != context.last_predictor.end();
      levels.push_back(at_stage ? last->second.first : context.finest_level);
    }
    return levels;
  }

  /// Each fit run's forces at the final parameters (nullopt where no solve converged): warm
  /// predictors and simulated curves in parallel, then a failed warm start simulated after all.
  std::vector<std::optional<Eigen::VectorXd>> final_forces(const FitContext& context,
                                                           const std::vector<int>& levels) const {
    const size_t n = context.fit_runs.size();
    std::vector<std::shared_ptr<Experiment>> warm(n);
    std::vector<size_t> cold;
    for (size_t r = 0; r < n; ++r) {
      const auto last = context.last_predictor.find(&context.fit_runs[r]);
      if (options_.warm_start && last != context.last_predictor.end() && last->second.first == levels[r])
        warm[r] = last->second.second;
      else
        cold.push_back(r);
    }
    std::vector<std::optional<Eigen::VectorXd>> forces(n);
    tbb::parallel_invoke(
        [&] {
          for (size_t r = 0; r < n; ++r) {
            Eigen::VectorXd values;
            std::string message;
            if (warm[r] && warm[r]->predict(context.params, {}, &values, nullptr, &message)) forces[r] = values;
          }
        },
        [&] { simulate(context, levels, cold, &forces); });
    std::vector<size_t> retry;
    for (size_t r = 0; r < n; ++r)
      if (warm[r] && !forces[r]) retry.push_back(r);
    simulate(context, levels, retry, &forces);
    return forces;
  }

  /// Simulates the runs `which` along their schedules, each at its level (StripCurves).
  static void simulate(const FitContext& context, const std::vector<int>& levels, const std::vector<size_t>& which,
                       std::vector<std::optional<Eigen::VectorXd>>* forces) {
    std::map<int, std::vector<size_t>> by_level;
    for (size_t r : which) by_level[levels[r]].push_back(r);
    StripCurves curves;
    for (const auto& [level, runs] : by_level) {
      std::vector<StripCurves::Request> requests;
      for (size_t r : runs) requests.push_back({&context.fit_runs[r], FitContext::strip_angle(context.fit_runs[r])});
      const auto simulated = curves.simulate(context, requests, level);
      for (size_t i = 0; i < runs.size(); ++i)
        if (simulated[i]) (*forces)[runs[i]] = simulated[i]->force_N;
    }
  }

  FinalCurvesOptions options_;
};

}  // namespace

void register_final_curves_stage(FitStageFactories& stages) {
  stages.add_bound<FinalCurves>("final-curves", "every fit run simulated at the final parameters, at its stage's level or the finest",
                                final_curves_bindings());
}

}  // namespace twill
