#pragma once
// Convergence-order checks of analytic derivatives against central finite differences.
//
// A central difference D(h) = (f(x+h) − f(x−h)) / 2h has error C h² + O(h⁴) + round-off
// ~ ε|f|/h. The check evaluates the error e(h) for h = h0, h0/2, h0/4, … and requires that,
// while e(h) is above the round-off floor, it falls by a factor ≈ 4 per halving (observed
// order in [1.7, 2.3]) and that the smallest error is small relative to the derivative.
// Exactly-differenced cases (e(h) at round-off for every h) are reported as such: a caller
// that expects truncation error must pick points where the function is not quadratic.
#include <Eigen/Core>
#include <cmath>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace twill::testing {

struct OrderCheck {
  bool ok = false;
  bool roundoff_only = false;   ///< every error was at the round-off floor
  double observed_order = 0.0;  ///< from the first pair above the floor
  double smallest_error = 0.0;  ///< relative to the derivative's scale
  std::string report;
};

/// errors[j] is the error at h0 / 2^j; floors[j] the round-off level at that step, below which
/// errors are not informative; `scale` normalises the reported error.
inline OrderCheck check_second_order(const std::vector<double>& errors,
                                     const std::vector<double>& floors, double scale,
                                     double max_relative_error) {
  OrderCheck c;
  std::ostringstream os;
  os << "errors:";
  for (double e : errors) os << ' ' << e;
  os << " floor " << floors.back() << " scale " << scale;
  c.smallest_error = errors.back() / scale;
  for (size_t j = 0; j + 1 < errors.size(); ++j) {
    if (errors[j + 1] > 10.0 * floors[j + 1]) {
      c.observed_order = std::log2(errors[j] / errors[j + 1]);
      break;
    }
  }
  double min_error = errors[0];
  for (double e : errors) min_error = std::min(min_error, e);
  c.smallest_error = min_error / scale;
  if (c.observed_order == 0.0) {
    c.roundoff_only = true;
    c.ok = min_error <= 10.0 * floors.back() + 1e-14 * scale;
  } else {
    c.ok = c.observed_order > 1.7 && c.observed_order < 2.3 && c.smallest_error < max_relative_error;
  }
  os << " -> order " << c.observed_order << ", smallest relative error " << c.smallest_error;
  c.report = os.str();
  return c;
}

/// Directional check of a vector-valued derivative: compares J·v (analytic) with central
/// differences of `f` along v. `f(x)` returns a vector; `jv` is the analytic directional
/// derivative. Uses the max-norm of the difference.
inline OrderCheck check_directional_derivative(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    const Eigen::VectorXd& v, const Eigen::VectorXd& jv, double h0, int halvings = 4,
    double max_relative_error = 1e-4) {
  std::vector<double> errors, floors;
  const Eigen::VectorXd f0 = f(x);
  const double value_scale = std::max(f0.cwiseAbs().maxCoeff(), 1e-300);
  const double scale = std::max(jv.cwiseAbs().maxCoeff(), 1e-300);
  double h = h0;
  for (int j = 0; j <= halvings; ++j, h *= 0.5) {
    const Eigen::VectorXd fd = (f(x + h * v) - f(x - h * v)) / (2.0 * h);
    errors.push_back((fd - jv).cwiseAbs().maxCoeff());
    floors.push_back(4.4e-16 * value_scale / h);  // round-off of the difference quotient
  }
  return check_second_order(errors, floors, scale, max_relative_error);
}

}  // namespace twill::testing
