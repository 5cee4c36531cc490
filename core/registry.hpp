#pragma once
// One registry through which every selectable implementation is created by name:
// discretizations, optimizers, experiments and effects (style.md practice 3).
//
// Each registered implementation has a name, a one-line description, an option schema
// (config.hpp: types, defaults, ranges, docs) and a factory. Asking for an unknown name is an
// InputError that lists the known names. `twill list` prints the whole registry.
//
// No globals, no static-initialisation tricks: the program builds one Registry and calls plain
// registration functions, one per module, so what is registered is visible in one place
// (app/program_registry.cpp).
//
// ---- How to register your implementation --------------------------------------------------
//
// 1. The module that defines an interface (a category's base class) also names the factory
//    signature of its category, next to the base class, e.g. in core/discretization.hpp's
//    module or in optimizers/optimizer.hpp:
//
//        // Factory: (resolved options, strip to mesh) -> a discretization of that strip.
//        using DiscretizationFactories = FactoryCategory<Discretization, const StripSpec&>;
//        using OptimizerFactories = FactoryCategory<Optimizer>;   // options only
//
//    Every factory of the category receives `const Options&` (already validated against the
//    implementation's schema, defaults filled in) followed by the Args... of the alias.
//
// 2. The implementation declares its options once, as a typed struct and its bindings
//    (core/option_binding.hpp: name, type, default from the struct, range or choices, doc),
//    and its module provides one function (declared in its header) that registers it:
//
//        OptionBindings<CatmullClarkKLOptions> catmull_clark_kl_option_bindings() {
//          return {integer_option<CatmullClarkKLOptions>("thickness_points",
//                      &CatmullClarkKLOptions::thickness_points, "Gauss points through τ", in_range(2, 64)),
//                  …};
//        }
//        void register_catmull_clark_kl(Registry& registry) {
//          registry.category<DiscretizationFactories>(registry_category::kDiscretization)
//              .add_bound<CatmullClarkKL>("catmull-clark-kl", "Kirchhoff–Love shell on Catmull–Clark limit surfaces",
//                                         catmull_clark_kl_option_bindings());
//        }
//
//    add_bound builds the schema from the bindings and a factory that calls
//    CatmullClarkKL(strip, parameters, options_from(bindings, resolved)). A factory may also
//    be written by hand with add(name, description, schema, factory).
//
// 3. The lead adds `register_catmull_clark_kl(registry);` in app/program_registry.cpp, which
//    the program and the registry-driven tests share (tests/discretizations/
//    test_every_discretization.cpp then checks the new part's derivatives without new code).
//
// 4. Users create instances from a config's component choice (config.hpp), or by name:
//
//        auto disc = registry.create<DiscretizationFactories>(registry_category::kDiscretization,
//                                                             config.get_component("discretization"), strip);
//        auto bfgs = registry.category<OptimizerFactories>(registry_category::kOptimizer)
//                        .create_with_defaults("bfgs");
//
// The typed view of a category is checked: asking for a category with a different factory
// signature than it was registered with throws std::logic_error (a programming error).
// Registering a name twice, an empty name, or a description that is empty or spans several
// lines also throws std::logic_error.
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/input_error.hpp"
#include "core/option_binding.hpp"

namespace twill {

/// The categories twill knows (listed by `twill list` even when nothing is registered).
namespace registry_category {
inline constexpr const char* kDiscretization = "discretization";
inline constexpr const char* kOptimizer = "optimizer";
inline constexpr const char* kExperiment = "experiment";
inline constexpr const char* kEffect = "effect";
inline constexpr const char* kStage = "stage";  ///< a kind of fit stage (fitting/fit_stage.hpp)
}  // namespace registry_category

/// What the registry knows about one implementation, independent of its factory type.
struct RegistryEntry {
  std::string name;
  std::string description;  ///< one line
  OptionSchema options;
};

/// The untyped view of a category: names, descriptions, schemas (for listing and configs).
class RegistryCategory {
 public:
  explicit RegistryCategory(std::string name) : name_(std::move(name)) {}
  virtual ~RegistryCategory() = default;
  RegistryCategory(const RegistryCategory&) = delete;
  RegistryCategory& operator=(const RegistryCategory&) = delete;

  const std::string& name() const { return name_; }
  /// In registration order.
  const std::vector<RegistryEntry>& entries() const { return entries_; }
  const RegistryEntry* find(const std::string& name) const;
  /// The entry, or InputError "unknown <category> '<name>' (known: a, b)".
  const RegistryEntry& at(const std::string& name) const;
  /// "a, b, c", or "none registered".
  std::string known_names() const;

 protected:
  /// Adds an entry; returns its index. Throws std::logic_error on a duplicate or malformed entry.
  std::size_t add_entry(RegistryEntry entry);

