// Ipopt specifics (optimizers/ipopt_optimizer.hpp): the adapter's first-step rule.
#include "optimizers/ipopt_optimizer.hpp"

#include <gtest/gtest.h>

#include "tests/optimizers/test_problems.hpp"

namespace twill {
namespace {

using testing::LeastSquaresTestProblem;

// f = 100 ‖x − x*‖² with x* = (1000, 1000, 1000): far from the start 0 and steep (‖∇f‖∞ 2e5),
// so a long first step along −∇f is still downhill and a line search accepts all of it.
class FarSteepBowl : public LeastSquaresTestProblem {
 public:
  FarSteepBowl() : LeastSquaresTestProblem(3) {}
  void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    r = kSlope * (x - minimum());
    if (J) *J = kSlope * Eigen::MatrixXd::Identity(3, 3);
  }
  static Eigen::VectorXd minimum() { return Eigen::VectorXd::Constant(3, 1000.0); }

 private:
  static constexpr double kSlope = 10.0;
};

// Ipopt's own B0 = I makes its first step the (scaled) gradient: here it took a step of
// length 100 with gradient-based scaling and 1562 without (measured with B0 = I), downhill
// all the way; on the poplin bias the accepted cut was still a jump into another basin
// (62.9 % error, the #12 acceptance row). The adapter scales B0 so that the first step is at
// most 1 long, as BFGS's (bfgs.hpp).
TEST(Ipopt, FirstStepIsAtMostOneLongWhateverTheGradient) {
  for (const std::string scaling : {"gradient-based", "none"}) {
    SCOPED_TRACE(scaling);
    FarSteepBowl problem;
    IpoptOptions options;
    options.nlp_scaling_method = scaling;
    const OptimizerResult result = IpoptOptimizer(options).minimize(problem, Eigen::VectorXd::Zero(3));
    ASSERT_GE(result.summary.trace.size(), 2u);
    const double first_step = result.summary.trace[1].step_length;
    EXPECT_GT(first_step, 0.0);
    EXPECT_LE(first_step, 1.0 + 1e-12);
    EXPECT_LT((result.x - problem.minimum()).lpNorm<Eigen::Infinity>(), 1e-6);  // still gets there
  }
}

}  // namespace
}  // namespace twill
