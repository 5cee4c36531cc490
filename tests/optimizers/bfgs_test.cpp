// BFGS specifics: the strong Wolfe conditions hold at every accepted step (asserted on the
// exposed line-search data, which is checked against independent evaluations), the update
// formula and its safeguard, and the eq. 6.20 scaling reproduced step by step.
#include "optimizers/bfgs.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <memory>

#include "tests/optimizers/test_problems.hpp"

namespace twill {
namespace {

using testing::ExponentialFit;
using testing::LeastSquaresTestProblem;
using testing::Rosenbrock;
using testing::ScaledQuadratic;

struct Case {
  std::string label;
  std::unique_ptr<LeastSquaresTestProblem> problem;
  Eigen::VectorXd start;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  out.push_back({"rosenbrock-2", std::make_unique<Rosenbrock>(2), Rosenbrock::start(2)});
  out.push_back({"rosenbrock-10", std::make_unique<Rosenbrock>(10), Rosenbrock::start(10)});
  out.push_back(
      {"quadratic-1e6", std::make_unique<ScaledQuadratic>(10, 1e6), Eigen::VectorXd::Zero(10)});
  out.push_back({"exp-fit", std::make_unique<ExponentialFit>(), ExponentialFit::start()});
  return out;
}

TEST(Bfgs, StrongWolfeConditionsHoldAtEveryAcceptedStep) {
  for (const double c2 : {0.9, 0.1}) {  // N&W's quasi-Newton value, and a tight one (more zooms)
    for (auto& c : cases()) {
      SCOPED_TRACE(c.label + ", c2 = " + std::to_string(c2));
      BfgsOptions options;
      options.c2 = c2;
      const OptimizerResult result = Bfgs(options).minimize(*c.problem, c.start);
      ASSERT_EQ(result.status, OptimizerStatus::converged) << result.message;
      const auto& searches = result.summary.line_searches;
      const auto& trace = result.summary.trace;
      const auto& iterates = c.problem->iterates;
      ASSERT_EQ(searches.size(), static_cast<std::size_t>(result.summary.iterations));
      int evaluations = 1;  // x0
      for (std::size_t k = 0; k < searches.size(); ++k) {
        const LineSearchRecord& s = searches[k];
        EXPECT_EQ(s.iteration, static_cast<int>(k) + 1);
        EXPECT_FALSE(s.step_limited);
        EXPECT_LT(s.dphi_0, 0.0);
        EXPECT_GT(s.alpha, 0.0);
        // Sufficient decrease (N&W 3.7a) and strong curvature (3.7b).
        EXPECT_LE(s.phi_alpha, s.phi_0 + options.c1 * s.alpha * s.dphi_0) << "step " << k + 1;
        EXPECT_LE(std::abs(s.dphi_alpha), c2 * std::abs(s.dphi_0)) << "step " << k + 1;
        // The data describe the actual iterates: φ(0) = f(x_k), φ(α) = f(x_{k+1}), and with
        // p = (x_{k+1} − x_k)/α: φ'(0) = ∇f(x_k)ᵀp, φ'(α) = ∇f(x_{k+1})ᵀp.
        EXPECT_EQ(s.phi_0, trace[k].value);
        EXPECT_EQ(s.phi_alpha, trace[k + 1].value);
        const Eigen::VectorXd p = (iterates[k + 1] - iterates[k]) / s.alpha;
        Eigen::VectorXd g0, g1;
        c.problem->evaluate(iterates[k], &g0);
        c.problem->evaluate(iterates[k + 1], &g1);
        // (x_{k+1} − x_k)/α loses digits to cancellation once steps are tiny next to x.
        const double cancellation = 4.0 * std::numeric_limits<double>::epsilon() *
                                    (iterates[k].norm() + iterates[k + 1].norm()) / s.alpha;
        const double scale = 1e-9 * g0.norm() * p.norm() + g0.norm() * cancellation;
        EXPECT_NEAR(s.dphi_0, g0.dot(p), scale);
        EXPECT_NEAR(s.dphi_alpha, g1.dot(p),
                    1e-9 * g1.norm() * p.norm() + g1.norm() * cancellation);
        evaluations += s.evaluations;
      }
      EXPECT_EQ(evaluations, result.summary.objective_evaluations);
    }
  }
}

TEST(Bfgs, UpdateSatisfiesTheSecantEquationAndKeepsPositiveDefiniteness) {
  const int n = 5;
  Eigen::MatrixXd H = Eigen::MatrixXd::Identity(n, n) * 0.3;
  H(0, 1) = H(1, 0) = 0.1;
  const Eigen::VectorXd s = Eigen::VectorXd::LinSpaced(n, 0.5, -0.3);
  const Eigen::VectorXd y = Eigen::VectorXd::LinSpaced(n, 1.0, 0.2) + 0.1 * s;
  ASSERT_GT(y.dot(s), 0.0);
  EXPECT_TRUE(bfgs_update(H, s, y, 1e-8));
  EXPECT_LE((H * y - s).lpNorm<Eigen::Infinity>(), 1e-14);  // N&W eq. 6.15 for H
  EXPECT_LE((H - H.transpose()).lpNorm<Eigen::Infinity>(), 1e-15);
  EXPECT_EQ(Eigen::LLT<Eigen::MatrixXd>(H).info(), Eigen::Success);
}

TEST(Bfgs, UpdateIsSkippedWithoutEnoughCurvature) {
  const Eigen::MatrixXd H0 = Eigen::MatrixXd::Identity(3, 3);
  const Eigen::Vector3d s(1.0, 0.0, 0.0);
  Eigen::MatrixXd H = H0;
  // yᵀs < 0 (would destroy positive definiteness).
  EXPECT_FALSE(bfgs_update(H, s, Eigen::Vector3d(-1.0, 0.0, 0.0), 1e-8));
  EXPECT_EQ(H, H0);
  // yᵀs = 1e-9 ‖s‖‖y‖ ≤ ε ‖s‖‖y‖ with ε = 1e-8: skipped; with ε = 1e-10: updated.
  const Eigen::Vector3d y(1e-9, 1.0, 0.0);
  EXPECT_FALSE(bfgs_update(H, s, y, 1e-8));
  EXPECT_EQ(H, H0);
  EXPECT_TRUE(bfgs_update(H, s, y, 1e-10));
}

// Reproduces the first two steps by hand: step 1 along −∇f(x0) (H = I), then H rescaled to
// (yᵀs / yᵀy) I (N&W eq. 6.20) and updated (eq. 6.17), step 2 along −H ∇f(x1).
TEST(Bfgs, SecondStepUsesTheScaledInitialHessian) {
  Rosenbrock problem(2);
  BfgsOptions options;
  options.max_iterations = 2;
  const OptimizerResult result = Bfgs(options).minimize(problem, Rosenbrock::start(2));
  ASSERT_EQ(result.summary.iterations, 2);
  const auto& x = problem.iterates;
  Eigen::VectorXd g0, g1;
  problem.evaluate(x[0], &g0);
  problem.evaluate(x[1], &g1);
  // Step 1: −g0 times α, with the first trial α = 1/‖g0‖ (moves one unit).
  const Eigen::VectorXd s = x[1] - x[0];
  EXPECT_NEAR(s.normalized().dot(-g0.normalized()), 1.0, 1e-14);
  // Step 2.
  const Eigen::VectorXd y = g1 - g0;
  Eigen::MatrixXd H = (y.dot(s) / y.squaredNorm()) * Eigen::MatrixXd::Identity(2, 2);
  ASSERT_TRUE(bfgs_update(H, s, y, 1e-8));
  const Eigen::VectorXd expected = x[1] - result.summary.line_searches[1].alpha * (H * g1);
  EXPECT_LE((x[2] - expected).lpNorm<Eigen::Infinity>(), 1e-13);
  // Without the rescaling the step would differ visibly.
  Eigen::MatrixXd unscaled = Eigen::MatrixXd::Identity(2, 2);
  bfgs_update(unscaled, s, y, 1e-8);
  EXPECT_GT(((unscaled * g1).normalized() - (H * g1).normalized()).norm(), 1e-3);
}

TEST(Bfgs, BoundLimitedStepsLandOnTheBound) {
  Rosenbrock problem(2);
  problem.set_bounds(Eigen::Vector2d(-5.0, -5.0), Eigen::Vector2d(0.5, 5.0));
  const OptimizerResult result = Bfgs().minimize(problem, Rosenbrock::start(2));
  ASSERT_EQ(result.status, OptimizerStatus::converged) << result.message;
  int limited = 0;
  for (const auto& s : result.summary.line_searches) {
    EXPECT_LE(s.phi_alpha, s.phi_0 + 1e-4 * s.alpha * s.dphi_0);  // sufficient decrease always
    if (s.step_limited) {
      ++limited;
      EXPECT_EQ(problem.iterates[s.iteration][0], 0.5);  // exactly on the bound
      EXPECT_LT(s.dphi_alpha, 0.0);  // still descending: that is why it was limited
    } else {
      EXPECT_LE(std::abs(s.dphi_alpha), 0.9 * std::abs(s.dphi_0));
    }
  }
  EXPECT_GE(limited, 1);
  EXPECT_EQ(result.x[0], 0.5);
  EXPECT_NEAR(result.x[1], 0.25, 1e-8);
}

}  // namespace
}  // namespace twill
