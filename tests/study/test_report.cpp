// `twill report` (issue #17; docs/studies.md §5): tables of any metric against any swept key,
// grouped by others, from a results database; failed runs apart; strict about names; the
// program writes report.md (and its plots) into a folder of its own.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/input_error.hpp"
#include "study/report.hpp"
#include "study/results_db.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    folder_ = fs::temp_directory_path() / ("twill-report-" + std::to_string(getpid()) + "-" +
                                           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(folder_);
    fs::create_directories(folder_);
    ResultsDb db(folder_ / "results.sqlite");
    // Resolution 16, 8, 32 (out of numeric order) × two optimisers × two seeds, one run failed.
    int order = 0;
    for (const char* cells : {"16", "8", "32"})
      for (const char* optimizer : {"bfgs", "gauss-newton"})
        for (const char* seed : {"1", "2"}) {
          StudyRun run;
          run.dataset = "canvas";
          run.hash = fmt::format("{:016x}", order + 1);
          run.values = {{"dataset", "canvas"}, {"cells", cells}, {"optimizer.name", optimizer}, {"seed", seed}};
          db.mark_running(run, "fit", order++, 0);
          RunOutcome o;
          const bool fails = std::string(cells) == "32" && std::string(optimizer) == "gauss-newton" && seed[0] == '2';
          o.status = fails ? "failed" : "done";
          o.error = fails ? "stage warp: degree 2 fit failed" : "";
          // error = 1/cells + 0.1 (gauss-newton) + 0.01·seed: cells exact per (cells, optimizer, seed).
          const double error = 1.0 / std::atof(cells) + (optimizer[0] == 'g' ? 0.1 : 0.0) + 0.01 * std::atof(seed);
          if (!fails) o.metrics = {{"error.fit", error}, {"param.a11_Pa", 1000.0 * error}, {"param.a22_Pa", 2000.0}};
          db.record(run.hash, o);
        }
  }
  void TearDown() override { fs::remove_all(folder_); }
  ResultsDb db() const { return ResultsDb(folder_ / "results.sqlite", ResultsDb::Access::read_only); }
  fs::path folder_;
};

TEST_F(ReportTest, AMetricAgainstASweptKeyGroupedByAnother) {
  const auto tables = tabulate(db(), {"error.fit", "cells", {"optimizer.name", "seed"}}, "test");
  ASSERT_EQ(tables.size(), 1u);
  const ReportTableData& t = tables[0];
  EXPECT_EQ(t.x_values, (std::vector<std::string>{"8", "16", "32"}));  // numeric order
  EXPECT_EQ(t.columns.size(), 4u);
  EXPECT_EQ(t.columns[0], "optimizer.name=bfgs, seed=1");
  EXPECT_NEAR(t.cells[0][0]->mean, 1.0 / 8 + 0.01, 1e-12);
  EXPECT_EQ(t.cells[0][0]->count, 1);
  EXPECT_FALSE(t.cells[2][3].has_value());  // the failed run is not a value
  const std::string md = markdown(t);
  EXPECT_NE(md.find("| 8 | 0.135 |"), std::string::npos) << md;
  EXPECT_NE(md.find(" — |"), std::string::npos) << md;
}

TEST_F(ReportTest, KeysOutsideXAndGroupArePooledAndSaidSo) {
  const auto t = tabulate(db(), {"error.fit", "cells", {"optimizer.name"}}, "test")[0];
  ASSERT_EQ(t.columns.size(), 2u);
  EXPECT_EQ(t.cells[1][0]->count, 2);  // 16 cells, bfgs: seeds 1 and 2
  EXPECT_NEAR(t.cells[1][0]->mean, 1.0 / 16 + 0.015, 1e-12);
  EXPECT_EQ(t.cells[2][1]->count, 1);  // 32, gauss-newton: seed 2 failed
  EXPECT_NE(markdown(t).find("mean of n runs"), std::string::npos);
}

TEST_F(ReportTest, APatternGivesATableEachAndUnknownNamesAreErrors) {
  EXPECT_EQ(tabulate(db(), {"param.*", "cells", {}}, "test").size(), 2u);
  // Grouped by the pseudo key `metric`: one table, a column per matched metric.
  const auto wide = tabulate(db(), {"param.*", "cells", {"metric"}}, "test");
  ASSERT_EQ(wide.size(), 1u);
  EXPECT_EQ(wide[0].columns, (std::vector<std::string>{"param.a11_Pa", "param.a22_Pa"}));
  EXPECT_EQ(wide[0].cells[0][1]->mean, 2000.0);
  try {
    tabulate(db(), {"error.fti", "cells", {}}, "test");
    FAIL() << "an unknown metric was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("error.fit, param.a11_Pa, param.a22_Pa"), std::string::npos) << e.what();
  }
  try {
    tabulate(db(), {"error.fit", "resolution", {}}, "test");
    FAIL() << "an unknown x key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("swept: dataset, cells, optimizer.name, seed"), std::string::npos) << e.what();
  }
}

