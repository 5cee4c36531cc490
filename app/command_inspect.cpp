// `twill inspect DATASET [--plot FILE] [--seed N]`: what a dataset folder holds, as twill reads
// it (core/dataset.hpp), and which repeats `twill fit` fits by default (core/repeat_selection.hpp).
// With --plot, every raw force–extension curve is drawn, one panel per tensile test, by
// scripts/plot_curves.py from a JSON file written to a temporary folder.
#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/commands.hpp"
#include "app/python_script.hpp"
#include "core/dataset.hpp"
#include "core/repeat_selection.hpp"
#include "fitting/fit_config.hpp"

namespace twill {
namespace {

struct InspectOptions {
  std::string dataset;
  std::string plot;
  std::uint64_t seed = static_cast<std::uint64_t>(FitRepeats{}.seed);  // twill fit's, so both pick the same run
};

std::string range_text(const std::vector<double>& v) {
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  return fmt::format("{:.4g} … {:.4g}", *lo, *hi);
}

std::string yes_no(bool b) { return b ? "yes" : "no"; }

// Whether run r of a fit test is the one the repeat rule selects (validation tests use all).
bool fitted(const TensileTest& t, const RepeatSelection& s, std::size_t r) {
  return t.role == TestRole::Fit && std::find(s.runs.begin(), s.runs.end(), r) != s.runs.end();
}

void print_dataset(std::ostream& out, const Dataset& d, const std::vector<RepeatSelection>& selections,
                   std::uint64_t seed) {
  out << fmt::format("dataset        {}  ({})\n", d.name, d.folder);
  out << fmt::format("areal density  {:g} g/m²\n", d.areal_density_g_m2);
  out << fmt::format("thickness      {:g} mm\n", d.thickness_mm);
  if (!d.weave.empty()) out << fmt::format("weave          {}\n", d.weave);

  out << fmt::format("\ntensile tests: {}\n", d.tensile.size());
  for (std::size_t i = 0; i < d.tensile.size(); ++i) {
    const TensileTest& t = d.tensile[i];
    std::string rate = t.rate_mm_min ? fmt::format(", rate {:g} mm/min", *t.rate_mm_min) : "";
    out << fmt::format("  {} — angle {:g}°, role {}, width {:g} mm, gauge length {:g} mm{}, {} run{}\n", t.label,
                       t.angle_deg, to_string(t.role), t.width_mm, t.gauge_length_mm, rate, t.runs.size(),
                       t.runs.size() == 1 ? "" : "s");
    std::size_t width = 0;
    for (const auto& run : t.runs) width = std::max(width, run.listed_path.size());
    for (std::size_t r = 0; r < t.runs.size(); ++r) {
      const TensileRun& run = t.runs[r];
      const bool chosen = fitted(t, selections[i], r);
      out << fmt::format("    {} {:<{}}  {:>4} points  extension {} mm  force {} N  unloading: {:<3}  "
                         "lateral strain: {:<3}  time: {}\n",
                         chosen ? '*' : ' ', run.listed_path, width, run.size(), range_text(run.extension_mm),
                         range_text(run.force_N), yes_no(run.has_unloading), yes_no(run.has_lateral_strain()),
                         yes_no(run.has_time()));
    }
    if (t.role == TestRole::Fit)
      out << fmt::format("    * fitted by default (repeats.rule: {}; §6.4, --seed {}): {}\n", to_string(FitRepeats{}.rule), seed,
                         selections[i].reason);
    else
      out << "    (validation test: every run is compared with the fitted model, paper §7)\n";
  }

  out << fmt::format("\nbend tests: {}\n", d.bend.size());
  for (const BendTest& b : d.bend) {
    double mean = 0;
    for (double o : b.overhang_mm) mean += o / static_cast<double>(b.overhang_mm.size());
    out << fmt::format("  {} — angle {:g}°, width {:g} mm, length {:g} mm, chord angle {:g}°, overhang {:g} mm "
                       "(mean of {}: {:.4g} mm)\n",
                       b.label, b.angle_deg, b.width_mm, b.length_mm, b.chord_angle_deg,
                       fmt::join(b.overhang_mm, ", "), b.overhang_mm.size(), mean);
  }
}

nlohmann::json plot_data(const Dataset& d, const std::vector<RepeatSelection>& selections) {
  nlohmann::json panels = nlohmann::json::array();
  for (std::size_t i = 0; i < d.tensile.size(); ++i) {
    const TensileTest& t = d.tensile[i];
    nlohmann::json curves = nlohmann::json::array();
    for (std::size_t r = 0; r < t.runs.size(); ++r) {
      const bool chosen = fitted(t, selections[i], r);
      curves.push_back({{"label", t.runs[r].name()},
                        {"x", t.runs[r].extension_mm},
                        {"y", t.runs[r].force_N},
                        {"highlight", chosen}});
    }
    panels.push_back({{"title", fmt::format("{} ({:g}°, {})", t.label, t.angle_deg, to_string(t.role))},
                      {"xlabel", "extension [mm]"},
                      {"ylabel", "force [N]"},
                      {"curves", curves}});
  }
  return {{"title", fmt::format("{}: raw tensile curves (thick: fitted by default)", d.name)},
          {"panels", panels}};
}

void check_plot_path(const std::string& path) {
  const std::filesystem::path p(path);
  const std::string ext = p.extension().string();
  if (ext != ".png" && ext != ".svg" && ext != ".pdf")
    throw InputError({"command line", 0, "--plot"}, "the plot file must end in .png, .svg or .pdf, got '" + path + "'");
  const auto parent = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(parent, ec))
    throw InputError({"command line", 0, "--plot"}, "the folder of the plot file does not exist: " + parent.string());
}

void run_inspect(const Context& context, const InspectOptions& o) {
  if (!o.plot.empty()) check_plot_path(o.plot);  // before any work: fail fast on a typo
  const Dataset d = read_dataset(o.dataset);
  const auto selections = select_repeats(d, FitRepeats{}.rule, o.seed);
  print_dataset(std::cout, d, selections, o.seed);
  if (o.plot.empty()) return;
  if (d.tensile.empty()) throw InputError({o.dataset, 0, "tensile"}, "nothing to plot: the dataset has no tensile tests");
  TemporaryDirectory tmp("twill-inspect-");
  const std::string json_path = tmp.path() + "/curves.json";
  {
    std::ofstream json(json_path);
    json << plot_data(d, selections).dump();
    if (!json.flush()) throw std::runtime_error("cannot write " + json_path);
  }
  run_python_script(context, "plot_curves.py", {json_path, o.plot});
  std::cout << "\nplot written to " << o.plot << "\n";
}

}  // namespace

void add_inspect_command(CLI::App& app, Context& context) {
  auto* cmd = app.add_subcommand("inspect", "Summarise a dataset folder (fabric.yaml + tensile CSVs), optionally plot it");
  auto o = std::make_shared<InspectOptions>();
  cmd->add_option("dataset", o->dataset, "Dataset folder (contains fabric.yaml)")->required();
  cmd->add_option("--plot", o->plot, "Write a plot of all raw force-extension curves (.png, .svg or .pdf)");
  // A non-negative integer: CLI11 would read "-1" into the unsigned seed as 2^64 - 1.
  cmd->add_option("--seed", o->seed, "Seed of the random repeat choice for off-axis tests (paper §6.4)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->callback([&context, o] { run_inspect(context, *o); });
}

}  // namespace twill
