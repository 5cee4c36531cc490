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
