// Output folders of `twill fit` (fitting/fit_output_folder.hpp): twill never deletes or
// overwrites what it did not create (issue #13). Each case runs in its own temporary folder.
#include "fitting/fit_output_folder.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/input_error.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

class FitOutputFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("twill-output-folder-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "ds");
    write(root_ / "ds" / "fabric.yaml", "name: x\n");
  }
  void TearDown() override { fs::remove_all(root_); }
  static void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
  }
  static std::string read(const fs::path& p) {
    std::stringstream s;
    s << std::ifstream(p).rdbuf();
    return s.str();
  }
  // A fit's outputs written and committed into `out`.
  void fit_into(const fs::path& out, bool force = false) {
    FitOutputFolder folder(out, (root_ / "ds").string(), force);
    write(folder.staging() / "params.yaml", "new\n");
    write(folder.staging() / "report.md", "new\n");
    folder.commit();
  }
  fs::path root_;
};

TEST(FitOutputNames, DefaultPathIsOneSafeComponent) {
  EXPECT_EQ(safe_path_component("/../../../ESCAPED"), "ESCAPED");
  EXPECT_EQ(safe_path_component("my fabric/2"), "my_fabric_2");
  EXPECT_EQ(safe_path_component(".."), "dataset");
  EXPECT_EQ(safe_path_component(""), "dataset");
  EXPECT_EQ(safe_path_component("Köper"), "K_per");
  EXPECT_EQ(safe_path_component(std::string(300, 'x')).size(), 64u);
  EXPECT_EQ(default_fit_folder("/../x"), fs::path("out") / "fit-x");
}

TEST_F(FitOutputFolderTest, NewFolderIsCreatedAtomicallyWithTheMarker) {
  fit_into(root_ / "out");
  EXPECT_EQ(read(root_ / "out" / "params.yaml"), "new\n");
  EXPECT_TRUE(fs::exists(root_ / "out" / kFitMarkerFile));
  EXPECT_FALSE(fs::exists(root_ / "out.partial"));
}

TEST_F(FitOutputFolderTest, ForeignFolderIsRefusedWithoutForce) {
  write(root_ / "mydir" / "notes.txt", "mine\n");
  EXPECT_THROW(FitOutputFolder(root_ / "mydir", (root_ / "ds").string(), false), InputError);
  EXPECT_FALSE(fs::exists(root_ / "mydir.partial"));
  fit_into(root_ / "mydir", true);  // --force: twill's files added, the notes kept
  EXPECT_EQ(read(root_ / "mydir" / "notes.txt"), "mine\n");
  EXPECT_EQ(read(root_ / "mydir" / "params.yaml"), "new\n");
}

TEST_F(FitOutputFolderTest, PreviousOutputIsReplacedButUserFilesStay) {
  fit_into(root_ / "out");
  write(root_ / "out" / "notes.txt", "mine\n");
  write(root_ / "out" / "fig2_force_elongation.png", "stale\n");
  fit_into(root_ / "out");
  EXPECT_EQ(read(root_ / "out" / "notes.txt"), "mine\n");
  EXPECT_FALSE(fs::exists(root_ / "out" / "fig2_force_elongation.png"));  // a stale output of twill's
  EXPECT_TRUE(fs::exists(root_ / "out" / kFitMarkerFile));
}

TEST_F(FitOutputFolderTest, FilesAndDatasetFoldersAreNeverOutputFolders) {
  write(root_ / "file.txt", "keep\n");
  for (bool force : {false, true}) {
    EXPECT_THROW(FitOutputFolder(root_ / "file.txt", (root_ / "ds").string(), force), InputError);
    EXPECT_THROW(FitOutputFolder(root_ / "ds", (root_ / "ds").string(), force), InputError);
    EXPECT_THROW(FitOutputFolder(root_ / "ds" / "tensile" / "..", (root_ / "ds").string(), force), InputError);
  }
  EXPECT_EQ(read(root_ / "file.txt"), "keep\n");
}

TEST_F(FitOutputFolderTest, FailedFitLeavesNothingOrAnIncompleteFolder) {
  { FitOutputFolder folder(root_ / "out", (root_ / "ds").string(), false); }
  EXPECT_FALSE(fs::exists(root_ / "out"));
  EXPECT_FALSE(fs::exists(root_ / "out.partial"));
  FitOutputFolder folder(root_ / "out", (root_ / "ds").string(), false);
  write(folder.staging() / "report-incomplete.md", "partial\n");
  const auto kept = folder.keep_incomplete();
  ASSERT_TRUE(kept);
  EXPECT_EQ(*kept, root_ / "out.incomplete");
  EXPECT_FALSE(fs::exists(root_ / "out"));
}

TEST_F(FitOutputFolderTest, IncompleteReportNeverLooksComplete) {
  FitReport finished;
  finished.dataset = "canvas";
  FitStageRecord warp;
  warp.stage = "warp";
  warp.resolution = "8x12";
  warp.avg_rel_error = 0.0123;
  finished.stages.push_back(warp);
  finished.notes.push_back("warp: degree 2 chosen");
  const Options config;  // the config is copied as given; its content does not matter here
  write_incomplete_fit_report(finished, config, "bend stage failed: no convergence", (root_ / "inc").string());
  const std::string md = read(root_ / "inc" / "report-incomplete.md");
  EXPECT_EQ(md.rfind("# INCOMPLETE twill fit: canvas", 0), 0u) << md;
  EXPECT_NE(md.find("bend stage failed: no convergence"), std::string::npos);
  EXPECT_NE(md.find("| warp | 8x12 |"), std::string::npos) << md;  // the finished stage is kept
  const std::string json = read(root_ / "inc" / "report-incomplete.json");
  EXPECT_NE(json.find("\"complete\": false"), std::string::npos) << json;
  EXPECT_FALSE(fs::exists(root_ / "inc" / "params.yaml"));
  EXPECT_FALSE(fs::exists(root_ / "inc" / "report.md"));
}

TEST_F(FitOutputFolderTest, UsersPartialFolderIsNotTouched) {
  write(root_ / "out.partial" / "x.txt", "mine\n");
  EXPECT_THROW(FitOutputFolder(root_ / "out", (root_ / "ds").string(), false), InputError);
  EXPECT_EQ(read(root_ / "out.partial" / "x.txt"), "mine\n");
}

}  // namespace
}  // namespace twill
