#pragma once
// The paper's fitting protocol end to end (paper §5.2–5.5, §6.4, §7; model.md §8): a dataset
// in, simulation-ready parameters and a report out. `twill fit` (app/command_fit.cpp) is a thin
// shell around run_fit() and write_fit_outputs().
//
// Why a folder of its own: the protocol uses every module (core's objective, experiments'
// predictors, a discretisation and an optimiser chosen by name from the registry), so it fits
// none of them (architecture.md allows such a folder).
//
// The protocol is data (issue #14 item 3): the fit config (fitting/fit_config.hpp) holds the
// fit-wide choices and `protocol`, a list of stage specifications run in order — by default
// the paper's, fitting/protocols/paper.yaml, which `twill fit --print-config` prints resolved.
// Each stage kind is a registered part (fitting/fit_stage.hpp, fitting/stages/):
//   initial-guess      §5.3   uniform-strain fits from the small-strain slopes
//   tensile-curve      §5.2, §5.4  one term of ψ fitted to the strips at one angle, degree raised
//   strain-cutoff      §5.2 steps 4, 6  a curve stage's cutoff at a fraction of the largest strain seen
//   resolution-ladder  §5.5.4  every level refits the curve stages before it, while they change
//   bend               §5.2 step 7  the thickness from the cantilever chord angles
//   final-curves              every fit run at the final parameters, finest level
//   validation         §7     the off-axis strips with their angle offsets Δθ
// Before the stages: the repeats of §6.4 per tensile test (`repeats`), each run's loading
// branch thinned (`data`), and the start of §5.3 from the small-strain slopes; after them,
// the effects' parameters (fitting/fit_effects.hpp). The report is the stages' reports, merged
// in order, with each stage's time. docs/fitting.md has the details and the measurements.
#include <Eigen/Core>
#include <array>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <nlohmann/json_fwd.hpp>
#include <vector>

#include "core/config.hpp"
#include "core/dataset.hpp"
#include "core/parameters.hpp"
#include "core/registry.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_input_checks.hpp"

