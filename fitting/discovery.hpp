#pragma once
// `twill discover` (issue #16; docs/discovery.md, docs/discover-design.md): where the paper's
// model and a dataset disagree, which registered effect explains it, and the gap before and
// after adding it — or `none`, `tied: A|B (needs: …)` or `unexplained at <test, range>`.
//
// The workflow, each step a fit (fitting/fit_protocol.hpp) with a different `effects` list:
//   1. audit: every candidate effect's data predicate (Effect::missing_data) and an effect-fit
//      stage for it in the protocol; without either it is `untestable (needs: …)`;
//   2. baseline: the protocol with no effect, every repeat fitted with its specimen scale
//      (`repeats.rule: all`, `repeats.scale: per-run`: the scatter between specimens is the
//      noise floor, docs/discover-design.md §1);
//   3. per testable candidate: from the baseline's parameters (start-from, the curves as
//      they stand), its effect-fit stage alone at the screening level; it gives the error
//      without and with it, per test, the calibrated score test at its neutral values and the
//      noise floor (core/score_test.hpp); passing ones are checked on held-out specimen folds;
//   4. judge (judge_candidates below): a candidate passes when its calibrated p-value is below
//      α / (candidates tested) and the misfit in excess of the floor shrinks by at least
//      `min_excess_shrink`; several passing are refitted jointly, and one whose score is no
//      longer significant after the others is `tied` with the one that explained it; named
//      effects are refitted from the baseline at its finest level.
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/dataset.hpp"
#include "core/registry.hpp"
#include "core/score_test.hpp"
#include "effects/effect.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {

/// The `discover` section of the config (discover_config_schema()).
struct DiscoverOptions {
  std::vector<std::string> candidates;  ///< registered effect names; empty: every registered effect
  double alpha = 0.05;                  ///< family-wise level of the score tests (Bonferroni)
  double min_excess_shrink = 3;         ///< (before − floor) / (after − floor) a named effect reaches
  double unexplained_ratio = 2;         ///< a test whose baseline error exceeds this × its floor is a misfit
                                        ///< (`unexplained` with nothing named; a candidate without a
                                        ///< score test needs one)
  bool held_out = true;                 ///< confirm on held-out specimens (two folds) before naming
  /// The resolution level candidates and held-out folds are fitted at (capped at the baseline's
  /// finest); named effects are refitted at the baseline's finest level.
  int screening_level = 0;
  /// Test a richer elastic curve (every fitted tensile curve raised until its error stops
  /// falling) as a candidate of its own, `curve-degree` (kCurveDegreeCandidate).
  bool curve_degree = true;
  /// How each held-out fold's baseline is fitted: "refit" (the protocol's tensile-curve stages
  /// from the baseline's parameters, on the fold's specimens) or "protocol" (the whole protocol
  /// from its initial guess).
  std::string fold_baselines = "refit";
};

/// The candidate that is not an effect: the paper's curves raised until their error stops
/// falling (a richer curve must not pass for physics, nor physics for a richer curve;
/// docs/discovery.md).
inline constexpr const char* kCurveDegreeCandidate = "curve-degree";

/// What a held-out check's folds held out (DiscoverHeldOut::held, discover_folds): specimens, the
/// folds every effect can take, or crosshead speeds.
inline constexpr const char* kHeldSpecimens = "specimens";
inline constexpr const char* kHeldSpeeds = "speeds";

/// The held-out check of a candidate (run_discover): two folds of the specimens (each fit test's
/// runs of even and of odd index), each fitted without and with the effect and evaluated on the
/// other fold's runs; the mean over the folds of the held-out runs' error.
struct DiscoverHeldOut {
  bool evaluated = false;
  double without = 0, with = 0;
  std::string note;  ///< why it was not evaluated, when not
  /// The effect's parameters as each fold's fit left them (resamples of the specimens: their
  /// spread is the parameters' interval, and their sides of the neutral values the stability).
  std::vector<std::vector<FitEffectParameter>> folds = {};
  std::string failure = {};  ///< what stopped it, when a fold's fit or evaluation failed (the candidate fails)
  std::string held = kHeldSpecimens;  ///< what the folds held out: kHeldSpecimens, kHeldSpeeds, ... (Effect::held_out)
  /// Per held-out test, its error without and with (error_without, error_with; the folds'
  /// evaluations together, a test held out in two folds merged, runs-weighted): what
  /// the excess over each test's floor is measured on. Empty where the check's error has no tests.
  std::vector<FitEffectTest> tests = {};
};

