#include "effects/effect_experiment.hpp"

#include <algorithm>
#include <stdexcept>

#include "experiments/shared_schedule.hpp"

namespace twill {
namespace {

// The flat entries of k' that the inner experiment must differentiate: law entries (before
// the effects' block, which the law does not see) reached by some requested column of J.
std::vector<int> law_entries_reached(const Eigen::MatrixXd& jacobian, const std::vector<int>& flat, int law_size) {
  std::vector<int> reached;
  for (int i = 0; i < law_size; ++i)
    for (int j : flat)
      if (jacobian(i, j) != 0.0) {
        reached.push_back(i);
        break;
      }
  return reached;
}

// Columns `flat` of m.
Eigen::MatrixXd columns(const Eigen::MatrixXd& m, const std::vector<int>& flat) {
  Eigen::MatrixXd out(m.rows(), static_cast<Eigen::Index>(flat.size()));
  for (size_t c = 0; c < flat.size(); ++c) out.col(static_cast<Eigen::Index>(c)) = m.col(flat[c]);
  return out;
}

}  // namespace

EffectExperiment::EffectExperiment(std::unique_ptr<Experiment> inner, const Registry& registry, RunConditions run)
    : inner_(std::move(inner)), registry_(registry), run_(std::move(run)) {
  run_.observable = inner_->observable();
  run_.schedule_quantity = inner_->schedule_quantity();
  run_.schedule = inner_->schedule();
}

EffectExperiment::Adjusted EffectExperiment::adjust(const MaterialParameters& k, bool with_jacobian) const {
  Adjusted a;
  a.effects = instantiate_effects(k, registry_);
  a.material = apply_law_hooks(a.effects, k, with_jacobian ? &a.jacobian : nullptr);
  return a;
}

void EffectExperiment::add_observable_changes(const Adjusted& a, Eigen::VectorXd* values, Eigen::MatrixXd* d_adjusted,
                                              Eigen::VectorXd* d_angle) const {
  const ObservableChange change = observable_additions(a.effects, run_, a.material, values->size());
  *values += change.added;
  if (d_adjusted) *d_adjusted += change.d_flat;
  if (d_angle) *d_angle += change.d_angle;
}

ExperimentRun EffectExperiment::simulate(const MaterialParameters& k) {
  const Adjusted a = adjust(k, false);
  ExperimentRun run = inner_->simulate(a.material);
  add_observable_changes(a, &run.values, nullptr, nullptr);
  return run;
}

bool EffectExperiment::predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
                               Eigen::MatrixXd* jacobian, std::string* message) {
  const Adjusted a = adjust(k, jacobian != nullptr);
  if (!jacobian) {
    if (!inner_->predict(a.material, {}, values, nullptr, message)) return false;
    add_observable_changes(a, values, nullptr, nullptr);
    return true;
  }
  const std::vector<int> reached = law_entries_reached(a.jacobian, flat, FlatLayout(k).effects);
  Eigen::MatrixXd inner_jacobian;
  if (!inner_->predict(a.material, reached, values, &inner_jacobian, message)) return false;
  Eigen::MatrixXd d_adjusted = Eigen::MatrixXd::Zero(values->size(), k.flat_size());
  for (size_t c = 0; c < reached.size(); ++c) d_adjusted.col(reached[c]) = inner_jacobian.col(static_cast<Eigen::Index>(c));
  add_observable_changes(a, values, &d_adjusted, nullptr);
  *jacobian = d_adjusted * columns(a.jacobian, flat);
  return true;
}

bool EffectExperiment::predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                                 Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                                 std::string* message) {
  const Adjusted a = adjust(k, false);
  if (!inner_->predict_setup_derivatives(a.material, quantities, values, jacobian, message)) return false;
  Eigen::VectorXd d_angle = Eigen::VectorXd::Zero(values->size());
  add_observable_changes(a, values, nullptr, &d_angle);
  for (size_t q = 0; q < quantities.size(); ++q)
    if (quantities[q] == setup_quantity::kAngle) jacobian->col(static_cast<Eigen::Index>(q)) += d_angle;
  return true;
}

