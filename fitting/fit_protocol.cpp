#include "fitting/fit_protocol.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "core/discretization_registry.hpp"
#include "core/fit_objective.hpp"
#include "core/input_error.hpp"
#include "core/repeat_selection.hpp"
#include "effects/effect.hpp"
#include "effects/misalignment.hpp"
#include "experiments/experiment.hpp"
#include "experiments/predictors.hpp"
#include "experiments/uniform_strain.hpp"
#include "optimizers/optimizer.hpp"

namespace twill {

OptionSchema fit_config_schema() {
  OptionSchema s;
  s.add_component("discretization", registry_category::kDiscretization, "catmull-clark-kl",
                  "shell discretisation of every simulated test");
  // Default Gauss–Newton: Eq. 3 is a sum of squared relative residuals with an exact Jacobian
  // (core/fit_objective), and on the example datasets GN took 3–12 iterations per stage where
  // BFGS and Ipopt hit the limits (papers/optimizer_comparison, papers/fit_examples).
  s.add_component("optimizer", registry_category::kOptimizer, "gauss-newton",
                  "minimiser of the fit objective (paper Eq. 3) in every stage");
  s.add_component_list("effects", registry_category::kEffect,
                       "the model's effects, estimated by the fit and written to params.yaml (twill list effect)");
  OptionSchema& experiments = s.add_section("experiments", "the simulated tests the stages fit (twill list experiment)");
  experiments.add_component("tensile", registry_category::kExperiment, "tensile",
                            "experiment of every fitted tensile run (warp, weft, bias stages)");
  experiments.add_component("bend", registry_category::kExperiment, "bend", "experiment of the bend stage");
  OptionSchema& stop = s.add_section("stopping", "per-stage limits, applied to the optimiser's common options");
  stop.add_int("max_iterations", 60, "iterations per stage at the coarsest level").at_least(1);
  stop.add_int("refine_max_iterations", 15,
               "iterations per stage at each refit of the resolution ladder (it starts at an optimum)").at_least(1);
  stop.add_int("max_evaluations", 150, "objective evaluations per stage and resolution").at_least(1);
  stop.add_double("gradient_tolerance", 1e-7, "projected-gradient inf-norm in scaled unknowns").at_least(0.0);
  stop.add_double("function_tolerance", 1e-7, "relative change of the objective per iteration").at_least(0.0);
  // A finer level starts at the coarser optimum and only corrects the discretisation change:
  // measured (canvas, Gauss–Newton, 32×48 warp) ε went 1.8103e-4 → 1.3491e-4 in one iteration,
  // then 3 more iterations and 12 rejected trials (14 of 16 curve evaluations, 30 s) moved
  // it by 1e-4 relative, i.e. the average error by ~5e-5 of itself. Tried and rejected
  // (2026-12-02): 1 %. With Gauss–Newton it is safe (canvas 132 → 117 s, τ·G12 moves by
  // 1.2e-4, fit errors unchanged), but a BFGS iteration can change ε by less than 1 % long
  // before it converges: canvas/bfgs stopped its refits early (weft 1.79 % instead of 1.37 %,
  // bias 0.65 % instead of 0.43 %, τ·G12 +5.04 %). The relative change of ε is not an
  // optimiser-independent convergence measure.
  stop.add_double("refine_function_tolerance", 1e-4,
                  "relative change of the objective per iteration at each refit of the ladder").at_least(0.0);
  OptionSchema& init = s.add_section("initial_guess", "uniform-strain initial guesses (paper §5.3)");
  init.add_component("optimizer", registry_category::kOptimizer, "gauss-newton",
                     "optimiser of the uniform-strain fits (its stopping limits are the stages')");
  init.add_bool("enabled", true, "fit the uniform-strain model first (false: slopes only)");
  OptionSchema& rep = s.add_section("repeats", "which repeated runs are fitted (paper §6.4)");
  rep.add_string("rule", "paper", "paper: largest forces for warp/weft, one random run for others")
      .choices({"paper", "largest", "random", "all"});
  rep.add_int("seed", 1, "seed of the random choice").at_least(0);
  OptionSchema& data = s.add_section("data", "measured points used in the objective");
  data.add_int("max_points", 20, "at most this many points per run, evenly spread").at_least(2);
  data.add_double("min_force_fraction", 0.005, "drop points below this fraction of the run's peak force (slack, noise)")
      .range(0.0, 0.9);
  OptionSchema& deg = s.add_section("degree", "automatic degree choice (paper §5.4)");
  deg.add_int("max", 3, "highest curve degree").range(1, 6);
  deg.add_double("target_error", 0.01, "stop raising below this average relative error (bias: twice it)")
      .greater_than(0.0);
  deg.add_double("min_improvement", 0.2, "stop raising when a raise improved the error by less than this fraction")
      .range(0.0, 1.0);
  deg.add_int("raise_attempts", 3, "starts tried per raise (best-scored first) before it counts as not improving")
      .range(1, 6);
  OptionSchema& res = s.add_section("resolution", "multiresolution (paper §5.5.4)");
  res.add_int("coarse_cells_across", 8, "cells across the strip width at the coarsest level").at_least(1);
  res.add_int("levels", 3, "levels, each doubling the cells (8x12 -> 16x24 -> 32x48)").range(1, 5);
  // The ladder's stopping rule (docs/fitting.md §6 item 5): the off-axis forces converge at
  // first order (docs/catmull_clark_kl.md §12), so a level's change estimates the
  // discretisation error left at it. 3 %: below the acceptance bar of the fitted shear
  // stiffness (5 % for τ·G12, issue #12) and above the off-axis force change from 16x24 to
  // 32x48 with the face-mean default (1.0–2.0 %), so the paper's ladder is kept where it is
  // needed and not extended.
  res.add_double("change_tolerance", 0.03,
                 "a stage whose membrane response changed less than this between two levels skips the "
                 "finer ones (0: never)").range(0.0, 1.0);
  // 0 by default: one more level costs about 4x the finest one (a 64x96 bias stage), so it is
  // a choice the user makes; the report says when the change was above the tolerance.
  res.add_int("extra_levels", 0,
              "levels added for a stage still changing by more than change_tolerance at the last level")
      .range(0, 2);
  OptionSchema& stages = s.add_section("stages", "the stages of paper §5.2");
  stages.add_double("cutoff_fraction", 0.95, "strain cutoffs at this fraction of the largest strain seen")
      .range(0.5, 1.0);
  stages.add_bool("cutoffs", true, "set the strain cutoffs (§5.2 steps 4 and 6)");
  stages.add_bool("bend", true, "fit the thickness to the cantilever data (§5.2 step 7)");
  stages.add_bool("validation", true, "evaluate the validation strips with an angle offset (§7)");
  OptionSchema& bend = s.add_section("bend", "cantilever simulation (paper §4)");
  bend.add_int("cells_across", 4, "cells across the 25 mm strip").at_least(1);
  bend.add_int("cells_along", 64, "cells along the overhang").at_least(4);
  bend.add_bool("find_overhang", true, "also report the simulated overhang at 41.5 degrees");
  OptionSchema& val = s.add_section("validation", "validation strips (paper §7)");
  // The offset is the misalignment effect's per-run parameter (effects/misalignment.hpp), so
  // its bound is the effect's.
  val.add_double("max_offset_deg", Misalignment::kMaxOffsetDeg, "search the angle offset in [-this, this]")
      .range(0.0, Misalignment::kMaxOffsetDeg);
  // Three steps: the error is nearly piecewise linear in the offset near its minimum, so the
  // first linearised step lands within the resolution on the example fits and a second one
  // confirms it; the third is a margin for strongly nonlinear curves.
  val.add_int("offset_iterations", 3, "Newton steps of the offset search (dF/dtheta exact; 0: no offset)")
      .range(0, 10);
  val.add_double("offset_resolution_deg", 0.05,
                 "offsets are rounded to this grid and the search stops at a step below it "
                 "(runs sharing an offset share a simulation; 0: exact)")
      .at_least(0.0);
  OptionSchema& solver = s.add_section("solver", "quasistatic equilibrium (paper §6.1)");
  solver.add_double("gradient_tolerance", 1e-8, "Newton stops at |g_f| <= this * force scale").greater_than(0.0);
  return s;
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

struct RunData {
  const TensileTest* test = nullptr;
  const TensileRun* run = nullptr;
  std::vector<double> extension_mm;
  Eigen::VectorXd force_N;
};

// Loading branch, small forces dropped, evenly thinned (data.* keys).
RunData measured_points(const TensileTest& test, const TensileRun& run, const Options& data) {
  const double peak_force = *std::max_element(run.force_N.begin(), run.force_N.begin() + static_cast<long>(run.peak_index) + 1);
  const double floor = data.get_double("min_force_fraction") * peak_force;
  std::vector<size_t> keep;
  double last_extension = -1e300;
  for (size_t i = 0; i <= run.peak_index; ++i)
    if (run.force_N[i] > floor && run.force_N[i] > 0 && run.extension_mm[i] > 0 &&
        run.extension_mm[i] > last_extension) {
      keep.push_back(i);
      last_extension = run.extension_mm[i];
    }
  const size_t max_points = static_cast<size_t>(data.get_int("max_points"));
  std::vector<size_t> chosen;
  if (keep.size() <= max_points) {
    chosen = keep;
  } else {
    for (size_t j = 0; j < max_points; ++j)
      chosen.push_back(keep[(j * (keep.size() - 1)) / (max_points - 1)]);
  }
  RunData d;
  d.test = &test;
  d.run = &run;
  d.force_N.resize(static_cast<Eigen::Index>(chosen.size()));
  for (size_t j = 0; j < chosen.size(); ++j) {
    d.extension_mm.push_back(run.extension_mm[chosen[j]]);
    d.force_N[static_cast<Eigen::Index>(j)] = run.force_N[chosen[j]];
  }
  if (d.extension_mm.size() < 2)
    throw InputError({run.path, 0, "force_N"},
                     "fewer than 2 usable points in the loading branch (forces above " +
                         fmt::format("{:.3g}", floor) + " N)");
  return d;
}

// Small-strain secant modulus τ·E along the strip [N/m] from the first points: F/(W ε).
double small_strain_membrane_modulus(const RunData& d) {
  const size_t n = std::min<size_t>(3, d.extension_mm.size());
  double sum = 0;
  for (size_t i = 0; i < n; ++i) {
    const double strain = d.extension_mm[i] / d.test->gauge_length_mm;
    sum += d.force_N[static_cast<Eigen::Index>(i)] / (1e-3 * d.test->width_mm * strain);
  }
  return sum / static_cast<double>(n);
}

struct Stage {
  std::string name;      // warp, weft, bias
  double angle_deg;      // 90, 0, 45
  std::string stiffness;  // a11_Pa, ...
  std::string curve;      // eta1, ...
  Curve MaterialParameters::*curve_member;
  std::optional<double> Cutoffs::*cutoff;  // the stage's own strain cutoff
  // Its term of ψ (model.md §2) is stress_factor/2 · a · η(E²): a/2 η(E²) for a stretch,
  // G12 η4(E12²) for the shear; the stress is stress_factor · a · E · η'(E²).
  double stress_factor;
};

const std::vector<Stage>& stages() {
  static const std::vector<Stage> s = {
      {"warp", 90.0, "a11_Pa", "eta1", &MaterialParameters::eta1, &Cutoffs::E11_max, 1.0},
      {"weft", 0.0, "a22_Pa", "eta3", &MaterialParameters::eta3, &Cutoffs::E22_max, 1.0},
      {"bias", 45.0, "G12_Pa", "eta4", &MaterialParameters::eta4, &Cutoffs::E12_max, 2.0}};
  return s;
}

// The raise of §5.4: one more term with a small weight, so the curve starts near where the
// lower degree ended; the new exponent is chosen by Protocol::raised_starts().
void add_term(Curve* c, double alpha) {
  const double weight = 0.05;
  c->mu[0] -= weight;
  c->mu.push_back(weight);
  c->alpha.push_back(alpha);
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

std::string resolution_text(const TensileSetup& s) {
  return std::to_string(s.cells_across) + "x" + std::to_string(s.cells_along);
}

}  // namespace

/// argmin_t Σ_i |f_i + t d_i − m_i|: a convex piecewise-linear function of t, minimal at a
/// weighted median of the breakpoints t_i = (m_i − f_i)/d_i with weights |d_i| (its slope
/// Σ |d_i| sign(t − t_i) changes sign there). 0 when every d_i is 0.
double linearised_l1_minimiser(const Eigen::VectorXd& f, const Eigen::VectorXd& d, const Eigen::VectorXd& m) {
  std::vector<std::pair<double, double>> breakpoints;  // (t_i, |d_i|)
  double total = 0;
  for (Eigen::Index i = 0; i < f.size(); ++i) {
    if (d[i] == 0.0) continue;
    breakpoints.emplace_back((m[i] - f[i]) / d[i], std::abs(d[i]));
    total += std::abs(d[i]);
  }
  if (breakpoints.empty()) return 0.0;
  std::sort(breakpoints.begin(), breakpoints.end());
  double below = 0;
  for (const auto& [t, w] : breakpoints) {
    below += w;
    if (below >= 0.5 * total) return t;
  }
  return breakpoints.back().first;
}

namespace {

class Protocol {
 public:
  Protocol(const Dataset& dataset, const Options& config, const Registry& registry,
           const FitProgress& progress)
      : dataset_(dataset), config_(config), registry_(registry), progress_(progress) {
    discretization_ = config.get_component("discretization");
    factory_ = [this](const StripSpec& strip, const MaterialParameters& p) {
      return registry_.create<DiscretizationFactories>(registry_category::kDiscretization,
                                                       discretization_, strip, p);
    };
    solver_.gradient_tolerance = config.get_section("solver").get_double("gradient_tolerance");
    for (const ComponentChoice& choice : config.get_component_list("effects"))
      effects_.push_back(registry_.create<EffectFactories>(registry_category::kEffect, choice));
    offset_effect_ = angle_offset_effect();
  }

  FitReport run() {
    const auto start = Clock::now();
    report_.dataset = dataset_.name;
    report_.folder = dataset_.folder;
    check_effects_data();
    select_data();
    auto t = Clock::now();
    initial_guess();
    report_.timing_s.emplace_back("initial_guess", seconds_since(t));
    // Phase A, coarsest level: degrees (§5.4) and cutoffs (§5.2 steps 4, 6) in the paper's
    // stage order. Phase B: every finer level refits each stage's chosen degree from the
    // coarser solution with all cutoffs in place (§5.5.4), so the finest fit sees the final
    // model; with a single level, phase B refits that level once the cutoffs are set.
    const bool cutoffs = config_.get_section("stages").get_bool("cutoffs");
    for (const Stage& stage : stages()) {
      if (runs_for(stage.angle_deg).empty()) {
        note("no " + stage.name + " test: stage skipped, its parameters stay at the initial guess");
        continue;
      }
      t = Clock::now();
      choose_degree(stage);
      report_.timing_s.emplace_back(stage.name + " (degree, coarsest level)", seconds_since(t));
      if (stage.name == "weft" && cutoffs) {
        t = Clock::now();
        set_stretch_cutoffs();
        report_.timing_s.emplace_back("cutoffs E11, E22", seconds_since(t));
      }
    }
    if (cutoffs && !runs_for(45.0).empty()) {
      t = Clock::now();
      set_shear_cutoff();
      report_.timing_s.emplace_back("cutoff E12", seconds_since(t));
    }
    refine_levels();
    t = Clock::now();
    if (config_.get_section("stages").get_bool("bend") && !dataset_.bend.empty()) fit_bend();
    report_.timing_s.emplace_back("bend", seconds_since(t));
    t = Clock::now();
    final_fit_curves();
    report_.timing_s.emplace_back("final curves", seconds_since(t));
    t = Clock::now();
    if (config_.get_section("stages").get_bool("validation")) validate();
    report_.timing_s.emplace_back("validation", seconds_since(t));
    estimate_effects();
    report_.timing_s.emplace_back("total", seconds_since(start));
    report_.parameters = params_;
    return report_;
  }

  /// What the finished stages learned, when run() threw (run_fit's `finished`).
  FitReport finished_so_far() const {
    FitReport r = report_;
    r.parameters = params_;
    return r;
  }

 private:
  void say(int level, const std::string& line) {
    if (progress_) progress_(level, line);
  }
  void note(const std::string& line) {
    report_.notes.push_back(line);
    say(0, line);
  }

  void select_data() {
    const Options& rep = config_.get_section("repeats");
    const RepeatRule rule = repeat_rule_from_string(rep.get_string("rule"));
    const auto seed = static_cast<std::uint64_t>(rep.get_int("seed"));
    for (const TensileTest& test : dataset_.tensile) {
      const RepeatSelection sel = select_repeats(test, rule, seed);
      if (test.role == TestRole::Fit) note(test.label + ": " + sel.reason);
      const std::vector<size_t> all = [&] {
        std::vector<size_t> v(test.runs.size());
        std::iota(v.begin(), v.end(), 0);
        return v;
      }();
      // Validation strips: every run is evaluated (paper §7, Table 5 reports per run).
      for (size_t i : test.role == TestRole::Fit ? sel.runs : all)
        (test.role == TestRole::Fit ? fit_runs_ : validation_runs_)
            .push_back(measured_points(test, test.runs[i], config_.get_section("data")));
    }
    if (runs_for(90.0).empty())
      throw InputError({dataset_.folder + "/fabric.yaml", 0, "tensile"},
                       "the fit needs a warp test (angle_deg: 90, role: fit)");
  }

  std::vector<const RunData*> runs_for(double angle) const {
    std::vector<const RunData*> out;
    for (const RunData& d : fit_runs_)
      if (std::abs(d.test->angle_deg - angle) < 1e-9) out.push_back(&d);
    return out;
  }

  TensileSetup setup_for(const TensileTest& test, int level) const {
    const Options& res = config_.get_section("resolution");
    TensileSetup s;
    s.angle_deg = test.angle_deg;
    s.width_mm = test.width_mm;
    s.gauge_length_mm = test.gauge_length_mm;
    s.cells_across = static_cast<int>(res.get_int("coarse_cells_across")) << level;
    s.cells_along = std::max(1, static_cast<int>(std::lround(s.cells_across * test.gauge_length_mm / test.width_mm)));
    return s;
  }
  int levels() const { return static_cast<int>(config_.get_section("resolution").get_int("levels")); }

  std::string run_label(const RunData& d) const { return d.test->label + " " + d.run->name(); }

  /// The input of an experiment on this fit's discretisation and solver (schedule and measured
  /// values are the caller's).
  ExperimentInput experiment_input(std::string label, double angle_deg, double width_mm, int cells_across,
                                   int cells_along, const MaterialParameters& p) const {
    ExperimentInput input;
    input.label = std::move(label);
    input.angle_deg = angle_deg;
    input.width_mm = width_mm;
    input.cells_across = cells_across;
    input.cells_along = cells_along;
    input.discretization = factory_;
    input.start = p;
    input.solver = solver_;
    return input;
  }

  /// A fit run's experiment at `level` from parameters `p`, created through the registry (the
  /// config's `experiments.tensile`), predicting the run's measured forces.
  std::shared_ptr<Experiment> tensile_experiment(const RunData& d, int level, const MaterialParameters& p) const {
    const TensileSetup s = setup_for(*d.test, level);
    ExperimentInput input = experiment_input(run_label(d), s.angle_deg, s.width_mm, s.cells_across, s.cells_along, p);
    input.length_mm = s.gauge_length_mm;
    input.schedule = d.extension_mm;
    input.measured = d.force_N;
    return registry_.create<ExperimentFactories>(registry_category::kExperiment,
                                                 config_.get_section("experiments").get_component("tensile"), input);
  }

  // ---- §5.3 initial guess --------------------------------------------------------------------
  void initial_guess() {
    MaterialParameters& p = params_;
    p.density_kg_m2 = 1e-3 * dataset_.areal_density_g_m2;
    p.thickness_m = 1e-3 * dataset_.thickness_mm;
    p.eta1 = p.eta3 = p.eta4 = Curve::linear();
    const double tau = p.thickness_m;
    auto modulus = [&](double angle) {
      std::vector<double> m;
      for (const RunData* d : runs_for(angle)) m.push_back(small_strain_membrane_modulus(*d) / tau);
      return mean(m);
    };
    p.a11_Pa = modulus(90.0);
    p.a22_Pa = runs_for(0.0).empty() ? p.a11_Pa : modulus(0.0);
    p.a12_Pa = MaterialParameters::tied_a12(p.a11_Pa, p.a22_Pa);
    // Bias: for stiff yarns the 45° modulus is ≈ 4 G12 (the strip deforms by shear alone).
    p.G12_Pa = runs_for(45.0).empty() ? 0.01 * p.a11_Pa : 0.25 * modulus(45.0);
    note(fmt::format("initial slopes: a11 {:.4g} Pa, a22 {:.4g} Pa, G12 {:.4g} Pa (tau {:.3g} mm)",
                     p.a11_Pa, p.a22_Pa, p.G12_Pa, 1e3 * tau));
    if (!config_.get_section("initial_guess").get_bool("enabled")) return;

    const ComponentChoice& choice = config_.get_section("initial_guess").get_component("optimizer");
    for (const Stage& stage : stages()) {
      const auto runs = runs_for(stage.angle_deg);
      if (runs.empty()) continue;
      std::vector<std::shared_ptr<Predictor>> predictors;
      for (const RunData* d : runs)
        predictors.push_back(std::make_shared<UniformStrainPredictor>(
            run_label(*d), setup_for(*d->test, 0), d->extension_mm, d->force_N));
      ParameterMap map(p, {stage.stiffness, stage.curve + ".*"});
      FitObjective objective(map, predictors);
      std::unique_ptr<Optimizer> optimizer = make_stage_optimizer(choice);
      const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
      if (std::isfinite(r.summary.final_value)) p = map.parameters(r.x);
      objective.evaluate(r.x, nullptr);
      for (size_t i = 0; i < runs.size(); ++i) {
        FitInitialGuess g;
        g.label = predictors[i]->label();
        g.avg_rel_error_uniform = objective.average_relative_error(static_cast<int>(i));
        report_.initial_guess.push_back(g);
      }
      say(0, fmt::format("initial guess {}: uniform-strain fit {} ({}), error {:.2f} %", stage.name,
                         choice.name, to_string(r.status), 100 * mean_error(objective, runs.size())));
    }
    // Agreement of the uniform-strain model with the full solve at the guess (coarsest level).
    size_t k = 0;
    for (const Stage& stage : stages())
      for (const RunData* d : runs_for(stage.angle_deg)) {
        const std::shared_ptr<Experiment> full = tensile_experiment(*d, 0, p);
        UniformStrainPredictor uniform(run_label(*d), setup_for(*d->test, 0), d->extension_mm, d->force_N);
        Eigen::VectorXd a, b;
        std::string message;
        if (k < report_.initial_guess.size() && full->predict(p, {}, &a, nullptr, &message) &&
            uniform.predict(p, {}, &b, nullptr, &message)) {
          report_.initial_guess[k].avg_rel_difference_full = (b - a).cwiseAbs().sum() / a.cwiseAbs().sum();
          say(0, fmt::format("  {}: uniform strain vs full solve at the guess: {:.2f} %", run_label(*d),
                             100 * report_.initial_guess[k].avg_rel_difference_full));
        }
        ++k;
      }
  }

  static double mean_error(const FitObjective& objective, size_t n) {
    std::vector<double> e;
    for (size_t i = 0; i < n; ++i) e.push_back(objective.average_relative_error(static_cast<int>(i)));
    return mean(e);
  }

  /// The config's optimiser (or `chosen`, e.g. the initial guess's) with the stages' stopping limits.
  std::unique_ptr<Optimizer> make_stage_optimizer(bool refine = false) const {
    return make_stage_optimizer(config_.get_component("optimizer"), refine);
  }
  std::unique_ptr<Optimizer> make_stage_optimizer(ComponentChoice choice, bool refine = false) const {
    const Options& stop = config_.get_section("stopping");
    choice.options.set("max_iterations", stop.get_int(refine ? "refine_max_iterations" : "max_iterations"));
    choice.options.set("max_evaluations", stop.get_int("max_evaluations"));
    choice.options.set("gradient_tolerance", stop.get_double("gradient_tolerance"));
    choice.options.set("function_tolerance",
                       stop.get_double(refine ? "refine_function_tolerance" : "function_tolerance"));
    return registry_.create<OptimizerFactories>(registry_category::kOptimizer, choice);
  }

  const FitStageRecord& record_stage(const std::string& stage, const std::string& resolution, int degree,
                                     double error, const Optimizer& optimizer, const OptimizerResult& r,
                                     const FitObjective& objective, Clock::time_point start) {
    FitStageRecord rec;
    rec.stage = stage;
    rec.resolution = resolution;
    rec.degree = degree;
    rec.avg_rel_error = error;
    rec.optimizer = optimizer.name();
    rec.status = to_string(r.status);
    rec.message = r.message;
    if (objective.failed_evaluations() > 0)
      rec.message += fmt::format(" ({} failed evaluations; last: {})", objective.failed_evaluations(),
                                 objective.last_failure());
    rec.iterations = r.summary.iterations;
    rec.evaluations = objective.evaluations();
    rec.equilibrium_solves = objective.equilibrium_solves();
    rec.wall_time_s = seconds_since(start);
    report_.stages.push_back(rec);
    return report_.stages.back();
  }

  // ---- §5.2 steps 2, 3, 5 with §5.4 and §5.5.4 --------------------------------------------------
  struct StageResult {
    double error = 0;
    bool ok = false;
  };

  /// `refining`: a refit from a converged solution of the same degree (the ladder), which uses
  /// the finer levels' stopping limits.
  StageResult fit_at(const Stage& stage, int level, MaterialParameters* p, bool refining = false) {
    const auto t = Clock::now();
    const auto runs = runs_for(stage.angle_deg);
    std::vector<std::shared_ptr<Predictor>> predictors;
    std::string resolution;
    for (const RunData* d : runs) {
      resolution = resolution_text(setup_for(*d->test, level));
      const std::shared_ptr<Experiment> experiment = tensile_experiment(*d, level, *p);
      last_predictor_[d] = {level, experiment};
      predictors.push_back(experiment);
    }
    ParameterMap map(*p, {stage.stiffness, stage.curve + ".*"});
    FitObjective objective(map, predictors);
    const int degree = ((*p).*(stage.curve_member)).degree();
    objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd&) {
      say(1, fmt::format("  {} {} degree {} it {:3d}: eps {:.4e} |g| {:.2e} ({} solves)", stage.name,
                         resolution, degree, it.iteration, it.value, it.gradient_norm,
                         objective.equilibrium_solves()));
    });
    std::unique_ptr<Optimizer> optimizer = make_stage_optimizer(refining);
    const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
    StageResult out;
    if (!std::isfinite(r.summary.final_value)) {
      note(fmt::format("{} {} degree {}: optimiser failed ({}): {}", stage.name, resolution, degree,
                       to_string(r.status), r.message));
      return out;
    }
    *p = map.parameters(r.x);
    objective.evaluate(r.x, nullptr);
    out.ok = true;
    out.error = mean_error(objective, runs.size());
    const FitStageRecord& rec =
        record_stage(stage.name, resolution, degree, out.error, *optimizer, r, objective, t);
    say(0, fmt::format("{} {} degree {}: error {:.2f} % ({}, {} its, {} solves, {:.1f} s){}", stage.name,
                       resolution, degree, 100 * out.error, rec.status, rec.iterations,
                       rec.equilibrium_solves, rec.wall_time_s,
                       r.status == OptimizerStatus::converged ? "" : ": " + rec.message));
    return out;
  }

  // Starts of a degree raise (§5.4): candidates for the new exponent α_new, each with the curve
  // refitted on the cheap uniform-strain model (§5.3, curve entries only), then scored by one
  // full evaluation at the coarsest level; best (lowest ε) first. One candidate keeps the plain
  // start (new term added, nothing refitted), so the best start is never worse than it.
  // Several starts, because a raise has a whole line of stationary points (α_new = α_old, where
  // the two terms merge and the weights split freely): an optimiser that slides onto it ends
  // at the lower degree's error (measured: Ipopt on the canvas bias, 6.65 % before and after).
  std::vector<MaterialParameters> raised_starts(const Stage& stage, const MaterialParameters& best) {
    const auto runs = runs_for(stage.angle_deg);
    const Curve& c = best.*(stage.curve_member);
    const double alpha_max = std::abs(*std::max_element(c.alpha.begin(), c.alpha.end(),
                                                        [](double a, double b) { return std::abs(a) < std::abs(b); }));
    std::vector<MaterialParameters> candidates;
    MaterialParameters plain = best;
    add_term(&(plain.*(stage.curve_member)), std::max(4.0 * alpha_max, 8.0));
    candidates.push_back(plain);
    const bool use_uniform = config_.get_section("initial_guess").get_bool("enabled");
    for (double alpha : {2.0, 10.0, 40.0, 150.0, 500.0}) {
      MaterialParameters trial = best;
      add_term(&(trial.*(stage.curve_member)), alpha);
      if (use_uniform) {
        std::vector<std::shared_ptr<Predictor>> uniform;
        for (const RunData* d : runs)
          uniform.push_back(std::make_shared<UniformStrainPredictor>(run_label(*d), setup_for(*d->test, 0),
                                                                     d->extension_mm, d->force_N));
        ParameterMap map(trial, {stage.curve + ".*"});
        FitObjective objective(map, uniform);
        const OptimizerResult r =
            make_stage_optimizer(config_.get_section("initial_guess").get_component("optimizer"))
                ->minimize(objective, map.initial_x());
        if (std::isfinite(r.summary.final_value)) {
          try {
            trial = map.parameters(r.x);
          } catch (const std::exception&) {
            continue;
          }
        }
      }
      candidates.push_back(trial);
    }
    // One full evaluation each, from the flat strip: independent, so in parallel, each with
    // its own predictors.
    std::vector<std::pair<double, MaterialParameters>> scored(candidates.size());
    tbb::parallel_for(size_t{0}, candidates.size(), [&](size_t i) {
      std::vector<std::shared_ptr<Predictor>> full;
      for (const RunData* d : runs)
        full.push_back(tensile_experiment(*d, 0, candidates[i]));
      ParameterMap map(candidates[i], {stage.curve + ".*"});
      FitObjective objective(map, full);
      const double value = objective.evaluate(map.initial_x(), nullptr);
      scored[i] = {std::isfinite(value) ? value : std::numeric_limits<double>::infinity(), candidates[i]};
    });
    std::stable_sort(scored.begin(), scored.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<MaterialParameters> starts;
    for (const auto& [value, p] : scored)
      if (std::isfinite(value)) starts.push_back(p);
    return starts;
  }

  // §5.4: degree 1 first; raise while the error is above the target. A raise is tried from up
  // to degree.raise_attempts of the best-scored starts, and accepted at the first that improves
  // the error by degree.min_improvement; if none does, the best of them is kept when it is
  // better at all, and raising stops.
  void choose_degree(const Stage& stage) {
    const Options& deg = config_.get_section("degree");
    const double target = deg.get_double("target_error") * (stage.name == "bias" ? 2.0 : 1.0);
    const double min_improvement = deg.get_double("min_improvement");
    const size_t attempts = static_cast<size_t>(deg.get_int("raise_attempts"));
    MaterialParameters best = params_;
    StageResult best_result = fit_at(stage, 0, &best);
    if (!best_result.ok) throw std::runtime_error("stage " + stage.name + ": degree 1 fit failed");
    while ((best.*(stage.curve_member)).degree() < deg.get_int("max") && best_result.error > target) {
      const std::vector<MaterialParameters> starts = raised_starts(stage, best);
      const int degree = (best.*(stage.curve_member)).degree() + 1;
      MaterialParameters raised;
      StageResult raised_result;
      for (size_t a = 0; a < std::min(attempts, starts.size()); ++a) {
        MaterialParameters trial = starts[a];
        say(0, fmt::format("{}: degree {} attempt {} starts with alpha_new = {:.3g}", stage.name, degree,
                           a + 1, (trial.*(stage.curve_member)).alpha.back()));
        const StageResult r = fit_at(stage, 0, &trial);
        if (r.ok && (!raised_result.ok || r.error < raised_result.error)) {
          raised = trial;
          raised_result = r;
        }
        if (raised_result.ok && 1.0 - raised_result.error / best_result.error >= min_improvement) break;
        if (a + 1 < std::min(attempts, starts.size()))
          note(fmt::format("{}: degree {} attempt {} improved the error by less than {:.0f} %: next start",
                           stage.name, degree, a + 1, 100 * min_improvement));
      }
      if (!raised_result.ok) break;
      const double improvement = 1.0 - raised_result.error / best_result.error;
      if (raised_result.error < best_result.error) {
        best = raised;
        best_result = raised_result;
      }
      if (improvement < min_improvement) {
        note(fmt::format("{}: raising to degree {} improved the error by {:.0f} % (< {:.0f} %): stop",
                         stage.name, degree, 100 * improvement, 100 * min_improvement));
        break;
      }
    }
    note(fmt::format("{}: degree {} chosen (error {:.2f} % at the coarsest level, target {:.1f} %)",
                     stage.name, (best.*(stage.curve_member)).degree(), 100 * best_result.error,
                     100 * target));
    params_ = best;
  }

  // ---- §5.5.4 resolution ladder ----------------------------------------------------------------
  /// A stage's fitted entries, membrane stiffness and membrane response at one level.
  struct Snapshot {
    std::string resolution;
    std::vector<std::string> names;
    std::vector<double> values;
    double stiffness_N_per_m = 0;
    std::vector<double> response_N_per_m;  ///< τ·σ of the stage's mode on membrane_strains()
  };

  /// Strains at which the stage's membrane response is compared: kResponseSamples points
  /// evenly over (0, the stage's cutoff], or over (0, kResponseStrainWithoutCutoff] when the
  /// cutoffs are off (a strip test seldom strains the yarns by more than that; the range only
  /// needs to cover what the fit saw).
  static constexpr int kResponseSamples = 20;
  static constexpr double kResponseStrainWithoutCutoff = 0.1;
  std::vector<double> membrane_strains(const Stage& stage) const {
    const std::optional<double>& cutoff = params_.cutoffs.*(stage.cutoff);
    const double top = cutoff ? *cutoff : kResponseStrainWithoutCutoff;
    std::vector<double> e;
    for (int i = 1; i <= kResponseSamples; ++i) e.push_back(top * i / kResponseSamples);
    return e;
  }

  Snapshot snapshot(const Stage& stage, int level) const {
    Snapshot s;
    s.resolution = resolution_text(setup_for(*runs_for(stage.angle_deg).front()->test, level));
    const ParameterMap map(params_, {stage.stiffness, stage.curve + ".*"});
    s.names = map.free_names();
    const Eigen::VectorXd flat = params_.to_flat();
    for (int i : map.free_indices()) s.values.push_back(flat[i]);
    const double stiffness = flat[params_.index_of(stage.stiffness)];
    s.stiffness_N_per_m = params_.thickness_m * stiffness;
    for (double e : membrane_strains(stage))
      s.response_N_per_m.push_back(stage.stress_factor * s.stiffness_N_per_m * e *
                                   evaluate_curve(params_.*(stage.curve_member), e * e).d1);
    return s;
  }

  static double relative_change(double from, double to) {
    return to == 0.0 ? std::abs(to - from) : std::abs(to - from) / std::abs(to);
  }

  FitRefinement compare(const Stage& stage, const Snapshot& from, const Snapshot& to) const {
    FitRefinement r;
    r.stage = stage.name;
    r.from_resolution = from.resolution;
    r.to_resolution = to.resolution;
    // Degrees are fixed after the coarsest level, so both levels have the same entries.
    for (size_t i = 0; i < to.names.size() && i < from.values.size(); ++i)
      r.changes.push_back({to.names[i], from.values[i], to.values[i], relative_change(from.values[i], to.values[i])});
    const std::string mode = stage.stiffness.substr(0, stage.stiffness.find('_'));
    r.changes.push_back({"tau_" + mode + "_N_per_m", from.stiffness_N_per_m, to.stiffness_N_per_m,
                         relative_change(from.stiffness_N_per_m, to.stiffness_N_per_m)});
    size_t worst = 0;
    for (size_t i = 0; i < to.response_N_per_m.size() && i < from.response_N_per_m.size(); ++i) {
      const double change = relative_change(from.response_N_per_m[i], to.response_N_per_m[i]);
      if (change > r.response_change) {
        r.response_change = change;
        worst = i;
      }
    }
    r.response_strain = membrane_strains(stage)[worst];
    return r;
  }

  /// What the ladder does after `level` (of the configured levels(), up to `last` with the
  /// extra ones), in the report's words.
  std::string ladder_decision(bool settled, int level, int last) const {
    const bool configured_left = level < levels() - 1;
    if (settled) return configured_left ? "settled: finer levels skipped" : "settled";
    if (configured_left) return "refined further";
    if (level < last) return "above tolerance at the last level: one more level";
    return "above tolerance, no level left (resolution.extra_levels)";
  }

  /// Phase B: every level, the coarsest included, refits each stage from the previous solution
  /// with all cutoffs in place (§5.5.4), so that successive levels differ by the mesh alone
  /// (the coarsest level's degree search ran before the cutoffs were set). From the second
  /// level on a stage's change from the previous one decides: at or below
  /// `resolution.change_tolerance` it is settled (finer levels skipped); still above at the
  /// last configured level, it gets up to `resolution.extra_levels` more.
  void refine_levels() {
    const Options& res = config_.get_section("resolution");
    const double tolerance = res.get_double("change_tolerance");
    const int last = levels() - 1 + static_cast<int>(res.get_int("extra_levels"));
    std::map<std::string, Snapshot> previous;
    std::vector<const Stage*> open;
    for (const Stage& stage : stages())
      if (!runs_for(stage.angle_deg).empty()) open.push_back(&stage);
    for (int level = 0; level <= last && !open.empty(); ++level) {
      finest_level_ = level;
      std::vector<const Stage*> still_open;
      for (const Stage* stage : open) {
        const auto t = Clock::now();
        MaterialParameters refined = params_;
        if (!fit_at(*stage, level, &refined, true).ok)
          throw std::runtime_error("stage " + stage->name + ": fit failed at level " + std::to_string(level));
        params_ = refined;
        report_.timing_s.emplace_back(stage->name + " (level " + std::to_string(level) + ")", seconds_since(t));
        const Snapshot now = snapshot(*stage, level);
        const auto before = previous.find(stage->name);
        if (before == previous.end()) {
          previous.emplace(stage->name, now);
          still_open.push_back(stage);
          continue;
        }
        FitRefinement r = compare(*stage, before->second, now);
        before->second = now;
        const bool settled = r.response_change <= tolerance;
        const std::string change = fmt::format(
            "membrane response changed up to {:.2f} % (at strain {:.3g}; {} {:+.2f} %) from {} to {} (tolerance {:.2f} %)",
            100 * r.response_change, r.response_strain, r.changes.back().name,
            100 * (r.changes.back().to - r.changes.back().from) / r.changes.back().to, r.from_resolution,
            r.to_resolution, 100 * tolerance);
        r.decision = ladder_decision(settled, level, last);
        note(r.stage + ": " + change + ": " + r.decision);
        if (!settled) still_open.push_back(stage);
        report_.refinement.push_back(std::move(r));
      }
      // One configured level: refitted once with the cutoffs, nothing to compare.
      open = levels() == 1 ? std::vector<const Stage*>{} : still_open;
    }
    report_.finest_resolution = resolution_text(setup_for(*fit_runs_.front().test, finest_level_));
  }

  // ---- §5.2 steps 4 and 6: cutoffs ------------------------------------------------------------
  // "The largest strain seen": the largest |Ẽ| component over the strip's mid-surface in the
  // stage's simulated tests at their largest measured extension, at the finest level
  // (TensileExperiment::largest_material_strain samples the strain field on a grid).
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

  double largest_simulated_strain(const Stage& stage, int component) const {
    double largest = 0;
    for (const RunData* d : runs_for(stage.angle_deg)) {
      TensileExperiment e(setup_for(*d->test, levels() - 1), factory_, params_, solver_);
      Eigen::VectorXd last;
      const TensileCurve c = e.run(strain_sample_schedule(d->extension_mm),
                                   [&](int, const Eigen::VectorXd& q, const EquilibriumSolver&) { last = q; });
      if (!c.completed || last.size() == 0) continue;
      largest = std::max(largest, e.largest_material_strain(last)[component]);
    }
    if (!(largest > 0))
      throw std::runtime_error("cutoffs: no converged " + stage.name + " simulation to measure strains on");
    return largest;
  }

  void set_stretch_cutoffs() {
    const double f = config_.get_section("stages").get_double("cutoff_fraction");
    params_.cutoffs.E11_max = f * largest_simulated_strain(stages()[0], 0);
    if (!runs_for(0.0).empty()) params_.cutoffs.E22_max = f * largest_simulated_strain(stages()[1], 1);
    note(fmt::format("cutoffs: E11_max {:.4g}, E22_max {}", *params_.cutoffs.E11_max,
                     params_.cutoffs.E22_max ? fmt::format("{:.4g}", *params_.cutoffs.E22_max) : "off"));
  }

  void set_shear_cutoff() {
    const double f = config_.get_section("stages").get_double("cutoff_fraction");
    params_.cutoffs.E12_max = f * largest_simulated_strain(stages()[2], 2);
    note(fmt::format("cutoff: E12_max {:.4g}", *params_.cutoffs.E12_max));
  }

  // ---- §5.2 step 7: bend -------------------------------------------------------------------------
  CantileverSetup bend_setup(const BendTest& b) const {
    const Options& o = config_.get_section("bend");
    CantileverSetup s;
    s.angle_deg = b.angle_deg;
    s.width_mm = b.width_mm;
    s.cells_across = static_cast<int>(o.get_int("cells_across"));
    s.cells_along = static_cast<int>(o.get_int("cells_along"));
    return s;
  }

  /// A bend test's experiment at the mean measured overhang, created through the registry (the
  /// config's `experiments.bend`), predicting the measured chord angle.
  std::shared_ptr<Experiment> bend_experiment(const BendTest& b) const {
    const CantileverSetup s = bend_setup(b);
    ExperimentInput input = experiment_input(b.label, s.angle_deg, s.width_mm, s.cells_across, s.cells_along, params_);
    input.schedule = {mean(b.overhang_mm)};
    input.measured = Eigen::VectorXd::Constant(1, b.chord_angle_deg);
    return registry_.create<ExperimentFactories>(registry_category::kExperiment,
                                                 config_.get_section("experiments").get_component("bend"), input);
  }

  void fit_bend() {
    const auto t = Clock::now();
    std::vector<std::shared_ptr<Predictor>> predictors;
    for (const BendTest& b : dataset_.bend) predictors.push_back(bend_experiment(b));
    ParameterMap::Options options;
    options.rescale_with_thickness = true;
    ParameterMap map(params_, {"thickness_m"}, options);
    FitObjective objective(map, predictors);
    objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd& x) {
      say(1, fmt::format("  bend it {:3d}: eps {:.4e}, tau {:.4g} mm", it.iteration, it.value,
                         1e3 * x[0] * params_.thickness_m));
    });
    std::unique_ptr<Optimizer> optimizer = make_stage_optimizer();
    const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
    if (!std::isfinite(r.summary.final_value))
      throw std::runtime_error("bend stage failed: " + r.message + " / " + objective.last_failure());
    params_ = map.parameters(r.x);
    objective.evaluate(r.x, nullptr);
    const FitStageRecord& rec = record_stage(
        "bend",
        fmt::format("{}x{}", config_.get_section("bend").get_int("cells_across"),
                    config_.get_section("bend").get_int("cells_along")),
        0, mean_error(objective, predictors.size()), *optimizer, r, objective, t);
    say(0, fmt::format("bend: tau {:.4g} mm, error {:.2f} % ({}, {} its)", 1e3 * params_.thickness_m,
                       100 * rec.avg_rel_error, rec.status, rec.iterations));
    for (size_t i = 0; i < dataset_.bend.size(); ++i) {
      const BendTest& b = dataset_.bend[i];
      FitBend fb;
      fb.label = b.label;
      fb.angle_deg = b.angle_deg;
      fb.measured_overhang_mm = mean(b.overhang_mm);
      fb.chord_angle_deg = objective.last_predictions()[i][0];
      if (config_.get_section("bend").get_bool("find_overhang")) {
        CantileverExperiment e(bend_setup(b), factory_, params_, solver_);
        const OverhangSearchResult s = e.find_overhang(b.chord_angle_deg);
        if (s.converged) fb.overhang_mm = s.overhang_mm;
      }
      report_.bend.push_back(fb);
    }
  }

