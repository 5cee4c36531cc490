#pragma once
// The misalignment effect: each strip is cut at a slightly other angle than its nominal one
// (paper §7: "we allowed a small angle offset Δθ per validation run", which absorbs the
// cutting error of an off-axis strip), with the offsets of a fabric's strips spread around
// zero with a shared spread.
//
// Model parameter (params.yaml `effects: {misalignment: {spread_deg: s}}`):
//   spread_deg ∈ [0, kMaxOffsetDeg]: the root mean square of the strips' offsets; a simulator
//   drawing strips of this fabric draws their offsets from N(0, s²).
// Per-run parameter: offset_deg ∈ [−kMaxOffsetDeg, kMaxOffsetDeg], default 0: the angle
//   offset Δθ of that run's strip.
// Hook: the experiment's set-up, θ ← θ0 + Δθ, so d(angle_deg)/d(offset_deg) = 1 and the
//   observables' derivative in Δθ is the experiment's dF/dθ (Eq. 6, tensile_strip.hpp).
// Data: repeats at some tensile angle (a spread needs at least two strips cut alike).
// Estimate from runs: spread = √(mean Δθ²) over the runs' fitted offsets (which runs:
//   fitting/fit_effects.cpp, docs/effects/misalignment.md "Which offsets the spread is
//   estimated from").
#include "core/option_binding.hpp"
#include "effects/effect.hpp"

namespace twill {

/// The model parameters (the registered options, declared once in misalignment_bindings()).
struct MisalignmentOptions {
  double spread_deg = 0.0;
  bool validate(std::string* error) const;
};
OptionBindings<MisalignmentOptions> misalignment_bindings();

class Misalignment final : public Effect {
 public:
  /// The largest offset a cut can plausibly have: 10°, the range of the fit's validation
  /// offset search (fitting's validation.max_offset_deg default), far above a careful cut's
  /// 1–2° and below the 22.5° between the tested angles.
  static constexpr double kMaxOffsetDeg = 10.0;
  static constexpr const char* kName = "misalignment";

  /// Throws InputError naming the option when `options` violates its bounds.
  explicit Misalignment(const MisalignmentOptions& options);
  /// The registered schema (the model parameters).
  static OptionSchema schema() { return option_schema(misalignment_bindings()); }

  double spread_deg() const { return spread_deg_; }
  std::string missing_data(const Dataset& dataset) const override;
  std::vector<EffectParameter> per_run_parameters() const override;
  Options estimated_from_runs(const std::vector<Eigen::VectorXd>& run_values, const Options& model) const override;
  std::vector<SetupChange> adjust_setup(const Eigen::VectorXd& run_values, ExperimentInput* input) const override;

 private:
  double spread_deg_;
};

}  // namespace twill
