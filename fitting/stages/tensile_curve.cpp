// Stage `tensile-curve` (paper §5.2 steps 2, 3 and 5 with §5.4): one term of ψ — its
// stiffness and curve (`term`) — fitted to the fit runs at `angle_deg` at the coarsest level
// (`level` 0; a finer one for studies),
// raising the curve's degree from 1 while the average relative error is above `target_error`
// and the last raise improved it by at least `min_improvement`, up to `max_degree`. Later
// stages refer to it by `label` (strain-cutoff; resolution-ladder refits it at every level).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include <tbb/parallel_for.h>

#include "core/option_binding.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"

namespace twill {
namespace {

struct TensileCurveOptions {
  std::string label = "warp";
  double angle_deg = 90.0;
  std::string term = "eta1";
  int max_degree = 3;
  double target_error = 0.01;
  double min_improvement = 0.2;
  int raise_attempts = 3;
  bool uniform_starts = true;
  int level = 0;
  bool fit = true;
  bool validate(std::string* error) const;
};

std::vector<std::string> term_names() {
  std::vector<std::string> names;
  for (const MembraneTerm& t : membrane_terms()) names.push_back(t.curve);
  return names;
}

OptionBindings<TensileCurveOptions> tensile_curve_bindings() {
  using S = TensileCurveOptions;
  return {
      text_option<S>("label", &S::label, "the stage's name in the report and in later stages' references"),
      real_option<S>("angle_deg", &S::angle_deg, "the fit tests it fits: those at this angle", in_range(-180.0, 180.0)),
      choice_option<S>("term", &S::term, term_names(),
                       "the term of psi it fits; free: its stiffness and curve (eta1: a11_Pa, eta1.*; eta3: a22_Pa, "
                       "eta3.*; eta4: G12_Pa, eta4.*)"),
      integer_option<S>("max_degree", &S::max_degree, "highest curve degree (paper §5.4)", in_range(1, kMaxCurveDegree)),
      real_option<S>("target_error", &S::target_error, "stop raising the degree below this average relative error",
                     greater_than(0.0)),
      real_option<S>("min_improvement", &S::min_improvement,
                     "stop raising when a raise improved the error by less than this fraction", in_range(0.0, 1.0)),
      integer_option<S>("raise_attempts", &S::raise_attempts,
                        "starts tried per raise (best-scored first) before it counts as not improving",
                        in_range(1, 6)),
      bool_option<S>("uniform_starts", &S::uniform_starts,
                     "refit each raise's start curve on the uniform-strain model (false: the plain starts)"),
      // The paper chooses degrees at the coarsest level (§5.5.4); a finer one lets a study ask
      // whether the coarse mesh's off-axis error steers the choice (issue #12).
      integer_option<S>("level", &S::level, "the resolution level of the degree search (0: the coarsest)",
                        in_range(0, 4)),
      // `twill discover` fits each candidate effect from the baseline's parameters: start-from,
      // then these stages with fit: false (so the effect-fit stages free the curves), then the
      // effect-fit stages; the elastic fit is not repeated per candidate.
      bool_option<S>("fit", &S::fit,
                     "false: take the curve as the current parameters hold it (after start-from): later stages see it "
                     "as fitted, nothing is optimised"),
  };
}

bool TensileCurveOptions::validate(std::string* error) const {
  return check_options(tensile_curve_bindings(), *this, error);
}

// The raise of §5.4: one more term with a small weight, so the curve starts near where the
// lower degree ended; the new exponent is chosen by raised_starts().
void add_term(Curve* c, double alpha) {
  const double weight = 0.05;
  c->mu[0] -= weight;
  c->mu.push_back(weight);
  c->alpha.push_back(alpha);
}

class TensileCurveStage final : public FitStage {
 public:
  explicit TensileCurveStage(TensileCurveOptions options)
      : options_(std::move(options)), stage_{options_.label, options_.angle_deg, &membrane_term(options_.term)} {}

