// `twill simulate`: one simulated tensile curve or cantilever from a params.yaml.
//
//   twill simulate --params P.yaml --test tensile --angle-deg A [--width-mm 50] [--gauge-mm 75]
//                  --extensions-mm 0.5,1,2 [--discretization NAME] [--resolution 16x24]
//                  [--option key=value ...] [--out FILE.csv] [--json] [--mesh-out FILE.obj]
//   twill simulate --params P.yaml --test bend --angle-deg A (--overhang-mm L | --find-overhang)
//                  [--width-mm 25] [--resolution 4x64] [--json] [--mesh-out FILE.obj]
//
// Tensile output: CSV `extension_mm,force_N,lateral_strain` (stdout without --out). Bend output:
// `chord_angle_deg=<v>` or, with --find-overhang, `overhang_mm=<v>` for a 41.5° chord.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "app/commands.hpp"
#include "core/discretization_registry.hpp"
#include "core/input_error.hpp"
#include "core/obj_writer.hpp"
#include "core/params_io.hpp"
#include "core/yaml_reader.hpp"
#include "experiments/cantilever_test.hpp"
#include "experiments/tensile_test.hpp"

namespace twill {
namespace {

struct SimulateArgs {
  std::string params, test, discretization = "catmull-clark-kl", resolution, out, mesh_out;
  double angle_deg = 90;
  std::optional<double> width_mm, gauge_mm, overhang_mm;
  std::string extensions;
  std::vector<std::string> options;
  bool find_overhang = false, json = false, planar = true;
};

// Comma-separated extensions [mm], each finite and a plausible strain of the gauge.
std::vector<double> parse_list(const std::string& text, double gauge_length_mm) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InputError({"command line", 0, "--extensions-mm"}, "not a number: '" + excerpt(item) + "'");
    }
    const std::string violation = range_violation(values.back() / gauge_length_mm, limits::kEngineeringStrain);
    if (!violation.empty())
      throw InputError({"command line", 0, "--extensions-mm"},
                       "extension '" + excerpt(item) + "' mm on a " + format_double(gauge_length_mm) +
                           " mm gauge: " + violation);
  }
  if (values.empty()) throw InputError({"command line", 0, "--extensions-mm"}, "no extensions given");
  return values;
}

DiscretizationFactory make_factory(Registry& registry, const SimulateArgs& args) {
  const auto& category = registry.category<DiscretizationFactories>(registry_category::kDiscretization);
  const RegistryEntry& entry = category.at(args.discretization);
  OptionSchema wrapper;
  wrapper.add_section("d", "discretization options") = entry.options;
  Options options = default_options(wrapper, &registry);
  for (const std::string& o : args.options) apply_override(options, wrapper, &registry, "d." + o);
  const Options chosen = options.get_section("d");
  const std::string name = args.discretization;
  return [&category, name, chosen](const StripSpec& s, const MaterialParameters& p) {
    return category.create(name, chosen, s, p);
  };
}

void write_mesh(const std::string& path, const Discretization& d, const Eigen::VectorXd& q) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  d.surface_mesh(q, &V, &F);
  write_obj(path, V, F);
}

void run_tensile(Registry& registry, const SimulateArgs& args, const MaterialParameters& p) {
  if (args.extensions.empty())
    throw InputError({"command line", 0, "--extensions-mm"}, "a tensile simulation needs --extensions-mm");
  TensileSetup setup;
  setup.angle_deg = args.angle_deg;
  setup.width_mm = checked_argument(args.width_mm.value_or(50.0), limits::kStripWidth, "--width-mm");
  setup.gauge_length_mm = checked_argument(args.gauge_mm.value_or(75.0), limits::kStripLength, "--gauge-mm");
  setup.planar = args.planar;
  const auto [across, along] = parse_resolution(args.resolution.empty() ? "16x24" : args.resolution, "--resolution");
  const std::vector<double> extensions = parse_list(args.extensions, setup.gauge_length_mm);
  setup.cells_across = across;
  setup.cells_along = along;
  std::string error;
  if (!setup.validate(&error)) throw InputError({"command line", 0, ""}, error);
  TensileExperiment experiment(setup, make_factory(registry, args), p);
  Eigen::VectorXd last_q;
  const TensileCurve curve = experiment.run(extensions,
                                            [&](int, const Eigen::VectorXd& q, const EquilibriumSolver&) { last_q = q; });
  if (!args.mesh_out.empty() && last_q.size() > 0) write_mesh(args.mesh_out, experiment.discretization(), last_q);

  std::ostringstream text;
  if (args.json) {
    nlohmann::json j;
    j["test"] = "tensile";
    j["angle_deg"] = setup.angle_deg;
    j["width_mm"] = setup.width_mm;
    j["gauge_length_mm"] = setup.gauge_length_mm;
    j["discretization"] = args.discretization;
    j["resolution"] = std::to_string(across) + "x" + std::to_string(along);
    j["completed"] = curve.completed;
    j["message"] = curve.message;
    j["wall_time_s"] = curve.wall_time_s;
    j["newton_iterations"] = curve.newton_iterations;
    for (const TensilePoint& pt : curve.points)
      j["points"].push_back({{"extension_mm", pt.extension_mm}, {"force_N", pt.force_N}, {"lateral_strain", pt.lateral_strain}});
    text << j.dump(2) << "\n";
  } else {
    text << "extension_mm,force_N,lateral_strain\n";
    char line[128];
    for (const TensilePoint& pt : curve.points) {
      std::snprintf(line, sizeof line, "%.6g,%.9g,%.9g\n", pt.extension_mm, pt.force_N, pt.lateral_strain);
      text << line;
    }
  }
  if (args.out.empty()) {
    std::cout << text.str();
  } else {
    std::ofstream file(args.out);
    if (!(file << text.str())) throw InputError({args.out, 0, ""}, "cannot write the output file");
  }
  if (!curve.completed) throw std::runtime_error("the tensile curve stopped early: " + curve.message);
}

