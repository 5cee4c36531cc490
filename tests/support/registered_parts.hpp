#pragma once
// What the registry-driven tests of experiments and effects share: the program's registry
// (tests/support/program_registry.hpp), small runs of
// experiments by their scheduled quantity, tight re-solves, and the finite-difference
// comparison of derivatives against re-solves at steps h and h/2.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "core/discretization_registry.hpp"
#include "core/params_io.hpp"
#include "experiments/experiment.hpp"
#include "tests/support/program_registry.hpp"

namespace twill::testing {

inline const Registry& registry() { return program_registry(); }

inline std::vector<std::string> registered(const char* category) { return registered_names(category); }

/// A registered implementation with its default options.
inline ComponentChoice default_choice(const char* category, const std::string& name) {
  return registry().choice(category, name, {});
}

inline DiscretizationFactory factory_for(const std::string& name) {
  const ComponentChoice choice = default_choice(registry_category::kDiscretization, name);
  return [choice](const StripSpec& s, const MaterialParameters& p) {
    return registry().create<DiscretizationFactories>(registry_category::kDiscretization, choice, s, p);
  };
}

/// A test name from registered names ('-' is not allowed in GoogleTest names).
inline std::string test_name(std::string text) {
  for (char& ch : text)
    if (ch == '-') ch = '_';
  return text;
}

// Re-solves must be converged far below the FD step's signal: Newton converges
// quadratically, so tightening the tolerance costs one or two iterations per point.
inline EquilibriumOptions tight_solver(double gradient_tolerance) {
  EquilibriumOptions o;
  o.gradient_tolerance = gradient_tolerance;
  o.decrement_tolerance = 1e-22;
  return o;
}

inline MaterialParameters poplin() {
  // Degree-2 warp and weft curves, so μ[1] is a free entry of the flat vector.
  return read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/poplin/params.yaml");
}

/// The paper's model of poplin: a12 tied to ½ min(a11, a22) (paper §5.2).
inline MaterialParameters paper_material() {
  MaterialParameters k = poplin();
  k.a12_Pa = MaterialParameters::tied_a12(k.a11_Pa, k.a22_Pa);
  return k;
}

/// A small run of an experiment, by the quantity it schedules. An experiment scheduling a
/// quantity not listed here fails the registry-driven tests until one is added.
struct SmallRun {
  std::vector<double> schedule;
  int cells_across = 0, cells_along = 0;
  /// Re-solve tolerance and relative FD step. The cantilever's force scale is its weight
  /// (mN): the round-off floor of ‖g_f‖ (≈ 1e-13 N, measured) is then 1e-10 of it, so its
  /// re-solve tolerance is 1e-9 and its FD step larger (1e-3 relative) to stay above the
  /// re-solve noise; a strip's forces are newtons, so 1e-11 and 1e-4 there.
  double gradient_tolerance = 0, relative_step = 0;
};

inline std::optional<SmallRun> small_run(const std::string& schedule_quantity) {
  if (schedule_quantity == "extension_mm") return SmallRun{{1.0, 3.0, 6.0}, 4, 6, 1e-11, 1e-4};
  if (schedule_quantity == "overhang_mm") return SmallRun{{40.0}, 2, 16, 1e-9, 1e-3};
  return std::nullopt;
}

/// The registered experiment `name` with default options on `discretization`, as a small run
/// at `input`'s angle (input's label, start and other fields are kept). nullptr (with a test
/// failure) when no small run is known for its schedule. `step` receives the FD step.
inline std::unique_ptr<Experiment> small_experiment(const std::string& name, const std::string& discretization,
                                                   ExperimentInput input, double* step = nullptr) {
  const ComponentChoice choice = default_choice(registry_category::kExperiment, name);
  input.discretization = factory_for(discretization);
  auto create = [&](const ExperimentInput& in) {
    return registry().create<ExperimentFactories>(registry_category::kExperiment, choice, in);
  };
  const std::string quantity = create(input)->schedule_quantity();  // empty schedule: simulation only
  const std::optional<SmallRun> run = small_run(quantity);
  if (!run) {
    ADD_FAILURE() << "no small run for an experiment scheduling '" << quantity << "': add one";
    return nullptr;
  }
  input.schedule = run->schedule;
  input.cells_across = run->cells_across;
  input.cells_along = run->cells_along;
  input.solver = tight_solver(run->gradient_tolerance);
  if (step) *step = run->relative_step;
  return create(input);
}

/// One effect on one experiment on one discretisation: the registry-driven effect tests' case.
struct EffectCase {
  std::string effect, experiment, discretization;
};
/// GoogleTest's description of a case (instead of its bytes).
inline void PrintTo(const EffectCase& c, std::ostream* os) {
  *os << c.effect << " via " << c.experiment << " on " << c.discretization;
}
/// Every registered effect × experiment × discretisation.
inline std::vector<EffectCase> every_effect_case() {
  std::vector<EffectCase> cases;
  for (const std::string& f : registered(registry_category::kEffect))
    for (const std::string& e : registered(registry_category::kExperiment))
      for (const std::string& d : registered(registry_category::kDiscretization)) cases.push_back({f, e, d});
  return cases;
}
/// The case's test name, e.g. hysteresis_tensile_catmull_clark_kl.
inline std::string effect_case_name(const EffectCase& c) {
  return test_name(c.effect + "_" + c.experiment + "_" + c.discretization);
}

// FD step: a fraction of the parameter's magnitude (1 when it is zero).
inline double relative_step(double value, double fraction) {
  return fraction * (value != 0 ? std::abs(value) : 1.0);
}

/// Analytic derivatives against central differences of re-solves at steps h and h/2: their
/// disagreement estimates the FD error (truncation O(h²) plus re-solve noise / h); a
/// comparison counts only where that estimate is below 1e-6 of `scale`, and then the analytic
/// value must agree with the h/2 difference within 1e-5 of `scale` (issue #5). Tests require
/// that most comparisons count, so they cannot pass by skipping.
struct Comparison {
  int counted = 0;
  int total = 0;
  double worst = 0;

  void compare(const std::string& what, double analytic, double fd_h, double fd_h2, double scale) {
    ++total;
    const double fd_error = std::abs(fd_h - fd_h2);
    if (fd_error > 1e-6 * scale) return;
    ++counted;
    const double rel = std::abs(analytic - fd_h2) / scale;
    worst = std::max(worst, rel);
    EXPECT_LE(rel, 1e-5) << what << ": analytic " << analytic << ", FD " << fd_h2 << " (FD self-difference "
                         << fd_error << ")";
  }
};

}  // namespace twill::testing