  std::string title() const override {
    return options_.label + (options_.level == 0 ? " (degree, coarsest level)"
                                                 : " (degree, level " + std::to_string(options_.level) + ")");
  }

  void check(const ProtocolCheck& check) const override {
    if (options_.level >= check.levels)
      throw InputError(check.locate(check.key + ".level"),
                       "level " + std::to_string(options_.level) + " is not one of the " + std::to_string(check.levels) +
                           " resolution levels (resolution.levels)");
  }
  const CurveStage* curve_stage() const override { return &stage_; }

  void run(FitContext& context, FitReport& out) override {
    (void)out;  // its records and notes go through the context
    if (context.runs_for(stage_.angle_deg).empty()) {
      context.note("no " + stage_.label + " test: stage skipped, its parameters stay at the initial guess");
      return;
    }
    if (options_.fit)
      choose_degree(context);
    else
      context.note(stage_.label + ": curve taken as the parameters hold it (fit: false)");
    context.fitted_curves.push_back(stage_);
  }

 private:
  Curve& curve_of(MaterialParameters& p) const { return p.*(stage_.term->curve_member); }
  const Curve& curve_of(const MaterialParameters& p) const { return p.*(stage_.term->curve_member); }

  // §5.4: degree 1 first; raise while the error is above the target. A raise is tried from up
  // to raise_attempts of the best-scored starts, and accepted at the first that improves the
  // error by min_improvement; if none does, the best of them is kept when it is better by at
  // least kNegligibleImprovement, and raising stops.
  //
  // Why not "better at all": a raise that buys nothing can end with its new term at a
  // vanishing weight on a stiff exponent (measured: μ = −3.2e-8 at α = 547, 0.00 % better, on
  // a generated dataset, papers/hidden_effects/README.md), which the later fresh continuations
  // of the strain-cutoff stage could not solve at the largest extension: the fit failed over
  // a term the data never asked for.
  static constexpr double kNegligibleImprovement = 1e-3;
  void choose_degree(FitContext& context) const {
    const double target = options_.target_error;
    const double min_improvement = options_.min_improvement;
    // An attempt ends the search only if its raise would be kept: at min_improvement 0 an
    // attempt that slid back onto the lower degree (α_new = α_old, 0.00 % better) ended it
    // before, and the raise was then not kept — the other starts never tried (Ipopt's and
    // NLopt's canvas bias at degree 2 in papers/optimizers: 4.24 % where BFGS reached 0.5 %).
    const double accept_at = std::max(min_improvement, kNegligibleImprovement);
    const size_t attempts = static_cast<size_t>(options_.raise_attempts);
    MaterialParameters best = context.params;
    FitContext::CurveFit best_result = context.fit_curve(stage_, options_.level, &best);
    if (!best_result.ok) throw std::runtime_error("stage " + stage_.label + ": degree 1 fit failed");
    while (curve_of(best).degree() < options_.max_degree && best_result.error > target) {
      const std::vector<MaterialParameters> starts = raised_starts(context, best);
      const int degree = curve_of(best).degree() + 1;
      MaterialParameters raised;
      FitContext::CurveFit raised_result;
      for (size_t a = 0; a < std::min(attempts, starts.size()); ++a) {
        MaterialParameters trial = starts[a];
        context.say(0, fmt::format("{}: degree {} attempt {} starts with alpha_new = {:.3g}", stage_.label, degree,
                                   a + 1, curve_of(trial).alpha.back()));
        const FitContext::CurveFit r = context.fit_curve(stage_, options_.level, &trial, FitContext::CurveStart::raise);
        if (r.ok && (!raised_result.ok || r.error < raised_result.error)) {
          raised = trial;
          raised_result = r;
        }
        if (raised_result.ok && 1.0 - raised_result.error / best_result.error >= accept_at) break;
        if (a + 1 < std::min(attempts, starts.size()))
          context.note(fmt::format("{}: degree {} attempt {} improved the error by less than {:.1f} %: next start",
                                   stage_.label, degree, a + 1, 100 * accept_at));
      }
      if (!raised_result.ok) break;
      const double improvement = 1.0 - raised_result.error / best_result.error;
      if (improvement < kNegligibleImprovement) {
        // Not kept, so the next pass would try the same raise from the same curve: stop here
        // whatever min_improvement says (at min_improvement 0 this looped for ever).
        context.note(fmt::format("{}: degree {} improved the error by {:.3f} % only: not kept, stop", stage_.label,
                                 degree, 100 * improvement));
        break;
      }
      best = raised;
      best_result = raised_result;
      if (improvement < min_improvement) {
        context.note(fmt::format("{}: raising to degree {} improved the error by {:.0f} % (< {:.0f} %): stop",
                                 stage_.label, degree, 100 * improvement, 100 * min_improvement));
        break;
      }
    }
    const std::string where = options_.level == 0 ? "the coarsest level" : "level " + std::to_string(options_.level);
    context.note(fmt::format("{}: degree {} chosen (error {:.2f} % at {}, target {:.1f} %)", stage_.label,
                             curve_of(best).degree(), 100 * best_result.error, where, 100 * target));
    context.params = best;
    context.keep_scales(context.runs_for(stage_.angle_deg), best_result.scales);
  }

