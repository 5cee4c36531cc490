#pragma once
// The tensile strip as a path-dependent effect sees it (docs/effects/strip_path.md): a lumped
// element in parallel with the simulated strip, driven by the strip's nominal strain along the
// run's schedule and split into the law's three deformation modes.
//
//   ε = x / L                        nominal axial strain (x the clamp extension, L the gauge)
//   e_m = c_m(θ) ε,  c(θ) = (sin²θ, cos²θ, sinθ cosθ)   warp Ẽ11, weft Ẽ22, shear Ẽ12 (tensor)
//   F = W Σ_m c_m σ_m                 clamp force [N] of mode stresses σ_m [N/m] (membrane
//                                     units: stress × thickness), by virtual work σ_m de_m
//
// with θ the strip axis vs the weft (model.md §7: θ = 90° pulls the warp) and W the width.
// The split is the strip's uniform strain without lateral contraction: exact for warp and
// weft strips, an approximation off-axis (documented with each effect). The path starts
// at ε = 0 with the element's state at rest and visits the schedule's entries in order, so
// loading and unloading rows give different forces when the element remembers its path.
//
// Clock (rate effects): the time of each path point from the run's time_s when it has one
// (the first segment, from 0 to the first row, at the crosshead speed: rate_mm_min, or the
// speed of the first two rows), otherwise from |Δx| / rate_mm_min.
#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "effects/effect.hpp"

namespace twill {

struct StripPath {
  std::vector<double> strain;  ///< ε at the path points: 0, then one per schedule entry
  std::vector<double> time_s;  ///< the clock at the same points; empty unless asked for
  double width_m = 0;
};

/// Whether the run is a strip pulled by extensions with a clamp force as its observable (the
/// runs a strip-path effect acts on; it leaves any other run, e.g. a cantilever, unchanged).
bool is_pulled_strip(const RunConditions& run);

/// The path of a tensile run. Throws InputError naming `effect` when the run is not a strip
/// pulled by extensions, or (with_clock) when it has neither time_s nor a rate.
StripPath strip_path(const RunConditions& run, const std::string& effect, bool with_clock);

/// c(θ) above for θ in degrees; Scalar may carry derivatives (Eigen's AutoDiffScalar).
template <class Scalar>
Eigen::Matrix<Scalar, 3, 1> mode_coefficients(const Scalar& angle_deg) {
  using std::cos;
  using std::sin;
  const Scalar t = angle_deg * (M_PI / 180.0);
  const Scalar s = sin(t), c = cos(t);
  return Eigen::Matrix<Scalar, 3, 1>(s * s, c * c, s * c);
}

}  // namespace twill
