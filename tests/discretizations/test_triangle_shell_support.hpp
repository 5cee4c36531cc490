#pragma once
// Shared set-up of the triangle-shell tests: the physical sizes and stiffnesses of the brief
// (a 75 mm × 50 mm strip of a canvas-like fabric) and geometric helpers.
#include <Eigen/Geometry>
#include <cmath>

#include "core/parameters.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"
#include "tests/support/test_materials.hpp"

namespace twill::triangle_shell_test {

/// L = 75 mm, W = 50 mm, material angle 90° (warp d1 = −x, weft d2 = +y).
inline StripSpec strip(int cells_across, int cells_along, double angle_deg = 90.0) {
  StripSpec s;
  s.length_m = 0.075;
  s.width_m = 0.050;
  s.cells_across = cells_across;
  s.cells_along = cells_along;
  s.angle_deg = angle_deg;
  return s;
}

/// The D1388 strip near the clamp at the cantilever's resolution (25 mm × 30 mm, 8 × 28 cells,
/// warp along x): where the alternating mesh's checkerboard mode is studied (docs §10).
inline StripSpec checkerboard_strip() {
  StripSpec s;
  s.length_m = 0.030;
  s.width_m = 0.025;
  s.cells_across = 8;
  s.cells_along = 28;
  s.angle_deg = 90;
  return s;
}

/// τ = 0.45 mm, a11 = 3e7, a22 = 2.2e7, a12 = 1.1e7, G12 = 4e5 Pa, ρ_A = 0.294 kg/m²,
/// linear curves (orthotropic StVK), cutoffs off.
inline MaterialParameters physical_parameters() { return testing::canvas_stvk(); }

/// Degree-2 curves (a negative μ, exponents on both sides of 1) on top of the physical
/// stiffnesses; the caller sets the cutoffs.
inline MaterialParameters nonlinear_parameters() {
  MaterialParameters p = physical_parameters();
  p.eta1 = Curve{{1.3, -0.3}, {2.0, 9.0}};
  p.eta3 = Curve{{0.6, 0.4}, {0.5, 6.0}};
  p.eta4 = Curve{{0.7, 0.3}, {3.0, -2.0}};
  return p;
}

/// The pattern with the default bending model (the shape operator).
inline TriangleShellOptions options(TrianglePattern pattern, int threads = 0) {
  TriangleShellOptions o;
  o.pattern = pattern;
  o.threads = threads;
  return o;
}

/// The pattern with a hinge bending model (tests of the hinge calibration, §4.1–4.6).
inline TriangleShellOptions hinge_options(TrianglePattern pattern,
                                          HingeModel model = HingeModel::Cylinders) {
  TriangleShellOptions o = options(pattern);
  o.hinge_model = model;
  return o;
}

/// Unit-curvature direction u (in-plane) and radius R: maps the reference point X isometrically
/// onto the cylinder through the strip centre whose curvature tensor is u⊗u/R (the axis is
/// ⟂ u): s = (X − c)·u, r = (X − c)·v,  x = c + r v + R sin(s/R) u + R (1 − cos(s/R)) ẑ.
inline Eigen::VectorXd cylinder_positions(const Eigen::VectorXd& rest, const Eigen::Vector2d& u,
                                          double radius, double length_m) {
  const Eigen::Vector2d un = u.normalized(), vn(-un.y(), un.x());
  const Eigen::Vector2d c(0.5 * length_m, 0.0);
  Eigen::VectorXd q(rest.size());
  for (Eigen::Index i = 0; i < rest.size() / 3; ++i) {
    const Eigen::Vector2d X = rest.segment<2>(3 * i) - c;
    const double s = X.dot(un), r = X.dot(vn);
    const Eigen::Vector2d xy = c + r * vn + radius * std::sin(s / radius) * un;
    q.segment<3>(3 * i) << xy.x(), xy.y(), radius * (1.0 - std::cos(s / radius));
  }
  return q;
}

/// The warp (a = 0) or weft (a = 1) direction of a strip at `angle_deg`
/// (core/discretization.hpp).
inline Eigen::Vector2d material_direction(double angle_deg, int a) {
  const double t = angle_deg * M_PI / 180.0;
  return a == 0 ? Eigen::Vector2d(-std::sin(t), std::cos(t))
                : Eigen::Vector2d(std::cos(t), std::sin(t));
}

/// Kirchhoff–Love bending energy per unit area of the cylinder u⊗u/R:
/// τ³/24 · ẽᵀ C ẽ / R², ẽ = (ũ1², ũ2², ũ1ũ2), C = [[a11, a12, 0], [a12, a22, 0], [0, 0, 2 G12]].
inline double kirchhoff_love_cylinder_density(const MaterialParameters& p, double angle_deg,
                                              const Eigen::Vector2d& u, double radius) {
  const Eigen::Vector2d un = u.normalized();
  const double u1 = un.dot(material_direction(angle_deg, 0));
  const double u2 = un.dot(material_direction(angle_deg, 1));
  const double e1 = u1 * u1, e2 = u2 * u2, e3 = u1 * u2;
  const double q =
      p.a11_Pa * e1 * e1 + 2 * p.a12_Pa * e1 * e2 + p.a22_Pa * e2 * e2 + 2 * p.G12_Pa * e3 * e3;
  const double t = p.thickness_m;
  return t * t * t / 24.0 * q / (radius * radius);
}

}  // namespace twill::triangle_shell_test
