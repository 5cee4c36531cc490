// Errors of a simulated curve against a reference curve (experiments/reference_errors.hpp).
#include "experiments/reference_errors.hpp"

#include <algorithm>
#include <cmath>

namespace twill {

ReferenceErrors reference_errors(const std::vector<double>& simulated_N, const std::vector<double>& reference_N) {
  ReferenceErrors e;
  e.points = std::min(simulated_N.size(), reference_N.size());
  double sum_difference = 0, sum_reference = 0;
  for (std::size_t i = 0; i < e.points; ++i) {
    sum_difference += std::abs(simulated_N[i] - reference_N[i]);
    sum_reference += std::abs(reference_N[i]);
    if (std::abs(reference_N[i]) <= kReferenceFloorN) continue;
    const double relative = simulated_N[i] / reference_N[i] - 1.0;
    if (std::abs(relative) > std::abs(e.worst)) e.worst = relative;
  }
  e.average = sum_reference > 0 ? sum_difference / sum_reference : 0.0;
  return e;
}

ReferenceErrors reference_errors(const TensileCurve& curve, const std::vector<double>& reference_N) {
  std::vector<double> forces;
  for (const TensilePoint& p : curve.points) forces.push_back(p.force_N);
  return reference_errors(forces, reference_N);
}

}  // namespace twill
