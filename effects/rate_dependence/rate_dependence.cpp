#include "effects/rate_dependence/rate_dependence.hpp"

#include <algorithm>
#include <cmath>
#include <unsupported/Eigen/AutoDiff>

#include "effects/strip_path.hpp"

namespace twill {
namespace {

// Active variables: β, t_r, θ, τ, a11, a22, G12.
enum Active { kRatio, kRelaxation, kAngle, kThickness, kA11, kA22, kG12, kActive };
using Dual = Eigen::AutoDiffScalar<Eigen::Matrix<double, kActive, 1>>;

Dual active(double value, int index) { return Dual(value, kActive, index); }

// The unit Maxwell response ψ at every schedule entry (header).
std::vector<Dual> unit_response(const StripPath& path, const Dual& relaxation_s) {
  std::vector<Dual> psi;
  Dual state(0.0);
  for (size_t i = 1; i < path.strain.size(); ++i) {
    const double step = path.strain[i] - path.strain[i - 1];
    const double dt = path.time_s[i] - path.time_s[i - 1];
    if (dt > 0) {
      const Dual decay = exp(-dt / relaxation_s);
      state = state * decay + (step / dt) * relaxation_s * (1.0 - decay);
    } else {
      state += step;  // a jump: the spring takes it all
    }
    psi.push_back(state);
  }
  return psi;
}

}  // namespace

OptionBindings<RateDependenceOptions> rate_dependence_bindings() {
  using O = RateDependenceOptions;
  return {real_option<O>("viscous_ratio", &O::viscous_ratio,
                         "Maxwell spring / small-strain membrane stiffness of each mode (β)",
                         in_range(0.0, RateDependence::kMaxViscousRatio)),
          real_option<O>("relaxation_s", &O::relaxation_s, "relaxation time of the Maxwell branch (t_r) [s]",
                         in_range(RateDependence::kMinRelaxation_s, RateDependence::kMaxRelaxation_s))};
}

bool RateDependenceOptions::validate(std::string* error) const {
  return check_options(rate_dependence_bindings(), *this, error);
}

RateDependence::RateDependence(const RateDependenceOptions& options) : options_(options) {
  require_valid(options, kName);
}

double run_speed_mm_min(const TensileTest& test, const TensileRun& run) {
  if (test.rate_mm_min) return *test.rate_mm_min;
  if (!run.has_time() || run.size() < 2) return 0.0;
  const double duration_s = run.time_s[run.peak_index] - run.time_s.front();
  const double range_mm = run.extension_mm[run.peak_index] - run.extension_mm.front();
  return duration_s > 0 ? 60.0 * std::abs(range_mm) / duration_s : 0.0;
}

std::string RateDependence::missing_data(const Dataset& dataset) const {
  std::vector<double> speeds;
  bool clocked_loop = false;  // a run with a clock that comes back down: its loop shows β and t_r
  for (const TensileTest& test : dataset.tensile)
    for (const TensileRun& run : test.runs)
      if (const double v = run_speed_mm_min(test, run); v > 0) {
        speeds.push_back(v);
        clocked_loop = clocked_loop || run.has_unloading;
      }
  if (!speeds.empty()) {
    const auto [lo, hi] = std::minmax_element(speeds.begin(), speeds.end());
    if (*hi > (1.0 + kDistinctSpeeds) * *lo || clocked_loop) return "";
  }
  return "needs tensile runs at two or more crosshead speeds, or runs at one speed with an unloading branch "
         "(rate_mm_min per test, or time_s columns)";
}

ObservableChange RateDependence::observable_change(const RunConditions& run, const MaterialParameters& k) const {
  const auto m = static_cast<Eigen::Index>(run.schedule.size());
  ObservableChange change = ObservableChange::zero(m, k.flat_size());
  if (!is_pulled_strip(run)) return change;
  const StripPath path = strip_path(run, kName, true);
  const Eigen::Matrix<Dual, 3, 1> c = mode_coefficients(active(run.angle_deg, kAngle));
  const Dual thickness = active(k.thickness_m, kThickness);
  const Eigen::Matrix<Dual, 3, 1> moduli(thickness * active(k.a11_Pa, kA11), thickness * active(k.a22_Pa, kA22),
                                         2.0 * thickness * active(k.G12_Pa, kG12));
  Dual stiffness(0.0);  // Σ_m M_m c_m² [N/m]
  for (int mode = 0; mode < 3; ++mode) stiffness += moduli[mode] * c[mode] * c[mode];
  const std::vector<Dual> psi = unit_response(path, active(options_.relaxation_s, kRelaxation));
  const Dual ratio = active(options_.viscous_ratio, kRatio);
  const int column[kActive] = {effect_flat_index(k, kName, "viscous_ratio"), effect_flat_index(k, kName, "relaxation_s"),
                               -1, FlatLayout::kThickness, FlatLayout::kA11, FlatLayout::kA22, FlatLayout::kG12};
  for (Eigen::Index i = 0; i < m; ++i) {
    const Dual f = path.width_m * ratio * psi[static_cast<size_t>(i)] * stiffness;
    change.added[i] = f.value();
    for (int a = 0; a < kActive; ++a)
      if (column[a] >= 0) change.d_flat(i, column[a]) = f.derivatives()[a];
    change.d_angle[i] = f.derivatives()[kAngle];
  }
  return change;
}

}  // namespace twill
