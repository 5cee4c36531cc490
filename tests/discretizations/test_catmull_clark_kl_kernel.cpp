// Unit tests of the pieces of the Catmull–Clark Kirchhoff–Love shell: the Gauss–Legendre
// rule, the OpenSubdiv limit-surface basis (regular B-spline patches only: a rectangular grid
// has no extraordinary vertex, so these tests cover REGULAR patches of every boundary type),
// the shell strains with their exact derivatives, and the through-thickness integral.
//
// The point-kernel derivative checks use a *normalised thick* configuration (unit metric,
// curvature ~0.3, τ = 0.2, stiffnesses ~1) where bending and membrane terms are of similar
// size: at physical canvas sizes bending is so much weaker that a mesh-level check could
// not see an error in it (test_catmull_clark_kl.cpp checks the assembly at physical sizes).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/bending_scale.hpp"
#include "core/material_law.hpp"
#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"
#include "discretizations/catmull_clark_kl/kirchhoff_love_kernel.hpp"
#include "discretizations/catmull_clark_kl/limit_surface_basis.hpp"
#include "tests/support/finite_difference.hpp"

namespace twill {
namespace {

using Eigen::Vector3d;
using Eigen::VectorXd;
using testing::check_directional_derivative;

MaterialParameters nonlinear_unit_law() {
  MaterialParameters p;
  p.density_kg_m2 = 0.3;
  p.thickness_m = 0.2;
  p.a11_Pa = 1.0;
  p.a22_Pa = 0.7;
  p.a12_Pa = 0.35;
  p.G12_Pa = 0.2;
  p.eta1 = Curve{{0.6, 0.4}, {2.5, 6.0}};
  p.eta3 = Curve{{1.3, -0.3}, {3.0, 0.5}};
  p.eta4 = Curve{{0.5, 0.5}, {4.0, 1.5}};
  // Faces placed between the law arguments of curved_jet() (see box_sides), so that its
  // through-thickness points lie on both sides of three of them.
  p.cutoffs.E11_min = -0.01;
  p.cutoffs.E11_max = 0.3;
  p.cutoffs.E22_min = 0.0;
  p.cutoffs.E22_max = 0.105;
  p.cutoffs.E12_max = 0.08;
  return p;
}

MaterialParameters stvk_unit_law() {
  MaterialParameters p = nonlinear_unit_law();
  p.eta1 = p.eta3 = p.eta4 = Curve::linear();
  p.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  return p;
}

/// A flat unit reference point (A = I, B = 0) with the material frame at 30°.
ReferencePoint unit_reference() {
  SurfaceJet Y = SurfaceJet::Zero();
  Y.segment<3>(0) = Vector3d::UnitX();
  Y.segment<3>(3) = Vector3d::UnitY();
  const double theta = 30.0 * M_PI / 180.0;
  return make_reference_point(Y, 0.7, Vector3d(-std::sin(theta), std::cos(theta), 0),
                              Vector3d(std::cos(theta), std::sin(theta), 0));
}

/// A deformed jet: stretched, sheared, tilted and curved (strains ~0.1, curvature ~0.3).
SurfaceJet curved_jet() {
  SurfaceJet y;
  y << 1.12, 0.05, 0.25,  //
      -0.04, 0.93, 0.12,  //
      0.03, -0.02, 0.35,  //
      0.01, 0.04, -0.22,  //
      -0.02, 0.03, 0.15;
  return y;
}

VectorXd random_vector(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = uniform(rng);
  return v;
}

/// Which side of each of the five box faces every law argument lies on (one bit each), for
/// orthotropic strains e = (e_m, e_b) and the through-thickness rule. ψ is only C² across a
/// face, so a central difference whose stencil crosses one loses an order: the derivative
/// checks assert that their stencils cross none.
std::vector<int> box_sides(const MaterialParameters& p, const GaussLegendreRule& rule,
                           const Vector6& e) {
  std::vector<int> sides;
  const Cutoffs& c = p.cutoffs;
  const Vector3d scaled_bending = bending_scale(p).diagonal.cwiseProduct(e.tail<3>());  // S e_b
  for (double s : rule.nodes) {
    const Vector3d x = e.head<3>() - 0.5 * p.thickness_m * s * scaled_bending;
    sides.push_back((x[0] < *c.E11_min) | (x[0] < *c.E11_max) << 1 | (x[1] < *c.E22_min) << 2 |
                    (x[1] < *c.E22_max) << 3 | (std::abs(x[2]) < *c.E12_max) << 4);
  }
  return sides;
}

Vector6 orthotropic_of(const ReferencePoint& ref, const SurfaceJet& y) {
  Vector3d membrane, bending;
  orthotropic_strains(ref, y, &membrane, &bending);
  Vector6 e;
  e << membrane, bending;
  return e;
}

/// Whether flat entry `column` moves the law's arguments (the through-thickness strains): τ
/// and the bending ratios, which the law itself does not see.
bool moves_law_arguments(const MaterialParameters& p, int column) {
  const int bending = FlatLayout(p).bending;
  return column == FlatLayout::kThickness || (column >= bending && column < bending + FlatLayout::kBendingRatios);
}

/// The unit law with anisotropic bending ratios (b_w ≠ b_f ≠ 1: every entry of S and of ∂S/∂b
/// differs), placed so that the through-thickness arguments stay off the box faces.
MaterialParameters anisotropic_unit_law() {
  MaterialParameters p = nonlinear_unit_law();
  p.bending_warp_ratio = 1.3;
  p.bending_weft_ratio = 0.8;
  return p;
}

/// Steps: small enough that no law argument crosses a box face within the stencil (asserted),
/// large enough that the truncation error stays far above round-off.
constexpr double kJetStep = 2e-3;

TEST(GaussLegendre, IntegratesPolynomialsUpToDegree2nMinus1Exactly) {
  for (int n = 1; n <= 10; ++n) {
    const GaussLegendreRule rule = GaussLegendreRule::make(n);
    ASSERT_EQ(rule.size(), n);
    for (int degree = 0; degree <= 2 * n - 1; ++degree) {
      double integral = 0.0;
      for (int g = 0; g < n; ++g)
        integral += rule.weights[static_cast<size_t>(g)] *
                    std::pow(rule.nodes[static_cast<size_t>(g)], degree);
      const double exact = degree % 2 == 1 ? 0.0 : 2.0 / (degree + 1);
      EXPECT_NEAR(integral, exact, 1e-14) << "n = " << n << ", degree " << degree;
    }
    for (int g = 0; g + 1 < n; ++g)
      EXPECT_LT(rule.nodes[static_cast<size_t>(g)], rule.nodes[static_cast<size_t>(g + 1)]);
  }
  // Degree 2n is not integrated exactly (the rule is exactly as strong as documented).
  const GaussLegendreRule two = GaussLegendreRule::make(2);
  double x4 = 0.0;
  for (int g = 0; g < 2; ++g) x4 += two.weights[static_cast<size_t>(g)] * std::pow(two.nodes[static_cast<size_t>(g)], 4);
  EXPECT_GT(std::abs(x4 - 0.4), 0.1);
  EXPECT_THROW(GaussLegendreRule::make(0), std::invalid_argument);
}

TEST(LimitSurfaceBasis, EveryFaceIsARegularPatchReproducingAffineMaps) {
  for (auto [nx, ny] : {std::pair{4, 3}, std::pair{1, 1}, std::pair{2, 5}}) {
    const LimitSurfaceBasis basis(nx, ny);  // throws if any patch were not regular
    EXPECT_EQ(basis.num_faces(), nx * ny);
    EXPECT_EQ(basis.num_nodes(), (nx + 1) * (ny + 1));
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int face = 0; face < basis.num_faces(); ++face) {
      const int i = face % nx, j = face / nx;
      for (int sample = 0; sample < 5; ++sample) {
        const double u = unit(rng), v = unit(rng);
        const PatchBasis b = basis.evaluate(face, u, v);
        // Node (i', j') at grid coordinates (i', j'): the limit point must be (i + u, j + v),
        // with constant first and zero second derivatives (affine reproduction).
        Eigen::Matrix<double, 6, 2> grid = Eigen::Matrix<double, 6, 2>::Zero();
        for (int k = 0; k < 16; ++k) {
          const int node = b.nodes[static_cast<size_t>(k)];
          grid.col(0) += b.weights.col(k) * (node % (nx + 1));
          grid.col(1) += b.weights.col(k) * (node / (nx + 1));
        }
        Eigen::Matrix<double, 6, 2> expected;
        expected << i + u, j + v, 1, 0, 0, 1, 0, 0, 0, 0, 0, 0;
        EXPECT_LT((grid - expected).cwiseAbs().maxCoeff(), 1e-13) << "face " << face;
        EXPECT_NEAR(b.weights.row(0).sum(), 1.0, 1e-15);
        EXPECT_GE(b.weights.row(0).minCoeff(), -1e-15);  // B-spline weights are non-negative
      }
    }
  }
}

TEST(LimitSurfaceBasis, DerivativesMatchFiniteDifferencesAtSecondOrder) {
  const LimitSurfaceBasis basis(4, 3);
  // Interior, edge and corner faces: every boundary type of regular patch.
  for (int face : {0, 1, 5, 6, 11}) {
    const double u = 0.37, v = 0.61;
    const PatchBasis b = basis.evaluate(face, u, v);
    for (int direction = 0; direction < 2; ++direction) {
      const Eigen::Vector2d dir = direction == 0 ? Eigen::Vector2d(1, 0) : Eigen::Vector2d(0, 1);
      // Rows N, N_u, N_v move along u as (N_u, N_uu, N_uv), along v as (N_v, N_uv, N_vv).
      auto rows = [&](const Eigen::VectorXd& uv) {
        const PatchBasis e = basis.evaluate(face, uv[0], uv[1]);
        VectorXd out(48);
        for (int r = 0; r < 3; ++r) out.segment<16>(16 * r) = e.weights.row(r).transpose();
        return out;
      };
      VectorXd exact(48);
      const int d0 = direction == 0 ? 1 : 2;
      const int d1 = direction == 0 ? 3 : 5;
      const int d2 = direction == 0 ? 5 : 4;
      exact << b.weights.row(d0).transpose(), b.weights.row(d1).transpose(),
          b.weights.row(d2).transpose();
      const auto check = check_directional_derivative(rows, Eigen::Vector2d(u, v), dir, exact, 0.02);
      EXPECT_TRUE(check.ok) << "face " << face << " direction " << direction << ": " << check.report;
      EXPECT_FALSE(check.roundoff_only) << check.report;
    }
  }
}

TEST(ShellStrains, FirstAndSecondDerivativesMatchFiniteDifferences) {
  const ReferencePoint ref = unit_reference();
  const SurfaceJet y = curved_jet();
  StrainJacobian J;
  shell_strains(y, ref.A, ref.B, &J);
  for (unsigned seed : {1u, 2u, 3u}) {
    const VectorXd direction = random_vector(15, seed);
    auto strains = [&](const VectorXd& x) -> VectorXd {
      return shell_strains(x, ref.A, ref.B, nullptr);
    };
    const auto first = check_directional_derivative(strains, y, direction, J * direction, 1e-2);
    EXPECT_TRUE(first.ok) << first.report;

    // Second derivatives contracted with weights g: FD of Jᵀ g vs (Σ g_k ∂²s_k) direction.
    const Vector6 g = random_vector(6, seed + 10);
    auto contracted = [&](const VectorXd& x) -> VectorXd {
      StrainJacobian Jx;
      shell_strains(x, ref.A, ref.B, &Jx);
      return Jx.transpose() * g;
    };
    const Matrix15 H = shell_strain_hessian(y, g);
    EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-14);
    const auto second = check_directional_derivative(contracted, y, direction, H * direction, 1e-2);
    EXPECT_TRUE(second.ok) << second.report;
    EXPECT_FALSE(second.roundoff_only) << second.report;  // the normal is not quadratic
  }
}

