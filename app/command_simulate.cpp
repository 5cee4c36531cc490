// `twill simulate`: one registered experiment (experiments/experiment.hpp) from a params.yaml.
//
//   twill simulate --params P.yaml --test tensile --angle-deg A [--width-mm 50] [--gauge-mm 75]
//                  --extensions-mm 0.5,1,2 [--rate-mm-min V] [--discretization NAME] [--resolution 16x24]
//                  [--option key=value ...] [--experiment-option key=value ...]
//                  [--out FILE.csv] [--json] [--mesh-out FILE.obj]
//   twill simulate --params P.yaml --test bend --angle-deg A (--overhang-mm L[,L2...] | --find-overhang)
//                  [--width-mm 25] [--resolution 4x64] [--json] [--mesh-out FILE.obj]
//
//   twill simulate --params P.yaml -c SIMULATION.yaml [--set KEY=VALUE ...] [--out FILE] [--json]
//
// --test is any registered experiment (`twill list experiment`); its schedule is given by
// --extensions-mm (tensile, validation) or --overhang-mm (bend). Output: CSV with the schedule,
// the observable and the experiment's extra columns (stdout without --out), or one JSON
// object with --json. --find-overhang (bend only): `overhang_mm=<v>` for a 41.5° chord.
// The params.yaml's effects (effects/effect_experiment.hpp) act on the simulation: a curve
// with an effect on is this one command (rate effects need --rate-mm-min, their clock).
// With -c/--set the simulation is a config (experiments/simulate_config.hpp: experiment and
// discretization with their options, angle, schedule, a reference curve whose errors --json
// reports), the form a study's `command: simulate` runs; the flags it replaces are refused then.
#include <cstdio>
#include <functional>
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
#include "effects/effect_experiment.hpp"
#include "experiments/experiment.hpp"
#include "experiments/predictors.hpp"
#include "experiments/reference_errors.hpp"
#include "experiments/simulate_config.hpp"

namespace twill {
namespace {

struct SimulateArgs {
  std::string params, test, discretization = "catmull-clark-kl", resolution, out, mesh_out, config;
  std::vector<std::string> sets;
  double angle_deg = 90;
  std::optional<double> width_mm, gauge_mm, rate_mm_min;
  std::string extensions;
  std::optional<std::string> overhangs;
  std::vector<std::string> options, experiment_options;
  bool find_overhang = false, json = false, out_of_plane = false, angle_given = false;
};

// Comma-separated numbers given as `option`, each checked by `check` (which returns a
// violation, empty when fine).
std::vector<double> parse_list(const std::string& text, const std::string& option,
                               const std::function<std::string(double)>& check) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InputError({"command line", 0, option}, "not a number: '" + excerpt(item) + "'");
    }
    const std::string violation = check(values.back());
    if (!violation.empty()) throw InputError({"command line", 0, option}, "'" + excerpt(item) + "': " + violation);
  }
  if (values.empty()) throw InputError({"command line", 0, option}, "no values given");
  return values;
}

// The options of a registered entry at their defaults with `key=value` overrides applied
// (checked like a config file; errors name `flag`).
Options entry_options(const Registry& registry, const RegistryEntry& entry, const std::vector<std::string>& overrides) {
  OptionSchema wrapper;
  wrapper.add_section("o", "options") = entry.options;
  Options options = default_options(wrapper, &registry);
  for (const std::string& o : overrides) apply_override(options, wrapper, &registry, "o." + o);
  return options.get_section("o");
}

// What one simulation needs, from the flags or from a config (experiments/simulate_config.hpp).
struct SimulationSpec {
  std::string test;
  Options experiment_options;
  std::string discretization;
  Options discretization_options;
  ExperimentInput input;
  std::optional<ReferenceCurve> reference;
};

DiscretizationFactory make_factory(Registry& registry, const std::string& name, const Options& chosen) {
  const auto& category = registry.category<DiscretizationFactories>(registry_category::kDiscretization);
  return [&category, name, chosen](const StripSpec& s, const MaterialParameters& p) {
    return category.create(name, chosen, s, p);
  };
}

