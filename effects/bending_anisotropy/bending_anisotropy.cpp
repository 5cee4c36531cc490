#include "effects/bending_anisotropy/bending_anisotropy.hpp"

#include <array>
#include <cmath>

namespace twill {

namespace {

// The warp angle of the dataset contract (strip axis vs weft, dataset-format.md).
constexpr double kWarpAngle_deg = 90.0;

bool along(double angle_deg, double axis_deg) {
  return std::abs(std::remainder(angle_deg - axis_deg, 180.0)) <= BendingAnisotropy::kAxisTolerance_deg;
}

}  // namespace

OptionBindings<BendingAnisotropyOptions> bending_anisotropy_bindings() {
  using O = BendingAnisotropyOptions;
  const auto range = in_range(BendingAnisotropy::kMinRatio, BendingAnisotropy::kMaxRatio);
  return {real_option<O>("warp_bending_ratio", &O::warp_bending_ratio,
                         "warp bending stiffness / the paper's (τ³/12 a11 at small curvature)", range),
          real_option<O>("weft_bending_ratio", &O::weft_bending_ratio,
                         "weft bending stiffness / the paper's (τ³/12 a22 at small curvature)", range)};
}

bool BendingAnisotropyOptions::validate(std::string* error) const {
  return check_options(bending_anisotropy_bindings(), *this, error);
}

BendingAnisotropy::BendingAnisotropy(const BendingAnisotropyOptions& options) : options_(options) {
  require_valid(options, kName);
}

std::string BendingAnisotropy::missing_data(const Dataset& dataset) const {
  bool warp = false, weft = false;
  for (const BendTest& test : dataset.bend) {
    warp = warp || along(test.angle_deg, kWarpAngle_deg);
    weft = weft || along(test.angle_deg, 0.0);
  }
  if (warp && weft) return "";
  const std::string missing = !warp && !weft ? "warp (90°) and weft (0°)" : !warp ? "warp (90°)" : "weft (0°)";
  return "needs bend tests (cantilevers) along warp (90°) and along weft (0°): none along " + missing;
}

MaterialParameters BendingAnisotropy::adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const {
  MaterialParameters adjusted = k;
  adjusted.bending_warp_ratio = options_.warp_bending_ratio;
  adjusted.bending_weft_ratio = options_.weft_bending_ratio;
  if (jacobian) {
    const int n = k.flat_size();
    const int law_entry = FlatLayout(k).bending;
    const std::array<const char*, FlatLayout::kBendingRatios> options = {"warp_bending_ratio", "weft_bending_ratio"};
    *jacobian = Eigen::MatrixXd::Identity(n, n);
    for (int j = 0; j < FlatLayout::kBendingRatios; ++j) {
      // The law entry is replaced by the effect's parameter: ∂k'/∂(effect parameter) = 1.
      jacobian->row(law_entry + j).setZero();
      (*jacobian)(law_entry + j, effect_flat_index(k, kName, options[static_cast<size_t>(j)])) = 1.0;
    }
  }
  return adjusted;
}

}  // namespace twill
