// Dataset folders: the shared examples load; both CSV column styles; unloading rows kept in
// order; every malformed input names its file, line and key or column.
#include <gtest/gtest.h>

#include <ostream>

#include "core/dataset.hpp"
#include "core/input_error.hpp"

namespace twill {
namespace {

const std::string kExamples = std::string(TWILL_SHARED_DIR) + "/data/examples/";
const std::string kFixtures = std::string(TWILL_SOURCE_DIR) + "/tests/data/datasets/";

TEST(Dataset, CanvasExampleLoads) {
  const Dataset d = read_dataset(kExamples + "canvas");
  EXPECT_EQ(d.name, "canvas");
  EXPECT_EQ(d.areal_density_g_m2, 294.0);
  EXPECT_EQ(d.thickness_mm, 0.53);
  EXPECT_EQ(d.weave, "basket");
  ASSERT_EQ(d.tensile.size(), 5u);
  const std::vector<std::pair<double, std::string>> expected = {
      {90, "warp"}, {0, "weft"}, {45, "bias"}, {22.5, "a22.5"}, {67.5, "a67.5"}};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const TensileTest& t = d.tensile[i];
    EXPECT_EQ(t.angle_deg, expected[i].first);
    EXPECT_EQ(t.label, expected[i].second);
    EXPECT_EQ(t.width_mm, 50.0);
    EXPECT_EQ(t.gauge_length_mm, 75.0);
    EXPECT_EQ(t.rate_mm_min, 300.0);
    EXPECT_EQ(t.role, i < 3 ? TestRole::Fit : TestRole::Validation);
    ASSERT_EQ(t.runs.size(), 5u);
    for (const auto& run : t.runs) {
      EXPECT_EQ(run.size(), 40u) << run.path;
      EXPECT_FALSE(run.has_unloading);
      EXPECT_FALSE(run.has_time());
      EXPECT_FALSE(run.has_lateral_strain());
      EXPECT_EQ(run.peak_index, 39u);
    }
  }
  // First and last rows of warp-1.csv.
  const TensileRun& warp1 = d.tensile[0].runs[0];
  EXPECT_EQ(warp1.listed_path, "tensile/warp-1.csv");
  EXPECT_EQ(warp1.name(), "warp-1");
  EXPECT_EQ(warp1.extension_mm.front(), 0.225);
  EXPECT_EQ(warp1.force_N.front(), 1.6836);
  EXPECT_EQ(warp1.extension_mm.back(), 9.0);
  EXPECT_EQ(warp1.force_N.back(), 312.51);
  ASSERT_EQ(d.bend.size(), 2u);
  EXPECT_EQ(d.bend[0].label, "warp");
  EXPECT_EQ(d.bend[0].chord_angle_deg, 41.5);
  EXPECT_EQ(d.bend[1].overhang_mm, (std::vector<double>{72.45, 73.62, 70.85}));
}

TEST(Dataset, PoplinExampleLoads) {
  const Dataset d = read_dataset(kExamples + "poplin");
  EXPECT_EQ(d.name, "poplin");
  EXPECT_EQ(d.areal_density_g_m2, 98.0);
  EXPECT_EQ(d.tensile.size(), 5u);
  EXPECT_EQ(d.bend.size(), 2u);
}

TEST(Dataset, BothColumnStylesAndUnits) {
  const Dataset d = read_dataset(kFixtures + "tester");
  ASSERT_EQ(d.tensile.size(), 2u);
  EXPECT_EQ(d.tensile[0].label, "warp");  // default from 90°
  EXPECT_EQ(d.tensile[0].role, TestRole::Fit);
  EXPECT_FALSE(d.tensile[0].rate_mm_min);
  EXPECT_EQ(d.tensile[1].label, "thirty");
  EXPECT_EQ(d.tensile[1].role, TestRole::Validation);
  EXPECT_EQ(d.tensile[1].rate_mm_min, 100.0);
  EXPECT_EQ(d.weave, "");

  // Tester export: "Time (s),Extension (mm),Load (N),Tensile strain (%)" with comments and
  // blank lines; the strain column is not lateral strain and is ignored.
  const TensileRun& exported = d.tensile[0].runs[0];
  EXPECT_EQ(exported.extension_mm, (std::vector<double>{0, 1, 2, 3, 2, 1}));
  EXPECT_EQ(exported.force_N, (std::vector<double>{0, 10.5, 25, 45.25, 20, 5}));
  EXPECT_EQ(exported.time_s, (std::vector<double>{0, 0.2, 0.4, 0.6, 0.8, 1.0}));
  EXPECT_FALSE(exported.has_lateral_strain());

  // Contract style: extension_mm, force_N, time_s, lateral_strain.
  const TensileRun& plain = d.tensile[0].runs[1];
  EXPECT_EQ(plain.extension_mm, (std::vector<double>{0, 1, 2, 3}));
  EXPECT_EQ(plain.force_N, (std::vector<double>{0, 10, 24, 44}));
  EXPECT_EQ(plain.lateral_strain, (std::vector<double>{0, -0.01, -0.02, -0.03}));
  EXPECT_TRUE(plain.has_time());
  EXPECT_FALSE(plain.has_unloading);

  // Quoted headers with other units: Elongation [cm], Force (kN), Lateral Strain (%).
  const TensileRun& units = d.tensile[0].runs[2];
  ASSERT_EQ(units.size(), 3u);
  EXPECT_DOUBLE_EQ(units.extension_mm[2], 2.5);
  EXPECT_DOUBLE_EQ(units.force_N[2], 30.0);
  EXPECT_DOUBLE_EQ(units.lateral_strain[2], -0.025);

  ASSERT_EQ(d.bend.size(), 1u);
  EXPECT_EQ(d.bend[0].label, "weft");
  EXPECT_EQ(d.bend[0].overhang_mm, (std::vector<double>{60, 61.5}));
}

TEST(Dataset, UnloadingRowsKeptInFileOrder) {
  const TensileRun run = read_tensile_run_csv(kFixtures + "tester/tensile/export.csv");
  EXPECT_TRUE(run.has_unloading);
  EXPECT_EQ(run.peak_index, 3u);  // 3 mm, the fourth data row
  for (std::size_t i = 1; i <= run.peak_index; ++i) EXPECT_GT(run.extension_mm[i], run.extension_mm[i - 1]);
  for (std::size_t i = run.peak_index + 1; i < run.size(); ++i) EXPECT_LT(run.extension_mm[i], run.extension_mm[i - 1]);
  EXPECT_EQ(run.force_N.back(), 5.0);
}

TEST(Dataset, DefaultLabels) {
  EXPECT_EQ(default_test_label(90), "warp");
  EXPECT_EQ(default_test_label(0), "weft");
  EXPECT_EQ(default_test_label(45), "bias");
  EXPECT_EQ(default_test_label(22.5), "a22.5");
  EXPECT_EQ(default_test_label(30), "a30");
}

struct BadDataset {
  const char* folder;
  const char* file;  // relative to the folder: fabric.yaml or the CSV
  int line;
  const char* key;
  const char* message;
};
void PrintTo(const BadDataset& c, std::ostream* os) {
  *os << c.folder << "/" << c.file << ":" << c.line << " " << c.key;
}

class DatasetErrors : public ::testing::TestWithParam<BadDataset> {};

TEST_P(DatasetErrors, NamesFileLineAndKey) {
  const BadDataset& c = GetParam();
  const std::string folder = kFixtures + c.folder;
  const std::string file = folder + "/" + c.file;
  try {
    read_dataset(folder);
    FAIL() << c.folder << " was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.where().file, file) << what;
    EXPECT_EQ(e.where().line, c.line) << what;
    EXPECT_EQ(e.where().key, c.key) << what;
    EXPECT_NE(what.find(file + ":" + std::to_string(c.line)), std::string::npos) << what;
    EXPECT_NE(what.find(c.message), std::string::npos) << "expected '" << c.message << "' in: " << what;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Malformed, DatasetErrors,
    ::testing::Values(
        BadDataset{"unknown_key", "fabric.yaml", 4, "colour", "unknown key"},
        BadDataset{"unknown_test_key", "fabric.yaml", 8, "tensile[0].speed_mm_min", "unknown key"},
        BadDataset{"missing_key", "fabric.yaml", 5, "tensile[0].gauge_length_mm", "missing required key"},
        BadDataset{"missing_run", "fabric.yaml", 10, "tensile[0].runs[1]", "cannot open file (no such file)"},
        BadDataset{"zero_width", "fabric.yaml", 6, "tensile[0].width_mm", "a strip width must be in (0, 1000] mm"},
        BadDataset{"negative_gauge", "fabric.yaml", 7, "tensile[0].gauge_length_mm", "a strip length must be in (0, 5000] mm"},
        BadDataset{"negative_bend_length", "fabric.yaml", 12, "bend[0].length_mm", "got -200 mm"},
        BadDataset{"unknown_role", "fabric.yaml", 8, "tensile[0].role", "unknown role 'fitting'"},
        BadDataset{"duplicate_label", "fabric.yaml", 9, "tensile[1]", "label 'warp' is already used"},
        BadDataset{"bad_cell", "tensile/run-1.csv", 4, "force_N", "not a finite number: '1O.0'"},
        BadDataset{"wrong_column_count", "tensile/run-1.csv", 3, "", "row has 3 cells, the header (line 1) has 2"},
        BadDataset{"missing_column", "tensile/run-1.csv", 2, "", "missing required force column"}),
    [](const ::testing::TestParamInfo<BadDataset>& param_info) { return std::string(param_info.param.folder); });

TEST(Dataset, MissingFolderAndFabricFile) {
  EXPECT_THROW(read_dataset(kFixtures + "no_such_dataset"), InputError);
  try {
    read_dataset(kFixtures + "tester/tensile");  // a folder without fabric.yaml
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fabric.yaml: cannot open file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace twill
