// What a study records of a fit (study/run_metrics.hpp), read from the report.json that
// write_fit_outputs writes: here the validation strips' strain range against the cutoffs
// (docs/fitting.md §7), and its absence in reports written before it.
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

}  // namespace
}  // namespace twill
