#pragma once
// The poisson effect: the coupling stiffness a12 free, identified from lateral strain (paper
// §5.2: "a12 cannot be identified from the standard tests", so the paper fixes
// a12 = ½ min(a11, a22); a video extensometer or DIC measuring the strip's narrowing can).
// Derivation: docs/effects/poisson.md.
//
// Model parameter (params.yaml `effects: {poisson: {coupling_ratio: r}}`):
//   coupling_ratio ∈ [−kMaxCouplingRatio, kMaxCouplingRatio], r:
//     a12 = r · min(a11, a22);
//   r = ½ (the neutral value, the default) is the paper's tie exactly.
// Hook: the law (a12 ← r min(a11, a22)), with ∂a12/∂r = min(a11, a22) and ∂a12/∂a11 or
// ∂a12/∂a22 = r on the smaller one (a11 at a tie, as ParameterMap's tie). The a12 written in
// params.yaml is replaced while the effect is on. η2 stays linear (η2's degree free is not
// part of this effect yet: the strips' lateral strains reach only small Ẽ22 off-axis).
// Data: lateral_strain columns in some tensile run.
#include "core/option_binding.hpp"
#include "effects/effect.hpp"

namespace twill {

struct PoissonOptions {
  double coupling_ratio = 0.5;
  bool validate(std::string* error) const;
};
OptionBindings<PoissonOptions> poisson_bindings();

class Poisson final : public Effect {
 public:
  static constexpr const char* kName = "poisson";
  /// |r| ≤ 0.9 keeps a12² ≤ 0.81 min(a11, a22)² < a11 a22: the small-strain law stays
  /// positive definite (model.md §2) for every a11, a22.
  static constexpr double kMaxCouplingRatio = 0.9;

  explicit Poisson(const PoissonOptions& options);

  std::string missing_data(const Dataset& dataset) const override;
  MaterialParameters adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const override;

 private:
  double ratio_;
};

}  // namespace twill
