#include "effects/poisson/poisson.hpp"

namespace twill {

OptionBindings<PoissonOptions> poisson_bindings() {
  return {real_option<PoissonOptions>("coupling_ratio", &PoissonOptions::coupling_ratio,
                                      "a12 / min(a11, a22); the paper's tie is 0.5",
                                      in_range(-Poisson::kMaxCouplingRatio, Poisson::kMaxCouplingRatio))};
}

bool PoissonOptions::validate(std::string* error) const { return check_options(poisson_bindings(), *this, error); }

Poisson::Poisson(const PoissonOptions& options) : ratio_(options.coupling_ratio) { require_valid(options, kName); }

std::string Poisson::missing_data(const Dataset& dataset) const {
  if (any_tensile_run(dataset, [](const TensileTest&, const TensileRun& run) { return run.has_lateral_strain(); }))
    return "";
  return "needs lateral strain: a lateral_strain column in some tensile run (video extensometer or DIC)";
}

MaterialParameters Poisson::adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const {
  MaterialParameters adjusted = k;
  const bool warp_smaller = k.a11_Pa <= k.a22_Pa;
  adjusted.a12_Pa = ratio_ * (warp_smaller ? k.a11_Pa : k.a22_Pa);
  if (jacobian) {
    const int n = k.flat_size();
    *jacobian = Eigen::MatrixXd::Identity(n, n);
    jacobian->row(FlatLayout::kA12).setZero();
    (*jacobian)(FlatLayout::kA12, warp_smaller ? FlatLayout::kA11 : FlatLayout::kA22) = ratio_;
    (*jacobian)(FlatLayout::kA12, effect_flat_index(k, kName, "coupling_ratio")) = warp_smaller ? k.a11_Pa : k.a22_Pa;
  }
  return adjusted;
}

}  // namespace twill
