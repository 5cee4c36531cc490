#include "fitting/fit_context.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "core/discretization_registry.hpp"
#include "effects/effect_experiment.hpp"
#include "core/input_error.hpp"
#include "experiments/uniform_strain.hpp"

namespace twill {

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

double geometric_mean(const std::vector<double>& v) {
  double log_sum = 0;
  for (double x : v) log_sum += std::log(x);
  return v.empty() ? 0.0 : std::exp(log_sum / static_cast<double>(v.size()));
}

std::vector<double> run_errors(const FitObjective& objective, size_t n) {
  std::vector<double> e;
  for (size_t i = 0; i < n; ++i) e.push_back(objective.average_relative_error(static_cast<int>(i)));
  return e;
}

double mean_run_error(const FitObjective& objective, size_t n) { return mean(run_errors(objective, n)); }

// Two tests' angles are one curve's when they agree to this (degrees; angles are read from
// the same decimal text, so any finite tolerance far below a cut's precision serves).
constexpr double kSameAngleDeg = 1e-9;
bool same_angle(double a, double b) { return std::abs(a - b) < kSameAngleDeg; }

namespace {

// At most max_points of `rows`, evenly spread, first and last kept.
std::vector<size_t> spread(const std::vector<size_t>& rows, size_t max_points) {
  if (rows.size() <= max_points) return rows;
  std::vector<size_t> chosen;
  for (size_t j = 0; j < max_points; ++j) chosen.push_back(rows[(j * (rows.size() - 1)) / (max_points - 1)]);
  return chosen;
}

// The rows [first, last] that pull the strip above the data selection's force floor (in file
// order; with `increasing`, only rows beyond every earlier kept extension).
std::vector<size_t> pulling_rows(const TensileRun& run, size_t first, size_t last, double floor, bool increasing) {
  std::vector<size_t> keep;
  double last_extension = -1e300;
  for (size_t i = first; i <= last && i < run.size(); ++i)
    if (run.force_N[i] > floor && run.force_N[i] > 0 && run.extension_mm[i] > 0 &&
        (!increasing || run.extension_mm[i] > last_extension)) {
      keep.push_back(i);
      last_extension = run.extension_mm[i];
    }
  return keep;
}

RunData run_data(const TensileTest& test, const TensileRun& run, const std::vector<size_t>& rows, double floor) {
  RunData d;
  d.test = &test;
  d.run = &run;
  d.force_N.resize(static_cast<Eigen::Index>(rows.size()));
  for (size_t j = 0; j < rows.size(); ++j) {
    d.extension_mm.push_back(run.extension_mm[rows[j]]);
    if (run.has_time()) d.time_s.push_back(run.time_s[rows[j]]);
    if (run.has_lateral_strain()) d.lateral_strain.push_back(run.lateral_strain[rows[j]]);
    d.force_N[static_cast<Eigen::Index>(j)] = run.force_N[rows[j]];
  }
  if (d.extension_mm.size() < 2)
    throw InputError({run.path, 0, "force_N"}, "fewer than 2 usable points in the loading branch (forces above " +
                                                   fmt::format("{:.3g}", floor) + " N)");
  return d;
}

double force_floor(const TensileRun& run, const FitDataSelection& data) {
  return data.min_force_fraction *
         *std::max_element(run.force_N.begin(), run.force_N.begin() + static_cast<long>(run.peak_index) + 1);
}

}  // namespace

RunData measured_points(const TensileTest& test, const TensileRun& run, const FitDataSelection& data) {
  const double floor = force_floor(run, data);
  const auto rows = pulling_rows(run, 0, run.peak_index, floor, true);
  return run_data(test, run, spread(rows, static_cast<size_t>(data.max_points)), floor);
}

RunData measured_path(const TensileTest& test, const TensileRun& run, const FitDataSelection& data) {
  const double floor = force_floor(run, data);
  const auto max_points = static_cast<size_t>(data.max_points);
  std::vector<size_t> rows = spread(pulling_rows(run, 0, run.peak_index, floor, true), max_points);
  const std::vector<size_t> unloading = spread(pulling_rows(run, run.peak_index + 1, run.size() - 1, floor, false),
                                               max_points);
  rows.insert(rows.end(), unloading.begin(), unloading.end());
  return run_data(test, run, rows, floor);
}

RunConditions FitContext::run_conditions(const RunData& d, double angle_deg) {
  RunConditions run;
  run.observable = "force_N";
  run.schedule_quantity = "extension_mm";
  run.schedule = d.extension_mm;
  run.angle_deg = angle_deg;
  run.width_mm = d.test->width_mm;
  run.gauge_length_mm = d.test->gauge_length_mm;
  run.rate_mm_min = d.test->rate_mm_min.value_or(0.0);
  run.time_s = d.time_s;
  return run;
}

const std::vector<MembraneTerm>& membrane_terms() {
  static const std::vector<MembraneTerm> terms = {
      {"eta1", "a11_Pa", &MaterialParameters::a11_Pa, &MaterialParameters::eta1, &Cutoffs::E11_max, "E11", 0, 1.0, 1.0, 0.0},
      {"eta3", "a22_Pa", &MaterialParameters::a22_Pa, &MaterialParameters::eta3, &Cutoffs::E22_max, "E22", 1, 1.0, 1.0, 1.0},
      {"eta4", "G12_Pa", &MaterialParameters::G12_Pa, &MaterialParameters::eta4, &Cutoffs::E12_max, "E12", 2, 2.0,
       0.25, 0.01}};
  return terms;
}

const MembraneTerm& membrane_term(const std::string& curve) {
  for (const MembraneTerm& t : membrane_terms())
    if (t.curve == curve) return t;
  throw std::logic_error("no membrane term '" + curve + "'");
}

StrainExcess strain_excess(const std::vector<Eigen::Vector3d>& samples, int component,
                           const std::optional<double>& cutoff) {
  StrainExcess e;
  for (const Eigen::Vector3d& s : samples) {
    e.largest = std::max(e.largest, s[component]);
    if (cutoff && s[component] > *cutoff) e.share_beyond += 1.0 / static_cast<double>(samples.size());
  }
  return e;
}

FitContext::FitContext(const Dataset& dataset, const FitConfig& config, const Registry& registry,
                       FitProgress progress)
    : dataset_(dataset), config_(config), registry_(registry), progress_(std::move(progress)) {
  factory_ = [this](const StripSpec& strip, const MaterialParameters& p) {
    return registry_.create<DiscretizationFactories>(registry_category::kDiscretization, config_.discretization,
                                                     strip, p);
  };
  solver_.gradient_tolerance = config.solver.gradient_tolerance;
  for (const ComponentChoice& choice : config.effects)
    effects.push_back(registry_.create<EffectFactories>(registry_category::kEffect, choice));
}

void FitContext::say(int level, const std::string& line) const {
  if (progress_) progress_(level, line);
}

void FitContext::note(const std::string& line) {
  if (out_) out_->notes.push_back(line);
  say(0, line);
}

const FitStageRecord& FitContext::record_stage(const std::string& stage, const std::string& resolution, int degree,
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
  if (!out_) throw std::logic_error("FitContext::record_stage outside a stage");
  out_->stages.push_back(rec);
  return out_->stages.back();
}

std::vector<const RunData*> FitContext::runs_for(double angle_deg) const {
  std::vector<const RunData*> out;
  for (const RunData& d : fit_runs)
    if (same_angle(d.test->angle_deg, angle_deg)) out.push_back(&d);
  return out;
}

const CurveStage* FitContext::fitted_curve_at(double angle_deg) const {
  for (const CurveStage& c : fitted_curves)
    if (same_angle(c.angle_deg, angle_deg)) return &c;
  return nullptr;
}

TensileSetup FitContext::setup_for(const TensileTest& test, int level) const {
  TensileSetup s;
  s.angle_deg = test.angle_deg;
  s.width_mm = test.width_mm;
  s.gauge_length_mm = test.gauge_length_mm;
  s.cells_across = config_.resolution.coarse_cells_across << level;
  s.cells_along = std::max(1, static_cast<int>(std::lround(s.cells_across * test.gauge_length_mm / test.width_mm)));
  return s;
}

std::string FitContext::resolution_text(int cells_across, int cells_along) {
  return std::to_string(cells_across) + "x" + std::to_string(cells_along);
}

ExperimentInput FitContext::experiment_input(std::string label, double angle_deg, double width_mm, int cells_across,
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

ExperimentInput FitContext::tensile_input(const RunData& d, int level, const MaterialParameters& p) const {
  const TensileSetup s = setup_for(*d.test, level);
  ExperimentInput input =
      experiment_input(run_label(d), strip_angle(d), s.width_mm, s.cells_across, s.cells_along, p);
  input.length_mm = s.gauge_length_mm;
  input.schedule = d.extension_mm;
  input.measured = d.force_N;
  input.rate_mm_min = d.test->rate_mm_min.value_or(0.0);
  input.time_s = d.time_s;
  return input;
}

ComponentChoice FitContext::tensile_choice(const std::string& name) const {
  ComponentChoice choice = config_.tensile_experiment;
  if (!name.empty()) choice.name = name;
  return choice;
}

std::shared_ptr<Experiment> FitContext::tensile_experiment(const RunData& d, int level, const MaterialParameters& p,
                                                           const std::string& name) const {
  return create_experiment(registry_, tensile_choice(name), tensile_input(d, level, p));
}

std::vector<std::shared_ptr<Experiment>> FitContext::tensile_experiments(const std::vector<const RunData*>& runs,
                                                                         int level, const MaterialParameters& p) const {
  std::vector<ExperimentInput> inputs;
  for (const RunData* d : runs) inputs.push_back(tensile_input(*d, level, p));
  return create_experiments(registry_, tensile_choice(""), inputs);
}

std::shared_ptr<Experiment> FitContext::bend_experiment(const BendTest& b, const MaterialParameters& p) const {
  ExperimentInput input = experiment_input(b.label, b.angle_deg, b.width_mm, 0, 0, p);
  input.schedule = {mean(b.overhang_mm)};
  input.measured = Eigen::VectorXd::Constant(1, b.chord_angle_deg);
  return create_experiment(registry_, config_.bend_experiment, input);
}

std::shared_ptr<Predictor> FitContext::uniform_strain_predictor(const RunData& d) const {
  return std::make_shared<UniformStrainPredictor>(run_label(d), setup_for(*d.test, 0), d.extension_mm, d.force_N);
}

std::unique_ptr<Optimizer> FitContext::make_optimizer(bool refine) const {
  return make_optimizer(config_.optimizer, refine);
}

std::unique_ptr<Optimizer> FitContext::make_optimizer(ComponentChoice choice, bool refine) const {
  const FitStopping& stop = config_.stopping;
  choice.options.set("max_iterations", refine ? stop.refine_max_iterations : stop.max_iterations);
  choice.options.set("max_evaluations", stop.max_evaluations);
  choice.options.set("gradient_tolerance", stop.gradient_tolerance);
  choice.options.set("function_tolerance", refine ? stop.refine_function_tolerance : stop.function_tolerance);
  return registry_.create<OptimizerFactories>(registry_category::kOptimizer, choice);
}

// A degree raise's first optimiser step at most this long in the fit's coordinates x = k/|k0|
// (1: a parameter moves by at most its own start value). A raise's new term makes the
// Jacobian nearly flat along the line where it merges with an old one; there Gauss–Newton's
// undamped first step was 5.3e3 long and the canvas bias raise slid onto the degree-1 line
// (docs/fitting.md §3b). The option's name is Gauss–Newton's; an optimiser without it keeps
// its own rule.
constexpr double kRaiseMaxFirstStep = 1.0;
constexpr const char* kFirstStepOption = "max_first_step";

std::unique_ptr<Optimizer> FitContext::make_raise_optimizer() const {
  ComponentChoice choice = config_.optimizer;
  const RegistryCategory* optimizers = registry_.find_category(registry_category::kOptimizer);
  const RegistryEntry* entry = optimizers ? optimizers->find(choice.name) : nullptr;
  if (entry && entry->options.find(kFirstStepOption)) choice.options.set(kFirstStepOption, kRaiseMaxFirstStep);
  return make_optimizer(choice);
}

FitContext::CurveFit FitContext::fit_curve(const CurveStage& stage, int level, MaterialParameters* p, CurveStart start) {
  const auto t = Clock::now();
  const auto runs = runs_for(stage.angle_deg);
  std::vector<std::shared_ptr<Predictor>> predictors;
  std::string resolution;
  const std::vector<std::shared_ptr<Experiment>> experiments = tensile_experiments(runs, level, *p);
  for (size_t i = 0; i < runs.size(); ++i) {
    const TensileSetup s = setup_for(*runs[i]->test, level);
    resolution = resolution_text(s.cells_across, s.cells_along);
    last_predictor[runs[i]] = {level, experiments[i]};
    predictors.push_back(experiments[i]);
  }
  ParameterMap map(*p, stage.free_parameters());
  FitObjective objective(map, predictors);
  objective.set_scale_groups(scale_groups(runs, predictors.size()));
  const int degree = ((*p).*(stage.term->curve_member)).degree();
  objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd&) {
    say(1, fmt::format("  {} {} degree {} it {:3d}: eps {:.4e} |g| {:.2e} ({} solves)", stage.label, resolution,
                       degree, it.iteration, it.value, it.gradient_norm, objective.equilibrium_solves()));
  });
  std::unique_ptr<Optimizer> optimizer =
      start == CurveStart::raise ? make_raise_optimizer() : make_optimizer(start == CurveStart::refine);
  const OptimizerResult r = optimizer->minimize(objective, map.initial_x());
  CurveFit out;
  if (!std::isfinite(r.summary.final_value)) {
    out.failure = fmt::format("optimiser failed ({}): {}", to_string(r.status), r.message);
    note(fmt::format("{} {} degree {}: {}", stage.label, resolution, degree, out.failure));
    return out;
  }
  // The predictors keep their last trial's states; a final point that cannot be re-evaluated
  // from there is the optimiser's failure (its error would be NaN), not a result.
  if (!std::isfinite(objective.evaluate(r.x, nullptr))) {
    out.failure = "the optimiser's final point could not be re-evaluated: " + objective.last_failure();
    note(fmt::format("{} {} degree {}: {}", stage.label, resolution, degree, out.failure));
    return out;
  }
  *p = map.parameters(r.x);
  out.ok = true;
  out.scales = objective.scales();
  out.error = mean_run_error(objective, runs.size());
  const FitStageRecord& rec = record_stage(stage.label, resolution, degree, out.error, *optimizer, r, objective, t);
  say(0, fmt::format("{} {} degree {}: error {:.2f} % ({}, {} its, {} solves, {:.1f} s){}", stage.label, resolution,
                     degree, 100 * out.error, rec.status, rec.iterations, rec.equilibrium_solves, rec.wall_time_s,
                     r.status == OptimizerStatus::converged ? "" : ": " + rec.message));
  return out;
}

