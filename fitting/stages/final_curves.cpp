// Stage `final-curves`: each fit run's curve at the final parameters and the finest level any
// stage reached (the report's fit table, Figs. 2–3). A run whose stage ended at that level is
// re-evaluated by its last predictor, warm-started from the states of its last evaluation (the
// parameters changed at most by the bend stage's τ rescaling, which leaves the planar strip's
// membrane unchanged, so the guesses are the equilibria); the others are simulated along their
// schedules (StripCurves), in parallel with those.
#include <tbb/parallel_invoke.h>

#include "core/option_binding.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"
#include "fitting/strip_curves.hpp"

namespace twill {
namespace {

struct FinalCurvesOptions {
  bool warm_start = true;
  bool validate(std::string* error) const;
};

OptionBindings<FinalCurvesOptions> final_curves_bindings() {
  using S = FinalCurvesOptions;
  return {bool_option<S>("warm_start", &S::warm_start,
                         "re-evaluate runs whose stage ended at the finest level from their last states "
                         "(false: simulate every run along its schedule)")};
}

bool FinalCurvesOptions::validate(std::string* error) const {
  return check_options(final_curves_bindings(), *this, error);
}

class FinalCurves final : public FitStage {
 public:
  explicit FinalCurves(FinalCurvesOptions options) : options_(options) {}
  std::string title() const override { return "final curves"; }

  void run(FitContext& context, FitReport& out) override {
    const std::vector<std::optional<Eigen::VectorXd>> forces = final_forces(context);
    for (size_t r = 0; r < context.fit_runs.size(); ++r) {
      const RunData& d = context.fit_runs[r];
      if (!forces[r]) {
        context.note("final curve of " + FitContext::run_label(d) + " did not converge");
        continue;
      }
      FitCurve c = FitContext::curve_record(d, "fit", d.specimen_scale * *forces[r]);
      c.delta_theta_deg = FitContext::strip_offset(d);
      c.specimen_scale = d.specimen_scale;
      if (const CurveStage* stage = context.fitted_curve_at(d.test->angle_deg))
        c.degree = (context.params.*(stage->term->curve_member)).degree();
      out.fit.push_back(c);
    }
  }

 private:
  /// Each fit run's forces at the final parameters (nullopt where no solve converged): warm
  /// predictors and simulated curves in parallel, then a failed warm start simulated after all.
  std::vector<std::optional<Eigen::VectorXd>> final_forces(const FitContext& context) const {
    const size_t n = context.fit_runs.size();
    std::vector<StripCurves::Request> requests, simulated_requests;
    std::vector<std::shared_ptr<Experiment>> warm(n);
    for (size_t r = 0; r < n; ++r) {
      const RunData& d = context.fit_runs[r];
      requests.push_back({&d, FitContext::strip_angle(d)});
      const auto last = context.last_predictor.find(&d);
      if (options_.warm_start && last != context.last_predictor.end() && last->second.first == context.finest_level)
        warm[r] = last->second.second;
      else
        simulated_requests.push_back(requests.back());
    }
    StripCurves curves;
    std::vector<std::optional<Eigen::VectorXd>> forces(n);
    std::vector<std::optional<StripCurves::Simulated>> simulated;
    tbb::parallel_invoke(
        [&] {
          for (size_t r = 0; r < n; ++r) {
            Eigen::VectorXd values;
            std::string message;
            if (warm[r] && warm[r]->predict(context.params, {}, &values, nullptr, &message)) forces[r] = values;
          }
        },
        [&] { simulated = curves.simulate(context, simulated_requests, context.finest_level); });
    std::vector<size_t> retry;
    for (size_t r = 0, k = 0; r < n; ++r) {
      if (!warm[r]) {
        if (simulated[k]) forces[r] = simulated[k]->force_N;
        ++k;
      } else if (!forces[r]) {
        retry.push_back(r);
      }
    }
    std::vector<StripCurves::Request> retry_requests;
    for (size_t r : retry) retry_requests.push_back(requests[r]);
    const auto retried = curves.simulate(context, retry_requests, context.finest_level);
    for (size_t i = 0; i < retry.size(); ++i)
      if (retried[i]) forces[retry[i]] = retried[i]->force_N;
    return forces;
  }

  FinalCurvesOptions options_;
};

}  // namespace

void register_final_curves_stage(FitStageFactories& stages) {
  stages.add_bound<FinalCurves>("final-curves", "every fit run simulated at the final parameters, finest level",
                                final_curves_bindings());
}

}  // namespace twill
