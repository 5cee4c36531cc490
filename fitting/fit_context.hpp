#pragma once
// The state a fit's stages share (fitting/fit_stage.hpp) and the steps several of them take:
// the measured points of the fit and validation runs, the parameters so far, the tensile-curve
// stages of the protocol, the mesh of a run at a level of the resolution ladder, the
// experiments and optimisers from the registry, one curve fit of a stage at one level (paper
// Eq. 3 over the stage's runs), and the records the report is made of. Every choice is read
// from the typed FitConfig (fitting/fit_config.hpp); nothing here looks a key up.
#include <Eigen/Core>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/dataset.hpp"
#include "core/equilibrium_solver.hpp"
#include "core/fit_objective.hpp"
#include "core/parameters.hpp"
#include "core/registry.hpp"
#include "effects/effect.hpp"
#include "experiments/experiment.hpp"
#include "experiments/tensile_strip.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_protocol.hpp"
#include "optimizers/optimizer.hpp"

namespace twill {

/// A fit run's measured points: the loading branch, small forces dropped, evenly thinned
/// (FitDataSelection).
struct RunData {
  const TensileTest* test = nullptr;
  const TensileRun* run = nullptr;
  std::vector<double> extension_mm;
  Eigen::VectorXd force_N;
  std::vector<double> time_s;  ///< of the chosen rows; empty when the run has no clock
  std::vector<double> lateral_strain;  ///< of the chosen rows; empty when the run has none
  /// The angle the run's strip is simulated at once the misalignment effect-fit has turned it
  /// (OffsetSearch::turned_angle, docs/effects/misalignment.md); the test's nominal angle
  /// while empty.
  std::optional<double> strip_angle_deg;
  /// The run's specimen scale s_r once a fit with `repeats.scale: per-run` has profiled it
  /// (core/specimen_scale.hpp): its simulated forces are s_r times the strip's; 1 otherwise.
  double specimen_scale = 1;
  /// The measured forces in the geometric-mean specimen's terms, p̆ / s_r (what a search with
  /// the run's scale held compares the strip's forces with).
  Eigen::VectorXd unscaled_force_N() const { return force_N / specimen_scale; }
};
RunData measured_points(const TensileTest& test, const TensileRun& run, const FitDataSelection& data);
/// As measured_points, but the whole path in file order: the loading branch's points, then
/// the unloading branch's (each spread over at most data.max_points rows above the floor),
/// for effects whose predictions depend on the path (docs/effects/strip_path.md).
RunData measured_path(const TensileTest& test, const TensileRun& run, const FitDataSelection& data);

/// A term of ψ that a tensile-curve stage fits (model.md §2), with what the protocol needs of
/// it. Its part of ψ is stress_factor/2 · a · η(E²): a/2 η(E²) for a stretch, G12 η4(E12²) for
/// the shear; the stress is stress_factor · a · E · η'(E²).
struct MembraneTerm {
  std::string curve;       ///< "eta1": the curve's entries are free ("eta1.*")
  std::string stiffness;   ///< "a11_Pa": free with the curve
  double MaterialParameters::*stiffness_member;
  Curve MaterialParameters::*curve_member;
  std::optional<double> Cutoffs::*cutoff;
  std::string cutoff_name;  ///< "E11", for notes
  int strain_component;     ///< 0, 1, 2: Ẽ11, Ẽ22, Ẽ12 (TensileExperiment::material_strain_samples)
  double stress_factor;
  /// The initial guess (§5.3): stiffness = slope_factor · small-strain modulus / τ (a stretch:
  /// 1; the shear: ¼, a stiff-yarn bias strip deforming by shear alone has modulus ≈ 4 G12).
  double slope_factor;
  /// The initial guess without a test for this term: this fraction of a11 (eta3: 1, the weft
  /// as stiff as the warp; eta4: 0.01, the shear of a stiff-yarn weave; eta1 needs its test).
  double fraction_of_a11_without_test;
};
/// The highest degree a tensile-curve stage raises a curve to (its max_degree's range).
inline constexpr int kMaxCurveDegree = 6;

/// eta1 (warp stretch), eta3 (weft stretch), eta4 (shear): the terms a strip test identifies.
const std::vector<MembraneTerm>& membrane_terms();
const MembraneTerm& membrane_term(const std::string& curve);

/// A strip's strain field against a cutoff (docs/fitting.md §7): over strain samples on an
/// even grid (TensileExperiment::material_strain_samples), the largest |component| and the
/// share of samples above `cutoff` (a share of the strip's area; 0 without a cutoff).
struct StrainExcess {
  double largest = 0, share_beyond = 0;
};
StrainExcess strain_excess(const std::vector<Eigen::Vector3d>& samples, int component,
                           const std::optional<double>& cutoff);

/// A tensile-curve stage as the other stages see it.
struct CurveStage {
  std::string label;  ///< "warp"
  double angle_deg = 0;
  const MembraneTerm* term = nullptr;
  std::vector<std::string> free_parameters() const { return {term->stiffness, term->curve + ".*"}; }
};

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t);
double mean(const std::vector<double>& v);
/// exp(mean(log v)) of positive values (0 for none).
double geometric_mean(const std::vector<double>& v);
/// The first n runs' average relative errors (model.md §8), and their mean.
std::vector<double> run_errors(const FitObjective& objective, size_t n);
double mean_run_error(const FitObjective& objective, size_t n);
/// Whether two tests' angles [deg] are one curve's (read from the same decimal text).
bool same_angle(double a, double b);

