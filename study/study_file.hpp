#pragma once
// Study files of `twill sweep` (issue #17; docs/studies.md): a list of datasets and, for any
// config key, a list of values; the study is their product (or an explicit list of
// combinations), each run a `twill fit` (or `twill simulate`) with its own resolved config.
//
//   command: fit                      # or simulate (study/study_command.hpp); default fit
//   datasets: [../../examples/canvas] # folders, relative to the study file's folder
//                                     # (simulate: params: [params.yaml files], same rule)
//   config: base.yaml                 # optional base config (else the defaults), same folder rule
//   vary:                             # any config key: a list of values; the product is run
//     optimizer.name: [gauss-newton, bfgs]
//     resolution.levels: [1, 2]
//   combinations:                     # or instead of vary: the runs' values, one mapping each
//     - {optimizer.name: bfgs, resolution.levels: 1}
//   set: {degree.max: 3}              # fixed overrides for every run
//   plots: false                      # each fit's figures (scripts/plot_fit.py); default off
//   report:                           # the tables `twill report` makes by default
//     - {metric: error.fit, x: resolution.levels, group: [optimizer.name]}
//     - {metric: param.*, x: cells_across, group: [discretization], convergence: true}
//
// Everything is validated when the file is read, before any run starts: unknown keys of the
// study, a config key or value the fit config rejects (the error names the study file, the
// line of the value and the config's own reason, e.g. its known keys), an unreadable dataset,
// a resolution or protocol the dataset cannot run (check_fit_sizes, check_fit_protocol).
#include <string>
#include <utility>
#include <vector>

#include "core/config.hpp"

namespace twill {

class Registry;

/// One run of a study: a dataset and a resolved config.
struct StudyRun {
  std::string dataset;  ///< the input: dataset folder (fit) or params file (simulate), resolved
  /// The run's coordinates, in study order: ("dataset", as written in the study), then each
  /// varied key with its value as YAML text.
  std::vector<std::pair<std::string, std::string>> values;
  Options config;    ///< the command's config: base config, `set`, then the run's values
  std::string hash;  ///< 16 hex digits of FNV-1a over command, dataset and the resolved config
};

/// One table of `twill report` (study/report.hpp): `metric` (a metric name, or a pattern with
/// `*` such as `param.*`: a table each) against the swept key `x`, a column for each value of
/// the `group` keys.
struct ReportTable {
  std::string metric, x;
  std::vector<std::string> group;
  bool convergence = false;  ///< add the observed order and Richardson limit per column
};

struct Study {
  std::string path;     ///< the study file
  std::string command;  ///< "fit", "simulate" (study/study_command.hpp)
  bool plots = false;   ///< each run's figures
  std::vector<StudyRun> runs;
  std::vector<ReportTable> report;  ///< `report:` (x and group keys checked to be swept)
};

/// Reads, expands and validates a study file (see the header comment); InputError on any
/// problem, located in the study file.
Study read_study_file(const std::string& path, const Registry& registry);

/// The run's values as one line, e.g. "dataset=canvas optimizer.name=bfgs".
std::string describe_run(const StudyRun& run);

}  // namespace twill
