// Running a study's fits as child processes (study/sweep.hpp).
#include "study/sweep.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <nlohmann/json.hpp>

#include "core/input_error.hpp"
#include "study/mpi_transport.hpp"
#include "study/report.hpp"
#include "study/results_db.hpp"
#include "study/run_metrics.hpp"
#include "study/study_command.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The prefix main() gives every error message (app/main.cpp).
constexpr const char* kErrorPrefix = "twill: error: ";

bool is_empty_folder(const fs::path& p) {
  std::error_code ec;
  return fs::is_empty(p, ec) && !ec;
}

// A run as the process that runs it needs it: all a worker rank is sent.
struct RunTask {
  std::string hash, command, dataset, config_yaml;
  std::string folder;  ///< DIR/runs/<hash>, absolute (a worker rank may have another working folder)
  bool plots = false;
};

RunTask task_of(const Study& study, const StudyRun& run, const SweepOptions& options) {
  return {run.hash, study.command, run.dataset, options_to_yaml(run.config),
          fs::absolute(options.out / "runs" / run.hash).string(), study.plots};
}

nlohmann::json to_json(const RunTask& t) {
  return {{"hash", t.hash},     {"command", t.command}, {"dataset", t.dataset},
          {"config", t.config_yaml}, {"folder", t.folder},   {"plots", t.plots}};
}

RunTask task_from_json(const std::string& bytes) {
  const auto j = nlohmann::json::parse(bytes);
  return {j.at("hash"), j.at("command"), j.at("dataset"), j.at("config"), j.at("folder"), j.at("plots")};
}

nlohmann::json to_json(const RunOutcome& o) {
  return {{"status", o.status}, {"exit_code", o.exit_code}, {"error", o.error},
          {"wall_s", o.wall_s}, {"out_dir", o.out_dir},     {"metrics", o.metrics}};
}

RunOutcome outcome_from_json(const nlohmann::json& j) {
  RunOutcome o;
  o.status = j.at("status");
  o.exit_code = j.at("exit_code");
  o.error = j.at("error");
  o.wall_s = j.at("wall_s");
  o.out_dir = j.at("out_dir");
  o.metrics = j.at("metrics").get<std::vector<std::pair<std::string, double>>>();
  return o;
}

const StudyCommand& command_of(const RunTask& task) {
  const StudyCommand* command = find_study_command(task.command);
  if (!command) throw std::runtime_error("twill sweep: a run of unknown command '" + task.command + "'");
  return *command;
}

// A child `twill <command>` for `task`, its terminal output in log.txt; never returns in the child.
pid_t start_child(const RunTask& task, const fs::path& program) {
  const fs::path folder = task.folder;
  fs::create_directories(folder);
  {
    std::ofstream config(folder / "config.yaml", std::ios::binary);
    config << task.config_yaml;
    if (!config.flush()) throw std::runtime_error("twill sweep: cannot write " + (folder / "config.yaml").string());
  }
  std::vector<std::string> args = {program.string()};
  for (std::string& a : command_of(task).child_args(task.dataset, folder, task.plots)) args.push_back(std::move(a));
  const std::string log = (folder / "log.txt").string();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("twill sweep: cannot start a run: ") + std::strerror(errno));
  if (pid > 0) return pid;
  // The child: die with the sweep (no orphan writing into a folder a resumed sweep re-runs).
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(127);
  const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd >= 0) {
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    close(fd);
  }
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  std::fprintf(stderr, "%scannot execute %s: %s\n", kErrorPrefix, argv[0], std::strerror(errno));
  _exit(127);
}

// The run's own error: the last `twill: error:` line of its log.
std::string error_of(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line))
    if (line.rfind(kErrorPrefix, 0) == 0) last = line.substr(std::strlen(kErrorPrefix));
  return last;
}

