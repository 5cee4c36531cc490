#pragma once
// Line search for the strong Wolfe conditions (Nocedal & Wright, Numerical Optimization,
// 2nd ed., 2006, Alg. 3.5 "Line Search Algorithm" with Alg. 3.6 "zoom", §3.5):
//
//   sufficient decrease   φ(α) ≤ φ(0) + c1 α φ'(0)          (N&W eq. 3.7a)
//   curvature             |φ'(α)| ≤ c2 |φ'(0)|               (N&W eq. 3.7b)
//
// for φ(α) = f(x + α p) along a descent direction p (φ'(0) < 0), 0 < c1 < c2 < 1.
// Trial steps inside a bracket come from the minimiser of the cubic interpolating φ and φ' at
// both ends (N&W eq. 3.59), kept at least 10% of the bracket away from its ends (else
// Alg. 3.6 could creep towards one end); extrapolation multiplies α by 4 (N&W allow any
// growing rule; 4 is Moré & Thuente's largest extrapolation factor) until a bracket is
// found or α_max is reached. φ and φ' are always evaluated together: in twill
// the gradient costs little once the value is computed (core/problem.hpp).
//
// A non-finite φ(α) (failed evaluation, core/problem.hpp) is treated as "too far": it closes
// the bracket and the next trial bisects it. Bracketing compares φ values only where they
// differ by more than round-off; ties are settled by φ' (see `higher` in the .cpp). The
// acceptance tests are always the exact conditions above.
#include <functional>
#include <limits>
#include <string>

namespace twill {

struct LineSearchOptions {
  double c1 = 1e-4;          ///< sufficient-decrease constant, 0 < c1 < c2
  double c2 = 0.9;           ///< curvature constant, c1 < c2 < 1 (0.9 for quasi-Newton, N&W §3.1)
  int max_evaluations = 20;  ///< evaluations of φ per line search

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null).
  bool validate(std::string* error) const;
};

struct LineSearchSample {
  double alpha = 0.0;
  double phi = 0.0;   ///< φ(α)
  double dphi = 0.0;  ///< φ'(α)
};

struct LineSearchOutcome {
  enum class Status {
    strong_wolfe,  ///< `accepted` satisfies both conditions
    step_limit,    ///< `accepted` is α_max: sufficient decrease holds, φ'(α_max) < 0 still
    failed,        ///< no acceptable step; `message` says why
  };
  Status status = Status::failed;
  LineSearchSample accepted;  ///< valid unless failed
  int evaluations = 0;
  std::string message;
};

/// φ(α) and, through `dphi`, φ'(α). A non-finite return marks a failed evaluation.
using LineFunction = std::function<double(double alpha, double* dphi)>;

/// Alg. 3.5/3.6. `at_zero` = (0, φ(0), φ'(0)) with φ'(0) < 0; the first trial is
/// min(alpha_initial, alpha_max); alpha_max may be +∞. Evaluates φ at most
/// options.max_evaluations times. Requires validated options.
LineSearchOutcome strong_wolfe_line_search(const LineFunction& phi, const LineSearchSample& at_zero,
                                           double alpha_initial, double alpha_max,
                                           const LineSearchOptions& options);

/// Minimiser of the cubic interpolating (a, φ_a, φ'_a) and (b, φ_b, φ'_b) (N&W eq. 3.59);
/// NaN when the cubic has no minimiser (or a sample is non-finite).
double cubic_minimizer(const LineSearchSample& a, const LineSearchSample& b);

}  // namespace twill
