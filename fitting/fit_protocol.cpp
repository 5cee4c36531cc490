#include "fitting/fit_protocol.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <memory>
#include <numeric>

#include "core/input_error.hpp"
#include "core/repeat_selection.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_effects.hpp"
#include "fitting/fit_stage.hpp"

namespace twill {

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

std::vector<std::unique_ptr<FitStage>> make_stages(const FitConfig& config, const Registry& registry) {
  std::vector<std::unique_ptr<FitStage>> stages;
  for (const ComponentChoice& choice : config.protocol)
    stages.push_back(registry.create<FitStageFactories>(registry_category::kStage, choice));
  return stages;
}

/// Up-front checks of the protocol: unique curve labels, a warp-stretch stage (the initial
/// guess starts from a11), and each stage's own check against the stages before it.
void check_stages(const std::vector<std::unique_ptr<FitStage>>& stages, const Dataset& dataset,
                  const FitConfig& config, const Registry& registry, const ConfigKeyLocator& locate) {
  ProtocolCheck check;
  check.dataset = &dataset;
  check.registry = &registry;
  check.levels = config.resolution.levels;
  check.locate = locate;
  if (const RegistryCategory* effects = registry.find_category(registry_category::kEffect))
    for (const RegistryEntry& e : effects->entries()) check.registered_effects.push_back(e.name);
  for (const ComponentChoice& e : config.effects) check.configured_effects.push_back(e.name);
  bool has_eta1 = false;
  for (size_t i = 0; i < stages.size(); ++i) {
    check.key = "protocol[" + std::to_string(i) + "]";
    stages[i]->check(check);
    has_eta1 = has_eta1 || stages[i]->sets_all_parameters();
    if (const CurveStage* curve = stages[i]->curve_stage()) {
      if (std::find(check.curve_labels.begin(), check.curve_labels.end(), curve->label) != check.curve_labels.end())
        throw InputError(locate(check.key + ".label"), "a second tensile-curve stage labelled '" + curve->label + "'");
      check.curve_labels.push_back(curve->label);
      has_eta1 = has_eta1 || curve->term->curve == "eta1";
    }
  }
  if (!has_eta1)
    throw InputError(locate("protocol"), "the protocol needs a tensile-curve stage with term eta1 or a start-from stage (a11: the "
                                         "initial guess and the other stiffnesses start from it)");
}

}  // namespace

void select_data(FitContext& context) {
  const FitConfig& config = context.config();
  for (const TensileTest& test : context.dataset().tensile) {
    const RepeatSelection sel = select_repeats(test, config.repeats.rule, static_cast<std::uint64_t>(config.repeats.seed));
    if (test.role == TestRole::Fit) {
      context.note(test.label + ": " + sel.reason);
      for (size_t i : sel.runs) context.fit_runs.push_back(measured_points(test, test.runs[i], config.data));
    } else {
      for (const TensileRun& run : test.runs) context.validation_runs.push_back(measured_points(test, run, config.data));
    }
  }
  for (const CurveStage& stage : context.declared_curves)
    if (stage.term->curve == "eta1" && context.runs_for(stage.angle_deg).empty())
      throw InputError({context.dataset().folder + "/fabric.yaml", 0, "tensile"},
                       fmt::format("the fit needs a {} test (angle_deg: {:g}, role: fit)", stage.label, stage.angle_deg));
}

