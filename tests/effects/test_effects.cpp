// Effects (effects/effect.hpp): every registered effect's parameter derivatives through its
// hooks against re-solves (registry-driven, on every registered experiment and
// discretisation that can report them), params.yaml's strictly validated `effects:` key, the
// effects' flat parameter view, and the misalignment effect's data predicate and estimate.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/input_error.hpp"
#include "core/yaml_reader.hpp"
#include "effects/effect.hpp"
#include "effects/misalignment.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

using namespace twill::testing;

// ---- registry-driven: derivatives in every per-run parameter through the set-up hook ----------


class EveryEffect : public ::testing::TestWithParam<EffectCase> {
 protected:
  static constexpr double kAngle_deg = 45.0;
  std::unique_ptr<Effect> effect() const {
    return registry().create<EffectFactories>(registry_category::kEffect,
                                              default_choice(registry_category::kEffect, GetParam().effect));
  }
  // The experiment of one run with the effect's set-up hook applied at per-run values `v`.
  std::unique_ptr<Experiment> run_at(const Effect& e, const Eigen::VectorXd& v, std::vector<SetupChange>* changes) const {
    ExperimentInput input;
    input.label = GetParam().effect + " on " + GetParam().experiment;
    input.angle_deg = kAngle_deg;
    input.start = poplin();
    const std::vector<SetupChange> c = e.adjust_setup(v, &input);
    if (changes) *changes = c;
    return small_experiment(GetParam().experiment, GetParam().discretization, input);
  }
};

TEST_P(EveryEffect, PerRunParameterDerivativesMatchFiniteDifferencesOfResolves) {
  const std::unique_ptr<Effect> e = effect();
  const std::vector<EffectParameter> parameters = e->per_run_parameters();
  if (parameters.empty()) GTEST_SKIP() << GetParam().effect << " has no per-run parameters";
  // Values inside the bounds, away from the default so that a sign error shows.
  Eigen::VectorXd v(static_cast<Eigen::Index>(parameters.size()));
  for (size_t j = 0; j < parameters.size(); ++j)
    v[static_cast<Eigen::Index>(j)] = 0.1 * std::min(parameters[j].upper, 10.0);
  std::vector<SetupChange> changes;
  std::unique_ptr<Experiment> experiment = run_at(*e, v, &changes);
  ASSERT_TRUE(experiment);
  if (changes.empty()) GTEST_SKIP() << GetParam().effect << " changes no set-up (its hooks are checked elsewhere)";
  std::vector<std::string> quantities;
  for (const SetupChange& c : changes) quantities.push_back(c.quantity);
  for (const std::string& q : quantities) {
    const auto available = experiment->setup_sensitivities();
    if (std::find(available.begin(), available.end(), q) == available.end())
      GTEST_SKIP() << GetParam().experiment << " reports no derivative in " << q;
  }
  const MaterialParameters p = poplin();
  Eigen::VectorXd values;
  Eigen::MatrixXd setup_jacobian;
  std::string message;
  ASSERT_TRUE(experiment->predict_setup_derivatives(p, quantities, &values, &setup_jacobian, &message)) << message;
  // Chain rule: d(observable)/d(v_j) = Σ_c d(observable)/d(quantity_c) · d(quantity_c)/d(v_j).
  Eigen::MatrixXd analytic = Eigen::MatrixXd::Zero(values.size(), v.size());
  for (size_t c = 0; c < changes.size(); ++c)
    analytic += setup_jacobian.col(static_cast<Eigen::Index>(c)) * changes[c].gradient.transpose();

  auto values_at = [&](Eigen::Index j, double dv) {
    Eigen::VectorXd w = v;
    w[j] += dv;
    Eigen::VectorXd out;
    EXPECT_TRUE(run_at(*e, w, nullptr)->predict(p, {}, &out, nullptr, &message)) << message;
    return out;
  };
  Comparison comparison;
  for (Eigen::Index j = 0; j < v.size(); ++j) {
    const double h = 0.02;  // per unit of the parameter (deg for offsets)
    const Eigen::VectorXd fd_h = (values_at(j, h) - values_at(j, -h)) / (2 * h);
    const Eigen::VectorXd fd_h2 = (values_at(j, h / 2) - values_at(j, -h / 2)) / h;
    for (Eigen::Index i = 0; i < values.size(); ++i)
      comparison.compare(parameters[static_cast<size_t>(j)].name + " " + experiment->observable() + "[" +
                             std::to_string(i) + "]",
                         analytic(i, j), fd_h[i], fd_h2[i], std::abs(values[i]));
  }
  std::printf("[measured] %s via %s on %s: %d/%d compared (worst rel %.2e)\n", GetParam().effect.c_str(),
              GetParam().experiment.c_str(), GetParam().discretization.c_str(), comparison.counted, comparison.total,
              comparison.worst);
  EXPECT_EQ(comparison.counted, comparison.total);
}

