#pragma once
// The program's registry (app/program_registry.cpp: everything `twill` registers), for tests
// that run every registered implementation instead of a literal list of names: a part
// registered there is covered by them the day it is added.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "app/program_registry.hpp"
#include "core/registry.hpp"

namespace twill::testing {

/// Built once per test process.
inline const Registry& program_registry() {
  static const Registry registry = [] {
    Registry r;
    register_program(r);
    return r;
  }();
  return registry;
}

/// The registered names of `category`, in registration order (empty when none).
inline std::vector<std::string> registered_names(const std::string& category) {
  std::vector<std::string> names;
  if (const RegistryCategory* found = program_registry().find_category(category))
    for (const auto& entry : found->entries()) names.push_back(entry.name);
  return names;
}

/// `name` of `category` created through the registry at its defaults with `--set`-style
/// `overrides` ("c2=0.5"), followed by the category's factory arguments.
template <class Category, class... Args>
std::unique_ptr<typename Category::Product> create_registered(const std::string& category,
                                                              const std::string& name,
                                                              const std::vector<std::string>& overrides,
                                                              Args&&... args) {
  const Registry& registry = program_registry();
  return registry.create<Category>(category, registry.choice(category, name, overrides),
                                   std::forward<Args>(args)...);
}

}  // namespace twill::testing
