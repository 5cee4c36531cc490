#include "experiments/register_experiments.hpp"

#include <memory>

#include "core/input_error.hpp"
#include "core/input_limits.hpp"
#include "core/option_binding.hpp"
#include "experiments/experiment.hpp"
#include "experiments/predictors.hpp"

namespace twill {
namespace {

// The standards' strip sizes and the resolutions used when a test does not give them.
// ASTM D5035: 50 mm wide strips on a 75 mm gauge; ASTM D1388: 25 mm wide strips.
constexpr double kTensileWidth_mm = 50.0;
constexpr double kTensileGauge_mm = 75.0;
constexpr double kBendWidth_mm = 25.0;
// 16x24: the tensile strip's off-axis force is within 2 % of the converged curves with the
// face-mean default (docs/catmull_clark_kl.md §12); 4x64: the cantilever's chord angle is
// converged along the overhang, and its width barely bends (docs/catmull_clark_kl.md).
constexpr int kTensileCellsAcross = 16, kTensileCellsAlong = 24;
constexpr int kBendCellsAcross = 4, kBendCellsAlong = 64;

// The experiments' options, each declared once through the bindings (core/option_binding.hpp).
struct StripOptions {
  double width_mm = 0;
  int cells_across = 0, cells_along = 0;
};

struct TensileOptions : StripOptions {
  TensileOptions() {
    width_mm = kTensileWidth_mm;
    cells_across = kTensileCellsAcross;
    cells_along = kTensileCellsAlong;
  }
  double gauge_length_mm = kTensileGauge_mm;
  bool planar = true;
  bool validate(std::string* error) const;
};

struct BendOptions : StripOptions {
  BendOptions() {
    width_mm = kBendWidth_mm;
    cells_across = kBendCellsAcross;
    cells_along = kBendCellsAlong;
  }
  int gravity_steps = 1;
  bool validate(std::string* error) const;
};

template <class Struct>
OptionBindings<Struct> strip_bindings() {
  return {real_option<Struct>("width_mm", &Struct::width_mm, "strip width [mm] when the test does not give one",
                              greater_than(0.0)),
          integer_option<Struct>("cells_across", &Struct::cells_across,
                                 "resolution across the width when the test does not give one", at_least(1)),
          integer_option<Struct>("cells_along", &Struct::cells_along,
                                 "resolution along the strip when the test does not give one", at_least(1))};
}

OptionBindings<TensileOptions> tensile_bindings() {
  OptionBindings<TensileOptions> b = strip_bindings<TensileOptions>();
  b.push_back(real_option<TensileOptions>("gauge_length_mm", &TensileOptions::gauge_length_mm,
                                          "gauge length [mm] when the test does not give one", greater_than(0.0)));
  b.push_back(bool_option<TensileOptions>("planar", &TensileOptions::planar,
                                          "hold the out-of-plane dofs (the flat equilibrium; tensile_strip.hpp)"));
  return b;
}

OptionBindings<BendOptions> bend_bindings() {
  OptionBindings<BendOptions> b = strip_bindings<BendOptions>();
  b.push_back(integer_option<BendOptions>(
      "gravity_steps", &BendOptions::gravity_steps,
      "load ramp from flat (cantilever.hpp: 1 step took 61 Newton iterations, 4 took 111)", in_range(1, 100)));
  return b;
}

bool TensileOptions::validate(std::string* error) const { return check_options(tensile_bindings(), *this, error); }
bool BendOptions::validate(std::string* error) const { return check_options(bend_bindings(), *this, error); }

double or_option(double given, double option) { return given > 0 ? given : option; }
int or_option(int given, int option) { return given > 0 ? given : option; }

// The set-up's own checks and the memory bound of core/input_limits.hpp.
template <class Setup>
void check_setup(const Setup& setup, const ExperimentInput& input) {
  std::string error;
  if (!setup.validate(&error)) throw InputError({"", 0, ""}, input.label + ": " + error);
  error = mesh_size_violation(setup.cells_across, setup.cells_along);
  if (!error.empty()) throw InputError({"", 0, ""}, input.label + ": " + error);
}

// The strip fields both set-ups share (StripOptions): the input's, or the options'.
template <class Setup>
Setup strip_setup(const StripOptions& o, const ExperimentInput& input) {
  Setup setup;
  setup.angle_deg = input.angle_deg;
  setup.width_mm = or_option(input.width_mm, o.width_mm);
  setup.cells_across = or_option(input.cells_across, o.cells_across);
  setup.cells_along = or_option(input.cells_along, o.cells_along);
  return setup;
}

std::unique_ptr<TensilePredictor> make_tensile(const TensileOptions& o, const ExperimentInput& input) {
  TensileSetup setup = strip_setup<TensileSetup>(o, input);
  setup.gauge_length_mm = or_option(input.length_mm, o.gauge_length_mm);
  setup.planar = o.planar;
  check_setup(setup, input);
  return std::make_unique<TensilePredictor>(input.label, setup, input.discretization, input.start, input.schedule,
                                            input.measured, input.solver);
}

std::unique_ptr<Experiment> make_bend(const BendOptions& o, const ExperimentInput& input) {
  CantileverSetup setup = strip_setup<CantileverSetup>(o, input);
  setup.gravity_steps = o.gravity_steps;
  check_setup(setup, input);
  return std::make_unique<CantileverPredictor>(input.label, setup, input.discretization, input.start, input.schedule,
                                               input.measured, input.solver);
}

}  // namespace

void register_experiments(Registry& registry) {
  auto& category = registry.category<ExperimentFactories>(registry_category::kExperiment);
  category.add("tensile", "ASTM D5035-like strip pulled between clamps: clamp force [N] per extension [mm]",
               option_schema(tensile_bindings()),
               [](const Options& o, const ExperimentInput& input) -> std::unique_ptr<Experiment> {
                 return make_tensile(options_from(tensile_bindings(), o, "tensile"), input);
               });
  category.add("validation",
               "off-axis tensile strip (paper §7): clamp force [N] per extension [mm] with dF/dθ [N/deg]",
               option_schema(tensile_bindings()),
               [](const Options& o, const ExperimentInput& input) -> std::unique_ptr<Experiment> {
                 auto strip = make_tensile(options_from(tensile_bindings(), o, "validation"), input);
                 strip->set_report_angle_derivative(true);
                 return strip;
               });
  category.add("tensile-lateral",
               "the tensile strip's lateral strain at mid-gauge [1] per extension [mm] (video extensometer, DIC)",
               option_schema(tensile_bindings()),
               [](const Options& o, const ExperimentInput& input) -> std::unique_ptr<Experiment> {
                 auto strip = make_tensile(options_from(tensile_bindings(), o, "tensile-lateral"), input);
                 strip->set_observable(StripObservable::LateralStrain);
                 return strip;
               });
  category.add("bend", "ASTM D1388 cantilever under its own weight: chord angle [deg] per overhang [mm]",
               option_schema(bend_bindings()), [](const Options& o, const ExperimentInput& input) {
                 return make_bend(options_from(bend_bindings(), o, "bend"), input);
               });
}

}  // namespace twill
