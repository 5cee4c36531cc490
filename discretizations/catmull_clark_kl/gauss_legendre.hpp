#pragma once
// Gauss–Legendre quadrature on [−1, 1]: n points integrate polynomials of degree ≤ 2n − 1
// exactly. Used twice by the Catmull–Clark shell: per face direction (paper §6.3: 4×4 points
// per face) and through the thickness (docs/catmull_clark_kl.md §3).
#include <vector>

namespace twill {

struct GaussLegendreRule {
  std::vector<double> nodes;    ///< abscissae in (−1, 1), increasing
  std::vector<double> weights;  ///< positive, sum 2

  int size() const { return static_cast<int>(nodes.size()); }
  /// The n-point rule (n ≥ 1), nodes and weights to machine precision (Newton on P_n).
  /// Throws std::invalid_argument for n < 1.
  static GaussLegendreRule make(int n);
};

}  // namespace twill
