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

#include "core/discretization_registry.hpp"
#include "core/params_io.hpp"
#include "core/sensitivity.hpp"
#include "discretizations/catmull_clark_kl/register_catmull_clark_kl.hpp"
#include "discretizations/triangle_shell/register_triangle_shell.hpp"
#include "experiments/experiment.hpp"
#include "experiments/register_experiments.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {
namespace {

const Registry& registry() {
  static const Registry r = [] {
    Registry reg;
    register_catmull_clark_kl(reg);
    register_triangle_shell(reg);
    register_experiments(reg);
    return reg;
  }();
  return r;
}

std::vector<std::string> registered(const char* category) {
  std::vector<std::string> names;
  for (const RegistryEntry& e : registry().find_category(category)->entries()) names.push_back(e.name);
  return names;
}

// A registered implementation with its default options.
ComponentChoice default_choice(const char* category, const std::string& name) {
  return {category, name, default_options(registry().find_category(category)->at(name).options, nullptr)};
}

DiscretizationFactory factory_for(const std::string& name) {
  const ComponentChoice choice = default_choice(registry_category::kDiscretization, name);
  return [choice](const StripSpec& s, const MaterialParameters& p) {
    return registry().create<DiscretizationFactories>(registry_category::kDiscretization, choice, s, p);
  };
}

// Re-solves must be converged far below the FD step's signal: Newton converges
// quadratically, so tightening the tolerance costs one or two iterations per point.
EquilibriumOptions tight_solver(double gradient_tolerance) {
  EquilibriumOptions o;
  o.gradient_tolerance = gradient_tolerance;
  o.decrement_tolerance = 1e-22;
  return o;
}

MaterialParameters poplin() {
  // Degree-2 warp and weft curves, so μ[1] is a free entry of the flat vector.
  return read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/poplin/params.yaml");
}

// A small run of an experiment, by the quantity it schedules. An experiment scheduling a
// quantity not listed here fails the tests below until one is added.
struct SmallRun {
  std::vector<double> schedule;
  int cells_across = 0, cells_along = 0;
  /// Re-solve tolerance and relative FD step. The cantilever's force scale is its weight
  /// (mN): the round-off floor of ‖g_f‖ (≈ 1e-13 N, measured) is then 1e-10 of it, so its
  /// re-solve tolerance is 1e-9 and its FD step larger (1e-3 relative) to stay above the
  /// re-solve noise; a strip's forces are newtons, so 1e-11 and 1e-4 there.
  double gradient_tolerance = 0, relative_step = 0;
};

std::optional<SmallRun> small_run(const std::string& schedule_quantity) {
  if (schedule_quantity == "extension_mm") return SmallRun{{1.0, 3.0, 6.0}, 4, 6, 1e-11, 1e-4};
  if (schedule_quantity == "overhang_mm") return SmallRun{{40.0}, 2, 16, 1e-9, 1e-3};
  return std::nullopt;
}

// The flat entries whose derivatives are checked: a stiffness, a curve weight and exponent,
// the shear stiffness, the thickness and the density (gravity).
std::vector<int> checked_entries(const MaterialParameters& p) {
  const FlatLayout layout(p);
  return {FlatLayout::kA11, layout.eta1, FlatLayout::alpha_offset(layout.eta1, 2) + 1, FlatLayout::kG12,
          FlatLayout::kThickness, FlatLayout::kDensity};
}

// FD step: a fraction of the parameter's magnitude (1 when it is zero).
double relative_step(double value, double fraction) {
  return fraction * (value != 0 ? std::abs(value) : 1.0);
}

// Compares analytic derivatives with central differences at steps h and h/2. Counts how many
// comparisons counted (where the FD is accurate, see the header).
struct Comparison {
  int counted = 0;
  int total = 0;
  double worst = 0;
};

void compare(const std::string& what, double analytic, double fd_h, double fd_h2, double scale, Comparison* c) {
  ++c->total;
  const double fd_error = std::abs(fd_h - fd_h2);
  if (fd_error > 1e-6 * scale) return;
  ++c->counted;
  const double rel = std::abs(analytic - fd_h2) / scale;
  c->worst = std::max(c->worst, rel);
  EXPECT_LE(rel, 1e-5) << what << ": analytic " << analytic << ", FD " << fd_h2 << " (FD self-difference "
                       << fd_error << ")";
}

struct Case {
  std::string experiment, discretization;
};

std::vector<Case> every_case() {
  std::vector<Case> cases;
  for (const std::string& e : registered(registry_category::kExperiment))
    for (const std::string& d : registered(registry_category::kDiscretization)) cases.push_back({e, d});
  return cases;
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string n = info.param.experiment + "_" + info.param.discretization;
  for (char& ch : n)
    if (ch == '-') ch = '_';
  return n;
}

class EveryExperiment : public ::testing::TestWithParam<Case> {
 protected:
  // The experiment on a coarse mesh at a bias-like angle (every stiffness entry matters).
  static constexpr double kAngle_deg = 45.0;

