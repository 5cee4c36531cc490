// `twill discover DATASET [-c CONFIG.yaml] [--set KEY=VALUE ...] [-o OUTDIR] [--force] [--quiet]`:
// which effect the paper's model misses on a dataset (fitting/discovery.hpp, docs/discovery.md).
//
// The config is a fit config (`twill fit --print-config`) with a `discover:` section
// (candidates, alpha, min_excess_shrink, unexplained_ratio; `twill discover --print-config`).
// Outputs (OUTDIR, default out/discover-<dataset name>): discover.json, discover.md,
// params.yaml (with the named effects' parameters under `effects:`), config.yaml, the
// baseline's and the refit's report.json, residuals.png. Everything is validated before any
// fit; the outputs are staged in OUTDIR.partial and moved into OUTDIR at the end, replacing only
// twill discover's own files (fitting/fit_output_folder.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <iostream>

#include "app/commands.hpp"
#include "app/python_script.hpp"
#include "core/config.hpp"
#include "core/dataset.hpp"
#include "fitting/discovery.hpp"
#include "fitting/fit_input_checks.hpp"
#include "fitting/fit_output_folder.hpp"

namespace twill {
namespace {

constexpr const char* kMarker = ".twill-discover";

struct DiscoverArgs {
  std::string dataset, config, out;
  std::vector<std::string> sets;
  bool quiet = false, print_config = false, no_plots = false, force = false;
};

const OutputFolderKind& discover_output_kind() {
  static const OutputFolderKind kind = {
      "twill discover", kMarker,
      [] {
        std::string files;
        for (const std::string& n : discover_output_file_names()) files += "  " + n + "\n";
        return files;
      }(),
      "dataset",
      [](const std::string& name) {
        const auto& names = discover_output_file_names();
        return name == kMarker || std::find(names.begin(), names.end(), name) != names.end();
      }};
  return kind;
}

Options resolved_config(Context& context, const DiscoverArgs& args) {
  const OptionSchema schema = discover_config_schema();
  Options config = args.config.empty() ? default_options(schema, &context.registry)
                                       : read_config_file(args.config, schema, &context.registry);
  apply_overrides(config, schema, &context.registry, args.sets);
  return config;
}

void run(Context& context, const DiscoverArgs& args) {
  const Options config = resolved_config(context, args);
  if (args.print_config) {
    std::cout << options_to_yaml(config);
    return;
  }
  if (args.dataset.empty()) throw InputError({"", 0, "DATASET"}, "twill discover needs a dataset folder");
  const Dataset dataset = read_dataset(args.dataset);
  const ConfigKeyLocator locate = [&](const std::string& key) { return command_line_key_location(args.sets, args.config, key); };
  const Options fit = discover_fit_config(config);
  check_fit_sizes(dataset, fit, locate);
  check_fit_protocol(dataset, fit, context.registry, locate);
  OutputFolder folder(discover_output_kind(),
                      args.out.empty() ? std::filesystem::path("out") / ("discover-" + safe_path_component(dataset.name))
                                       : std::filesystem::path(args.out),
                      dataset.folder, args.force);

  const bool quiet = args.quiet;
  auto progress = [quiet](int level, const std::string& line) {
    if (!quiet && level <= 1) std::cout << line << std::endl;
  };
  if (!quiet) std::cout << fmt::format("twill discover {} -> {}\n", dataset.folder, folder.out().string());
  const DiscoverResult result = run_discover(dataset, config, context.registry, progress);
  write_discover_outputs(result, config, folder.staging().string());
  if (!args.no_plots)
    run_python_script(context, "plot_discover.py", {folder.staging().string()});
  folder.commit();
  if (!quiet)
    std::cout << fmt::format("verdict: {} ({:.0f} s): {}/discover.md\n", result.verdict, result.time_s,
                             folder.out().string());
}

}  // namespace

void add_discover_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<DiscoverArgs>();
  CLI::App* cmd = app.add_subcommand("discover", "find the effect the model misses on a dataset (issue #16)");
  cmd->add_option("dataset", args->dataset, "dataset folder (fabric.yaml + runs)");
  cmd->add_option("-c,--config", args->config, "config YAML: a fit config with a discover: section (--print-config)");
  cmd->add_option("--set", args->sets, "override a config key, KEY=VALUE (repeatable)");
  cmd->add_option("-o,--out", args->out, "output folder (default out/discover-<dataset name>)");
  cmd->add_flag("--force", args->force,
                "write into an existing non-empty folder that is not a twill output (only twill's files are replaced)");
  cmd->add_flag("--quiet", args->quiet, "no progress output");
  cmd->add_flag("--no-plots", args->no_plots, "skip the figure (no matplotlib needed)");
  cmd->add_flag("--print-config", args->print_config, "print the resolved config and exit");
  cmd->callback([&context, args] { run(context, *args); });
}

}  // namespace twill
