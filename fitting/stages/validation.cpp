// Stage `validation` (paper §7): the angle offset Δθ of each validation run, at the finest
// level any stage reached (the off-axis discretisation error of coarse levels is larger than
// the offsets themselves, measured: a search at 8×12 picked +1° where the finest level's
// optimum is near 0°). A 1-D Newton search on the run's error e(Δθ) = Σ|F(θ0 + Δθ) − F̆| / Σ|F̆|
// with the exact dF/dθ (Eq. 6, TensileExperiment::set_angle_sensitivity) at the nominal angle
// and the secant through the last two samples after that: at the current offset the forces
// are linear in the step t, F + t F', and the step minimises Σ|F + t F' − F̆| exactly (a
// weighted median, linearised_l1_minimiser); it is clamped to ±max_offset_deg, rounded to
// offset_resolution_deg, and taken while it moves the offset by at least that resolution, at
// most offset_iterations times. The best evaluated offset wins (Δθ = 0 is always evaluated).
// Strips are turned through the angle-offset effect's set-up hook (fitting/fit_effects.hpp).
// Runs of one test share their simulations (StripCurves): the nominal angle costs one curve
// per test, each later step one per distinct offset, warm-started from the nominal strip's
// q + Δθ dq/dθ.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/option_binding.hpp"
#include "effects/misalignment.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_effects.hpp"
#include "fitting/fit_stage.hpp"
#include "fitting/stages/stage_kinds.hpp"
#include "fitting/strip_curves.hpp"

namespace twill {
namespace {

struct ValidationOptions {
  double max_offset_deg = Misalignment::kMaxOffsetDeg;
  int offset_iterations = 3;
  double offset_resolution_deg = 0.05;
  bool validate(std::string* error) const;
};

OptionBindings<ValidationOptions> validation_bindings() {
  using S = ValidationOptions;
  return {
      // The offset is the misalignment effect's per-run parameter (effects/misalignment.hpp),
      // so its bound is the effect's.
      real_option<S>("max_offset_deg", &S::max_offset_deg, "search the angle offset in [-this, this]",
                     in_range(0.0, Misalignment::kMaxOffsetDeg)),
      // Three steps: the error is nearly piecewise linear in the offset near its minimum, so
      // the first linearised step lands within the resolution on the example fits and a second
      // one confirms it; the third is a margin for strongly nonlinear curves.
      integer_option<S>("offset_iterations", &S::offset_iterations,
                        "Newton steps of the offset search (dF/dtheta exact; 0: no offset)", in_range(0, 10)),
      real_option<S>("offset_resolution_deg", &S::offset_resolution_deg,
                     "offsets are rounded to this grid and the search stops at a step below it "
                     "(runs sharing an offset share a simulation; 0: exact)",
                     at_least(0.0)),
  };
}

bool ValidationOptions::validate(std::string* error) const {
  return check_options(validation_bindings(), *this, error);
}

class Validation final : public FitStage {
 public:
  explicit Validation(ValidationOptions options) : options_(options) {}
  std::string title() const override { return "validation"; }

  void run(FitContext& context, FitReport& out) override {
    offset_effect_ = angle_offset_effect(context);
    samples_.assign(context.validation_runs.size(), {});
    search_offsets(context);
    for (size_t i = 0; i < context.validation_runs.size(); ++i) report_run(context, i, out);
  }

 private:
  struct Sample {
    double offset, error;
    StripCurves::Simulated simulated;
  };

  double offset_angle(double nominal_deg, double offset_deg) const {
    ExperimentInput input;
    input.angle_deg = nominal_deg;
    offset_effect_->adjust_setup(Eigen::VectorXd::Constant(1, offset_deg), &input);
    return input.angle_deg;
  }

