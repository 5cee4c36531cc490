// Stage `effect-fit` (issue #15; docs/effects.md): the parameters of one configured effect
// fitted to the fit runs at one resolution level — jointly with every fitted tensile-curve
// stage's parameters (`with_curves`, default: the curves fitted without the effect absorbed
// part of it), or with the law held — and the error of those runs without the effect (its
// neutral values, the schema defaults: the paper's model, at the parameters the stages before
// left) and with it. A protocol lists one such stage per effect it can fit; the stage does
// nothing (its timing row reads 0 s) when the config's `effects` does not name its effect, so
// the paper's protocol carries them inactive.
//
// Data: the bend tests' chord angles (`observable: chord_angle_deg`; the curves are then not
// free, the thickness stays the bend stage's), or every fit tensile run, its whole path in file order (`rows: path`, loading then
// unloading, FitContext's measured_path) or its loading branch (`rows: loading`), each run with
// its clock (rate_mm_min, time_s) for rate effects.
//
// An angle-offset effect (misalignment) fits per-run values, not entries of the material's flat
// vector: its per-run offsets are searched run by run and alternated with the curves'
// refit (fit_offsets below, `rounds`); its model parameter, the spread, is estimated from them.
// Its error without is the runs' error at their nominal angles. With two or more validation
// strips it is judged on those instead (validation_evidence: their offsets are identified,
// the fit runs' trade with the specimen scales), with a score test, and the spread is theirs.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numeric>
#include <optional>

#include "core/option_binding.hpp"
#include "core/score_test.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_effects.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/offset_search.hpp"
#include "fitting/repeat_branches.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

/// The registered experiment that reports a strip's lateral strain (experiments/).
constexpr const char* kLateralExperiment = "tensile-lateral";
/// The level of the finest stage so far (a negative `level`).
constexpr int kFinestSoFar = -1;
/// The overhang step of a cantilever's dθ/dL [mm]: D1388 reads the overhang to 1 mm, and the
/// chord angle is smooth in it (a few degrees per 10 mm), so a forward difference over it is
/// exact to the percent the noise estimate needs.
constexpr double kOverhangStepMm = 1.0;
/// The relative step of a direction's membrane stiffness for a cantilever's dθ/d log a: the
/// chord angle is smooth in the bending stiffness, and its level's noise (several %) needs the
/// slope to the percent.
constexpr double kStiffnessStep = 0.01;
/// The offset a strip is cut at to measure the cuts' pattern in its lateral strain [deg]: a
/// typical cutting error of a hand-cut strip, and the pattern is the same for any small one
/// (it goes as the offset's square: an 8×12 warp strip's contraction grows by 0.9…6.6 % from 1
/// to 12 mm at 1°, by 2.6…19.7 % at 1.7°, 2.9× for 1.7² = 2.89).
constexpr double kCutProbeDeg = 1.0;

// How far the lateral strains' known patterns can reach in the `unexplained` rule's error
// (set_errors_beyond_known). The mesh's: the continuum's error is the sum of every finer
// level's step, at an order p ≥ 1 at most 1/(1 − 2^−p) ≤ 2 times the one step measured (and
// of its sign: data are finer than the fit). The cuts': on a warp or weft strip (a symmetry
// axis) their shared narrowing grows as the square of the offset (lateral_known_directions),
// so a spread of kCutSpreadBoundDeg reaches [0, (kCutSpreadBoundDeg / kCutProbeDeg)²] times the
// 1° pattern; off the axes (bias) a cut moves the contraction to first order, either way, and
// the specimens' mean offset reaches ±kCutSpreadBoundDeg / kCutProbeDeg. 2° RMS is twice the generator's
// cuts (papers/hidden_effects) and about what a 50 mm strip cut by hand against a yarn
// drifts (1.7 mm over 50 mm); a larger spread is left to misalignment's candidate.
constexpr double kMeshPatternReach = 2.0;
constexpr double kCutSpreadBoundDeg = 2.0;

// argmin over lower ≤ c ≤ upper (lower ≤ 0 ≤ upper) of ‖e − a c‖ for a few columns: each
// coefficient free, at its lower or at its upper bound, the best feasible of the 3^n choices (a
// convex problem's minimum is one).
Eigen::VectorXd box_least_squares(const Eigen::MatrixXd& a, const Eigen::VectorXd& e, const Eigen::VectorXd& lower,
                                  const Eigen::VectorXd& upper) {
  const Eigen::Index n = a.cols();
  Eigen::VectorXd best = Eigen::VectorXd::Zero(n);
  double best_residual = e.squaredNorm();
  int choices = 1;
  for (Eigen::Index i = 0; i < n; ++i) choices *= 3;
  for (int code = 0; code < choices; ++code) {
    Eigen::VectorXd c = Eigen::VectorXd::Zero(n);
    std::vector<Eigen::Index> free;
    for (Eigen::Index i = 0, k = code; i < n; ++i, k /= 3) {
      if (k % 3 == 0) free.push_back(i);
      c[i] = k % 3 == 1 ? lower[i] : k % 3 == 2 ? upper[i] : 0.0;
    }
    if (!free.empty()) {
      Eigen::MatrixXd columns(a.rows(), static_cast<Eigen::Index>(free.size()));
      for (size_t j = 0; j < free.size(); ++j) columns.col(static_cast<Eigen::Index>(j)) = a.col(free[j]);
      const Eigen::VectorXd x = columns.colPivHouseholderQr().solve(e - a * c);
      for (size_t j = 0; j < free.size(); ++j) c[free[j]] = x[static_cast<Eigen::Index>(j)];
    }
    if ((c.array() < lower.array()).any() || (c.array() > upper.array()).any()) continue;
    const double residual = (e - a * c).squaredNorm();
    if (residual < best_residual) {
      best_residual = residual;
      best = c;
    }
  }
  return best;
}/// An effect parameter whose neutral value is 0 has no scale of its own: x = 1 stands for this
/// fraction of its range (hysteresis' frictions: 100 N/m of [0, 1e5], a few % of a strip's
/// force per width).
constexpr double kScaleOfRange = 1e-3;

struct EffectFitOptions {
  std::string effect = "hysteresis";
  std::string rows = "path";
  std::string observable = "force_N";
  int level = kFinestSoFar;
  bool with_curves = true;
  bool fit = true;
  int rounds = 3;
  bool validate(std::string* error) const;
};

OptionBindings<EffectFitOptions> effect_fit_bindings() {
  using S = EffectFitOptions;
  return {text_option<S>("effect", &S::effect, "the registered effect whose parameters it fits (twill list effect)"),
          choice_option<S>("rows", &S::rows, {"path", "loading"},
                           "the runs' rows: the whole path (loading, then unloading) or the loading branch"),
          choice_option<S>("observable", &S::observable, {"force_N", "lateral_strain", "both", "chord_angle_deg"},
                           "what it fits: the clamp forces, the lateral strains (of runs with a lateral_strain "
                           "column, rows above data.min_force_fraction of the run's largest |lateral strain|), both, "
                           "or the bend tests' chord angles (the curves are then not free)"),
          integer_option<S>("level", &S::level, "resolution level (-1: the finest any stage before it reached)",
                            in_range(kFinestSoFar, 4)),
          bool_option<S>("with_curves", &S::with_curves,
                         "free every fitted tensile-curve stage's stiffness and curve with the effect (false: the law held)"),
          bool_option<S>("fit", &S::fit,
                         "false: nothing fitted, the error with the effect is the runs' at the parameters so far "
                         "(twill discover's held-out check: parameters fitted on other specimens, start-from)"),
          // Three: warp and weft offsets settle in the first round (the gauge's unconstrained
          // Δθ²); a stiff-yarn bias converges linearly, measured on poplin-like strips (1°
          // strip: 0.65, 0.75, 0.90, 1.00° over rounds 2–5; tests/fitting/test_fit_effects.cpp),
          // and each round costs a joint refit of every curve.
          integer_option<S>("rounds", &S::rounds,
                            "angle-offset effects (misalignment): rounds of offset search and curve refit",
                            in_range(1, 10))};
}

bool EffectFitOptions::validate(std::string* error) const { return check_options(effect_fit_bindings(), *this, error); }

// The effect's parameters as the fit's parameter map takes them (bounds and scale).
std::vector<ParameterRange> ranges_of(const std::vector<EffectParameter>& parameters) {
  std::vector<ParameterRange> ranges;
  for (const EffectParameter& p : parameters)
    ranges.push_back({p.name, p.lower, p.upper, p.value != 0 ? 0.0 : kScaleOfRange * (p.upper - p.lower)});
  return ranges;
}

// A validation strip at its nominal angle: forces F, dF/dθ [N/deg] and the measured forces.
struct StripForces {
  Eigen::VectorXd force_N, dforce_dangle, measured_N;
};

// The grid the common offset of a validation test's strips is searched on: the offset search's
// own rounding (OffsetSearchOptions::resolution_deg), over its range.
constexpr double kCommonOffsetStepDeg = 0.05;

// Which of a strip's rows: all, or every other one (the two halves of a 2-fold split by rows).
enum class Rows { all, even, odd };

// A strip's error Σ|s F − F̆| / Σ|F̆| over `rows` at offset δ, F ≈ F + δ F' (linear in Δθ off the
// axes, OffsetSearch), at its own best scale there.
double strip_error(const StripForces& f, double delta, Rows rows) {
  const Eigen::Index n = f.measured_N.size(), first = rows == Rows::odd ? 1 : 0, step = rows == Rows::all ? 1 : 2;
  const Eigen::Index size = (n - first + step - 1) / step;
  const auto pick = [&](const Eigen::VectorXd& v) -> Eigen::VectorXd {
    return Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<>>(v.data() + first, size, Eigen::InnerStride<>(step));
  };
  const Eigen::VectorXd measured = pick(f.measured_N);
  return OffsetSearch::misfit(pick(f.force_N) + delta * pick(f.dforce_dangle), measured, true) / measured.cwiseAbs().sum();
}