void write_text(const std::string& path, const std::string& text) {
  if (path.empty()) {
    std::cout << text;
    return;
  }
  std::ofstream file(path);
  if (!(file << text)) throw InputError({path, 0, ""}, "cannot write the output file");
}

// The experiment's input from the command line: geometry, schedule, resolution. Geometry the
// command line leaves out comes from the experiment's options (0 here).
ExperimentInput simulate_input(const SimulateArgs& args, const Options& experiment_options) {
  ExperimentInput input;
  input.label = args.test + " (" + format_double(args.angle_deg) + "°)";
  input.angle_deg = args.angle_deg;
  if (args.width_mm) input.width_mm = checked_argument(*args.width_mm, limits::kStripWidth, "--width-mm");
  if (args.gauge_mm) input.length_mm = checked_argument(*args.gauge_mm, limits::kStripLength, "--gauge-mm");
  if (args.rate_mm_min)
    input.rate_mm_min = checked_argument(*args.rate_mm_min, limits::kCrossheadRate, "--rate-mm-min");
  if (!args.resolution.empty()) {
    const auto [across, along] = parse_resolution(args.resolution, "--resolution");
    input.cells_across = across;
    input.cells_along = along;
  }
  if (args.overhangs) {
    input.schedule = parse_list(*args.overhangs, "--overhang-mm",
                                [](double v) { return range_violation(v, limits::kStripLength); });
  } else if (!args.extensions.empty()) {
    const double gauge_mm = input.length_mm > 0 ? input.length_mm
                            : experiment_options.has("gauge_length_mm") ? experiment_options.get_double("gauge_length_mm")
                                                                        : 0.0;
    if (!(gauge_mm > 0))
      throw InputError({"command line", 0, "--extensions-mm"}, "experiment '" + args.test + "' is not scheduled by extensions (it has no gauge length)");
    input.schedule = parse_list(args.extensions, "--extensions-mm", [gauge_mm](double v) {
      const std::string violation = range_violation(v / gauge_mm, limits::kEngineeringStrain);
      return violation.empty() ? violation : "extension on a " + format_double(gauge_mm) + " mm gauge: " + violation;
    });
  }
  return input;
}

SimulationSpec spec_from_flags(Registry& registry, const SimulateArgs& args) {
  const std::string required = "required (or give the simulation as a config: -c FILE)";
  if (args.test.empty()) throw InputError({"command line", 0, "--test"}, required);
  if (!args.angle_given) throw InputError({"command line", 0, "--angle-deg"}, required);
  checked_argument(args.angle_deg, limits::kAngle, "--angle-deg");
  const auto& experiments = registry.category<ExperimentFactories>(registry_category::kExperiment);
  if (!experiments.find(args.test))
    throw InputError({"command line", 0, "--test"},
                     "unknown experiment '" + excerpt(args.test) + "' (known: " + experiments.known_names() + ")");
  std::vector<std::string> experiment_overrides = args.experiment_options;
  if (args.out_of_plane) experiment_overrides.push_back("planar=false");
  SimulationSpec spec;
  spec.test = args.test;
  spec.experiment_options = entry_options(registry, experiments.at(args.test), experiment_overrides);
  const auto& shells = registry.category<DiscretizationFactories>(registry_category::kDiscretization);
  spec.discretization = args.discretization;
  spec.discretization_options = entry_options(registry, shells.at(args.discretization), args.options);
  spec.input = simulate_input(args, spec.experiment_options);
  return spec;
}

// The flags a config replaces (experiments/simulate_config.hpp): giving both is an error.
constexpr const char* kConfigReplacedFlags[] = {"--test", "--angle-deg", "--width-mm", "--gauge-mm", "--extensions-mm",
                                                "--rate-mm-min", "--overhang-mm", "--discretization", "--resolution",
                                                "--option", "--experiment-option", "--out-of-plane"};

