#include "optimizers/strong_wolfe_line_search.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace twill {
namespace {

std::string number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

class Search {
 public:
  Search(const LineFunction& phi, const LineSearchSample& at_zero, const LineSearchOptions& options)
      : phi_(phi), zero_(at_zero), options_(options) {}

  LineSearchOutcome run(double alpha_initial, double alpha_max) {
    // N&W Alg. 3.5: bracket a strong Wolfe step, or find one while extrapolating.
    if (!(zero_.dphi < 0.0))
      return fail("phi'(0) = " + number(zero_.dphi) + " >= 0: not a descent direction");
    if (!(alpha_initial > 0.0) || !(alpha_max > 0.0))
      return fail("the initial step " + number(alpha_initial) + " and the largest step " +
                  number(alpha_max) + " must be positive");
    LineSearchSample previous = zero_;
    double alpha = std::min(alpha_initial, alpha_max);
    for (int i = 1;; ++i) {
      if (out_of_budget())
        return fail("no bracket within " + std::to_string(options_.max_evaluations) +
                    " evaluations (last alpha " + number(previous.alpha) + ")");
      const LineSearchSample current = sample(alpha);
      if (!std::isfinite(current.phi) || !sufficient_decrease(current) ||
          (i > 1 && higher(current, previous)))
        return zoom(previous, current);
      if (curvature(current)) return accept(current, LineSearchOutcome::Status::strong_wolfe);
      if (current.dphi >= 0.0) return zoom(current, previous);
      if (alpha >= alpha_max) return accept(current, LineSearchOutcome::Status::step_limit);
      previous = current;
      alpha = std::min(4.0 * alpha, alpha_max);
    }
  }

 private:
  // N&W Alg. 3.6. Invariants: `lo` satisfies sufficient decrease and has the lowest φ seen
  // among such steps; φ'(lo)(hi − lo) < 0, so the bracket holds a strong Wolfe step.
  LineSearchOutcome zoom(LineSearchSample lo, LineSearchSample hi) {
    for (;;) {
      const double a = std::min(lo.alpha, hi.alpha), b = std::max(lo.alpha, hi.alpha);
      const double width = b - a;
      if (out_of_budget())
        return fail("no strong Wolfe step within " + std::to_string(options_.max_evaluations) +
                    " evaluations (bracket [" + number(a) + ", " + number(b) + "])");
      if (width <= 4.0 * std::numeric_limits<double>::epsilon() * b)
        return fail("the bracket [" + number(a) + ", " + number(b) +
                    "] shrank to round-off without a strong Wolfe step");
      double alpha = cubic_minimizer(lo, hi);
      const double margin = 0.1 * width;
      alpha = std::isfinite(alpha) ? std::clamp(alpha, a + margin, b - margin) : 0.5 * (a + b);
      const LineSearchSample current = sample(alpha);
      if (!std::isfinite(current.phi) || !sufficient_decrease(current) || higher(current, lo)) {
        hi = current;
      } else {
        if (curvature(current)) return accept(current, LineSearchOutcome::Status::strong_wolfe);
        if (current.dphi * (hi.alpha - lo.alpha) >= 0.0) hi = lo;
        lo = current;
      }
    }
  }

  LineSearchSample sample(double alpha) {
    ++evaluations_;
    LineSearchSample s;
    s.alpha = alpha;
    s.phi = phi_(alpha, &s.dphi);
    if (!std::isfinite(s.dphi)) s.phi = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  // N&W's "φ(α_j) ≥ φ(α_lo)", except that values equal to round-off count as not higher, so
  // that φ' decides instead. Near a minimiser φ varies by O(δα²) and the values stop carrying
  // information long before φ' does (Moré–Thuente function 2 needs |α − α*| < 3e-9, where φ
  // differs by 1e-16 relative); the acceptance tests themselves are unchanged.
  static bool higher(const LineSearchSample& a, const LineSearchSample& b) {
    const double round_off =
        8.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(a.phi), std::abs(b.phi));
    return a.phi > b.phi + round_off;
  }
  bool out_of_budget() const { return evaluations_ >= options_.max_evaluations; }
  bool sufficient_decrease(const LineSearchSample& s) const {
    return s.phi <= zero_.phi + options_.c1 * s.alpha * zero_.dphi;
  }
  bool curvature(const LineSearchSample& s) const {
    return std::abs(s.dphi) <= -options_.c2 * zero_.dphi;
  }
  LineSearchOutcome accept(const LineSearchSample& s, LineSearchOutcome::Status status) const {
    LineSearchOutcome out;
    out.status = status;
    out.accepted = s;
    out.evaluations = evaluations_;
    return out;
  }
  LineSearchOutcome fail(std::string message) const {
    LineSearchOutcome out;
    out.status = LineSearchOutcome::Status::failed;
    out.evaluations = evaluations_;
    out.message = std::move(message);
    return out;
  }

  const LineFunction& phi_;
  LineSearchSample zero_;
  const LineSearchOptions& options_;
  int evaluations_ = 0;
};

}  // namespace

bool LineSearchOptions::validate(std::string* error) const {
  std::string problem;
  if (!(c1 > 0.0 && c1 < 1.0)) {
    problem = "c1 = " + number(c1) + " is outside (0, 1)";
  } else if (!(c2 > 0.0 && c2 < 1.0)) {
    problem = "c2 = " + number(c2) + " is outside (0, 1)";
  } else if (!(c1 < c2)) {
    problem = "c1 = " + number(c1) + " must be smaller than c2 = " + number(c2) +
              " (N&W Lemma 3.1: else no strong Wolfe step need exist)";
  } else if (max_evaluations < 1) {
    problem = "max_evaluations = " + std::to_string(max_evaluations) + " must be at least 1";
  }
  if (problem.empty()) return true;
  if (error) *error = problem;
  return false;
}

double cubic_minimizer(const LineSearchSample& a, const LineSearchSample& b) {
  if (!std::isfinite(a.phi) || !std::isfinite(b.phi) || !std::isfinite(a.dphi) ||
      !std::isfinite(b.dphi) || a.alpha == b.alpha)
    return std::numeric_limits<double>::quiet_NaN();
  // N&W eq. 3.59 with α_{i−1} = a, α_i = b.
  const double d1 = a.dphi + b.dphi - 3.0 * (a.phi - b.phi) / (a.alpha - b.alpha);
  const double discriminant = d1 * d1 - a.dphi * b.dphi;
  if (discriminant < 0.0) return std::numeric_limits<double>::quiet_NaN();
  const double d2 = std::copysign(std::sqrt(discriminant), b.alpha - a.alpha);
  const double denominator = b.dphi - a.dphi + 2.0 * d2;
  if (denominator == 0.0) return std::numeric_limits<double>::quiet_NaN();
  return b.alpha - (b.alpha - a.alpha) * (b.dphi + d2 - d1) / denominator;
}

LineSearchOutcome strong_wolfe_line_search(const LineFunction& phi, const LineSearchSample& at_zero,
                                           double alpha_initial, double alpha_max,
                                           const LineSearchOptions& options) {
  Search search(phi, at_zero, options);
  return search.run(alpha_initial, alpha_max);
}

}  // namespace twill