namespace twill {

/// One line of progress (stage, resolution, iteration, current error). `level` 0 = stage
/// boundaries, 1 = iterations.
using FitProgress = std::function<void(int level, const std::string& line)>;

struct FitCurve {
  std::string label;  ///< test label, e.g. "warp"
  double angle_deg = 0;
  std::string run;    ///< run name, e.g. "warp-1"
  std::string role;   ///< "fit" or "validation"
  int degree = 0;     ///< degree of the stage's curve (0 for validation)
  std::string resolution;  ///< fit runs: the level the final curve ran at, e.g. "16x24"
  double delta_theta_deg = 0;  ///< the strip's angle offset (validation; fit runs the misalignment effect-fit turned)
  double specimen_scale = 1;   ///< fit runs with `repeats.scale: per-run`: the run's s_r (forces are s_r p̂)
  double avg_rel_error = 0;    ///< Σ|p̂ − p̆| / Σ|p̆| (model.md §8)
  double avg_rel_error_without_offset = 0;  ///< validation: error at Δθ = 0
  std::vector<double> extension_mm, measured_N, simulated_N;
};

/// A validation test's nominal strip against the fitted strain box (paper §3.2, model.md §4):
/// the largest strain components over the strip at the test's largest extension, and the
/// cutoffs. Beyond a cutoff ψ is the quadratic extension of the fitted law, so a validation
/// strip that goes there tests the extrapolation, not the fit (measured: poplin 67.5°,
/// docs/fitting.md "Validation beyond the cutoffs").
struct FitStrainRange {
  std::string label;  ///< validation test label, e.g. "a67.5"
  double angle_deg = 0;
  double extension_mm = 0;
  std::array<double, 3> largest{};              ///< |Ẽ11|, |Ẽ22|, |Ẽ12|
  std::array<std::optional<double>, 3> cutoff;  ///< E11_max, E22_max, E12_max (nullopt: off)
  std::array<double, 3> share_beyond{};         ///< share of the strip's area beyond each cutoff
};

struct FitStageRecord {
  std::string stage;       ///< "warp", "weft", "bias", "bend"
  std::string resolution;  ///< e.g. "8x12"
  int degree = 0;
  double avg_rel_error = 0;  ///< over the stage's curves (mean)
  std::string optimizer;
  std::string status;        ///< optimiser status
  std::string message;       ///< the optimiser's own words on why it stopped
  int iterations = 0;
  long evaluations = 0;
  long equilibrium_solves = 0;
  double wall_time_s = 0;
};

/// The discretisation error the fit states about itself: one stage's parameters at two
/// successive levels of the resolution ladder (docs/fitting.md, "Resolution ladder").
struct FitRefinement {
  struct Change {
    std::string name;  ///< flat-entry name (parameters.hpp) or "tau_a11_N_per_m", ...
    double from = 0, to = 0;
    double relative = 0;  ///< |to − from| / |to|
  };
  std::string stage;
  std::string from_resolution, to_resolution;
  std::vector<Change> changes;  ///< every fitted entry of the stage, then its membrane stiffness
  /// The decision quantity: the largest relative change of the stage's membrane stress
  /// τ·σ(E) (τ a E η'(E²), or 2 τ G12 E η4'(E²) for the shear) over strains up to the stage's
  /// cutoff, and the strain where it is largest.
  double response_change = 0;
  double response_strain = 0;
  std::string decision;  ///< what the ladder did next, in words
};

struct FitBend {
  std::string label;
  double angle_deg = 0;
  double measured_overhang_mm = 0;  ///< mean of the repeats
  double chord_angle_deg = 0;       ///< simulated at the measured overhang (41.5° measured)
  double overhang_mm = 0;           ///< simulated overhang at 41.5° (0 when not computed)
};

struct FitInitialGuess {
  std::string label;
  double avg_rel_error_uniform = 0;  ///< uniform-strain model vs data
  double avg_rel_difference_full = 0;  ///< uniform-strain vs full shell solve at the guess
};

/// One fitted effect parameter with its unit and bounds (report rows).
struct FitEffectParameter {
  std::string name;  ///< "hysteresis.warp_friction_N_m"
  std::string unit;
  double value = 0, lower = 0, upper = 0;
  double neutral = 0;  ///< its value in the paper's model (the effect's schema default)
};

/// One test's share of an effect-fit stage: its runs' mean error without and with the effect,
/// and the noise floor (ScoreTest::run_noise averaged over the test's runs; NaN when the score
/// test was not evaluated).
struct FitEffectTest {
  std::string test;  ///< the test's label; "<label> lateral strain", "bend <label>" for those observables
  int runs = 0;
  double error_without = 0, error_with = 0;
  double noise_floor = std::numeric_limits<double>::quiet_NaN();
  /// Its runs' share of the score's T (ScoreTest::run_share summed; NaN without a score test).
  double score_share = std::numeric_limits<double>::quiet_NaN();
  /// A lateral-strain test's error without the effect once the mesh's and a 1° cut's patterns
  /// (the score test's known directions, effect_fit.cpp lateral_known_directions) are fitted
  /// out of its rows, by least squares over the test's runs: what `twill discover` judges an
  /// unexplained lateral misfit on (docs/discovery.md §1). NaN for other tests, or where the
  /// patterns were not measured.
  double error_beyond_known = std::numeric_limits<double>::quiet_NaN();
};

/// One force run of an effect-fit stage: its rows in file order (loading, then unloading) and
/// the forces predicted without and with the effect, each at the run's profiled scale
/// (`twill discover`'s residual plots).
struct FitEffectCurve {
  std::string test, run;
  std::vector<double> extension_mm, measured_N, without_N, with_N;
};

/// What an effect-fit stage found (docs/effects.md): the effect's parameters and the error on
/// its runs without the effect (its neutral values) and with it.
struct FitEffect {
  std::string effect;      ///< registered name
  std::string resolution;
  int runs = 0;            ///< runs fitted
  int points = 0;          ///< observables fitted
  double error_without = 0, error_with = 0;  ///< mean of the runs' average relative errors
  /// The score test at the effect's neutral values before it is fitted (core/score_test.hpp):
  /// T, its degrees of freedom, the p-value if the residuals were iid, and the p-value
  /// calibrated by correlated-noise replicates (score_noise_correlation: the runs' mean fitted
  /// lag-one correlation); NaN when not evaluated (an angle-offset effect, or the baseline failed).
  double score = std::numeric_limits<double>::quiet_NaN();
  int score_dof = 0;
  double score_p_value_iid = 1;
  double score_p_value = 1;
  double score_noise_correlation = 0;
  std::vector<double> score_run_share;  ///< ScoreTest::run_share, per run of the stage (tests[…].score_share sums it)
  std::vector<FitEffectParameter> parameters;
  std::vector<FitEffectTest> tests;  ///< per test, in the order the stage's runs come
  std::vector<FitEffectCurve> curves;  ///< per force run (not for angle-offset effects or fit: false)
  /// An angle-offset effect judged on validation strips: the strips' mean error on every other
  /// row with the offsets fitted on the rows between (both ways) — one per test (without) and
  /// one per strip (with); NaN otherwise (twill discover's held-out check for it).
  double held_out_rows_without = std::numeric_limits<double>::quiet_NaN();
  double held_out_rows_with = std::numeric_limits<double>::quiet_NaN();

};

struct FitReport {
  std::string dataset;  ///< dataset name
  std::string folder;
  MaterialParameters parameters;
  std::vector<FitInitialGuess> initial_guess;
  std::vector<FitStageRecord> stages;
  /// Per curve stage that ran, its label and the degree its curve ended at (`stages` also holds
  /// the raises the degree search tried and did not keep).
  std::vector<std::pair<std::string, int>> curve_degrees;
  std::vector<FitRefinement> refinement;  ///< per stage and finer level, in fit order
  std::string finest_resolution;          ///< where the final curves and validation ran
  int finest_level = 0;                   ///< its level (0: the coarsest; FitContext::finest_level)
  std::vector<FitCurve> fit;
  std::vector<FitBend> bend;
  std::vector<FitCurve> validation;
  std::vector<FitStrainRange> validation_strain;  ///< one per validation test
  std::vector<FitEffect> effects;  ///< one per effect-fit stage that ran
  std::vector<std::pair<std::string, double>> timing_s;  ///< per stage, then "total"
  std::vector<std::string> notes;  ///< choices made on the way (repeats, cutoffs, degrees)
};

/// argmin over t of Σ_i |f_i + t d_i − m_i| (the offset search's probe side and gauge; a
/// weighted median). 0 when every d_i is 0. Exposed for its test.
double linearised_l1_minimiser(const Eigen::VectorXd& f, const Eigen::VectorXd& d, const Eigen::VectorXd& m);

class FitContext;
/// The fit's data (run_fit's first step): per tensile test the repeats of §6.4 (fit runs) or
/// every run (validation strips, paper §7, Table 5 reports per run), as measured points.
/// Throws InputError where a declared warp stage has no test.
void select_data(FitContext& context);

/// Runs the protocol. Throws InputError for a dataset the protocol cannot use (e.g. no warp
/// test) and std::runtime_error when a stage fails outright (the message names the stage).
/// When it throws and `finished` is given, *finished receives what the stages that finished
/// learned (their records, notes, timings, the parameters so far), so a late failure does not
/// throw an hour of work away (write_incomplete_fit_report()).
FitReport run_fit(const Dataset& dataset, const Options& config, const Registry& registry,
                  const FitProgress& progress, FitReport* finished = nullptr);

/// The protocol's up-front checks (a stage's references to the stages before it, unique
/// labels, each stage's own limits) for `twill fit` to run before any work; run_fit runs them
/// too. Throws InputError located by `locate`, e.g. at "protocol[3].stage".
void check_fit_protocol(const Dataset& dataset, const Options& config, const Registry& registry,
                        const ConfigKeyLocator& locate);

/// An effect-fit stage's curves as report.json and discover.json carry them.
nlohmann::json effect_curves_json(const std::vector<FitEffectCurve>& curves);

/// report.json's text (every curve, the stages, the effects; what write_fit_outputs writes).
std::string fit_report_json_text(const FitReport& report, const Options& config);

/// Writes params.yaml, report.json (with every curve, for scripts/plot_fit.py), report.md and
/// config.yaml (the resolved config) into `dir` (created if needed). `twill fit` writes into a
/// staging folder and renames it only when everything, plots included, is complete.
void write_fit_outputs(const FitReport& report, const Options& config, const std::string& dir);

/// Writes report-incomplete.md and report-incomplete.json (with `"complete": false` and the
/// error) and config.yaml into `dir`: the stages that finished before `error`, marked
/// incomplete in their names, titles and content, and no params.yaml, so the folder never
/// looks like a finished fit.
void write_incomplete_fit_report(const FitReport& finished, const Options& config, const std::string& error,
                                 const std::string& dir);

}  // namespace twill
