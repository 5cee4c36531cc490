// Stage `strain-cutoff` (paper §5.2 steps 4 and 6): the named tensile-curve stage's strain
// cutoff (Ẽ11max for eta1, Ẽ22max for eta3, Ẽ12max for eta4) at `fraction` of "the largest
// strain seen": the largest |Ẽ| component over the strip's mid-surface in the stage's simulated
// tests at their largest measured extension, at the finest configured level
// (TensileExperiment::material_strain_samples samples the strain field on a grid).
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "core/option_binding.hpp"
#include "effects/effect_experiment.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct StrainCutoffOptions {
  std::string stage = "warp";
  double fraction = 0.95;
  bool validate(std::string* error) const;
};

OptionBindings<StrainCutoffOptions> strain_cutoff_bindings() {
  using S = StrainCutoffOptions;
  return {text_option<S>("stage", &S::stage, "label of the tensile-curve stage (before this one) whose cutoff is set"),
          real_option<S>("fraction", &S::fraction, "the cutoff as this fraction of the largest strain seen",
                         in_range(0.5, 1.0))};
}

bool StrainCutoffOptions::validate(std::string* error) const {
  return check_options(strain_cutoff_bindings(), *this, error);
}

class StrainCutoff final : public FitStage {
 public:
  explicit StrainCutoff(StrainCutoffOptions options) : options_(std::move(options)) {}
  std::string title() const override { return "cutoff of " + options_.stage; }

  void check(const ProtocolCheck& check) const override {
    const auto& labels = check.curve_labels;
    if (std::find(labels.begin(), labels.end(), options_.stage) != labels.end()) return;
    std::string before;
    for (const std::string& l : labels) before += (before.empty() ? "" : ", ") + l;
    throw InputError(check.locate(check.key + ".stage"),
                     "no tensile-curve stage '" + options_.stage + "' before this one (before it: " +
                         (before.empty() ? "none" : before) + ")");
  }

  void run(FitContext& context, FitReport& out) override {
    (void)out;
    const CurveStage* stage = fitted(context);
    if (!stage) {
      context.note("cutoff of " + options_.stage + ": the stage did not run (no test), cutoff off");
      return;
    }
    const MembraneTerm& term = *stage->term;
    const std::vector<Eigen::Vector3d> samples = simulated_strains(context, *stage);
    context.params.cutoffs.*(term.cutoff) = options_.fraction * strain_excess(samples, term.strain_component, {}).largest;
    context.note(fmt::format("cutoff: {}_max {:.4g}", term.cutoff_name, *(context.params.cutoffs.*(term.cutoff))));
    note_other_cutoffs_passed(context, *stage, samples);
  }

 private:
  const CurveStage* fitted(const FitContext& context) const {
    for (const CurveStage& c : context.fitted_curves)
      if (c.label == options_.stage) return &c;
    return nullptr;
  }

  // Only the equilibrium at the largest extension is measured, and a hyperelastic strip's
  // equilibrium does not depend on the loading path, so the continuation takes
  // kStrainSampleSteps evenly spaced steps of the run's schedule instead of all of them
  // (measured, 32x48 with the tangent predictor: warp to 9 mm and poplin bias to 22 mm converge
  // in 3 and 5 steps to the 20-step equilibrium within 1e-9 of the force, 2.2-2.4x faster).
  static constexpr size_t kStrainSampleSteps = 5;
  static std::vector<double> strain_sample_schedule(const std::vector<double>& extensions_mm) {
    if (extensions_mm.size() <= kStrainSampleSteps) return extensions_mm;
    std::vector<double> schedule;
    for (size_t j = 1; j <= kStrainSampleSteps; ++j)
      schedule.push_back(extensions_mm[(j * extensions_mm.size()) / kStrainSampleSteps - 1]);
    return schedule;
  }

  // The runs of one strip (the same TensileSetup: the repeats of a test, its tests at other
  // speeds), simulated by one continuation: the sample schedule of the run that goes furthest,
  // with every other run's largest extension put in. Because the equilibrium does not depend on
  // the path (above), the state at a run's largest extension is the same whichever run's
  // schedule reached it.
  struct StripRuns {
    TensileSetup setup;
    const std::vector<double>* furthest = nullptr;  ///< the rows of the run that goes furthest
    std::vector<double> ends;                       ///< each run's largest extension (its last row)