/// A held-out check's fold: the data a fit sees and the data it is judged on.
struct DiscoverFold {
  std::string name;  ///< "fold 1", "at 300 mm/min", "cantilevers 1", ...
  Dataset fitted, held;
  bool cantilevers_only = false;  ///< only the bend tests' overhangs split (cantilever_folds)
};

/// The folds that confirm an effect that holds out `kind` (Effect::held_out): one per crosshead
/// speed of the fit tests (fitted on that speed's tests, judged on the others'; validation tests
/// in both) when there are two or more speeds, otherwise two specimen folds (even and odd runs
/// of every fit test); none, with `why`, when every fit test has one specimen. `held` names what
/// was held out: kHeldSpeeds or kHeldSpecimens.
std::vector<DiscoverFold> discover_folds(const Dataset& dataset, Effect::HeldOut kind, std::string* held, std::string* why);

/// The folds of an effect fitted to the cantilevers' chord angles (bending-anisotropy): each
/// bend test's overhangs of even and of odd index, the tensile tests whole in both (a bend test
/// with one overhang keeps it in both); none when no bend test has two or more.
std::vector<DiscoverFold> cantilever_folds(const Dataset& dataset);

/// `params`' mean error (model.md §8) on `dataset`'s fit runs (their loading rows, as `fit`
/// selects them) simulated at `level`, each run at its own L1-best scale (a held-out
/// specimen's scale is its own, as in effect-fit's evaluations); `fit`'s effects left out.
/// curve-degree's held-out rows where it is measured on the fit runs. Throws where a run
/// cannot be simulated.
double fit_runs_error_at(const Dataset& dataset, const Options& fit, const Registry& registry,
                         const MaterialParameters& params, int level);

/// Whether the effect keeps its direction on each fold: in every fold's fit some parameter the
/// fit on all specimens moved off its neutral value stays off it on the same side (the effect
/// neither vanishes nor turns round on half of the specimens); `why` names the fold that fails.
/// True when there are no folds.
bool stable_over_folds(const std::vector<FitEffectParameter>& fitted, const DiscoverHeldOut& held_out, std::string* why);

/// A candidate's statuses and the verdicts' kinds (a verdict starts with its kind): the one list
/// discovery, its metrics and reports use.
const std::vector<std::string>& discover_statuses();  ///< named, rejected, untestable, tied, failed
const std::vector<std::string>& discover_verdict_kinds();  ///< named, none, tied, unexplained

/// One candidate effect: what became of it and why.
struct DiscoverCandidate {
  std::string name;
  std::string status;  ///< "named", "rejected", "untestable", "tied", "failed"
  std::string reason;  ///< in words: what it needs, which criterion it failed, the error
  std::optional<FitEffect> effect;  ///< its effect-fit stage's record, when fitted
  DiscoverHeldOut held_out;          ///< for candidates that passed on the fitted data
  /// For one of a tied pair whose held-out kinds differ (one holds out speeds): its check on the
  /// folds that separate the two (separate_tie, docs/discovery.md §1); not evaluated otherwise.
  DiscoverHeldOut separating = {};
};

