// Parameter sensitivities (paper Eq. 6, core/sensitivity.hpp) against central finite
// differences of full re-solves, for every registered experiment on every registered
// discretisation (both lists come from the registry: a new experiment or discretisation is
// tested the day it is registered):
//   - the observables' derivatives in the material parameters (Experiment::predict's Jacobian);
//   - the derivatives in each set-up quantity the experiment reports (today the strip angle,
//     which the validation offsets and the misalignment effect chain through);
// and, for the tensile strip's engine, the lateral strain's derivatives (an extra output, not
// an observable of the interface).
//
// Acceptance (issue #5): relative agreement ≤ 1e-5 wherever the finite difference is itself
// accurate. "Accurate" is measured, not assumed: the central difference is taken at steps h
// and h/2; their disagreement estimates the FD error (truncation O(h²) plus re-solve noise
// / h), and a comparison counts only where that estimate is below 1e-6 of the value. The tests
// also require that most comparisons count, so they cannot pass by skipping.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>

#include "core/sensitivity.hpp"
#include "experiments/tensile_strip.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

using namespace twill::testing;

// The flat entries whose derivatives are checked: a stiffness, a curve weight and exponent,
// the shear stiffness, the thickness and the density (gravity).
std::vector<int> checked_entries(const MaterialParameters& p) {
  const FlatLayout layout(p);
  return {FlatLayout::kA11, layout.eta1, FlatLayout::alpha_offset(layout.eta1, 2) + 1, FlatLayout::kG12,
          FlatLayout::kThickness, FlatLayout::kDensity};
}

struct Case {
  std::string experiment, discretization;
};

// GoogleTest's description of a case (instead of its bytes).
void PrintTo(const Case& c, std::ostream* os) { *os << c.experiment << " on " << c.discretization; }

std::vector<Case> every_case() {
  std::vector<Case> cases;
  for (const std::string& e : registered(registry_category::kExperiment))
    for (const std::string& d : registered(registry_category::kDiscretization)) cases.push_back({e, d});
  return cases;
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  return test_name(info.param.experiment + "_" + info.param.discretization);
}

class EveryExperiment : public ::testing::TestWithParam<Case> {
 protected:
  // The experiment on a coarse mesh at a bias-like angle (every stiffness entry matters).
  static constexpr double kAngle_deg = 45.0;

  std::unique_ptr<Experiment> make(const MaterialParameters& p, double angle_deg) const {
    ExperimentInput input;
    input.label = GetParam().experiment;
    input.angle_deg = angle_deg;
    input.start = p;
    return small_experiment(GetParam().experiment, GetParam().discretization, input, &step_);
  }
  mutable double step_ = 0;
};

TEST_P(EveryExperiment, ObservableDerivativesMatchFiniteDifferencesOfResolves) {
  const MaterialParameters base = poplin();
  const std::vector<int> entries = checked_entries(base);
  std::unique_ptr<Experiment> experiment = make(base, kAngle_deg);
  ASSERT_TRUE(experiment);
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(experiment->predict(base, entries, &values, &jacobian, &message)) << message;
  ASSERT_EQ(jacobian.cols(), static_cast<Eigen::Index>(entries.size()));

  const Eigen::VectorXd k0 = base.to_flat();
  auto values_at = [&](int index, double dk) {
    MaterialParameters p = base;
    Eigen::VectorXd k = k0;
    k[index] += dk;
    p.set_from_flat(k);
    Eigen::VectorXd v;
    EXPECT_TRUE(experiment->predict(p, {}, &v, nullptr, &message)) << message;
    return v;
  };
  Comparison c;
  for (size_t j = 0; j < entries.size(); ++j) {
    const int index = entries[j];
    const double h = relative_step(k0[index], step_);
    const Eigen::VectorXd fd_h = (values_at(index, h) - values_at(index, -h)) / (2 * h);
    const Eigen::VectorXd fd_h2 = (values_at(index, h / 2) - values_at(index, -h / 2)) / h;
    for (Eigen::Index i = 0; i < values.size(); ++i)
      c.compare(experiment->label() + " " + experiment->observable() + "[" + std::to_string(i) + "] d/d" +
                  base.parameter_names()[static_cast<size_t>(index)],
              jacobian(i, static_cast<Eigen::Index>(j)), fd_h[i], fd_h2[i],
              // Scale: the observable's own size per relative parameter change, so a derivative
              // that is legitimately ~0 is compared on the scale of the others.
              std::abs(values[i]) / std::abs(relative_step(k0[index], 1.0)));
  }
  std::printf("[measured] %s on %s: %d/%d compared (worst rel %.2e)\n", GetParam().experiment.c_str(),
              GetParam().discretization.c_str(), c.counted, c.total, c.worst);
  // Density matters to the cantilever only and the curve entries little to a small bend, so
  // not every comparison counts; most must.
  EXPECT_GE(c.counted, c.total / 2);
}

