// Option schemas and validation: every options struct names the violated constraint; options
// given like a config (`--set key=value`) are checked against the schema with InputErrors that
// name the key; the factory rejects unknown names listing the known ones; the schemas'
// defaults are the structs' defaults; registration in the registry works.
#include <gtest/gtest.h>

#include <set>

#include "core/registry.hpp"
#include "optimizers/bfgs.hpp"
#include "optimizers/gauss_newton.hpp"
#include "optimizers/ipopt_optimizer.hpp"
#include "optimizers/nlopt_optimizer.hpp"
#include "optimizers/optimizer_factory.hpp"

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

TEST(OptimizerFactory, UnknownNameListsTheKnownOnes) {
  for (auto body : {std::function<void()>([] { make_optimizer("newton"); }),
                    std::function<void()>([] { optimizer_options("newton"); })}) {
    const InputError e = input_error(body);
    EXPECT_EQ(e.where().key, "optimizer");
    EXPECT_TRUE(
        contains(e.what(), "unknown optimizer 'newton'; known: bfgs, gauss-newton, ipopt, nlopt"))
        << e.what();
  }
}

TEST(OptimizerFactory, BadOptionsNameTheKey) {
  InputError e = input_error([] { optimizer_options("bfgs", {"c3=0.1"}); });
  EXPECT_EQ(e.where().key, "c3");
  EXPECT_TRUE(contains(e.what(), "c1")) << e.what();  // the known keys are listed

  e = input_error([] { optimizer_options("bfgs", {"c2=high"}); });
  EXPECT_EQ(e.where().key, "c2");

  e = input_error([] { optimizer_options("bfgs", {"max_iterations=2.5"}); });
  EXPECT_EQ(e.where().key, "max_iterations");

  e = input_error([] { optimizer_options("bfgs", {"c2=1.5"}); });
  EXPECT_EQ(e.where().key, "c2");
  EXPECT_TRUE(contains(e.what(), "must be in (0, 1), got 1.5")) << e.what();

  e = input_error([] { optimizer_options("gauss-newton", {"damping=trust-region"}); });
  EXPECT_EQ(e.where().key, "damping");
  EXPECT_TRUE(contains(e.what(), "one of: none, levenberg-marquardt")) << e.what();

  e = input_error([] { optimizer_options("nlopt", {"algorithm=LD_FOO"}); });
  EXPECT_EQ(e.where().key, "algorithm");
  EXPECT_TRUE(contains(e.what(), "LD_LBFGS, LD_SLSQP, LD_MMA")) << e.what();
  EXPECT_TRUE(contains(e.what(), "LN_BOBYQA")) << e.what();

  e = input_error([] { optimizer_options("ipopt", {"max_evaluations=0"}); });
  EXPECT_EQ(e.where().key, "max_evaluations");

  // Each key passes on its own, the combination fails: the message names both.
  e = input_error([] { make_optimizer("bfgs", optimizer_options("bfgs", {"c1=0.5", "c2=0.4"})); });
  EXPECT_TRUE(contains(e.what(), "c1 = 0.5 must be smaller than c2 = 0.4")) << e.what();

  // Options that do not match the schema are a programming error, not an input error.
  Options wrong = optimizer_options("bfgs");
  wrong.set("c9", 1.0);
  EXPECT_THROW(make_optimizer("bfgs", wrong), std::logic_error);
}

TEST(OptimizerFactory, OverridesReachTheOptimizer) {
  auto optimizer = make_optimizer(
      "gauss-newton", optimizer_options("gauss-newton", {"max_iterations=20", "damping=none",
                                                         "gradient_tolerance=1e-3"}));
  const auto& gn = dynamic_cast<const GaussNewton&>(*optimizer);
  EXPECT_EQ(gn.options().max_iterations, 20);
  EXPECT_EQ(gn.options().damping, GaussNewtonDamping::none);
  EXPECT_EQ(gn.options().gradient_tolerance, 1e-3);
  const Options resolved = optimizer->resolved_options();
  EXPECT_EQ(resolved.get_int("max_iterations"), 20);
  EXPECT_EQ(resolved.get_string("damping"), "none");
}

TEST(OptimizerCatalogue, SchemasMatchTheOptionStructs) {
  const auto catalogue = optimizer_catalogue();
  ASSERT_EQ(catalogue.size(), 4u);
  for (const auto& info : catalogue) {
    SCOPED_TRACE(info.name);
    EXPECT_FALSE(info.description.empty());
    const Options defaults = default_options(info.options, nullptr);
    auto optimizer = make_optimizer(info.name);
    EXPECT_EQ(optimizer->name(), info.name);
    // The schema's defaults are the struct's defaults, every one valid and documented.
    EXPECT_EQ(optimizer->resolved_options(), defaults);
    std::set<std::string> names;
    for (const auto& spec : info.options.options()) {
      SCOPED_TRACE(spec.name);
      EXPECT_TRUE(names.insert(spec.name).second) << "duplicate option";
      EXPECT_FALSE(spec.doc.empty());
      EXPECT_EQ(spec.violation(defaults.value(spec.name)), "");
    }
    for (const auto* common : {"gradient_tolerance", "function_tolerance", "step_tolerance",
                               "max_iterations", "max_evaluations"})
      EXPECT_TRUE(names.count(common)) << common;
    // The resolved options round-trip through the factory.
    const Options changed = optimizer_options(info.name, {"max_evaluations=77"});
    EXPECT_EQ(make_optimizer(info.name, changed)->resolved_options(), changed);
  }
}

TEST(OptimizerCatalogue, RangesReadAsConstraints) {
  const OptionSchema bfgs = optimizer_catalogue()[0].options;
  EXPECT_EQ(bfgs.find("c1")->constraint_text(), "in (0, 1)");
  EXPECT_EQ(bfgs.find("gradient_tolerance")->constraint_text(), ">= 0");
  EXPECT_EQ(bfgs.find("max_line_search_evaluations")->constraint_text(), "in [1, 1000]");
  EXPECT_EQ(bfgs.find("c2")->type, OptionType::Double);
  EXPECT_EQ(bfgs.find("max_iterations")->type, OptionType::Int);
  const OptionSchema gn = optimizer_catalogue()[1].options;
  EXPECT_EQ(gn.find("damping")->type, OptionType::String);
  EXPECT_EQ(gn.find("damping")->constraint_text(), "one of: none, levenberg-marquardt");
  EXPECT_EQ(gn.find("damping")->default_text(), "levenberg-marquardt");
  const OptionSchema nlopt = optimizer_catalogue()[3].options;
  EXPECT_TRUE(contains(nlopt.find("max_iterations")->doc, "not used")) << "NLopt has no iterations";
}

TEST(OptimizerRegistration, EveryOptimizerIsCreatedThroughTheRegistry) {
  Registry registry;
  register_optimizers(registry);
  auto& category = registry.category<OptimizerFactories>(registry_category::kOptimizer);
  EXPECT_EQ(category.known_names(), "bfgs, gauss-newton, ipopt, nlopt");
  for (const auto& name : optimizer_names()) {
    auto optimizer = category.create_with_defaults(name);
    ASSERT_TRUE(optimizer);
    EXPECT_EQ(optimizer->name(), name);
  }
  const InputError e = input_error([&] { category.create_with_defaults("newton"); });
  EXPECT_TRUE(contains(e.what(), "bfgs, gauss-newton, ipopt, nlopt")) << e.what();
}

}  // namespace
}  // namespace twill
