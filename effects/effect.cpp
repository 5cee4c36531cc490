#include "effects/effect.hpp"

#include <stdexcept>

#include "core/input_error.hpp"

namespace twill {

std::string unit_of(const std::string& name) {
  const auto cut = name.rfind('_');
  return cut == std::string::npos ? std::string() : name.substr(cut + 1);
}

std::vector<EffectParameter> effect_parameters(const std::vector<ComponentChoice>& effects, const Registry& registry) {
  const RegistryCategory* category = registry.find_category(registry_category::kEffect);
  std::vector<EffectParameter> out;
  for (const ComponentChoice& effect : effects) {
    if (!category) throw std::logic_error("effect '" + effect.name + "' without a registered effect category");
    for (const OptionSpec& spec : category->at(effect.name).options.options()) {
      if (spec.type != OptionType::Double) continue;
      EffectParameter p;
      p.name = effect.name + "." + spec.name;
      p.unit = unit_of(spec.name);
      p.doc = spec.doc;
      if (spec.min) p.lower = *spec.min;
      if (spec.max) p.upper = *spec.max;
      p.value = effect.options.get_double(spec.name);
      out.push_back(p);
    }
  }
  return out;
}

void set_effect_parameters(const Eigen::VectorXd& values, const Registry& registry,
                           std::vector<ComponentChoice>* effects) {
  const RegistryCategory* category = registry.find_category(registry_category::kEffect);
  Eigen::Index next = 0;
  for (ComponentChoice& effect : *effects) {
    const OptionSchema& schema = category->at(effect.name).options;
    for (const OptionSpec& spec : schema.options()) {
      if (spec.type != OptionType::Double) continue;
      if (next >= values.size()) throw std::invalid_argument("set_effect_parameters: too few values");
      const OptionValue value(values[next++]);
      const std::string violation = spec.violation(value);
      if (!violation.empty())
        throw InputError({"", 0, "effects." + effect.name + "." + spec.name}, violation);
      effect.options.value(spec.name) = value;
    }
  }
  if (next != values.size()) throw std::invalid_argument("set_effect_parameters: too many values");
}

}  // namespace twill
