// Every registered stage kind (category `stage`, fitting/fit_stage.hpp) runs, with its default
// options, at the end of a tiny protocol on the bundled canvas example — three linear curve
// stages on a 2-cell-wide strip — and reports its time; a stage kind is tested the day it is
// registered. A kind whose defaults the protocol's up-front check rejects here (tensile-curve:
// its default label is the warp stage's) is skipped with the check's words.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/dataset.hpp"
#include "core/input_error.hpp"
#include "fitting/fit_protocol.hpp"
#include "tests/support/program_registry.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

const Registry& registry() { return testing::program_registry(); }

// The curve stages every kind runs after: linear curves, no uniform-strain starts.
constexpr const char* kTinyCurves =
    "[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1, uniform_starts: false},"
    " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1, uniform_starts: false},"
    " {name: tensile-curve, label: bias, angle_deg: 45, term: eta4, max_degree: 1, uniform_starts: false}]";

class EveryStage : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryStage, RunsWithItsDefaultsAtTheEndOfATinyProtocol) {
  const Dataset dataset = read_dataset(std::string(TWILL_SOURCE_DIR) + "/examples/canvas");
  const OptionSchema schema = fit_config_schema();
  Options config = default_options(schema, &registry());
  apply_overrides(config, schema, &registry(),
                  {"resolution.coarse_cells_across=2", "resolution.levels=1", "data.max_points=6",
                   std::string("protocol=") + kTinyCurves, "experiments.bend.cells_across=2",
                   "experiments.bend.cells_along=16"});
  std::vector<ComponentChoice> protocol = config.get_component_list("protocol");
  const RegistryEntry& entry = registry().find_category(registry_category::kStage)->at(GetParam());
  protocol.push_back({registry_category::kStage, entry.name, default_options(entry.options, &registry())});
  config.set("protocol", protocol);
  try {
    check_fit_protocol(dataset, config, registry(), [](const std::string& key) { return InputLocation{"", 0, key}; });
  } catch (const InputError& e) {
    GTEST_SKIP() << "its defaults do not fit this protocol: " << e.what();
  }
  const FitReport report = run_fit(dataset, config, registry(), {});
  ASSERT_GE(report.timing_s.size(), 5u);  // three curve stages, this one, the total
  EXPECT_EQ(report.timing_s.back().first, "total");
  const auto& [title, seconds] = report.timing_s[report.timing_s.size() - 2];
  EXPECT_FALSE(title.empty());
  EXPECT_GE(seconds, 0.0);
  const Eigen::VectorXd flat = report.parameters.to_flat();
  EXPECT_TRUE(flat.allFinite()) << entry.name << " left a non-finite parameter";
  std::printf("[measured] stage %s: '%s' %.2f s\n", entry.name.c_str(), title.c_str(), seconds);
}

INSTANTIATE_TEST_SUITE_P(Registered, EveryStage, ::testing::ValuesIn(testing::registered_names(registry_category::kStage)),
                         [](const auto& info) { return testing::test_name(info.param); });

}  // namespace
}  // namespace twill
