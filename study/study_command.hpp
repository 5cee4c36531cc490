#pragma once
// The commands a study can run (the study file's `command`; docs/studies.md §1, §7): for each,
// what its runs take as input, the config schema their values are checked against, the
// checks that need the input, how a child process runs one, and where its result and
// metrics are. One table, so the study reader, the sweep and `--refresh-metrics` agree.
//
//   fit       datasets: [folders]     child `twill fit DATASET -c config.yaml -o RUN/fit`,
//                                     metrics from RUN/fit/report.json (study/run_metrics.hpp)
//   simulate  params: [params.yaml]   child `twill simulate --params P -c config.yaml --json
//                                     --out RUN/simulate.json`, metrics from that file
//   discover  datasets: [folders]     child `twill discover DATASET -c config.yaml -o RUN/discover`,
//                                     metrics from RUN/discover/discover.json (discover_metrics)
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "core/config.hpp"
#include "core/input_error.hpp"

namespace twill {

class Registry;

struct StudyCommand {
  std::string name;       ///< "fit", "simulate", "discover"
  std::string input_key;  ///< the study file's list of inputs: "datasets", "params"
  std::string input_coordinate;  ///< a run's first coordinate, e.g. dataset=canvas: "dataset", "params"
  bool input_is_folder;   ///< datasets are folders, params files
  OptionSchema (*schema)();
  /// Checks a run's resolved config against its input (errors located by `locate`).
  void (*check)(const std::string& input, const Options& config, const Registry& registry,
                const ConfigKeyLocator& locate);
  /// The child's arguments after the program path; `run` is the run's folder.
  std::vector<std::string> (*child_args)(const std::string& input, const std::filesystem::path& run, bool plots);
  /// The run's output (a folder or a file) and the file its metrics are read from.
  std::filesystem::path (*output)(const std::filesystem::path& run);
  std::filesystem::path (*result)(const std::filesystem::path& run);
  std::vector<std::pair<std::string, double>> (*metrics)(const std::filesystem::path& result);
};

/// The commands, `fit` first (the default).
const std::vector<StudyCommand>& study_commands();
/// The command named `name`; nullptr when none is.
const StudyCommand* find_study_command(const std::string& name);

}  // namespace twill
