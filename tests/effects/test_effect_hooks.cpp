// The effects' law and observable hooks (effects/effect_experiment.hpp), registry-driven over
// every registered effect, experiment and discretisation: neutral parameters are the paper's
// model (values and the fit's derivatives to round-off), and the derivatives in every effect
// parameter, in the law's stiffnesses and in the strip angle match central differences of
// re-solves. Then each effect's own physics and data predicate.
#include <gtest/gtest.h>

#include <cstdio>

#include "core/fit_objective.hpp"
#include "effects/effect_experiment.hpp"
#include "effects/hysteresis/hysteresis.hpp"
#include "effects/poisson/poisson.hpp"
#include "effects/rate_dependence/rate_dependence.hpp"
#include "tests/support/acting_effects.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

using namespace twill::testing;

// Loading, then part of the way back down: path effects differ on the way down.
constexpr double kRate_mm_min = 300;  // ASTM D5035's 300 mm/min

class EveryEffectHook : public ::testing::TestWithParam<EffectCase> {
 protected:
  static constexpr double kAngle_deg = 45.0;  // every deformation mode strained
  double step_ = 0;

  // The case's experiment (small run, with an unloading tail on strips) for material k.
  std::unique_ptr<Experiment> experiment(const MaterialParameters& k, double angle_deg = kAngle_deg) {
    ExperimentInput input;
    input.label = GetParam().effect + " on " + GetParam().experiment;
    input.angle_deg = angle_deg;
    input.start = k;
    input.rate_mm_min = kRate_mm_min;
    std::unique_ptr<Experiment> bare = small_experiment(GetParam().experiment, GetParam().discretization, input, &step_);
    if (!bare) return nullptr;
    input.schedule = bare->schedule();
    if (bare->schedule_quantity() == "extension_mm") input.schedule.push_back(0.5 * input.schedule.back());
    input.discretization = factory_for(GetParam().discretization);
    const std::optional<SmallRun> run = small_run(bare->schedule_quantity());
    input.cells_across = run->cells_across;
    input.cells_along = run->cells_along;
    input.solver = tight_solver(run->gradient_tolerance);
    // Measured values (any non-zero ones) so that the fit objective has residuals.
    input.measured = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(input.schedule.size()));
    return create_experiment(registry(), default_choice(registry_category::kExperiment, GetParam().experiment), input);
  }
};

TEST_P(EveryEffectHook, NeutralParametersAreThePapersModel) {
  const MaterialParameters paper = paper_material();
  MaterialParameters with = paper;
  with.effects = {default_choice(registry_category::kEffect, GetParam().effect)};
  std::unique_ptr<Experiment> bare = experiment(paper), neutral = experiment(with);
  ASSERT_TRUE(bare && neutral);
  // As the fit sees the model: a11, a22, G12 and η1 free, a12 tied (ParameterMap).
  const std::vector<std::string> free = {"a11_Pa", "a22_Pa", "G12_Pa", "eta1.*"};
  auto residuals = [&](std::unique_ptr<Experiment>& e, const MaterialParameters& k, Eigen::MatrixXd* j) {
    std::shared_ptr<Predictor> p(std::move(e));
    FitObjective objective(ParameterMap(k, free), {p});
    Eigen::VectorXd r;
    objective.residuals(objective.map().initial_x(), &r, j);
    return r;
  };
  Eigen::MatrixXd j_bare, j_neutral;
  const Eigen::VectorXd r_bare = residuals(bare, paper, &j_bare);
  const Eigen::VectorXd r_neutral = residuals(neutral, with, &j_neutral);
  ASSERT_EQ(r_bare.size(), r_neutral.size());
  ASSERT_GT(r_bare.size(), 0);
  const double round_off = 1e-12;
  EXPECT_LE((r_bare - r_neutral).cwiseAbs().maxCoeff(), round_off * (1 + r_bare.cwiseAbs().maxCoeff()));
  EXPECT_LE((j_bare - j_neutral).cwiseAbs().maxCoeff(), round_off * (1 + j_bare.cwiseAbs().maxCoeff()));
}

