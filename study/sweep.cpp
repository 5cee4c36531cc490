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
#include <nlohmann/json.hpp>

#include "core/input_error.hpp"
#include "study/results_db.hpp"
#include "study/run_metrics.hpp"

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

fs::path run_folder(const SweepOptions& options, const StudyRun& run) { return options.out / "runs" / run.hash; }

// A child `twill fit` for `run`, its terminal output in log.txt; never returns in the child.
pid_t start_child(const Study& study, const StudyRun& run, const SweepOptions& options) {
  const fs::path folder = run_folder(options, run);
  fs::create_directories(folder);
  write_config_file(run.config, (folder / "config.yaml").string());
  std::vector<std::string> args = {options.twill.string(), study.command, run.dataset, "-c",
                                   (folder / "config.yaml").string(), "-o", (folder / "fit").string(), "--quiet"};
  if (!study.plots) args.push_back("--no-plots");
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

RunOutcome outcome_of(const StudyRun& run, const SweepOptions& options, int wait_status, double wall_s) {
  const fs::path folder = run_folder(options, run);
  RunOutcome o;
  o.wall_s = wall_s;
  o.out_dir = (folder / "fit").string();
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
    std::ifstream in(folder / "fit" / "report.json");
    o.metrics = fit_metrics(nlohmann::json::parse(in));
    o.status = "done";
  } catch (const std::exception& e) {
    o.status = "failed";
    o.error = std::string("the run ended without a readable report.json: ") + e.what();
  }
  return o;
}

std::string duration(double seconds) {
  if (seconds < 10) return fmt::format("{:.1f} s", seconds);
  if (seconds < 120) return fmt::format("{:.0f} s", seconds);
  if (seconds < 7200) return fmt::format("{:.0f} min", seconds / 60);
  return fmt::format("{:.1f} h", seconds / 3600);
}

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

SweepSummary run_sweep(const Study& study, const SweepOptions& options, const SweepProgress& progress) {
  const auto t0 = Clock::now();
  ResultsDb db(options.out / "results.sqlite");
  SweepSummary summary;
  summary.total = static_cast<int>(study.runs.size());
  std::vector<size_t> pending;
  for (size_t i = 0; i < study.runs.size(); ++i) {
    const auto status = db.status(study.runs[i].hash);
    if (status == "done")
      ++summary.already_done;
    else if (status == "failed" && !options.retry_failed)
      ++summary.skipped_failed;
    else
      pending.push_back(i);
  }
  progress(fmt::format("{} runs: {} done before, {} failed before{}, {} to run, {} at once", summary.total,
                       summary.already_done, summary.skipped_failed,
                       summary.skipped_failed && !options.retry_failed ? " (skipped; --retry-failed re-runs them)" : "",
                       pending.size(), options.jobs));
  struct Active {
    size_t index;
    Clock::time_point start;
  };
  std::map<pid_t, Active> active;
  size_t next = 0;
  double busy_s = 0;  // summed wall time of the finished runs, for the estimate
  const size_t to_run = pending.size();
  while (next < pending.size() || !active.empty()) {
    while (next < pending.size() && active.size() < static_cast<size_t>(options.jobs)) {
      const size_t i = pending[next++];
      db.mark_running(study.runs[i], study.command, static_cast<int>(i), 0);
      active[start_child(study, study.runs[i], options)] = {i, Clock::now()};
    }
    int status = 0;
    const pid_t pid = waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(std::string("twill sweep: waiting for a run: ") + std::strerror(errno));
    }
    const auto it = active.find(pid);
    if (it == active.end()) continue;  // not one of ours
    const StudyRun& run = study.runs[it->second.index];
    const double wall = std::chrono::duration<double>(Clock::now() - it->second.start).count();
    active.erase(it);
    const RunOutcome outcome = outcome_of(run, options, status, wall);
    db.record(run.hash, outcome);
    (outcome.status == "done" ? summary.done : summary.failed)++;
    busy_s += wall;
    const size_t finished = static_cast<size_t>(summary.done + summary.failed);
    const double left = busy_s / static_cast<double>(finished) * static_cast<double>(to_run - finished) /
                        static_cast<double>(options.jobs);
    progress(fmt::format("[{}/{}] {} {} ({}){}; {} failed so far{}", finished, to_run,
                         outcome.status == "done" ? "done" : "FAILED", describe_run(run), duration(wall),
                         outcome.status == "done" ? "" : ": " + outcome.error, summary.failed,
                         finished < to_run ? ", about " + duration(left) + " left" : ""));
  }
  summary.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return summary;
}

}  // namespace twill
