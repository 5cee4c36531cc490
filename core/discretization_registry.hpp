#pragma once
// The registry category of discretisations (core/registry.hpp): a factory receives its
// resolved options, the strip to mesh and the material.
#include "core/discretization.hpp"
#include "core/registry.hpp"

namespace twill {

using DiscretizationFactories = FactoryCategory<Discretization, const StripSpec&, const MaterialParameters&>;

}  // namespace twill
