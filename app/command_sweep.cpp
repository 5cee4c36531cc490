// `twill sweep STUDY.yaml [-o DIR] [--jobs N] [--retry-failed] [--quiet]`: every run of a study
// (study/study_file.hpp), each a `twill fit` of its own, results in DIR/results.sqlite
// (study/results_db.hpp), outputs in DIR/runs/<hash>/ (study/sweep.hpp). The study is
// validated whole before the first run; a failing run is recorded and the sweep goes on;
// re-running skips what is done. Exit status 0 when every run is done, 1 when any failed.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <stdexcept>

#include "app/commands.hpp"
#include "fitting/fit_output_folder.hpp"
#include "study/mpi_transport.hpp"
#include "study/study_file.hpp"
#include "study/sweep.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

// Runs at once, at most: more than a few per core only thrashes.
constexpr int kMaxJobs = 256;

struct SweepArgs {
  std::string study, out;
  int jobs = 1;
  bool retry_failed = false, refresh_metrics = false, quiet = false;
};

SweepOptions sweep_options(const SweepArgs& args) {
  if (args.jobs < 1 || args.jobs > kMaxJobs)
    throw InputError({"command line", 0, "--jobs"}, fmt::format("expected 1 … {} runs at once, got {}", kMaxJobs, args.jobs));
  SweepOptions options;
  options.out = args.out.empty() ? fs::path("out") / ("sweep-" + safe_path_component(fs::path(args.study).stem().string()))
                                 : fs::path(args.out);
  options.twill = fs::read_symlink("/proc/self/exe");
  options.jobs = args.jobs;
  options.retry_failed = args.retry_failed;
  options.refresh_metrics = args.refresh_metrics;
  return options;
}

// The study's runs on this machine, or on rank 0 of an MPI job with `mpi`.
void lead(Context& context, const SweepArgs& args, const MpiTransport* mpi) {
  const SweepOptions options = sweep_options(args);
  const Study study = read_study_file(args.study, context.registry);
  prepare_sweep_folder(options.out, "-o");
  const bool quiet = args.quiet;
  if (!quiet) std::cout << fmt::format("twill sweep {} -> {}\n", args.study, options.out.string());
  const SweepSummary s = run_sweep(
      study, options,
      [quiet](const std::string& line) {
        if (!quiet) std::cout << line << std::endl;
      },
      mpi);
  if (!quiet)
    std::cout << fmt::format("sweep finished in {:.1f} s: {} done, {} failed this time; {} done before; {}\n", s.wall_s,
                             s.done, s.failed, s.already_done, (options.out / "results.sqlite").string());
  if (s.failed > 0)
    throw std::runtime_error(fmt::format("{} of {} runs failed (their errors are in {}: runs.error)", s.failed,
                                         s.done + s.failed, (options.out / "results.sqlite").string()));
}

// Under mpirun (docs/studies.md §4): rank 0 leads — reads the study, owns the database, runs
// `--jobs` fits itself — and the other ranks run what it sends them. When rank 0 rejects the
// study or the folder, it tells the workers to stop before it reports the error.
void run_under_mpi(Context& context, const SweepArgs& args) {
  const MpiTransport mpi;
  if (mpi.rank() > 0) return serve_sweep_worker(mpi, sweep_options(args));
  try {
    lead(context, args, &mpi);
  } catch (...) {
    stop_sweep_workers(mpi);
    throw;
  }
}

void run(Context& context, const SweepArgs& args) {
  if (launched_by_mpi()) return run_under_mpi(context, args);
  lead(context, args, nullptr);
}

}  // namespace

void add_sweep_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<SweepArgs>();
  CLI::App* cmd = app.add_subcommand("sweep", "run a study file's fits (docs/studies.md): results.sqlite + one folder per run");
  cmd->add_option("study", args->study, "study file (YAML: datasets, vary, set)")->required();
  cmd->add_option("-o,--out", args->out, "output folder (default out/sweep-<study file name>)");
  cmd->add_option("--jobs", args->jobs, "runs at once (default 1)");
  cmd->add_flag("--retry-failed", args->retry_failed, "re-run the runs an earlier sweep recorded as failed");
  cmd->add_flag("--refresh-metrics", args->refresh_metrics,
                "re-read every done run's report.json into its metrics (after twill learnt new ones)");
  cmd->add_flag("--quiet", args->quiet, "no progress output");
  cmd->callback([&context, args] { run(context, *args); });
}

}  // namespace twill