RunOutcome outcome_of(const RunTask& task, int wait_status, double wall_s) {
  const fs::path folder = task.folder;
  RunOutcome o;
  o.wall_s = wall_s;
  const StudyCommand& command = command_of(task);
  o.out_dir = command.output(folder).string();
  if (WIFSIGNALED(wait_status)) {
    o.status = "failed";
    o.exit_code = -WTERMSIG(wait_status);
    o.error = fmt::format("crashed: signal {} ({})", WTERMSIG(wait_status), strsignal(WTERMSIG(wait_status)));
    return o;
  }
  o.exit_code = WEXITSTATUS(wait_status);
  if (o.exit_code != 0) {
    o.status = "failed";
    o.error = error_of(folder / "log.txt");
    if (o.error.empty()) o.error = fmt::format("exit status {} without an error message", o.exit_code);
    return o;
  }
  try {
    o.metrics = command.metrics(command.result(folder));
    o.status = "done";
  } catch (const std::exception& e) {
    o.status = "failed";
    o.error = "the run ended without a readable " + command.result(folder).filename().string() + ": " + e.what();
  }
  return o;
}

std::string duration(double seconds) {
  if (seconds < 10) return fmt::format("{:.1f} s", seconds);
  if (seconds < 120) return fmt::format("{:.0f} s", seconds);
  if (seconds < 7200) return fmt::format("{:.0f} min", seconds / 60);
  return fmt::format("{:.1f} h", seconds / 3600);
}

// Messages between the ranks (docs/studies.md §4): a worker asks for a run (kRequest, one
// at a time), rank 0 answers with one (kTask) or tells it to stop (kStop); the worker sends
// every finished run's outcome (kResult) and ends after kStop once its runs are finished.
enum MessageTag : int { kRequest = 1, kTask = 2, kStop = 3, kResult = 4 };

// How long a scheduler with nothing to do sleeps between looks at its children and messages:
// nothing against a run (seconds at least), nothing for the processor either.
constexpr auto kIdlePoll = std::chrono::milliseconds(20);

// The runs this process has going as children.
class ChildRuns {
 public:
  explicit ChildRuns(fs::path program) : program_(std::move(program)) {}
  size_t size() const { return active_.size(); }
  void start(RunTask task) {
    const pid_t pid = start_child(task, program_);
    active_.emplace(pid, Active{std::move(task), Clock::now()});
  }
  /// A finished run and its outcome; nullopt when none has finished (`block`: waits for one).
  std::optional<std::pair<RunTask, RunOutcome>> reap(bool block) {
    while (!active_.empty()) {
      int status = 0;
      const pid_t pid = waitpid(-1, &status, block ? 0 : WNOHANG);
      if (pid == 0) return std::nullopt;
      if (pid < 0) {
        if (errno == EINTR) continue;
        throw std::runtime_error(std::string("twill sweep: waiting for a run: ") + std::strerror(errno));
      }
      const auto it = active_.find(pid);
      if (it == active_.end()) continue;  // not one of ours
      const double wall = std::chrono::duration<double>(Clock::now() - it->second.start).count();
      RunTask task = std::move(it->second.task);
      active_.erase(it);
      RunOutcome outcome = outcome_of(task, status, wall);
      return std::make_pair(std::move(task), std::move(outcome));
    }
    return std::nullopt;
  }

 private:
  struct Active {
    RunTask task;
    Clock::time_point start;
  };
  fs::path program_;
  std::map<pid_t, Active> active_;
};

// Rank 0 (or the only process): hands the study's pending runs to its own children and to the
// worker ranks that ask, records every start and end in the database, reports progress.
class Scheduler {
 public:
  Scheduler(const Study& study, const SweepOptions& options, const SweepProgress& progress, const MpiTransport* mpi)
      : study_(study), options_(options), progress_(progress), mpi_(mpi), db_(options.out / "results.sqlite"),
        children_(options.twill) {}

