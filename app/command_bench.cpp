// `twill bench`: speed figures of the simulator (issue #3 "measured, not asserted").
//
// For each discretisation and resolution: one full 40-point tensile curve of the canvas
// reference material (warp and bias, extensions of the reference files), reporting the curve's
// wall time, time per equilibrium solve, Newton iterations per step and the process's peak
// resident memory. Timings are wall clock on this machine; run on an idle machine.
#include <sys/resource.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "app/commands.hpp"
#include "core/dataset.hpp"
#include "core/discretization_registry.hpp"
#include "core/params_io.hpp"
#include "experiments/tensile_test.hpp"

namespace twill {
namespace {

double peak_memory_mb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

struct BenchArgs {
  std::string reference;  // folder with params.yaml and tensile-<label>.csv
  std::vector<std::string> discretizations = {"catmull-clark-kl", "triangle-shell"};
  std::vector<std::string> resolutions = {"8x12", "16x24", "32x48"};
  std::vector<std::string> labels = {"warp", "bias"};
};

}  // namespace

void add_bench_command(CLI::App& app, Context& context) {
  auto args = std::make_shared<BenchArgs>();
  CLI::App* cmd = app.add_subcommand("bench", "time tensile curves per discretization and resolution");
  cmd->add_option("--reference", args->reference,
                  "folder with params.yaml and tensile-<label>.csv (e.g. ../shared/data/reference/canvas)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--discretization", args->discretizations, "registered names (repeatable)");
  cmd->add_option("--resolution", args->resolutions, "NxM (repeatable)");
  cmd->add_option("--label", args->labels, "reference curves to run (warp, weft, bias, a22.5, a67.5)");
  cmd->callback([args, &context] {
    const std::filesystem::path folder(args->reference);
    const MaterialParameters p = read_params_file((folder / "params.yaml").string());
    auto& category = context.registry.category<DiscretizationFactories>(registry_category::kDiscretization);
    std::printf("%-18s %-6s %-6s %7s %9s %10s %9s %9s %10s %9s\n", "discretization", "res", "curve", "points",
                "curve_s", "solve_ms", "newton/pt", "max_err%", "dofs", "peak_MB");
    for (const std::string& label : args->labels) {
      const TensileRun ref = read_tensile_run_csv((folder / ("tensile-" + label + ".csv")).string());
      const double angle = label == "warp" ? 90 : label == "weft" ? 0 : label == "bias" ? 45
                                                                      : std::stod(label.substr(1));
      for (const std::string& name : args->discretizations) {
        const RegistryEntry& entry = category.at(name);
        const Options options = default_options(entry.options, &context.registry);
        for (const std::string& res : args->resolutions) {
          TensileSetup setup;
          setup.angle_deg = angle;
          char x = 0;
          std::istringstream in(res);
          in >> setup.cells_across >> x >> setup.cells_along;
          TensileExperiment experiment(
              setup, [&](const StripSpec& s, const MaterialParameters& m) { return category.create(name, options, s, m); }, p);
          const TensileCurve curve = experiment.run(ref.extension_mm);
          double worst = 0;
          for (size_t i = 0; i < curve.points.size(); ++i)
            if (ref.force_N[i] > 1.0)
              worst = std::max(worst, std::abs(curve.points[i].force_N / ref.force_N[i] - 1.0));
          const double n = static_cast<double>(std::max<size_t>(curve.points.size(), 1));
          std::printf("%-18s %-6s %-6s %7zu %9.3f %10.2f %9.2f %9.3f %10d %9.1f%s\n", name.c_str(), res.c_str(),
                      label.c_str(), curve.points.size(), curve.wall_time_s, 1e3 * curve.wall_time_s / n,
                      curve.newton_iterations / n, 100 * worst, experiment.discretization().num_dofs(), peak_memory_mb(),
                      curve.completed ? "" : "  (stopped early)");
          std::fflush(stdout);
        }
      }
    }
  });
}

}  // namespace twill