// The offset δ on a kCommonOffsetStepDeg grid over ±Misalignment::kMaxOffsetDeg that minimises
// the mean error of the strips `members` over `rows`: one offset for all of them (a test cut
// alike, which the law's own error at that angle looks like) or a strip's own.
double grid_offset(const std::vector<StripForces>& strips, const std::vector<size_t>& members, Rows rows) {
  double best = 0, best_sum = std::numeric_limits<double>::infinity();
  for (double delta = -Misalignment::kMaxOffsetDeg; delta <= Misalignment::kMaxOffsetDeg + 1e-12;
       delta += kCommonOffsetStepDeg) {
    double sum = 0;
    for (size_t k : members) sum += strip_error(strips[k], delta, rows);
    if (sum < best_sum) {
      best_sum = sum;
      best = delta;
    }
  }
  return best;
}

// An angle-offset effect's record on the validation strips (EffectFit::validation_evidence).
struct ValidationEvidence {
  FitEffect record;
  std::vector<Eigen::VectorXd> offsets;  ///< per strip, its best offset [deg]
};

// The instruments whose noise the score test's calibration profiles apart
// (ScoreCalibration::instruments).
enum Instrument { kLoadCell, kLateralGauge };

// The score test's system on the validation strips' rows (EffectFit::validation_evidence):
// residuals r = (s F − F̆)/F̆ at the nominal angle; baseline columns per strip its scale
// (s F/F̆), then per test a common offset (its strips' s F'/F̆); candidate columns per strip
// its own offset (s F'/F̆).
struct ValidationSystem {
  std::vector<Eigen::Index> rows;           ///< per strip
  std::vector<const TensileTest*> tests;    ///< the strips' tests, each once, in order met
  Eigen::VectorXd r;
  Eigen::MatrixXd baseline, offsets;
  ScoreCalibration calibration;             ///< one instrument, the load cell

  explicit ValidationSystem(const std::vector<const RunData*>& runs) {
    for (const RunData* d : runs) {
      rows.push_back(d->force_N.size());
      if (std::find(tests.begin(), tests.end(), d->test) == tests.end()) tests.push_back(d->test);
    }
    const Eigen::Index m = std::accumulate(rows.begin(), rows.end(), Eigen::Index{0});
    const auto n_runs = static_cast<Eigen::Index>(runs.size()), n_tests = static_cast<Eigen::Index>(tests.size());
    r.resize(m);
    baseline = Eigen::MatrixXd::Zero(m, n_runs + n_tests);
    offsets = Eigen::MatrixXd::Zero(m, n_runs);
    calibration.measured.resize(m);
    calibration.instruments.assign(runs.size(), kLoadCell);
  }

  // Strip k's rows from `row` on, of test `test`.
  void add_strip(size_t k, Eigen::Index row, const TensileTest* test, const StripForces& f) {
    const double s = OffsetSearch::scale(f.force_N, f.measured_N, true);
    const auto i = static_cast<Eigen::Index>(k), n = rows[k];
    const auto n_runs = static_cast<Eigen::Index>(offsets.cols());
    const auto t = static_cast<Eigen::Index>(std::find(tests.begin(), tests.end(), test) - tests.begin());
    const Eigen::VectorXd slope = (s * f.dforce_dangle).cwiseQuotient(f.measured_N.cwiseAbs());
    r.segment(row, n) = (s * f.force_N - f.measured_N).cwiseQuotient(f.measured_N.cwiseAbs());
    calibration.measured.segment(row, n) = f.measured_N.cwiseAbs();
    baseline.col(i).segment(row, n) = (s * f.force_N).cwiseQuotient(f.measured_N.cwiseAbs());
    baseline.col(n_runs + t).segment(row, n) = slope;
    offsets.col(i).segment(row, n) = slope;
  }
};

// The validation strips' errors without the effect (each test's strips at their common offset)
// and held out by rows (2-fold): the offsets fitted on every other row of each strip (per test
// common, per strip own) judged on the rows between, and the other way round.
struct ValidationErrors {
  std::vector<double> without, held_without, held_with;
};

ValidationErrors common_offset_errors(const std::vector<StripForces>& forces, const std::vector<const RunData*>& runs,
                                      const std::vector<const TensileTest*>& tests) {
  ValidationErrors out;
  out.without.resize(runs.size());
  for (const TensileTest* test : tests) {
    std::vector<size_t> members;
    for (size_t k = 0; k < runs.size(); ++k)
      if (runs[k]->test == test) members.push_back(k);
    const double common = grid_offset(forces, members, Rows::all);
    for (size_t k : members) out.without[k] = strip_error(forces[k], common, Rows::all);
    for (const auto& [fitted, judged] : {std::pair{Rows::even, Rows::odd}, std::pair{Rows::odd, Rows::even}}) {
      const double common_fold = grid_offset(forces, members, fitted);
      for (size_t k : members) {
        out.held_without.push_back(strip_error(forces[k], common_fold, judged));
        out.held_with.push_back(strip_error(forces[k], grid_offset(forces, {k}, fitted), judged));
      }
    }
  }
  return out;
}

class EffectFit final : public FitStage {
 public:
  explicit EffectFit(EffectFitOptions options) : options_(std::move(options)) {}
  std::string title() const override { return "effect " + options_.effect; }

  void check(const ProtocolCheck& check) const override {
    const auto& known = check.registered_effects;
    if (std::find(known.begin(), known.end(), options_.effect) != known.end()) return;
    std::string names;
    for (const std::string& n : known) names += (names.empty() ? "" : ", ") + n;
    throw InputError(check.locate(check.key + ".effect"),
                     "unknown effect '" + excerpt(options_.effect) + "' (known: " + names + ")");
  }

  void run(FitContext& context, FitReport& out) override {
    const auto configured = std::find_if(context.params.effects.begin(), context.params.effects.end(),
                                         [&](const ComponentChoice& c) { return c.name == options_.effect; });
    if (configured == context.params.effects.end()) return;  // inactive: the config does not name the effect
    const auto index = static_cast<size_t>(configured - context.params.effects.begin());  // params is replaced below
    const int level = options_.level == kFinestSoFar ? context.finest_level : std::min(options_.level, context.levels() - 1);
    if (is_angle_offset(*context.effects.at(index))) {
      if (!options_.fit)
        throw std::runtime_error("effect-fit " + options_.effect + ": fit: false is not available for an angle-offset "
                                 "effect (its per-run offsets are found by fitting)");
      fit_offsets(context, index, level, out);
      return;
    }
    const auto t = Clock::now();
    const Observations observed = observations(context, level);
    const Unknowns unknowns = unknowns_of(context, *configured);
    FitEffect result = effect_record(context, level, observed.predictors);
    if (!options_.fit) {
      evaluate_in_place(context, *configured, unknowns, observed, &result);
    } else {
      fit_and_score(context, ComponentChoice(*configured), level, unknowns, observed, t, &result);
      record_parameters(context, context.params.effects[index], &result);
      note_unpinned(context, result);
    }
    finish(context, std::move(result), out);
  }

 private:
  EffectFitOptions options_;
  std::deque<RunData> runs_;          ///< runs whose forces it fits (stable addresses)
  std::deque<RunData> lateral_runs_;  ///< runs whose lateral strains it fits

  bool bends() const { return options_.observable == "chord_angle_deg"; }

  /// What the stage fits: a predictor per force run, lateral-strain run and (for the chord
  /// angles) bend test, each with its test's label for the per-test breakdown; the force runs
  /// are the first force_runs.size() predictors.
  struct Observations {
    std::vector<std::shared_ptr<Predictor>> predictors;
    std::vector<std::string> tests;
    std::vector<const RunData*> force_runs;
  };
  Observations observations(FitContext& context, int level) {
    Observations o;
    select_runs(context);
    for (const RunData& d : runs_) o.force_runs.push_back(&d);
    for (const auto& experiment : context.tensile_experiments(o.force_runs, level, context.params))
      o.predictors.push_back(experiment);
    for (const RunData& d : runs_) o.tests.push_back(d.test->label);
    for (const RunData& d : lateral_runs_) {
      o.predictors.push_back(context.tensile_experiment(d, level, context.params, kLateralExperiment));
      o.tests.push_back(d.test->label + " lateral strain");
    }
    if (bends())
      for (const BendTest& b : context.dataset().bend) {
        o.predictors.push_back(context.bend_experiment(b, context.params));
        o.tests.push_back("bend " + b.label);
      }
    if (o.predictors.empty())
      throw std::runtime_error("effect-fit " + options_.effect + ": the dataset has no " + options_.observable + " data");
    return o;
  }

  /// The fit's unknowns: the effect's parameters (within their ranges), then with `with_curves`
  /// the fitted curves' entries.
  struct Unknowns {
    std::vector<std::string> free, effect_free;
    ParameterMap::Options map_options;
  };
  Unknowns unknowns_of(const FitContext& context, const ComponentChoice& configured) const {
    Unknowns u;
    const std::vector<EffectParameter> parameters = effect_parameters({configured}, context.registry());
    for (const EffectParameter& p : parameters) u.free.push_back(p.name);
    u.effect_free = u.free;
    if (options_.with_curves && !bends()) append_curve_parameters(context, &u.free);
    u.map_options.ranges = ranges_of(parameters);
    return u;
  }

