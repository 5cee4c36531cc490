// Option schemas and validation: every options struct names the violated constraint; the
// factory rejects unknown names, unknown keys, wrong types and out-of-range values with an
// InputError naming the key and listing what is known; the catalogue is consistent with the
// structs' defaults.
#include <gtest/gtest.h>

#include <set>

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

  BfgsOptions bfgs;
  bfgs.c1 = 0.5;
  bfgs.c2 = 0.4;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_TRUE(contains(error, "c1 = 0.5 must be smaller than c2 = 0.4")) << error;
  bfgs = {};
  bfgs.c2 = 1.0;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_TRUE(contains(error, "c2 = 1 is outside (0, 1)")) << error;
  bfgs = {};
  bfgs.gradient_tolerance = -1e-3;
  EXPECT_FALSE(bfgs.validate(&error));
  EXPECT_TRUE(contains(error, "gradient_tolerance = -0.001 is outside [0, inf)")) << error;
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
  EXPECT_TRUE(contains(error, "mu_strategy = 'probing-ish' is not one of {monotone, adaptive}"))
      << error;

  NloptOptions nlopt;
  nlopt.algorithm = "LD_NEWTON";
  EXPECT_FALSE(nlopt.validate(&error));
  EXPECT_TRUE(contains(error, "LD_NEWTON")) << error;
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
  const InputError e = input_error([] { make_optimizer("newton"); });
  EXPECT_EQ(e.where().key, "optimizer");
  EXPECT_TRUE(
      contains(e.what(), "unknown optimizer 'newton'; known: bfgs, gauss-newton, ipopt, nlopt"))
      << e.what();
}

TEST(OptimizerFactory, BadOptionsNameTheKey) {
  InputError e = input_error([] { make_optimizer("bfgs", {{"c3", 0.1}}); });
  EXPECT_EQ(e.where().key, "c3");
  EXPECT_TRUE(contains(e.what(), "unknown option 'c3'; known options: gradient_tolerance"))
      << e.what();
  EXPECT_TRUE(contains(e.what(), "c1, c2")) << e.what();

  e = input_error([] { make_optimizer("bfgs", {{"c2", std::string("high")}}); });
  EXPECT_EQ(e.where().key, "c2");
  EXPECT_TRUE(contains(e.what(), "c2 = 'high' is not of type real")) << e.what();

  e = input_error([] { make_optimizer("bfgs", {{"max_iterations", 2.5}}); });
  EXPECT_EQ(e.where().key, "max_iterations");
  EXPECT_TRUE(contains(e.what(), "is not of type integer")) << e.what();

  e = input_error([] {
    make_optimizer("gauss-newton", {{"damping", std::string("trust-region")}});
  });
  EXPECT_EQ(e.where().key, "damping");
  EXPECT_TRUE(contains(e.what(), "{none, levenberg-marquardt}")) << e.what();

  e = input_error([] { make_optimizer("nlopt", {{"algorithm", std::string("LD_FOO")}}); });
  EXPECT_EQ(e.where().key, "algorithm");
  EXPECT_TRUE(contains(e.what(), "LD_LBFGS, LD_SLSQP, LD_MMA")) << e.what();
  EXPECT_TRUE(contains(e.what(), "LN_BOBYQA")) << e.what();

  e = input_error([] { make_optimizer("ipopt", {{"max_evaluations", 0}}); });
  EXPECT_EQ(e.where().key, "max_evaluations");
  EXPECT_TRUE(contains(e.what(), "max_evaluations = 0 is outside [1, 2147483647]")) << e.what();

  // Each key passes on its own, the combination fails: the message names both.
  e = input_error([] { make_optimizer("bfgs", {{"c1", 0.5}, {"c2", 0.4}}); });
  EXPECT_TRUE(contains(e.what(), "c1 = 0.5 must be smaller than c2 = 0.4")) << e.what();
}

TEST(OptimizerFactory, AcceptsIntegralRealsAndIntsForReals) {
  auto optimizer = make_optimizer("bfgs", {{"max_iterations", 20.0}, {"gradient_tolerance", 0}});
  const OptionValues resolved = optimizer->resolved_options();
  EXPECT_EQ(std::get<int>(resolved.at("max_iterations")), 20);
  EXPECT_EQ(std::get<double>(resolved.at("gradient_tolerance")), 0.0);
}

TEST(OptimizerCatalogue, DescriptionsMatchTheOptionStructs) {
  const auto catalogue = optimizer_catalogue();
  ASSERT_EQ(catalogue.size(), 4u);
  for (const auto& info : catalogue) {
    SCOPED_TRACE(info.name);
    EXPECT_FALSE(info.description.empty());
    auto optimizer = make_optimizer(info.name);
    EXPECT_EQ(optimizer->name(), info.name);
    const OptionValues resolved = optimizer->resolved_options();
    EXPECT_EQ(resolved.size(), info.options.size());
    std::set<std::string> names;
    for (const auto& d : info.options) {
      SCOPED_TRACE(d.name);
      EXPECT_TRUE(names.insert(d.name).second) << "duplicate option";
      EXPECT_FALSE(d.doc.empty());
      EXPECT_EQ(d.check(d.default_value), "");  // every default is valid
      ASSERT_TRUE(resolved.count(d.name));
      EXPECT_EQ(resolved.at(d.name), d.default_value);  // defaults come from the struct
    }
    for (const auto* common : {"gradient_tolerance", "function_tolerance", "step_tolerance",
                               "max_iterations", "max_evaluations"})
      EXPECT_TRUE(names.count(common)) << common;
    // The resolved options round-trip through the factory.
    EXPECT_EQ(make_optimizer(info.name, resolved)->resolved_options(), resolved);
  }
}

TEST(OptimizerCatalogue, RangesReadAsIntervals) {
  const auto bfgs = optimizer_catalogue()[0].options;
  auto find = [&](const std::string& name) {
    for (const auto& d : bfgs)
      if (d.name == name) return d;
    ADD_FAILURE() << name;
    return OptionDescription{};
  };
  EXPECT_EQ(find("c1").range(), "(0, 1)");
  EXPECT_EQ(find("gradient_tolerance").range(), "[0, inf)");
  EXPECT_EQ(find("max_line_search_evaluations").range(), "[1, 1000]");
  EXPECT_EQ(find("c2").type, OptionType::real);
  EXPECT_EQ(to_string(find("max_iterations").type), "integer");
  const auto gn = optimizer_catalogue()[1].options;
  for (const auto& d : gn)
    if (d.name == "damping") {
      EXPECT_EQ(d.type, OptionType::choice);
      EXPECT_EQ(d.range(), "{none, levenberg-marquardt}");
      EXPECT_EQ(std::get<std::string>(d.default_value), "levenberg-marquardt");
    }
}

}  // namespace
}  // namespace twill