  // ---- reports -------------------------------------------------------------------------------------
  FitCurve curve_record(const RunData& d, const std::string& role, const Eigen::VectorXd& simulated) const {
    FitCurve c;
    c.label = d.test->label;
    c.angle_deg = d.test->angle_deg;
    c.run = d.run->name();
    c.role = role;
    c.extension_mm = d.extension_mm;
    c.measured_N.assign(d.force_N.data(), d.force_N.data() + d.force_N.size());
    c.simulated_N.assign(simulated.data(), simulated.data() + simulated.size());
    c.avg_rel_error = (simulated - d.force_N).cwiseAbs().sum() / d.force_N.cwiseAbs().sum();
    return c;
  }

  // Simulated forces of several runs at given strip angles, at one level (final fit curves,
  // validation). Requests on the same test and angle share the strip, so one continuation over
  // the union of their extensions serves them all (a quasistatic equilibrium does not depend on
  // the loading path); the distinct curves run in parallel (TBB tasks, each with its own
  // discretisation and solver; assembly inside nests in the same scheduler). A request gets
  // nullopt when the curve stopped before its largest extension.
  struct CurveRequest {
    const RunData* run;
    double angle_deg;
  };
  /// A run's simulated forces at its extensions [N], and dF/dθ [N/°] when asked for.
  struct SimulatedRun {
    Eigen::VectorXd force_N, dforce_dangle;
  };
  /// A test's equilibria at one angle with dq/dθ per point: strips of that test at nearby
  /// angles start each point from q + Δθ dq/dθ (validation offsets) instead of continuing.
  struct AngleAnchor {
    double angle_deg = 0;
    std::vector<double> extensions;
    std::vector<Eigen::VectorXd> q, dq_dangle;
  };
  std::map<const TensileTest*, AngleAnchor> angle_anchors_;
  /// Each fit run's predictor of its stage's last fit, with that fit's level.
  std::map<const RunData*, std::pair<int, std::shared_ptr<Experiment>>> last_predictor_;