  /// `fit: false`: the errors without the effect and with it where the parameters hold it; no
  /// score (nothing is fitted) and no noise floor.
  void evaluate_in_place(const FitContext& context, const ComponentChoice& configured, const Unknowns& u,
                         const Observations& o, FitEffect* result) const {
    const size_t n = o.force_runs.size();
    set_errors(o.tests, free_scale_errors(neutral_params(context, configured), u.effect_free, u.map_options, o.predictors, n),
               free_scale_errors(context.params, u.effect_free, u.map_options, o.predictors, n), {}, result);
  }

  /// The score test at the effect's neutral values, then the fit (the effect's parameters first
  /// when the curves are free too), the errors without and with it and the noise floors.
  void fit_and_score(FitContext& context, const ComponentChoice& configured, int level, const Unknowns& u,
                     const Observations& o, Clock::time_point t, FitEffect* result) {
    std::vector<Eigen::VectorXd> predicted_without, predicted_with;
    const std::vector<double> without =
        errors_at_neutral(context, configured, u.effect_free, u.map_options, o.predictors, o.force_runs, &predicted_without);
    const MaterialParameters neutral = neutral_params(context, configured);
    const LateralTerms lateral{lateral_level_noise(context, neutral, o.predictors),
                               lateral_known_directions(context, level, neutral, o.predictors, predicted_without)};
    const size_t n_effect = u.effect_free.size();
    const std::vector<double> noise =
        bends() ? bend_score_at_neutral(context, configured, u.effect_free, u.map_options, result)
                : score_at_neutral(context, configured, u.free, n_effect, u.map_options, o.predictors, o.force_runs,
                                   lateral, result);
    if (u.free.size() > n_effect)
      fit_effect_first(context, u.effect_free, u.map_options, o.predictors, o.force_runs, result->resolution, t);
    const std::vector<double> with =
        fit_free(context, u.free, u.map_options, o.predictors, o.force_runs, result->resolution, t, &predicted_with);
    keep_curves(o.predictors, predicted_without, predicted_with, result);
    set_errors(o.tests, without, with,
               smaller_noise(noise, noise_at_fit(context, u.free, n_effect, u.map_options, o.predictors, o.force_runs, lateral)),
               result);
    set_errors_beyond_known(o, predicted_without, lateral.known, result);
  }

  // Each lateral test's error at the neutral values with its known patterns taken out as far as
  // they can physically reach (FitEffectTest::error_beyond_known): the residual m − p of the
  // test's runs, least squares against its two patterns in strain units (the columns of `known`
  // are relative to the measured, lateral_known_directions) with bounded amplitudes — the
  // mesh's in [0, kMeshPatternReach], a 1° cut's in [0, (kCutSpreadBoundDeg / kCutProbeDeg)²]
  // (box_least_squares) — each run's Σ|m − p − a c| / Σ|m| then averaged over the test's runs,
  // as error_without is. The score test takes these patterns as its baseline's; the
  // `unexplained` rule must too, or a misfit every cut shares (a cut narrows a strip more,
  // whatever its sign) reads as one no effect explains (docs/discovery.md §1). Bounded, they do
  // not take a coupling unlike the paper's (test FitWithEffects.TheLateralErrorBeyondTheKnownPatterns…).
  void set_errors_beyond_known(const Observations& o, const std::vector<Eigen::VectorXd>& at_neutral,
                               const Eigen::MatrixXd& known, FitEffect* result) const {
    if (known.cols() == 0 || at_neutral.size() != o.predictors.size()) return;
    for (const auto& [test, segments] : lateral_segments(o))
      for (FitEffectTest& t : result->tests)
        if (t.test == test) t.error_beyond_known = error_beyond_patterns(o, at_neutral, known, segments);
  }

  // A lateral run's rows among the predictors' (`row`, `n`) and its predictor's index.
  struct LateralSegment {
    Eigen::Index row, n;
    size_t run;
  };
  // The lateral runs' segments by test (o.tests' labels).
  std::map<std::string, std::vector<LateralSegment>> lateral_segments(const Observations& o) const {
    std::map<std::string, std::vector<LateralSegment>> by_test;
    Eigen::Index row = lateral_layout(o.predictors).second;
    for (size_t i = runs_.size(); i < runs_.size() + lateral_runs_.size(); ++i) {
      const Eigen::Index n = o.predictors[i]->measured().size();
      by_test[o.tests[i]].push_back({row, n, i});
      row += n;
    }
    return by_test;
  }

  // One lateral test's error beyond its patterns (set_errors_beyond_known): its pair of columns
  // of `known` (mesh, cut: the first column not zero on its rows, rounded down to the pair's
  // first), in strain units, fitted to m − p with bounded amplitudes; NaN without columns.
  double error_beyond_patterns(const Observations& o, const std::vector<Eigen::VectorXd>& at_neutral,
                               const Eigen::MatrixXd& known, const std::vector<LateralSegment>& segments) const {
    const Eigen::Index first = segments.front().row, n = segments.front().n;
    Eigen::Index pair = 0;
    while (pair < known.cols() && known.col(pair).segment(first, n).isZero(0)) ++pair;
    if (pair >= known.cols()) return std::numeric_limits<double>::quiet_NaN();
    pair -= pair % 2;
    Eigen::Index rows = 0;
    for (const LateralSegment& g : segments) rows += g.n;
    Eigen::MatrixXd a(rows, 2);
    Eigen::VectorXd e(rows);
    for (Eigen::Index at = 0; const LateralSegment& g : segments) {
      const Eigen::VectorXd& m = o.predictors[g.run]->measured();
      a.middleRows(at, g.n) = m.asDiagonal() * known.block(g.row, pair, g.n, 2);
      e.segment(at, g.n) = m - at_neutral[g.run];  // what the prediction lacks: m ≈ p + a c
      at += g.n;
    }
    const double reach = kCutSpreadBoundDeg / kCutProbeDeg;
    const double angle_deg = lateral_runs_.at(segments.front().run - runs_.size()).test->angle_deg;
    const bool on_axis = std::abs(std::remainder(angle_deg, 90.0)) < 1e-9;  // warp or weft
    const Eigen::Vector2d lower(0.0, on_axis ? 0.0 : -reach), upper(kMeshPatternReach, on_axis ? reach * reach : reach);
    const Eigen::VectorXd left = e - a * box_least_squares(a, e, lower, upper);
    double sum = 0;
    for (Eigen::Index at = 0; const LateralSegment& g : segments) {
      sum += left.segment(at, g.n).cwiseAbs().sum() / o.predictors[g.run]->measured().cwiseAbs().sum();
      at += g.n;
    }
    return sum / static_cast<double>(segments.size());
  }

  // What the lateral strains carry beside each run's noise, on the predictors' rows (none
  // without lateral rows): the curves' levels (lateral_level_noise) and the mesh's and the
  // cuts' patterns (lateral_known_directions).
  struct LateralTerms {
    Eigen::MatrixXd level;
    Eigen::MatrixXd known;
  };

  // Before the joint fit (with_curves): the effect's own parameters first, from its neutral
  // values, so that the joint problem starts where the effect already explains what it can.
  void fit_effect_first(FitContext& context, const std::vector<std::string>& effect_free,
                        const ParameterMap::Options& map_options, const std::vector<std::shared_ptr<Predictor>>& predictors,
                        const std::vector<const RunData*>& force_runs, const std::string& resolution,
                        Clock::time_point t) const {
    // The effect alone first, the curves held; then every unknown from there. From the
    // neutral values the joint problem's first steps trade the curves against the effect:
    // measured on a hysteresis fit of 15 warp/weft/bias runs (8x12), Levenberg–Marquardt
    // took G12 from 3.9 to 0.19 MPa and gave the shear curve a negative weight (a non-convex
    // law, whose strip equilibria then depend on the solver's start), reached ε 6.0 from 469
    // on warm-started solves that the loading path from the flat strip does not reproduce
    // (ε 5.3e7 there), and the stage kept its start: 9.10 % → 9.10 %.
    const Eigen::VectorXd before = context.params.to_flat();
    fit_free(context, effect_free, map_options, predictors, force_runs, resolution, t, nullptr,
             " (curves held)");
    // An effect the curves leave no room for does not move from neutral alone: a Maxwell branch
    // adds force on the loading branch the baseline already fits (measured on the five-specimen
    // friction dataset, 8x12: rate-dependence sat at its neutral bound, projected gradient 0,
    // and the joint phase then took 60 iterations — its cap — and 14 failed solves on
    // non-convex trial curves to 1.44 % from 9.10 %). Then the curves' stiffnesses are freed
    // with it, their shapes held (a scaled curve keeps its shape and the law its convexity):
    // 1.20 %, converged in 12 + 44 iterations. Not when the effect moved alone: for hysteresis
    // on the same data it bought nothing (1.02 % either way) for 2.5x the time.
    if (!moved(before, context.params.to_flat()))
      fit_free(context, with_stiffnesses(context, effect_free), map_options, predictors, force_runs,
               resolution, t, nullptr, " (curve shapes held)");
  }

  // Whether any flat entry changed beyond round-off (the parameter map's round trip).
  static bool moved(const Eigen::VectorXd& before, const Eigen::VectorXd& after) {
    constexpr double kRoundOff = 1e-12;
    for (Eigen::Index i = 0; i < before.size(); ++i)
      if (std::abs(after[i] - before[i]) > kRoundOff * std::max(1.0, std::abs(before[i]))) return true;
    return false;
  }

  // `free` and the stiffnesses of the curves fitted so far (a11_Pa, ...; once each).
  static std::vector<std::string> with_stiffnesses(const FitContext& context, std::vector<std::string> free) {
    for (const CurveStage& c : context.fitted_curves)
      if (std::find(free.begin(), free.end(), c.term->stiffness) == free.end()) free.push_back(c.term->stiffness);
    return free;
  }