SimulationSpec spec_from_config(Registry& registry, const SimulateArgs& args) {
  const OptionSchema schema = simulate_config_schema();
  Options config = args.config.empty() ? default_options(schema, &registry)
                                       : read_config_file(args.config, schema, &registry);
  apply_overrides(config, schema, &registry, args.sets);
  const ConfigKeyLocator locate = [&](const std::string& key) { return command_line_key_location(args.sets, args.config, key); };
  check_simulate_config(config, args.params, registry, locate);
  const ComponentChoice& experiment = config.get_component("experiment");
  const ComponentChoice& discretization = config.get_component("discretization");
  SimulationSpec spec{experiment.name, experiment.options, discretization.name, discretization.options, {}, {}};
  spec.input.angle_deg = config.get_double("angle_deg");
  spec.input.label = spec.test + " (" + format_double(spec.input.angle_deg) + "°)";
  spec.input.rate_mm_min = config.get_double("rate_mm_min");
  spec.input.schedule = simulate_schedule(config, locate);
  if (!config.get_string("reference").empty()) spec.reference = read_reference_curve(config.get_string("reference"));
  return spec;
}

// The schedule flag each experiment reads, by its scheduled quantity.
const char* schedule_flag(const std::string& quantity) {
  return quantity == "overhang_mm" ? "--overhang-mm" : "--extensions-mm";
}

std::string run_as_csv(const Experiment& experiment, const ExperimentRun& run) {
  std::ostringstream text;
  text << experiment.schedule_quantity() << "," << experiment.observable();
  for (const auto& [name, values] : run.extras) text << "," << name;
  text << "\n";
  char cell[64];
  for (size_t i = 0; i < run.schedule.size(); ++i) {
    std::snprintf(cell, sizeof cell, "%.6g,%.9g", run.schedule[i], run.values[static_cast<Eigen::Index>(i)]);
    text << cell;
    for (const auto& [name, values] : run.extras) {
      std::snprintf(cell, sizeof cell, ",%.9g", values[i]);
      text << cell;
    }
    text << "\n";
  }
  return text.str();
}

nlohmann::json run_as_json(const Experiment& experiment, const ExperimentRun& run, const SimulationSpec& spec) {
  nlohmann::json j;
  j["test"] = spec.test;
  j["angle_deg"] = spec.input.angle_deg;
  j["discretization"] = spec.discretization;
  j["schedule_quantity"] = experiment.schedule_quantity();
  j["observable"] = experiment.observable();
  j["completed"] = run.completed;
  j["message"] = run.message;
  j["wall_time_s"] = run.wall_time_s;
  j["newton_iterations"] = run.newton_iterations;
  j["points"] = nlohmann::json::array();
  for (size_t i = 0; i < run.schedule.size(); ++i) {
    nlohmann::json point{{experiment.schedule_quantity(), run.schedule[i]},
                         {experiment.observable(), run.values[static_cast<Eigen::Index>(i)]}};
    for (const auto& [name, values] : run.extras) point[name] = values[i];
    j["points"].push_back(point);
  }
  if (spec.reference) {
    const std::vector<double> simulated(run.values.data(), run.values.data() + run.values.size());
    const ReferenceErrors e = reference_errors(simulated, spec.reference->values);
    // worst: signed, + where the simulation is stiffer (experiments/reference_errors.hpp)
    j["reference"] = {{"avg_rel_error", e.average}, {"worst_rel_error", e.worst}, {"points", e.points}};
  }
  return j;
}

void write_mesh(const std::string& path, const Experiment& experiment) {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  if (experiment.last_surface(&V, &F)) write_obj(path, V, F);
}

// --find-overhang: the bend experiment's overhang search (not a schedule).
void find_overhang(Experiment& experiment, const SimulationSpec& spec, const SimulateArgs& args) {
  auto* bend = dynamic_cast<CantileverPredictor*>(&innermost(experiment));
  if (!bend) throw InputError({"command line", 0, "--find-overhang"}, "applies to the bend experiment only");
  const OverhangSearchResult r = bend->experiment().find_overhang();
  if (args.json) {
    nlohmann::json j{{"test", spec.test}, {"angle_deg", spec.input.angle_deg}, {"discretization", spec.discretization},
                     {"overhang_mm", r.overhang_mm}, {"chord_angle_deg", r.chord_angle_deg}, {"solves", r.evaluations},
                     {"wall_time_s", r.wall_time_s}, {"converged", r.converged}, {"message", r.message}};
    std::cout << j.dump(2) << "\n";
  } else {
    std::printf("overhang_mm=%.6g\n", r.overhang_mm);
  }
  if (!args.mesh_out.empty()) write_mesh(args.mesh_out, experiment);
  if (!r.converged) throw std::runtime_error("the overhang search did not converge: " + r.message);
}

