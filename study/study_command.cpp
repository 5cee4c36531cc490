// The commands a study can run (study/study_command.hpp).
#include "study/study_command.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/dataset.hpp"
#include "experiments/simulate_config.hpp"
#include "fitting/discovery.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_input_checks.hpp"
#include "fitting/fit_protocol.hpp"
#include "study/run_metrics.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  return nlohmann::json::parse(in);
}

void check_fit_run(const std::string& dataset, const Options& config, const Registry& registry,
                   const ConfigKeyLocator& locate) {
  const Dataset data = read_dataset(dataset);
  check_fit_sizes(data, config, locate);
  check_fit_protocol(data, config, registry, locate);
}

std::vector<std::string> fit_child_args(const std::string& dataset, const fs::path& run, bool plots) {
  std::vector<std::string> args = {"fit", dataset, "-c", (run / "config.yaml").string(), "-o", (run / "fit").string(),
                                   "--quiet"};
  if (!plots) args.push_back("--no-plots");
  return args;
}

void check_discover_run(const std::string& dataset, const Options& config, const Registry& registry,
                        const ConfigKeyLocator& locate) {
  check_fit_run(dataset, discover_fit_config(config), registry, locate);
}

std::vector<std::string> discover_child_args(const std::string& dataset, const fs::path& run, bool plots) {
  std::vector<std::string> args = {"discover", dataset, "-c", (run / "config.yaml").string(), "-o",
                                   (run / "discover").string(), "--quiet"};
  if (!plots) args.push_back("--no-plots");
  return args;
}

std::vector<std::string> simulate_child_args(const std::string& params, const fs::path& run, bool) {
  return {"simulate", "--params", params, "-c", (run / "config.yaml").string(), "--json",
          "--out", (run / "simulate.json").string()};
}

}  // namespace

const std::vector<StudyCommand>& study_commands() {
  static const std::vector<StudyCommand> commands = {
      {"fit", "datasets", "dataset", true, &fit_config_schema, &check_fit_run, &fit_child_args,
       [](const fs::path& run) { return run / "fit"; }, [](const fs::path& run) { return run / "fit" / "report.json"; },
       [](const fs::path& result) { return fit_metrics(read_json(result)); }},
      {"simulate", "params", "params", false, &simulate_config_schema,
       [](const std::string& params, const Options& config, const Registry& registry, const ConfigKeyLocator& locate) {
         check_simulate_config(config, params, registry, locate);
       },
       &simulate_child_args, [](const fs::path& run) { return run / "simulate.json"; },
       [](const fs::path& run) { return run / "simulate.json"; },
       [](const fs::path& result) { return simulate_metrics(read_json(result)); }},
      {"discover", "datasets", "dataset", true, &discover_config_schema, &check_discover_run, &discover_child_args,
       [](const fs::path& run) { return run / "discover"; },
       [](const fs::path& run) { return run / "discover" / "discover.json"; },
       [](const fs::path& result) { return discover_metrics(read_json(result)); }},
  };
  return commands;
}

const StudyCommand* find_study_command(const std::string& name) {
  for (const StudyCommand& c : study_commands())
    if (c.name == name) return &c;
  return nullptr;
}

}  // namespace twill
