// What a study records of a fit (study/run_metrics.hpp), read from the report.json that
// write_fit_outputs writes: here the validation strips' strain range against the cutoffs
// (docs/fitting.md §7), and its absence in reports written before it; a curve stage's degree
// and error at the end, not at a raise the degree search tried and did not keep.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "fitting/fit_config.hpp"
#include "fitting/fit_protocol.hpp"
#include "study/run_metrics.hpp"
#include "tests/support/program_registry.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

nlohmann::json written_report(const FitReport& report) {
  const fs::path dir = fs::temp_directory_path() / ("twill-run-metrics-" + std::to_string(getpid()));
  fs::remove_all(dir);
  write_fit_outputs(report, default_options(fit_config_schema(), &testing::program_registry()), dir.string());
  std::ifstream in(dir / "report.json");
  nlohmann::json j = nlohmann::json::parse(in);
  fs::remove_all(dir);
  return j;
}

TEST(RunMetrics, ValidationStrainRangePerTestAndComponent) {
  FitReport report;
  report.validation_strain.push_back(FitStrainRange{"a67.5", 67.5, 11.0, {0.212, 0.08, 0.495}, {0.1085, 0.136, std::nullopt},
                                                    {0.437, 0.0, 0.0}});
  std::map<std::string, double> m;
  for (const auto& [name, value] : fit_metrics(written_report(report))) m[name] = value;
  EXPECT_DOUBLE_EQ(m.at("strain.validation.a67.5.E11.largest"), 0.212);
  EXPECT_DOUBLE_EQ(m.at("strain.validation.a67.5.E11.share_beyond_cutoff"), 0.437);
  EXPECT_DOUBLE_EQ(m.at("strain.validation.a67.5.E12.largest"), 0.495);
  EXPECT_DOUBLE_EQ(m.at("strain.validation.a67.5.E22.share_beyond_cutoff"), 0.0);

  nlohmann::json older = written_report(report);
  older.erase("validation_strain_range");
  for (const auto& [name, value] : fit_metrics(older)) EXPECT_EQ(name.rfind("strain.", 0), std::string::npos) << name;
}

// papers/optimizers: Ipopt's bias stage tried degree 2 (no better) and kept degree 1; the
// metric read the last optimiser run and said 2.
TEST(RunMetrics, StageDegreeAndErrorAreTheKeptOnes) {
  FitReport report;
  const auto run = [](const std::string& stage, const std::string& resolution, int degree, double error) {
    FitStageRecord r;
    r.stage = stage;
    r.resolution = resolution;
    r.degree = degree;
    r.avg_rel_error = error;
    return r;
  };
  report.stages = {run("warp", "8x12", 1, 0.05), run("warp", "8x12", 2, 0.010), run("warp", "16x24", 2, 0.012),
                   run("bias", "8x12", 1, 0.042), run("bias", "8x12", 2, 0.0424)};
  report.curve_degrees = {{"warp", 2}, {"bias", 1}};
  std::map<std::string, double> m;
  for (const auto& [name, value] : fit_metrics(written_report(report))) m[name] = value;
  EXPECT_EQ(m.at("degree.stage.warp"), 2);
  EXPECT_DOUBLE_EQ(m.at("error.stage.warp"), 0.012);  // the finest level's refit
  EXPECT_EQ(m.at("degree.stage.bias"), 1);
  EXPECT_DOUBLE_EQ(m.at("error.stage.bias"), 0.042);

  // Reports written before curve_degrees: the fit table's degree of the stage's label, and
  // without that, the last run.
  FitCurve bias;
  bias.label = "bias";
  bias.degree = 1;
  report.fit.push_back(bias);
  nlohmann::json older = written_report(report);
  older.erase("curve_degrees");
  m.clear();
  for (const auto& [name, value] : fit_metrics(older)) m[name] = value;
  EXPECT_EQ(m.at("degree.stage.bias"), 1);
  EXPECT_EQ(m.at("degree.stage.warp"), 2);  // the last run's
}

}  // namespace
}  // namespace twill