/// The load cell's noise as every fit test's repeats show it (discovery_noise.cpp;
/// docs/discovery.md §2, "The noise floor from the repeats"): each test's runs on their shared
/// loading rows (repeat_branches), each at its weighted least-squares relative scale onto their
/// mean, the relative deviations u = (s f − m)/m; their profile (core/score_test.hpp,
/// NoiseProfile: sd a + b|y|; the scales reweighted by it, three sweeps), level (Σ (u/profile)²
/// over the degrees of freedom left, Σ (rows − 1)(runs − 1)) and mean lag-one correlation,
/// pooled over the tests. The
/// deviations hold whatever makes specimens differ beyond a scale (the noise, a cut's shape), not
/// what they share.
struct RepeatNoise {
  NoiseProfile profile;
  double level = 0;        ///< the relative sd where the profile is 1: sd(y) = level · profile.at(|y|) · |y|
  double correlation = 0;  ///< the runs' mean lag-one correlation (noise_correlation)
  int runs = 0, rows = 0;  ///< what it was fitted to
  /// The standard deviation of one reading of magnitude |y| [N].
  double sd(double reading) const {
    const double y = std::abs(reading);
    return level * profile.at(y) * y;
  }
};
/// Per test: the error of the paper's model, of the model with the named effects, and the
/// noise floor (the mean |noise| the calibration fitted; docs/discovery.md).
struct DiscoverGap {
  std::string test;
  double before = 0, after = 0, floor = 0;
  /// The test's repeats' own scatter (repeat_floors; NaN without two runs on a shared grid).
  double repeat_floor = std::numeric_limits<double>::quiet_NaN();
  /// The baseline's own resolution error on the test's strip: its forces at the refit's level
  /// against one level finer (NaN when not measured).
  double resolution_error = std::numeric_limits<double>::quiet_NaN();
  /// What the repeats' pooled noise makes a perfect model miss the test's runs by, and the
  /// p-value of `before` against it (noise_floor_test; NaN where not measured: no repeats, not a
  /// force test, or something was named).
  double noise_floor = std::numeric_limits<double>::quiet_NaN();
  double misfit_p = std::numeric_limits<double>::quiet_NaN();
  /// A lateral-strain test's `before` with the mesh's and a 1° cut's patterns fitted out
  /// (FitEffectTest::error_beyond_known; NaN elsewhere): what `unexplained` judges there.
  double before_beyond_known = std::numeric_limits<double>::quiet_NaN();
  /// The error `unexplained` judges: before_beyond_known where measured, else before.
  double judged_before() const { return std::isfinite(before_beyond_known) ? before_beyond_known : before; }
};

struct DiscoverResult {
  std::vector<std::string> named;
  std::string verdict;  ///< "named", "none", "tied: A|B (needs: …)", "unexplained at <test, range>"
  std::vector<DiscoverGap> gap;
  std::string gap_rows;  ///< which effect-fit stage's rows the gap was measured on
  /// Those rows per force run: without = before (the first record's), with = after (the last
  /// record's; before again when nothing is named). For the residual plots.
  std::vector<FitEffectCurve> curves;
  std::vector<DiscoverCandidate> candidates;
  /// The load cell's noise from the repeats (repeat_noise), when nothing was named and it was fitted.
  std::optional<RepeatNoise> noise;
  FitReport baseline;
  std::optional<FitReport> refit;  ///< the fit with the named (or tied) effects
  std::string screening_resolution;  ///< where the candidates and held-out folds were fitted
  std::vector<std::string> notes;
  double time_s = 0;
  /// Each step's wall time in order (the baseline, each candidate, each fold's baseline, each
  /// held-out check without its fold baselines, the refit): where a discover's time goes.
  std::vector<std::pair<std::string, double>> step_times;
};

/// The fit config's schema plus the `discover` section.
OptionSchema discover_config_schema();
DiscoverOptions read_discover_options(const Options& config);
/// The fit config inside a discover config (every entry but the `discover` section).
Options discover_fit_config(const Options& config);
/// The baseline's fit config (step 2): the discover config's fit config with every repeat fitted
/// at a specimen scale of its own, no effects, and each tensile-curve stage's target_error
/// lowered to its angle's repeat floor (the runs-weighted repeat_floors of its fit tests) where
/// that is below the protocol's; what changed is said in `notes`.
Options discover_baseline_config(const Dataset& dataset, const Options& config, const Registry& registry,
                                 std::vector<std::string>* notes);
/// The first tensile-curve stage of `fit` (a baseline config) whose angle's fit runs miss by more
/// than its target_error at the end of `report` (the mean of their final curves' average
/// relative errors), in words; "" when none does. The baseline takes a second pass then.
std::string baseline_above_target(const FitReport& report, const Options& fit);

