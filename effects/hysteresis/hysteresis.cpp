#include "effects/hysteresis/hysteresis.hpp"

#include <unsupported/Eigen/AutoDiff>

#include "effects/strip_path.hpp"

namespace twill {
namespace {

// Active variables of the forward-mode derivative: the three frictions, e_c, θ.
constexpr int kFrictions = 3, kStrainScale = 3, kAngle = 4, kActive = 5;
using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, kActive, 1>>;

Dual active(double value, int index) { return Dual(value, kActive, index); }

// Unit Dahl responses φ_m (σ_m = σ_s,m φ_m) at every path point for the modes' strain
// magnitudes |c_m| ε (c σ(cε) = |c| σ(|c| ε): Dahl's law is odd; strip_path.hpp).
// Returns W Σ_m |c_m| σ_s,m φ_m per schedule entry.
std::vector<Dual> friction_forces(const StripPath& path, const Eigen::Matrix<Dual, 3, 1>& frictions,
                                  const Dual& strain_scale, const Dual& angle_deg) {
  const Eigen::Matrix<Dual, 3, 1> c = mode_coefficients(angle_deg);
  std::vector<Dual> forces;
  Eigen::Matrix<Dual, 3, 1> phi(Dual(0.0), Dual(0.0), Dual(0.0));
  for (size_t i = 1; i < path.strain.size(); ++i) {
    const double step = path.strain[i] - path.strain[i - 1];
    Dual force(0.0);
    for (int m = 0; m < 3; ++m) {
      const Dual magnitude = c[m].value() < 0 ? Dual(-c[m]) : c[m];
      if (step != 0.0) {
        const double s = step > 0 ? 1.0 : -1.0;
        phi[m] = s + (phi[m] - s) * exp(-(magnitude * std::abs(step)) / strain_scale);
      }
      force += magnitude * frictions[m] * phi[m];
    }
    forces.push_back(path.width_m * force);
  }
  return forces;
}

}  // namespace

OptionBindings<HysteresisOptions> hysteresis_bindings() {
  using O = HysteresisOptions;
  const auto friction = in_range(0.0, Hysteresis::kMaxFriction_N_m);
  return {
      real_option<O>("warp_friction_N_m", &O::warp_friction_N_m, "friction the warp mode saturates at [N/m]", friction),
      real_option<O>("weft_friction_N_m", &O::weft_friction_N_m, "friction the weft mode saturates at [N/m]", friction),
      real_option<O>("shear_friction_N_m", &O::shear_friction_N_m, "friction the shear mode saturates at [N/m]",
                     friction),
      real_option<O>("saturation_strain", &O::saturation_strain,
                     "strain over which friction builds up after a reversal (Dahl's σ_s/σ0)",
                     in_range(Hysteresis::kMinSaturationStrain, Hysteresis::kMaxSaturationStrain))};
}

bool HysteresisOptions::validate(std::string* error) const { return check_options(hysteresis_bindings(), *this, error); }

Hysteresis::Hysteresis(const HysteresisOptions& options) : options_(options) { require_valid(options, kName); }

std::string Hysteresis::missing_data(const Dataset& dataset) const {
  if (any_tensile_run(dataset, [](const TensileTest&, const TensileRun& run) { return run.has_unloading; })) return "";
  return "needs a tensile run that goes up and comes back down (unloading rows)";
}

ObservableChange Hysteresis::observable_change(const RunConditions& run, const MaterialParameters& k) const {
  const auto m = static_cast<Eigen::Index>(run.schedule.size());
  ObservableChange change = ObservableChange::zero(m, k.flat_size());
  if (!is_pulled_strip(run)) return change;
  const StripPath path = strip_path(run, kName, false);
  const Eigen::Matrix<Dual, 3, 1> frictions(active(options_.warp_friction_N_m, 0),
                                            active(options_.weft_friction_N_m, 1),
                                            active(options_.shear_friction_N_m, 2));
  const std::vector<Dual> forces =
      friction_forces(path, frictions, active(options_.saturation_strain, kStrainScale), active(run.angle_deg, kAngle));
  const char* names[kActive - 1] = {"warp_friction_N_m", "weft_friction_N_m", "shear_friction_N_m",
                                    "saturation_strain"};
  for (Eigen::Index i = 0; i < m; ++i) {
    const Dual& f = forces[static_cast<size_t>(i)];
    change.added[i] = f.value();
    for (int a = 0; a < kFrictions + 1; ++a) change.d_flat(i, effect_flat_index(k, kName, names[a])) = f.derivatives()[a];
    change.d_angle[i] = f.derivatives()[kAngle];
  }
  return change;
}

}  // namespace twill