namespace {

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

/// §5.3's start: the dataset's density and thickness, linear curves, and each term's
/// stiffness from the small-strain slopes of its stage's runs (MembraneTerm::slope_factor), or
/// a fraction of a11 when no stage of the protocol has a test for it; a12 tied (§5.2). The
/// runs' slopes are averaged arithmetically, or geometrically when each run has its own
/// specimen scale (`repeats.scale: per-run`: the fit's stiffness is then the geometric-mean
/// specimen's, core/specimen_scale.hpp).
void start_from_slopes(FitContext& context) {
  MaterialParameters& p = context.params;
  p.density_kg_m2 = 1e-3 * context.dataset().areal_density_g_m2;
  p.thickness_m = 1e-3 * context.dataset().thickness_mm;
  p.eta1 = p.eta3 = p.eta4 = Curve::linear();
  const double tau = p.thickness_m;
  for (const MembraneTerm& term : membrane_terms()) {
    std::vector<double> moduli;
    for (const CurveStage& stage : context.declared_curves)
      if (stage.term == &term && moduli.empty())
        for (const RunData* d : context.runs_for(stage.angle_deg))
          moduli.push_back(small_strain_membrane_modulus(*d) / tau);
    const bool per_run = context.config().repeats.scale == SpecimenScale::PerRun;
    p.*(term.stiffness_member) = moduli.empty() ? term.fraction_of_a11_without_test * p.a11_Pa
                                 : per_run      ? term.slope_factor * geometric_mean(moduli)
                                                : term.slope_factor * mean(moduli);
  }
  p.a12_Pa = MaterialParameters::tied_a12(p.a11_Pa, p.a22_Pa);
  context.note(fmt::format("initial slopes: a11 {:.4g} Pa, a22 {:.4g} Pa, G12 {:.4g} Pa (tau {:.3g} mm)", p.a11_Pa,
                           p.a22_Pa, p.G12_Pa, 1e3 * tau));
}

/// Appends a stage's report to the fit's; its timings first, then the stage's own (a title
/// seen before gets " #n", report.json keys timings by title).
void merge(FitReport& report, FitReport&& part, const std::string& title, double seconds) {
  auto append = [](auto& to, auto& from) { std::move(from.begin(), from.end(), std::back_inserter(to)); };
  append(report.initial_guess, part.initial_guess);
  append(report.stages, part.stages);
  append(report.refinement, part.refinement);
  append(report.fit, part.fit);
  append(report.bend, part.bend);
  append(report.validation, part.validation);
  append(report.validation_strain, part.validation_strain);
  append(report.effects, part.effects);
  append(report.notes, part.notes);
  append(report.timing_s, part.timing_s);
  if (!part.finest_resolution.empty()) report.finest_resolution = part.finest_resolution;
  std::string key = title;
  for (int n = 2; std::any_of(report.timing_s.begin(), report.timing_s.end(),
                              [&](const auto& t) { return t.first == key; });
       ++n)
    key = title + " #" + std::to_string(n);
  report.timing_s.emplace_back(key, seconds);
}

InputLocation default_config_location(const std::string& key) { return {"config", 0, key}; }

}  // namespace

void check_fit_protocol(const Dataset& dataset, const Options& config, const Registry& registry,
                        const ConfigKeyLocator& locate) {
  const FitConfig typed = read_fit_config(config);
  check_stages(make_stages(typed, registry), dataset, typed, registry, locate);
}

// What the fit ended with: its parameters, finest level and each curve stage's degree.
void record_end(const FitContext& context, FitReport* report) {
  report->parameters = context.params;
  report->finest_level = context.finest_level;
  report->curve_degrees.clear();
  for (const CurveStage& c : context.fitted_curves)
    report->curve_degrees.emplace_back(c.label, (context.params.*(c.term->curve_member)).degree());
}

FitReport run_fit(const Dataset& dataset, const Options& options, const Registry& registry,
                  const FitProgress& progress, FitReport* finished) {
  const auto start = Clock::now();
  const FitConfig config = read_fit_config(options);
  std::vector<std::unique_ptr<FitStage>> stages = make_stages(config, registry);
  check_stages(stages, dataset, config, registry, default_config_location);
  FitContext context(dataset, config, registry, progress);
  for (const auto& stage : stages)
    if (const CurveStage* curve = stage->curve_stage()) context.declared_curves.push_back(*curve);
  FitReport report;
  report.dataset = dataset.name;
  report.folder = dataset.folder;
  FitReport part;        // the running stage's
  std::string running;   // its title
  auto stage_start = Clock::now();
  try {
    context.set_output(&report);
    check_effects_data(dataset, config, registry);
    select_data(context);
    // A protocol that opens by setting every parameter (start-from) has no slopes to start from.
    if (stages.empty() || !stages.front()->sets_all_parameters()) start_from_slopes(context);
    context.params.effects = config.effects;  // at their configured values: neutral by default
    for (const auto& stage : stages) {
      part = FitReport{};
      context.set_output(&part);
      running = stage->title();
      stage_start = Clock::now();
      stage->run(context, part);
      merge(report, std::move(part), running, seconds_since(stage_start));
      running.clear();
    }
    context.set_output(&report);
    context.params.effects = estimate_effects(context, report.validation);
  } catch (...) {
    if (finished) {
      if (!running.empty()) merge(report, std::move(part), running + " (failed)", seconds_since(stage_start));
      *finished = report;
      record_end(context, finished);
    }
    throw;
  }
  report.timing_s.emplace_back("total", seconds_since(start));
  record_end(context, &report);
  return report;
}

}  // namespace twill
