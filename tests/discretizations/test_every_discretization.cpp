// The checks every discretisation must pass (style.md practices 7 and 8), run on every part
// registered in the program's registry (app/program_registry.cpp), not on a literal list: a
// new discretisation is tested the day it is registered (issue #14, item 5).
//
// Each registered part runs at its defaults and once more for every other value of each of its
// choice options (Catmull–Clark's fibre_strain; the triangle shell's pattern, clamp_hinges and
// hinge_model), one option at a time, so a new choice is covered too:
//   - ∂E/∂q, ∂²E/∂q² and ∂g/∂k (every flat parameter) against central differences, with the
//     error falling at second order as the step halves, at the paper's bending (ratios 1) and
//     with anisotropic bending ratios;
//   - rigid-motion invariance of the energy, and forces and Hessian rotating with the body;
//   - the patch test: a uniform in-plane strain, rigidly rotated out of the plane, gives exactly
//     the energy of the homogeneous sheet, L·W·τ·ψ(Ẽ), at several material angles;
//     (both skipped, saying so, for options that put the clamps' jaws into the energy);
//   - pattern reuse: the Hessian's storage is kept between calls and refilled with the values
//     a fresh assembly gives.
// Meshes are coarse (3 × 4 cells), at the physical sizes of a canvas strip (L = 75 mm,
// W = 50 mm, τ = 0.45 mm, a11 = 3e7 Pa, …), with a degree-2 law (negative μ, exponents on both
// sides of 1). The law's cutoffs are off here, so every derivative is smooth; states straddling
// the cutoffs need the part's own strains and are in its own tests, through the same checks
// (discretization_checks.hpp).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <ostream>
#include <string>
#include <vector>

#include "core/discretization_registry.hpp"
#include "core/material_law.hpp"
#include "tests/discretizations/discretization_checks.hpp"
#include "tests/support/program_registry.hpp"
#include "tests/support/test_materials.hpp"

namespace twill {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using testing::canvas_degree2;
using testing::distorted_state;
using testing::smooth_direction;

constexpr double kLength = 0.075, kWidth = 0.050;

/// One registered discretisation with `--set`-style option overrides.
struct DiscretizationCase {
  std::string name;
  std::vector<std::string> overrides;
  std::string label() const {
    std::string out = name;
    for (const auto& o : overrides) out += " " + o;
    return out;
  }
};
void PrintTo(const DiscretizationCase& c, std::ostream* os) { *os << c.label(); }

/// Every registered discretisation at its defaults, then each other value of each choice option.
std::vector<DiscretizationCase> every_discretization() {
  std::vector<DiscretizationCase> cases;
  const RegistryCategory* category = testing::program_registry().find_category(registry_category::kDiscretization);
  if (!category) return cases;
  for (const auto& entry : category->entries()) {
    cases.push_back({entry.name, {}});
    for (const auto& spec : entry.options.options()) {
      if (spec.type != OptionType::String) continue;
      for (const auto& value : spec.allowed)
        if (value != std::get<std::string>(spec.default_value)) cases.push_back({entry.name, {spec.name + "=" + value}});
    }
  }
  return cases;
}

std::string test_name(const ::testing::TestParamInfo<DiscretizationCase>& info) {
  std::string out = info.param.label();
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return out;
}

StripSpec strip(double angle_deg) {
  StripSpec s;
  s.length_m = kLength;
  s.width_m = kWidth;
  s.cells_across = 3;
  s.cells_along = 4;
  s.angle_deg = angle_deg;
  return s;
}

class EveryDiscretization : public ::testing::TestWithParam<DiscretizationCase> {
 protected:
  std::unique_ptr<Discretization> make(const StripSpec& s, const MaterialParameters& p) const {
    return testing::create_registered<DiscretizationFactories>(registry_category::kDiscretization, GetParam().name,
                                                               GetParam().overrides, s, p);
  }

