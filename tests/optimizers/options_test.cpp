// Option schemas and validation: every options struct names the violated constraint; options
// given like a config (`--set key=value`) are checked against the schema with InputErrors that
// name the key; the registry rejects unknown names listing the known ones; every registered
// optimiser's schema defaults are its struct's defaults.
#include <gtest/gtest.h>

#include <set>

#include "core/registry.hpp"
#include "optimizers/bfgs.hpp"
#include "optimizers/gauss_newton.hpp"
#include "optimizers/ipopt_optimizer.hpp"
#include "optimizers/nlopt_optimizer.hpp"
#include "tests/support/program_registry.hpp"

namespace twill {
namespace {

// The InputError `body` throws (fails the test if it throws nothing or something else).
template <class Body>
InputError input_error(Body&& body) {
  try {
    body();
  } catch (const InputError& e) {
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw something other than InputError: " << e.what();
    return InputError({}, "");
  }
  ADD_FAILURE() << "did not throw";
  return InputError({}, "");
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(OptimizerOptions, ValidateNamesTheViolatedConstraint) {
  std::string error;
  EXPECT_TRUE(BfgsOptions{}.validate(&error));
  EXPECT_TRUE(GaussNewtonOptions{}.validate(&error));
  EXPECT_TRUE(IpoptOptions{}.validate(&error));
  EXPECT_TRUE(NloptOptions{}.validate(&error));
  EXPECT_TRUE(OptimizerOptions{}.validate(&error));

  BfgsOptions bfgs;
  bfgs.c1 = 0.5;
  bfgs.c2 = 0.4;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_TRUE(contains(error, "c1 = 0.5 must be smaller than c2 = 0.4")) << error;
  bfgs = {};
  bfgs.c2 = 1.0;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_EQ(error, "c2 must be in (0, 1), got 1");
  bfgs = {};
  bfgs.gradient_tolerance = -1e-3;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_EQ(error, "gradient_tolerance must be >= 0, got -0.001");
  bfgs = {};
  bfgs.function_tolerance = std::nan("");
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_TRUE(contains(error, "function_tolerance must be finite")) << error;
  bfgs = {};
  bfgs.max_iterations = 0;
  EXPECT_FALSE(bfgs.validate(nullptr));

  GaussNewtonOptions gn;
  gn.initial_lambda = 1e3;
  gn.max_lambda = 1.0;
  EXPECT_FALSE(gn.validate(&error));
  EXPECT_TRUE(contains(error, "initial_lambda = 1000 must not exceed max_lambda = 1")) << error;

  IpoptOptions ipopt;
  ipopt.mu_strategy = "probing-ish";
  EXPECT_FALSE(ipopt.validate(&error));
  EXPECT_EQ(error, "mu_strategy must be one of: monotone, adaptive; got 'probing-ish'");

  NloptOptions nlopt;
  nlopt.algorithm = "LD_NEWTON";
  EXPECT_FALSE(nlopt.validate(&error));
  EXPECT_TRUE(contains(error, "got 'LD_NEWTON'")) << error;
  for (const auto& name : supported_nlopt_algorithms()) EXPECT_TRUE(contains(error, name)) << error;
}

TEST(OptimizerOptions, ConstructorsRejectInvalidOptions) {
  BfgsOptions bfgs;
  bfgs.c1 = 0.95;
  const InputError e = input_error([&] { Bfgs{bfgs}; });
  EXPECT_TRUE(contains(e.what(), "bfgs: c1 = 0.95 must be smaller than c2 = 0.9")) << e.what();
  NloptOptions nlopt;
  nlopt.algorithm = "GN_DIRECT";
  EXPECT_THROW(NloptOptimizer{nlopt}, InputError);
  GaussNewtonOptions gn;
  gn.max_line_search_evaluations = 0;
  EXPECT_THROW(GaussNewton{gn}, InputError);
  IpoptOptions ipopt;
  ipopt.print_level = 13;
  EXPECT_THROW(IpoptOptimizer{ipopt}, InputError);
}

// The optimizer category of the program's registry, and choices in it with overrides.
const OptimizerFactories& optimizers() {
  return dynamic_cast<const OptimizerFactories&>(
      *testing::program_registry().find_category(registry_category::kOptimizer));
}
ComponentChoice choice(const std::string& name, const std::vector<std::string>& overrides = {}) {
  return testing::program_registry().choice(registry_category::kOptimizer, name, overrides);
}
std::unique_ptr<Optimizer> create(const ComponentChoice& chosen) { return optimizers().create(chosen); }

TEST(OptimizerRegistry, UnknownNameListsTheKnownOnes) {
  std::string known;
  for (const auto& name : testing::registered_names(registry_category::kOptimizer))
    known += (known.empty() ? "" : ", ") + name;
  EXPECT_EQ(optimizers().known_names(), known);
  for (auto body : {std::function<void()>([] { optimizers().create_with_defaults("newton"); }),
                    std::function<void()>([] { choice("newton"); })}) {
    const InputError e = input_error(body);
    EXPECT_TRUE(contains(e.what(), "unknown optimizer 'newton' (known: " + known + ")")) << e.what();
  }
}

TEST(OptimizerRegistry, BadOptionsNameTheKey) {
  InputError e = input_error([] { choice("bfgs", {"c3=0.1"}); });
  EXPECT_EQ(e.where().key, "c3");
  EXPECT_TRUE(contains(e.what(), "c1")) << e.what();  // the known keys are listed

  e = input_error([] { choice("bfgs", {"c2=high"}); });
  EXPECT_EQ(e.where().key, "c2");

  e = input_error([] { choice("bfgs", {"max_iterations=2.5"}); });
  EXPECT_EQ(e.where().key, "max_iterations");

  e = input_error([] { choice("bfgs", {"c2=1.5"}); });
  EXPECT_EQ(e.where().key, "c2");
  EXPECT_TRUE(contains(e.what(), "must be in (0, 1), got 1.5")) << e.what();

  e = input_error([] { choice("gauss-newton", {"damping=trust-region"}); });
  EXPECT_EQ(e.where().key, "damping");
  EXPECT_TRUE(contains(e.what(), "one of: none, levenberg-marquardt")) << e.what();

  e = input_error([] { choice("nlopt", {"algorithm=LD_FOO"}); });
  EXPECT_EQ(e.where().key, "algorithm");
  EXPECT_TRUE(contains(e.what(), "LD_LBFGS, LD_SLSQP, LD_MMA")) << e.what();
  EXPECT_TRUE(contains(e.what(), "LN_BOBYQA")) << e.what();

  e = input_error([] { choice("ipopt", {"max_evaluations=0"}); });
  EXPECT_EQ(e.where().key, "max_evaluations");

  // Each key passes on its own, the combination fails: the message names both, the key the first.
  e = input_error([] { create(choice("bfgs", {"c1=0.5", "c2=0.4"})); });
  EXPECT_TRUE(contains(e.what(), "c1 = 0.5 must be smaller than c2 = 0.4")) << e.what();
  EXPECT_EQ(e.where().key, "c1");

  // Options that do not match the schema are a programming error, not an input error.
  ComponentChoice wrong = choice("bfgs");
  wrong.options.set("c9", 1.0);
  EXPECT_THROW(create(wrong), std::logic_error);
}

TEST(OptimizerRegistry, OverridesReachTheOptimizer) {
  auto optimizer = create(choice("gauss-newton", {"max_iterations=20", "damping=none",
                                                  "gradient_tolerance=1e-3"}));
  const auto& gn = dynamic_cast<const GaussNewton&>(*optimizer);
  EXPECT_EQ(gn.options().max_iterations, 20);
  EXPECT_EQ(gn.options().damping, GaussNewtonDamping::none);
  EXPECT_EQ(gn.options().gradient_tolerance, 1e-3);
  const Options resolved = optimizer->resolved_options();
  EXPECT_EQ(resolved.get_int("max_iterations"), 20);
  EXPECT_EQ(resolved.get_string("damping"), "none");
}

TEST(OptimizerRegistry, EverySchemaMatchesItsOptionStruct) {
  ASSERT_FALSE(optimizers().entries().empty());
  for (const auto& entry : optimizers().entries()) {
    SCOPED_TRACE(entry.name);
    EXPECT_FALSE(entry.description.empty());
    const Options defaults = default_options(entry.options, nullptr);
    auto optimizer = optimizers().create_with_defaults(entry.name);
    ASSERT_TRUE(optimizer);
    EXPECT_EQ(optimizer->name(), entry.name);
    // The schema's defaults are the struct's defaults, every one valid and documented.
    EXPECT_EQ(optimizer->resolved_options(), defaults);
    std::set<std::string> names;
    for (const auto& spec : entry.options.options()) {
      SCOPED_TRACE(spec.name);
      EXPECT_TRUE(names.insert(spec.name).second) << "duplicate option";
      EXPECT_FALSE(spec.doc.empty());
      EXPECT_EQ(spec.violation(defaults.value(spec.name)), "");
    }
    for (const auto* common : {"gradient_tolerance", "function_tolerance", "step_tolerance",
                               "max_iterations", "max_evaluations"})
      EXPECT_TRUE(names.count(common)) << common;
    // The resolved options round-trip through the factory.
    const ComponentChoice changed = choice(entry.name, {"max_evaluations=77"});
    EXPECT_EQ(create(changed)->resolved_options(), changed.options);
  }
}

TEST(OptimizerRegistry, RangesReadAsConstraints) {
  const OptionSchema& bfgs = optimizers().at("bfgs").options;
  EXPECT_EQ(bfgs.find("c1")->constraint_text(), "in (0, 1)");
  EXPECT_EQ(bfgs.find("gradient_tolerance")->constraint_text(), ">= 0");
  EXPECT_EQ(bfgs.find("max_line_search_evaluations")->constraint_text(), "in [1, 1000]");
  EXPECT_EQ(bfgs.find("c2")->type, OptionType::Double);
  EXPECT_EQ(bfgs.find("max_iterations")->type, OptionType::Int);
  const OptionSchema& gn = optimizers().at("gauss-newton").options;
  EXPECT_EQ(gn.find("damping")->type, OptionType::String);
  EXPECT_EQ(gn.find("damping")->constraint_text(), "one of: none, levenberg-marquardt");
  EXPECT_EQ(gn.find("damping")->default_text(), "levenberg-marquardt");
  const OptionSchema& nlopt = optimizers().at("nlopt").options;
  EXPECT_TRUE(contains(nlopt.find("max_iterations")->doc, "not used")) << "NLopt has no iterations";
}

}  // namespace
}  // namespace twill
