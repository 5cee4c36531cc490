#pragma once
// Running a study (`twill sweep`, issue #17; docs/studies.md).
//
// Each run is its own `twill fit` process (the program itself, given its resolved config as a
// file): a run that fails or crashes — an exception, an abort, a segfault, the memory limit —
// is recorded with its error and the sweep goes on. `jobs` runs go at once. A run's outputs
// are DIR/runs/<hash>/: config.yaml, log.txt (the fit's terminal output) and fit/ (its usual
// outputs). Its rows in DIR/results.sqlite are written when it starts ('running') and when it
// ends, each in one transaction, so a sweep killed at any moment loses only its unfinished
// runs; re-running the study skips every run already done (same hash) and re-runs the
// unfinished ones, and the failed ones when asked (`retry_failed`). A run's child process is
// killed with the sweep (Linux's parent-death signal), so no orphan writes after it.
#include <filesystem>
#include <functional>
#include <string>

#include "study/study_file.hpp"

namespace twill {

class MpiTransport;

/// The marker file in every folder `twill sweep` fills.
inline constexpr const char* kSweepMarkerFile = ".twill-sweep";

struct SweepOptions {
  std::filesystem::path out;    ///< DIR: results.sqlite, runs/
  std::filesystem::path twill;  ///< the program each run executes (this one)
  int jobs = 1;                 ///< runs at once
  bool retry_failed = false;    ///< re-run the runs recorded as failed
  bool refresh_metrics = false; ///< re-read the done runs' report.json into their metrics
};

struct SweepSummary {
  int total = 0;            ///< runs in the study
  int already_done = 0;     ///< skipped: done in an earlier sweep
  int skipped_failed = 0;   ///< skipped: failed in an earlier sweep (retry_failed off)
  int done = 0, failed = 0; ///< of the runs this sweep ran
  double wall_s = 0;
};

/// One line of progress for people.
using SweepProgress = std::function<void(const std::string& line)>;

/// Accepts DIR when it is new, empty, or an earlier sweep's (its marker); creates it with the
/// marker. Anything else is an InputError located at `option` (nothing of it is touched).
void prepare_sweep_folder(const std::filesystem::path& out, const std::string& option);

/// Runs every run of `study` not done yet (see the header comment). Under MPI (`mpi` given,
/// rank 0): also hands runs to the worker ranks that ask (serve_sweep_worker), each of which
/// runs `options.jobs` at once too; rank 0 alone touches the database.
SweepSummary run_sweep(const Study& study, const SweepOptions& options, const SweepProgress& progress,
                       const MpiTransport* mpi = nullptr);

/// A worker rank (> 0): asks rank 0 for runs, runs them as children (`options.jobs` at once;
/// `options.twill` the program), sends back each outcome, until rank 0 says stop.
void serve_sweep_worker(const MpiTransport& mpi, const SweepOptions& options);

/// Rank 0 whose study or folder was rejected: tells every worker to end without a run.
void stop_sweep_workers(const MpiTransport& mpi);

}  // namespace twill