TEST_P(EveryEffect, ModelParametersHaveUnitsAndBounds) {
  // The flat view's contract: every double parameter is named with its unit and bounded.
  const ComponentChoice choice = default_choice(registry_category::kEffect, GetParam().effect);
  for (const EffectParameter& p : effect_parameters({choice}, registry())) {
    EXPECT_FALSE(p.unit.empty()) << p.name << ": name the unit as a suffix, e.g. spread_deg";
    EXPECT_TRUE(std::isfinite(p.lower) && std::isfinite(p.upper)) << p.name << ": give bounds";
    EXPECT_GE(p.value, p.lower);
    EXPECT_LE(p.value, p.upper);
  }
  for (const EffectParameter& p : effect()->per_run_parameters()) {
    EXPECT_FALSE(p.unit.empty()) << p.name;
    EXPECT_TRUE(std::isfinite(p.lower) && std::isfinite(p.upper)) << p.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Registered, EveryEffect, ::testing::ValuesIn(every_effect_case()),
                         [](const auto& info) { return effect_case_name(info.param); });

// ---- params.yaml's effects: key ----------------------------------------------------------------

class ParamsEffects : public ::testing::Test {
 protected:
  static std::filesystem::path dir() {
    return std::filesystem::temp_directory_path() / ("twill_effects_" + std::to_string(::getpid()));
  }
  void TearDown() override { std::filesystem::remove_all(dir()); }  // nothing left in /tmp
  std::string write(const std::string& effects_text) {
    std::filesystem::create_directories(dir());
    const std::string path = (dir() / "params.yaml").string();
    std::string text = params_to_yaml(poplin());
    text += effects_text;
    std::ofstream(path) << text;
    return path;
  }
  static std::string error_of(const std::string& path, const Registry* r) {
    try {
      read_params_file(path, r);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(ParamsEffects, ReadWriteRoundTrip) {
  const MaterialParameters p = read_params_file(write("effects:\n  misalignment: {spread_deg: 1.5}\n"), &registry());
  ASSERT_EQ(p.effects.size(), 1u);
  EXPECT_EQ(p.effects[0].name, "misalignment");
  EXPECT_EQ(p.effects[0].options.get_double("spread_deg"), 1.5);
  const std::string again = write("");  // the paper's model: no effects key written
  EXPECT_EQ(params_to_yaml(read_params_file(again)).find("effects"), std::string::npos);
  std::ofstream(again) << params_to_yaml(p);
  const MaterialParameters back = read_params_file(again, &registry());
  ASSERT_EQ(back.effects.size(), 1u);
  EXPECT_EQ(back.effects[0], p.effects[0]);
  // A parameter left out takes the effect's default; an empty mapping is the paper's model.
  EXPECT_EQ(read_params_file(write("effects:\n  misalignment: {}\n"), &registry()).effects[0].options.get_double("spread_deg"), 0.0);
  EXPECT_TRUE(read_params_file(write("effects: {}\n"), &registry()).effects.empty());
}

TEST_F(ParamsEffects, StrictErrorsNameFileLineAndKey) {
  const std::string unknown_effect = error_of(write("effects:\n  sag: {strength: 1}\n"), &registry());
  EXPECT_NE(unknown_effect.find("unknown effect 'sag'"), std::string::npos) << unknown_effect;
  EXPECT_NE(unknown_effect.find("misalignment"), std::string::npos) << unknown_effect;  // lists the known
  EXPECT_NE(unknown_effect.find("params.yaml:14"), std::string::npos) << unknown_effect;  // 12 lines, effects:, sag:
  const std::string unknown_key = error_of(write("effects:\n  misalignment: {spread: 1}\n"), &registry());
  EXPECT_NE(unknown_key.find("spread"), std::string::npos) << unknown_key;
  EXPECT_NE(unknown_key.find("spread_deg"), std::string::npos) << unknown_key;  // lists the known
  const std::string out_of_bounds = error_of(write("effects:\n  misalignment: {spread_deg: 11}\n"), &registry());
  EXPECT_NE(out_of_bounds.find("effects.misalignment.spread_deg"), std::string::npos) << out_of_bounds;
  const std::string no_registry = error_of(write("effects:\n  misalignment: {spread_deg: 1}\n"), nullptr);
  EXPECT_NE(no_registry.find("unknown effect"), std::string::npos) << no_registry;
}

// ---- the flat view ---------------------------------------------------------------------------

TEST(EffectParameters, FlatViewReadsAndWritesWithBounds) {
  std::vector<ComponentChoice> effects = {default_choice(registry_category::kEffect, "misalignment")};
  const std::vector<EffectParameter> flat = effect_parameters(effects, registry());
  ASSERT_EQ(flat.size(), 1u);
  EXPECT_EQ(flat[0].name, "misalignment.spread_deg");
  EXPECT_EQ(flat[0].unit, "deg");
  EXPECT_EQ(flat[0].lower, 0.0);
  EXPECT_EQ(flat[0].upper, Misalignment::kMaxOffsetDeg);
  set_effect_parameters(Eigen::VectorXd::Constant(1, 2.5), registry(), &effects);
  EXPECT_EQ(effects[0].options.get_double("spread_deg"), 2.5);
  EXPECT_THROW(set_effect_parameters(Eigen::VectorXd::Constant(1, -1.0), registry(), &effects), InputError);
  EXPECT_THROW(set_effect_parameters(Eigen::VectorXd::Zero(2), registry(), &effects), std::invalid_argument);
}

// ---- misalignment --------------------------------------------------------------------------------

TEST(Misalignment, NeedsRepeatsAndEstimatesTheSpreadAsTheRmsOffset) {
  const Misalignment m(MisalignmentOptions{});
  Dataset one_run;
  one_run.tensile.resize(1);
  one_run.tensile[0].runs.resize(1);
  EXPECT_NE(m.missing_data(one_run).find("repeats"), std::string::npos);
  Dataset repeats = one_run;
  repeats.tensile[0].runs.resize(2);
  EXPECT_EQ(m.missing_data(repeats), "");
  const Options model = default_options(Misalignment::schema(), nullptr);
  const Options estimated = m.estimated_from_runs({Eigen::VectorXd::Constant(1, 3.0), Eigen::VectorXd::Constant(1, -4.0)}, model);
  EXPECT_DOUBLE_EQ(estimated.get_double("spread_deg"), std::sqrt((9.0 + 16.0) / 2));
  ExperimentInput input;
  input.angle_deg = 22.5;
  const auto changes = m.adjust_setup(Eigen::VectorXd::Constant(1, 0.5), &input);
  EXPECT_DOUBLE_EQ(input.angle_deg, 23.0);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].quantity, setup_quantity::kAngle);
}

}  // namespace
}  // namespace twill