std::vector<int> FitContext::scale_groups(const std::vector<const RunData*>& runs, size_t predictors) const {
  if (config_.repeats.scale == SpecimenScale::None) return {};
  // One gauge per fitted curve, i.e. per angle (a tensile-curve stage fits every run at its
  // angle): the flat direction the gauge removes is the curve's stiffness against its runs'
  // common factor. A gauge per test over-constrains when several tests share a curve (one per
  // crosshead speed): each test's specimens were then forced to average 1 on their own, and
  // the chance difference of two small groups' means (≈ 7 % for two specimens each at 10 %
  // scatter) became a misfit no effect explains (docs/fitting.md §3a).
  std::vector<int> groups(predictors, -1);
  std::vector<double> angles;
  for (size_t i = 0; i < runs.size(); ++i) {
    const double angle = runs[i]->test->angle_deg;
    auto at = std::find_if(angles.begin(), angles.end(), [&](double a) { return same_angle(a, angle); });
    if (at == angles.end()) at = angles.insert(angles.end(), angle);
    groups[i] = static_cast<int>(at - angles.begin());
  }
  return groups;
}

void FitContext::keep_scales(const std::vector<const RunData*>& runs, const std::vector<double>& scales) {
  if (config_.repeats.scale == SpecimenScale::None) return;
  for (size_t i = 0; i < runs.size(); ++i)
    for (RunData& d : fit_runs)
      if (d.test == runs[i]->test && d.run == runs[i]->run) d.specimen_scale = scales.at(i);
}

FitCurve FitContext::curve_record(const RunData& d, const std::string& role, const Eigen::VectorXd& simulated) {
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

}  // namespace twill
