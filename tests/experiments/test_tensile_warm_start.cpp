// TensileExperiment::run_from: points warm-started from q_i + ∂q_i/∂k·Δk (the fit's
// evaluations) are solved in parallel chunks, one solver per chunk. The curve must not depend
// on how many threads solved it, must equal a continuation run at the same parameters, and a
// point whose guess fails must be retried from the previous equilibrium in schedule order.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <tbb/global_control.h>

#include "core/params_io.hpp"
#include "core/registry.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"
#include "experiments/predictors.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {
namespace {

// Converged far below the comparison's tolerance, so differences are the solver's round-off.
EquilibriumOptions tight_solver() {
  EquilibriumOptions o;
  o.gradient_tolerance = 1e-11;
  o.decrement_tolerance = 1e-22;
  return o;
}

struct WarmStartCase {
  const std::vector<double> extensions_mm{1.0, 2.0, 4.0, 6.0, 8.0, 10.0};
  DiscretizationFactory factory = [](const StripSpec& s, const MaterialParameters& p) -> std::unique_ptr<Discretization> {
    return std::make_unique<CatmullClarkKL>(s, p);
  };
  TensileSetup setup;
  MaterialParameters anchor, moved;
  std::vector<Eigen::VectorXd> guesses;

  WarmStartCase() {
    setup.angle_deg = 45.0;  // off-axis: every parameter family is active
    setup.cells_across = 4;
    setup.cells_along = 6;
    anchor = read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/poplin/params.yaml");
    moved = anchor;
    moved.G12_Pa *= 1.02;  // an optimiser's step
    TensileExperiment e(setup, factory, anchor, tight_solver());
    const int g12 = anchor.index_of("G12_Pa");
    e.set_sensitivity_parameters({g12});
    e.set_keep_states(true);
    const TensileCurve c = e.run(extensions_mm);
    if (!c.completed) throw std::runtime_error("anchor curve: " + c.message);
    const double dk = moved.G12_Pa - anchor.G12_Pa;
    for (const TensilePoint& p : c.points) guesses.push_back(p.q + p.dq_dk.col(0) * dk);
  }