namespace {

// What the observable hooks see of the run `input` describes (the strip's size from the
// experiment's options where the input leaves it at 0).
RunConditions run_conditions(const Options& options, const ExperimentInput& input) {
  RunConditions run;
  run.angle_deg = input.angle_deg;
  auto resolved = [&options](double given, const char* key) {
    return given > 0 ? given : options.has(key) ? options.get_double(key) : 0.0;
  };
  run.width_mm = resolved(input.width_mm, "width_mm");
  run.gauge_length_mm = resolved(input.length_mm, "gauge_length_mm");
  run.rate_mm_min = input.rate_mm_min;
  run.time_s = input.time_s;
  return run;
}

// `experiment` (built from the law-adjusted material) in the effects of input.start, or
// itself when there are none.
std::unique_ptr<Experiment> with_effects(std::unique_ptr<Experiment> experiment, const Registry& registry,
                                         const Options& options, const ExperimentInput& input) {
  if (input.start.effects.empty()) return experiment;
  return std::make_unique<EffectExperiment>(std::move(experiment), registry, run_conditions(options, input));
}

// The input with the law-adjusted material its inner experiment starts from.
ExperimentInput law_adjusted_input(const ExperimentInput& input, const Registry& registry) {
  ExperimentInput adjusted = input;
  if (!input.start.effects.empty()) adjusted.start = law_adjusted(input.start, registry);
  return adjusted;
}

// Whether two inputs are the same strip (create_experiments: they may share a simulation).
bool same_strip(const ExperimentInput& a, const ExperimentInput& b) {
  return a.angle_deg == b.angle_deg && a.width_mm == b.width_mm && a.length_mm == b.length_mm &&
         a.cells_across == b.cells_across && a.cells_along == b.cells_along && a.start == b.start;
}

// The inputs by strip (same_strip), in order of first appearance.
std::vector<std::vector<size_t>> strips(const std::vector<ExperimentInput>& inputs) {
  std::vector<std::vector<size_t>> groups;
  for (size_t i = 0; i < inputs.size(); ++i) {
    auto at = std::find_if(groups.begin(), groups.end(),
                           [&](const std::vector<size_t>& g) { return same_strip(inputs[g.front()], inputs[i]); });
    if (at == groups.end()) groups.push_back({i});
    else at->push_back(i);
  }
  return groups;
}

}  // namespace

std::unique_ptr<Experiment> create_experiment(const Registry& registry, const std::string& name, const Options& options,
                                              const ExperimentInput& input) {
  const ComponentChoice choice{registry_category::kExperiment, name, options};
  std::unique_ptr<Experiment> experiment = registry.create<ExperimentFactories>(
      registry_category::kExperiment, choice, law_adjusted_input(input, registry));
  return with_effects(std::move(experiment), registry, options, input);
}

std::unique_ptr<Experiment> create_experiment(const Registry& registry, const ComponentChoice& choice,
                                              const ExperimentInput& input) {
  return create_experiment(registry, choice.name, choice.options, input);
}

std::vector<std::shared_ptr<Experiment>> create_experiments(const Registry& registry, const ComponentChoice& choice,
                                                            const std::vector<ExperimentInput>& inputs) {
  std::vector<std::shared_ptr<Experiment>> out(inputs.size());
  for (const std::vector<size_t>& group : strips(inputs)) {
    std::vector<std::vector<double>> schedules;
    for (size_t i : group) schedules.push_back(inputs[i].schedule);
    const ScheduleUnion u = schedule_union(schedules);
    if (!shares_enough(u, schedules)) {
      for (size_t i : group) out[i] = create_experiment(registry, choice, inputs[i]);
      continue;
    }
    ExperimentInput whole = law_adjusted_input(inputs[group.front()], registry);
    whole.label += " (shared by " + std::to_string(group.size()) + " runs)";
    whole.schedule = u.entries;
    whole.measured.resize(0);
    whole.time_s.clear();
    auto shared = std::make_shared<SharedSchedule>(
        registry.create<ExperimentFactories>(registry_category::kExperiment, choice, whole));
    for (size_t j = 0; j < group.size(); ++j) {
      const ExperimentInput& input = inputs[group[j]];
      auto view = std::make_unique<ScheduleView>(shared, input.label, input.schedule, input.measured, u.rows[j], j == 0);
      out[group[j]] = with_effects(std::move(view), registry, choice.options, input);
    }
  }
  return out;
}

std::vector<std::unique_ptr<Effect>> instantiate_effects(const MaterialParameters& k, const Registry& registry) {
  std::vector<std::unique_ptr<Effect>> effects;
  for (const ComponentChoice& choice : k.effects)
    effects.push_back(registry.create<EffectFactories>(registry_category::kEffect, choice));
  return effects;
}

ObservableChange observable_additions(const std::vector<std::unique_ptr<Effect>>& effects, const RunConditions& run,
                                      const MaterialParameters& adjusted, Eigen::Index m) {
  ObservableChange sum = ObservableChange::zero(m, adjusted.flat_size());
  for (const auto& effect : effects) {
    if (!effect->changes_observables()) continue;
    const ObservableChange change = effect->observable_change(run, adjusted);
    // The path state of entry i depends on entries ≤ i only: the first m are those of a run
    // that stopped early.
    sum.added += change.added.head(m);
    sum.d_flat += change.d_flat.topRows(m);
    sum.d_angle += change.d_angle.head(m);
  }
  return sum;
}

Experiment& innermost(Experiment& experiment) {
  auto* wrapper = dynamic_cast<EffectExperiment*>(&experiment);
  return wrapper ? innermost(wrapper->inner()) : experiment;
}

MaterialParameters apply_law_hooks(const std::vector<std::unique_ptr<Effect>>& effects, const MaterialParameters& k,
                                   Eigen::MatrixXd* jacobian) {
  MaterialParameters adjusted = k;
  if (jacobian) jacobian->setIdentity(k.flat_size(), k.flat_size());
  for (const auto& effect : effects) {
    Eigen::MatrixXd step;
    adjusted = effect->adjusted_material(adjusted, jacobian ? &step : nullptr);
    if (jacobian) *jacobian = step * *jacobian;
  }
  return adjusted;
}

MaterialParameters law_adjusted(const MaterialParameters& k, const Registry& registry) {
  return apply_law_hooks(instantiate_effects(k, registry), k);
}

}  // namespace twill
