#pragma once
// Effect: a named extension of the paper's model with parameters of its own (registry
// category "effect"; issue #14, docs/extending.md). The effect library (hysteresis,
// rate dependence, misalignment, …) and `twill discover` are built on this interface.
//
// An effect has
//   - model parameters: its registered option schema (name with the unit as suffix, e.g.
//     `spread_deg`; bounds; default; doc). They are what params.yaml carries under `effects:`
//     (core/params_io.hpp) and what a simulator uses; the factory receives their values;
//   - per-run parameters: nuisance parameters every run of a dataset gets (e.g. the angle at
//     which that strip was cut), solved by a fit and reported, not written to params.yaml;
//   - a data predicate, missing_data(): what a dataset must carry for the effect to be
//     identifiable (unloading rows, several rates, lateral strain, bend directions, repeats
//     per angle), in words when it is missing;
//   - hooks through which it changes predictions: the material law (with ∂k'/∂k), an
//     experiment's set-up, the observables (what a path-dependent effect adds along the run's
//     schedule, with its derivatives). Every hook has a no-op default; an effect overrides the
//     ones it uses. A set-up hook returns d(set-up quantity)/d(per-run parameter), which
//     chains with the experiment's set-up derivatives (experiments/experiment.hpp) into exact
//     derivatives of the observables in the effect's parameters. effect_experiment.hpp puts
//     the law and observable hooks around any registered experiment.
//
// The model parameters are also the last block of the material's flat vector
// (core/parameters.hpp), so a fit frees them by name like any material parameter.
//
// Flat view: effect_parameters() lists the model parameters of a model's effects as the
// optimisers see any parameter (name, unit, bounds, value; in a fixed order) and
// set_effect_parameters() writes such a vector back, bounds checked.
//
// Factory: (resolved options = the model parameters) -> the effect.
#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/dataset.hpp"
#include "core/parameters.hpp"
#include "core/registry.hpp"
#include "experiments/experiment.hpp"

namespace twill {

/// One scalar parameter of an effect, as optimisers and reports see it.
struct EffectParameter {
  std::string name;  ///< e.g. "misalignment.spread_deg", "misalignment.offset_deg"
  std::string unit;  ///< the name's suffix after the last '_', e.g. "deg"
  std::string doc;   ///< one line
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  double value = 0;  ///< the current value (a per-run parameter: its default)
};

/// How a set-up hook changed one set-up quantity: d(quantity)/d(each per-run parameter).
struct SetupChange {
  std::string quantity;     ///< setup_quantity::kAngle, ...
  Eigen::VectorXd gradient;  ///< one entry per per-run parameter of the effect
};

/// What an observable hook sees of one run (effect_experiment.hpp builds it from the
/// experiment and its input).
struct RunConditions {
  std::string observable;         ///< the experiment's, e.g. "force_N"
  std::string schedule_quantity;  ///< e.g. "extension_mm"
  std::vector<double> schedule;   ///< in the order the lab applied it (loading, unloading)
  double angle_deg = 90;          ///< strip axis vs weft [deg]
  double width_mm = 0, gauge_length_mm = 0;  ///< the strip's (0: not a strip)
  double rate_mm_min = 0;         ///< crosshead speed; 0 when not known
  std::vector<double> time_s;     ///< per schedule entry; empty when not known
};

/// What an observable hook adds to a run's m observables, with its derivatives.
struct ObservableChange {
  Eigen::VectorXd added;    ///< m entries, in the observable's unit
  Eigen::MatrixXd d_flat;   ///< m × k.flat_size(): ∂added/∂k
  Eigen::VectorXd d_angle;  ///< m: ∂added/∂(angle_deg)
  /// No change for m observables and a flat vector of n entries.
  static ObservableChange zero(Eigen::Index m, Eigen::Index n);
};

class Effect {
 public:
  virtual ~Effect() = default;

  /// Empty when `dataset` carries what this effect needs, otherwise what is missing, e.g.
  /// "needs at least two repeats at some tensile angle".
  virtual std::string missing_data(const Dataset& dataset) const = 0;

  /// What `twill discover` holds out to confirm this effect (docs/discovery.md §1): other
  /// specimens (the default), or the tests at another crosshead speed, for an effect that
  /// claims to predict one speed from another (issue #16's held-out check by observation type).
  enum class HeldOut { specimens, speeds };
  virtual HeldOut held_out() const { return HeldOut::specimens; }

  /// The parameters each run gets (with their defaults as values); none by default.
  virtual std::vector<EffectParameter> per_run_parameters() const { return {}; }
  /// The model parameters estimated from the runs' fitted per-run values (one vector per run,
  /// in per_run_parameters() order), e.g. a spread from offsets. Default: unchanged.
  virtual Options estimated_from_runs(const std::vector<Eigen::VectorXd>& run_values, const Options& model) const {
    (void)run_values;
    return model;
  }

  /// Hook: the material law an experiment simulates, k -> k'. With `jacobian`, also ∂k'/∂k
  /// (flat × flat in k's layout, which k' shares; the effect's own parameters are k's last
  /// columns, parameters.hpp), so that predictions chain to k exactly. Default: k' = k.
  virtual MaterialParameters adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const;
  /// Hook: the set-up of one run's experiment, given that run's per-run values. Returns the
  /// quantities it changed with their derivatives. Default: no change.
  virtual std::vector<SetupChange> adjust_setup(const Eigen::VectorXd& run_values, ExperimentInput* input) const {
    (void)run_values;
    (void)input;
    return {};
  }
  /// Whether observable_change() adds anything (false by default: no path-dependent part).
  virtual bool changes_observables() const { return false; }
  /// Hook: what the effect adds to a run's observables, given the run's conditions and the
  /// (law-adjusted) material k, with its derivatives in k's flat vector and in the strip's
  /// angle. Only called when changes_observables(). An effect that cannot predict this run
  /// (e.g. a rate effect without a clock) throws InputError saying what is missing.
  virtual ObservableChange observable_change(const RunConditions& run, const MaterialParameters& k) const;
};

using EffectFactories = FactoryCategory<Effect>;

/// The model parameters of `effects` (params.yaml's `effects:`) as one flat list: every
/// double option of each effect in schema order, named "<effect>.<option>", with the
/// schema's bounds. Integer, bool and text options are choices, not parameters: skipped.
std::vector<EffectParameter> effect_parameters(const std::vector<ComponentChoice>& effects, const Registry& registry);
/// Writes `values` (effect_parameters() order) back into `effects`. Throws InputError naming
/// the parameter when a value violates its bounds, std::invalid_argument on a size mismatch.
void set_effect_parameters(const Eigen::VectorXd& values, const Registry& registry,
                           std::vector<ComponentChoice>* effects);

/// The unit of a parameter named with its unit as suffix: "spread_deg" -> "deg",
/// "warp_friction_N_m" -> "N/m" (compound units: kCompoundUnits in effect.cpp), and "1" for
/// a dimensionless name ending in _ratio or _strain; empty when the name has no '_'.
std::string unit_of(const std::string& name);

/// Whether some tensile run of `dataset` satisfies `has` (the data predicates' common form).
template <class Predicate>
bool any_tensile_run(const Dataset& dataset, Predicate has) {
  for (const TensileTest& test : dataset.tensile)
    for (const TensileRun& run : test.runs)
      if (has(test, run)) return true;
  return false;
}

/// The flat index (parameters.hpp) of the effect parameter "<effect>.<option>" of k.
int effect_flat_index(const MaterialParameters& k, const std::string& effect, const std::string& option);

}  // namespace twill
