// The option-binding mechanism (core/option_binding.hpp): a typed options struct declared once
// gives its schema (defaults from the struct), its validation (ranges from the same
// declarations, cross-field rules in validate()), the struct from resolved options, and a
// registry entry (FactoryCategory::add_bound) whose schema and factory cannot disagree.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include "core/option_binding.hpp"
#include "core/registry.hpp"

namespace twill {
namespace {

enum class Shape { Round, Square };

struct ToyOptions {
  double strength = 0.1;
  int samples = 4;
  std::uint64_t seed = 7;
  bool verbose = false;
  Shape shape = Shape::Square;
  std::string mode = "fast";
  double limit = 1.0;

  bool validate(std::string* error) const;
};

OptionBindings<ToyOptions> toy_bindings() {
  return {
      real_option<ToyOptions>("strength", &ToyOptions::strength, "sag per unit load", at_least(0.0)),
      integer_option<ToyOptions>("samples", &ToyOptions::samples, "samples per cell", in_range(1, 16)),
      integer_option<ToyOptions>("seed", &ToyOptions::seed, "random seed"),
      bool_option<ToyOptions>("verbose", &ToyOptions::verbose, "print progress"),
      enum_option<ToyOptions>("shape", &ToyOptions::shape, {{"round", Shape::Round}, {"square", Shape::Square}},
                              "cell shape"),
      choice_option<ToyOptions>("mode", &ToyOptions::mode, {"fast", "exact"}, "evaluation mode"),
      real_option<ToyOptions>("limit", &ToyOptions::limit, "upper limit (>= strength)", greater_than(0.0)),
  };
}

bool ToyOptions::validate(std::string* error) const {
  if (!check_options(toy_bindings(), *this, error)) return false;
  if (!(strength <= limit)) {
    if (error) *error = "strength = " + std::to_string(strength) + " must not exceed limit";
    return false;
  }
  return true;
}

struct Toy {
  virtual ~Toy() = default;
};
struct BoundToy final : Toy {
  ToyOptions options;
  int tag;
  BoundToy(int t, ToyOptions o) : options(std::move(o)), tag(t) { require_valid(options, "toy"); }
};
using ToyFactories = FactoryCategory<Toy, int>;

TEST(OptionBinding, SchemaTakesTypesDefaultsAndRangesFromTheDeclarations) {
  const OptionSchema schema = option_schema(toy_bindings());
  ASSERT_EQ(schema.options().size(), 7u);
  EXPECT_EQ(schema.find("strength")->type, OptionType::Double);
  EXPECT_EQ(schema.find("strength")->default_text(), "0.1");
  EXPECT_EQ(schema.find("strength")->constraint_text(), ">= 0");
  EXPECT_EQ(schema.find("samples")->constraint_text(), "in [1, 16]");
  EXPECT_EQ(schema.find("seed")->constraint_text(), ">= 0");  // unsigned
  EXPECT_EQ(schema.find("verbose")->type, OptionType::Bool);
  EXPECT_EQ(schema.find("shape")->default_text(), "square");
  EXPECT_EQ(schema.find("shape")->constraint_text(), "one of: round, square");
  EXPECT_EQ(schema.find("mode")->doc, "evaluation mode");
  // The resolved defaults are the struct's, and read back into an equal struct.
  const Options defaults = default_options(schema, nullptr);
  EXPECT_EQ(options_of(toy_bindings(), ToyOptions{}), defaults);
  const ToyOptions read = options_from(toy_bindings(), defaults, "toy");
  EXPECT_EQ(read.seed, 7u);
  EXPECT_EQ(read.shape, Shape::Square);
}

TEST(OptionBinding, ValidationUsesTheSameRangesAndNamesTheField) {
  std::string error;
  EXPECT_TRUE(ToyOptions{}.validate(&error)) << error;
  ToyOptions o;
  o.samples = 17;
  EXPECT_FALSE(o.validate(&error));
  EXPECT_EQ(error, "samples must be in [1, 16], got 17");
  o = {};
  o.strength = 2.0;  // each field in range, the pair is not
  EXPECT_FALSE(o.validate(&error));
  try {
    require_valid(o, "toy");
    FAIL() << "invalid options accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "strength");
    EXPECT_NE(std::string(e.what()).find("toy: strength = 2.000000 must not exceed limit"), std::string::npos)
        << e.what();
  }
  o = {};
  o.limit = std::nan("");
  EXPECT_FALSE(o.validate(&error));
  EXPECT_EQ(error.rfind("limit must be finite", 0), 0u) << error;
}

TEST(OptionBinding, RegisteredFromTheBindingsConfigAndStructAgree) {
  Registry registry;
  auto& category = registry.category<ToyFactories>("toy");
  category.add_bound<BoundToy>("bound-toy", "a toy registered from its bindings", toy_bindings());
  const OptionSchema& schema = category.at("bound-toy").options;
  EXPECT_EQ(schema.options().size(), 7u);

  Options o = default_options(schema, nullptr);
  apply_overrides(o, schema, nullptr, {"samples=9", "shape=round", "seed=42", "verbose=true"});
  const auto toy = category.create("bound-toy", o, 5);
  const auto& bound = dynamic_cast<const BoundToy&>(*toy);
  EXPECT_EQ(bound.tag, 5);
  EXPECT_EQ(bound.options.samples, 9);
  EXPECT_EQ(bound.options.shape, Shape::Round);
  EXPECT_EQ(bound.options.seed, 42u);
  EXPECT_TRUE(bound.options.verbose);
  EXPECT_EQ(options_of(toy_bindings(), bound.options), o);

  // A config out of range is rejected by the schema, with the binding's constraint.
  EXPECT_THROW(apply_override(o, schema, nullptr, "samples=0"), InputError);
  // A cross-field violation passes the schema and is rejected when the struct is built.
  apply_overrides(o, schema, nullptr, {"strength=3", "limit=2"});
  EXPECT_THROW(category.create("bound-toy", o, 0), InputError);
  // Options that do not match the schema are a programming error.
  Options wrong = default_options(schema, nullptr);
  wrong.set("extra", 1.0);
  EXPECT_THROW(category.create("bound-toy", wrong, 0), std::logic_error);
}

}  // namespace
}  // namespace twill
