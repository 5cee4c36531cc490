#pragma once
// How experiments obtain meshes: a factory that builds a discretisation of a strip. The
// registry (core/registry.hpp) provides one per registered discretisation name and options;
// experiments depend only on this signature, never on a concrete discretisation.
#include <functional>
#include <memory>

#include "core/discretization.hpp"

namespace twill {

using DiscretizationFactory = std::function<std::unique_ptr<Discretization>(
    const StripSpec& strip, const MaterialParameters& parameters)>;

}  // namespace twill
