// Configs validated against schemas: defaults filled, every kind of bad input named with
// file, key path and line, `--set` overrides type-checked, resolved configs round-trip.
#include <gtest/gtest.h>

#include <filesystem>
#include <ostream>

#include "tests/core/toy_registry.hpp"

namespace twill {
namespace {

const std::string kFixtures = std::string(TWILL_SOURCE_DIR) + "/tests/data/configs/";

// A command-like schema using every option type.
OptionSchema fit_like_schema() {
  OptionSchema s;
  s.add_string("dataset", "", "dataset folder").required();
  s.add_int("seed", 1, "seed of the random repeat choice").at_least(0);
  s.add_string("repeats", "paper", "repeat rule").choices({"paper", "largest", "random", "all"});
  s.add_double_list("weights", {1.0, 1.0}, "weights of warp and weft data").at_least(0);
  s.add_component("optimizer", registry_category::kOptimizer, "toy-gd", "the minimiser");
  s.add_component_list("effects", registry_category::kEffect, "model extensions");
  OptionSchema& solver = s.add_section("solver", "equilibrium solver");
  solver.add_double("tolerance", 1e-9, "relative residual to stop at").greater_than(0);
  solver.add_int("max_iterations", 50, "Newton iteration limit").range(1, 1000);
  solver.add_bool("line_search", true, "backtracking on the energy");
  return s;
}

class Config : public ::testing::Test {
 protected:
  Config() {
    toy::register_toy_minimizers(registry);
    toy::register_toy_effects(registry);
  }
  Options read(const std::string& file) const { return read_config_file(kFixtures + file, schema, &registry); }