  TensileCurve warm(const std::vector<Eigen::VectorXd>& starts, int threads) const {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    TensileExperiment e(setup, factory, moved, tight_solver());
    return e.run_from(extensions_mm, starts);
  }
};

constexpr double kAgreement = 1e-9;  // relative force; the solves converge to ~1e-11 of F

TEST(TensileWarmStart, SameCurveForAnyNumberOfThreadsAndAsByContinuation) {
  const WarmStartCase c;
  TensileExperiment reference(c.setup, c.factory, c.moved, tight_solver());
  const TensileCurve continued = reference.run(c.extensions_mm);
  ASSERT_TRUE(continued.completed) << continued.message;
  for (int threads : {1, 2, 3}) {
    const TensileCurve warm = c.warm(c.guesses, threads);
    ASSERT_TRUE(warm.completed) << warm.message;
    ASSERT_EQ(warm.points.size(), c.extensions_mm.size());
    for (size_t i = 0; i < warm.points.size(); ++i) {
      EXPECT_EQ(warm.points[i].extension_mm, c.extensions_mm[i]);
      EXPECT_NEAR(warm.points[i].force_N, continued.points[i].force_N, kAgreement * continued.points[i].force_N)
          << threads << " threads, point " << i;
    }
    // Warm starts this close need fewer Newton iterations than continuation.
    EXPECT_LT(warm.newton_iterations, continued.newton_iterations) << threads << " threads";
  }
}

TEST(TensileWarmStart, FailedGuessIsRetriedFromThePreviousEquilibrium) {
  const WarmStartCase c;
  std::vector<Eigen::VectorXd> starts = c.guesses;
  starts[3].setConstant(std::numeric_limits<double>::quiet_NaN());  // its solve fails at once
  const TensileCurve one = c.warm(c.guesses, 2);
  const TensileCurve retried = c.warm(starts, 2);
  ASSERT_TRUE(retried.completed) << retried.message;
  for (size_t i = 0; i < retried.points.size(); ++i)
    EXPECT_NEAR(retried.points[i].force_N, one.points[i].force_N, kAgreement * one.points[i].force_N) << i;

  // The first point has no previous equilibrium: the curve ends there, with the reason.
  starts = c.guesses;
  starts[0].setConstant(std::numeric_limits<double>::quiet_NaN());
  const TensileCurve failed = c.warm(starts, 2);
  EXPECT_FALSE(failed.completed);
  EXPECT_TRUE(failed.points.empty());
  EXPECT_NE(failed.message.find("extension 1.0"), std::string::npos) << failed.message;
}

// Without derivatives run_from's points confirm convergence with the previous iterate's
// factor (EquilibriumSolver::set_solution_factor_needed, docs/solver.md): a warm guess this
// close takes one Newton step, and no second factorisation; with a sensitivity asked for,
// the factor at the solution is kept. The forces are the same either way.
TEST(TensileWarmStart, WithoutDerivativesPointsConvergeWithThePreviousFactor) {
  const WarmStartCase c;
  const TensileCurve lazy = c.warm(c.guesses, 2);
  TensileExperiment exact_experiment(c.setup, c.factory, c.moved, tight_solver());
  exact_experiment.set_sensitivity_parameters({c.moved.index_of("G12_Pa")});
  const TensileCurve exact = exact_experiment.run_from(c.extensions_mm, c.guesses);
  ASSERT_TRUE(lazy.completed && exact.completed) << lazy.message << exact.message;
  int lazy_factors = 0, exact_factors = 0;
  for (size_t i = 0; i < lazy.points.size(); ++i) {
    EXPECT_TRUE(lazy.points[i].solve.decrement_from_previous_factor) << i << ": " << lazy.points[i].solve.message;
    EXPECT_FALSE(exact.points[i].solve.decrement_from_previous_factor) << i;
    EXPECT_NEAR(lazy.points[i].force_N, exact.points[i].force_N, kAgreement * exact.points[i].force_N) << i;
    lazy_factors += lazy.points[i].solve.factorizations;
    exact_factors += exact.points[i].solve.factorizations;
  }
  EXPECT_EQ(lazy_factors, exact_factors - static_cast<int>(lazy.points.size()));
}

// The bend stage rescales the thickness and every membrane stiffness together (τ·k fixed):
// the planar strip's equilibria do not move, but G12 — a column of a bias anchor — changes
// by the factor. The warm start must not extrapolate along that column (a wrong guess, then
// a branch retry from the flat strip: 13.6 s instead of 2.0 s for canvas's final bias curve);
// the anchor's states are the guesses, and the forces equal a fresh solve's.
TEST(TensileWarmStart, AThicknessRescaleKeepsTheAnchorsStates) {
  const WarmStartCase c;
  const std::vector<int> flat = {c.anchor.index_of("G12_Pa"), c.anchor.index_of("eta4.alpha[0]")};
  const Eigen::VectorXd measured = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(c.extensions_mm.size()));
  const auto predictor = [&] { return TensilePredictor("bias", c.setup, c.factory, c.anchor, c.extensions_mm, measured, tight_solver()); };
  constexpr double kThicknessRatio = 0.8;
  MaterialParameters rescaled = c.anchor;
  rescaled.thickness_m *= kThicknessRatio;
  for (double MaterialParameters::*stiffness :
       {&MaterialParameters::a11_Pa, &MaterialParameters::a12_Pa, &MaterialParameters::a22_Pa, &MaterialParameters::G12_Pa})
    rescaled.*stiffness /= kThicknessRatio;
  Eigen::VectorXd anchored, warm_values, cold;
  Eigen::MatrixXd jacobian;
  std::string message;
  TensilePredictor warm = predictor();
  ASSERT_TRUE(warm.predict(c.anchor, flat, &anchored, &jacobian, &message)) << message;
  const long anchor_solves = warm.equilibrium_solves();
  ASSERT_TRUE(warm.predict(rescaled, {}, &warm_values, nullptr, &message)) << message;
  EXPECT_EQ(warm.branch_retries(), 0);
  EXPECT_EQ(warm.equilibrium_solves() - anchor_solves, static_cast<long>(c.extensions_mm.size()));  // no retry
  TensilePredictor fresh = predictor();
  ASSERT_TRUE(fresh.predict(rescaled, {}, &cold, nullptr, &message)) << message;
  for (Eigen::Index i = 0; i < cold.size(); ++i) EXPECT_NEAR(warm_values[i], cold[i], kAgreement * std::abs(cold[i])) << i;
}

