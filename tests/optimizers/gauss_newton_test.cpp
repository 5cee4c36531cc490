// Gauss–Newton specifics (optimizers/gauss_newton.hpp): the first-step bound of its
// Levenberg–Marquardt damping.
#include "optimizers/gauss_newton.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/optimizers/test_problems.hpp"

namespace twill {
namespace {

using testing::FarSteepBowl;

// On a linear least-squares problem the undamped model step is the whole way to the minimum
// (‖h‖ = 1732 here); λ₀ = 1e-3 barely shortens it. With the bound (1, as the fit's degree
// raises set it) the first step is at most 1 long, as BFGS's and Ipopt's, and the run still
// gets there; without it (0, the default) the first step is the long one.
TEST(GaussNewton, FirstStepIsAtMostMaxFirstStepLong) {
  for (const double bound : {1.0, 0.0}) {
    SCOPED_TRACE(bound);
    FarSteepBowl problem;
    GaussNewtonOptions options;
    options.max_first_step = bound;
    const OptimizerResult result = GaussNewton(options).minimize(problem, Eigen::VectorXd::Zero(3));
    const double first_step = testing::first_step_length(result);  // ∞-norm ≤ Euclidean
    ASSERT_FALSE(std::isnan(first_step)) << "no step taken";
    if (bound > 0)
      EXPECT_LE(first_step, bound + 1e-12);
    else
      EXPECT_GT(first_step, 900.0);
    EXPECT_EQ(result.status, OptimizerStatus::converged) << result.message;
    EXPECT_LT((result.x - problem.minimum()).lpNorm<Eigen::Infinity>(), 1e-6);
  }
}

}  // namespace
}  // namespace twill