  /// Candidate exponents of the raised term (§5.4); the plain start's is max(4 α_max, 8).
  static constexpr double kCandidateAlphas[] = {2.0, 10.0, 40.0, 150.0, 500.0};
  /// Two starts are one when their new exponents agree to this (relative) and their scores to
  /// kSameScore: the uniform-strain refits of several candidates often converge to one curve,
  /// each to its optimiser's tolerance (measured: α_new 155.0155 and 154.9744, scores 0.23977
  /// and 0.23992; −1731.8 and −1733.8, 0.264566 and 0.264571), while distinct starts differ by
  /// percents (158.41 at 0.23174 beside them).
  static constexpr double kSameAlpha = 1e-2;
  static constexpr double kSameScore = 1e-3;

  // Starts of a degree raise (§5.4): candidates for the new exponent α_new, each with the curve
  // refitted on the cheap uniform-strain model (§5.3, curve entries only), then scored by one
  // full evaluation at the coarsest level; best (lowest ε) first, each start once. One candidate
  // keeps the plain start (new term added, nothing refitted), so the best start is never worse
  // than it.
  // Several starts, because a raise has a whole line of stationary points (α_new = α_old, where
  // the two terms merge and the weights split freely): an optimiser that slides onto it ends
  // at the lower degree's error (measured: Ipopt on the canvas bias, 6.65 % before and after).
  // Each start once, because a repeated one spends an attempt on a curve already tried: a null
  // twin's weft (papers/discovery, session 36) had starts 158, 155, 155, −1.73e3, …; the two
  // 155s slid back to degree 2 (1.35 %) and the search stopped, where −1.73e3 reaches 0.45 %.
  std::vector<MaterialParameters> raised_starts(const FitContext& context, const MaterialParameters& best) const {
    std::vector<MaterialParameters> candidates = {plain_start(best)};
    for (double alpha : kCandidateAlphas)
      if (std::optional<MaterialParameters> start = candidate_start(context, best, alpha))
        candidates.push_back(std::move(*start));
    return distinct_best_first(context, score_starts(context, std::move(candidates)), curve_of(best).degree() + 1);
  }

  // The stage's curve entries (its term's μ and α), what a start's refit and score free.
  std::vector<std::string> curve_entries() const { return {stage_.term->curve + ".*"}; }

  MaterialParameters plain_start(const MaterialParameters& best) const {
    const Curve& c = curve_of(best);
    const double alpha_max = std::abs(*std::max_element(c.alpha.begin(), c.alpha.end(),
                                                        [](double a, double b) { return std::abs(a) < std::abs(b); }));
    MaterialParameters plain = best;
    add_term(&curve_of(plain), std::max(4.0 * alpha_max, 8.0));
    return plain;
  }

