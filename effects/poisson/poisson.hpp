#pragma once
// The poisson effect: the coupling stiffness a12 free, identified from lateral strain (paper
// §5.2: "a12 cannot be identified from the standard tests", so the paper fixes
// a12 = ½ min(a11, a22); a video extensometer or DIC measuring the strip's narrowing can).
// Derivation: docs/effects/poisson.md.
//
// Model parameters (params.yaml `effects: {poisson: {coupling_ratio: r, coupling_curvature: c}}`):
//   coupling_ratio ∈ [−kMaxCouplingRatio, kMaxCouplingRatio], r:
//     a12 = r · min(a11, a22);
//   r = ½ (the neutral value, the default) is the paper's tie exactly.
//   coupling_curvature ∈ [kMinCouplingCurvature, kMaxCouplingCurvature], c = η2''(0):
//     η2(x) = ((1 + x)^(1+c) − 1)/(1 + c), degree 1 with α = 1 + c;
//   c = 0 (neutral, the default) is the paper's η2(x) = x exactly (Curve::linear()).
//   Why one number and not η2's degree: where a strip's lateral contraction puts one strain
//   below its compression cutoff 0, the law's coupling is its Taylor polynomial about u = 0,
//   in which η2 enters through η2'(0) = 1 and η2''(0) alone (core/material_law.hpp, test
//   MaterialLaw.BelowTheCompressionCutoffTheCouplingSeesOnlyItsCurvatureAtZero);
//   docs/effects/poisson.md.
// Hook: the law (a12 ← r min(a11, a22); η2 ← the curve above), with ∂a12/∂r = min(a11, a22),
// ∂a12/∂a11 or ∂a12/∂a22 = r on the smaller one (a11 at a tie, as ParameterMap's tie) and
// ∂(η2's α)/∂c = 1. The a12 and η2 written in params.yaml are replaced while the effect is on;
// the material's η2 must have degree 1 (the hook keeps the flat layout).
// Data: lateral_strain columns in some tensile run.
#include "core/option_binding.hpp"
#include "effects/effect.hpp"

namespace twill {

struct PoissonOptions {
  double coupling_ratio = 0.5;
  double coupling_curvature = 0.0;
  bool validate(std::string* error) const;
};
OptionBindings<PoissonOptions> poisson_bindings();

class Poisson final : public Effect {
 public:
  static constexpr const char* kName = "poisson";
  /// |r| ≤ 0.9 keeps a12² ≤ 0.81 min(a11, a22)² < a11 a22: the small-strain law stays
  /// positive definite (model.md §2) for every a11, a22.
  static constexpr double kMaxCouplingRatio = 0.9;
  /// c ≥ −10 keeps a warp strip's lateral stiffness ∂²ψ/∂Ẽ22² = a22 + a12 c Ẽ11² (Ẽ22 below its
  /// cutoff) positive up to Ẽ11 = 0.3, beyond a D5035 strip's strains (canvas: 0.17), at
  /// |r| ≤ kMaxCouplingRatio (a12 ≤ 0.9 a22): 1 − 0.9 · 10 · 0.09 = 0.19 > 0; likewise weft.
  static constexpr double kMinCouplingCurvature = -10.0;
  /// c ≤ 200: above the curvature η''(0) = Σ μ(α − 1) of every curve fitted to the reference
  /// fabrics (canvas: η1 53, η4 ~100), a coupling stiffening as fast as the yarns do.
  static constexpr double kMaxCouplingCurvature = 200.0;

  explicit Poisson(const PoissonOptions& options);

  std::string missing_data(const Dataset& dataset) const override;
  MaterialParameters adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const override;

 private:
  double ratio_;
  double curvature_;
};

}  // namespace twill
