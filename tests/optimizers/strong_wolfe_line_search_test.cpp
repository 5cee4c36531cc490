// The strong Wolfe line search (N&W Alg. 3.5/3.6) on its own: the one-dimensional test
// functions of Moré & Thuente ("Line search algorithms with guaranteed sufficient decrease",
// ACM TOMS 20, 1994, §5, functions 1–3) from initial steps 1e-3 … 1e3, plus the edge cases
// (bound-limited step, failed evaluations, no descent, exhausted budget).
#include "optimizers/strong_wolfe_line_search.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace twill {
namespace {

// φ with φ', and how often it was called.
struct CountedLine {
  std::function<double(double, double*)> f;
  int calls = 0;
  LineFunction function() {
    return [this](double alpha, double* dphi) {
      ++calls;
      return f(alpha, dphi);
    };
  }
  LineSearchSample at(double alpha) {
    LineSearchSample s;
    s.alpha = alpha;
    s.phi = f(alpha, &s.dphi);
    return s;
  }
};

void expect_strong_wolfe(const LineSearchOutcome& out, const LineSearchSample& zero,
                         const LineSearchOptions& options) {
  ASSERT_EQ(out.status, LineSearchOutcome::Status::strong_wolfe) << out.message;
  EXPECT_GT(out.accepted.alpha, 0.0);
  EXPECT_LE(out.accepted.phi, zero.phi + options.c1 * out.accepted.alpha * zero.dphi);
  EXPECT_LE(std::abs(out.accepted.dphi), options.c2 * std::abs(zero.dphi));
}

// Moré–Thuente function 1: φ(α) = −α / (α² + β), β = 2; minimiser √2.
CountedLine more_thuente_1() {
  return {[](double a, double* d) {
    const double beta = 2.0;
    *d = (a * a - beta) / ((a * a + beta) * (a * a + beta));
    return -a / (a * a + beta);
  }};
}

// Moré–Thuente function 2: φ(α) = (α + β)⁵ − 2(α + β)⁴, β = 0.004; minimiser 1.596.
CountedLine more_thuente_2() {
  return {[](double a, double* d) {
    const double t = a + 0.004;
    *d = 5.0 * std::pow(t, 4) - 8.0 * std::pow(t, 3);
    return std::pow(t, 5) - 2.0 * std::pow(t, 4);
  }};
}

// Moré–Thuente function 3: φ(α) = φ0(α) + 2(1 − β)/(lπ) sin(lπα/2), β = 0.01, l = 39, with
// φ0 the piecewise function of the paper (linear, quadratic near 1, linear): many local
// minimisers, so the bracket must be handled carefully.
CountedLine more_thuente_3() {
  return {[](double a, double* d) {
    const double beta = 0.01, l = 39.0, pi = std::numbers::pi;
    double phi0 = 0.0, dphi0 = 0.0;
    if (a <= 1.0 - beta) {
      phi0 = 1.0 - a;
      dphi0 = -1.0;
    } else if (a >= 1.0 + beta) {
      phi0 = a - 1.0;
      dphi0 = 1.0;
    } else {
      phi0 = (a - 1.0) * (a - 1.0) / (2.0 * beta) + beta / 2.0;
      dphi0 = (a - 1.0) / beta;
    }
    *d = dphi0 + (1.0 - beta) * std::cos(l * pi * a / 2.0);
    return phi0 + 2.0 * (1.0 - beta) / (l * pi) * std::sin(l * pi * a / 2.0);
  }};
}

struct MoreThuenteCase {
  const char* name;
  CountedLine (*make)();
  double c1, c2;
};

TEST(StrongWolfeLineSearch, MoreThuenteFunctionsFromEveryInitialStep) {
  // c1, c2 as in Moré & Thuente's Tables 1–3.
  const MoreThuenteCase cases[] = {{"function 1", more_thuente_1, 1e-3, 0.1},
                                   {"function 2", more_thuente_2, 0.1, 0.1},
                                   {"function 3", more_thuente_3, 0.1, 0.1}};
  for (const auto& c : cases) {
    for (const double alpha0 : {1e-3, 1e-1, 1e1, 1e3}) {
      SCOPED_TRACE(std::string(c.name) + ", alpha0 = " + std::to_string(alpha0));
      CountedLine line = c.make();
      const LineSearchSample zero = line.at(0.0);
      ASSERT_LT(zero.dphi, 0.0);
      LineSearchOptions options;
      options.c1 = c.c1;
      options.c2 = c.c2;
      options.max_evaluations = 30;
      const LineSearchOutcome out = strong_wolfe_line_search(
          line.function(), zero, alpha0, std::numeric_limits<double>::infinity(), options);
      expect_strong_wolfe(out, zero, options);
      EXPECT_EQ(out.evaluations, line.calls);
      // Measured 1–15 (docs/optimizers.md).
      EXPECT_LE(out.evaluations, 15);
    }
  }
}

TEST(StrongWolfeLineSearch, UnitStepOnAQuadraticIsAcceptedAtOnce) {
  // φ(α) = (α − 1)²: α = 1 is the exact minimiser; one evaluation suffices.
  CountedLine line{[](double a, double* d) {
    *d = 2.0 * (a - 1.0);
    return (a - 1.0) * (a - 1.0);
  }};
  const LineSearchOptions options;
  const LineSearchSample zero = line.at(0.0);
  const LineSearchOutcome out =
      strong_wolfe_line_search(line.function(), zero, 1.0, 1e300, options);
  expect_strong_wolfe(out, zero, options);
  EXPECT_EQ(out.evaluations, 1);
  EXPECT_EQ(out.accepted.alpha, 1.0);
}

TEST(StrongWolfeLineSearch, StepLimitedWhenStillDescendingAtAlphaMax) {
  // φ(α) = −α never satisfies the curvature condition; α grows 4-fold up to α_max = 5.
  CountedLine line{[](double a, double* d) {
    *d = -1.0;
    return -a;
  }};
  const LineSearchOptions options;
  const LineSearchOutcome out =
      strong_wolfe_line_search(line.function(), line.at(0.0), 1.0, 5.0, options);
  EXPECT_EQ(out.status, LineSearchOutcome::Status::step_limit);
  EXPECT_EQ(out.accepted.alpha, 5.0);
  EXPECT_EQ(out.evaluations, 3);  // 1, 4, 5
}

TEST(StrongWolfeLineSearch, FailedEvaluationsCloseTheBracket) {
  // φ(α) = (α − 1.5)², undefined (NaN) beyond α = 2; the first trial α = 10 fails.
  CountedLine line{[](double a, double* d) {
    if (a > 2.0) {
      *d = std::nan("");
      return std::nan("");
    }
    *d = 2.0 * (a - 1.5);
    return (a - 1.5) * (a - 1.5);
  }};
  const LineSearchOptions options;
  const LineSearchSample zero = line.at(0.0);
  const LineSearchOutcome out =
      strong_wolfe_line_search(line.function(), zero, 10.0, 1e300, options);
  expect_strong_wolfe(out, zero, options);
  EXPECT_LE(out.accepted.alpha, 2.0);
}

TEST(StrongWolfeLineSearch, ReportsFailures) {
  CountedLine line = more_thuente_1();
  LineSearchOptions options;
  // Not a descent direction: φ'(0) > 0 (direction reversed).
  LineSearchSample uphill = line.at(0.0);
  uphill.dphi = -uphill.dphi;
  LineSearchOutcome out = strong_wolfe_line_search(line.function(), uphill, 1.0, 1e300, options);
  EXPECT_EQ(out.status, LineSearchOutcome::Status::failed);
  EXPECT_NE(out.message.find("descent"), std::string::npos) << out.message;
  EXPECT_EQ(line.calls, 0);
  // Budget exhausted: from 1e-3, one trial cannot bracket the minimiser at √2.
  options.max_evaluations = 1;
  out = strong_wolfe_line_search(line.function(), line.at(0.0), 1e-3, 1e300, options);
  EXPECT_EQ(out.status, LineSearchOutcome::Status::failed);
  EXPECT_EQ(out.evaluations, 1);
  EXPECT_NE(out.message.find("1 evaluations"), std::string::npos) << out.message;
}

TEST(StrongWolfeLineSearch, CubicInterpolationIsExactForCubics) {
  // φ(α) = α³ − 3α has its local minimiser at α = 1; samples at 0 and 2 (either order).
  auto sample = [](double a) {
    return LineSearchSample{a, a * a * a - 3.0 * a, 3.0 * a * a - 3.0};
  };
  EXPECT_NEAR(cubic_minimizer(sample(0.0), sample(2.0)), 1.0, 1e-14);
  EXPECT_NEAR(cubic_minimizer(sample(2.0), sample(0.0)), 1.0, 1e-14);
  EXPECT_NEAR(cubic_minimizer(sample(0.5), sample(3.0)), 1.0, 1e-14);
  // Quadratics are cubics too: (α − 0.7)² from 0 and 5.
  auto quadratic = [](double a) {
    return LineSearchSample{a, (a - 0.7) * (a - 0.7), 2.0 * (a - 0.7)};
  };
  EXPECT_NEAR(cubic_minimizer(quadratic(0.0), quadratic(5.0)), 0.7, 1e-14);
  // No minimiser (φ = −α³ − α is strictly decreasing): NaN, so the caller bisects.
  auto falling = [](double a) { return LineSearchSample{a, -a * a * a - a, -3.0 * a * a - 1.0}; };
  EXPECT_TRUE(std::isnan(cubic_minimizer(falling(0.0), falling(1.0))));
}

TEST(StrongWolfeLineSearch, OptionsNameTheViolatedConstraint) {
  std::string error;
  EXPECT_TRUE(LineSearchOptions{}.validate(&error));
  LineSearchOptions o;
  o.c1 = 0.5;
  o.c2 = 0.4;
  EXPECT_FALSE(o.validate(&error));
  EXPECT_NE(error.find("c1 = 0.5 must be smaller than c2 = 0.4"), std::string::npos) << error;
  o = {};
  o.c2 = 1.0;
  EXPECT_FALSE(o.validate(&error));
  EXPECT_NE(error.find("c2 = 1 is outside (0, 1)"), std::string::npos) << error;
  o = {};
  o.max_evaluations = 0;
  EXPECT_FALSE(o.validate(nullptr));
}

}  // namespace
}  // namespace twill
