// Stage `initial-guess` (paper §5.3): from the small-strain slopes the protocol starts from,
// each tensile-curve stage's term is fitted to its runs on the uniform-strain model of the strip
// (experiments/uniform_strain.hpp, config uniform_strain.optimizer), and that model's agreement
// with the full shell solve at the guess is measured per run at the coarsest level and
// reported. Without this stage the fit starts from the slopes alone.
#include <fmt/format.h>

#include <cmath>

#include "core/option_binding.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct InitialGuessOptions {
  bool compare_full_solve = true;
  bool validate(std::string* error) const;
};

OptionBindings<InitialGuessOptions> initial_guess_bindings() {
  using S = InitialGuessOptions;
  return {bool_option<S>("compare_full_solve", &S::compare_full_solve,
                         "also solve each run's strip at the guess (coarsest level) and report how far the "
                         "uniform-strain model is from it")};
}

bool InitialGuessOptions::validate(std::string* error) const {
  return check_options(initial_guess_bindings(), *this, error);
}

class InitialGuess final : public FitStage {
 public:
  explicit InitialGuess(InitialGuessOptions options) : options_(options) {}
  std::string title() const override { return "initial_guess"; }

  void run(FitContext& context, FitReport& out) override {
    for (const CurveStage& stage : context.declared_curves) fit_uniform_strain(context, stage, out);
    if (options_.compare_full_solve) compare_with_full_solve(context, out);
  }

 private:
  static void fit_uniform_strain(FitContext& context, const CurveStage& stage, FitReport& out) {
    const auto runs = context.runs_for(stage.angle_deg);
    if (runs.empty()) return;
    std::vector<std::shared_ptr<Predictor>> predictors;
    for (const RunData* d : runs) predictors.push_back(context.uniform_strain_predictor(*d));
    MaterialParameters& p = context.params;
    ParameterMap map(p, stage.free_parameters());
    FitObjective objective(map, predictors);
    const ComponentChoice& choice = context.config().uniform_strain_optimizer;
    std::unique_ptr<Optimizer> optimizer = context.make_optimizer(choice);
    const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
    if (std::isfinite(r.summary.final_value)) p = map.parameters(r.x);
    objective.evaluate(r.x, nullptr);
    for (size_t i = 0; i < runs.size(); ++i) {
      FitInitialGuess g;
      g.label = predictors[i]->label();
      g.avg_rel_error_uniform = objective.average_relative_error(static_cast<int>(i));
      out.initial_guess.push_back(g);
    }
    context.say(0, fmt::format("initial guess {}: uniform-strain fit {} ({}), error {:.2f} %", stage.label,
                               choice.name, to_string(r.status), 100 * mean_run_error(objective, runs.size())));
  }

  /// The uniform-strain model against the full solve at the guess, per run (coarsest level).
  static void compare_with_full_solve(FitContext& context, FitReport& out) {
    size_t k = 0;
    const MaterialParameters& p = context.params;
    for (const CurveStage& stage : context.declared_curves)
      for (const RunData* d : context.runs_for(stage.angle_deg)) {
        const std::shared_ptr<Experiment> full = context.tensile_experiment(*d, 0, p);
        const std::shared_ptr<Predictor> uniform = context.uniform_strain_predictor(*d);
        Eigen::VectorXd a, b;
        std::string message;
        if (k < out.initial_guess.size() && full->predict(p, {}, &a, nullptr, &message) &&
            uniform->predict(p, {}, &b, nullptr, &message)) {
          out.initial_guess[k].avg_rel_difference_full = (b - a).cwiseAbs().sum() / a.cwiseAbs().sum();
          context.say(0, fmt::format("  {}: uniform strain vs full solve at the guess: {:.2f} %",
                                     FitContext::run_label(*d), 100 * out.initial_guess[k].avg_rel_difference_full));
        }
        ++k;
      }
  }

  InitialGuessOptions options_;
};

}  // namespace

void register_initial_guess_stage(FitStageFactories& stages) {
  stages.add_bound<InitialGuess>("initial-guess",
                                 "paper §5.3: each curve stage's term fitted on the uniform-strain strip model",
                                 initial_guess_bindings());
}

}  // namespace twill