void run_bend(Registry& registry, const SimulateArgs& args, const MaterialParameters& p) {
  if (args.find_overhang == args.overhang_mm.has_value())
    throw InputError({"command line", 0, "--overhang-mm"}, "a bend simulation needs exactly one of --overhang-mm and --find-overhang");
  CantileverSetup setup;
  setup.angle_deg = args.angle_deg;
  setup.width_mm = checked_argument(args.width_mm.value_or(25.0), limits::kStripWidth, "--width-mm");
  if (args.overhang_mm) checked_argument(*args.overhang_mm, limits::kStripLength, "--overhang-mm");
  if (!args.resolution.empty()) {
    const auto [across, along] = parse_resolution(args.resolution, "--resolution");
    setup.cells_across = across;
    setup.cells_along = along;
  }
  std::string error;
  if (!setup.validate(&error)) throw InputError({"command line", 0, ""}, error);
  CantileverExperiment experiment(setup, make_factory(registry, args), p);
  nlohmann::json j;
  j["test"] = "bend";
  j["angle_deg"] = setup.angle_deg;
  j["width_mm"] = setup.width_mm;
  j["discretization"] = args.discretization;
  j["resolution"] = std::to_string(setup.cells_across) + "x" + std::to_string(setup.cells_along);
  bool ok = false;
  std::string message;
  if (args.find_overhang) {
    const OverhangSearchResult r = experiment.find_overhang();
    ok = r.converged;
    message = r.message;
    j["overhang_mm"] = r.overhang_mm;
    j["chord_angle_deg"] = r.chord_angle_deg;
    j["solves"] = r.evaluations;
    j["wall_time_s"] = r.wall_time_s;
    if (!args.json) std::printf("overhang_mm=%.6g\n", r.overhang_mm);
  } else {
    const CantileverResult r = experiment.solve(*args.overhang_mm);
    ok = r.converged;
    message = r.message;
    j["overhang_mm"] = r.overhang_mm;
    j["chord_angle_deg"] = r.chord_angle_deg;
    j["tip_deflection_mm"] = r.tip_deflection_mm;
    j["newton_iterations"] = r.newton_iterations;
    j["wall_time_s"] = r.wall_time_s;
    if (!args.json) std::printf("chord_angle_deg=%.6g\n", r.chord_angle_deg);
  }
  j["converged"] = ok;
  j["message"] = message;
  if (args.json) std::cout << j.dump(2) << "\n";
  if (!args.mesh_out.empty() && experiment.last_discretization())
    write_mesh(args.mesh_out, *experiment.last_discretization(), experiment.last_positions());
  if (!ok) throw std::runtime_error("the cantilever did not converge: " + message);
}

}  // namespace

void add_simulate_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand("simulate", "simulate one tensile curve or cantilever from a params.yaml");
  cmd->add_option("--params", args->params, "parameter file (params.yaml)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--test", args->test, "tensile or bend")->required()->check(CLI::IsMember({"tensile", "bend"}));
  cmd->add_option("--angle-deg", args->angle_deg, "strip axis vs weft: 0 weft, 90 warp, 45 bias")->required();
  cmd->add_option("--width-mm", args->width_mm, "strip width (tensile 50, bend 25)");
  cmd->add_option("--gauge-mm", args->gauge_mm, "tensile gauge length (75)");
  cmd->add_option("--extensions-mm", args->extensions, "tensile: comma-separated clamp extensions, applied in order");
  cmd->add_option("--overhang-mm", args->overhang_mm, "bend: overhang length");
  cmd->add_flag("--find-overhang", args->find_overhang, "bend: find the overhang with a 41.5 deg chord angle");
  cmd->add_option("--discretization", args->discretization, "registered discretization (twill list)");
  cmd->add_option("--resolution", args->resolution, "cells across x along (tensile 16x24, bend 4x64)");
  cmd->add_option("--option", args->options, "discretization option key=value (repeatable; twill list)");
  cmd->add_option("--out", args->out, "tensile: write the CSV (or JSON) here instead of stdout");
  cmd->add_option("--mesh-out", args->mesh_out, "write the final equilibrium surface as OBJ");
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->add_flag("!--out-of-plane", args->planar, "tensile: solve in 3-D instead of holding the strip in its plane");
  cmd->callback([args, &context] {
    checked_argument(args->angle_deg, limits::kAngle, "--angle-deg");
    const MaterialParameters p = read_params_file(args->params);
    if (args->test == "tensile")
      run_tensile(context.registry, *args, p);
    else
      run_bend(context.registry, *args, p);
  });
}

}  // namespace twill