  static void append_curve_parameters(const FitContext& context, std::vector<std::string>* free) {
    for (const CurveStage& c : context.fitted_curves)
      for (const std::string& name : c.free_parameters()) free->push_back(name);
  }

  FitEffect effect_record(const FitContext& context, int level,
                          const std::vector<std::shared_ptr<Predictor>>& predictors) const {
    FitEffect result;
    result.effect = options_.effect;
    result.resolution = resolution_at(context, level);
    result.runs = static_cast<int>(predictors.size());
    for (const auto& p : predictors) result.points += static_cast<int>(p->measured().size());
    return result;
  }

  // The force runs' rows with their predictions without and with the effect (runs_ are the
  // first predictors).
  void keep_curves(const std::vector<std::shared_ptr<Predictor>>& predictors, const std::vector<Eigen::VectorXd>& without,
                   const std::vector<Eigen::VectorXd>& with, FitEffect* result) const {
    const auto vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
    for (size_t i = 0; i < runs_.size() && i < without.size() && i < with.size(); ++i)
      result->curves.push_back({runs_[i].test->label, runs_[i].run->name(), runs_[i].extension_mm,
                                vec(predictors[i]->measured()), vec(without[i]), vec(with[i])});
  }

  // The stage's errors: the mean over runs and per test (`tests`: each run's), with each test's
  // noise floor (the mean of its runs' `noise`; empty when the score test was not evaluated).
  static void set_errors(const std::vector<std::string>& tests, const std::vector<double>& without,
                         const std::vector<double>& with, const std::vector<double>& noise, FitEffect* result) {
    result->error_without = mean(without);
    result->error_with = mean(with);
    for (size_t i = 0; i < tests.size(); ++i) {
      auto t = std::find_if(result->tests.begin(), result->tests.end(),
                            [&](const FitEffectTest& e) { return e.test == tests[i]; });
      const bool shared = result->score_run_share.size() == tests.size();
      if (t == result->tests.end()) {
        FitEffectTest fresh;
        fresh.test = tests[i];
        if (!noise.empty()) fresh.noise_floor = 0;
        if (shared) fresh.score_share = 0;
        t = result->tests.insert(t, fresh);
      }
      t->error_without += without[i];
      t->error_with += with[i];
      if (!noise.empty()) t->noise_floor += noise[i];
      if (shared) t->score_share += result->score_run_share[i];
      ++t->runs;
    }
    for (FitEffectTest& t : result->tests) {
      t.error_without /= t.runs;
      t.error_with /= t.runs;
      t.noise_floor /= t.runs;
    }
  }

  void finish(FitContext& context, FitEffect result, FitReport& out) const {
    context.note(fmt::format("effect {}: error {:.2f} % without it, {:.2f} % with it ({} runs, {} points, {})",
                             options_.effect, 100 * result.error_without, 100 * result.error_with, result.runs,
                             result.points, result.resolution));
    out.effects.push_back(std::move(result));
  }

  // Fits `free` entries of context.params to `predictors` with the config's optimiser, records
  // the stage's row and returns each run's error at the optimum. The first predictors
  // predict `force_runs`' forces, each with its specimen scale when the config models one.
  std::vector<double> fit_free(FitContext& context, const std::vector<std::string>& free, const ParameterMap::Options& map_options,
                  const std::vector<std::shared_ptr<Predictor>>& predictors,
                  const std::vector<const RunData*>& force_runs, const std::string& resolution,
                  Clock::time_point t, std::vector<Eigen::VectorXd>* predictions = nullptr,
                  const std::string& what = "") const {
    ParameterMap map(context.params, free, map_options);
    FitObjective objective(map, predictors);
    objective.set_scale_groups(context.scale_groups(force_runs, predictors.size()));
    objective.set_progress([&](const IterationRecord& it, const Eigen::VectorXd&) {
      context.say(1, fmt::format("  effect {}{} it {:3d}: eps {:.4e} |g| {:.2e}", options_.effect, what, it.iteration,
                                 it.value, it.gradient_norm));
    });
    std::unique_ptr<Optimizer> optimizer = context.make_optimizer();
    const Eigen::VectorXd start = map.initial_x();
    const double at_start = objective.evaluate(start, nullptr);
    const OptimizerResult r = optimizer->minimize(objective, start);
    const double at_end = objective.evaluate(r.x, nullptr);
    if (!std::isfinite(at_end))
      throw std::runtime_error("effect-fit " + options_.effect + ": the optimiser's final point could not be evaluated: " +
                               objective.last_failure());
    Eigen::VectorXd x = r.x;
    if (at_end > at_start) {  // measured: a rate fit from neutral ended at 26.6 % from 9.4 % (docs/discovery.md §4)
      context.note(fmt::format("effect {}{}: the optimiser ended above its start (ε {:.4e} > {:.4e}, {}): the start kept",
                               options_.effect, what, at_end, at_start, r.message));
      x = start;
      objective.evaluate(x, nullptr);
    }
    context.params = map.parameters(x);
    context.keep_scales(force_runs, objective.scales());
    const std::vector<double> errors = run_errors(objective, predictors.size());
    if (predictions) *predictions = objective.last_predictions();
    context.record_stage("effect " + options_.effect + what, resolution, 0, mean(errors), *optimizer, r, objective, t);
    return errors;
  }

  // An angle-offset effect (misalignment, docs/effects/misalignment.md): `rounds` rounds of
  // (1) every fit run's offset searched with the law held (fitting/offset_search.hpp), put in
  // the gauge the data leave free (gauge_offsets), the run's strip turned by it, and (2) every
  // fitted curve stage's stiffness and curve refitted to the turned strips; then the effect's
  // model parameters estimated from the offsets (Effect::estimated_from_runs).
  void fit_offsets(FitContext& context, size_t index, int level, FitReport& out) {
    std::vector<RunData*> runs;
    for (RunData& d : context.fit_runs) runs.push_back(&d);
    std::optional<ValidationEvidence> evidence = validation_evidence(context, index, level);
    if (!has_repeats(runs)) {
      context.note("effect " + options_.effect + ": every fit test has one fit run, whose offset the curve "
                   "absorbs: fit-run offsets need repeats (repeats.rule=all); the spread comes from the validation "
                   "offsets alone");
      if (evidence) finish_with_validation(context, index, std::move(*evidence), out);
      return;
    }
    const std::vector<const RunData*> fixed(runs.begin(), runs.end());
    OffsetSearchOptions search_options;
    search_options.free_scale = context.config().repeats.scale == SpecimenScale::PerRun;
    OffsetSearch search(search_options, context.effects[index]);
    const std::vector<double> without = errors_at_nominal_angles(context, fixed, level);
    std::vector<std::shared_ptr<Predictor>> predictors;
    std::vector<double> with;
    std::string resolution;
    for (int round = 0; round < options_.rounds; ++round) {
      const auto t = Clock::now();
      const auto samples = search.search(context, fixed, level);
      std::vector<double> offsets;
      for (size_t i = 0; i < runs.size(); ++i) {
        const OffsetSearch::Sample* best = OffsetSearch::best(samples[i]);
        if (!best)
          throw std::runtime_error("effect-fit " + options_.effect + ": " + FitContext::run_label(*runs[i]) +
                                   " did not converge at its nominal angle");
        offsets.push_back(best->offset_deg);
      }
      gauge_offsets(fixed, samples, search_options.free_scale, &offsets);
      predictors.clear();
      for (size_t i = 0; i < runs.size(); ++i) {
        runs[i]->strip_angle_deg = search.turned_angle(runs[i]->test->angle_deg, offsets[i]);
        const auto experiment = context.tensile_experiment(*runs[i], level, context.params);
        if (level == context.finest_level) context.last_predictor[runs[i]] = {level, experiment};
        predictors.push_back(experiment);
      }
      resolution = resolution_at(context, level);
      std::vector<std::string> free;
      append_curve_parameters(context, &free);
      with = fit_free(context, free, {}, predictors, fixed, resolution, t);
      report_offsets(context, round, fixed);
    }
    FitEffect result = effect_record(context, level, predictors);
    std::vector<std::string> tests;
    for (const RunData* d : fixed) tests.push_back(d->test->label);
    set_errors(tests, without, with, {}, &result);
    std::vector<Eigen::VectorXd> run_values;
    for (const RunData* d : fixed)
      run_values.push_back(Eigen::VectorXd::Constant(1, FitContext::strip_offset(*d)));
    if (evidence) {
      finish_with_validation(context, index, std::move(*evidence), out);
      return;
    }
    ComponentChoice& fitted = context.params.effects[index];
    fitted.options = context.effects[index]->estimated_from_runs(run_values, fitted.options);
    record_parameters(context, fitted, &result);
    finish(context, std::move(result), out);
  }

  // The validation strips' record (validation_evidence) with the spread estimated from their
  // offsets, which also becomes the effect's spread in the parameters.
  void finish_with_validation(FitContext& context, size_t index, ValidationEvidence evidence, FitReport& out) const {
    ComponentChoice& fitted = context.params.effects[index];
    fitted.options = context.effects[index]->estimated_from_runs(evidence.offsets, fitted.options);
    record_parameters(context, fitted, &evidence.record);
    context.note(fmt::format("effect {}: judged on the {} validation strips (off the material axes a cut moves the "
                             "force to first order; fit-run offsets trade with the specimen scales), at the curves "
                             "fitted before it; the spread is theirs",
                             options_.effect, evidence.offsets.size()));
    finish(context, std::move(evidence.record), out);
  }