  /// Curve of `experiment` over `extensions`: warm-started from the test's angle anchor when
  /// it covers every extension (all points in parallel, TensileExperiment::run_from), by
  /// continuation otherwise or when a warm start fails.
  TensileCurve run_anchored(TensileExperiment& experiment, const TensileTest& test,
                            const std::vector<double>& extensions) const {
    const auto anchor = angle_anchors_.find(&test);
    if (anchor != angle_anchors_.end()) {
      const AngleAnchor& a = anchor->second;
      const double offset = experiment.setup().angle_deg - a.angle_deg;
      std::vector<Eigen::VectorXd> guesses;
      for (double e : extensions) {
        const auto at = std::find(a.extensions.begin(), a.extensions.end(), e);
        if (at == a.extensions.end()) break;
        const size_t j = static_cast<size_t>(at - a.extensions.begin());
        if (a.q[j].size() != experiment.discretization().num_dofs()) break;  // another level's anchor
        guesses.push_back(a.q[j] + offset * a.dq_dangle[j]);
      }
      if (guesses.size() == extensions.size()) {
        TensileCurve curve = experiment.run_from(extensions, guesses);
        if (curve.completed) return curve;
      }
    }
    return experiment.run(extensions);
  }

  /// Simulates every request at `level`; requests of one test at one angle share one
  /// continuation over the union of their extensions (the quasistatic equilibrium does not
  /// depend on the loading path), distinct ones run in parallel. nullopt where it stopped early.
  /// With `angle_derivative`, dF/dθ is reported and each curve becomes its test's angle anchor
  /// (later requests of that test at other angles are warm-started from it).
  std::vector<std::optional<SimulatedRun>> simulate_runs(const std::vector<CurveRequest>& requests,
                                                         int level, bool angle_derivative = false) {
    struct Group {
      const TensileTest* test;
      double angle_deg;
      std::vector<double> extensions;
      TensileCurve curve;
    };
    std::vector<Group> groups;
    std::vector<size_t> group_of(requests.size());
    for (size_t r = 0; r < requests.size(); ++r) {
      const CurveRequest& q = requests[r];
      auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& x) {
        return x.test == q.run->test && x.angle_deg == q.angle_deg;
      });
      if (g == groups.end()) g = groups.insert(groups.end(), Group{q.run->test, q.angle_deg, {}, {}});
      g->extensions.insert(g->extensions.end(), q.run->extension_mm.begin(), q.run->extension_mm.end());
      group_of[r] = static_cast<size_t>(g - groups.begin());
    }
    for (Group& g : groups) {
      std::sort(g.extensions.begin(), g.extensions.end());
      g.extensions.erase(std::unique(g.extensions.begin(), g.extensions.end()), g.extensions.end());
    }
    tbb::parallel_for(size_t{0}, groups.size(), [&](size_t i) {
      Group& g = groups[i];
      TensileSetup setup = setup_for(*g.test, level);
      setup.angle_deg = g.angle_deg;
      TensileExperiment experiment(setup, factory_, params_, solver_);
      experiment.set_angle_sensitivity(angle_derivative);
      experiment.set_keep_states(angle_derivative);
      g.curve = run_anchored(experiment, *g.test, g.extensions);
    });
    if (angle_derivative)
      for (Group& g : groups) {
        if (!g.curve.completed) continue;
        AngleAnchor& a = angle_anchors_[g.test];
        a = AngleAnchor{g.angle_deg, g.extensions, {}, {}};
        for (TensilePoint& p : g.curve.points) {
          a.q.push_back(std::move(p.q));
          a.dq_dangle.push_back(std::move(p.dq_dangle));
        }
      }
    std::vector<std::optional<SimulatedRun>> out(requests.size());
    for (size_t r = 0; r < requests.size(); ++r) {
      const std::vector<TensilePoint>& points = groups[group_of[r]].curve.points;
      const std::vector<double>& wanted = requests[r].run->extension_mm;
      SimulatedRun run{Eigen::VectorXd(static_cast<Eigen::Index>(wanted.size())),
                       Eigen::VectorXd(static_cast<Eigen::Index>(wanted.size()))};
      size_t j = 0;
      for (size_t i = 0; i < wanted.size(); ++i) {
        while (j < points.size() && points[j].extension_mm != wanted[i]) ++j;
        if (j == points.size()) break;
        run.force_N[static_cast<Eigen::Index>(i)] = points[j].force_N;
        run.dforce_dangle[static_cast<Eigen::Index>(i)] = points[j].dforce_dangle;
        if (i + 1 == wanted.size()) out[r] = run;
      }
    }
    return out;
  }

  /// Each fit run's curve at the final parameters and the finest level. A run whose stage
  /// ended at that level is re-evaluated by its last predictor, warm-started from the states of
  /// its last evaluation (the parameters changed at most by the bend stage's τ rescaling, which
  /// leaves the planar strip's membrane unchanged, so the guesses are the equilibria); the
  /// others are simulated along their schedules, in parallel with those.
  void final_fit_curves() {
    std::vector<CurveRequest> requests, simulated_requests;
    std::vector<std::shared_ptr<Experiment>> warm(fit_runs_.size());
    for (size_t r = 0; r < fit_runs_.size(); ++r) {
      const RunData& d = fit_runs_[r];
      requests.push_back({&d, d.test->angle_deg});
      const auto last = last_predictor_.find(&d);
      if (last != last_predictor_.end() && last->second.first == finest_level_)
        warm[r] = last->second.second;
      else
        simulated_requests.push_back(requests.back());
    }
    std::vector<std::optional<Eigen::VectorXd>> forces(fit_runs_.size());
    std::vector<std::optional<SimulatedRun>> simulated;
    tbb::parallel_invoke(
        [&] {
          for (size_t r = 0; r < warm.size(); ++r) {
            Eigen::VectorXd values;
            std::string message;
            if (warm[r] && warm[r]->predict(params_, {}, &values, nullptr, &message)) forces[r] = values;
          }
        },
        [&] { simulated = simulate_runs(simulated_requests, finest_level_); });
    // A warm start that failed is simulated along its schedule after all.
    std::vector<size_t> retry;
    for (size_t r = 0, k = 0; r < requests.size(); ++r) {
      if (!warm[r]) {
        if (simulated[k]) forces[r] = simulated[k]->force_N;
        ++k;
      } else if (!forces[r]) {
        retry.push_back(r);
      }
    }
    std::vector<CurveRequest> retry_requests;
    for (size_t r : retry) retry_requests.push_back(requests[r]);
    const auto retried = simulate_runs(retry_requests, finest_level_);
    for (size_t i = 0; i < retry.size(); ++i)
      if (retried[i]) forces[retry[i]] = retried[i]->force_N;
    for (size_t r = 0; r < requests.size(); ++r) {
      const RunData& d = *requests[r].run;
      if (!forces[r]) {
        note("final curve of " + run_label(d) + " did not converge");
        continue;
      }
      FitCurve c = curve_record(d, "fit", *forces[r]);
      for (const Stage& s : stages())
        if (std::abs(s.angle_deg - d.test->angle_deg) < 1e-9) c.degree = (params_.*(s.curve_member)).degree();
      report_.fit.push_back(c);
    }
  }

  // §7: the angle offset Δθ of each validation run, at the finest level (the off-axis
  // discretisation error of coarse levels is larger than the offsets themselves, measured:
  // a search at 8×12 picked +1° where the finest level's optimum is near 0°). A 1-D Newton
  // search on the run's error e(Δθ) = Σ|F(θ0 + Δθ) − F̆| / Σ|F̆| with the exact dF/dθ (Eq. 6,
  // TensileExperiment::set_angle_sensitivity) at the nominal angle and the secant through the
  // last two samples after that: at the current offset the forces are linear in
  // the step t, F + t F', and the step minimises Σ|F + t F' − F̆| exactly (a weighted median,
  // linearised_l1_minimiser); it is clamped to ±`validation.max_offset_deg`, rounded to
  // `validation.offset_resolution_deg`, and taken while it moves the offset by at least that
  // resolution, at most `validation.offset_iterations` times. The best evaluated offset wins
  // (Δθ = 0 is always evaluated). Runs of one test share their simulations (simulate_runs): the
  // nominal angle costs one curve per test, each later step one per distinct offset.
  // ---- effects (effects/effect.hpp) ---------------------------------------------------------------
  /// Whether an effect's per-run parameter is the strip's angle offset (its set-up hook turns
  /// the angle by its one per-run value): the validation offsets are then its values.
  static bool is_angle_offset(const Effect& effect) {
    if (effect.per_run_parameters().size() != 1) return false;
    ExperimentInput probe;
    const std::vector<SetupChange> changes = effect.adjust_setup(Eigen::VectorXd::Ones(1), &probe);
    return changes.size() == 1 && changes[0].quantity == setup_quantity::kAngle && changes[0].gradient.size() == 1 &&
           changes[0].gradient[0] == 1.0;
  }
  /// The configured angle-offset effect, or the registry's misalignment with its defaults:
  /// the validation stage turns its strips through this effect's set-up hook (§7's Δθ).
  std::shared_ptr<const Effect> angle_offset_effect() const {
    for (const auto& e : effects_)
      if (is_angle_offset(*e)) return e;
    const RegistryEntry& entry = registry_.find_category(registry_category::kEffect)->at(Misalignment::kName);
    return registry_.create<EffectFactories>(
        registry_category::kEffect,
        ComponentChoice{registry_category::kEffect, entry.name, default_options(entry.options, nullptr)});
  }
  double offset_angle(double nominal_deg, double offset_deg) const {
    ExperimentInput input;
    input.angle_deg = nominal_deg;
    offset_effect_->adjust_setup(Eigen::VectorXd::Constant(1, offset_deg), &input);
    return input.angle_deg;
  }
  /// Every configured effect must be identifiable from this dataset (its data predicate).
  void check_effects_data() const {
    const auto& choices = config_.get_component_list("effects");
    for (size_t i = 0; i < effects_.size(); ++i) {
      const std::string missing = effects_[i]->missing_data(dataset_);
      if (!missing.empty())
        throw InputError({"", 0, "effects[" + std::to_string(i) + "]"},
                         "effect '" + choices[i].name + "' cannot be fitted to dataset '" + dataset_.name + "': " + missing);
    }
  }
  /// The fitted model's effects: an angle-offset effect's model parameters estimated from
  /// the validation offsets (its per-run values); any other effect keeps its configured
  /// parameters (the fit estimates no other per-run values yet), which a note says.
  void estimate_effects() {
    const auto& choices = config_.get_component_list("effects");
    for (size_t i = 0; i < effects_.size(); ++i) {
      ComponentChoice fitted = choices[i];
      if (is_angle_offset(*effects_[i]) && !report_.validation.empty()) {
        std::vector<Eigen::VectorXd> offsets;
        for (const FitCurve& c : report_.validation) offsets.push_back(Eigen::VectorXd::Constant(1, c.delta_theta_deg));
        fitted.options = effects_[i]->estimated_from_runs(offsets, fitted.options);
        note("effect " + fitted.name + ": estimated from the " + std::to_string(offsets.size()) +
             " validation offsets");
      } else {
        note("effect " + fitted.name + ": parameters as configured (the fit estimates none of them)");
      }
      params_.effects.push_back(fitted);
    }
  }

  void validate() {
    const Options& v = config_.get_section("validation");
    const double max_offset = v.get_double("max_offset_deg");
    const double grid = v.get_double("offset_resolution_deg");
    const int iterations = static_cast<int>(v.get_int("offset_iterations"));
    struct Sample {
      double offset, error;
      SimulatedRun simulated;
    };
    std::vector<std::vector<Sample>> samples(validation_runs_.size());
    // (run, offset) pairs; the exact dF/dθ only where asked for (the nominal angle).
    auto sample_all = [&](const std::vector<std::pair<size_t, double>>& wanted, bool angle_derivative) {
      std::vector<CurveRequest> requests;
      for (const auto& [i, offset] : wanted)
        requests.push_back({&validation_runs_[i], offset_angle(validation_runs_[i].test->angle_deg, offset)});
      const auto simulated = simulate_runs(requests, finest_level_, angle_derivative);
      for (size_t r = 0; r < wanted.size(); ++r) {
        if (!simulated[r]) continue;
        const RunData& d = validation_runs_[wanted[r].first];
        samples[wanted[r].first].push_back(
            {wanted[r].second,
             (simulated[r]->force_N - d.force_N).cwiseAbs().sum() / d.force_N.cwiseAbs().sum(), *simulated[r]});
      }
    };
    // dF/dθ at the last sample: exact (Eq. 6) at the nominal angle, then the secant through
    // the run's last two samples (offsets are fractions of a degree, so the secant is as good
    // a slope as the tangent and needs no turned meshes); samples closer than
    // kSecantMinimumDeg keep the nominal slope (forces are converged to ~1e-8 of themselves,
    // so a closer secant would be mostly solver tolerance).
    static constexpr double kSecantMinimumDeg = 0.01;
    auto slope = [](const std::vector<Sample>& run) -> Eigen::VectorXd {
      const Sample& last = run.back();
      if (run.size() < 2) return last.simulated.dforce_dangle;
      const Sample& before = run[run.size() - 2];
      if (std::abs(last.offset - before.offset) < kSecantMinimumDeg) return run.front().simulated.dforce_dangle;
      return (last.simulated.force_N - before.simulated.force_N) / (last.offset - before.offset);
    };
    std::vector<std::pair<size_t, double>> wanted;
    for (size_t i = 0; i < validation_runs_.size(); ++i) wanted.emplace_back(i, 0.0);
    for (int iteration = 0; !wanted.empty(); ++iteration) {
      sample_all(wanted, iteration == 0);
      wanted.clear();
      if (iteration == iterations) break;
      for (size_t i = 0; i < validation_runs_.size(); ++i) {
        if (samples[i].empty()) continue;
        const Sample& last = samples[i].back();
        const double step =
            linearised_l1_minimiser(last.simulated.force_N, slope(samples[i]), validation_runs_[i].force_N);
        double next = std::clamp(last.offset + step, -max_offset, max_offset);
        if (grid > 0) next = grid * std::round(next / grid);
        const bool seen = std::any_of(samples[i].begin(), samples[i].end(), [&](const Sample& s) {
          return std::abs(s.offset - next) < 0.5 * std::max(grid, 1e-9);
        });
        if (!seen) wanted.emplace_back(i, next);
      }
    }
    for (size_t i = 0; i < validation_runs_.size(); ++i) {
      const RunData& d = validation_runs_[i];
      const auto nominal = std::find_if(samples[i].begin(), samples[i].end(),
                                        [](const Sample& s) { return s.offset == 0.0; });
      if (nominal == samples[i].end()) {
        note("validation " + run_label(d) + " did not converge at the nominal angle");
        continue;
      }
      const Sample& best = *std::min_element(samples[i].begin(), samples[i].end(),
                                             [](const Sample& a, const Sample& b) { return a.error < b.error; });
      FitCurve c = curve_record(d, "validation", best.simulated.force_N);
      c.delta_theta_deg = best.offset;
      c.avg_rel_error_without_offset = nominal->error;
      report_.validation.push_back(c);
      say(0, fmt::format("validation {}: offset {:+.2f} deg, error {:.2f} % (without offset {:.2f} %, {} evaluations)",
                         run_label(d), best.offset, 100 * c.avg_rel_error, 100 * c.avg_rel_error_without_offset,
                         samples[i].size()));
    }
  }

  const Dataset& dataset_;
  const Options& config_;
  const Registry& registry_;
  FitProgress progress_;
  ComponentChoice discretization_;
  DiscretizationFactory factory_;
  EquilibriumOptions solver_;
  std::vector<RunData> fit_runs_, validation_runs_;
  std::vector<std::shared_ptr<const Effect>> effects_;  ///< the config's, in its order
  std::shared_ptr<const Effect> offset_effect_;         ///< turns the validation strips
  MaterialParameters params_;
  int finest_level_ = 0;  ///< the finest level any stage reached (final curves, validation)
  FitReport report_;
};

}  // namespace

FitReport run_fit(const Dataset& dataset, const Options& config, const Registry& registry,
                  const FitProgress& progress, FitReport* finished) {
  Protocol protocol(dataset, config, registry, progress);
  try {
    return protocol.run();
  } catch (...) {
    if (finished) *finished = protocol.finished_so_far();
    throw;
  }
}

}  // namespace twill
