// `twill fit DATASET [-c CONFIG.yaml] [--set KEY=VALUE ...] [-o OUTDIR] [--force] [--quiet]`:
// the paper's fitting protocol end to end (fitting/fit_protocol.hpp). Every protocol choice is
// a config key (`twill fit --print-config` lists them with defaults); --set overrides any key,
// e.g. `--set optimizer=ipopt`, `--set discretization=triangle-shell`, `--set resolution.levels=2`.
//
// Outputs (OUTDIR, default out/fit-<dataset name made one safe path component>): params.yaml,
// report.json, report.md, config.yaml (resolved), fig2/3/4 PNGs. Everything is validated
// before any work: config, dataset, the sizes of every simulated strip, and OUTDIR (new, empty
// or a previous twill output unless --force; writable). The outputs are written into
// OUTDIR.partial and moved into OUTDIR at the end, replacing only twill's own files
// (fitting/fit_output_folder.hpp): a failed or interrupted fit never leaves an OUTDIR that
// looks complete. When a stage fails after others finished, their report is kept in
// OUTDIR.incomplete (report-incomplete.md/.json, no params.yaml).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "app/commands.hpp"
#include "app/python_script.hpp"
#include "core/config.hpp"
#include "core/dataset.hpp"
#include "fitting/fit_input_checks.hpp"
#include "fitting/fit_output_folder.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {
namespace {

struct FitArgs {
  std::string dataset, config, out;
  std::vector<std::string> sets;
  bool quiet = false, print_config = false, no_plots = false, force = false;
};

// Runs the protocol; when a stage fails after others finished, keeps their report in
// OUTDIR.incomplete and says so in the error (the error keeps its kind: bad input or failure).
FitReport run_fit_keeping_finished(const Dataset& dataset, const Options& config, const Registry& registry,
                                   const FitProgress& progress, FitOutputFolder& folder) {
  FitReport finished;
  try {
    return run_fit(dataset, config, registry, progress, &finished);
  } catch (const std::exception& e) {
    if (finished.stages.empty()) throw;  // nothing was learned yet
    write_incomplete_fit_report(finished, config, e.what(), folder.staging().string());
    const auto kept = folder.keep_incomplete();
    const std::string where =
        kept ? "; the stages that finished are reported, marked incomplete, in " + (*kept / "report-incomplete.md").string()
             : "; the report of the finished stages could not be kept (" + folder.out().string() +
                   ".incomplete exists and is not twill's)";
    if (const auto* input = dynamic_cast<const InputError*>(&e)) throw InputError(input->where(), input->reason() + where);
    throw std::runtime_error(e.what() + where);
  }
}

// The config file (or the defaults) with the --set overrides; an unknown key of a config
// written before the protocol became data says where it moved.
Options resolved_config(Context& context, const FitArgs& args) {
  const OptionSchema schema = fit_config_schema();
  try {
    Options config = args.config.empty() ? default_options(schema, &context.registry)
                                         : read_config_file(args.config, schema, &context.registry);
    apply_overrides(config, schema, &context.registry, args.sets);
    return config;
  } catch (const InputError& e) {
    const std::string hint = moved_key_hint(e.where().key);
    if (hint.empty()) throw;
    throw InputError(e.where(), e.reason() + "; " + hint);
  }
}

void run(Context& context, const FitArgs& args) {
  const Options config = resolved_config(context, args);
  if (args.print_config) {
    std::cout << options_to_yaml(config);
    return;
  }
  if (args.dataset.empty()) throw InputError({"", 0, "DATASET"}, "twill fit needs a dataset folder");
  // Bad data, impossible sizes and an unacceptable OUTDIR fail before any work.
  const Dataset dataset = read_dataset(args.dataset);
  const ConfigKeyLocator locate = [&](const std::string& key) { return command_line_key_location(args.sets, args.config, key); };
  check_fit_sizes(dataset, config, locate);
  check_fit_protocol(dataset, config, context.registry, locate);
  FitOutputFolder folder(args.out.empty() ? default_fit_folder(dataset.name) : std::filesystem::path(args.out),
                         dataset.folder, args.force);

  const bool quiet = args.quiet;
  auto progress = [quiet](int level, const std::string& line) {
    if (quiet) return;
    if (level == 0 || level == 1) std::cout << line << std::endl;
  };
  if (!quiet) std::cout << fmt::format("twill fit {} -> {}\n", dataset.folder, folder.out().string());
  const FitReport report = run_fit_keeping_finished(dataset, config, context.registry, progress, folder);
  write_fit_outputs(report, config, folder.staging().string());
  if (!args.no_plots)
    run_python_script(context, "plot_fit.py",
                      {(folder.staging() / "report.json").string(), folder.staging().string()});
  folder.commit();
  if (!quiet) {
    std::cout << fmt::format("done in {:.1f} s: {}/params.yaml, report.md, report.json\n",
                             report.timing_s.back().second, folder.out().string());
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
  cmd->add_flag("--force", args->force,
                "write into an existing non-empty folder that is not a twill output (only twill's files are replaced)");
  cmd->add_flag("--quiet", args->quiet, "no progress output");
  cmd->add_flag("--no-plots", args->no_plots, "skip the figures (no matplotlib needed)");
  cmd->add_flag("--print-config", args->print_config, "print the resolved config and exit");
  cmd->callback([&context, args] { run(context, *args); });
}

}  // namespace twill