  // Misalignment where the data identify it (docs/effects/misalignment.md, "Judged on the
  // validation strips"): the validation strips, off the material axes, where a cut moves the
  // force to first order and each strip's offset is its own. At the curves fitted before this
  // stage (the baseline). The law's own error at a validation angle (its interpolation between
  // warp, weft and bias) moves every strip of that test alike and looks like a common offset
  // (measured: 0.2 % on strips cut on their angles, which per-strip offsets halve); a cut is
  // each strip's own. So the baseline of the score test has per strip its scale (column
  // s F/F̆) and per test a common offset (the sum of its strips' columns), the candidate per
  // strip its offset (s F'/F̆, F' = dF/dθ, Eq. 6), residuals r = (s F − F̆)/F̆ at the nominal
  // angle: d = strips − tests. Errors: without, each test's strips at their best common offset
  // (F linear in Δθ off the axes: F + δ F' on a grid) and own scales; with, each strip at the
  // offset its search finds, scale free; held out, both kinds of offset fitted on every other
  // row of each strip and judged on the rows between, both ways (a cut moves every row; an
  // offset fitted to noise does not predict the next row's). Halves by extension were tried
  // first: the lower half, its forces small, pins an offset with a free scale too loosely
  // (papers/discovery seed 4: cuts found at p 5e-4, 2.16 % → 0.49 %, held-out upper halves
  // 3.43 % → 4.19 %). nullopt with fewer than kValidationStripsForASpread validation strips.
  std::optional<ValidationEvidence> validation_evidence(FitContext& context, size_t index, int level) const {
    std::vector<const RunData*> runs;
    for (const RunData& d : context.validation_runs) runs.push_back(&d);
    if (runs.size() < kValidationStripsForASpread) return std::nullopt;
    OffsetSearchOptions search_options;
    search_options.free_scale = true;
    OffsetSearch search(search_options, context.effects[index]);
    const auto samples = search.search(context, runs, level);
    ValidationSystem system(runs);
    ValidationEvidence evidence;
    std::vector<double> with;
    std::vector<std::string> tests;
    std::vector<StripForces> forces;
    Eigen::Index row = 0;
    for (size_t k = 0; k < runs.size(); ++k) {
      forces.push_back(nominal_forces(samples[k], *runs[k]));
      system.add_strip(k, row, runs[k]->test, forces.back());
      row += system.rows[k];
      const OffsetSearch::Sample& best = *OffsetSearch::best(samples[k]);
      with.push_back(best.error);
      tests.push_back(runs[k]->test->label);
      evidence.offsets.push_back(Eigen::VectorXd::Constant(1, best.offset_deg));
    }
    const ValidationErrors errors = common_offset_errors(forces, runs, system.tests);
    const ScoreTest t = score_test(system.r, system.baseline, system.offsets, system.rows, system.calibration);
    FitEffect& result = evidence.record;
    result.effect = options_.effect;
    result.resolution = resolution_at(context, level);
    result.runs = static_cast<int>(runs.size());
    result.points = static_cast<int>(system.r.size());
    set_score(t, &result);
    set_errors(tests, errors.without, with, t.run_noise, &result);
    result.held_out_rows_without = mean(errors.held_without);
    result.held_out_rows_with = mean(errors.held_with);
    return evidence;
  }

  // A validation strip's forces at its nominal angle, with dF/dθ there.
  StripForces nominal_forces(const std::vector<OffsetSearch::Sample>& samples, const RunData& run) const {
    const OffsetSearch::Sample* nominal = OffsetSearch::nominal(samples);
    if (!nominal)
      throw std::runtime_error("effect-fit " + options_.effect + ": validation " + FitContext::run_label(run) +
                               " did not converge at its nominal angle");
    const Eigen::VectorXd& f = nominal->simulated.force_N;
    if (nominal->simulated.dforce_dangle.size() != f.size())
      throw std::logic_error("effect-fit " + options_.effect + ": the offset search kept no dF/dθ at the nominal angle");
    return {f, nominal->simulated.dforce_dangle, run.unscaled_force_N()};
  }

  static bool has_repeats(const std::vector<RunData*>& runs) {
    for (const RunData* d : runs)
      if (std::count_if(runs.begin(), runs.end(), [&](const RunData* e) { return e->test == d->test; }) >= 2)
        return true;
    return false;
  }

  // What the strips' forces cannot fix, fixed by the prior (docs/effects/misalignment.md).
  // Where a test's forces are nearly even in the offset (OffsetSearch::nearly_even: warp and
  // weft on the material axes; the bias of a stiff-yarn weave, whose force is smallest at
  // 45°), F ≈ F0 + c Δθ² and a common shift of v = Δθ² trades against the curve: the smallest
  // v of the test is set to 0 (paper §6.4's "the strip closest to its target angle", which is
  // the one with the largest forces on an axis and the smallest on a stiff-yarn bias), v
  // taken unconstrained (negative for a strip beyond the nominal model, so that one round
  // puts every strip where the curve refitted to the best-aligned one will see it); the sign
  // is not identified and the offset reported is |Δθ|. Elsewhere a common offset of the
  // test's strips trades against the curve: their mean is set to 0 (a cut has no side).
  static void gauge_offsets(const std::vector<const RunData*>& runs,
                            const std::vector<std::vector<OffsetSearch::Sample>>& samples, bool free_scale,
                            std::vector<double>* offsets) {
    std::map<const TensileTest*, std::vector<size_t>> by_test;
    for (size_t i = 0; i < runs.size(); ++i) by_test[runs[i]->test].push_back(i);
    for (const auto& [test, members] : by_test) {
      std::vector<std::vector<OffsetSearch::Sample>> test_samples;
      for (size_t i : members) test_samples.push_back(samples[i]);
      if (OffsetSearch::nearly_even(test_samples)) {
        std::vector<double> v;
        for (size_t i : members) {
          const double unconstrained = OffsetSearch::unconstrained_squared_offset(*runs[i], samples[i], free_scale);
          v.push_back(unconstrained < 0 ? unconstrained : (*offsets)[i] * (*offsets)[i]);
        }
        const double smallest = *std::min_element(v.begin(), v.end());
        for (size_t k = 0; k < members.size(); ++k) (*offsets)[members[k]] = std::sqrt(v[k] - smallest);
      } else {
        double sum = 0;
        for (size_t i : members) sum += (*offsets)[i];
        for (size_t i : members) (*offsets)[i] -= sum / static_cast<double>(members.size());
      }
    }
  }

  void report_offsets(FitContext& context, int round, const std::vector<const RunData*>& runs) const {
    std::string line;
    for (const RunData* d : runs)
      line += fmt::format("{}{} {:+.2f}", line.empty() ? "" : ", ", d->run->name(), FitContext::strip_offset(*d));
    context.say(0, fmt::format("effect {} round {}: offsets (deg) {}", options_.effect, round + 1, line));
  }

  bool forces() const { return options_.observable == "force_N" || options_.observable == "both"; }
  bool laterals() const { return options_.observable == "lateral_strain" || options_.observable == "both"; }

  // The runs whose forces it fits (runs_) and those whose lateral strains it fits.
  void select_runs(const FitContext& context) {
    runs_.clear();
    lateral_runs_.clear();
    const FitDataSelection& data = context.config().data;
    for (const RunData& d : context.fit_runs) {
      RunData rows = options_.rows == "path" ? measured_path(*d.test, *d.run, data)
                                             : measured_points(*d.test, *d.run, data);
      rows.strip_angle_deg = d.strip_angle_deg;
      if (forces()) runs_.push_back(rows);
      if (laterals() && d.run->has_lateral_strain()) {
        keep_lateral_rows(data.min_force_fraction, &rows);
        lateral_runs_.push_back(std::move(rows));
      }
    }
  }

  // The run as its lateral-strain experiment predicts it: the rows whose |lateral strain| is at
  // least `fraction` of the run's largest (relative residuals of the first, near-zero ones
  // would be noise), their lateral strains as the measured values (the experiment predicts
  // d.force_N, FitContext::tensile_experiment).
  static void keep_lateral_rows(double fraction, RunData* d) {
    double largest = 0;
    for (double v : d->lateral_strain) largest = std::max(largest, std::abs(v));
    RunData kept = *d;
    kept.extension_mm.clear();
    kept.time_s.clear();
    kept.lateral_strain.clear();
    for (size_t i = 0; i < d->lateral_strain.size(); ++i) {
      if (!(std::abs(d->lateral_strain[i]) >= fraction * largest && d->lateral_strain[i] != 0)) continue;
      kept.extension_mm.push_back(d->extension_mm[i]);
      if (!d->time_s.empty()) kept.time_s.push_back(d->time_s[i]);
      kept.lateral_strain.push_back(d->lateral_strain[i]);
    }
    kept.force_N = Eigen::Map<const Eigen::VectorXd>(kept.lateral_strain.data(),
                                                     static_cast<Eigen::Index>(kept.lateral_strain.size()));
    *d = std::move(kept);
  }

  std::string resolution_at(const FitContext& context, int level) const {
    if (bends()) {
      const Options& bend = context.config().bend_experiment.options;
      return FitContext::resolution_text(static_cast<int>(bend.get_int("cells_across")),
                                         static_cast<int>(bend.get_int("cells_along")));
    }
    const RunData& d = !runs_.empty() ? runs_.front() : !lateral_runs_.empty() ? lateral_runs_.front()
                                                                                : context.fit_runs.front();
    const TensileSetup s = context.setup_for(*d.test, level);
    return FitContext::resolution_text(s.cells_across, s.cells_along);
  }

  // The effect's options at its neutral values (the schema defaults: the paper's model).
  static Options neutral_options(const FitContext& context, const std::string& effect) {
    return default_options(context.registry().find_category(registry_category::kEffect)->at(effect).options, nullptr);
  }

