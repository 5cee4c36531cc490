#include "effects/effect.hpp"

#include <stdexcept>

#include "core/input_error.hpp"

namespace twill {

namespace {

// Units of more than one word, as a name's suffix spells them and as reports print them.
const std::vector<std::pair<std::string, std::string>> kCompoundUnits = {{"_N_m", "N/m"}, {"_mm_min", "mm/min"}};
// Suffixes of dimensionless parameters.
const std::vector<std::string> kDimensionless = {"_ratio", "_strain"};

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() > suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

std::string unit_of(const std::string& name) {
  for (const auto& [suffix, unit] : kCompoundUnits)
    if (ends_with(name, suffix)) return unit;
  for (const std::string& suffix : kDimensionless)
    if (ends_with(name, suffix)) return "1";
  const auto cut = name.rfind('_');
  return cut == std::string::npos ? std::string() : name.substr(cut + 1);
}

int effect_flat_index(const MaterialParameters& k, const std::string& effect, const std::string& option) {
  return k.index_of(effect + "." + option);
}

ObservableChange ObservableChange::zero(Eigen::Index m, Eigen::Index n) {
  return {Eigen::VectorXd::Zero(m), Eigen::MatrixXd::Zero(m, n), Eigen::VectorXd::Zero(m)};
}

MaterialParameters Effect::adjusted_material(const MaterialParameters& k, Eigen::MatrixXd* jacobian) const {
  if (jacobian) *jacobian = Eigen::MatrixXd::Identity(k.flat_size(), k.flat_size());
  return k;
}

ObservableChange Effect::observable_change(const RunConditions& run, const MaterialParameters& k) const {
  return ObservableChange::zero(static_cast<Eigen::Index>(run.schedule.size()), k.flat_size());
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