void run_simulation(Registry& registry, SimulationSpec spec, const SimulateArgs& args, const MaterialParameters& p) {
  spec.input.discretization = make_factory(registry, spec.discretization, spec.discretization_options);
  spec.input.start = p;
  std::unique_ptr<Experiment> experiment = create_experiment(registry, spec.test, spec.experiment_options, spec.input);
  if (args.find_overhang) return find_overhang(*experiment, spec, args);
  if (spec.input.schedule.empty())
    throw InputError({"command line", 0, schedule_flag(experiment->schedule_quantity())},
                     "experiment '" + spec.test + "' needs " + schedule_flag(experiment->schedule_quantity()));
  const ExperimentRun run = experiment->simulate(p);
  if (!args.mesh_out.empty()) write_mesh(args.mesh_out, *experiment);
  write_text(args.out, args.json ? run_as_json(*experiment, run, spec).dump(2) + "\n" : run_as_csv(*experiment, run));
  if (!run.completed) throw std::runtime_error("the " + spec.test + " simulation stopped early: " + run.message);
}

}  // namespace

void add_simulate_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand("simulate", "simulate one tensile curve or cantilever from a params.yaml");
  cmd->add_option("--params", args->params, "parameter file (params.yaml)")->required()->check(CLI::ExistingFile);
  cmd->add_option("-c,--config", args->config, "the simulation as a config file (experiments/simulate_config.hpp)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--set", args->sets, "config override KEY=VALUE (repeatable), e.g. angle_deg=45");
  cmd->add_option("--test", args->test, "registered experiment (twill list experiment)");
  cmd->add_option("--angle-deg", args->angle_deg, "strip axis vs weft: 0 weft, 90 warp, 45 bias");
  cmd->add_option("--width-mm", args->width_mm, "strip width (tensile 50, bend 25)");
  cmd->add_option("--gauge-mm", args->gauge_mm, "tensile gauge length (75)");
  cmd->add_option("--extensions-mm", args->extensions, "tensile: comma-separated clamp extensions, applied in order");
  cmd->add_option("--rate-mm-min", args->rate_mm_min, "tensile: crosshead speed (the clock of rate effects)");
  cmd->add_option("--overhang-mm", args->overhangs, "bend: comma-separated overhang lengths");
  cmd->add_flag("--find-overhang", args->find_overhang, "bend: find the overhang with a 41.5 deg chord angle");
  cmd->add_option("--discretization", args->discretization, "registered discretization (twill list)");
  cmd->add_option("--resolution", args->resolution, "cells across x along (tensile 16x24, bend 4x64)");
  cmd->add_option("--option", args->options, "discretization option key=value (repeatable; twill list)");
  cmd->add_option("--experiment-option", args->experiment_options,
                  "experiment option key=value (repeatable; twill list experiment)");
  cmd->add_option("--out", args->out, "tensile: write the CSV (or JSON) here instead of stdout");
  cmd->add_option("--mesh-out", args->mesh_out, "write the final equilibrium surface as OBJ");
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->add_flag("--out-of-plane", args->out_of_plane, "tensile: solve in 3-D (experiment option planar=false)");
  cmd->callback([args, &context, cmd] {
    args->angle_given = cmd->count("--angle-deg") > 0;
    const bool from_config = !args->config.empty() || !args->sets.empty();
    if (from_config)
      for (const char* flag : kConfigReplacedFlags)
        if (cmd->count(flag) > 0)
          throw InputError({"command line", 0, flag}, "set by the config with -c/--set; give one or the other");
    const MaterialParameters p = read_params_file(args->params, &context.registry);
    run_simulation(context.registry, from_config ? spec_from_config(context.registry, *args) : spec_from_flags(context.registry, *args),
                   *args, p);
  });
}

}  // namespace twill