  // The effect's parameters as fitted, each with its neutral value beside it.
  static void record_parameters(const FitContext& context, const ComponentChoice& fitted, FitEffect* result) {
    const ComponentChoice neutral{fitted.category, fitted.name, neutral_options(context, fitted.name)};
    const std::vector<EffectParameter> at_neutral = effect_parameters({neutral}, context.registry());
    const std::vector<EffectParameter> values = effect_parameters({fitted}, context.registry());
    for (size_t i = 0; i < values.size(); ++i)
      result->parameters.push_back({values[i].name, values[i].unit, values[i].value, values[i].lower, values[i].upper,
                                    i < at_neutral.size() ? at_neutral[i].value : 0.0});
  }

  // A fitted parameter that ends on a bound other than its neutral value is not pinned by the
  // data: it took up what the model misses elsewhere (measured: poisson's coupling_curvature at
  // its lower bound on hidden and null data alike when the strips are cut ±1.7° off their angles,
  // papers/hidden_effects/README.md). The report says so rather than hand it out as measured.
  static void note_unpinned(FitContext& context, const FitEffect& result) {
    for (const FitEffectParameter& p : result.parameters) {
      const bool lower = p.value <= p.lower, upper = p.value >= p.upper;
      if ((lower || upper) && p.value != p.neutral)
        context.note(fmt::format("effect {}: {} ended at its {} bound {:g}: the data do not pin it (it takes up "
                                 "what the model misses elsewhere, e.g. the strips' cutting offsets)",
                                 result.effect, p.name, lower ? "lower" : "upper", p.value));
    }
  }

  // The parameters so far with the effect at its neutral values.
  static MaterialParameters neutral_params(const FitContext& context, const ComponentChoice& configured) {
    MaterialParameters neutral = context.params;
    for (ComponentChoice& c : neutral.effects)
      if (c.name == configured.name)
        c.options = neutral_options(context, c.name);
    return neutral;
  }

  // The score test of the effect's unknowns (`free`'s first n_effect) at `params`, the other
  // free names, the runs' specimen scales and the lateral strains' known patterns
  // (`known`, lateral_known_directions) its baseline (core/score_test.hpp); the calibration
  // draws the curves' levels on the lateral strains (calibration.shared_noise,
  // lateral_level_noise) beside each run's noise.
  static ScoreTest score_at(const FitContext& context, const MaterialParameters& params,
                            const std::vector<std::string>& free, size_t n_effect,
                            const ParameterMap::Options& map_options,
                            const std::vector<std::shared_ptr<Predictor>>& predictors,
                            const std::vector<const RunData*>& force_runs, const ScoreCalibration& calibration,
                            const Eigen::MatrixXd& known) {
    std::vector<std::string> baseline_first(free.begin() + static_cast<std::ptrdiff_t>(n_effect), free.end());
    baseline_first.insert(baseline_first.end(), free.begin(), free.begin() + static_cast<std::ptrdiff_t>(n_effect));
    ParameterMap map(params, baseline_first, map_options);
    FitObjective objective(map, predictors);
    objective.set_scale_groups(context.scale_groups(force_runs, predictors.size()));
    // Counted in unknowns, not names: a curve's name is a pattern of several (eta3.*). Counted
    // in names, the shape parameters of every curve after the first two fell to the candidate:
    // poisson's test on a null twin had d = 8 for its 2 parameters, its curves' shapes judged on
    // the lateral strains as if they were the effect (found 2026-12-05).
    const std::vector<std::string> effect_names(free.begin(), free.begin() + static_cast<std::ptrdiff_t>(n_effect));
    const int n_candidate = ParameterMap(params, effect_names, map_options).dimension();
    return score_test(objective, map.initial_x(), map.dimension() - n_candidate, calibration, known);
  }

  // The noise per run at the fitted effect (ScoreTest::run_noise there, no calibration): at the
  // neutral values a nonlinear effect's linearisation leaves part of its own signal in the
  // noise (Dahl friction from zero: a floor of 4–5 % on data with 0.5 % noise), at the fit it
  // does not. Empty when it cannot be evaluated.
  std::vector<double> noise_at_fit(FitContext& context, const std::vector<std::string>& free, size_t n_effect,
                                   const ParameterMap::Options& map_options,
                                   const std::vector<std::shared_ptr<Predictor>>& predictors,
                                   const std::vector<const RunData*>& force_runs,
                                   const LateralTerms& lateral) const {
    try {
      ScoreCalibration none;
      none.replicates = 0;
      return with_level_floors(
          score_at(context, context.params, free, n_effect, map_options, predictors, force_runs, none, lateral.known)
              .run_noise,
          lateral.level, predictors);
    } catch (const std::runtime_error& e) {
      context.note("effect " + options_.effect + ": the noise at the fitted effect not evaluated: " + e.what());
    }
    return {};
  }

  // Per run the smaller of two noise estimates (either may be empty: the other).
  static std::vector<double> smaller_noise(const std::vector<double>& a, const std::vector<double>& b) {
    if (a.empty() || b.size() != a.size()) return a.empty() ? b : a;
    std::vector<double> out;
    for (size_t i = 0; i < a.size(); ++i) out.push_back(std::min(a[i], b[i]));
    return out;
  }

  // The score test of the effect at the parameters so far with the effect neutral (its result
  // in *result; a note when it cannot be evaluated); returns the runs' noise there.
  std::vector<double> score_at_neutral(FitContext& context, const ComponentChoice& configured,
                        const std::vector<std::string>& free, size_t n_effect, const ParameterMap::Options& map_options,
                        const std::vector<std::shared_ptr<Predictor>>& predictors,
                        const std::vector<const RunData*>& force_runs, const LateralTerms& lateral,
                        FitEffect* result) const {
    try {
      ScoreCalibration calibration;
      calibration.shared_noise = lateral.level;
      set_instruments(predictors, &calibration);
      const ScoreTest t = score_at(context, neutral_params(context, configured), free, n_effect, map_options, predictors,
                                   force_runs, calibration, lateral.known);
      set_score(t, result);
      return with_level_floors(t.run_noise, lateral.level, predictors);
    } catch (const std::runtime_error& e) {
      result->score = std::numeric_limits<double>::quiet_NaN();  // reported as not evaluated, and why
      context.note("effect " + options_.effect + ": score test not evaluated: " + e.what());
    }
    return {};
  }

  // The calibration's instruments (ScoreCalibration::measured): each row's |measured| and each
  // run's instrument, the load cell for the force runs (the first), the lateral strains' gauge
  // for the lateral runs.
  void set_instruments(const std::vector<std::shared_ptr<Predictor>>& predictors, ScoreCalibration* calibration) const {
    Eigen::Index rows = 0;
    for (const auto& p : predictors) rows += p->measured().size();
    calibration->measured.resize(rows);
    rows = 0;
    for (size_t i = 0; i < predictors.size(); ++i) {
      const Eigen::VectorXd& measured = predictors[i]->measured();
      calibration->measured.segment(rows, measured.size()) = measured.cwiseAbs();
      calibration->instruments.push_back(i < runs_.size() ? kLoadCell : kLateralGauge);
      rows += measured.size();
    }
  }

  // The chord angles' test at the effect's neutral values (docs/effects/bending-anisotropy.md,
  // "Judged against the repeated overhangs"): one chord angle per cantilever direction, at the
  // mean of its repeated overhangs, leaves no residual to judge the noise by (two ratios, two
  // directions), but the repeats measure it: a direction's chord angle scatters by
  // |dθ/dL| sd(L)/√n (dθ/dL by a step of kOverhangStepMm, sd(L) from the overhangs' relative sd
  // pooled over the directions, pooled_relative_sd). Residuals
  // and directions in units of that error, the baseline's direction the thickness (the bend
  // stage's unknown, with the membrane held: a ← a τ0/τ), the candidate's its parameters:
  // score_test_with_known_noise, with Σ (n − 1) degrees of freedom. Returns each cantilever's
  // floor, the mean |noise| √(2/π) se; empty (score NaN, a note) when no direction has two
  // overhangs.
  std::vector<double> bend_score_at_neutral(FitContext& context, const ComponentChoice& configured,
                                            const std::vector<std::string>& effect_free,
                                            const ParameterMap::Options& map_options, FitEffect* result) const {
    result->score = std::numeric_limits<double>::quiet_NaN();
    const std::vector<BendTest>& bends = context.dataset().bend;
    int noise_dof = 0;
    const double relative_sd = pooled_relative_sd(bends, &noise_dof);
    if (noise_dof == 0) {
      context.note("effect " + options_.effect + ": score test not evaluated: one overhang per cantilever direction "
                   "(needs repeated overhangs to measure the chord angles' noise)");
      return {};
    }
    try {
      const MaterialParameters neutral = neutral_params(context, configured);
      std::vector<std::shared_ptr<Predictor>> predictors;
      for (const BendTest& b : bends) predictors.push_back(context.bend_experiment(b, neutral));
      Eigen::VectorXd r, unused;
      Eigen::MatrixXd thickness, candidate;
      ParameterMap::Options rescale;
      rescale.rescale_with_thickness = true;
      residuals_at(neutral, {"thickness_m"}, rescale, predictors, &r, &thickness);
      residuals_at(neutral, effect_free, map_options, predictors, &unused, &candidate);
      int dof = 0;
      const Eigen::VectorXd se = chord_angle_noise(context, bends, neutral, relative_sd, noise_dof, &dof);
      const ScoreTest t = score_test_with_known_noise(r.cwiseQuotient(se), se.cwiseInverse().asDiagonal() * thickness,
                                                      se.cwiseInverse().asDiagonal() * candidate, dof);
      set_score(t, result);
      std::vector<double> floors;
      for (Eigen::Index j = 0; j < se.size(); ++j) floors.push_back(std::sqrt(2 / M_PI) * se[j]);
      return floors;
    } catch (const std::runtime_error& e) {
      context.note("effect " + options_.effect + ": score test not evaluated: " + e.what());
    }
    return {};
  }

