// `twill report DB [-o DIR] [--metric M ...] [--x KEY] [--group KEY ...] [--no-plots]`:
// Markdown tables and PNG plots of a study's results (study/report.hpp; docs/studies.md §5).
// DB is a sweep's results.sqlite or its folder. Without --metric the tables are the study's
// `report:` list, else every error metric and the total time against each swept key. DIR
// (default: DB's folder/report) follows the output-folder rules of twill fit: its own
// marker, written whole in DIR.partial and moved into place, never someone else's files.
#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include "app/commands.hpp"
#include "app/python_script.hpp"
#include "core/input_error.hpp"
#include "fitting/fit_output_folder.hpp"
#include "study/report.hpp"
#include "study/results_db.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

constexpr const char* kReportFile = "report.md";
constexpr const char* kTablesFile = "tables.json";
constexpr const char* kPlotPrefix = "plot-";

struct ReportArgs {
  std::string db, out, x;
  std::vector<std::string> metrics, group;
  bool no_plots = false, quiet = false, convergence = false;
};

const OutputFolderKind& report_output_kind() {
  static const OutputFolderKind kind = {
      "twill report", ".twill-report", fmt::format("  {}\n  {}\n  {}*.png\n", kReportFile, kTablesFile, kPlotPrefix), "sweep",
      [](const std::string& name) {
        return name == kReportFile || name == kTablesFile ||
               (name.rfind(kPlotPrefix, 0) == 0 && name.size() > 4 && name.compare(name.size() - 4, 4, ".png") == 0);
      }};
  return kind;
}

fs::path database_file(const std::string& given) {
  const fs::path p(given);
  return fs::is_directory(p) ? p / "results.sqlite" : p;
}

// The tables the command line names, else the database's defaults.
std::vector<ReportTable> requested_tables(const ReportArgs& args, const ResultsDb& db) {
  if (args.metrics.empty()) {
    if (!args.x.empty() || !args.group.empty() || args.convergence)
      throw InputError({"command line", 0, "--metric"}, "--x, --group and --convergence need --metric (the metric to tabulate)");
    return default_report_tables(db);
  }
  if (args.x.empty()) throw InputError({"command line", 0, "--x"}, "--metric needs --x (the swept key of the rows)");
  std::vector<ReportTable> out;
  for (const std::string& m : args.metrics) out.push_back({m, args.x, args.group, args.convergence});
  return out;
}

std::string plot_file(size_t index, const ReportTableData& t) {
  return fmt::format("{}{:02d}-{}-vs-{}.png", kPlotPrefix, index + 1, safe_path_component(t.metric), safe_path_component(t.x));
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error("cannot write " + path.string());
}

// report.md's text and the plots' numbers (tables.json) of `tables`.
std::pair<std::string, nlohmann::json> report_contents(const ResultsDb& db, const fs::path& file,
                                                       const std::vector<ReportTableData>& tables, bool plots) {
  const auto study = db.meta("study");
  std::string text = fmt::format("# Study report\n\nDatabase: `{}`{}\n\n", fs::absolute(file).string(),
                                 study ? fmt::format("; study file `{}`", *study) : "");
  for (const auto& c : db.query("SELECT status, COUNT(*) FROM runs GROUP BY status ORDER BY status"))
    text += fmt::format("- {} runs {}\n", c[1], c[0]);
  nlohmann::json numbers = {{"tables", nlohmann::json::array()}};
  for (size_t i = 0; i < tables.size(); ++i) {
    const std::string png = plot_file(i, tables[i]);
    text += fmt::format("\n## {} against {}\n\n{}", tables[i].metric, tables[i].x, markdown(tables[i]));
    if (plots) text += fmt::format("\n![{} against {}]({})\n", tables[i].metric, tables[i].x, png);
    nlohmann::json p = plot_json(tables[i]);
    p["file"] = png;
    numbers["tables"].push_back(p);
  }
  if (const std::string unfinished = unfinished_runs_markdown(db); !unfinished.empty())
    text += "\n## Runs not done (left out of every table)\n\n" + unfinished;
  return {text, numbers};
}

void run(Context& context, const ReportArgs& args) {
  const fs::path file = database_file(args.db);
  const ResultsDb db(file, ResultsDb::Access::read_only);
  std::vector<ReportTableData> tables;
  const std::string where = args.metrics.empty() ? db.meta("study").value_or(file.string()) : "command line";
  for (const ReportTable& spec : requested_tables(args, db))
    for (ReportTableData& t : tabulate(db, spec, where)) tables.push_back(std::move(t));
  OutputFolder folder(report_output_kind(), args.out.empty() ? file.parent_path() / "report" : fs::path(args.out),
                      file.parent_path().string(), false);
  const auto [text, numbers] = report_contents(db, file, tables, !args.no_plots);
  write_text(folder.staging() / kTablesFile, numbers.dump(1) + "\n");
  if (!args.no_plots)
    run_python_script(context, "plot_report.py", {(folder.staging() / kTablesFile).string(), folder.staging().string()});
  write_text(folder.staging() / kReportFile, text);
  folder.commit();
  if (!args.quiet)
    std::cout << fmt::format("twill report: {} tables of {} -> {}\n", tables.size(), file.string(),
                             (folder.out() / kReportFile).string());
}

}  // namespace

void add_report_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand("report", "tables and plots of a study's results (docs/studies.md §5)");
  cmd->add_option("db", args->db, "a sweep's results.sqlite, or its folder")->required();
  cmd->add_option("-o,--out", args->out, "output folder (default: the database's folder/report)");
  cmd->add_option("--metric", args->metrics, "metric to tabulate (repeatable; '*' matches any run of characters, e.g. 'param.*')");
  cmd->add_option("--x", args->x, "swept key of the rows (with --metric)");
  cmd->add_option("--group", args->group, "swept key whose values are the columns (repeatable)");
  cmd->add_flag("--convergence", args->convergence, "add each column's observed order, Richardson limit and where it is within 1 % (numeric x)");
  cmd->add_flag("--no-plots", args->no_plots, "skip the figures (no matplotlib needed)");
  cmd->add_flag("--quiet", args->quiet, "no summary line");
  cmd->callback([&context, args] { run(context, *args); });
}

}  // namespace twill
