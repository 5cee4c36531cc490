#pragma once
// The derivative and invariance checks of a discretisation (core/discretization.hpp), written
// once against the interface: the registry-driven suite (test_every_discretization.cpp) runs
// them on every registered part, and a part's own tests run them again at states only that
// part knows how to build (e.g. strains straddling the law's cutoffs).
//
// Every finite-difference check is a central difference whose error must fall at second order
// as the step halves (tests/support/finite_difference.hpp).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <optional>
#include <random>
#include <string>

#include "core/discretization.hpp"
#include "tests/support/finite_difference.hpp"

namespace twill::testing {

/// ∂E/∂q along `v` (scaled like positions) from h0 down by `halvings`; the state must be
/// curved enough that truncation error is visible (not round-off only).
inline void expect_gradient_converges(const Discretization& d, const Eigen::VectorXd& q,
                                      const Eigen::VectorXd& v, double h0, int halvings,
                                      double max_relative_error) {
  Eigen::VectorXd g;
  d.energy(q, &g, nullptr);
  auto value = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return Eigen::VectorXd::Constant(1, d.energy(x, nullptr, nullptr));
  };
  const OrderCheck check = check_directional_derivative(value, q, v, Eigen::VectorXd::Constant(1, g.dot(v)), h0,
                                                        halvings, max_relative_error);
  EXPECT_TRUE(check.ok) << "gradient: " << check.report;
  EXPECT_FALSE(check.roundoff_only) << "gradient: the state must exercise truncation error: " << check.report;
}

/// ∂²E/∂q² applied to `v` against central differences of the gradient, and its symmetry
/// (relative to the largest entry).
inline void expect_hessian_converges(const Discretization& d, const Eigen::VectorXd& q,
                                     const Eigen::VectorXd& v, double h0, int halvings,
                                     double max_relative_error, double symmetry_tolerance) {
  SparseMatrix H;
  d.energy(q, nullptr, &H);
  const double largest = H.coeffs().cwiseAbs().maxCoeff();
  EXPECT_LT(SparseMatrix(SparseMatrix(H.transpose()) - H).coeffs().cwiseAbs().maxCoeff(),
            symmetry_tolerance * largest);
  auto gradient = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    Eigen::VectorXd g;
    d.energy(x, &g, nullptr);
    return g;
  };
  const OrderCheck check = check_directional_derivative(gradient, q, v, H * v, h0, halvings, max_relative_error);
  EXPECT_TRUE(check.ok) << "Hessian: " << check.report;
  EXPECT_FALSE(check.roundoff_only) << "Hessian: " << check.report;
}

/// How to difference one flat parameter: its first step, and whether the gradient is
/// nonlinear in it (then truncation error must be visible; linear parameters, e.g. density,
/// the stiffnesses and the μ's, are differenced exactly up to round-off).
struct ParameterStep {
  double h0;
  bool nonlinear;
};
/// The step of a flat parameter, or nullopt to leave that parameter out.
using ParameterStepRule = std::function<std::optional<ParameterStep>(const std::string& name, double value)>;

/// Every parameter, with a step relative to its value. The gradient is linear in density, the
/// stiffnesses and the μ's; it depends on τ, the bending ratios (through √b and (b_w b_f)^¼,
/// core/bending_scale.hpp) and the α's nonlinearly. An α acts through (1 + Ẽ²)^α with
/// Ẽ² ~ 1e-3, so its third derivative is tiny: a step of 0.4 α is still in the asymptotic
/// range and keeps the truncation error above round-off.
inline std::optional<ParameterStep> relative_parameter_step(const std::string& name, double value) {
  const bool alpha = name.find(".alpha[") != std::string::npos;
  const bool nonlinear =
      alpha || name == "thickness_m" || name == kBendingWarpRatioName || name == kBendingWeftRatioName;
  return ParameterStep{(alpha ? 0.4 : 1e-2) * std::abs(value), nonlinear};
}

