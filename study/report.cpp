// Tables of a study's results (study/report.hpp).
#include "study/report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <cstdlib>
#include <map>
#include <set>

#include "core/input_error.hpp"
#include "study/results_db.hpp"

namespace twill {
namespace {

using Rows = std::vector<std::vector<std::string>>;

// The pseudo group key whose values are the matched metrics' names: one table, a column each.
constexpr const char* kMetricKey = "metric";

// The metrics every default report shows: the errors, and the time a run took.
constexpr const char* kDefaultErrorPrefix = "error.";
constexpr const char* kDefaultTimeMetric = "time.total";

std::string quoted(const std::string& text) {  // an SQL string literal
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

// `*` matches any run of characters; every other character itself (metric names hold '[').
bool matches(const std::string& pattern, const std::string& name) {
  const size_t star = pattern.find('*');
  if (star == std::string::npos) return pattern == name;
  if (name.compare(0, star, pattern, 0, star) != 0) return false;
  const std::string rest = pattern.substr(star + 1);
  for (size_t from = star; from <= name.size(); ++from)
    if (matches(rest, name.substr(from))) return true;
  return false;
}

bool is_number(const std::string& text) {
  if (text.empty()) return false;
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  return *end == '\0';
}

std::vector<std::string> column(const Rows& rows, size_t c) {
  std::vector<std::string> out;
  for (const auto& r : rows) out.push_back(r.at(c));
  return out;
}

std::string known_list(const std::vector<std::string>& names) {
  return names.empty() ? "none" : fmt::format("{}", fmt::join(names, ", "));
}

// Each done run's swept values (hash -> key -> value), in run order.
struct DoneRuns {
  std::vector<std::string> hashes;
  std::map<std::string, std::map<std::string, std::string>> values;
  std::vector<std::string> keys;  // swept keys in first-seen order
};

DoneRuns done_runs(const ResultsDb& db) {
  DoneRuns out;
  out.hashes = column(db.query("SELECT hash FROM runs WHERE status = 'done' ORDER BY run_order"), 0);
  for (const auto& r : db.query("SELECT s.hash, s.key, s.value FROM swept s JOIN runs r ON r.hash = s.hash "
                                "ORDER BY r.run_order, s.rowid")) {
    out.values[r[0]][r[1]] = r[2];
    if (std::find(out.keys.begin(), out.keys.end(), r[1]) == out.keys.end()) out.keys.push_back(r[1]);
  }
  return out;
}

void check_key(const std::string& key, const DoneRuns& runs, const std::string& where, const std::string& what) {
  if (std::find(runs.keys.begin(), runs.keys.end(), key) == runs.keys.end())
    throw InputError({where, 0, what}, "'" + key + "' is not a swept key of this study (swept: " + known_list(runs.keys) + ")");
}

std::vector<std::string> metric_names(const ResultsDb& db) {
  return column(db.query("SELECT DISTINCT name FROM metrics ORDER BY name"), 0);
}

// Ratios of consecutive x values that differ by less than this (relative) are one ratio.
constexpr double kRatioTolerance = 1e-9;

std::optional<ReportConvergence> converge(const std::array<double, 3>& x, const std::array<double, 3>& p,
                                          const std::vector<std::pair<std::string, std::optional<double>>>& column) {
  const double ratio = x[1] / x[0];
  ReportConvergence c;
  const double d1 = p[1] - p[0], d2 = p[2] - p[1];
  const bool constant = d1 == 0 && d2 == 0;  // converged exactly: its own limit, order infinite
  c.asymptotic = constant || (d1 * d2 > 0 && std::abs(d2) < std::abs(d1));
  if (!c.asymptotic) return c;
  c.order = constant ? std::numeric_limits<double>::infinity() : std::log(d1 / d2) / std::log(ratio);
  c.limit = constant ? p[2] : p[2] + d2 / (std::pow(ratio, c.order) - 1);
  for (auto it = column.rbegin(); it != column.rend(); ++it) {
    if (!it->second || std::abs(*it->second - c.limit) > kLimitBand * std::abs(c.limit)) break;
    c.within_from = it->first;
  }
  return c;
}

// The refinement of every column over the last three x values (report.hpp).
void add_refinement(ReportTableData& t) {
  const size_t n = t.x_values.size();
  if (!t.convergence || !t.numeric_x || n < 3) return;
  const std::array<double, 3> x = {std::strtod(t.x_values[n - 3].c_str(), nullptr),
                                   std::strtod(t.x_values[n - 2].c_str(), nullptr),
                                   std::strtod(t.x_values[n - 1].c_str(), nullptr)};
  if (x[0] <= 0 || std::abs(x[2] / x[1] - x[1] / x[0]) > kRatioTolerance * x[1] / x[0] || x[1] / x[0] <= 1) return;
  for (size_t c = 0; c < t.columns.size(); ++c) {
    std::vector<std::pair<std::string, std::optional<double>>> column;
    for (size_t r = 0; r < n; ++r)
      column.emplace_back(t.x_values[r], t.cells[r][c] ? std::optional<double>(t.cells[r][c]->mean) : std::nullopt);
    const auto& a = column[n - 3].second;
    const auto& b = column[n - 2].second;
    const auto& last = column[n - 1].second;
    t.refinement.push_back(a && b && last ? converge(x, {*a, *b, *last}, column) : std::nullopt);
  }
}

using Samples = std::map<std::pair<std::string, std::string>, std::vector<double>>;  // (x, column) -> values

// A run's column: its group values ("all" without a group); the pseudo key `metric` gives the
// metric's own name.
std::string column_of(const std::vector<std::string>& group, const std::map<std::string, std::string>& values,
                      const std::string& metric) {
  std::string col;
  for (const std::string& g : group)
    col += (col.empty() ? "" : ", ") +
           (g == kMetricKey ? metric : g + "=" + (values.count(g) ? values.at(g) : std::string()));
  return col.empty() ? "all" : col;
}

// Every done run's value of each metric by (x, column); rows and columns in first-seen order.
Samples collect(const ResultsDb& db, const DoneRuns& runs, const std::vector<std::string>& metrics, ReportTableData& t) {
  Samples samples;
  for (const std::string& metric : metrics) {
    std::map<std::string, double> value;  // hash -> metric value
    for (const auto& r : db.query("SELECT hash, value FROM metrics WHERE value IS NOT NULL AND name = " + quoted(metric)))
      value[r[0]] = std::strtod(r[1].c_str(), nullptr);
    for (const std::string& hash : runs.hashes) {
      const auto& v = runs.values.at(hash);
      const std::string x = v.count(t.x) ? v.at(t.x) : "";
      const std::string col = column_of(t.group, v, metric);
      if (std::find(t.x_values.begin(), t.x_values.end(), x) == t.x_values.end()) t.x_values.push_back(x);
      if (std::find(t.columns.begin(), t.columns.end(), col) == t.columns.end()) t.columns.push_back(col);
      if (value.count(hash)) samples[{x, col}].push_back(value.at(hash));
    }
  }
  return samples;
}

void fill_cells(ReportTableData& t, const Samples& samples) {
  for (const std::string& x : t.x_values) {
    t.cells.emplace_back();
    for (const std::string& col : t.columns) {
      const auto it = samples.find({x, col});
      if (it == samples.end()) {
        t.cells.back().push_back(std::nullopt);
        continue;
      }
      const auto& s = it->second;
      ReportCell c{0, *std::min_element(s.begin(), s.end()), *std::max_element(s.begin(), s.end()), static_cast<int>(s.size())};
      for (const double v : s) c.mean += v / static_cast<double>(s.size());
      t.cells.back().push_back(c);
    }
  }
}

// One table of `metrics` (several only when the group has the pseudo key `metric`).
ReportTableData table_of(const ResultsDb& db, const DoneRuns& runs, const ReportTable& spec,
                         const std::vector<std::string>& metrics, const std::string& title) {
  ReportTableData t{title, spec.x, spec.group, spec.convergence, {}, {}, {}, false, {}};
  const Samples samples = collect(db, runs, metrics, t);
  t.numeric_x = std::all_of(t.x_values.begin(), t.x_values.end(), is_number);
  if (t.numeric_x)
    std::stable_sort(t.x_values.begin(), t.x_values.end(),
                     [](const std::string& a, const std::string& b) { return std::strtod(a.c_str(), nullptr) < std::strtod(b.c_str(), nullptr); });
  fill_cells(t, samples);
  add_refinement(t);
  return t;
}

// The refinement of each column as three more rows of the table.
std::string refinement_rows(const ReportTableData& t) {
  std::string order = "| observed order |", limit = "| Richardson limit |",
              within = fmt::format("| within {:g} % from |", 100 * kLimitBand);
  for (const auto& c : t.refinement) {
    if (!c || !c->asymptotic) {
      const char* why = c ? " not asymptotic |" : " — |";
      order += why;
      limit += why;
      within += why;
      continue;
    }
    order += fmt::format(" {:.2f} |", c->order);
    limit += fmt::format(" {:.4g} |", c->limit);
    within += c->within_from.empty() ? std::string(" beyond |") : " " + c->within_from + " |";
  }
  return order + "\n" + limit + "\n" + within + "\n";
}

}  // namespace

std::vector<ReportTableData> tabulate(const ResultsDb& db, const ReportTable& spec, const std::string& where) {
  const DoneRuns runs = done_runs(db);
  check_key(spec.x, runs, where, "x");
  for (const std::string& g : spec.group)
    if (g != kMetricKey) check_key(g, runs, where, "group");
  const std::vector<std::string> names = metric_names(db);
  std::vector<ReportTableData> out;
  std::vector<std::string> matched;
  for (const std::string& name : names)
    if (matches(spec.metric, name)) matched.push_back(name);
  const bool by_metric = std::find(spec.group.begin(), spec.group.end(), kMetricKey) != spec.group.end();
  if (by_metric && !matched.empty()) out.push_back(table_of(db, runs, spec, matched, spec.metric));
  if (!by_metric)
    for (const std::string& name : matched) out.push_back(table_of(db, runs, spec, {name}, name));
  if (out.empty())
    throw InputError({where, 0, "metric"}, "no metric '" + spec.metric + "' in this database (its metrics: " +
                                               known_list(names) + "; a '*' matches any run of characters)");
  return out;
}

std::vector<ReportTable> default_report_tables(const ResultsDb& db) {
  if (const auto stored = db.meta("report")) {
    std::vector<ReportTable> out;
    for (const auto& j : nlohmann::json::parse(*stored)) out.push_back(report_table_from_json(j));
    if (!out.empty()) return out;
  }
  const DoneRuns runs = done_runs(db);
  std::vector<std::string> varying;  // swept keys with more than one value
  for (const std::string& key : runs.keys) {
    std::set<std::string> values;
    for (const auto& [hash, v] : runs.values)
      if (v.count(key)) values.insert(v.at(key));
    if (values.size() > 1) varying.push_back(key);
  }
  if (varying.empty()) varying.push_back("dataset");
  std::vector<std::string> metrics;
  for (const std::string& name : metric_names(db))
    if (name.rfind(kDefaultErrorPrefix, 0) == 0 || name == kDefaultTimeMetric) metrics.push_back(name);
  std::vector<ReportTable> out;
  for (const std::string& x : varying) {
    std::vector<std::string> group;
    for (const std::string& k : varying)
      if (k != x) group.push_back(k);
    for (const std::string& m : metrics) out.push_back({m, x, group});
  }
  return out;
}

std::string markdown(const ReportTableData& t) {
  bool pooled = false;
  std::string text = fmt::format("| {} \\ {} |", t.x, t.group.empty() ? t.metric : fmt::format("{}", fmt::join(t.group, ", ")));
  for (const std::string& c : t.columns) text += " " + c + " |";
  text += "\n|---|";
  for (size_t i = 0; i < t.columns.size(); ++i) text += "---|";
  text += "\n";
  for (size_t r = 0; r < t.x_values.size(); ++r) {
    text += "| " + t.x_values[r] + " |";
    for (const auto& cell : t.cells[r]) {
      if (!cell) {
        text += " — |";
        continue;
      }
      pooled = pooled || cell->count > 1;
      text += cell->count == 1 ? fmt::format(" {:.4g} |", cell->mean)
                               : fmt::format(" {:.4g} (n={}, {:.4g}…{:.4g}) |", cell->mean, cell->count, cell->min, cell->max);
    }
    text += "\n";
  }
  if (!t.refinement.empty()) text += refinement_rows(t);
  else if (t.convergence)
    text += "\n(no refinement rows: they need a numeric x whose last three values have one ratio above 1)\n";
  if (pooled) text += "\nA cell with n > 1 is the mean of n runs that differ in keys neither in x nor in the group.\n";
  return text;
}

std::string unfinished_runs_markdown(const ResultsDb& db) {
  const Rows rows = db.query("SELECT hash, status, error FROM runs WHERE status != 'done' ORDER BY run_order");
  if (rows.empty()) return "";
  std::string text = "| run | status | swept values | error |\n|---|---|---|---|\n";
  for (const auto& r : rows) {
    std::string values;
    for (const auto& v : db.query("SELECT key, value FROM swept WHERE hash = " + quoted(r[0]) + " ORDER BY rowid"))
      values += (values.empty() ? "" : " ") + v[0] + "=" + v[1];
    std::string error = r[2];
    std::replace(error.begin(), error.end(), '|', '/');
    std::replace(error.begin(), error.end(), '\n', ' ');
    text += fmt::format("| {} | {} | {} | {} |\n", r[0], r[1], values, error);
  }
  return text;
}

nlohmann::json to_json(const ReportTable& t) {
  return {{"metric", t.metric}, {"x", t.x}, {"group", t.group}, {"convergence", t.convergence}};
}

ReportTable report_table_from_json(const nlohmann::json& j) {
  return {j.at("metric"), j.at("x"), j.at("group").get<std::vector<std::string>>(), j.value("convergence", false)};
}

nlohmann::json plot_json(const ReportTableData& t) {
  nlohmann::json series = nlohmann::json::array();
  for (size_t c = 0; c < t.columns.size(); ++c) {
    nlohmann::json y = nlohmann::json::array();
    for (size_t r = 0; r < t.x_values.size(); ++r)
      y.push_back(t.cells[r][c] ? nlohmann::json(t.cells[r][c]->mean) : nlohmann::json(nullptr));
    series.push_back({{"label", t.columns[c]}, {"y", y}});
  }
  return {{"metric", t.metric}, {"x_key", t.x}, {"x", t.x_values}, {"numeric_x", t.numeric_x}, {"series", series}};
}

}  // namespace twill