TEST_P(EveryExperiment, SetupDerivativesMatchFiniteDifferencesOfResolves) {
  // The derivative in each set-up quantity the experiment reports (dF/dθ: Eq. 6 with ∂g/∂θ
  // from two turned copies of the mesh), against central differences of whole re-solves of
  // the experiment built at θ ± h and θ ± h/2.
  const MaterialParameters base = poplin();
  std::unique_ptr<Experiment> experiment = make(base, kAngle_deg);
  ASSERT_TRUE(experiment);
  const std::vector<std::string> quantities = experiment->setup_sensitivities();
  if (quantities.empty()) GTEST_SKIP() << GetParam().experiment << " reports no set-up derivatives";
  for (const std::string& quantity : quantities)
    ASSERT_EQ(quantity, setup_quantity::kAngle) << "a set-up quantity this test cannot vary: add it";
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(experiment->predict_setup_derivatives(base, quantities, &values, &jacobian, &message)) << message;
  auto values_at = [&](double offset_deg) {
    Eigen::VectorXd v;
    EXPECT_TRUE(make(base, kAngle_deg + offset_deg)->predict(base, {}, &v, nullptr, &message)) << message;
    return v;
  };
  const double h = 0.02;  // degrees
  const Eigen::VectorXd fd_h = (values_at(h) - values_at(-h)) / (2 * h);
  const Eigen::VectorXd fd_h2 = (values_at(h / 2) - values_at(-h / 2)) / h;
  Comparison c;
  for (Eigen::Index i = 0; i < values.size(); ++i)
    c.compare(experiment->label() + " d" + experiment->observable() + "[" + std::to_string(i) + "]/dθ", jacobian(i, 0),
            fd_h[i], fd_h2[i], std::abs(values[i]) /* per degree */);
  std::printf("[measured] %s on %s: d/dtheta %d/%d compared (worst rel %.2e)\n", GetParam().experiment.c_str(),
              GetParam().discretization.c_str(), c.counted, c.total, c.worst);
  EXPECT_EQ(c.counted, c.total);
}

INSTANTIATE_TEST_SUITE_P(Registered, EveryExperiment, ::testing::ValuesIn(every_case()), case_name);

// The tensile strip's lateral strain (an extra output of the engine) on every discretisation.
class LateralStrainSensitivity : public ::testing::TestWithParam<std::string> {};

TEST_P(LateralStrainSensitivity, MatchesFiniteDifferencesOfResolves) {
  const std::string disc = GetParam();
  TensileSetup setup;
  setup.angle_deg = 45.0;
  setup.cells_across = 4;
  setup.cells_along = 6;
  const std::vector<double> extensions = {1.0, 3.0, 6.0};
  const MaterialParameters base = poplin();
  std::vector<int> entries = checked_entries(base);
  entries.pop_back();  // density: no gravity in a tensile strip
  TensileExperiment experiment(setup, factory_for(disc), base, tight_solver(1e-11));
  experiment.set_sensitivity_parameters(entries);
  const TensileCurve curve = experiment.run(extensions);
  ASSERT_TRUE(curve.completed) << curve.message;
  experiment.set_sensitivity_parameters({});
  const Eigen::VectorXd k0 = base.to_flat();
  auto rerun = [&](int index, double dk) {
    MaterialParameters p = base;
    Eigen::VectorXd k = k0;
    k[index] += dk;
    p.set_from_flat(k);
    experiment.set_parameters(p);
    TensileCurve c = experiment.run(extensions);
    EXPECT_TRUE(c.completed) << c.message;
    return c;
  };
  Comparison lateral;
  for (size_t j = 0; j < entries.size(); ++j) {
    const int index = entries[j];
    const double h = relative_step(k0[index], 1e-4);
    const TensileCurve plus = rerun(index, h), minus = rerun(index, -h);
    const TensileCurve plus2 = rerun(index, h / 2), minus2 = rerun(index, -h / 2);
    for (size_t i = 0; i < extensions.size(); ++i) {
      const auto& p = curve.points[i];
      lateral.compare(disc + " lateral strain d/d" + base.parameter_names()[static_cast<size_t>(index)] + " at " +
                  std::to_string(extensions[i]) + " mm",
              p.dlateral_strain_dk[static_cast<Eigen::Index>(j)],
              (plus.points[i].lateral_strain - minus.points[i].lateral_strain) / (2 * h),
              (plus2.points[i].lateral_strain - minus2.points[i].lateral_strain) / h,
              std::abs(p.lateral_strain) / std::abs(relative_step(k0[index], 1.0)));
    }
  }
  std::printf("[measured] %s: lateral %d/%d compared (worst %.2e)\n", disc.c_str(), lateral.counted, lateral.total,
              lateral.worst);
  EXPECT_GE(lateral.counted, lateral.total * 3 / 4);
}

INSTANTIATE_TEST_SUITE_P(Registered, LateralStrainSensitivity,
                         ::testing::ValuesIn(registered(registry_category::kDiscretization)),
                         [](const auto& info) { return test_name(info.param); });

}  // namespace
}  // namespace twill
