#pragma once
// Tables of a study's results (`twill report DB`, issue #17; docs/studies.md §5): any metric
// against any swept key, a column per value of the group keys, from DIR/results.sqlite.
//
// A cell is the metric over the done runs with that x and those group values: the value when
// one run has it, else the mean of the n runs (the table says so: keys neither x nor group
// then vary inside a cell). Failed and unfinished runs are listed apart, never averaged in.
// x values sort as numbers when all are numbers, else in the study's run order. The group may
// hold the pseudo key `metric`: one table whose columns are the metrics a pattern matches
// (e.g. error.fit.* against dataset with group [metric]: the paper's Table 3 layout).
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "study/study_file.hpp"

namespace twill {

class ResultsDb;

struct ReportCell {
  double mean = 0, min = 0, max = 0;
  int count = 0;
};

/// Refinement of one column against a numeric x with a constant ratio r between its last
/// three values (e.g. cells across 8, 16, 32): the observed order p = log(|d1/d2|)/log r of
/// the last two differences, the Richardson limit P3 + d2/(r^p − 1), and the first x from
/// which every value is within kLimitBand of that limit (docs/studies.md §5).
struct ReportConvergence {
  double order = 0, limit = 0;
  std::string within_from;  ///< "" when no value is within the band
  bool asymptotic = false;  ///< the last two differences have one sign (else no order, no limit)
};

/// The band of "within 1 % of its limit" (issue #17's mesh-independence question).
inline constexpr double kLimitBand = 0.01;

struct ReportTableData {
  std::string metric, x;
  std::vector<std::string> group;
  bool convergence = false;
  std::vector<std::string> x_values;  ///< rows
  std::vector<std::string> columns;   ///< "key=value, …" of each group combination ("all" when no group)
  std::vector<std::vector<std::optional<ReportCell>>> cells;  ///< [row][column]
  bool numeric_x = false;
  /// Per column, when asked for and x is numeric with a constant ratio over its last three
  /// values (nullopt for a column without those three values).
  std::vector<std::optional<ReportConvergence>> refinement;
};

/// The tables of `spec` (a metric pattern with `*` gives a table per matching metric). An
/// unknown metric, x or group key is an InputError located at `where` ("--metric", or the
/// study file) that lists the known ones.
std::vector<ReportTableData> tabulate(const ResultsDb& db, const ReportTable& spec, const std::string& where);

/// The tables a database asks for when the command line names none: the study's `report:`,
/// else every error metric and the total time against each swept key that takes more than one
/// value, grouped by the other such keys.
std::vector<ReportTable> default_report_tables(const ResultsDb& db);

/// A table as Markdown (values to 4 significant digits; "—" where no run has the value).
std::string markdown(const ReportTableData& table);
/// The runs that are not done (status, swept values, error), as Markdown; "" when none.
std::string unfinished_runs_markdown(const ResultsDb& db);

nlohmann::json to_json(const ReportTable& table);
ReportTable report_table_from_json(const nlohmann::json& j);
/// A table's data for scripts/plot_report.py.
nlohmann::json plot_json(const ReportTableData& table);

}  // namespace twill