    /// refinement 0: the sample schedule of the furthest run's rows; refinement r > 0:
    /// kStrainSampleSteps·2^r evenly spaced extensions up to its end (the retries below).
    std::vector<double> schedule(int refinement = 0) const {
      std::vector<double> s = refinement == 0 ? strain_sample_schedule(*furthest) : evenly_spaced(refinement);
      s.insert(s.end(), ends.begin(), ends.end());
      std::sort(s.begin(), s.end());
      s.erase(std::unique(s.begin(), s.end()), s.end());
      return s;
    }
    std::vector<double> evenly_spaced(int refinement) const {
      const size_t n = kStrainSampleSteps << refinement;
      std::vector<double> s;
      for (size_t j = 1; j <= n; ++j) s.push_back(furthest->back() * static_cast<double>(j) / static_cast<double>(n));
      return s;
    }
  };
  // A continuation of kStrainSampleSteps steps can stop where smaller steps get through: a
  // curve raised to degree 4 whose exponential terms nearly cancel (canvas warp with
  // Gauss–Newton, papers/optimizers: Newton's fallbacks exhausted at 7 mm in 5 or 8 steps and
  // at 9 mm in 12, through to 9 mm in 36) — while the fit itself, warm-started from its last
  // evaluation, converged there. Then the strip is loaded again with twice the steps, up to
  // kStrainSampleRefinements times (40 steps).
  static constexpr int kStrainSampleRefinements = 3;
  static std::vector<StripRuns> strips_of(const FitContext& context, const std::vector<const RunData*>& runs) {
    std::vector<StripRuns> strips;
    for (const RunData* d : runs) {
      const TensileSetup setup = context.setup_for(*d->test, context.levels() - 1);
      auto at = std::find_if(strips.begin(), strips.end(), [&](const StripRuns& s) { return s.setup == setup; });
      if (at == strips.end()) at = strips.insert(strips.end(), StripRuns{setup, nullptr, {}});
      at->ends.push_back(d->extension_mm.back());
      if (!at->furthest || d->extension_mm.back() > at->furthest->back()) at->furthest = &d->extension_mm;
    }
    return strips;
  }

  // Where this stage's strips pass a cutoff set before (the bias strips and the warp/weft
  // cutoffs): there the stage was fitted to the law's quadratic extension (docs/fitting.md §7).
  static void note_other_cutoffs_passed(FitContext& context, const CurveStage& stage,
                                        const std::vector<Eigen::Vector3d>& samples) {
    for (const MembraneTerm& other : membrane_terms()) {
      if (&other == stage.term) continue;
      const std::optional<double> cutoff = context.params.cutoffs.*(other.cutoff);
      const StrainExcess e = strain_excess(samples, other.strain_component, cutoff);
      if (e.share_beyond > 0)
        context.note(fmt::format("cutoff of {}: its strips pass {}_max {:.4g} over {:.1f} % of their area, up to "
                                 "{:.4g}: the {} fit saw the law's extrapolation there",
                                 stage.label, other.cutoff_name, *cutoff, 100 * e.share_beyond, e.largest, stage.label));
    }
  }