/// The candidates' audit (step 1): each registered (or configured) candidate, `untestable` with
/// what it needs, or with an empty status when it can be fitted.
std::vector<DiscoverCandidate> audit_candidates(const Dataset& dataset, const Options& fit_config,
                                                const DiscoverOptions& options, const Registry& registry);

/// The scatter of each fit test's repeats about their own mean curve, without any model (the
/// pure error of a lack-of-fit test; docs/discovery.md §2): the runs' loading branches on the
/// first run's extensions (linear interpolation where they differ; the rows every run covers),
/// each run at its L1-best scale onto the mean, the mean of the runs' Σ|s f − m|/Σ|m| times
/// √(n/(n − 1)) (a run's deviation from a mean it is part of). Per test label; a test with
/// one run, or fewer than kRepeatFloorRows shared rows, has none.
std::map<std::string, double> repeat_floors(const Dataset& dataset);

/// nullopt when fewer than two runs of the fit tests share rows with another run.
std::optional<RepeatNoise> repeat_noise(const Dataset& dataset);

/// One run's readings on the rows a misfit is judged on: measured and the model's prediction
/// (at the run's specimen scale).
struct RunReadings {
  std::vector<double> measured, predicted;
};
/// A test's error against what the noise alone makes of it.
struct NoiseFloorTest {
  double observed = std::numeric_limits<double>::quiet_NaN();  ///< the runs' mean average relative error
  double floor = std::numeric_limits<double>::quiet_NaN();     ///< its mean over the draws: a perfect model's error
  double p_value = std::numeric_limits<double>::quiet_NaN();   ///< (1 + #{E* + offset ≥ observed}) / (B + 1)
};
/// Draws B (calibration.replicates, its seed) replicates of the test's runs as the prediction
/// plus the repeats' noise (level, profile, AR(1)), refits each run's scale (least squares in
/// relative residuals, as the fit), and measures each replicate's error E* as the observed one
/// is. `offset` (the resolution error) is added to every E*: a mesh's own error is not a missing
/// mechanism. NaN fields when a reading is 0 or there are no runs.
NoiseFloorTest noise_floor_test(const RepeatNoise& noise, const std::vector<RunReadings>& runs, double offset,
                                const ScoreCalibration& calibration = {});

/// With nothing named: "unexplained at <test, range>" for the test whose baseline error is
/// furthest above `ratio` times its floor — the smaller of the effects' floor and the
/// model-free one (the repeats' pooled noise floor, noise_floor_test, where measured, else the
/// test's repeat scatter) plus the baseline's resolution error (a misfit no effect explains stays
/// in the effects' residual floors; the mesh's own error is not a missing mechanism) — and, where
/// the test has a misfit_p, beyond the noise at α / (tests with one); "" when none is. A test
/// that the curve-degree candidate's richer curves bring within `ratio` times its floor is the
/// curves' shape, not unexplained, and one within the noise's reach is not a misfit: both are
/// said in `note` instead (docs/discovery.md §1, §2).
std::string unexplained_misfit(const DiscoverResult& result, double ratio, double alpha, std::string* note);

/// Step 4 on candidates whose `effect` is set: statuses, reasons, `named` and the verdict's
/// kind (the joint refit's records, when several pass, come in `joint`; with two passing, the
/// refit in the other order in `reversed`, so that each is scored after the other). Pure: no fits.
void judge_candidates(const DiscoverOptions& options, const std::vector<FitEffect>* joint, DiscoverResult* result,
                      const std::vector<FitEffect>* reversed = nullptr);

/// The whole workflow (above). Throws InputError for a config or dataset it cannot use.
DiscoverResult run_discover(const Dataset& dataset, const Options& config, const Registry& registry,
                            const FitProgress& progress);

/// discover.json, discover.md, params.yaml (the refit's, else the baseline's), config.yaml and
/// the baseline's and refit's report.json as baseline-report.json / refit-report.json.
void write_discover_outputs(const DiscoverResult& result, const Options& config, const std::string& dir);

/// The file names `twill discover` writes (its output folder's kind).
const std::vector<std::string>& discover_output_file_names();

}  // namespace twill
