#pragma once
// A simulated tensile curve against a reference curve at the same extensions: the measure of
// every reference comparison (issues #3, #4, #12; README figures; `twill bench --reference`,
// `twill simulate` with a reference, the reference tests).
#include <cstddef>
#include <vector>

#include "experiments/tensile_strip.hpp"

namespace twill {

/// Points whose reference force is at most this are left out of the worst relative error:
/// near zero force a relative error says nothing.
inline constexpr double kReferenceFloorN = 1.0;

struct ReferenceErrors {
  double average = 0;  ///< Σ|F − F_ref| / Σ|F_ref| (model.md §8)
  double worst = 0;    ///< F/F_ref − 1 of largest magnitude over |F_ref| > kReferenceFloorN (+: stiffer)
  std::size_t points = 0;  ///< points compared: the shorter of the two curves
};

ReferenceErrors reference_errors(const std::vector<double>& simulated_N, const std::vector<double>& reference_N);
/// The same for a simulated curve (its converged points, in order).
ReferenceErrors reference_errors(const TensileCurve& curve, const std::vector<double>& reference_N);

}  // namespace twill
