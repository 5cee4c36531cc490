#pragma once
// Effects with parameters away from their neutral defaults, for the registry-driven effect
// tests (tests/effects): every hook of the effect then acts.
#include <algorithm>
#include <string>

#include "effects/effect.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill::testing {

/// The registered effect with each double option at default + 2 % of its range (inside the
/// bounds for every registered effect).
inline ComponentChoice acting(const std::string& effect) {
  ComponentChoice choice = default_choice(registry_category::kEffect, effect);
  for (const EffectParameter& p : effect_parameters({choice}, registry())) {
    const std::string option = p.name.substr(effect.size() + 1);
    choice.options.set(option, std::min(p.upper, p.value + 0.02 * (p.upper - p.lower)));
  }
  return choice;
}

}  // namespace twill::testing
