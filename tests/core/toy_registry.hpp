#pragma once
// Placeholder implementations registered the way real modules do (registry.hpp), for the
// registry and config tests only: the app registers real modules, never these.
#include <memory>
#include <string>

#include "core/registry.hpp"

namespace twill::toy {

/// A toy "optimiser" interface; the factory takes (options, an int tag).
struct Minimizer {
  virtual ~Minimizer() = default;
  virtual std::string summary() const = 0;
};
using MinimizerFactories = FactoryCategory<Minimizer, int>;

struct GradientDescent final : Minimizer {
  std::int64_t max_iterations;
  double step;
  std::string line_search;
  int tag;
  GradientDescent(const Options& o, int t)
      : max_iterations(o.get_int("max_iterations")),
        step(o.get_double("step")),
        line_search(o.get_string("line_search")),
        tag(t) {}
  std::string summary() const override {
    return "gd " + std::to_string(max_iterations) + " " + line_search + " " + std::to_string(tag);
  }
};

struct Newton final : Minimizer {
  double damping;
  std::string summary() const override { return "newton"; }
  explicit Newton(const Options& o) : damping(o.get_double("damping")) {}
};

/// A toy "effect" with a list option.
struct Effect {
  virtual ~Effect() = default;
};
using EffectFactories = FactoryCategory<Effect>;
struct Sag final : Effect {};

inline void register_toy_minimizers(Registry& registry) {
  OptionSchema gd;
  gd.add_int("max_iterations", 100, "iteration limit").at_least(1);
  gd.add_double("step", 0.1, "initial step length").greater_than(0).at_most(10);
  gd.add_string("line_search", "wolfe", "line-search policy").choices({"armijo", "wolfe"});
  gd.add_bool("verbose", false, "print every iteration");
  OptionSchema newton;
  newton.add_double("damping", 0.0, "Levenberg damping added to the Hessian").at_least(0);
  newton.add_double_list("weights", {1.0, 2.0}, "per-residual weights").greater_than(0).non_empty();
  registry.category<MinimizerFactories>(registry_category::kOptimizer)
      .add("toy-gd", "gradient descent (test placeholder)", std::move(gd),
           [](const Options& o, int tag) -> std::unique_ptr<Minimizer> {
             return std::make_unique<GradientDescent>(o, tag);
           })
      .add("toy-newton", "damped Newton (test placeholder)", std::move(newton),
           [](const Options& o, int) -> std::unique_ptr<Minimizer> { return std::make_unique<Newton>(o); });
}

inline void register_toy_effects(Registry& registry) {
  OptionSchema sag;
  sag.add_double("strength", 0.5, "how strong").range(0, 1);
  registry.category<EffectFactories>(registry_category::kEffect)
      .add("sag", "sagging under gravity (test placeholder)", std::move(sag),
           [](const Options&) -> std::unique_ptr<Effect> { return std::make_unique<Sag>(); })
      .add("thermal", "thermal expansion (test placeholder)", OptionSchema{},
           [](const Options&) -> std::unique_ptr<Effect> { return std::make_unique<Sag>(); });
}

}  // namespace twill::toy
