#pragma once
// The material parameters the tests share: a canvas-like fabric at physical sizes.
#include <optional>

#include "core/parameters.hpp"

namespace twill::testing {

/// τ = 0.45 mm, a11 = 3e7, a22 = 2.2e7, a12 = 1.1e7, G12 = 4e5 Pa, ρ_A = 0.294 kg/m²,
/// linear curves (orthotropic StVK), cutoffs off.
inline MaterialParameters canvas_stvk() {
  MaterialParameters p;
  p.density_kg_m2 = 0.294;
  p.thickness_m = 0.45e-3;
  p.a11_Pa = 3e7;
  p.a22_Pa = 2.2e7;
  p.a12_Pa = 1.1e7;
  p.G12_Pa = 4e5;
  p.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  return p;
}

/// canvas_stvk() with degree-2 curves (a negative μ, exponents on both sides of 1); cutoffs
/// still off, so the law is smooth everywhere.
inline MaterialParameters canvas_degree2() {
  MaterialParameters p = canvas_stvk();
  p.eta1 = Curve{{0.6, 0.4}, {2.5, 6.0}};
  p.eta3 = Curve{{1.3, -0.3}, {3.0, 0.5}};
  p.eta4 = Curve{{0.5, 0.5}, {4.0, 1.5}};
  return p;
}

}  // namespace twill::testing
