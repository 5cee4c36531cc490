#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace twill {

GaussLegendreRule GaussLegendreRule::make(int n) {
  if (n < 1)
    throw std::invalid_argument("GaussLegendreRule::make: needs n >= 1 points, got " +
                                std::to_string(n));
  GaussLegendreRule rule;
  rule.nodes.resize(static_cast<size_t>(n));
  rule.weights.resize(static_cast<size_t>(n));
  // Roots of P_n by Newton from the Tricomi-type initial guess cos(π(i − ¼)/(n + ½)), which is
  // close enough for quadratic convergence from the first step for every n.
  for (int i = 0; i < (n + 1) / 2; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p_prev = 1.0, p = x;  // P_0 and P_1, then the three-term recurrence up to P_n
      for (int k = 2; k <= n; ++k) {
        const double p_next = ((2.0 * k - 1.0) * x * p - (k - 1.0) * p_prev) / k;
        p_prev = p;
        p = p_next;
      }
      // P_n' from P_n and P_{n−1} (for n = 1, p_prev = P_0 = 1 gives P_1' = 1).
      dp = n * (x * p - p_prev) / (x * x - 1.0);
      const double dx = p / dp;
      x -= dx;
      if (std::abs(dx) < 1e-16) break;
    }
    const double w = 2.0 / ((1.0 - x * x) * dp * dp);
    // Roots come out decreasing in i (largest first); store them mirrored and increasing.
    rule.nodes[static_cast<size_t>(i)] = -x;
    rule.nodes[static_cast<size_t>(n - 1 - i)] = x;
    rule.weights[static_cast<size_t>(i)] = w;
    rule.weights[static_cast<size_t>(n - 1 - i)] = w;
  }
  if (n % 2 == 1) rule.nodes[static_cast<size_t>(n / 2)] = 0.0;  // exact midpoint
  return rule;
}

}  // namespace twill