  /// Simulates (run, offset) pairs; the exact dF/dθ only where asked for (the nominal angle).
  void sample(const FitContext& context, const std::vector<std::pair<size_t, double>>& wanted, bool angle_derivative) {
    std::vector<StripCurves::Request> requests;
    for (const auto& [i, offset] : wanted)
      requests.push_back(
          {&context.validation_runs[i], offset_angle(context.validation_runs[i].test->angle_deg, offset)});
    const auto simulated = curves_.simulate(context, requests, context.finest_level, angle_derivative);
    for (size_t r = 0; r < wanted.size(); ++r) {
      if (!simulated[r]) continue;
      const RunData& d = context.validation_runs[wanted[r].first];
      samples_[wanted[r].first].push_back(
          {wanted[r].second, (simulated[r]->force_N - d.force_N).cwiseAbs().sum() / d.force_N.cwiseAbs().sum(),
           *simulated[r]});
    }
  }

  // dF/dθ at the last sample: exact (Eq. 6) at the nominal angle, then the secant through the
  // run's last two samples (offsets are fractions of a degree, so the secant is as good a
  // slope as the tangent and needs no turned meshes); samples closer than kSecantMinimumDeg
  // keep the nominal slope (forces are converged to ~1e-8 of themselves, so a closer secant
  // would be mostly solver tolerance).
  static constexpr double kSecantMinimumDeg = 0.01;
  static Eigen::VectorXd slope(const std::vector<Sample>& run) {
    const Sample& last = run.back();
    if (run.size() < 2) return last.simulated.dforce_dangle;
    const Sample& before = run[run.size() - 2];
    if (std::abs(last.offset - before.offset) < kSecantMinimumDeg) return run.front().simulated.dforce_dangle;
    return (last.simulated.force_N - before.simulated.force_N) / (last.offset - before.offset);
  }

  void search_offsets(const FitContext& context) {
    const double grid = options_.offset_resolution_deg;
    std::vector<std::pair<size_t, double>> wanted;
    for (size_t i = 0; i < context.validation_runs.size(); ++i) wanted.emplace_back(i, 0.0);
    for (int iteration = 0; !wanted.empty(); ++iteration) {
      sample(context, wanted, iteration == 0);
      wanted.clear();
      if (iteration == options_.offset_iterations) break;
      for (size_t i = 0; i < context.validation_runs.size(); ++i) {
        if (samples_[i].empty()) continue;
        const Sample& last = samples_[i].back();
        const double step =
            linearised_l1_minimiser(last.simulated.force_N, slope(samples_[i]), context.validation_runs[i].force_N);
        double next = std::clamp(last.offset + step, -options_.max_offset_deg, options_.max_offset_deg);
        if (grid > 0) next = grid * std::round(next / grid);
        const bool seen = std::any_of(samples_[i].begin(), samples_[i].end(), [&](const Sample& s) {
          return std::abs(s.offset - next) < 0.5 * std::max(grid, 1e-9);
        });
        if (!seen) wanted.emplace_back(i, next);
      }
    }
  }

  void report_run(FitContext& context, size_t i, FitReport& out) const {
    const RunData& d = context.validation_runs[i];
    const std::vector<Sample>& samples = samples_[i];
    const auto nominal =
        std::find_if(samples.begin(), samples.end(), [](const Sample& s) { return s.offset == 0.0; });
    if (nominal == samples.end()) {
      context.note("validation " + FitContext::run_label(d) + " did not converge at the nominal angle");
      return;
    }
    const Sample& best = *std::min_element(samples.begin(), samples.end(),
                                           [](const Sample& a, const Sample& b) { return a.error < b.error; });
    FitCurve c = FitContext::curve_record(d, "validation", best.simulated.force_N);
    c.delta_theta_deg = best.offset;
    c.avg_rel_error_without_offset = nominal->error;
    out.validation.push_back(c);
    context.say(0, fmt::format("validation {}: offset {:+.2f} deg, error {:.2f} % (without offset {:.2f} %, {} "
                               "evaluations)",
                               FitContext::run_label(d), best.offset, 100 * c.avg_rel_error,
                               100 * c.avg_rel_error_without_offset, samples.size()));
  }

  ValidationOptions options_;
  std::shared_ptr<const Effect> offset_effect_;
  StripCurves curves_;
  std::vector<std::vector<Sample>> samples_;
};

}  // namespace

void register_validation_stage(FitStageFactories& stages) {
  stages.add_bound<Validation>("validation", "paper §7: the validation strips with their angle offsets",
                               validation_bindings());
}

}  // namespace twill