TEST_P(EveryEffectHook, DerivativesMatchFiniteDifferencesOfResolves) {
  MaterialParameters k = paper_material();
  k.effects = {acting(GetParam().effect)};
  // Every parameter of the effect, and the law entries a hook may depend on.
  std::vector<int> flat;
  for (const EffectParameter& p : effect_parameters(k.effects, registry())) flat.push_back(k.index_of(p.name));
  for (const char* name : {"thickness_m", "a11_Pa", "a22_Pa", "G12_Pa"}) flat.push_back(k.index_of(name));
  std::unique_ptr<Experiment> e = experiment(k);
  ASSERT_TRUE(e);
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(e->predict(k, flat, &values, &jacobian, &message)) << message;
  auto values_at = [&](int j, double dk) {
    MaterialParameters moved = k;
    Eigen::VectorXd f = k.to_flat();
    f[j] += dk;
    moved.set_from_flat(f);
    Eigen::VectorXd out;
    EXPECT_TRUE(experiment(moved)->predict(moved, {}, &out, nullptr, &message)) << message;
    return out;
  };
  Comparison comparison;
  const Eigen::VectorXd k_flat = k.to_flat();
  const std::vector<std::string> names = k.parameter_names();
  for (size_t c = 0; c < flat.size(); ++c) {
    const double h = relative_step(k_flat[flat[c]], step_);
    const Eigen::VectorXd fd_h = (values_at(flat[c], h) - values_at(flat[c], -h)) / (2 * h);
    const Eigen::VectorXd fd_h2 = (values_at(flat[c], h / 2) - values_at(flat[c], -h / 2)) / h;
    for (Eigen::Index i = 0; i < values.size(); ++i)
      comparison.compare(names[static_cast<size_t>(flat[c])] + " [" + std::to_string(i) + "]",
                         jacobian(i, static_cast<Eigen::Index>(c)) * std::abs(h), fd_h[i] * std::abs(h),
                         fd_h2[i] * std::abs(h), std::abs(values[i]) * step_);
  }
  std::printf("[measured] %s via %s on %s: %d/%d compared (worst rel %.2e)\n", GetParam().effect.c_str(),
              GetParam().experiment.c_str(), GetParam().discretization.c_str(), comparison.counted, comparison.total,
              comparison.worst);
  EXPECT_EQ(comparison.counted, comparison.total);
}

TEST_P(EveryEffectHook, AngleDerivativeIncludesTheObservableHook) {
  MaterialParameters k = paper_material();
  k.effects = {acting(GetParam().effect)};
  std::unique_ptr<Experiment> e = experiment(k);
  ASSERT_TRUE(e);
  const auto available = e->setup_sensitivities();
  if (std::find(available.begin(), available.end(), setup_quantity::kAngle) == available.end())
    GTEST_SKIP() << GetParam().experiment << " reports no angle derivative";
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(e->predict_setup_derivatives(k, {setup_quantity::kAngle}, &values, &jacobian, &message)) << message;
  auto values_at = [&](double dtheta) {
    Eigen::VectorXd out;
    EXPECT_TRUE(experiment(k, kAngle_deg + dtheta)->predict(k, {}, &out, nullptr, &message)) << message;
    return out;
  };
  const double h = 0.02;  // deg, as the per-run offset test
  const Eigen::VectorXd fd_h = (values_at(h) - values_at(-h)) / (2 * h);
  const Eigen::VectorXd fd_h2 = (values_at(h / 2) - values_at(-h / 2)) / h;
  Comparison comparison;
  for (Eigen::Index i = 0; i < values.size(); ++i)
    comparison.compare("dθ [" + std::to_string(i) + "]", jacobian(i, 0), fd_h[i], fd_h2[i], std::abs(values[i]));
  EXPECT_EQ(comparison.counted, comparison.total);
}

INSTANTIATE_TEST_SUITE_P(Registered, EveryEffectHook, ::testing::ValuesIn(every_effect_case()),
                         [](const auto& info) { return effect_case_name(info.param); });

// ---- the flat vector carries the effects' parameters -----------------------------------------