class FitContext {
 public:
  FitContext(const Dataset& dataset, const FitConfig& config, const Registry& registry, FitProgress progress);

  const Dataset& dataset() const { return dataset_; }
  const FitConfig& config() const { return config_; }
  const Registry& registry() const { return registry_; }

  // ---- what the stages share ----
  MaterialParameters params;
  std::vector<RunData> fit_runs, validation_runs;
  std::vector<CurveStage> declared_curves;  ///< every tensile-curve stage of the protocol, in order
  std::vector<CurveStage> fitted_curves;    ///< those that ran, in order (the ladder refits them)
  int finest_level = 0;                     ///< the finest level any stage reached
  std::vector<std::shared_ptr<const Effect>> effects;  ///< the config's, in its order
  /// Each fit run's predictor of its stage's last fit, with that fit's level (final curves
  /// re-evaluate it warm).
  std::map<const RunData*, std::pair<int, std::shared_ptr<Experiment>>> last_predictor;

  // ---- output: progress lines, and notes and records into the running stage's report ----
  void set_output(FitReport* out) { out_ = out; }
  void say(int level, const std::string& line) const;
  void note(const std::string& line);
  /// Records one optimisation of a stage (its report row) and returns it.
  const FitStageRecord& record_stage(const std::string& stage, const std::string& resolution, int degree,
                                     double error, const Optimizer& optimizer, const OptimizerResult& r,
                                     const FitObjective& objective, Clock::time_point start);

  // ---- data and meshes ----
  std::vector<const RunData*> runs_for(double angle_deg) const;
  const CurveStage* fitted_curve_at(double angle_deg) const;
  /// The strip of `test` at ladder level `level` (level 0: coarse_cells_across across).
  TensileSetup setup_for(const TensileTest& test, int level) const;
  int levels() const { return config_.resolution.levels; }
  static std::string run_label(const RunData& d) { return d.test->label + " " + d.run->name(); }
  /// The angle the run's strip is simulated at (RunData::strip_angle_deg, else nominal).
  static double strip_angle(const RunData& d) { return d.strip_angle_deg.value_or(d.test->angle_deg); }
  /// The run's strip angle minus its test's nominal angle (0 unless turned).
  static double strip_offset(const RunData& d) { return strip_angle(d) - d.test->angle_deg; }
  /// What the effects' observable hooks see of a run's strip at `angle_deg` (its schedule,
  /// geometry and clock).
  static RunConditions run_conditions(const RunData& d, double angle_deg);
  static std::string resolution_text(int cells_across, int cells_along);