TEST(ShellStrains, ZeroAtRestAndMatchTheReferenceMap) {
  const ReferencePoint ref = unit_reference();
  SurfaceJet Y = SurfaceJet::Zero();
  Y.segment<3>(0) = Vector3d::UnitX();
  Y.segment<3>(3) = Vector3d::UnitY();
  EXPECT_EQ(shell_strains(Y, ref.A, ref.B, nullptr).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_NEAR(ref.weight_area, 0.7, 1e-15);
  // A = I: T is the rotation of a symmetric tensor into the material frame, Ẽ = DᵀED.
  const Eigen::Vector3d eps(0.03, -0.01, 0.02);
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  E.topLeftCorner<2, 2>() << eps(0), eps(2), eps(2), eps(1);
  const double theta = 30.0 * M_PI / 180.0;
  const Vector3d d1(-std::sin(theta), std::cos(theta), 0), d2(std::cos(theta), std::sin(theta), 0);
  const Vector3d expected(d1.dot(E * d1), d2.dot(E * d2), d1.dot(E * d2));
  EXPECT_LT((ref.T * eps - expected).cwiseAbs().maxCoeff(), 1e-16);
}

TEST(ThicknessIntegral, StVKWithTwoOrMorePointsIsExact) {
  // For quadratic ψ: ∫ψ(e_m − ξ e_b)dξ = τ ψ(e_m) + τ³/24 e_b:C:e_b (the linear term in ξ
  // integrates to zero), with C = ∂²ψ/∂Ẽ² constant.
  const MaterialLaw law(stvk_unit_law());
  const double tau = 0.2;
  Vector6 e;
  e << 0.05, -0.02, 0.03, 0.4, -0.3, 0.25;
  Vector3 dpsi;
  Matrix3 C;
  const double psi_m = law.energy_density(e.head<3>(), &dpsi, &C);
  const double exact = tau * psi_m + tau * tau * tau / 24.0 * e.tail<3>().dot(C * e.tail<3>());
  for (int n : {2, 3, 5}) {
    const double W = thickness_integral(law, tau, GaussLegendreRule::make(n), e, nullptr, nullptr);
    EXPECT_NEAR(W, exact, 1e-15 * exact) << "n_xi = " << n;
  }
  // One point (the mid-surface) would lose the bending term: why validate() asks for ≥ 2.
  const double midpoint = thickness_integral(law, tau, GaussLegendreRule::make(1), e, nullptr, nullptr);
  EXPECT_NEAR(midpoint, tau * psi_m, 1e-15 * exact);
  EXPECT_GT(std::abs(midpoint - exact), 1e-3 * exact);
}

TEST(ThicknessIntegral, NonlinearLawConvergesAsPointsIncrease) {
  // Large through-thickness variation (τκ/2 ~ 0.2, far beyond the physical ~1e-3) so that the
  // quadrature error is visible. Reference: 60 points.
  Vector6 e;
  e << 0.18, 0.05, 0.06, 2.0, -1.5, 0.8;
  const double tau = 0.2;
  auto relative_errors = [&](const MaterialParameters& p, const std::vector<int>& counts) {
    const MaterialLaw law(p);
    const double reference =
        thickness_integral(law, tau, GaussLegendreRule::make(60), e, nullptr, nullptr);
    std::vector<double> errors;
    for (int n : counts)
      errors.push_back(std::abs(thickness_integral(law, tau, GaussLegendreRule::make(n), e, nullptr,
                                                   nullptr) - reference) / reference);
    return errors;
  };
  // Smooth law (no cutoffs): the integrand is analytic, the error falls geometrically.
  MaterialParameters smooth = nonlinear_unit_law();
  smooth.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  const std::vector<double> geometric = relative_errors(smooth, {2, 3, 4, 5, 6});
  EXPECT_GT(geometric[0], 1e-4);  // the law really is non-polynomial here
  for (size_t k = 1; k < geometric.size(); ++k) EXPECT_LT(geometric[k], 0.05 * geometric[k - 1]);
  EXPECT_LT(geometric.back(), 1e-10);
  // With cutoffs crossed inside the thickness the integrand is only C² (the Taylor
  // extrapolation joins with a jump in the third derivative): convergence is algebraic and
  // not monotone.
  const std::vector<double> algebraic = relative_errors(nonlinear_unit_law(), {2, 4, 8, 16, 32});
  EXPECT_GT(algebraic[0], 1e-4);
  EXPECT_LT(algebraic[2], 1e-2 * algebraic[0]);
  EXPECT_LT(algebraic[4], 1e-4 * algebraic[0]);
}

void check_thickness_integral_derivatives(const MaterialParameters& parameters) {
  const MaterialLaw law(parameters);
  const GaussLegendreRule rule = GaussLegendreRule::make(3);
  const double tau = parameters.thickness_m;
  Vector6 e;
  e << 0.18, 0.05, 0.06, 2.0, -1.5, 0.8;
  Vector6 grad;
  Matrix6 hess;
  thickness_integral(law, tau, rule, e, &grad, &hess);
  const VectorXd direction = random_vector(6, 4);
  ASSERT_EQ(box_sides(parameters, rule, e + kJetStep * direction), box_sides(parameters, rule, e));
  ASSERT_EQ(box_sides(parameters, rule, e - kJetStep * direction), box_sides(parameters, rule, e));
  auto value = [&](const VectorXd& x) -> VectorXd {
    return VectorXd::Constant(1, thickness_integral(law, tau, rule, x, nullptr, nullptr));
  };
  auto gradient = [&](const VectorXd& x) -> VectorXd {
    Vector6 g;
    thickness_integral(law, tau, rule, x, &g, nullptr);
    return g;
  };
  const auto first = check_directional_derivative(value, e, direction,
                                                  VectorXd::Constant(1, grad.dot(direction)), kJetStep);
  EXPECT_TRUE(first.ok) << first.report;
  EXPECT_FALSE(first.roundoff_only) << first.report;
  const auto second = check_directional_derivative(gradient, e, direction, hess * direction, kJetStep);
  EXPECT_FALSE(second.roundoff_only) << second.report;
  EXPECT_TRUE(second.ok) << second.report;

  StrainParameterJacobian dk;
  thickness_integral_parameter_jacobian(law, tau, rule, e, &dk);
  const VectorXd k0 = parameters.to_flat();
  ASSERT_EQ(dk.cols(), k0.size());
  EXPECT_EQ(dk.col(FlatLayout::kDensity).cwiseAbs().maxCoeff(), 0.0);
  for (int column = 0; column < k0.size(); ++column) {
    auto gradient_at = [&](const VectorXd& k) -> VectorXd {
      MaterialParameters p = parameters;
      p.set_from_flat(k);
      Vector6 g;
      thickness_integral(MaterialLaw(p), p.thickness_m, rule, e, &g, nullptr);
      return g;
    };
    const std::string name = parameters.parameter_names()[static_cast<size_t>(column)];
    // Linear in the stiffnesses and μ's (exact differences up to round-off); nonlinear in τ
    // and the bending ratios (they move the through-thickness points: kept off the box faces)
    // and the α's.
    const bool alpha = name.find(".alpha[") != std::string::npos;
    const double h0 = (alpha ? 0.4 : 1e-2) * std::abs(k0[column]);
    const VectorXd unit = VectorXd::Unit(k0.size(), column);
    if (moves_law_arguments(parameters, column))
      for (double sign : {-1.0, 1.0}) {
        MaterialParameters moved = parameters;
        moved.set_from_flat(k0 + sign * h0 * unit);
        ASSERT_EQ(box_sides(moved, rule, e), box_sides(parameters, rule, e)) << name;
      }
    const auto check = check_directional_derivative(gradient_at, k0, unit, dk.col(column), h0);
    EXPECT_TRUE(check.ok) << name << ": " << check.report;
    if (alpha || moves_law_arguments(parameters, column)) {
      EXPECT_FALSE(check.roundoff_only) << name << ": " << check.report;
    }
  }
}

TEST(ThicknessIntegral, GradientHessianAndParameterJacobianMatchFiniteDifferences) {
  for (const MaterialParameters& parameters : {nonlinear_unit_law(), anisotropic_unit_law()}) {
    SCOPED_TRACE("bending ratios " + std::to_string(parameters.bending_warp_ratio) + ", " +
                 std::to_string(parameters.bending_weft_ratio));
    check_thickness_integral_derivatives(parameters);
  }
}

TEST(ThicknessIntegral, BendingRatiosScaleTheSmallCurvatureStiffnessBySCS) {
  // StVK: W = τ ψ(e_m) + τ³/24 (S e_b)ᵀ C (S e_b) exactly (docs/effects/bending-anisotropy.md),
  // so pure warp, weft and twist curvatures cost b_w, b_f and √(b_w b_f) times the paper's.
  MaterialParameters p = stvk_unit_law();
  p.bending_warp_ratio = 4.0;
  p.bending_weft_ratio = 0.25;
  const double tau = p.thickness_m;
  const Vector3d factor(p.bending_warp_ratio, p.bending_weft_ratio,
                        std::sqrt(p.bending_warp_ratio * p.bending_weft_ratio));
  const GaussLegendreRule rule = GaussLegendreRule::make(2);
  for (int i = 0; i < 3; ++i) {
    Vector6 e = Vector6::Zero();
    e[3 + i] = 0.3;  // [1/m]
    const double paper = thickness_integral(MaterialLaw(stvk_unit_law()), tau, rule, e, nullptr, nullptr);
    const double scaled = thickness_integral(MaterialLaw(p), tau, rule, e, nullptr, nullptr);
    EXPECT_NEAR(scaled, factor[i] * paper, 1e-15 * scaled) << "component " << i;
  }
  // The membrane is untouched.
  Vector6 membrane = Vector6::Zero();
  membrane.head<3>() << 0.05, -0.02, 0.03;
  EXPECT_EQ(thickness_integral(MaterialLaw(p), tau, rule, membrane, nullptr, nullptr),
            thickness_integral(MaterialLaw(stvk_unit_law()), tau, rule, membrane, nullptr, nullptr));
}

void check_point_derivatives(const MaterialParameters& parameters) {
  const MaterialLaw law(parameters);
  const GaussLegendreRule rule = GaussLegendreRule::make(3);
  const double tau = parameters.thickness_m;
  const ReferencePoint ref = unit_reference();
  const SurfaceJet y = curved_jet();
  Vector15 grad;
  Matrix15 hess;
  const double E = kirchhoff_love_point(law, tau, rule, ref, y, &grad, &hess);
  EXPECT_GT(E, 0.0);
  EXPECT_LT((hess - hess.transpose()).cwiseAbs().maxCoeff(), 1e-13 * hess.cwiseAbs().maxCoeff());
  // Bending must matter here, or this test would not check it.
  Eigen::Vector3d membrane, bending;
  orthotropic_strains(ref, y, &membrane, &bending);
  EXPECT_GT(0.5 * tau * bending.norm(), 0.2 * membrane.norm());

  auto value = [&](const VectorXd& x) -> VectorXd {
    return VectorXd::Constant(1, kirchhoff_love_point(law, tau, rule, ref, x, nullptr, nullptr));
  };
  auto gradient = [&](const VectorXd& x) -> VectorXd {
    Vector15 g;
    kirchhoff_love_point(law, tau, rule, ref, x, &g, nullptr);
    return g;
  };
  for (unsigned seed : {5u, 6u}) {
    const VectorXd direction = random_vector(15, seed);
    for (double sign : {-1.0, 1.0})
      ASSERT_EQ(box_sides(parameters, rule, orthotropic_of(ref, y + sign * kJetStep * direction)),
                box_sides(parameters, rule, orthotropic_of(ref, y)));
    const auto first = check_directional_derivative(
        value, y, direction, VectorXd::Constant(1, grad.dot(direction)), kJetStep);
    EXPECT_TRUE(first.ok) << first.report;
    EXPECT_FALSE(first.roundoff_only) << first.report;
    const auto second = check_directional_derivative(gradient, y, direction, hess * direction, kJetStep);
    EXPECT_TRUE(second.ok) << second.report;
    EXPECT_FALSE(second.roundoff_only) << second.report;
  }

  JetParameterJacobian dk;
  kirchhoff_love_point_parameter_jacobian(law, tau, rule, ref, y, &dk);
  const VectorXd k0 = parameters.to_flat();
  for (int column = 0; column < k0.size(); ++column) {
    auto gradient_at = [&](const VectorXd& k) -> VectorXd {
      MaterialParameters p = parameters;
      p.set_from_flat(k);
      Vector15 g;
      kirchhoff_love_point(MaterialLaw(p), p.thickness_m, rule, ref, y, &g, nullptr);
      return g;
    };
    const std::string name = parameters.parameter_names()[static_cast<size_t>(column)];
    // Linear in the stiffnesses and μ's (exact differences up to round-off); nonlinear in τ
    // and the bending ratios (they move the through-thickness points: kept off the box faces)
    // and the α's.
    const bool alpha = name.find(".alpha[") != std::string::npos;
    const double h0 = (alpha ? 0.4 : 1e-2) * std::abs(k0[column]);
    const VectorXd unit = VectorXd::Unit(k0.size(), column);
    if (moves_law_arguments(parameters, column))
      for (double sign : {-1.0, 1.0}) {
        MaterialParameters moved = parameters;
        moved.set_from_flat(k0 + sign * h0 * unit);
        ASSERT_EQ(box_sides(moved, rule, orthotropic_of(ref, y)), box_sides(parameters, rule, orthotropic_of(ref, y)))
            << name;
      }
    const auto check = check_directional_derivative(gradient_at, k0, unit, dk.col(column), h0);
    EXPECT_TRUE(check.ok) << name << ": " << check.report;
    if (alpha || moves_law_arguments(parameters, column)) {
      EXPECT_FALSE(check.roundoff_only) << name << ": " << check.report;
    }
  }
}

TEST(KirchhoffLovePoint, GradientHessianAndParameterJacobianMatchFiniteDifferences) {
  for (const MaterialParameters& parameters : {nonlinear_unit_law(), anisotropic_unit_law()}) {
    SCOPED_TRACE("bending ratios " + std::to_string(parameters.bending_warp_ratio) + ", " +
                 std::to_string(parameters.bending_weft_ratio));
    check_point_derivatives(parameters);
  }
}

}  // namespace
}  // namespace twill