TEST(EffectFlatVector, EffectParametersAreTheLastBlockAndAFitCanFreeThem) {
  MaterialParameters k = paper_material();
  const int law = k.flat_size();
  k.effects = {default_choice(registry_category::kEffect, Hysteresis::kName)};
  const std::vector<EffectParameter> parameters = effect_parameters(k.effects, registry());
  ASSERT_EQ(k.flat_size(), law + static_cast<int>(parameters.size()));
  EXPECT_EQ(k.parameter_names()[static_cast<size_t>(law)], parameters[0].name);
  Eigen::VectorXd f = k.to_flat();
  f[law] = 123.0;
  k.set_from_flat(f);
  EXPECT_EQ(k.effects[0].options.get_double("warp_friction_N_m"), 123.0);
  std::vector<ParameterRange> ranges;
  for (const EffectParameter& p : parameters) ranges.push_back({p.name, p.lower, p.upper, 0});
  ParameterMap::Options options;
  options.ranges = ranges;
  const ParameterMap map(k, {"hysteresis.*"}, options);
  EXPECT_EQ(map.dimension(), static_cast<int>(parameters.size()));
  EXPECT_EQ(map.lower_bounds()[0], 0.0);
  EXPECT_DOUBLE_EQ(map.upper_bounds()[0] * 123.0, Hysteresis::kMaxFriction_N_m);
}

TEST(EffectUnits, CompoundAndDimensionlessSuffixes) {
  EXPECT_EQ(unit_of("warp_friction_N_m"), "N/m");
  EXPECT_EQ(unit_of("saturation_strain"), "1");
  EXPECT_EQ(unit_of("coupling_ratio"), "1");
  EXPECT_EQ(unit_of("relaxation_s"), "s");
  EXPECT_EQ(unit_of("spread_deg"), "deg");
}

// ---- each effect's physics ---------------------------------------------------------------------

// A warp strip (4x6, the first registered discretisation) for material k at `schedule`.
std::unique_ptr<Experiment> warp_strip(const MaterialParameters& k, const std::vector<double>& schedule,
                                       double rate_mm_min) {
  ExperimentInput input;
  input.label = "warp";
  input.angle_deg = 90;
  input.start = k;
  input.schedule = schedule;
  input.rate_mm_min = rate_mm_min;
  input.cells_across = 4;
  input.cells_along = 6;
  input.discretization = factory_for(registered(registry_category::kDiscretization).front());
  return create_experiment(registry(), default_choice(registry_category::kExperiment, "tensile"), input);
}

// The clamp force of that strip at each extension.
Eigen::VectorXd warp_curve(const MaterialParameters& k, const std::vector<double>& schedule, double rate_mm_min) {
  Eigen::VectorXd f;
  std::string message;
  EXPECT_TRUE(warp_strip(k, schedule, rate_mm_min)->predict(k, {}, &f, nullptr, &message)) << message;
  return f;
}

TEST(HysteresisEffect, UnloadingCarriesLessForceByTwiceTheSaturatedFriction) {
  MaterialParameters k = paper_material();
  const double friction_N_m = 200, width_m = 0.05;
  ComponentChoice h = default_choice(registry_category::kEffect, Hysteresis::kName);
  h.options.set("warp_friction_N_m", friction_N_m);
  k.effects = {h};
  // Up to 6 mm (ε = 8 %, 16 e_c: saturated), back to 3 mm (ε down 4 %: saturated again).
  const Eigen::VectorXd f = warp_curve(k, {3.0, 6.0, 3.0}, 0);
  // At the same extension the elastic part is the same: the gap is the friction from +σ_s
  // to −σ_s, 2 σ_s W, short of it by 3 exp(−Δε/e_c) σ_s W = 1.0e-3 σ_s W (Δε = 4 %: the
  // unsaturated rise to 3 mm and the unsaturated return), so the bar is 2e-3 of σ_s W.
  EXPECT_NEAR(f[0] - f[2], 2 * friction_N_m * width_m, 2e-3 * friction_N_m * width_m);
  Dataset no_unloading;
  no_unloading.tensile.resize(1);
  no_unloading.tensile[0].runs.resize(1);
  const Hysteresis effect{HysteresisOptions{}};
  EXPECT_NE(effect.missing_data(no_unloading).find("unloading"), std::string::npos);
  no_unloading.tensile[0].runs[0].has_unloading = true;
  EXPECT_EQ(effect.missing_data(no_unloading), "");
}

