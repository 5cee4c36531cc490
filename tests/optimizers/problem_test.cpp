// The Problem interface's defaults, the test problems' derivatives (central differences must
// converge at second order), and the box helpers the optimisers share.
#include "core/problem.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "optimizers/optimizer.hpp"
#include "tests/optimizers/test_problems.hpp"

namespace twill {
namespace {

using testing::ExponentialFit;
using testing::LeastSquaresTestProblem;
using testing::Rosenbrock;
using testing::ScaledQuadratic;

constexpr double kInf = std::numeric_limits<double>::infinity();

class Sphere : public Problem {
 public:
  int dimension() const override { return 3; }
  double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) override {
    if (gradient) *gradient = 2.0 * x;
    return x.squaredNorm();
  }
};

TEST(Problem, DefaultsAreUnboundedWithoutResiduals) {
  Sphere sphere;
  EXPECT_FALSE(sphere.has_residuals());
  EXPECT_FALSE(sphere.has_bounds());
  EXPECT_EQ(sphere.lower_bounds(), Eigen::VectorXd::Constant(3, -kInf));
  EXPECT_EQ(sphere.upper_bounds(), Eigen::VectorXd::Constant(3, kInf));
  Eigen::VectorXd r;
  EXPECT_THROW(sphere.residuals(Eigen::VectorXd::Zero(3), &r, nullptr), std::logic_error);
  EXPECT_NO_THROW(sphere.on_iteration(IterationRecord{}, Eigen::VectorXd::Zero(3)));
  Rosenbrock bounded(2);
  bounded.set_bounds(Eigen::Vector2d(-kInf, 0.0), Eigen::Vector2d::Constant(kInf));
  EXPECT_TRUE(bounded.has_bounds());
}

// Central differences of f and r: the error must fall by ≈ 4 as h halves (second order),
// until round-off; and evaluate() = Σ r².
TEST(TestProblems, DerivativesPassTheCentralDifferenceOrderTest) {
  std::vector<std::pair<std::string, std::unique_ptr<LeastSquaresTestProblem>>> problems;
  problems.emplace_back("rosenbrock-4", std::make_unique<Rosenbrock>(4));
  problems.emplace_back("quadratic", std::make_unique<ScaledQuadratic>(4, 1e2));
  problems.emplace_back("exp-fit", std::make_unique<ExponentialFit>());
  for (auto& [label, problem] : problems) {
    SCOPED_TRACE(label);
    const int n = problem->dimension();
    Eigen::VectorXd x(n), direction(n);
    for (int i = 0; i < n; ++i) {
      x[i] = 0.3 + 0.17 * i - 0.4 * (i % 2);
      direction[i] = 1.0 - 0.3 * i;
    }
    direction.normalize();
    Eigen::VectorXd g, r;
    Eigen::MatrixXd J;
    const double f = problem->evaluate(x, &g);
    problem->residuals(x, &r, &J);
    EXPECT_NEAR(f, r.squaredNorm(), 1e-14 * (1.0 + f));
    EXPECT_LE((g - 2.0 * J.transpose() * r).lpNorm<Eigen::Infinity>(), 1e-12 * (1.0 + g.norm()));

    std::vector<double> value_errors, residual_errors;
    for (double h = 1e-2; h >= 1e-2 / 16; h /= 2) {
      Eigen::VectorXd rp, rm;
      problem->residuals(x + h * direction, &rp, nullptr);
      problem->residuals(x - h * direction, &rm, nullptr);
      const double fd = (problem->evaluate(x + h * direction, nullptr) -
                         problem->evaluate(x - h * direction, nullptr)) /
                        (2.0 * h);
      value_errors.push_back(std::abs(fd - g.dot(direction)));
      residual_errors.push_back(((rp - rm) / (2.0 * h) - J * direction).norm());
    }
    int ratios = 0;
    for (const auto* errors : {&value_errors, &residual_errors}) {
      for (std::size_t i = 0; i + 1 < errors->size(); ++i) {
        if ((*errors)[i] < 1e-10) continue;  // exact (linear residuals) or at round-off
        EXPECT_NEAR((*errors)[i] / (*errors)[i + 1], 4.0, 0.2) << "h index " << i;
        ++ratios;
      }
    }
    // The quadratic's residuals are linear (central differences exact); the others must
    // have shown their order.
    if (label != "quadratic") {
      EXPECT_GE(ratios, 4);
    }
  }
}

TEST(BoxHelpers, ProjectedGradientIgnoresOutwardComponentsAtBounds) {
  const Eigen::Vector3d lower(0.0, -kInf, -1.0), upper(1.0, kInf, 1.0);
  const Eigen::Vector3d x(0.0, 5.0, 0.5);
  // At x0 = lower, a positive gradient pushes outward: no contribution. At x2, −g moves
  // 0.5 → clamp(0.5 + 2, ·) = 1, a projected step of 0.5.
  EXPECT_EQ(projected_gradient_norm(x, Eigen::Vector3d(3.0, 0.25, -2.0), lower, upper), 0.5);
  EXPECT_EQ(projected_gradient_norm(x, Eigen::Vector3d(-3.0, 0.0, 0.0), lower, upper), 1.0);
  // A failed evaluation has no gradient: an error, not a read through a null pointer (the
  // Ipopt adapter once reached here with one and crashed on the poplin example).
  EXPECT_THROW(projected_gradient_norm(x, Eigen::VectorXd(), lower, upper), std::invalid_argument);
}

TEST(BoxHelpers, StepsStayInTheBox) {
  const Eigen::Vector2d lower(0.0, -kInf), upper(1.0, kInf);
  const Eigen::Vector2d x(0.25, 0.0);
  EXPECT_EQ(max_feasible_step(x, Eigen::Vector2d(0.5, 1.0), lower, upper), 1.5);
  EXPECT_EQ(max_feasible_step(x, Eigen::Vector2d(-1.0, 1.0), lower, upper), 0.25);
  EXPECT_EQ(max_feasible_step(x, Eigen::Vector2d(0.0, 1.0), lower, upper), kInf);
  // The step to the bound lands exactly on it despite round-off in x + α p.
  const Eigen::Vector2d p(0.1, 1.0);
  const double alpha = max_feasible_step(x, p, lower, upper);
  EXPECT_EQ(take_step(x, p, alpha, lower, upper)[0], 1.0);
  // Components pushing through a touched bound are dropped.
  Eigen::VectorXd q = Eigen::Vector2d(-1.0, 2.0);
  drop_blocked_components(Eigen::Vector2d(0.0, 0.0), lower, upper, q);
  EXPECT_EQ(q, Eigen::Vector2d(0.0, 2.0));
}

TEST(Convergence, NamesTheTestThatPassed) {
  OptimizerOptions o;
  const Eigen::Vector2d x0(1.0, 1.0), x1(1.5, 1.0);
  EXPECT_FALSE(check_convergence(o, 2.0, 1.0, x0, x1, 1.0).has_value());
  EXPECT_NE(check_convergence(o, 2.0, 1.0, x0, x1, 1e-9)->find("gradient norm"), std::string::npos);
  EXPECT_NE(check_convergence(o, 1.0, 1.0 - 1e-13, x0, x1, 1.0)->find("relative function change"),
            std::string::npos);
  EXPECT_NE(check_convergence(o, 2.0, 1.0, x0, x0 + Eigen::Vector2d(1e-13, 0.0), 1.0)->find("step"),
            std::string::npos);
}

}  // namespace
}  // namespace twill