  SweepSummary run() {
    const auto t0 = Clock::now();
    record_study();
    select_pending();
    const int ranks = mpi_ ? mpi_->size() : 1;
    progress_(fmt::format("{} runs: {} done before, {} failed before{}, {} to run, {} at once{}", summary_.total,
                          summary_.already_done, summary_.skipped_failed,
                          summary_.skipped_failed && !options_.retry_failed ? " (skipped; --retry-failed re-runs them)" : "",
                          pending_.size(), options_.jobs * ranks, ranks > 1 ? fmt::format(" on {} ranks", ranks) : ""));
    answer_first_requests();
    while (!finished()) {
      while (next_ < pending_.size() && children_.size() < static_cast<size_t>(options_.jobs))
        children_.start(dispatch(0));
      bool idle = true;
      if (auto done = children_.reap(mpi_ == nullptr)) {
        record(done->first.hash, done->second, 0);
        idle = false;
      }
      if (mpi_)
        while (auto message = mpi_->poll()) {
          handle(*message);
          idle = false;
        }
      if (idle && mpi_) std::this_thread::sleep_for(kIdlePoll);
    }
    summary_.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
    return summary_;
  }

 private:
  // What `twill report` reads of the study: its path and its `report:` tables.
  void record_study() {
    db_.set_meta("study", fs::absolute(study_.path).string());
    nlohmann::json tables = nlohmann::json::array();
    for (const ReportTable& t : study_.report) tables.push_back(to_json(t));
    db_.set_meta("report", tables.dump());
  }
  void select_pending() {
    summary_.total = static_cast<int>(study_.runs.size());
    for (size_t i = 0; i < study_.runs.size(); ++i) {
      const auto status = db_.status(study_.runs[i].hash);
      if (status == "done" && options_.refresh_metrics) refresh_metrics(study_.runs[i]);
      if (status == "done")
        ++summary_.already_done;
      else if (status == "failed" && !options_.retry_failed)
        ++summary_.skipped_failed;
      else
        pending_.push_back(i);
    }
  }
  // A done run's metrics read again from its result (metrics a newer twill knows).
  void refresh_metrics(const StudyRun& run) {
    const StudyCommand* command = find_study_command(study_.command);
    try {
      db_.replace_metrics(run.hash, command->metrics(command->result(options_.out / "runs" / run.hash)));
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("--refresh-metrics: ") + e.what());
    }
  }
  // Under MPI, each worker's first request is answered before rank 0 starts runs of its own,
  // so that the workers get runs by the order of the study, not by the race between their
  // start-up and rank 0's first fits (a short study could otherwise all run on rank 0).
  void answer_first_requests() {
    if (!mpi_) return;
    std::set<int> asked;
    while (asked.size() < static_cast<size_t>(mpi_->size() - 1)) {
      if (auto message = mpi_->poll()) {
        if (message->tag == kRequest) asked.insert(message->source);
        handle(*message);
      } else {
        std::this_thread::sleep_for(kIdlePoll);
      }
    }
  }
  bool finished() const {
    const int workers = mpi_ ? mpi_->size() - 1 : 0;
    return next_ == pending_.size() && running_.empty() && stopped_workers_ == workers;
  }
  // The next pending run, marked running on `rank`.
  RunTask dispatch(int rank) {
    const size_t i = pending_[next_++];
    db_.mark_running(study_.runs[i], study_.command, static_cast<int>(i), rank);
    running_[study_.runs[i].hash] = i;
    return task_of(study_, study_.runs[i], options_);
  }
  void handle(const MpiMessage& message) {
    if (message.tag == kRequest) {
      if (next_ < pending_.size()) {
        mpi_->send(message.source, kTask, to_json(dispatch(message.source)).dump());
      } else {
        mpi_->send(message.source, kStop, "");
        ++stopped_workers_;
      }
    } else if (message.tag == kResult) {
      const auto j = nlohmann::json::parse(message.bytes);
      record(j.at("hash"), outcome_from_json(j.at("outcome")), message.source);
    }
  }
  void record(const std::string& hash, const RunOutcome& outcome, int rank) {
    const auto it = running_.find(hash);
    if (it == running_.end()) throw std::logic_error("twill sweep: an outcome of run " + hash + ", which is not running");
    const StudyRun& run = study_.runs[it->second];
    running_.erase(it);
    db_.record(hash, outcome);
    (outcome.status == "done" ? summary_.done : summary_.failed)++;
    busy_s_ += outcome.wall_s;
    const size_t finished = static_cast<size_t>(summary_.done + summary_.failed), to_run = pending_.size();
    const int slots = options_.jobs * (mpi_ ? mpi_->size() : 1);
    const double left = busy_s_ / static_cast<double>(finished) * static_cast<double>(to_run - finished) / slots;
    progress_(fmt::format("[{}/{}] {} {} ({}{}){}; {} failed so far{}", finished, to_run,
                          outcome.status == "done" ? "done" : "FAILED", describe_run(run), duration(outcome.wall_s),
                          mpi_ ? fmt::format(", rank {}", rank) : "", outcome.status == "done" ? "" : ": " + outcome.error,
                          summary_.failed, finished < to_run ? ", about " + duration(left) + " left" : ""));
  }

  const Study& study_;
  const SweepOptions& options_;
  const SweepProgress& progress_;
  const MpiTransport* mpi_;
  ResultsDb db_;
  ChildRuns children_;
  SweepSummary summary_;
  std::vector<size_t> pending_;
  size_t next_ = 0;
  std::map<std::string, size_t> running_;  // hash -> study index of every run started, not finished
  int stopped_workers_ = 0;
  double busy_s_ = 0;  // summed wall time of the finished runs, for the estimate
};

}  // namespace

