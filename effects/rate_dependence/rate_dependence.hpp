#pragma once
// The rate-dependence effect: viscoelastic overstress, so that a strip pulled faster carries
// more force (paper §4: the tests ran at 300 and 200 mm/min and the paper could not say
// whether that matters). Derivation: docs/effects/rate-dependence.md.
//
// Model: one Maxwell branch (a spring in series with a dashpot) in parallel with the elastic
// strip, per deformation mode m, on the strip path of effects/strip_path.hpp. The branch's
// spring is a fraction β of the mode's small-strain membrane stiffness M_m = τ (a11, a22,
// 2 G12) (∂²ψ/∂e_m² at e = 0, model.md §2), its relaxation time t_r:
//
//   dσ_m/dt = β M_m de_m/dt − σ_m / t_r.
//
// With e_m = c_m ε the overstress is σ_m = β M_m c_m ψ, ψ the unit response on ε's path,
// exact for strain linear in time over each segment (rate r = Δε/Δt, E = exp(−Δt/t_r)):
//
//   ψ ← ψ E + r t_r (1 − E),        F_v = W β ψ Σ_m M_m c_m².
//
// Model parameters (params.yaml `effects: {rate-dependence: {...}}`):
//   viscous_ratio ∈ [0, kMaxViscousRatio], β: 0 (neutral, the default) is the paper's
//     elastic model exactly;
//   relaxation_s ∈ [kMinRelaxation_s, kMaxRelaxation_s], t_r (default 10 s, the order of a
//     strip test's duration at 300 mm/min).
// Hook: the observables (clamp force += F_v), derivatives exact in β, t_r, τ, a11, a22, G12
// and θ. Needs the run's clock (strip_path.hpp); data: tensile tests at two or more speeds.
#include "core/option_binding.hpp"
#include "effects/effect.hpp"

namespace twill {

struct RateDependenceOptions {
  double viscous_ratio = 0.0;
  double relaxation_s = 10.0;
  bool validate(std::string* error) const;
};
OptionBindings<RateDependenceOptions> rate_dependence_bindings();

class RateDependence final : public Effect {
 public:
  static constexpr const char* kName = "rate-dependence";
  /// β ≤ 10: a branch ten times the elastic stiffness, far above the few tens of % woven
  /// fabrics show between quasi-static and test speeds.
  static constexpr double kMaxViscousRatio = 10.0;
  /// 0.01 s … 1e4 s: from a hundredth of a second (no effect at test speeds) to about three
  /// hours (relaxed only in a creep test).
  static constexpr double kMinRelaxation_s = 1e-2, kMaxRelaxation_s = 1e4;
  /// Two speeds differ when they differ by more than this fraction (a tester's speed is set
  /// to better than 1 %; ASTM D5035 allows ±3 %).
  static constexpr double kDistinctSpeeds = 0.05;

  explicit RateDependence(const RateDependenceOptions& options);

  std::string missing_data(const Dataset& dataset) const override;
  /// Confirmed by predicting the tests at one speed from a fit to the others.
  HeldOut held_out() const override { return HeldOut::speeds; }
  bool changes_observables() const override { return true; }
  ObservableChange observable_change(const RunConditions& run, const MaterialParameters& k) const override;

 private:
  RateDependenceOptions options_;
};

/// The crosshead speed of a run [mm/min]: its test's rate_mm_min, or the run's extension
/// range over its time range when it has time_s; 0 when neither says.
double run_speed_mm_min(const TensileTest& test, const TensileRun& run);

}  // namespace twill