  // Each cantilever's chord-angle standard error (relative to θ̆): the overhangs' scatter and its
  // direction's curve level in quadrature, from one solve at `params` each; *dof Satterthwaite's
  // for the summed variances — the overhangs' share one pooled estimate (noise_dof), each
  // direction's level its own (n − 1) — at most their dofs summed, the overhangs' own when no
  // variance is measured.
  static Eigen::VectorXd chord_angle_noise(const FitContext& context, const std::vector<BendTest>& bends,
                                           const MaterialParameters& params, double relative_sd, int noise_dof,
                                           int* dof) {
    Eigen::VectorXd se(static_cast<Eigen::Index>(bends.size()));
    double overhangs = 0, levels = 0, levels_over_dof = 0;
    int dof_sum = noise_dof;
    for (size_t j = 0; j < bends.size(); ++j) {
      const double at = chord_angle(context, bends[j], params);
      const double overhang = chord_angle_error(context, bends[j], params, at, relative_sd);
      const LevelNoise level = curve_level_error(context, bends[j], params, at);
      se[static_cast<Eigen::Index>(j)] = std::hypot(overhang, level.se);
      overhangs += overhang * overhang;
      levels += level.se * level.se;
      if (level.dof > 0) levels_over_dof += std::pow(level.se, 4) / level.dof;
      dof_sum += level.dof;
    }
    const double total = overhangs + levels, spread = overhangs * overhangs / noise_dof + levels_over_dof;
    *dof = spread > 0 ? std::clamp(static_cast<int>(std::min<double>(total * total / spread, dof_sum)), 1, dof_sum)
                      : noise_dof;
    return se;
  }

  // A score test's statistic, degrees of freedom and p-values into the stage's record.
  static void set_score(const ScoreTest& t, FitEffect* result) {
    result->score = t.statistic;
    result->score_dof = t.dof;
    result->score_p_value_iid = t.p_value_iid;
    result->score_p_value = t.p_value;
    result->score_noise_correlation = t.noise_correlation;
    result->score_run_share = t.run_share;
  }

  // The residuals (p̂ − p̆)/p̆ of `predictors` at `params` and their Jacobian in `free`.
  static void residuals_at(const MaterialParameters& params, const std::vector<std::string>& free,
                           const ParameterMap::Options& map_options,
                           const std::vector<std::shared_ptr<Predictor>>& predictors, Eigen::VectorXd* r,
                           Eigen::MatrixXd* jacobian) {
    ParameterMap map(params, free, map_options);
    FitObjective objective(map, predictors);
    objective.residuals(map.initial_x(), r, jacobian);
    if (!std::isfinite(r->sum()))
      throw std::runtime_error("the cantilevers could not be evaluated: " + objective.last_failure());
  }

  // The standard error of a cantilever direction's chord angle at the mean of its n overhangs,
  // relative to the measured angle: |dθ/dL| sd(L)/√n / θ̆, with sd(L) = L̄ times the overhangs'
  // relative sd pooled over the directions (`relative_sd`).
  static double chord_angle_error(const FitContext& context, const BendTest& b, const MaterialParameters& params,
                                  double at, double relative_sd) {
    BendTest longer = b;
    for (double& l : longer.overhang_mm) l += kOverhangStepMm;
    const double beyond = chord_angle(context, longer, params);
    const double n = static_cast<double>(b.overhang_mm.size());
    return std::abs(beyond - at) / kOverhangStepMm * relative_sd * mean(b.overhang_mm) / std::sqrt(n) /
           b.chord_angle_deg;
  }

  // The noise a cantilever's chord angle carries from its direction's membrane stiffness: the
  // curve of that direction is off by its level's error (curve_level), and the bending
  // stiffness τ³a/12 follows a — so the chord angle by |dθ/d log a| times that, relative to the
  // measured angle (dof n − 1). Without it, null data whose warp and weft curves missed their truth by
  // 14 % and 6 % (3 strips each at 20 % scatter) were named anisotropic (papers/discovery,
  // bending twin 4; docs/effects/bending-anisotropy.md, "What the chord angles cannot tell from
  // anisotropy"). None (0, 0) without a fitted curve at the cantilever's angle or with fewer
  // than two runs there.
  struct LevelNoise {
    double se = 0;
    int dof = 0;
  };
  static LevelNoise curve_level_error(const FitContext& context, const BendTest& b, const MaterialParameters& params,
                                      double at) {
    const auto stage = std::find_if(context.fitted_curves.begin(), context.fitted_curves.end(),
                                    [&](const CurveStage& c) { return c.angle_deg == b.angle_deg; });
    if (stage == context.fitted_curves.end()) return {};
    const LevelNoise level = curve_level(context, b.angle_deg);
    if (level.dof == 0) return {};
    MaterialParameters stiffer = params;
    stiffer.*(stage->term->stiffness_member) *= 1 + kStiffnessStep;
    const double slope = (chord_angle(context, b, stiffer) - at) / std::log1p(kStiffnessStep);
    return {std::abs(slope) * level.se / b.chord_angle_deg, level.dof};
  }

  // The standard error of the level of the curve fitted at `angle_deg` (log of its stiffness):
  // the curve sits at the geometric mean of its fit runs' scales, off by sd(log s_r)/√n with
  // n − 1 dof. The scales are the runs' own onto their mean (repeat_branches, no model: the stage
  // may run after a start-from that kept none). None (0, 0) with fewer than two runs.
  static LevelNoise curve_level(const FitContext& context, double angle_deg) {
    std::vector<double> logs;
    for (const TensileTest& test : context.dataset().tensile)
      if (test.role == TestRole::Fit && test.angle_deg == angle_deg)
        if (const std::optional<RepeatBranches> repeats = repeat_branches(test))
          for (double scale : repeats->scales) logs.push_back(std::log(scale));
    if (logs.size() < 2) return {};
    const double n = static_cast<double>(logs.size()), m = mean(logs);
    double squares = 0;
    for (double l : logs) squares += (l - m) * (l - m);
    return {std::sqrt(squares / (n - 1) / n), static_cast<int>(logs.size()) - 1};
  }

  // The curves' levels on the lateral strains (docs/discovery.md §2, "The lateral strains' noise
  // beyond each run's"): every fitted curve's stiffness is off its truth by its level's
  // error δ_k (curve_level), and a strip's contraction follows the stiffnesses' ratios (a weft
  // strip's by a12/a11), which no specimen scale absorbs — the lateral strains have none. So
  // every lateral row of every run shares the noise J_L δ, J_L = ∂r_L/∂log a_k (the objective's
  // exact Jacobian in the stiffnesses, the tie of a12 included). Returns L = J_L diag(se_k) on
  // the predictors' rows (m × k, zero off the lateral rows; the lateral predictors follow the
  // force runs'), no columns without lateral rows or a curve with two runs. Measured without
  // it: a null twin whose weft curves' ratio a22/a11 came out 0.918 (one level sd at 10 %
  // scatter) missed the weft's lateral strains by 8.86 %, and poisson was named (p 0.018).
  Eigen::MatrixXd lateral_level_noise(FitContext& context, const MaterialParameters& params,
                                      const std::vector<std::shared_ptr<Predictor>>& predictors) const {
    const auto [rows, first] = lateral_layout(predictors);
    std::vector<std::string> stiffnesses;
    std::vector<double> se;
    for (const CurveStage& c : context.fitted_curves)
      if (const LevelNoise level = curve_level(context, c.angle_deg); level.dof > 0) {
        stiffnesses.push_back(c.term->stiffness);
        se.push_back(level.se);
      }
    if (lateral_runs_.empty() || stiffnesses.empty()) return {};
    const std::vector<std::shared_ptr<Predictor>> laterals(
        predictors.begin() + static_cast<std::ptrdiff_t>(runs_.size()),
        predictors.begin() + static_cast<std::ptrdiff_t>(runs_.size() + lateral_runs_.size()));
    ParameterMap map(params, stiffnesses, {});
    FitObjective objective(map, laterals);
    Eigen::VectorXd r;
    Eigen::MatrixXd jacobian;  // ∂r/∂x, x_k = a_k/a_k0: ∂r/∂log a_k at x = 1
    objective.residuals(map.initial_x(), &r, &jacobian);
    if (!std::isfinite(r.sum())) {
      context.note("effect " + options_.effect + ": the curves' levels left out of the lateral strains' noise: " +
                   objective.last_failure());
      return {};
    }
    Eigen::MatrixXd level = Eigen::MatrixXd::Zero(rows, jacobian.cols());
    level.middleRows(first, jacobian.rows()) =
        jacobian * Eigen::Map<const Eigen::VectorXd>(se.data(), static_cast<Eigen::Index>(se.size())).asDiagonal();
    return level;
  }