  // The strain field over each of the stage's runs at its largest extension, at the finest
  // level (the model's law with the effects' law hooks applied, as every experiment of the fit
  // sees it), pooled: each run's grid covers its strip evenly. One continuation per strip
  // (strips_of): canvas bias with its 5 repeats, 5 continuations of 5 steps before, one of
  // 9 now.
  static std::vector<Eigen::Vector3d> simulated_strains(FitContext& context, const CurveStage& stage) {
    const MaterialParameters material = law_adjusted(context.params, context.registry());
    std::vector<Eigen::Vector3d> samples;
    std::string stopped;  // why the last strip that did not reach every run's end stopped
    for (const StripRuns& strip : strips_of(context, context.runs_for(stage.angle_deg))) {
      TensileExperiment e(strip.setup, context.discretization(), material, context.solver());
      const LoadedStrip loaded = load(context, stage, strip, e);
      if (!loaded.stopped.empty()) stopped = loaded.stopped;
      bool reached_an_end = false;
      for (double end : strip.ends) {
        const auto step = static_cast<size_t>(std::lower_bound(loaded.schedule.begin(), loaded.schedule.end(), end) -
                                              loaded.schedule.begin());
        if (loaded.states[step].size() == 0) continue;  // the continuation stopped before this run's end
        const std::vector<Eigen::Vector3d> run = e.material_strain_samples(loaded.states[step]);
        samples.insert(samples.end(), run.begin(), run.end());
        reached_an_end = true;
      }
      if (!reached_an_end) add_furthest_reached(context, stage, strip, loaded, e, samples);
    }
    if (!(strain_excess(samples, stage.term->strain_component, {}).largest > 0))
      throw std::runtime_error("cutoffs: no converged " + stage.label + " simulation to measure strains on (" +
                               stopped + ")");
    return samples;
  }

  // A strip loaded along its sample schedule, and again with more steps while it stops short.
  struct LoadedStrip {
    std::vector<double> schedule;
    std::vector<Eigen::VectorXd> states;  ///< per schedule entry; empty where not reached
    std::string stopped;                  ///< why the last attempt stopped; empty when it completed
  };
  static LoadedStrip load(FitContext& context, const CurveStage& stage, const StripRuns& strip, TensileExperiment& e) {
    LoadedStrip loaded;
    for (int refinement = 0; refinement <= kStrainSampleRefinements; ++refinement) {
      loaded.schedule = strip.schedule(refinement);
      loaded.states.assign(loaded.schedule.size(), Eigen::VectorXd());
      const TensileCurve curve = e.run(loaded.schedule, [&](int step, const Eigen::VectorXd& q, const EquilibriumSolver&) {
        loaded.states[static_cast<size_t>(step)] = q;
      });
      loaded.stopped = curve.completed ? "" : curve.message;
      if (curve.completed) break;
      context.note(refinement < kStrainSampleRefinements
                       ? fmt::format("cutoff of {}: the strip's continuation stopped ({}); again in {} steps", stage.label,
                                     curve.message, kStrainSampleSteps << (refinement + 1))
                       : fmt::format("cutoff of {}: the strip's continuation stopped in {} steps too ({}); the runs "
                                     "it did not reach are left out of the cutoff",
                                     stage.label, loaded.schedule.size(), curve.message));
    }
    return loaded;
  }

  // A strip whose continuation stopped short of every run's end (a law fitted to a force that
  // falls, as yarn damage makes it: the strip's stiffness turns indefinite on the way, while the
  // fit, warm-started from its last evaluation, got through): its strains at the furthest
  // extension it reached stand in for the runs' ends, and a note says so. The largest strain
  // seen is then a lower bound, and so is the cutoff. Without this the whole fit failed
  // (papers/discovery: yarn damage at 20 % scatter, seed 5, weft stopped at step 35 of 40).
  static void add_furthest_reached(FitContext& context, const CurveStage& stage, const StripRuns& strip,
                                   const LoadedStrip& loaded, TensileExperiment& e,
                                   std::vector<Eigen::Vector3d>& samples) {
    size_t reached = loaded.states.size();
    while (reached > 0 && loaded.states[reached - 1].size() == 0) --reached;
    if (reached == 0) return;  // not even the first step: nothing to measure
    const std::vector<Eigen::Vector3d> furthest = e.material_strain_samples(loaded.states[reached - 1]);
    samples.insert(samples.end(), furthest.begin(), furthest.end());
    context.note(fmt::format("cutoff of {}: the strip reached {:.4g} mm of its runs' {:.4g} mm; its strains there "
                             "stand in for theirs, so the cutoff is a lower bound",
                             stage.label, loaded.schedule[reached - 1], strip.furthest->back()));
  }

  StrainCutoffOptions options_;
};

}  // namespace

void register_strain_cutoff_stage(FitStageFactories& stages) {
  stages.add_bound<StrainCutoff>("strain-cutoff",
                                 "paper §5.2 steps 4 and 6: a curve stage's strain cutoff from the largest strain seen",
                                 strain_cutoff_bindings());
}

}  // namespace twill
