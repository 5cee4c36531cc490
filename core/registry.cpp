#include "core/registry.hpp"

#include <array>

namespace twill {
namespace {

constexpr std::array<const char*, 4> kStandardCategories = {
    registry_category::kDiscretization, registry_category::kOptimizer, registry_category::kExperiment,
    registry_category::kEffect};

}  // namespace

const RegistryEntry* RegistryCategory::find(const std::string& name) const {
  for (const auto& e : entries_)
    if (e.name == name) return &e;
  return nullptr;
}

const RegistryEntry& RegistryCategory::at(const std::string& name) const {
  if (const RegistryEntry* e = find(name)) return *e;
  throw InputError({}, "unknown " + name_ + " '" + name + "' (known: " + known_names() + ")");
}

std::string RegistryCategory::known_names() const {
  std::string out;
  for (const auto& e : entries_) out += (out.empty() ? "" : ", ") + e.name;
  return out.empty() ? "none registered" : out;
}

std::size_t RegistryCategory::add_entry(RegistryEntry entry) {
  if (entry.name.empty() || entry.name.find_first_of(" \t\n") != std::string::npos)
    throw std::logic_error("registry: " + name_ + " name '" + entry.name + "' must be non-empty without spaces");
  if (find(entry.name)) throw std::logic_error("registry: " + name_ + " '" + entry.name + "' is registered twice");
  if (entry.description.empty() || entry.description.find('\n') != std::string::npos)
    throw std::logic_error("registry: " + name_ + " '" + entry.name + "' needs a one-line description");
  // A config selects an implementation with `name:` next to its options (config.hpp).
  if (entry.options.find("name"))
    throw std::logic_error("registry: " + name_ + " '" + entry.name + "' may not have an option called 'name'");
  entries_.push_back(std::move(entry));
  return entries_.size() - 1;
}

const RegistryCategory* Registry::find_category(const std::string& name) const {
  auto it = categories_.find(name);
  return it == categories_.end() ? nullptr : it->second.get();
}

ComponentChoice Registry::choice(const std::string& category, const std::string& name,
                                 const std::vector<std::string>& overrides) const {
  const RegistryCategory* found = find_category(category);
  if (!found) throw InputError({}, "unknown " + category + " '" + name + "' (known: none registered)");
  const OptionSchema& schema = found->at(name).options;
  ComponentChoice out{category, name, default_options(schema, this)};
  apply_overrides(out.options, schema, this, overrides);
  return out;
}

std::vector<std::string> Registry::category_names() const {
  std::vector<std::string> out(kStandardCategories.begin(), kStandardCategories.end());
  out.insert(out.end(), extra_order_.begin(), extra_order_.end());
  return out;
}

bool Registry::is_standard(const std::string& name) {
  for (const char* c : kStandardCategories)
    if (name == c) return true;
  return false;
}

}  // namespace twill