TEST(RateDependenceEffect, FasterPullsCarryMoreForceAndSlowOnesRelax) {
  MaterialParameters k = paper_material();
  ComponentChoice r = default_choice(registry_category::kEffect, RateDependence::kName);
  r.options.set("viscous_ratio", 0.2);
  k.effects = {r};
  const std::vector<double> schedule = {1.0, 2.0};
  const Eigen::VectorXd fast = warp_curve(k, schedule, 3000), slow = warp_curve(k, schedule, 30);
  MaterialParameters elastic = paper_material();
  const Eigen::VectorXd quasistatic = warp_curve(elastic, schedule, 0);
  EXPECT_GT(fast[1], slow[1]);
  EXPECT_GT(slow[1], quasistatic[1]);
  // Fast (Δt = 0.04 s ≪ t_r = 10 s): the branch is a spring, F_v → β τ a11 W ε.
  const double spring_limit = 0.2 * k.thickness_m * k.a11_Pa * 0.05 * (2.0 / 75.0);
  EXPECT_NEAR(fast[1] - quasistatic[1], spring_limit, 0.01 * spring_limit);
  // Without a clock the effect cannot predict: an error saying what to give.
  try {
    warp_curve(k, schedule, 0);
    ADD_FAILURE() << "no clock accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rate_mm_min"), std::string::npos) << e.what();
  }
  Dataset one_speed;
  one_speed.tensile.resize(2);
  one_speed.tensile[0].rate_mm_min = 300;
  one_speed.tensile[1].rate_mm_min = 300;
  one_speed.tensile[0].runs.resize(1);
  one_speed.tensile[1].runs.resize(1);
  const RateDependence effect{RateDependenceOptions{}};
  EXPECT_NE(effect.missing_data(one_speed).find("two or more"), std::string::npos);
  // One speed, but a run that comes back down: its loop shows the branch.
  TensileRun& loop = one_speed.tensile[0].runs[0];
  loop.has_unloading = true;  // as the reader sets it for rows that come back down
  EXPECT_EQ(effect.missing_data(one_speed), "");
  loop.has_unloading = false;
  EXPECT_NE(effect.missing_data(one_speed).find("two or more"), std::string::npos);
  one_speed.tensile[1].rate_mm_min = 200;  // the paper's two speeds
  EXPECT_EQ(effect.missing_data(one_speed), "");
}

TEST(PoissonEffect, TheCouplingRatioSetsA12AndTheStripNarrowsMoreWithIt) {
  MaterialParameters k = paper_material();
  ComponentChoice c = default_choice(registry_category::kEffect, Poisson::kName);
  c.options.set("coupling_ratio", 0.8);
  k.effects = {c};
  const MaterialParameters adjusted = law_adjusted(k, registry());
  EXPECT_DOUBLE_EQ(adjusted.a12_Pa, 0.8 * std::min(k.a11_Pa, k.a22_Pa));
  auto lateral = [](const MaterialParameters& m) {
    const ExperimentRun run = warp_strip(m, {3.0}, 0)->simulate(m);
    for (const auto& [name, values] : run.extras)
      if (name == "lateral_strain") return values.at(0);
    ADD_FAILURE() << "no lateral strain";
    return 0.0;
  };
  EXPECT_LT(lateral(k), lateral(paper_material()));  // narrower: a more negative lateral strain
  // η2''(0) = c: η2 = ((1+x)^(1+c) − 1)/(1+c). Below the compression cutoff the coupling's slope
  // is η2'(u) = 1 + c u with u = Ẽ11 Ẽ22 < 0: a positive c weakens the coupling as the strip
  // stretches, so the strip narrows less (docs/effects/poisson.md).
  MaterialParameters curved = k;
  curved.effects[0].options.set("coupling_curvature", 20.0);
  const MaterialParameters curved_law = law_adjusted(curved, registry());
  EXPECT_EQ(curved_law.eta2, (Curve{{1.0}, {21.0}}));
  EXPECT_EQ(adjusted.eta2, Curve::linear());  // the neutral curvature is the paper's η2 exactly
  EXPECT_GT(lateral(curved), lateral(k));
  Dataset no_lateral;
  no_lateral.tensile.resize(1);
  no_lateral.tensile[0].runs.resize(1);
  const Poisson effect{PoissonOptions{}};
  EXPECT_NE(effect.missing_data(no_lateral).find("lateral"), std::string::npos);
  no_lateral.tensile[0].runs[0].lateral_strain = {0.0};
  EXPECT_EQ(effect.missing_data(no_lateral), "");
}

}  // namespace
}  // namespace twill