  // Patterns the lateral strains carry that no unknown does and the data cannot tell from a
  // coupling, as directions of the score test's baseline (m × 2·tests, zero off the lateral
  // rows; none without lateral rows, with a note when a strip fails), from each lateral
  // predictor's prediction at `params` (`at_neutral`, the errors without the effect's). Per
  // lateral test:
  // - the mesh's own error, its runs' rows (p_finer − p)/p̆, p_finer the strip one level finer.
  //   Generated data are simulated finer than they are fitted, as real data are continuous,
  //   and a strip's contraction converges slowly near the first strains (an 8×12 strip's is
  //   3.4 % short of a 16×24 strip's at 2 mm, within 0.5 % from 8 mm on), a shape the coupling
  //   curvature takes up: a cut-free null twin named poisson at p 5e-4 with η2''(0) 5.3 (the
  //   aligned twins' mesh bias gave 3.4–5.1; papers/hidden_effects/README.md, "Poisson"); with
  //   this direction p 0.32;
  // - the strips' cutting offsets, (p_finer(θ + kCutProbeDeg) − p_finer)/p̆. A cut moves a
  //   warp or weft strip's contraction evenly in the offset (±θ alike) and as its square, so
  //   unknown cuts bias every strip the same way, by a pattern that grows with the strain
  //   (kCutProbeDeg). It is taken on the finer strip: the coarse strip's response to a cut is
  //   not the continuum's — at 1.3° a warp strip narrows 1.6/3.3/6.6/11.7 % more at 1/4/8/12 mm
  //   on 8×12 and 1.3/2.8/6.8/20.6 % on 16×24 (truth of poisson twin 1) — and a column of the
  //   coarse pattern left the rest to the coupling: on the 1°-cut null twin 1 (10 %) the warp
  //   lateral strains alone gave T 6.4 of 10.2, p 0.0055, named; with the finer pattern T 0.19,
  //   p 0.78 (docs/effects/poisson.md, "The cuts, on the finer strip").
  Eigen::MatrixXd lateral_known_directions(FitContext& context, int level, const MaterialParameters& params,
                                           const std::vector<std::shared_ptr<Predictor>>& predictors,
                                           const std::vector<Eigen::VectorXd>& at_neutral) const {
    if (lateral_runs_.empty()) return {};
    auto [rows, row] = lateral_layout(predictors);
    std::vector<std::string> tests;  // each lateral test's pair of columns
    Eigen::MatrixXd known = Eigen::MatrixXd::Zero(rows, 0);
    for (size_t j = 0; j < lateral_runs_.size(); ++j) {
      const std::shared_ptr<Predictor>& at = predictors[runs_.size() + j];
      const Eigen::VectorXd& nominal = at_neutral.at(runs_.size() + j);
      RunData cut = lateral_runs_[j];
      cut.strip_angle_deg = FitContext::strip_angle(cut) + kCutProbeDeg;
      Eigen::VectorXd finer, offset;
      std::string message = "the strip at the neutral values did not converge";
      const bool solved =
          std::isfinite(nominal.sum()) &&
          context.tensile_experiment(lateral_runs_[j], level + 1, params, kLateralExperiment)
              ->predict(params, {}, &finer, nullptr, &message) &&
          context.tensile_experiment(cut, level + 1, params, kLateralExperiment)->predict(params, {}, &offset, nullptr,
                                                                                          &message);
      if (!solved || finer.size() != nominal.size() || offset.size() != nominal.size()) {
        context.note("effect " + options_.effect + ": the mesh's and the cuts' patterns in the lateral strains not "
                     "measured: " + message);
        return {};
      }
      const std::string& test = lateral_runs_[j].test->label;
      auto found = std::find(tests.begin(), tests.end(), test);
      if (found == tests.end()) {
        tests.push_back(test);
        known.conservativeResize(Eigen::NoChange, known.cols() + 2);
        known.rightCols(2).setZero();
        found = tests.end() - 1;
      }
      const Eigen::Index n = nominal.size(), column = 2 * (found - tests.begin());
      known.col(column).segment(row, n) = (finer - nominal).cwiseQuotient(at->measured());
      known.col(column + 1).segment(row, n) = (offset - finer).cwiseQuotient(at->measured());
      row += n;
    }
    return known;
  }

  // The predictors' rows in all and the first lateral row (the lateral predictors follow the
  // force runs').
  std::pair<Eigen::Index, Eigen::Index> lateral_layout(const std::vector<std::shared_ptr<Predictor>>& predictors) const {
    Eigen::Index rows = 0, first = 0;
    for (size_t i = 0; i < predictors.size(); ++i) {
      if (i == runs_.size()) first = rows;
      rows += predictors[i]->measured().size();
    }
    return {rows, first};
  }

  // Each run's floor with the curves' levels (`level`, lateral_level_noise) added in
  // quadrature: its rows' mean |J_L δ|, √(2/π) sd per row, averaged over the run's rows. The
  // force runs' floors are unchanged (their scales absorb a level).
  static std::vector<double> with_level_floors(std::vector<double> noise, const Eigen::MatrixXd& level,
                                               const std::vector<std::shared_ptr<Predictor>>& predictors) {
    if (level.cols() == 0 || noise.size() != predictors.size()) return noise;
    Eigen::Index row = 0;
    for (size_t i = 0; i < predictors.size(); ++i) {
      const Eigen::Index n = predictors[i]->measured().size();
      if (n > 0) {
        const double shared = std::sqrt(2 / M_PI) * level.middleRows(row, n).rowwise().norm().mean();
        noise[i] = std::hypot(noise[i], shared);
      }
      row += n;
    }
    return noise;
  }

  // The repeated overhangs' relative sd, pooled over the directions (Σ (n − 1) degrees of
  // freedom, *dof): a specimen's bending stiffness B scatters by a share, as its tensile scale
  // does (paper §6.4), and the overhang L ∝ B^(1/3) (D1388) by a share of that, so one relative
  // sd serves both directions; pooled, T/d is F(d, Σ (n − 1)) (score_test_with_known_noise).
  static double pooled_relative_sd(const std::vector<BendTest>& bends, int* dof) {
    double squares = 0;
    *dof = 0;
    for (const BendTest& b : bends) {
      const double m = mean(b.overhang_mm);
      for (double l : b.overhang_mm) squares += (l / m - 1) * (l / m - 1);
      *dof += std::max<int>(0, static_cast<int>(b.overhang_mm.size()) - 1);
    }
    return *dof > 0 ? std::sqrt(squares / *dof) : 0.0;
  }

  static double chord_angle(const FitContext& context, const BendTest& b, const MaterialParameters& params) {
    Eigen::VectorXd value;
    std::string message;
    if (!context.bend_experiment(b, params)->predict(params, {}, &value, nullptr, &message))
      throw std::runtime_error("cantilever " + b.label + " did not converge: " + message);
    return value[0];
  }

  // Each run's error at `params`, by the fit objective's measure (each force run with its
  // profiled scale under repeats.scale: per-run): what error_with is measured by.
  static std::vector<double> errors_at(const FitContext& context, const MaterialParameters& params,
                         const std::vector<std::string>& free, const ParameterMap::Options& map_options,
                         const std::vector<std::shared_ptr<Predictor>>& predictors,
                         const std::vector<const RunData*>& force_runs,
                         std::vector<Eigen::VectorXd>* predictions = nullptr) {
    ParameterMap map(params, free, map_options);
    FitObjective objective(map, predictors);
    objective.set_scale_groups(context.scale_groups(force_runs, predictors.size()));
    objective.evaluate(map.initial_x(), nullptr);
    if (predictions) *predictions = objective.last_predictions();
    return run_errors(objective, predictors.size());
  }

  // The fit runs' mean error at their nominal angles with the curves as fitted so far — not the
  // offset search's misfit, whose scale is the run's own unconstrained best one and would
  // flatter the nominal model.
  static std::vector<double> errors_at_nominal_angles(FitContext& context, const std::vector<const RunData*>& runs,
                                                      int level) {
    const auto experiments = context.tensile_experiments(runs, level, context.params);
    const std::vector<std::shared_ptr<Predictor>> predictors(experiments.begin(), experiments.end());
    std::vector<std::string> curves;  // evaluated at their values, not fitted
    append_curve_parameters(context, &curves);
    return errors_at(context, context.params, curves, {}, predictors, runs);
  }

  // Each run's error at `params` with each force run (the first `force_runs` predictors) at its
  // own best scale s = argmin Σ|s p̂ − p̆| (the error's own measure, a weighted median; robust to
  // the near-zero forces at the end of an unloading branch, where p̂/p̆ is not) — no gauge: the
  // specimens of an evaluation are not those the parameters were fitted on, so their mean scale
  // is theirs to have (with the gauge a fold of lighter specimens would read as a stiffness
  // error of the law).
  std::vector<double> free_scale_errors(const MaterialParameters& params, const std::vector<std::string>& free,
                                        const ParameterMap::Options& map_options,
                                        const std::vector<std::shared_ptr<Predictor>>& predictors,
                                        size_t force_runs) const {
    ParameterMap map(params, free, map_options);
    FitObjective objective(map, predictors);
    if (!std::isfinite(objective.evaluate(map.initial_x(), nullptr)))
      throw std::runtime_error("effect-fit " + options_.effect + ": the runs could not be evaluated: " +
                               objective.last_failure());
    std::vector<double> errors;
    for (size_t i = 0; i < predictors.size(); ++i) {
      const Eigen::VectorXd& p = objective.last_predictions()[i];
      const Eigen::VectorXd& m = predictors[i]->measured();
      const double s = i < force_runs ? linearised_l1_minimiser(Eigen::VectorXd::Zero(p.size()), p, m) : 1.0;
      errors.push_back((s * p - m).cwiseAbs().sum() / m.cwiseAbs().sum());
    }
    return errors;
  }

  // Each run's error with the effect at its neutral values (the schema defaults).
  static std::vector<double> errors_at_neutral(const FitContext& context, const ComponentChoice& configured,
                                 const std::vector<std::string>& free, const ParameterMap::Options& map_options,
                                 const std::vector<std::shared_ptr<Predictor>>& predictors,
                                 const std::vector<const RunData*>& force_runs,
                                 std::vector<Eigen::VectorXd>* predictions = nullptr) {
    return errors_at(context, neutral_params(context, configured), free, map_options, predictors, force_runs,
                     predictions);
  }
};

}  // namespace

void register_effect_fit_stage(FitStageFactories& stages) {
  stages.add_bound<EffectFit>("effect-fit",
                              "one configured effect's parameters fitted to the fit runs (inactive when the config's "
                              "effects do not name it), with the error without and with it",
                              effect_fit_bindings());
}

}  // namespace twill
