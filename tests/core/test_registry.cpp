// The registry: creation by name with resolved options, unknown names list the known ones,
// misuse (duplicate names, wrong factory signature, hand-built options) is a logic_error.
#include <gtest/gtest.h>

#include "tests/core/toy_registry.hpp"

namespace twill {
namespace {

TEST(Registry, CreatesByNameWithDefaultsAndGivenOptions) {
  Registry registry;
  toy::register_toy_minimizers(registry);
  const auto& category = registry.category<toy::MinimizerFactories>(registry_category::kOptimizer);
  EXPECT_EQ(category.create_with_defaults("toy-gd", 7)->summary(), "gd 100 wolfe 7");

  Options o = default_options(category.at("toy-gd").options, nullptr);
  o.set("max_iterations", 5);
  o.set("line_search", "armijo");
  EXPECT_EQ(category.create("toy-gd", o, 3)->summary(), "gd 5 armijo 3");

  const ComponentChoice choice{registry_category::kOptimizer, "toy-newton",
                               default_options(category.at("toy-newton").options, nullptr)};
  const auto newton = registry.create<toy::MinimizerFactories>(registry_category::kOptimizer, choice, 0);
  EXPECT_EQ(newton->summary(), "newton");
}

TEST(Registry, UnknownNameListsKnownNames) {
  Registry registry;
  toy::register_toy_minimizers(registry);
  const auto& category = registry.category<toy::MinimizerFactories>(registry_category::kOptimizer);
  try {
    category.create_with_defaults("toy-bfgs", 0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "input: unknown optimizer 'toy-bfgs' (known: toy-gd, toy-newton)");
  }
  // A category nobody registered into.
  const ComponentChoice choice{registry_category::kExperiment, "tensile", {}};
  try {
    registry.create<FactoryCategory<toy::Effect>>(registry_category::kExperiment, choice);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown experiment 'tensile' (known: none registered)"), std::string::npos)
        << e.what();
  }
}

TEST(Registry, ListsCategoriesAndEntries) {
  Registry registry;
  toy::register_toy_minimizers(registry);
  toy::register_toy_effects(registry);
  registry.category<FactoryCategory<toy::Effect>>("postprocessor");
  EXPECT_EQ(registry.category_names(),
            (std::vector<std::string>{"discretization", "optimizer", "experiment", "effect", "postprocessor"}));
  EXPECT_EQ(registry.find_category("discretization"), nullptr);
  const RegistryCategory* optimizers = registry.find_category("optimizer");
  ASSERT_NE(optimizers, nullptr);
  ASSERT_EQ(optimizers->entries().size(), 2u);
  EXPECT_EQ(optimizers->entries()[0].name, "toy-gd");
  EXPECT_EQ(optimizers->entries()[0].description, "gradient descent (test placeholder)");
  const OptionSpec* step = optimizers->entries()[0].options.find("step");
  ASSERT_NE(step, nullptr);
  EXPECT_EQ(step->type, OptionType::Double);
  EXPECT_EQ(step->default_text(), "0.1");
  EXPECT_EQ(step->constraint_text(), "in (0, 10]");
  EXPECT_EQ(optimizers->entries()[0].options.find("line_search")->constraint_text(), "one of: armijo, wolfe");
  EXPECT_EQ(optimizers->known_names(), "toy-gd, toy-newton");
}

TEST(Registry, MisuseIsALogicError) {
  Registry registry;
  toy::register_toy_minimizers(registry);
  // Registering twice.
  EXPECT_THROW(toy::register_toy_minimizers(registry), std::logic_error);
  // The same category with another factory signature.
  EXPECT_THROW(registry.category<FactoryCategory<toy::Minimizer>>(registry_category::kOptimizer), std::logic_error);
  // A multi-line description, an option called "name".
  auto& effects = registry.category<toy::EffectFactories>(registry_category::kEffect);
  auto make = [](const Options&) -> std::unique_ptr<toy::Effect> { return std::make_unique<toy::Sag>(); };
  EXPECT_THROW(effects.add("x", "two\nlines", {}, make), std::logic_error);
  OptionSchema with_name;
  with_name.add_string("name", "a", "clashes with the component's name key");
  EXPECT_THROW(effects.add("y", "one line", with_name, make), std::logic_error);
  // Options not resolved against the schema.
  Options partial;
  partial.set("max_iterations", 5);
  const auto& optimizers = registry.category<toy::MinimizerFactories>(registry_category::kOptimizer);
  EXPECT_THROW(optimizers.create("toy-gd", partial, 0), std::logic_error);
  Options wrong_type = default_options(optimizers.at("toy-gd").options, nullptr);
  wrong_type.set("max_iterations", 5.0);
  EXPECT_THROW(optimizers.create("toy-gd", wrong_type, 0), std::logic_error);
}

TEST(Registry, SchemaDefaultsMustSatisfyConstraints) {
  OptionSchema s;
  EXPECT_THROW(s.add_double("tolerance", -1.0, "must be positive").greater_than(0), std::logic_error);
  EXPECT_THROW(s.add_string("mode", "fast", "choice").choices({"slow", "exact"}), std::logic_error);
  EXPECT_THROW(s.add_bool("flag", true, "no range on bools").at_least(0), std::logic_error);
  EXPECT_THROW(s.add_int("flag", 1, "defined twice"), std::logic_error);
  EXPECT_THROW(s.add_int("a.b", 1, "dots are key-path separators"), std::logic_error);
}

}  // namespace
}  // namespace twill