/// ∂g/∂k, column by column for every flat parameter `step` does not leave out, against central differences of the
/// gradient in that parameter (set_parameters; restored afterwards). Every column must be
/// non-zero (each parameter acts on the gradient at q; set gravity so that density does).
inline void expect_parameter_jacobian_converges(Discretization& d, const Eigen::VectorXd& q,
                                                const ParameterStepRule& step, int halvings,
                                                double max_relative_error) {
  Eigen::MatrixXd dk;
  d.gradient_parameter_jacobian(q, &dk);
  const MaterialParameters p0 = d.parameters();
  const Eigen::VectorXd k0 = p0.to_flat();
  const auto names = p0.parameter_names();
  ASSERT_EQ(dk.rows(), d.num_dofs());
  ASSERT_EQ(dk.cols(), k0.size());
  auto gradient_at = [&](const Eigen::VectorXd& k) -> Eigen::VectorXd {
    MaterialParameters p = p0;
    p.set_from_flat(k);
    d.set_parameters(p);
    Eigen::VectorXd g;
    d.energy(q, &g, nullptr);
    return g;
  };
  for (Eigen::Index column = 0; column < k0.size(); ++column) {
    const std::string& name = names[static_cast<size_t>(column)];
    const std::optional<ParameterStep> s = step(name, k0[column]);
    if (!s) continue;
    const OrderCheck check = check_directional_derivative(gradient_at, k0, Eigen::VectorXd::Unit(k0.size(), column),
                                                          dk.col(column), s->h0, halvings, max_relative_error);
    EXPECT_TRUE(check.ok) << name << ": " << check.report;
    if (s->nonlinear) {
      EXPECT_FALSE(check.roundoff_only) << name << ": " << check.report;
    }
    EXPECT_GT(dk.col(column).cwiseAbs().maxCoeff(), 0.0) << name;
  }
  d.set_parameters(p0);
}

/// Rest positions plus a smooth displacement: stretch along x, contraction across, shear and an
/// out-of-plane bulge (strains of a few percent, curvature ~10 /m on a 75 mm × 50 mm strip).
inline Eigen::VectorXd distorted_state(const Discretization& d) {
  const double L = d.strip().length_m, W = d.strip().width_m;
  Eigen::VectorXd q = d.rest_positions();
  for (int i = 0; i < d.num_nodes(); ++i) {
    const double x = q[3 * i], y = q[3 * i + 1];
    q[3 * i] += 0.04 * x + 0.002 * std::sin(M_PI * x / L) * std::cos(M_PI * y / W) + 0.01 * y;
    q[3 * i + 1] += 0.005 * y + 0.001 * std::sin(2 * M_PI * x / L);
    q[3 * i + 2] += 0.004 * std::sin(M_PI * x / L) * (1.0 + 0.3 * y / W) + 0.001 * std::cos(M_PI * y / W);
  }
  return q;
}

/// A smooth random direction (random low modes per component) plus a little noise, scaled by
/// the strip length.
inline Eigen::VectorXd smooth_direction(const Discretization& d, unsigned seed) {
  const double L = d.strip().length_m, W = d.strip().width_m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  double c[3][4];
  for (auto& row : c)
    for (double& v : row) v = uniform(rng);
  Eigen::VectorXd v(d.num_dofs());
  const Eigen::VectorXd& X = d.rest_positions();
  for (int i = 0; i < d.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) {
      const double x = X[3 * i] / L, y = X[3 * i + 1] / W;
      v[3 * i + k] = L * (c[k][0] * std::sin(M_PI * x) + c[k][1] * std::cos(M_PI * y) + c[k][2] * x * y +
                          0.1 * c[k][3] * uniform(rng));
    }
  return v;
}

/// x ↦ R x + t applied to every node of q.
inline Eigen::VectorXd rigidly_moved(const Eigen::VectorXd& q, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Eigen::VectorXd out(q.size());
  for (Eigen::Index i = 0; i < q.size() / 3; ++i) out.segment<3>(3 * i) = R * q.segment<3>(3 * i) + t;
  return out;
}

}  // namespace twill::testing
