#pragma once
// The hysteresis effect: internal friction between yarns, so that a strip pulled and let back
// carries less force coming down than going up (paper §2, §8; Miguel et al. 2013 model it
// with a Dahl-type friction per deformation mode). Derivation: docs/effects/hysteresis.md.
//
// Model: a Dahl friction element per deformation mode m (warp, weft, shear) in parallel with
// the elastic strip, on the strip path of effects/strip_path.hpp:
//
//   dσ_m/de_m = (σ_s,m / e_c) (1 − sgn(ė_m) σ_m / σ_s,m)        (Dahl 1968, exponent 1)
//
// so σ_m tends to ±σ_s,m over the strain scale e_c whenever e_m moves; exactly, along a
// segment of the path (s = sgn Δe_m):   σ_m ← s σ_s,m + (σ_m − s σ_s,m) exp(−|Δe_m| / e_c).
//
// Model parameters (params.yaml `effects: {hysteresis: {...}}`), membrane units N/m (friction
// stress × thickness, like τ·a: what a strip test identifies):
//   warp_friction_N_m, weft_friction_N_m, shear_friction_N_m ∈ [0, kMaxFriction_N_m], σ_s,m:
//     the friction each mode saturates at; 0 (the neutral value, the default) is the paper's
//     elastic model exactly;
//   saturation_strain ∈ [kMinSaturationStrain, kMaxSaturationStrain], e_c: the strain over
//     which friction builds up after a reversal (default 0.005).
// Hook: the observables (clamp force += W Σ c_m σ_m, strip_path.hpp), derivatives in every
// parameter and in θ exact (forward-mode differentiation of the segment update above).
// Data: some tensile run with an unloading branch.
#include "core/option_binding.hpp"
#include "effects/effect.hpp"

namespace twill {

struct HysteresisOptions {
  double warp_friction_N_m = 0.0;
  double weft_friction_N_m = 0.0;
  double shear_friction_N_m = 0.0;
  double saturation_strain = 0.005;
  bool validate(std::string* error) const;
};
OptionBindings<HysteresisOptions> hysteresis_bindings();

class Hysteresis final : public Effect {
 public:
  static constexpr const char* kName = "hysteresis";
  /// 1e5 N/m = 100 N per mm of width: the breaking strength of heavy canvas, far above any
  /// friction a strip test shows (a few % of its force).
  static constexpr double kMaxFriction_N_m = 1e5;
  /// 1e-4 … 0.2: from below any tester's resolution of strain to a fifth of the strain range
  /// fabrics are tested over (paper §4: up to ~0.3).
  static constexpr double kMinSaturationStrain = 1e-4, kMaxSaturationStrain = 0.2;

  explicit Hysteresis(const HysteresisOptions& options);

  std::string missing_data(const Dataset& dataset) const override;
  bool changes_observables() const override { return true; }
  ObservableChange observable_change(const RunConditions& run, const MaterialParameters& k) const override;

 private:
  HysteresisOptions options_;
};

}  // namespace twill
