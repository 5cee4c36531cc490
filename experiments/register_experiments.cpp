#include "experiments/register_experiments.hpp"

#include <memory>

#include "core/input_error.hpp"
#include "core/input_limits.hpp"
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

void add_strip_options(OptionSchema* schema, double width_mm, int across, int along) {
  schema->add_double("width_mm", width_mm, "strip width [mm] when the test does not give one").greater_than(0);
  schema->add_int("cells_across", across, "resolution across the width when the test does not give one")
      .at_least(1);
  schema->add_int("cells_along", along, "resolution along the strip when the test does not give one")
      .at_least(1);
}

OptionSchema tensile_options() {
  OptionSchema schema;
  add_strip_options(&schema, kTensileWidth_mm, kTensileCellsAcross, kTensileCellsAlong);
  schema.add_double("gauge_length_mm", kTensileGauge_mm, "gauge length [mm] when the test does not give one")
      .greater_than(0);
  schema.add_bool("planar", true, "hold the out-of-plane dofs (the flat equilibrium; tensile_strip.hpp)");
  return schema;
}

OptionSchema bend_options() {
  OptionSchema schema;
  add_strip_options(&schema, kBendWidth_mm, kBendCellsAcross, kBendCellsAlong);
  schema.add_int("gravity_steps", 1, "load ramp from flat (cantilever.hpp: 1 step took 61 Newton iterations, 4 took 111)")
      .range(1, 100);
  return schema;
}

double or_option(double given, const Options& o, const char* key) { return given > 0 ? given : o.get_double(key); }
int or_option(int given, const Options& o, const char* key) {
  return given > 0 ? given : static_cast<int>(o.get_int(key));
}

// The set-up's own checks and the memory bound of core/input_limits.hpp.
template <class Setup>
void check_setup(const Setup& setup, const ExperimentInput& input) {
  std::string error;
  if (!setup.validate(&error)) throw InputError({"", 0, ""}, input.label + ": " + error);
  error = mesh_size_violation(setup.cells_across, setup.cells_along);
  if (!error.empty()) throw InputError({"", 0, ""}, input.label + ": " + error);
}

// The strip fields both set-ups share (add_strip_options): the input's, or the options'.
template <class Setup>
Setup strip_setup(const Options& o, const ExperimentInput& input) {
  Setup setup;
  setup.angle_deg = input.angle_deg;
  setup.width_mm = or_option(input.width_mm, o, "width_mm");
  setup.cells_across = or_option(input.cells_across, o, "cells_across");
  setup.cells_along = or_option(input.cells_along, o, "cells_along");
  return setup;
}

std::unique_ptr<TensilePredictor> make_tensile(const Options& o, const ExperimentInput& input) {
  TensileSetup setup = strip_setup<TensileSetup>(o, input);
  setup.gauge_length_mm = or_option(input.length_mm, o, "gauge_length_mm");
  setup.planar = o.get_bool("planar");
  check_setup(setup, input);
  return std::make_unique<TensilePredictor>(input.label, setup, input.discretization, input.start, input.schedule,
                                            input.measured, input.solver);
}

std::unique_ptr<Experiment> make_bend(const Options& o, const ExperimentInput& input) {
  CantileverSetup setup = strip_setup<CantileverSetup>(o, input);
  setup.gravity_steps = static_cast<int>(o.get_int("gravity_steps"));
  check_setup(setup, input);
  const Eigen::VectorXd measured = input.measured.size() ? input.measured : Eigen::VectorXd();
  return std::make_unique<CantileverPredictor>(input.label, setup, input.discretization, input.start, input.schedule,
                                               measured, input.solver);
}

}  // namespace

void register_experiments(Registry& registry) {
  auto& category = registry.category<ExperimentFactories>(registry_category::kExperiment);
  category.add("tensile", "ASTM D5035-like strip pulled between clamps: clamp force [N] per extension [mm]",
               tensile_options(), [](const Options& o, const ExperimentInput& input) -> std::unique_ptr<Experiment> {
                 return make_tensile(o, input);
               });
  category.add("validation",
               "off-axis tensile strip (paper §7): clamp force [N] per extension [mm] with dF/dθ [N/deg]",
               tensile_options(), [](const Options& o, const ExperimentInput& input) -> std::unique_ptr<Experiment> {
                 auto strip = make_tensile(o, input);
                 strip->set_report_angle_derivative(true);
                 return strip;
               });
  category.add("bend", "ASTM D1388 cantilever under its own weight: chord angle [deg] per overhang [mm]",
               bend_options(), make_bend);
}

}  // namespace twill
