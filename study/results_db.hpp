#pragma once
// The results database of a study (`DIR/results.sqlite`, issue #17; docs/studies.md §3):
//
//   runs(hash PRIMARY KEY, command, dataset, run_order, status, exit_code, error, wall_s,
//        started, finished, rank, out_dir, config_yaml)
//        status: 'running' (started, not finished: an interrupted sweep left it), 'done',
//        'failed' (the run's own error message in `error`; a crash says which signal)
//   swept(hash, key, value)      the run's coordinates: dataset and each varied config key
//   metrics(hash, name, value)   what the run measured (study/run_metrics.hpp): per-test and
//                                per-stage errors, fitted parameters, per-stage timings,
//                                solver and optimiser counts
//   meta(key, value)             schema_version; study (the study file's path) and report (its
//                                `report:` tables as JSON), written by the sweep
//
// A run's rows are written in one transaction when it finishes, so a killed sweep leaves every
// finished run complete and nothing half-written. Debian's libsqlite3; every failing call
// throws std::runtime_error with SQLite's message and the file.
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

struct sqlite3;

namespace twill {

struct StudyRun;

/// What a finished run left: its status and what it measured.
struct RunOutcome {
  std::string status;  ///< "done" or "failed"
  int exit_code = 0;   ///< the child's exit status; −signal when it was killed by one
  std::string error;   ///< the run's error message (failed runs)
  double wall_s = 0;
  std::string out_dir;
  std::vector<std::pair<std::string, double>> metrics;
};

class ResultsDb {
 public:
  enum class Access { create, read_only };
  /// Opens the database: with `create`, creating it and its tables when new; `read_only`
  /// requires an existing twill results database (std::runtime_error naming the file if not).
  explicit ResultsDb(const std::filesystem::path& file, Access access = Access::create);
  ~ResultsDb();
  ResultsDb(const ResultsDb&) = delete;
  ResultsDb& operator=(const ResultsDb&) = delete;

  /// The stored status of a run ("running", "done", "failed"), nullopt when never started.
  std::optional<std::string> status(const std::string& hash) const;
  /// Records that a run started (status 'running', its coordinates and config).
  void mark_running(const StudyRun& run, const std::string& command, int order, int rank);
  /// Records a finished run: status, error, time and metrics replace what was stored.
  void record(const std::string& hash, const RunOutcome& outcome);

  /// A meta value, nullopt when unset.
  std::optional<std::string> meta(const std::string& key) const;
  void set_meta(const std::string& key, const std::string& value);

  /// Replaces a finished run's metrics (its status and times stay): `twill sweep
  /// --refresh-metrics` after twill learnt new ones.
  void replace_metrics(const std::string& hash, const std::vector<std::pair<std::string, double>>& metrics);

  /// Rows of a query with text columns (for `twill report` and tests).
  std::vector<std::vector<std::string>> query(const std::string& sql) const;

 private:
  void check_schema(bool create);
  void write_metrics(const std::string& hash, const std::vector<std::pair<std::string, double>>& metrics);
  void execute(const std::string& sql) const;
  sqlite3* db_ = nullptr;
  std::string file_;
};

}  // namespace twill