  // ---- parts from the registry ----
  const DiscretizationFactory& discretization() const { return factory_; }
  const EquilibriumOptions& solver() const { return solver_; }
  /// An experiment's input on this fit's discretisation and solver (schedule and measured
  /// values are the caller's).
  ExperimentInput experiment_input(std::string label, double angle_deg, double width_mm, int cells_across,
                                   int cells_along, const MaterialParameters& p) const;
  /// A fit run's experiment at `level` from `p` (config experiments.tensile; `name`: another
  /// registered experiment with the same options, e.g. tensile-lateral) predicting d.force_N.
  std::shared_ptr<Experiment> tensile_experiment(const RunData& d, int level, const MaterialParameters& p,
                                                 const std::string& name = "") const;
  /// The fit runs' experiments at `level` from `p` (config experiments.tensile), each
  /// predicting its run's forces; runs of one strip share a simulation where that halves the solves
  /// (create_experiments, experiments/shared_schedule.hpp). Same order as `runs`.
  std::vector<std::shared_ptr<Experiment>> tensile_experiments(const std::vector<const RunData*>& runs, int level,
                                                               const MaterialParameters& p) const;
  /// A bend test's experiment from `p` at the mean measured overhang (config experiments.bend,
  /// its cells its own), predicting the measured chord angle.
  std::shared_ptr<Experiment> bend_experiment(const BendTest& b, const MaterialParameters& p) const;
  /// A fit run's uniform-strain predictor (paper §5.3; the strip's cells do not matter to it).
  std::shared_ptr<Predictor> uniform_strain_predictor(const RunData& d) const;
  /// The config's optimiser (or `choice`) with the stages' limits (`refine`: a ladder refit's).
  std::unique_ptr<Optimizer> make_optimizer(bool refine = false) const;
  std::unique_ptr<Optimizer> make_optimizer(ComponentChoice choice, bool refine = false) const;
  /// The config's optimiser for a degree raise: its first step bounded where the optimiser
  /// leaves that to an option (Gauss–Newton's max_first_step; BFGS and Ipopt always bound it).
  std::unique_ptr<Optimizer> make_raise_optimizer() const;

  // ---- the step several stages take ----
  struct CurveFit {
    double error = 0;
    bool ok = false;
    std::vector<double> scales;  ///< the runs' profiled specimen scales (runs_for order; all 1 without)
    std::string failure;         ///< why, when not ok (also in the notes)
  };
  /// Where a curve fit starts: a stage's first fit, a degree raise (§5.4: a converged curve plus
  /// a new term, next to a line of stationary points), or a ladder refit (a converged solution
  /// of the same degree, with the ladder's limits).
  enum class CurveStart { first, raise, refine };
  /// Fits `stage`'s free parameters of *p to its runs at `level` (Eq. 3), records it. The
  /// caller that keeps *p keeps the result's scales (keep_scales).
  CurveFit fit_curve(const CurveStage& stage, int level, MaterialParameters* p, CurveStart start = CurveStart::first);
  /// A fit or validation run's curve record with its simulated forces.
  static FitCurve curve_record(const RunData& d, const std::string& role, const Eigen::VectorXd& simulated);

  // ---- the repeat scatter (`repeats.scale`, core/specimen_scale.hpp) ----
  /// The scale groups of an objective whose first runs.size() predictors predict these runs'
  /// forces (one group per angle, i.e. per fitted curve; none after them); empty when the config models no scatter.
  std::vector<int> scale_groups(const std::vector<const RunData*>& runs, size_t predictors) const;
  /// Keeps the first runs.size() of `scales` (an objective's profiled scales) as those fit
  /// runs' RunData::specimen_scale; nothing when the config models no scatter.
  void keep_scales(const std::vector<const RunData*>& runs, const std::vector<double>& scales);

 private:
  ExperimentInput tensile_input(const RunData& d, int level, const MaterialParameters& p) const;
  /// The config's tensile experiment, or the registered `name` with its options.
  ComponentChoice tensile_choice(const std::string& name) const;

  const Dataset& dataset_;
  const FitConfig& config_;
  const Registry& registry_;
  FitProgress progress_;
  DiscretizationFactory factory_;
  EquilibriumOptions solver_;
  FitReport* out_ = nullptr;
};

}  // namespace twill
