#include "effects/poisson/poisson.hpp"

#include <stdexcept>
#include <string>

namespace twill {

OptionBindings<PoissonOptions> poisson_bindings() {
  return {real_option<PoissonOptions>("coupling_ratio", &PoissonOptions::coupling_ratio,
                                      "a12 / min(a11, a22); the paper's tie is 0.5",
                                      in_range(-Poisson::kMaxCouplingRatio, Poisson::kMaxCouplingRatio)),
          real_option<PoissonOptions>("coupling_curvature", &PoissonOptions::coupling_curvature,
                                      "eta2''(0): eta2(x) = ((1+x)^(1+c) - 1)/(1+c); the paper's eta2(x) = x is 0",
                                      in_range(Poisson::kMinCouplingCurvature, Poisson::kMaxCouplingCurvature))};
}

bool PoissonOptions::validate(std::string* error) const { return check_options(poisson_bindings(), *this, error); }

Poisson::Poisson(const PoissonOptions& options)
    : ratio_(options.coupling_ratio), curvature_(options.coupling_curvature) {
  require_valid(options, kName);
}

std::string Poisson::missing_data(const Dataset& dataset) const {
  if (any_tensile_run(dataset, [](const TensileTest&, const TensileRun& run) { return run.has_lateral_strain(); }))
    return "";
  return "needs lateral strain: a lateral_strain column in some tensile run (video extensometer or DIC)";
}

MaterialParameters Poisson::adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const {
  if (k.eta2.degree() != 1)
    throw std::invalid_argument(std::string("effect ") + kName + " sets eta2 (degree 1, alpha = 1 + coupling_curvature) "
                                "but the material's eta2 has degree " + std::to_string(k.eta2.degree()) +
                                ": give eta2 in params.yaml or the effect, not both");
  MaterialParameters adjusted = k;
  const bool warp_smaller = k.a11_Pa <= k.a22_Pa;
  adjusted.a12_Pa = ratio_ * (warp_smaller ? k.a11_Pa : k.a22_Pa);
  adjusted.eta2 = Curve{{1.0}, {1.0 + curvature_}};  // c = 0: Curve::linear(), the paper's η2 exactly
  if (jacobian) {
    const int n = k.flat_size();
    *jacobian = Eigen::MatrixXd::Identity(n, n);
    jacobian->row(FlatLayout::kA12).setZero();
    (*jacobian)(FlatLayout::kA12, warp_smaller ? FlatLayout::kA11 : FlatLayout::kA22) = ratio_;
    (*jacobian)(FlatLayout::kA12, effect_flat_index(k, kName, "coupling_ratio")) = warp_smaller ? k.a11_Pa : k.a22_Pa;
    const int alpha = FlatLayout::alpha_offset(FlatLayout(k).eta2, 1);
    jacobian->row(alpha).setZero();
    (*jacobian)(alpha, effect_flat_index(k, kName, "coupling_curvature")) = 1.0;
  }
  return adjusted;
}

}  // namespace twill
