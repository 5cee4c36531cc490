#pragma once
// A registered experiment with the model's effects around it (effects/effect.hpp,
// docs/effects.md): the law hooks change the material before the experiment simulates it,
// the observable hooks add what path-dependent effects contribute along the run's schedule.
//
// Derivatives (paper Eq. 6 extended by the chain rule). With k the flat parameters (the
// material's and, last, the effects', core/parameters.hpp), k' = h(k) the law-adjusted
// material (the effects' law hooks in params.yaml order, J = ∂k'/∂k their chained Jacobians)
// and a(k') what the observable hooks add,
//
//     p̂(k) = p̂_exp(k') + a(k'),     ∂p̂/∂k = (∂p̂_exp/∂k' + ∂a/∂k') · J.
//
// The inner experiment is asked for ∂p̂_exp/∂k' only in the law's entries that some
// requested column of J reaches (so its warm starts and Eq. 6 solves stay as they were).
// Effects are instantiated from k.effects on every call: their parameters are the values of
// the flat vector the caller passes (a fit moves them like any parameter).
#include <memory>
#include <string>
#include <vector>

#include "core/registry.hpp"
#include "effects/effect.hpp"

namespace twill {

class EffectExperiment final : public Experiment {
 public:
  EffectExperiment(std::unique_ptr<Experiment> inner, const Registry& registry, RunConditions run);

  std::string observable() const override { return inner_->observable(); }
  std::string schedule_quantity() const override { return inner_->schedule_quantity(); }
  const std::vector<double>& schedule() const override { return inner_->schedule(); }
  ExperimentRun simulate(const MaterialParameters& k) override;
  std::vector<std::string> setup_sensitivities() const override { return inner_->setup_sensitivities(); }
  bool predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                 Eigen::VectorXd* values, Eigen::MatrixXd* jacobian, std::string* message) override;
  bool last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const override { return inner_->last_surface(V, F); }

  std::string label() const override { return inner_->label(); }
  const Eigen::VectorXd& measured() const override { return inner_->measured(); }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string* message) override;
  long equilibrium_solves() const override { return inner_->equilibrium_solves(); }

  /// The experiment the effects wrap (e.g. to reach a TensilePredictor's curve).
  Experiment& inner() { return *inner_; }
  const RunConditions& conditions() const { return run_; }

 private:
  std::unique_ptr<Experiment> inner_;
  const Registry& registry_;
  RunConditions run_;

  struct Adjusted {
    MaterialParameters material;  ///< k'
    Eigen::MatrixXd jacobian;     ///< ∂k'/∂k
    std::vector<std::unique_ptr<Effect>> effects;
  };
  Adjusted adjust(const MaterialParameters& k, bool with_jacobian) const;
  // Adds the observable hooks' contributions for the first values.size() schedule entries.
  void add_observable_changes(const Adjusted& a, Eigen::VectorXd* values, Eigen::MatrixXd* d_adjusted,
                              Eigen::VectorXd* d_angle) const;
};

/// The registered experiment `name` built from `input`, wrapped in an EffectExperiment when
/// input.start carries effects (otherwise the experiment itself: the paper's model costs
/// nothing extra). The inner experiment starts from the law-adjusted material. The run's conditions come from the input and, where the input leaves the
/// strip's width or gauge at 0, from the experiment's options.
std::unique_ptr<Experiment> create_experiment(const Registry& registry, const std::string& name,
                                              const Options& options, const ExperimentInput& input);
/// As above with the experiment's options resolved from a component choice.
std::unique_ptr<Experiment> create_experiment(const Registry& registry, const ComponentChoice& choice,
                                              const ExperimentInput& input);

/// create_experiment for the runs of one fit at once (the same discretisation and solver):
/// inputs that are the same strip (angle, size, resolution, material) share one simulation
/// on the union of their schedules when that saves at least half the points
/// (experiments/shared_schedule.hpp); each keeps its own schedule, measured values, label,
/// clock and effects' observable hooks. Same order as `inputs`.
std::vector<std::shared_ptr<Experiment>> create_experiments(const Registry& registry, const ComponentChoice& choice,
                                                            const std::vector<ExperimentInput>& inputs);

/// What the observable hooks of `effects` add to a run of m observables at the law-adjusted
/// material k' (the sum of their ObservableChange), for code that simulates the elastic part
/// itself (fitting/strip_curves.cpp) and for EffectExperiment.
ObservableChange observable_additions(const std::vector<std::unique_ptr<Effect>>& effects, const RunConditions& run,
                                      const MaterialParameters& adjusted, Eigen::Index m);
/// The effects of k.effects, instantiated with their parameters.
std::vector<std::unique_ptr<Effect>> instantiate_effects(const MaterialParameters& k, const Registry& registry);

/// The experiment inside any effect wrappers (e.g. to reach a CantileverPredictor's search).
Experiment& innermost(Experiment& experiment);

/// k' = the law hooks of `effects` applied to k in order, with J = ∂k'/∂k (their chained
/// Jacobians) when `jacobian` is given.
MaterialParameters apply_law_hooks(const std::vector<std::unique_ptr<Effect>>& effects, const MaterialParameters& k,
                                   Eigen::MatrixXd* jacobian = nullptr);
/// The material with every effect of k.effects' law hook applied (k' above), for code that
/// simulates without an experiment (the strain cutoffs, the strip curves).
MaterialParameters law_adjusted(const MaterialParameters& k, const Registry& registry);

}  // namespace twill
