// `twill fit DATASET [-c CONFIG.yaml] [--set KEY=VALUE ...] [-o OUTDIR] [--quiet]`: the paper's
// fitting protocol end to end (fitting/fit_protocol.hpp). Every protocol choice is a config key
// (`twill fit --print-config` lists them with defaults); --set overrides any key, e.g.
// `--set optimizer=ipopt`, `--set discretization=triangle-shell`, `--set resolution.levels=2`.
//
// Outputs (OUTDIR, default out/fit-<dataset name>): params.yaml, report.json, report.md,
// config.yaml (resolved), fig2/3/4 PNGs. They are written into OUTDIR.partial and renamed at
// the end: a failed or interrupted fit never leaves an OUTDIR that looks complete (the
// .partial folder is removed on failure).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "app/commands.hpp"
#include "app/python_script.hpp"
#include "core/config.hpp"
#include "core/dataset.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {
namespace {

struct FitArgs {
  std::string dataset, config, out;
  std::vector<std::string> sets;
  bool quiet = false, print_config = false, no_plots = false;
};

void run(Context& context, const FitArgs& args) {
  const OptionSchema schema = fit_config_schema();
  Options config = args.config.empty() ? default_options(schema, &context.registry)
                                       : read_config_file(args.config, schema, &context.registry);
  apply_overrides(config, schema, &context.registry, args.sets);
  if (args.print_config) {
    std::cout << options_to_yaml(config);
    return;
  }
  if (args.dataset.empty()) throw InputError({"", 0, "DATASET"}, "twill fit needs a dataset folder");
  const Dataset dataset = read_dataset(args.dataset);  // bad data fails before anything is written
  const std::filesystem::path out =
      args.out.empty() ? std::filesystem::path("out") / ("fit-" + dataset.name) : std::filesystem::path(args.out);
  const std::filesystem::path staging = out.string() + ".partial";

  const bool quiet = args.quiet;
  auto progress = [quiet](int level, const std::string& line) {
    if (quiet) return;
    if (level == 0 || level == 1) std::cout << line << std::endl;
  };
  if (!quiet) std::cout << fmt::format("twill fit {} -> {}\n", dataset.folder, out.string());
  try {
    std::filesystem::remove_all(staging);
    const FitReport report = run_fit(dataset, config, context.registry, progress);
    write_fit_outputs(report, config, staging.string());
    if (!args.no_plots)
      run_python_script(context, "plot_fit.py", {(staging / "report.json").string(), staging.string()});
    std::filesystem::remove_all(out);
    std::filesystem::rename(staging, out);
    if (!quiet) {
      std::cout << fmt::format("done in {:.1f} s: {}/params.yaml, report.md, report.json\n",
                               report.timing_s.back().second, out.string());
    }
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove_all(staging, ignored);
    throw;
  }
}

}  // namespace

void add_fit_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<FitArgs>();
  CLI::App* cmd = app.add_subcommand("fit", "fit the model to a dataset (paper §5): params.yaml + report");
  cmd->add_option("dataset", args->dataset, "dataset folder (fabric.yaml + runs)");
  cmd->add_option("-c,--config", args->config, "config YAML (keys: twill fit --print-config)");
  cmd->add_option("--set", args->sets, "override a config key, KEY=VALUE (repeatable)");
  cmd->add_option("-o,--out", args->out, "output folder (default out/fit-<dataset name>)");
  cmd->add_flag("--quiet", args->quiet, "no progress output");
  cmd->add_flag("--no-plots", args->no_plots, "skip the figures (no matplotlib needed)");
  cmd->add_flag("--print-config", args->print_config, "print the resolved config and exit");
  cmd->callback([&context, args] { run(context, *args); });
}

}  // namespace twill