  Registry registry;
  OptionSchema schema = fit_like_schema();
};

TEST_F(Config, DefaultsAreFilledIn) {
  const Options c = read("good.yaml");
  EXPECT_EQ(c.get_string("dataset"), "/data/canvas");
  EXPECT_EQ(c.get_int("seed"), 1);
  EXPECT_EQ(c.get_string("repeats"), "paper");
  EXPECT_EQ(c.get_double_list("weights"), (std::vector<double>{1.0, 1.0}));
  const ComponentChoice& opt = c.get_component("optimizer");
  EXPECT_EQ(opt.category, "optimizer");
  EXPECT_EQ(opt.name, "toy-newton");
  EXPECT_EQ(opt.options.get_double("damping"), 0.5);
  EXPECT_EQ(opt.options.get_double_list("weights"), (std::vector<double>{1.0, 2.0}));
  const auto& effects = c.get_component_list("effects");
  ASSERT_EQ(effects.size(), 2u);
  EXPECT_EQ(effects[0].options.get_double("strength"), 0.5);
  EXPECT_EQ(effects[1].options.get_double("strength"), 0.25);
  const Options& solver = c.get_section("solver");
  EXPECT_EQ(solver.get_double("tolerance"), 1e-10);
  EXPECT_EQ(solver.get_int("max_iterations"), 50);
  EXPECT_TRUE(solver.get_bool("line_search"));
  // Schema order, whatever the file's order.
  ASSERT_EQ(c.entries().size(), 7u);
  EXPECT_EQ(c.entries()[4].key, "optimizer");

  const Options m = read("minimal.yaml");
  EXPECT_EQ(m.get_component("optimizer").name, "toy-gd");
  EXPECT_EQ(m.get_component("optimizer").options.get_int("max_iterations"), 100);
  EXPECT_TRUE(m.get_component_list("effects").empty());
  // The resolved component creates its implementation.
  const auto gd = registry.create<toy::MinimizerFactories>(registry_category::kOptimizer, m.get_component("optimizer"), 9);
  EXPECT_EQ(gd->summary(), "gd 100 wolfe 9");
}

TEST_F(Config, ResolvedConfigRoundTrips) {
  Options c = read("good.yaml");
  apply_override(c, schema, &registry, "solver.tolerance=0.1");  // not exactly representable
  apply_override(c, schema, &registry, "dataset=folder with spaces: and 'quotes'");
  const auto dir = std::filesystem::temp_directory_path() / "twill_test_config";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "resolved.yaml").string();
  write_config_file(c, path);
  const Options back = read_config_file(path, schema, &registry);
  EXPECT_TRUE(back == c) << options_to_yaml(c) << "\nread back as\n" << options_to_yaml(back);
  EXPECT_EQ(back.get_section("solver").get_double("tolerance"), 0.1);
  std::filesystem::remove_all(dir);
}

struct BadConfig {
  const char* file;
  int line;
  const char* key;
  const char* message;
};
void PrintTo(const BadConfig& c, std::ostream* os) { *os << c.file << ":" << c.line << " " << c.key; }

class ConfigErrors : public Config, public ::testing::WithParamInterface<BadConfig> {};

TEST_P(ConfigErrors, NamesFileKeyPathAndLine) {
  const BadConfig& c = GetParam();
  const std::string path = kFixtures + c.file;
  try {
    read(c.file);
    FAIL() << c.file << " was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.where().file, path) << what;
    EXPECT_EQ(e.where().line, c.line) << what;
    EXPECT_EQ(e.where().key, c.key) << what;
    EXPECT_NE(what.find(path + ":" + std::to_string(c.line)), std::string::npos) << what;
    EXPECT_NE(what.find(c.message), std::string::npos) << "expected '" << c.message << "' in: " << what;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Malformed, ConfigErrors,
    ::testing::Values(
        BadConfig{"unknown_key.yaml", 4, "solver.max_iter", "unknown key (known keys here: line_search, max_iterations, tolerance)"},
        BadConfig{"unknown_component_key.yaml", 4, "optimizer.damping", "unknown key"},
        BadConfig{"out_of_range.yaml", 3, "solver.max_iterations", "must be in [1, 1000], got 0"},
        BadConfig{"out_of_range_component.yaml", 2, "optimizer.step", "must be in (0, 10], got 20"},
        BadConfig{"wrong_type.yaml", 2, "seed", "expected an integer, got 'many'"},
        BadConfig{"int_with_fraction.yaml", 2, "seed", "expected an integer, got '2.5'"},
        BadConfig{"bad_choice.yaml", 2, "repeats", "must be one of: paper, largest, random, all; got 'best'"},
        BadConfig{"unknown_component.yaml", 3, "optimizer", "unknown optimizer 'toy-bfgs' (known: toy-gd, toy-newton)"},
        BadConfig{"missing_required.yaml", 2, "dataset", "missing required key"},
        BadConfig{"list_item_out_of_range.yaml", 2, "weights", "item [1] must be >= 0, got -1"},
        BadConfig{"component_without_name.yaml", 4, "effects[1].name", "missing required key"}),
    [](const ::testing::TestParamInfo<BadConfig>& param_info) {
      std::string name = param_info.param.file;
      return name.substr(0, name.find('.'));
    });

TEST_F(Config, OverridesAreTypeChecked) {
  Options c = read("good.yaml");
  apply_overrides(c, schema, &registry,
                  {"seed=12", "weights=[0.5, 2]", "solver.line_search=false", "solver.tolerance=1e-12",
                   "repeats=random", "optimizer.damping=2", "effects[1].strength=0.75"});
  EXPECT_EQ(c.get_int("seed"), 12);
  EXPECT_EQ(c.get_double_list("weights"), (std::vector<double>{0.5, 2.0}));
  EXPECT_FALSE(c.get_section("solver").get_bool("line_search"));
  EXPECT_EQ(c.get_section("solver").get_double("tolerance"), 1e-12);
  EXPECT_EQ(c.get_string("repeats"), "random");
  EXPECT_EQ(c.get_component("optimizer").options.get_double("damping"), 2.0);
  EXPECT_EQ(c.get_component_list("effects")[1].options.get_double("strength"), 0.75);
  // A whole component list, as YAML, each entry resolved like a file's.
  Options whole = read("good.yaml");
  apply_override(whole, schema, &registry, "effects=[{name: sag, strength: 0.25}]");
  ASSERT_EQ(whole.get_component_list("effects").size(), 1u);
  EXPECT_EQ(whole.get_component_list("effects")[0].options.get_double("strength"), 0.25);
  apply_override(whole, schema, &registry, "effects=[]");
  EXPECT_TRUE(whole.get_component_list("effects").empty());
  EXPECT_THROW(apply_override(whole, schema, &registry, "effects=[{name: sag, strength: -1}]"), InputError);

  struct Case {
    const char* assignment;
    const char* key;
    const char* message;
  };
  const Case bad[] = {
      {"seed=2.5", "seed", "expected an integer, got '2.5'"},
      {"seed=-1", "seed", "must be >= 0, got -1"},
      {"solver.tolerance=small", "solver.tolerance", "expected a number, got 'small'"},
      {"solver.tolerance=0", "solver.tolerance", "must be > 0, got 0"},
      {"solver.line_search=maybe", "solver.line_search", "expected true or false"},
      {"weights=[1, x]", "weights[1]", "expected a number, got 'x'"},
      {"repeats=best", "repeats", "must be one of: paper, largest, random, all"},
      {"solver.max_iter=3", "solver.max_iter", "unknown key (known keys here: tolerance, max_iterations, line_search)"},
      {"solver=3", "solver", "is a section; set one of its keys"},
      {"seed.x=3", "seed", "is of type int and has no keys below it"},
      {"optimizer.step=1", "optimizer.step", "unknown key"},  // toy-newton has no step
      {"optimizer=toy-lbfgs", "optimizer", "unknown optimizer 'toy-lbfgs' (known: toy-gd, toy-newton)"},
      {"effects[5].strength=1", "effects[5]", "has 2 entries"},
      {"effects.strength=1", "effects", "address one as effects[i]"},
      {"seed[0]=1", "seed[0]", "not a list of components"},
      {"no_equals_sign", "", "expected key.path=value"},
      {"=3", "", "expected key.path=value"},
  };
  for (const Case& k : bad) {
    Options copy = c;
    try {
      apply_override(copy, schema, &registry, k.assignment);
      ADD_FAILURE() << k.assignment << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().file, "--set") << k.assignment;
      EXPECT_EQ(e.where().key, k.key) << k.assignment << ": " << e.what();
      EXPECT_NE(std::string(e.what()).find(k.message), std::string::npos) << k.assignment << ": " << e.what();
    }
    EXPECT_TRUE(copy == c) << k.assignment << " changed the config although it failed";
  }
}

TEST_F(Config, OverridingAComponentNameResetsItsOptions) {
  Options c = read("good.yaml");
  apply_override(c, schema, &registry, "optimizer.name=toy-gd");
  EXPECT_EQ(c.get_component("optimizer").name, "toy-gd");
  EXPECT_EQ(c.get_component("optimizer").options.get_int("max_iterations"), 100);
  apply_override(c, schema, &registry, "optimizer.max_iterations=7");
  EXPECT_EQ(c.get_component("optimizer").options.get_int("max_iterations"), 7);
  apply_override(c, schema, &registry, "optimizer=toy-newton");
  EXPECT_EQ(c.get_component("optimizer").options.get_double("damping"), 0.0);
  apply_override(c, schema, &registry, "effects[0]=thermal");
  EXPECT_EQ(c.get_component_list("effects")[0].name, "thermal");
  EXPECT_TRUE(c.get_component_list("effects")[0].options.empty());
  // Strings are verbatim, including characters YAML would interpret.
  apply_override(c, schema, &registry, "dataset=#a: b");
  EXPECT_EQ(c.get_string("dataset"), "#a: b");
}

// list[*].key sets the key in every entry that has it (a protocol's stages of several kinds),
// and is an error when no entry has it; a component list's default may be a YAML list.
TEST_F(Config, EveryEntryOverrideAndDefaultItems) {
  OptionSchema with_default;
  with_default.add_component_list("effects", registry_category::kEffect, "model extensions")
      .default_items("[sag, thermal, {name: sag, strength: 0.1}]", "the default effects");
  Options c = default_options(with_default, &registry);
  ASSERT_EQ(c.get_component_list("effects").size(), 3u);
  EXPECT_EQ(c.get_component_list("effects")[2].options.get_double("strength"), 0.1);
  EXPECT_EQ(with_default.find("effects")->default_text(), "(the default effects)");
  apply_override(c, with_default, &registry, "effects[*].strength=0.75");  // thermal has no strength
  EXPECT_EQ(c.get_component_list("effects")[0].options.get_double("strength"), 0.75);
  EXPECT_TRUE(c.get_component_list("effects")[1].options.empty());
  EXPECT_EQ(c.get_component_list("effects")[2].options.get_double("strength"), 0.75);
  for (const auto& [assignment, key] : std::vector<std::pair<std::string, std::string>>{
           {"effects[*].weight=1", "effects[*].weight"},    // no entry has it
           {"effects[*].strength=2", "effects[*].strength"},  // out of range in the entries that have it
           {"effects[*]=sag", "effects[*]"},                  // no key after [*]
           {"effects[*].name=sag", "effects[*].name"}}) {
    try {
      apply_override(c, with_default, &registry, assignment);
      ADD_FAILURE() << assignment << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.where().key, key) << assignment << ": " << e.what();
    }
  }
  // A bad default is the program's error, found when the defaults are resolved.
  OptionSchema bad;
  bad.add_component_list("effects", registry_category::kEffect, "x").default_items("[nonexistent]", "bad default");
  EXPECT_THROW(default_options(bad, &registry), InputError);
}

TEST_F(Config, DefaultOptionsNeedRequiredValues) {
  EXPECT_THROW(default_options(schema, &registry), InputError);  // dataset is required
  OptionSchema plain;
  plain.add_int("n", 3, "count");
  plain.add_section("inner", "nested").add_double("x", 0.5, "value");
  const Options d = default_options(plain, nullptr);
  EXPECT_EQ(d.get_int("n"), 3);
  EXPECT_EQ(d.get_section("inner").get_double("x"), 0.5);
  // Getters guard against programming errors.
  EXPECT_THROW(d.get_double("n"), std::logic_error);
  EXPECT_THROW(d.get_int("m"), std::logic_error);
}

}  // namespace
}  // namespace twill
