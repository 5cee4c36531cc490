#include "core/specimen_scale.hpp"

#include <algorithm>
#include <cmath>

namespace twill {

namespace {

// Bisection halvings of the multiplier's bracket: 200 take any finite bracket below a double's
// spacing; the loop stops earlier once the bracket stops shrinking.
constexpr int kMaxHalvings = 200;

struct RunSums {
  double a = 0, b = 0, w = 1;  // Σ q², Σ q, weight
  // The positive root of w (a s² − b s) = λ/2: s f'(s) = λ with f = w Σ (s q − 1)².
  double scale(double lambda) const {
    const double disc = std::max(0.0, b * b + 2.0 * a * lambda / w);
    return (b + std::sqrt(disc)) / (2.0 * a);
  }
};

double sum_log_scales(const std::vector<RunSums>& runs, double lambda) {
  double h = 0;
  for (const RunSums& r : runs) h += std::log(r.scale(lambda));
  return h;
}

}  // namespace

std::vector<double> profiled_group_scales(const std::vector<ScaledRun>& group) {
  std::vector<double> ones(group.size(), 1.0);
  if (group.size() < 2) return ones;
  std::vector<RunSums> runs;
  for (const ScaledRun& g : group) {
    RunSums r;
    r.a = g.relative_prediction->squaredNorm();
    r.b = g.relative_prediction->sum();
    r.w = g.weight;
    if (!(r.b > 0) || !(r.a > 0) || !std::isfinite(r.a)) return ones;
    runs.push_back(r);
  }
  // λ below which some run's root is complex: there s_r = b/(2a), the smallest stationary scale.
  double lo = -1e300;
  for (const RunSums& r : runs) lo = std::max(lo, -r.w * r.b * r.b / (2.0 * r.a));
  double hi = std::max(1.0, std::abs(lo));
  while (sum_log_scales(runs, hi) < 0 && std::isfinite(hi)) hi *= 2;
  if (sum_log_scales(runs, lo) >= 0) hi = lo;  // see below
  for (int k = 0; k < kMaxHalvings && lo < hi; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (sum_log_scales(runs, mid) < 0 ? lo : hi) = mid;
  }
  // hi = lo above: no run set reaches the gauge from the stationary branch; the bracket's lower end is
  // the closest (a group whose runs disagree by more than a factor of ~2 in shape).
  std::vector<double> s;
  for (const RunSums& r : runs) s.push_back(r.scale(0.5 * (lo + hi)));
  // Remove the bisection's last residue of the gauge exactly (a relative 1e-16 shift).
  double log_mean = 0;
  for (double v : s) log_mean += std::log(v);
  log_mean /= static_cast<double>(s.size());
  for (double& v : s) v *= std::exp(-log_mean);
  return s;
}

}  // namespace twill
