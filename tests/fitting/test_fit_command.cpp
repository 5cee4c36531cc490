// `twill fit` as a user runs it: bad input ends with a clear error (exit status 2) that names
// the file, and no output folder is left behind looking complete (issue #6 acceptance).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fitting/fit_config.hpp"
#include "tests/support/program_registry.hpp"

namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int status;
  std::string output;
};

CommandResult twill(const std::string& arguments) {
  // One log per test process and call: ctest runs these tests in parallel, and a shared log
  // file let one test truncate another's output (seen on a clean-clone CI run).
  static int call = 0;
  const fs::path log = fs::temp_directory_path() /
                       ("twill-fit-command-" + std::to_string(::getpid()) + "-" + std::to_string(call++) + ".log");
  const std::string cmd = std::string(TWILL_BINARY) + " " + arguments + " >" + log.string() + " 2>&1";
  const int raw = std::system(cmd.c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  in.close();
  fs::remove(log);
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, text.str()};
}

TEST(FitCommand, MalformedDatasetFailsClearlyAndLeavesNoOutput) {
  const fs::path out = fs::temp_directory_path() / "twill-fit-bad";
  fs::remove_all(out);
  const std::string dataset = std::string(TWILL_SOURCE_DIR) + "/tests/data/datasets/bad_cell";
  const CommandResult r = twill("fit " + dataset + " -o " + out.string() + " --quiet");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("run-1.csv"), std::string::npos) << r.output;  // names the file
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
}

TEST(FitCommand, ImpossibleConfigFailsBeforeAnythingIsWritten) {
  const fs::path out = fs::temp_directory_path() / "twill-fit-bad-config";
  fs::remove_all(out);
  const std::string dataset = std::string(TWILL_SOURCE_DIR) + "/examples/canvas";
  for (const char* set : {"resolution.levels=9", "optimizer=newton", "degree.maximum=2"}) {
    const CommandResult r = twill("fit " + dataset + " -o " + out.string() + " --quiet --set " + set);
    EXPECT_EQ(r.status, 2) << set << ": " << r.output;
    EXPECT_NE(r.output.find("error"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << set;
  }
}

TEST(FitCommand, PrintConfigListsEveryProtocolKey) {
  const CommandResult r = twill("fit --print-config --set optimizer=ipopt");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* key : {"discretization:", "optimizer:", "name: \"ipopt\"", "resolution:", "repeats:", "protocol:"})
    EXPECT_NE(r.output.find(key), std::string::npos) << key << "\n" << r.output;
  // Every stage of the default protocol, by its registered kind, with its options (kinds that
  // need an input to run, as start-from its params.yaml, are not in the default protocol).
  const twill::OptionSchema schema = twill::fit_config_schema();
  const twill::Options defaults = twill::default_options(schema, &twill::testing::program_registry());
  const auto* stages = twill::testing::program_registry().find_category(twill::registry_category::kStage);
  for (const twill::ComponentChoice& stage : defaults.get_component_list("protocol")) {
    EXPECT_NE(r.output.find("name: \"" + stage.name + "\""), std::string::npos) << stage.name;
    for (const twill::OptionSpec& option : stages->at(stage.name).options.options())
      EXPECT_NE(r.output.find(option.name + ":"), std::string::npos) << stage.name << "." << option.name;
  }
}

}  // namespace

namespace {

// `twill discover` (fitting/discovery.hpp) as a user runs it: a candidate that is not a
// registered effect fails before any fit, naming the key and the known names; on the bundled
// canvas (no unloading rows, no second rate, no lateral strain, one cantilever per direction)
// every candidate but those the data can test is `untestable`, with what it needs, and the
// outputs land complete.
TEST(DiscoverCommand, UnknownCandidateFailsBeforeAnyFit) {
  const fs::path out = fs::temp_directory_path() / ("twill-discover-bad-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string dataset = std::string(TWILL_SOURCE_DIR) + "/examples/canvas";
  const CommandResult r = twill("discover " + dataset + " -o " + out.string() + " --quiet --set 'discover.candidates=[friction]'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("friction"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hysteresis"), std::string::npos) << r.output;  // the known names
  EXPECT_FALSE(fs::exists(out));
  const CommandResult config = twill("discover --print-config");
  EXPECT_EQ(config.status, 0) << config.output;
  EXPECT_NE(config.output.find("discover:"), std::string::npos) << config.output;
  EXPECT_NE(config.output.find("min_excess_shrink"), std::string::npos) << config.output;
}

TEST(DiscoverCommand, UntestableCandidatesAreReportedWithWhatTheyNeed) {
  const fs::path out = fs::temp_directory_path() / ("twill-discover-canvas-" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string dataset = std::string(TWILL_SOURCE_DIR) + "/examples/canvas";
  const std::string tiny =
      " --set resolution.coarse_cells_across=2 --set resolution.levels=1 --set data.max_points=6"
      " --set 'protocol=[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1},"
      " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1},"
      " {name: effect-fit, effect: hysteresis}]'"
      " --set 'discover.candidates=[hysteresis, rate-dependence, poisson]'";
  const CommandResult r = twill("discover " + dataset + " -o " + out.string() + " --quiet --no-plots" + tiny);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream in(out / "discover.json");
  std::stringstream text;
  text << in.rdbuf();
  const std::string json = text.str();
  EXPECT_NE(json.find("\"verdict\""), std::string::npos) << json;
  EXPECT_NE(json.find("needs: a tensile run that goes up and comes back down"), std::string::npos) << json;
  EXPECT_NE(json.find("needs: lateral strain"), std::string::npos) << json;
  EXPECT_EQ(json.find("\"named\": [\n    \""), std::string::npos) << json;  // nothing named
  EXPECT_NE(json.find("\"repeat_noise\": {"), std::string::npos) << json;  // the canvas's repeats: the load cell's law
  for (const char* file : {"discover.md", "params.yaml", "config.yaml", "baseline-report.json", ".twill-discover"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
  fs::remove_all(out);
}

}  // namespace