 private:
  std::string name_;
  std::vector<RegistryEntry> entries_;
};

/// A category whose implementations derive from Base and are built from (options, args...).
template <class Base, class... Args>
class FactoryCategory final : public RegistryCategory {
 public:
  using Product = Base;
  using Factory = std::function<std::unique_ptr<Base>(const Options&, Args...)>;

  using RegistryCategory::RegistryCategory;

  /// Registers an implementation. `description` is one line; `options` its schema.
  FactoryCategory& add(std::string name, std::string description, OptionSchema options, Factory factory) {
    if (!factory) throw std::logic_error("registry: '" + name + "' registered without a factory");
    add_entry(RegistryEntry{std::move(name), std::move(description), std::move(options)});
    factories_.push_back(std::move(factory));
    return *this;
  }

  /// Registers `Product`, whose options are the typed struct `Struct` declared by `bindings`
  /// (option_binding.hpp): the schema comes from the bindings, and the factory builds
  /// Product(args..., options_from(bindings, options)), so schema and validation agree.
  template <class Product, class Struct>
  FactoryCategory& add_bound(std::string name, std::string description, OptionBindings<Struct> bindings) {
    OptionSchema schema = option_schema(bindings);
    Factory factory = [bindings = std::move(bindings), owner = name](const Options& options,
                                                                     Args... args) -> std::unique_ptr<Base> {
      return std::make_unique<Product>(std::forward<Args>(args)..., options_from(bindings, options, owner));
    };
    return add(std::move(name), std::move(description), std::move(schema), std::move(factory));
  }

  /// Creates `name` with resolved `options` (from a config, or default_options()).
  std::unique_ptr<Base> create(const std::string& name, const Options& options, Args... args) const {
    const RegistryEntry& entry = at(name);  // InputError listing the known names
    check_resolved_options(entry.options, options, this->name() + " '" + name + "'");
    const std::size_t index = static_cast<std::size_t>(&entry - entries().data());
    return factories_[index](options, std::forward<Args>(args)...);
  }
  /// Creates the implementation a config chose.
  std::unique_ptr<Base> create(const ComponentChoice& choice, Args... args) const {
    return create(choice.name, choice.options, std::forward<Args>(args)...);
  }
  /// Creates `name` with every option at its default.
  std::unique_ptr<Base> create_with_defaults(const std::string& name, Args... args) const {
    return create(name, default_options(at(name).options, nullptr), std::forward<Args>(args)...);
  }

 private:
  std::vector<Factory> factories_;  // parallel to entries()
};

class Registry {
 public:
  Registry() = default;
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;
  Registry(Registry&&) = default;
  Registry& operator=(Registry&&) = default;

  /// The typed category `name`, created on first use. Category is a FactoryCategory<...>.
  template <class Category>
  Category& category(const std::string& name) {
    auto it = categories_.find(name);
    if (it == categories_.end()) {
      auto created = std::make_unique<Category>(name);
      Category& ref = *created;
      categories_.emplace(name, std::move(created));
      if (!is_standard(name)) extra_order_.push_back(name);
      return ref;
    }
    return checked_cast<Category>(*it->second);
  }

  /// Creates an implementation chosen in a config (the choice's category must be `name`).
  template <class Category, class... CallArgs>
  std::unique_ptr<typename Category::Product> create(const std::string& name, const ComponentChoice& choice,
                                                     CallArgs&&... args) const {
    const RegistryCategory* found = find_category(name);
    if (!found) throw InputError({}, "unknown " + name + " '" + choice.name + "' (known: none registered)");
    return checked_cast<const Category>(*found).create(choice, std::forward<CallArgs>(args)...);
  }

  /// A choice of `name` in `category` at its defaults with `--set`-style overrides applied
  /// ("c2=0.5", "algorithm=LN_BOBYQA"), checked like a config file: an unknown name lists the
  /// known ones; an unknown key, a wrong type or an out-of-range value names the key
  /// (config.hpp's apply_override). Pass it to create().
  ComponentChoice choice(const std::string& category, const std::string& name,
                         const std::vector<std::string>& overrides = {}) const;

  /// The untyped category, or nullptr when nothing was registered under that name.
  const RegistryCategory* find_category(const std::string& name) const;
  /// The standard categories (always, in the order discretization, optimizer, experiment,
  /// effect) and then any other category in creation order.
  std::vector<std::string> category_names() const;

 private:
  static bool is_standard(const std::string& name);

  template <class Category, class Stored>
  static Category& checked_cast(Stored& stored) {
    auto* typed = dynamic_cast<Category*>(&stored);
    if (!typed)
      throw std::logic_error("registry: category '" + stored.name() +
                             "' is used with a different factory signature than it was registered with");
    return *typed;
  }

  std::map<std::string, std::unique_ptr<RegistryCategory>> categories_;
  std::vector<std::string> extra_order_;
};

}  // namespace twill