  /// True when the case models the clamps' jaws in its energy (an option `clamp_hinges` other
  /// than none): a clamp hinge measures the end's slope against the fixed platform
  /// (triangle_shell.hpp §8), so the energy is anchored in space and neither rigid-motion
  /// invariance nor the free patch test applies to it.
  bool models_jaws() const {
    for (const auto& o : GetParam().overrides)
      if (o.rfind("clamp_hinges=", 0) == 0 && o != "clamp_hinges=none") return true;
    return false;
  }
};

TEST(EveryDiscretizationRegistry, SomethingIsRegistered) {
  EXPECT_FALSE(every_discretization().empty());
}

TEST_P(EveryDiscretization, GradientMatchesFiniteDifferencesAtSecondOrder) {
  const auto d = make(strip(30), canvas_degree2());
  const VectorXd q = distorted_state(*d);
  for (unsigned seed : {11u, 12u}) testing::expect_gradient_converges(*d, q, smooth_direction(*d, seed), 1e-3, 5, 1e-6);
}

TEST_P(EveryDiscretization, HessianMatchesFiniteDifferencesOfTheGradient) {
  const auto d = make(strip(30), canvas_degree2());
  const VectorXd q = distorted_state(*d);
  for (unsigned seed : {21u, 22u})
    testing::expect_hessian_converges(*d, q, smooth_direction(*d, seed), 2e-5, 3, 1e-6, 1e-12);
}

TEST_P(EveryDiscretization, ParameterJacobianMatchesFiniteDifferencesForEveryParameter) {
  const auto d = make(strip(30), canvas_degree2());
  d->set_gravity(Vector3d(0.4, -0.3, -9.81));  // so that density enters the gradient
  const VectorXd q = distorted_state(*d);
  const testing::ParameterStepRule step = testing::relative_parameter_step;
  testing::expect_parameter_jacobian_converges(*d, q, step, 4, 1e-6);
}

/// canvas_degree2() with the law-side bending ratios away from 1 and from each other, so that
/// every entry of S and ∂S/∂b differs (core/bending_scale.hpp).
MaterialParameters anisotropic_bending() {
  MaterialParameters p = canvas_degree2();
  p.bending_warp_ratio = 2.5;
  p.bending_weft_ratio = 0.4;
  return p;
}

TEST_P(EveryDiscretization, AnisotropicBendingDerivativesMatchFiniteDifferences) {
  // The bending ratios enter every bending term: E, g, H and ∂g/∂k (the ratios' own columns
  // included) at b ≠ 1, by the same checks as at the paper's b = 1 above.
  const auto d = make(strip(30), anisotropic_bending());
  d->set_gravity(Vector3d(0.4, -0.3, -9.81));  // so that density enters the gradient
  const VectorXd q = distorted_state(*d);
  testing::expect_gradient_converges(*d, q, smooth_direction(*d, 11u), 1e-3, 5, 1e-6);
  testing::expect_hessian_converges(*d, q, smooth_direction(*d, 21u), 2e-5, 3, 1e-6, 1e-12);
  testing::expect_parameter_jacobian_converges(*d, q, testing::relative_parameter_step, 4, 1e-6);
}

/// canvas_degree2() with a nonlinear coupling curve η2 (paper Eq. 2; the paper keeps η2(x) = x).
/// Its extrapolation bound u = Ẽ11 Ẽ22 = 0 lies where Ẽ11 or Ẽ22 crosses its compression cutoff
/// 0 (material_law.hpp), a face the other terms already have; the box is open above.
MaterialParameters nonlinear_coupling() {
  MaterialParameters p = canvas_degree2();
  p.eta2 = Curve{{0.7, 0.3}, {12.0, -3.0}};
  return p;
}

TEST_P(EveryDiscretization, CouplingCurveDerivativesMatchFiniteDifferences) {
  // η2 enters every membrane term through a12's: E, g, H and ∂g/∂k (its own columns included),
  // by the same checks as the paper's linear η2 above.
  const auto d = make(strip(30), nonlinear_coupling());
  d->set_gravity(Vector3d(0.4, -0.3, -9.81));  // so that density enters the gradient
  const VectorXd q = distorted_state(*d);
  testing::expect_gradient_converges(*d, q, smooth_direction(*d, 11u), 1e-3, 5, 1e-6);
  testing::expect_hessian_converges(*d, q, smooth_direction(*d, 21u), 2e-5, 3, 1e-6, 1e-12);
  testing::expect_parameter_jacobian_converges(*d, q, testing::relative_parameter_step, 4, 1e-6);
}

TEST_P(EveryDiscretization, RigidMotionLeavesEnergyInvariantAndRotatesForcesAndHessian) {
  const auto d = make(strip(30), canvas_degree2());
  const VectorXd q = distorted_state(*d);
  if (models_jaws()) GTEST_SKIP() << "the energy holds the clamps' jaws fixed in space";
  const Matrix3d R = Eigen::AngleAxisd(0.7, Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const VectorXd moved = testing::rigidly_moved(q, R, Vector3d(0.02, -0.013, 0.4));
  VectorXd g, g_moved;
  SparseMatrix H, H_moved;
  const double e = d->energy(q, &g, &H);
  const double e_moved = d->energy(moved, &g_moved, &H_moved);
  EXPECT_GT(e, 0.0);
  EXPECT_NEAR(e_moved, e, 1e-12 * e);
  // Forces rotate with the body: g(Rq + t) = R g(q) node by node.
  const VectorXd g_rotated = testing::rigidly_moved(g, R, Vector3d::Zero());
  EXPECT_LT((g_moved - g_rotated).cwiseAbs().maxCoeff(), 1e-11 * g.cwiseAbs().maxCoeff());
  // H(Rq + t) = R H(q) Rᵀ blockwise: compare H_moved (R v) with R (H v).
  const VectorXd v = smooth_direction(*d, 5);
  const VectorXd Rv = testing::rigidly_moved(v, R, Vector3d::Zero());
  const VectorXd RHv = testing::rigidly_moved(H * v, R, Vector3d::Zero());
  EXPECT_LT((H_moved * Rv - RHv).cwiseAbs().maxCoeff(), 1e-11 * (H * v).cwiseAbs().maxCoeff());
}

TEST_P(EveryDiscretization, PatchTestUniformStrainGivesTheHomogeneousEnergyAtEveryAngle) {
  // x = R F X: in-plane stretch, contraction and shear, then a rigid rotation out of the plane.
  Eigen::Matrix<double, 3, 2> F;
  F << 1.03, 0.012, -0.004, 0.985, 0.0, 0.0;
  if (models_jaws()) GTEST_SKIP() << "the energy holds the clamps' jaws fixed in space";
  const Matrix3d R = Eigen::AngleAxisd(0.4, Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  const Eigen::Matrix<double, 3, 2> RF = R * F;
  const Eigen::Matrix2d E = 0.5 * (F.topRows<2>().transpose() * F.topRows<2>() - Eigen::Matrix2d::Identity());
  MaterialParameters p = canvas_degree2();
  p.cutoffs = Cutoffs{0.0, 0.02, 0.0, 0.05, 0.01};  // the strain is outside some bounds on purpose
  for (double angle : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    SCOPED_TRACE(angle);
    const auto d = make(strip(angle), p);
    // Orthotropic strain Ẽ = Dᵀ E D in the warp/weft frame (core/discretization.hpp).
    const double t = angle * M_PI / 180.0;
    Eigen::Matrix2d D;
    D.col(0) << -std::sin(t), std::cos(t);  // d1 warp
    D.col(1) << std::cos(t), std::sin(t);   // d2 weft
    const Eigen::Matrix2d Et = D.transpose() * E * D;
    const double exact = kLength * kWidth * p.thickness_m *
                         MaterialLaw(p).energy_density(Vector3(Et(0, 0), Et(1, 1), Et(0, 1)));
    const VectorXd& rest = d->rest_positions();
    VectorXd q(rest.size());
    for (Eigen::Index i = 0; i < rest.size() / 3; ++i)
      q.segment<3>(3 * i) = RF * rest.segment<2>(3 * i) + Vector3d(0.01, -0.02, 0.003);
    EXPECT_NEAR(d->energy(q, nullptr, nullptr), exact, 1e-12 * exact);
  }
}

TEST_P(EveryDiscretization, HessianPatternIsReusedAndRefilledExactly) {
  const auto d = make(strip(30), canvas_degree2());
  const VectorXd q = distorted_state(*d);
  SparseMatrix H;
  d->energy(q, nullptr, &H);
  const double* values = H.valuePtr();
  const int* inner = H.innerIndexPtr();
  const VectorXd q2 = q + 1e-4 * smooth_direction(*d, 3);
  d->energy(q2, nullptr, &H);
  EXPECT_EQ(H.valuePtr(), values) << "the second call must reuse the storage";
  EXPECT_EQ(H.innerIndexPtr(), inner);
  SparseMatrix fresh;
  d->energy(q2, nullptr, &fresh);
  EXPECT_EQ(SparseMatrix(H - fresh).coeffs().cwiseAbs().maxCoeff(), 0.0);
}

INSTANTIATE_TEST_SUITE_P(Registered, EveryDiscretization, ::testing::ValuesIn(every_discretization()), test_name);

}  // namespace
}  // namespace twill
