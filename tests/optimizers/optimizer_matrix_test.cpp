// One test matrix (PolyFEM style): every optimiser configuration × every test problem, each
// reaching the known minimum to a stated tolerance with the default stopping tolerances.
// Also checks the bookkeeping every optimiser shares: counted evaluations match the problem's
// own count, the trace matches the progress reports, status and summary are consistent.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>

#include "tests/optimizers/optimizer_cases.hpp"
#include "tests/optimizers/test_problems.hpp"

namespace twill {
namespace {

using testing::ExponentialFit;
using testing::LeastSquaresTestProblem;
using testing::optimizer_cases;
using testing::OptimizerCase;
using testing::Rosenbrock;
using testing::ScaledQuadratic;

struct ProblemCase {
  std::string label;
  std::function<std::unique_ptr<LeastSquaresTestProblem>()> make;
  Eigen::VectorXd start, minimum;
};

std::vector<ProblemCase> problem_cases() {
  const ScaledQuadratic quadratic(10, 1e6);
  return {
      {"rosenbrock-2", [] { return std::make_unique<Rosenbrock>(2); }, Rosenbrock::start(2),
       Rosenbrock::minimum(2)},
      {"rosenbrock-10", [] { return std::make_unique<Rosenbrock>(10); }, Rosenbrock::start(10),
       Rosenbrock::minimum(10)},
      {"quadratic-1e6", [] { return std::make_unique<ScaledQuadratic>(10, 1e6); },
       Eigen::VectorXd::Zero(10), quadratic.minimum()},
      {"exp-fit", [] { return std::make_unique<ExponentialFit>(); }, ExponentialFit::start(),
       ExponentialFit::minimum()},
  };
}

// MMA and CCSAQ (the conservative convex separable approximations of NLopt).
bool is_ccsa(const OptimizerCase& o) {
  return o.label == "nlopt algorithm=LD_MMA" || o.label == "nlopt algorithm=LD_CCSAQ";
}

// Accuracy required of ‖x − x*‖∞ (docs/optimizers.md): 1e-6 for gradient-based methods at the
// default tolerances; 1e-5 for MMA and CCSAQ (their conservative convex approximations creep
// along the Rosenbrock valley: measured 4e-7) and for derivative-free methods (BOBYQA measured
// 1e-9; looser because nothing but the trust-region radius or simplex size bounds the error).
double tolerance(const OptimizerCase& o) { return o.derivative_free || is_ccsa(o) ? 1e-5 : 1e-6; }

// Combinations left out, with the reason (measured with 1e5 evaluations, step_tolerance 1e-10,
// docs/optimizers.md "Other NLopt algorithms"): every registered configuration runs, these
// pairs do not reach the minimum within the matrix's budget of 20000 evaluations.
bool skipped(const OptimizerCase& o, const ProblemCase& p) {
  const std::string& a = o.label;
  // MMA / CCSAQ do not get close on the condition-1e6 quadratic (|x - x*| = 0.33 / 0.48).
  if (is_ccsa(o) && p.label == "quadratic-1e6") return true;
  // COBYLA needs 38030 evaluations on rosenbrock-2 and does not converge on the other two.
  if (a == "nlopt algorithm=LN_COBYLA" && p.label != "exp-fit") return true;
  // Nelder-Mead stops on its function test at |x - x*| = 5.7 on rosenbrock-10.
  if (a == "nlopt algorithm=LN_NELDERMEAD" && p.label == "rosenbrock-10") return true;
  // Subplex reaches the limit on rosenbrock-10 (1.7e-1) and the quadratic (7.4e-1).
  if (a == "nlopt algorithm=LN_SBPLX" && (p.label == "rosenbrock-10" || p.label == "quadratic-1e6")) return true;
  return false;
}

TEST(OptimizerMatrix, EveryOptimizerReachesEveryKnownMinimum) {
  std::printf(
      "| optimizer | problem | status | iterations | evaluations | gradients | time ms | |x-x*|inf "
      "|\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const auto& o : optimizer_cases()) {
    for (const auto& p : problem_cases()) {
      if (skipped(o, p)) continue;
      SCOPED_TRACE(o.label + " on " + p.label);
      auto problem = p.make();
      auto optimizer = o.make();
      const OptimizerResult result = optimizer->minimize(*problem, p.start);
      const double error = (result.x - p.minimum).lpNorm<Eigen::Infinity>();
      std::printf("| %s | %s | %s | %d | %d | %d | %.1f | %.1e |\n", o.label.c_str(),
                  p.label.c_str(), to_string(result.status).c_str(), result.summary.iterations,
                  result.summary.objective_evaluations, result.summary.gradient_evaluations,
                  1e3 * result.summary.wall_time_s, error);

      EXPECT_EQ(result.status, OptimizerStatus::converged) << result.message;
      EXPECT_LE(error, tolerance(o)) << result.message;
      // Bookkeeping shared by every optimiser.
      EXPECT_EQ(result.summary.objective_evaluations, problem->calls);
      EXPECT_EQ(result.summary.gradient_evaluations, problem->gradient_calls);
      if (o.derivative_free) {
        EXPECT_EQ(problem->gradient_calls, 0);
      }
      EXPECT_LE(result.summary.objective_evaluations,
                optimizer->resolved_options().get_int("max_evaluations"));
      ASSERT_FALSE(result.summary.trace.empty());
      EXPECT_EQ(result.summary.iterations, static_cast<int>(result.summary.trace.size()) - 1);
      ASSERT_EQ(problem->progress_reports.size(), result.summary.trace.size());
      for (std::size_t i = 0; i < result.summary.trace.size(); ++i) {
        const IterationRecord& record = result.summary.trace[i];
        EXPECT_EQ(problem->progress_reports[i].iteration, static_cast<int>(i));
        EXPECT_EQ(problem->progress_reports[i].value, record.value);
        // The trace describes the iterates the problem was shown.
        Eigen::VectorXd g;
        EXPECT_NEAR(problem->evaluate(problem->iterates[i], &g), record.value,
                    1e-12 * (1.0 + std::abs(record.value)));
        if (!o.derivative_free) {
          EXPECT_NEAR(record.gradient_norm, g.lpNorm<Eigen::Infinity>(),
                      1e-12 * (1.0 + g.lpNorm<Eigen::Infinity>()));
        }
        if (i > 0) {
          EXPECT_NEAR(record.step_length,
                      (problem->iterates[i] - problem->iterates[i - 1]).lpNorm<Eigen::Infinity>(),
                      1e-14);
        }
      }
      EXPECT_EQ(result.summary.trace.front().step_length, 0.0);
      EXPECT_EQ(problem->iterates.front(), p.start);
      Eigen::VectorXd g;
      const double f = problem->evaluate(result.x, &g);
      EXPECT_NEAR(result.summary.final_value, f, 1e-12 * (1.0 + std::abs(f)));
      if (!o.derivative_free) {
        EXPECT_NEAR(result.summary.final_gradient_norm, g.lpNorm<Eigen::Infinity>(),
                    1e-12 * (1.0 + g.lpNorm<Eigen::Infinity>()));
      }
      EXPECT_GT(result.summary.wall_time_s, 0.0);
    }
  }
}

// Rosenbrock with x0 ≤ 0.5: for fixed x0 the first term vanishes at x1 = x0², and (1 − x0)²
// decreases up to the bound, so the minimum is (0.5, 0.25) with f = 0.25 and an active bound
// (∂f/∂x0 = −1 there, pushing outward).
TEST(OptimizerMatrix, EveryOptimizerFindsTheMinimumOnABound) {
  for (const auto& o : optimizer_cases()) {
    SCOPED_TRACE(o.label);
    Rosenbrock problem(2);
    problem.set_bounds(Eigen::Vector2d(-5.0, -5.0), Eigen::Vector2d(0.5, 5.0));
    const OptimizerResult result = o.make()->minimize(problem, Rosenbrock::start(2));
    EXPECT_EQ(result.status, OptimizerStatus::converged) << result.message;
    EXPECT_LE((result.x - Eigen::Vector2d(0.5, 0.25)).lpNorm<Eigen::Infinity>(),
              o.derivative_free ? 1e-5 : 1e-6)
        << result.message;
    EXPECT_LE(result.x[0], 0.5);
    for (const auto& x : problem.iterates) EXPECT_LE(x[0], 0.5);
    EXPECT_NEAR(result.summary.final_value, 0.25, 1e-6);
    // The projected gradient vanishes although ∂f/∂x0 = −1.
    if (!o.derivative_free) {
      EXPECT_LE(result.summary.final_gradient_norm, 1e-6);
    }
  }
}

TEST(OptimizerMatrix, EvaluationBudgetIsAHardCap) {
  for (const auto& o : optimizer_cases()) {
    SCOPED_TRACE(o.label);
    Rosenbrock problem(10);
    const OptimizerResult result =
        o.make({"max_evaluations=10"})->minimize(problem, Rosenbrock::start(10));
    EXPECT_EQ(result.status, OptimizerStatus::iteration_limit) << result.message;
    EXPECT_LE(problem.calls, 10);
    EXPECT_EQ(result.summary.objective_evaluations, problem.calls);
    EXPECT_TRUE(result.x.allFinite());
    EXPECT_LE(result.summary.final_value, problem.evaluate(Rosenbrock::start(10), nullptr));
  }
}

TEST(OptimizerMatrix, IterationLimitIsReported) {
  for (const auto& o : optimizer_cases()) {
    if (o.name == "nlopt") continue;  // NLopt has no iterations (nlopt_optimizer.hpp)
    SCOPED_TRACE(o.label);
    Rosenbrock problem(2);
    const OptimizerResult result =
        o.make({"max_iterations=3"})->minimize(problem, Rosenbrock::start(2));
    EXPECT_EQ(result.status, OptimizerStatus::iteration_limit) << result.message;
    EXPECT_EQ(result.summary.iterations, 3);
    EXPECT_EQ(result.summary.trace.size(), 4u);
  }
}

}  // namespace
}  // namespace twill
