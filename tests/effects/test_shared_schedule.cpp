// Runs of one strip share a simulation (experiments/shared_schedule.hpp, create_experiments in
// effects/effect_experiment.hpp): each run's predictions and Eq. 6 derivatives are those of its
// own experiment, with and without an effect whose hook depends on the run's clock, for fewer
// equilibrium solves; strips that differ, or schedules that fall, are not shared.
#include <gtest/gtest.h>

#include "effects/effect_experiment.hpp"
#include "experiments/shared_schedule.hpp"
#include "tests/support/acting_effects.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

using namespace twill::testing;

TEST(ScheduleUnion, MergesEqualEntriesAndMapsEachScheduleIntoIt) {
  const ScheduleUnion u = schedule_union({{1, 2, 3}, {2, 4}, {1, 3}});
  EXPECT_EQ(u.entries, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(u.rows, (std::vector<std::vector<int>>{{0, 1, 2}, {1, 3}, {0, 2}}));
  // 3 entries for 8: shared; 4 for 6 is more than half: not.
  EXPECT_TRUE(shares_enough(schedule_union({{1, 2, 3}, {1, 2, 3}, {2, 3}}), {{1, 2, 3}, {1, 2, 3}, {2, 3}}));
  EXPECT_FALSE(shares_enough(schedule_union({{1, 2}, {3, 4}, {1, 3}}), {{1, 2}, {3, 4}, {1, 3}}));
}

// A bias strip (every mode strained) of the first registered discretisation at 4x6.
ExperimentInput bias_run(const MaterialParameters& k, std::vector<double> schedule, double rate_mm_min) {
  ExperimentInput input;
  input.label = "bias at " + std::to_string(rate_mm_min) + " mm/min";
  input.angle_deg = 45;
  input.start = k;
  input.schedule = std::move(schedule);
  input.rate_mm_min = rate_mm_min;
  input.cells_across = 4;
  input.cells_along = 6;
  input.discretization = factory_for(registered(registry_category::kDiscretization).front());
  input.solver = tight_solver(1e-10);
  input.measured = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(input.schedule.size()));
  return input;
}

// Three runs of one strip, two at one speed and one at another that comes back down, on
// overlapping schedules (union 8 entries for 20): each shared run's forces and derivatives
// against its own experiment's (which solves its path in file order), and the solves of both.
void expect_shared_runs_match_their_own(const MaterialParameters& k) {
  const ComponentChoice tensile = default_choice(registry_category::kExperiment, "tensile");
  const std::vector<ExperimentInput> inputs = {bias_run(k, {1, 2, 3, 4, 5, 6, 7, 8}, 300),
                                               bias_run(k, {1, 2, 3, 4, 5, 6}, 300),
                                               bias_run(k, {2, 4, 6, 8, 6, 4}, 30)};
  const auto shared = create_experiments(registry(), tensile, inputs);
  // Law entries, and every effect parameter (the hooks' own derivatives).
  std::vector<int> flat = {FlatLayout::kA11, FlatLayout::kG12, FlatLayout(k).eta4};
  for (int i = FlatLayout(k).effects; i < k.flat_size(); ++i) flat.push_back(i);
  long shared_solves = 0, own_solves = 0;
  std::vector<Eigen::VectorXd> own_forces;
  for (size_t i = 0; i < inputs.size(); ++i) {
    const auto own = create_experiment(registry(), tensile, inputs[i]);
    Eigen::VectorXd f_shared, f_own;
    Eigen::MatrixXd d_shared, d_own;
    std::string message;
    ASSERT_TRUE(shared[i]->predict(k, flat, &f_shared, &d_shared, &message)) << message;
    ASSERT_TRUE(own->predict(k, flat, &f_own, &d_own, &message)) << message;
    ASSERT_EQ(f_shared.size(), static_cast<Eigen::Index>(inputs[i].schedule.size()));
    // Both are equilibria to the solver's tolerance, reached by other paths.
    EXPECT_LT((f_shared - f_own).cwiseAbs().maxCoeff(), 1e-7 * f_own.cwiseAbs().maxCoeff()) << inputs[i].label;
    for (Eigen::Index c = 0; c < d_own.cols(); ++c)  // each parameter on its own scale
      EXPECT_LE((d_shared.col(c) - d_own.col(c)).cwiseAbs().maxCoeff(), 1e-6 * d_own.col(c).cwiseAbs().maxCoeff())
          << inputs[i].label << ", parameter " << k.parameter_names()[static_cast<size_t>(flat[static_cast<size_t>(c)])];
    own_solves += own->equilibrium_solves();
    own_forces.push_back(f_own);
  }
  for (const auto& e : shared) shared_solves += e->equilibrium_solves();
  // One solve per point: the union's 8 once, against 8 + 6 + 6.
  EXPECT_EQ(own_solves, 20);
  EXPECT_EQ(shared_solves, 8);
  for (size_t i = 0; i < inputs.size(); ++i) {
    const ExperimentRun run = shared[i]->simulate(k);
    EXPECT_TRUE(run.completed);
    EXPECT_EQ(run.schedule, inputs[i].schedule);
    EXPECT_LT((run.values - own_forces[i]).cwiseAbs().maxCoeff(), 1e-7 * own_forces[i].cwiseAbs().maxCoeff());
  }
}

TEST(SharedSchedule, EachRunGetsItsOwnForcesAndDerivativesFromOneSimulation) {
  expect_shared_runs_match_their_own(paper_material());
}

// Every registered effect acting (its hooks on each run's own path and clock: a friction loop
// on the way down, a relaxing overstress at each speed).
TEST(SharedSchedule, EveryEffectStillActsOnEachRunsOwnPathAndClock) {
  for (const std::string& effect : registered(registry_category::kEffect)) {
    SCOPED_TRACE(effect);
    MaterialParameters k = paper_material();
    k.effects = {acting(effect)};
    expect_shared_runs_match_their_own(k);
  }
}

TEST(SharedSchedule, OnlyRunsOfTheSameStripShareAndOnlyWhereThatHalvesTheSolves) {
  const MaterialParameters k = paper_material();
  const ComponentChoice tensile = default_choice(registry_category::kExperiment, "tensile");
  ExperimentInput other_angle = bias_run(k, {1, 2, 3}, 300);
  other_angle.angle_deg = 90;
  ExperimentInput narrower = bias_run(k, {1, 2, 3}, 300);
  narrower.width_mm = 25;
  const auto experiments = create_experiments(
      registry(), tensile, {bias_run(k, {1, 2, 3}, 300), bias_run(k, {1, 2, 3, 2}, 30), other_angle, narrower});
  EXPECT_NE(dynamic_cast<ScheduleView*>(experiments[0].get()), nullptr);
  EXPECT_NE(dynamic_cast<ScheduleView*>(experiments[1].get()), nullptr);
  EXPECT_EQ(dynamic_cast<ScheduleView*>(experiments[2].get()), nullptr);
  EXPECT_EQ(dynamic_cast<ScheduleView*>(experiments[3].get()), nullptr);
  // One run up and down once: 3 entries for 5, not worth it; twice: 3 for 9.
  const auto once = create_experiments(registry(), tensile, {bias_run(k, {1, 2, 3, 2, 1}, 300)});
  const auto twice = create_experiments(registry(), tensile, {bias_run(k, {1, 2, 3, 2, 1, 2, 3, 2, 1}, 300)});
  EXPECT_EQ(dynamic_cast<ScheduleView*>(once[0].get()), nullptr);
  EXPECT_NE(dynamic_cast<ScheduleView*>(twice[0].get()), nullptr);
}

}  // namespace
}  // namespace twill