TEST_F(ReportTest, RefinementRowsGiveTheObservedOrderAndTheLimit) {
  // bfgs, seed 1: 1/cells + 0.01 at 8, 16, 32 cells: differences halve, order 1, limit 0.01.
  const auto t = tabulate(db(), {"error.fit", "cells", {"optimizer.name", "seed"}, true}, "test")[0];
  ASSERT_EQ(t.refinement.size(), 4u);
  ASSERT_TRUE(t.refinement[0] && t.refinement[0]->asymptotic);
  EXPECT_NEAR(t.refinement[0]->order, 1.0, 1e-9);
  EXPECT_NEAR(t.refinement[0]->limit, 0.01, 1e-12);
  EXPECT_EQ(t.refinement[0]->within_from, "");  // 0.04125 at 32 cells is far from 0.01
  EXPECT_FALSE(t.refinement[3].has_value());       // gauss-newton seed 2 has no value at 32
  // param.a22_Pa is 2000 everywhere: a constant is its own limit, within the band from the start.
  const auto flat = tabulate(db(), {"param.a22_Pa", "cells", {}, true}, "test")[0];
  ASSERT_EQ(flat.refinement.size(), 1u);
  EXPECT_TRUE(flat.refinement[0]->asymptotic);
  EXPECT_EQ(flat.refinement[0]->limit, 2000.0);
  EXPECT_EQ(flat.refinement[0]->within_from, "8");
  // gauss-newton seed 1 (0.235, 0.1725, 0.14125 at 8, 16, 32): order 1, limit its offset 0.11.
  EXPECT_NEAR(t.refinement[2]->order, 1.0, 1e-9);
  EXPECT_NEAR(t.refinement[2]->limit, 0.11, 1e-12);
  const std::string md = markdown(t);
  EXPECT_NE(md.find("| observed order | 1.00 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| within 1 % from | beyond |"), std::string::npos) << md;
}

TEST_F(ReportTest, DefaultTablesAreTheStudysElseErrorsAndTimeAgainstEachVaryingKey) {
  const auto tables = default_report_tables(db());
  ASSERT_EQ(tables.size(), 3u);  // error.fit against cells, optimizer.name, seed (dataset does not vary)
  EXPECT_EQ(tables[0].x, "cells");
  EXPECT_EQ(tables[0].group, (std::vector<std::string>{"optimizer.name", "seed"}));
  {
    ResultsDb writable(folder_ / "results.sqlite");
    writable.set_meta("report", R"([{"metric": "param.a11_Pa", "x": "seed", "group": []}])");
  }
  const auto stored = default_report_tables(db());
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].metric, "param.a11_Pa");
  EXPECT_NE(unfinished_runs_markdown(db()).find("| failed | dataset=canvas cells=32 optimizer.name=gauss-newton seed=2 | "
                                                "stage warp: degree 2 fit failed |"),
            std::string::npos)
      << unfinished_runs_markdown(db());
}

TEST_F(ReportTest, TheProgramWritesItsTableIntoAFolderOfItsOwn) {
  const std::string twill = TWILL_BINARY;
  const auto run = [&](const std::string& args) {
    const std::string command = twill + " report " + args + " > " + (folder_ / "log.txt").string() + " 2>&1";
    const int status = std::system(command.c_str());
    std::ifstream in(folder_ / "log.txt");
    std::stringstream s;
    s << in.rdbuf();
    return std::make_pair(WIFEXITED(status) ? WEXITSTATUS(status) : -1, s.str());
  };
  auto [status, log] = run(folder_.string() + " --metric error.fit --x cells --group optimizer.name --quiet");
  ASSERT_EQ(status, 0) << log;
  std::ifstream in(folder_ / "report" / "report.md");
  std::stringstream md;
  md << in.rdbuf();
  EXPECT_NE(md.str().find("## error.fit against cells"), std::string::npos) << md.str();
  EXPECT_NE(md.str().find("| 8 | 0.14 (n=2, 0.135…0.145) |"), std::string::npos) << md.str();
  EXPECT_TRUE(fs::exists(folder_ / "report" / "plot-01-error.fit-vs-cells.png"));
  // Run again: its own folder is replaced; a folder of someone else's is refused untouched.
  EXPECT_EQ(run(folder_.string() + " --no-plots --quiet").first, 0);
  EXPECT_FALSE(fs::exists(folder_ / "report" / "plot-01-error.fit-vs-cells.png"));
  fs::create_directories(folder_ / "notes");
  std::ofstream(folder_ / "notes" / "mine.txt") << "mine";
  std::tie(status, log) = run(folder_.string() + " -o " + (folder_ / "notes").string() + " --no-plots");
  EXPECT_EQ(status, 2) << log;
  EXPECT_NE(log.find("not a twill output"), std::string::npos) << log;
  EXPECT_EQ(run((folder_ / "nosuch.sqlite").string()).first, 1);
}

}  // namespace
}  // namespace twill