  // The raised curve with exponent `alpha`, refitted on the uniform-strain model
  // (uniform_starts); nullopt when the refit leaves parameters the law rejects.
  std::optional<MaterialParameters> candidate_start(const FitContext& context, const MaterialParameters& best,
                                                    double alpha) const {
    MaterialParameters trial = best;
    add_term(&curve_of(trial), alpha);
    if (!options_.uniform_starts) return trial;
    std::vector<std::shared_ptr<Predictor>> uniform;
    for (const RunData* d : context.runs_for(stage_.angle_deg)) uniform.push_back(context.uniform_strain_predictor(*d));
    ParameterMap map(trial, curve_entries());
    FitObjective objective(map, uniform);
    const OptimizerResult r =
        context.make_optimizer(context.config().uniform_strain_optimizer)->minimize(objective, map.initial_x());
    if (!std::isfinite(r.summary.final_value)) return trial;
    try {
      return map.parameters(r.x);
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }

  // One full evaluation of each start, from the flat strip: independent, so in parallel, each
  // with its own predictors; sorted best first (a failed evaluation scores +inf).
  std::vector<std::pair<double, MaterialParameters>> score_starts(const FitContext& context,
                                                                  std::vector<MaterialParameters> candidates) const {
    const auto runs = context.runs_for(stage_.angle_deg);
    std::vector<std::pair<double, MaterialParameters>> scored(candidates.size());
    tbb::parallel_for(size_t{0}, candidates.size(), [&](size_t i) {
      const auto experiments = context.tensile_experiments(runs, options_.level, candidates[i]);
      const std::vector<std::shared_ptr<Predictor>> full(experiments.begin(), experiments.end());
      ParameterMap map(candidates[i], curve_entries());
      FitObjective objective(map, full);
      objective.set_scale_groups(context.scale_groups(runs, full.size()));
      const double value = objective.evaluate(map.initial_x(), nullptr);
      scored[i] = {std::isfinite(value) ? value : std::numeric_limits<double>::infinity(), std::move(candidates[i])};
    });
    std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    return scored;
  }

  // The scored starts that evaluated, each once (kSameAlpha, kSameScore), best first; listed on
  // the progress.
  std::vector<MaterialParameters> distinct_best_first(const FitContext& context,
                                                      const std::vector<std::pair<double, MaterialParameters>>& scored,
                                                      int degree) const {
    std::vector<const std::pair<double, MaterialParameters>*> kept;
    std::string listed;
    size_t repeated = 0;
    const auto same = [&](const std::pair<double, MaterialParameters>& a, const std::pair<double, MaterialParameters>& b) {
      const double alpha = curve_of(b.second).alpha.back();
      return std::abs(curve_of(a.second).alpha.back() - alpha) <= kSameAlpha * std::abs(alpha) &&
             std::abs(a.first - b.first) <= kSameScore * std::abs(b.first);
    };
    for (const auto& start : scored) {
      if (!std::isfinite(start.first)) continue;
      if (std::any_of(kept.begin(), kept.end(), [&](const auto* k) { return same(*k, start); })) {
        ++repeated;
        continue;
      }
      kept.push_back(&start);
      listed += fmt::format("{}{:.4g} ({:.4g})", listed.empty() ? "" : ", ", curve_of(start.second).alpha.back(),
                            start.first);
    }
    context.say(0, fmt::format("{}: degree {} starts, best first: alpha_new (score) {}{}", stage_.label, degree, listed,
                               repeated ? fmt::format("; {} repeated start(s) dropped", repeated) : ""));
    std::vector<MaterialParameters> starts;
    for (const auto* k : kept) starts.push_back(k->second);
    return starts;
  }

  TensileCurveOptions options_;
  CurveStage stage_;
};

}  // namespace

void register_tensile_curve_stage(FitStageFactories& stages) {
  stages.add_bound<TensileCurveStage>("tensile-curve",
                                 "paper §5.2/§5.4: one term of psi fitted to the strips at one angle, degree raised",
                                 tensile_curve_bindings());
}

}  // namespace twill
