#pragma once
// The `twill` program: one file per command (command_<name>.cpp), each adding itself to the
// CLI11 app with one function, so a new command is one file plus one line in main.cpp.
//
// Conventions every command follows:
// - output for people goes to stdout; errors are thrown, never printed and swallowed;
// - bad input (files, options) throws twill::InputError: main prints `twill: error: <msg>` and
//   exits with status 2; any other failure exits with status 1;
// - implementations are created through Context::registry (core/registry.hpp), never by
//   naming concrete classes, so every registered alternative is reachable from the command line.
#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <utility>

#include "core/input_limits.hpp"
#include "core/registry.hpp"

namespace twill {

/// What every command may use. Built once in main().
struct Context {
  Registry registry;                   ///< every registered implementation
  std::filesystem::path scripts_dir;   ///< the repository's scripts/ (plot helpers)
  std::string python = "/usr/bin/python3";  ///< Debian's python, which sees python3-matplotlib
};

// ---- Argument checks shared by the commands (app/command_args.cpp) ---------------------------

/// "NxM" (cells across x along, e.g. 16x24) read strictly and checked against the memory limit
/// of core/input_limits.hpp; errors are InputErrors naming `option` (e.g. "--resolution").
std::pair<int, int> parse_resolution(const std::string& text, const std::string& option);
/// `value` (given as `option`) checked against a physical range of core/input_limits.hpp.
double checked_argument(double value, const PhysicalRange& range, const std::string& option);

/// `twill list [CATEGORY]`: every registered name per category, with description and options.
void add_list_command(CLI::App& app, Context& context);
/// `twill inspect DATASET [--plot FILE] [--seed N]`: summary of a dataset folder, optional plot.
void add_inspect_command(CLI::App& app, Context& context);
/// `twill simulate ...`: one tensile curve or cantilever (command_simulate.cpp).
void add_simulate_command(CLI::App& app, Context& context);
/// `twill bench --reference DIR`: tensile-curve timings per discretization and resolution.
void add_bench_command(CLI::App& app, Context& context);
/// `twill fit DATASET [-c CONFIG] [--set K=V] [-o OUTDIR]`: the paper's protocol (command_fit.cpp).
void add_fit_command(CLI::App& app, Context& context);
/// `twill discover DATASET [-c CONFIG] [--set K=V] [-o OUTDIR]`: the missing effect (command_discover.cpp).
void add_discover_command(CLI::App& app, Context& context);
/// `twill recover ...`: one parameter-recovery run (optimiser studies, command_recover.cpp).
void add_recover_command(CLI::App& app, Context& context);
/// `twill sweep STUDY.yaml [-o DIR] [--jobs N]`: a study's fits, results in SQLite (command_sweep.cpp).
void add_sweep_command(CLI::App& app, Context& context);
/// `twill report DB`: tables and plots of a study's results (study/report.hpp).
void add_report_command(CLI::App& app, Context& context);

}  // namespace twill