  std::unique_ptr<Experiment> make(const MaterialParameters& p, double angle_deg) const {
    ExperimentInput input;
    input.label = GetParam().experiment;
    input.angle_deg = angle_deg;
    input.discretization = factory_for(GetParam().discretization);
    input.start = p;
    const ComponentChoice choice = default_choice(registry_category::kExperiment, GetParam().experiment);
    auto create = [&](const ExperimentInput& in) {
      return registry().create<ExperimentFactories>(registry_category::kExperiment, choice, in);
    };
    const std::string quantity = create(input)->schedule_quantity();  // empty schedule: simulation only
    const std::optional<SmallRun> run = small_run(quantity);
    if (!run) ADD_FAILURE() << "no small run for an experiment scheduling '" << quantity << "': add one";
    if (!run) return nullptr;
    input.schedule = run->schedule;
    input.cells_across = run->cells_across;
    input.cells_along = run->cells_along;
    input.solver = tight_solver(run->gradient_tolerance);
    step_ = run->relative_step;
    return create(input);
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
      compare(experiment->label() + " " + experiment->observable() + "[" + std::to_string(i) + "] d/d" +
                  base.parameter_names()[static_cast<size_t>(index)],
              jacobian(i, static_cast<Eigen::Index>(j)), fd_h[i], fd_h2[i],
              // Scale: the observable's own size per relative parameter change, so a derivative
              // that is legitimately ~0 is compared on the scale of the others.
              std::abs(values[i]) / std::abs(relative_step(k0[index], 1.0)), &c);
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
    compare(experiment->label() + " d" + experiment->observable() + "[" + std::to_string(i) + "]/dθ", jacobian(i, 0),
            fd_h[i], fd_h2[i], std::abs(values[i]) /* per degree */, &c);
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
      compare(disc + " lateral strain d/d" + base.parameter_names()[static_cast<size_t>(index)] + " at " +
                  std::to_string(extensions[i]) + " mm",
              p.dlateral_strain_dk[static_cast<Eigen::Index>(j)],
              (plus.points[i].lateral_strain - minus.points[i].lateral_strain) / (2 * h),
              (plus2.points[i].lateral_strain - minus2.points[i].lateral_strain) / h,
              std::abs(p.lateral_strain) / std::abs(relative_step(k0[index], 1.0)), &lateral);
    }
  }
  std::printf("[measured] %s: lateral %d/%d compared (worst %.2e)\n", disc.c_str(), lateral.counted, lateral.total,
              lateral.worst);
  EXPECT_GE(lateral.counted, lateral.total * 3 / 4);
}

INSTANTIATE_TEST_SUITE_P(Registered, LateralStrainSensitivity,
                         ::testing::ValuesIn(registered(registry_category::kDiscretization)),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

}  // namespace
}  // namespace twill