// TensilePredictor across evaluations (an optimiser's): a warm run that stays within the
// anchor's first-order prediction is kept; one that leaves it by more than 5 % of the run's
// largest force is solved again from the flat strip, so the value at k is the loading path's
// whatever point the predictor was anchored at before (path independence).
TEST(TensileWarmStart, AWarmRunOffTheAnchorsPredictionIsSolvedAgainFromTheFlatStrip) {
  const WarmStartCase c;
  const std::vector<int> flat = {c.anchor.index_of("G12_Pa"), c.anchor.index_of("eta4.alpha[0]")};
  const Eigen::VectorXd measured = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(c.extensions_mm.size()));
  const auto predictor = [&] { return TensilePredictor("bias", c.setup, c.factory, c.anchor, c.extensions_mm, measured, tight_solver()); };
  MaterialParameters near = c.moved, far = c.anchor;
  far.eta4.alpha[0] *= 4;  // the shear curve's exponent 20 → 80: the force is far from linear in it
  Eigen::VectorXd values, cold, v;
  Eigen::MatrixXd jacobian, j;
  std::string message;

  TensilePredictor warm = predictor();
  ASSERT_TRUE(warm.predict(c.anchor, flat, &v, &j, &message)) << message;
  ASSERT_TRUE(warm.predict(near, flat, &values, &jacobian, &message)) << message;  // an accepted step
  EXPECT_EQ(warm.branch_retries(), 0);
  ASSERT_TRUE(warm.predict(far, flat, &values, &jacobian, &message)) << message;
  EXPECT_EQ(warm.branch_retries(), 1);
  TensilePredictor fresh = predictor();
  ASSERT_TRUE(fresh.predict(far, flat, &cold, &j, &message)) << message;
  for (Eigen::Index i = 0; i < cold.size(); ++i) EXPECT_EQ(values[i], cold[i]) << i;
}

// The effects' block of k's flat vector is not the law's: an effect fit moves its entries at
// every trial (a strip-path effect adds to the observables outside the strip; the strip sees
// only law entries). Counted as moved outside the anchor's columns, they skipped the
// first-order guess and the branch test, and a rate fit's joint phase ran on a bias strip
// left on another branch (docs/fitting.md §5). With them moving too, a warm run off the
// anchor's prediction is still solved again from the flat strip, and a near step is not.
TEST(TensileWarmStart, TheEffectsEntriesMovingDoNotSkipTheBranchTest) {
  const WarmStartCase c;
  const auto with_rate = [](MaterialParameters k, double viscous_ratio) {
    ComponentChoice rate{registry_category::kEffect, "rate-dependence", {}};
    rate.options.set("viscous_ratio", viscous_ratio);
    rate.options.set("relaxation_s", 10.0);
    k.effects = {rate};
    return k;
  };
  const MaterialParameters anchor = with_rate(c.anchor, 0.0);
  const std::vector<int> flat = {anchor.index_of("G12_Pa"), anchor.index_of("eta4.alpha[0]")};
  const Eigen::VectorXd measured = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(c.extensions_mm.size()));
  TensilePredictor warm("bias", c.setup, c.factory, anchor, c.extensions_mm, measured, tight_solver());
  MaterialParameters near = with_rate(c.moved, 0.1), far = with_rate(c.anchor, 0.2);
  far.eta4.alpha[0] *= 4;  // as in the test above: far from linear in it
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(warm.predict(anchor, flat, &values, &jacobian, &message)) << message;
  ASSERT_TRUE(warm.predict(near, flat, &values, &jacobian, &message)) << message;
  EXPECT_EQ(warm.branch_retries(), 0);
  ASSERT_TRUE(warm.predict(far, flat, &values, &jacobian, &message)) << message;
  EXPECT_EQ(warm.branch_retries(), 1);
}

}  // namespace
}  // namespace twill