void prepare_sweep_folder(const fs::path& out, const std::string& option) {
  auto fail = [&](const std::string& what) {
    throw InputError({"command line", 0, option}, "output folder " + out.string() + ": " + what);
  };
  if (out.empty()) fail("an empty path");
  std::error_code ec;
  if (fs::exists(fs::symlink_status(out, ec))) {
    if (!fs::is_directory(out, ec)) fail("exists and is not a folder; twill never replaces a file");
    if (fs::exists(out / "fabric.yaml")) fail("holds a fabric.yaml: it is a dataset folder, never an output folder");
    if (!fs::exists(out / kSweepMarkerFile) && !is_empty_folder(out))
      fail(std::string("exists, is not empty and is not a twill sweep (no ") + kSweepMarkerFile +
           " marker); choose another -o");
    if (access(out.c_str(), W_OK | X_OK) != 0) fail(std::string("not writable: ") + std::strerror(errno));
  }
  fs::create_directories(out / "runs", ec);
  if (ec) fail("cannot be created: " + ec.message());
  std::ofstream(out / kSweepMarkerFile) << "twill sweep output: results.sqlite and runs/<hash>/\n";
  if (!fs::exists(out / kSweepMarkerFile)) fail("not writable");
}

SweepSummary run_sweep(const Study& study, const SweepOptions& options, const SweepProgress& progress,
                       const MpiTransport* mpi) {
  return Scheduler(study, options, progress, mpi).run();
}

void serve_sweep_worker(const MpiTransport& mpi, const SweepOptions& options) {
  ChildRuns children(options.twill);
  bool stopped = false, asked = false;
  while (!stopped || children.size() > 0) {
    if (!stopped && !asked && children.size() < static_cast<size_t>(options.jobs)) {
      mpi.send(0, kRequest, "");
      asked = true;
    }
    bool idle = true;
    if (auto message = mpi.poll()) {
      idle = false;
      asked = false;
      if (message->tag == kTask) children.start(task_from_json(message->bytes));
      if (message->tag == kStop) stopped = true;
    }
    if (auto done = children.reap(false)) {
      idle = false;
      mpi.send(0, kResult, nlohmann::json{{"hash", done->first.hash}, {"outcome", to_json(done->second)}}.dump());
    }
    if (idle) std::this_thread::sleep_for(kIdlePoll);
  }
}

void stop_sweep_workers(const MpiTransport& mpi) {
  for (int rank = 1; rank < mpi.size(); ++rank) mpi.send(rank, kStop, "");
}

}  // namespace twill
