// The uniform-strain tensile strip of paper §5.3 (experiments/uniform_strain.hpp):
//   (a) dF/dk and d(lateral strain)/dk against central differences, second order, for every
//       flat parameter kind, with free and held shear and with active strain cutoffs; F against
//       the derivative of the strip energy (F = ∂Ψ/∂u, the paper's definition) and the
//       tangent stiffness against differences of F;
//   (b) orthotropic StVK: F against the closed-form off-axis modulus (exact at any strain for
//       StVK), the nonlinear law's small-strain limit, held vs free shear;
//   (c) against the Catmull–Clark shell with clamps, canvas, warp/weft/bias, 8×12;
//   (d) Gauss–Newton recovers a11 and η1 from the model's own data through FitObjective.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numbers>
#include <ostream>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/fit_objective.hpp"
#include "core/params_io.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"
#include "experiments/tensile_strip.hpp"
#include "experiments/uniform_strain.hpp"
#include "optimizers/optimizer.hpp"
#include "tests/support/program_registry.hpp"
#include "tests/support/finite_difference.hpp"

namespace twill {
namespace {

MaterialParameters canvas() {
  return read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/canvas/params.yaml");
}

constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

UniformStrainStrip strip_at(double angle_deg, UniformStrainShear shear = UniformStrainShear::Free) {
  UniformStrainStrip s;
  s.angle_deg = angle_deg;
  s.shear = shear;
  return s;
}

// ---------------------------------------------------------------------------------------------
// (a) Derivatives.

struct DerivativeCase {
  const char* name;
  double angle_deg;
  UniformStrainShear shear;
  bool cutoffs;  // strain cutoffs inside the strain range, so the §3.2 extrapolation is active
  // The curve that carries the load: the stretch curve on axis, the shear curve off axis with
  // free shear (uniaxial stress off axis is shear-dominated: held/free force ≈ 7–9 at 22.5°
  // and 67.5°, HeldShearIsStifferOffAxisAndEqualOnAxis) and in bias.
  const char* loaded_curve;
};
void PrintTo(const DerivativeCase& c, std::ostream* os) { *os << c.name; }

std::string derivative_case_name(const ::testing::TestParamInfo<DerivativeCase>& info) {
  return info.param.name;
}

/// Magnitudes of the terms of ∂ψ/∂e: ∂ψ/∂e1 = F1' + a12 e2, ∂ψ/∂e2 = F3' + a12 e1, ∂ψ/∂e3 = F4'
/// (material_law.hpp). A sum of such terms is known to a few ε of the sum of their magnitudes.
Vector3 gradient_term_magnitudes(const MaterialLaw& law, const Vector3& e) {
  Vector3 ge;
  law.energy_density(e, &ge);
  const double a12 = law.parameters().a12_Pa;
  return {std::abs(ge[0] - a12 * e[1]) + std::abs(a12 * e[1]),
          std::abs(ge[1] - a12 * e[0]) + std::abs(a12 * e[0]), std::abs(ge[2])};
}

/// Round-off amplification κ of the force at p: S_xx = Σ_i T_i0 ∂ψ/∂e_i is a sum whose terms
/// can be far larger than S_xx, and the lateral strains, exact to a few ulps, move it by
/// H_xl δE_l, which off axis is far larger than S_xx (bias: a·E against G12·E). The
/// differences' round-off floor is therefore ~κ ε |F| / h, not ε |F| / h.
double round_off_amplification(const MaterialLaw& law, const UniformStrainStrip& strip,
                               const UniformStrainPoint& p) {
  const Matrix3 t = strip_to_material_strain(strip.angle_deg);
  Vector3 ge;
  Matrix3 he;
  law.energy_density(t * p.strain, &ge, &he);
  const Vector3 g = t.transpose() * ge;
  const Matrix3 h = t.transpose() * he * t;
  const double terms = t.col(0).cwiseAbs().dot(gradient_term_magnitudes(law, t * p.strain)) +
                       std::abs(h(0, 1) * p.strain[1]) + std::abs(h(0, 2) * p.strain[2]);
  return std::max(1.0, terms / std::abs(g[0]));
}

/// check_directional_derivative (tests/support) along v with six halvings, the round-off floor
/// raised by κ (above), relative error < 1e-6.
testing::OrderCheck check_with_amplified_floor(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    const Eigen::VectorXd& v, const Eigen::VectorXd& jv, double h0, double kappa) {
  std::vector<double> errors, floors;
  const double value_scale = std::max(f(x).cwiseAbs().maxCoeff(), 1e-300);
  const double scale = std::max(jv.cwiseAbs().maxCoeff(), 1e-300);
  double h = h0;
  for (int j = 0; j <= 6; ++j, h *= 0.5) {
    const Eigen::VectorXd fd = (f(x + h * v) - f(x - h * v)) / (2.0 * h);
    errors.push_back((fd - jv).cwiseAbs().maxCoeff());
    floors.push_back(4.4e-16 * kappa * value_scale / h);
  }
  return testing::check_second_order(errors, floors, scale, 1e-6);
}

class UniformStrainDerivatives : public ::testing::TestWithParam<DerivativeCase> {};

TEST_P(UniformStrainDerivatives, ParameterDerivativesConvergeAtSecondOrder) {
  const DerivativeCase c = GetParam();
  MaterialParameters k = canvas();  // degrees 2, 3, 2: every flat kind (μ[1], μ[2], α) occurs
  if (c.cutoffs) {
    // Largest strains at 6 mm of 75 mm: E_xx ≈ 0.083; |Ẽ| of each component reaches a few %.
    k.cutoffs.E11_max = 0.02;
    k.cutoffs.E22_max = 0.02;
    k.cutoffs.E12_max = 0.01;
  }
  const UniformStrainStrip strip = strip_at(c.angle_deg, c.shear);
  const std::vector<double> extensions = {1.5, 4.0, 6.0};
  const int n = k.flat_size();
  const std::vector<std::string> names = k.parameter_names();

  auto curve = [&](const Eigen::VectorXd& flat, bool lateral) {
    MaterialParameters kk = k;
    kk.set_from_flat(flat);
    const MaterialLaw law(kk);
    Eigen::VectorXd out(static_cast<Eigen::Index>(extensions.size()));
    for (size_t i = 0; i < extensions.size(); ++i) {
      const UniformStrainPoint p = uniform_strain_tension(law, strip, extensions[i], false);
      EXPECT_TRUE(p.converged) << p.message;
      out[static_cast<Eigen::Index>(i)] = lateral ? p.lateral_strain : p.force_N;
    }
    return out;
  };
  const MaterialLaw law(k);
  Eigen::MatrixXd dforce(static_cast<Eigen::Index>(extensions.size()), n), dlateral = dforce;
  double kappa = 1.0;
  for (size_t i = 0; i < extensions.size(); ++i) {
    const UniformStrainPoint p = uniform_strain_tension(law, strip, extensions[i], true);
    ASSERT_TRUE(p.converged) << p.message;
    kappa = std::max(kappa, round_off_amplification(law, strip, p));
    ASSERT_EQ(p.dforce_dk.size(), n);
    dforce.row(static_cast<Eigen::Index>(i)) = p.dforce_dk.transpose();
    dlateral.row(static_cast<Eigen::Index>(i)) = p.dlateral_strain_dk.transpose();
  }

  const Eigen::VectorXd flat = k.to_flat();
  const Eigen::VectorXd forces = curve(flat, false);
  int truncation_checked = 0;
  for (int j = 0; j < n; ++j) {
    const Eigen::VectorXd v = Eigen::VectorXd::Unit(n, j);
    // Step 2 % of the parameter (0.02 where it is zero), halved six times: large enough that
    // the truncation error of the nonlinear columns stands above the round-off floor.
    const double h0 = 2e-2 * (flat[j] != 0 ? std::abs(flat[j]) : 1.0);
    for (bool lateral : {false, true}) {
      const Eigen::VectorXd jv = lateral ? dlateral.col(j) : dforce.col(j);
      const testing::OrderCheck check = check_with_amplified_floor(
          [&](const Eigen::VectorXd& x) { return curve(x, lateral); }, flat, v, jv, h0, kappa);
      EXPECT_TRUE(check.ok) << names[static_cast<size_t>(j)] << (lateral ? " lateral" : " force")
                            << ": " << check.report;
      if (!lateral && !check.roundoff_only) ++truncation_checked;
    }
  }
  // A column passes either with second-order convergence or, where F is linear in k_j
  // (thickness; μ; a11 on the warp axis) or independent of it (density; the bending ratios: the
  // strip does not bend; a curve whose strain lies in the quadratic compression extrapolation
  // of §3.2), by agreeing with the differences to round-off at every step. So that the test cannot pass on zeros, the curve of the
  // loaded direction must have a real sensitivity: |∂F/∂k_j|·|k_j| ≥ 1e-4 max F.
  const FlatLayout layout(k);
  const std::string curve_name = c.loaded_curve;
  const int first = curve_name == "eta1" ? layout.eta1 : curve_name == "eta3" ? layout.eta3 : layout.eta4;
  const int last = curve_name == "eta1" ? layout.eta3 : curve_name == "eta3" ? layout.eta4 : layout.eta2;
  for (int j = first; j < last; ++j)
    EXPECT_GE(dforce.col(j).cwiseAbs().maxCoeff() * std::abs(flat[j]),
              1e-4 * forces.cwiseAbs().maxCoeff())
        << names[static_cast<size_t>(j)] << " hardly moves the force: not a meaningful check";
  std::printf("[measured] uniform strain dF/dk %-18s: %d of %d columns converge at second order, "
              "the others agree to round-off (κ = %.0f)\n", c.name, truncation_checked, n, kappa);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, UniformStrainDerivatives,
    ::testing::Values(DerivativeCase{"warp_free", 90.0, UniformStrainShear::Free, false, "eta1"},
                      DerivativeCase{"weft_held", 0.0, UniformStrainShear::Held, false, "eta3"},
                      DerivativeCase{"a22_5_free", 22.5, UniformStrainShear::Free, false, "eta4"},
                      DerivativeCase{"bias_held", 45.0, UniformStrainShear::Held, false, "eta4"},
                      DerivativeCase{"a67_5_free_cutoffs", 67.5, UniformStrainShear::Free, true, "eta4"}),
    derivative_case_name);

TEST(UniformStrain, ForceIsTheDerivativeOfTheStripEnergy) {
  // Paper §5.3: F = ∂Ψ/∂(Δℓ) with Ψ the strip's energy at its (laterally relaxed) uniform
  // strain. The code computes F = W τ λ S_xx from the first Piola stress: the two must agree.
  const MaterialLaw law(canvas());
  for (double angle : {90.0, 22.5, 45.0}) {
    for (UniformStrainShear shear : {UniformStrainShear::Free, UniformStrainShear::Held}) {
      const UniformStrainStrip strip = strip_at(angle, shear);
      const double u = 3.0;
      const UniformStrainPoint p = uniform_strain_tension(law, strip, u, false);
      ASSERT_TRUE(p.converged) << p.message;
      auto energy = [&](const Eigen::VectorXd& x) {  // x: extension [m]
        return Eigen::VectorXd::Constant(
            1, uniform_strain_tension(law, strip, 1e3 * x[0], false).energy_J);
      };
      auto force = [&](const Eigen::VectorXd& x) {  // x: extension [mm]
        return Eigen::VectorXd::Constant(1, uniform_strain_tension(law, strip, x[0], false).force_N);
      };
      const Eigen::VectorXd one = Eigen::VectorXd::Ones(1);
      const testing::OrderCheck de = testing::check_directional_derivative(
          energy, Eigen::VectorXd::Constant(1, 1e-3 * u), one,
          Eigen::VectorXd::Constant(1, p.force_N), 1e-4, 4, 1e-6);
      EXPECT_TRUE(de.ok) << angle << "°: F vs dΨ/du: " << de.report;
      const testing::OrderCheck df = testing::check_directional_derivative(
          force, Eigen::VectorXd::Constant(1, u), one,
          Eigen::VectorXd::Constant(1, p.dforce_dextension_N_per_mm), 0.1, 4, 1e-6);
      EXPECT_TRUE(df.ok) << angle << "°: dF/du: " << df.report;
    }
  }
}

TEST(UniformStrain, LateralTractionVanishesToMachinePrecision) {
  const MaterialLaw law(canvas());
  for (double angle : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    for (UniformStrainShear shear : {UniformStrainShear::Free, UniformStrainShear::Held}) {
      for (double u : {0.01, 2.0, 9.0}) {
        const UniformStrainPoint p = uniform_strain_tension(law, strip_at(angle, shear), u, false);
        ASSERT_TRUE(p.converged) << angle << "° " << u << " mm: " << p.message;
        const Matrix3 t = strip_to_material_strain(angle);
        Vector3 ge;
        law.energy_density(t * p.strain, &ge);
        const Vector3 g = t.transpose() * ge;  // ∂ψ/∂(E_xx, E_yy, E_xy)
        // Machine precision: the traction is zero to a few ε of the magnitudes of the terms it
        // sums, or the strains are within a few ulps of the root (|g_l| ≲ ε Σ_m |H_lm E_m|:
        // with stiffening curves F'' ≫ F'/x, so an ulp of E moves g by more than ε·terms).
        const Vector3 terms = gradient_term_magnitudes(law, t * p.strain);
        Vector3 ge2;
        Matrix3 he;
        law.energy_density(t * p.strain, &ge2, &he);
        const Matrix3 h = t.transpose() * he * t;
        const Vector3 ulp_moves = h.cwiseAbs() * p.strain.cwiseAbs();
        EXPECT_LE(std::abs(g[1]), 8 * kEpsilon * (t.col(1).cwiseAbs().dot(terms) + ulp_moves[1]))
            << angle << "° " << u << " mm";
        if (shear == UniformStrainShear::Free) {
          EXPECT_LE(std::abs(g[2]), 8 * kEpsilon * (t.col(2).cwiseAbs().dot(terms) + ulp_moves[2]))
              << angle << "° " << u << " mm";
        } else {
          EXPECT_EQ(p.strain[2], 0.0);
        }
        EXPECT_LT(p.lateral_iterations, 120) << angle << "° " << u << " mm";
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// (b) Closed forms.

/// Orthotropic StVK with the canvas stiffnesses (a11 ≠ a22, a12 ≠ 0).
MaterialParameters stvk() {
  MaterialParameters k;
  k.thickness_m = 4.5e-4;
  k.a11_Pa = 3.0e7;
  k.a12_Pa = 1.1e7;
  k.a22_Pa = 2.2e7;
  k.G12_Pa = 4.0e5;
  return k;  // linear curves, E11_min = E22_min = 0 (the extrapolation of a quadratic is exact)
}

/// Small-strain modulus along an axis at θ from the weft, uniaxial stress (free shear).
/// Material-frame compliance of σ = [[a11, a12], [a12, a22]] ε with D = a11 a22 − a12²:
/// 1/E1 = a22/D (warp), 1/E2 = a11/D, ν12/E1 = a12/D; engineering shear modulus G12/2 (ψ has
/// G12 Ẽ12², docs/material_law.md §1). The warp axis is at φ from the strip with cos φ = sin θ:
///   1/E_θ = sin⁴θ a22/D + cos⁴θ a11/D + (2/G12 − 2 a12/D) sin²θ cos²θ.
/// At θ = 90° this is E = a11 − a12²/a22.
double off_axis_modulus(const MaterialParameters& k, double angle_deg) {
  const double th = angle_deg * std::numbers::pi / 180.0;
  const double s2 = std::pow(std::sin(th), 2), c2 = std::pow(std::cos(th), 2);
  const double d = k.a11_Pa * k.a22_Pa - k.a12_Pa * k.a12_Pa;
  return 1.0 / (s2 * s2 * k.a22_Pa / d + c2 * c2 * k.a11_Pa / d +
                (2.0 / k.G12_Pa - 2.0 * k.a12_Pa / d) * s2 * c2);
}

TEST(UniformStrain, StVKForceIsTheOffAxisModulusTimesStrain) {
  // StVK is linear in E, so uniaxial stress gives S_xx = E_θ E_xx exactly at every strain:
  // F = W τ λ E_θ E_xx up to round-off.
  const MaterialParameters k = stvk();
  const MaterialLaw law(k);
  const double area_m2 = 50e-3 * k.thickness_m;
  for (double angle : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    for (double u : {1e-3, 3.0}) {
      const UniformStrainPoint p = uniform_strain_tension(law, strip_at(angle), u, false);
      ASSERT_TRUE(p.converged) << p.message;
      const double lambda = 1.0 + u / 75.0, exx = 0.5 * (lambda * lambda - 1.0);
      const double expected = area_m2 * lambda * off_axis_modulus(k, angle) * exx;
      EXPECT_NEAR(p.force_N / expected - 1.0, 0.0, 1e-12) << angle << "° at " << u << " mm";
    }
  }
  // θ = 90° (warp along the axis): E_yy = −(a12/a22) E_xx, E = a11 − a12²/a22.
  const UniformStrainPoint warp = uniform_strain_tension(law, strip_at(90.0), 3.0, false);
  EXPECT_NEAR(warp.strain[1] / warp.strain[0], -k.a12_Pa / k.a22_Pa, 1e-14);
  EXPECT_NEAR(off_axis_modulus(k, 90.0) / (k.a11_Pa - k.a12_Pa * k.a12_Pa / k.a22_Pa), 1.0, 1e-14);
}

TEST(UniformStrain, NonlinearLawHasTheStVKModulusAtSmallStrain) {
  // η'(0) = 1 (paper §3.1): as u → 0 the canvas law's force tends to the StVK closed form with
  // the same a's. At u = 1e-3 mm (E ≈ 1.3e-5) the curves deviate by O(α E²) ≈ 1e-8.
  const MaterialParameters k = canvas();
  const MaterialLaw law(k);
  for (double angle : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    const double u = 1e-3;
    const UniformStrainPoint p = uniform_strain_tension(law, strip_at(angle), u, false);
    ASSERT_TRUE(p.converged) << p.message;
    const double lambda = 1.0 + u / 75.0, exx = 0.5 * (lambda * lambda - 1.0);
    const double expected = 50e-3 * k.thickness_m * lambda * off_axis_modulus(k, angle) * exx;
    EXPECT_NEAR(p.force_N / expected - 1.0, 0.0, 1e-6) << angle << "°";
  }
}

TEST(UniformStrain, HeldShearIsStifferOffAxisAndEqualOnAxis) {
  const MaterialLaw law(canvas());
  for (double angle : {0.0, 90.0}) {
    const UniformStrainPoint f = uniform_strain_tension(law, strip_at(angle), 5.0, false);
    const UniformStrainPoint h =
        uniform_strain_tension(law, strip_at(angle, UniformStrainShear::Held), 5.0, false);
    EXPECT_NEAR(h.force_N / f.force_N - 1.0, 0.0, 1e-13) << angle << "°";
  }
  // Off axis, holding E_xy = 0 constrains the minimisation over lateral states: the reduced
  // stiffness is larger (Schur complement), so is the force at every extension.
  for (double angle : {22.5, 67.5}) {
    const UniformStrainPoint f = uniform_strain_tension(law, strip_at(angle), 2.0, false);
    const UniformStrainPoint h =
        uniform_strain_tension(law, strip_at(angle, UniformStrainShear::Held), 2.0, false);
    EXPECT_GT(h.force_N, 1.01 * f.force_N) << angle << "°";
    std::printf("[measured] uniform strain %.1f° at 2 mm: held/free force %.4f\n", angle,
                h.force_N / f.force_N);
  }
}

// ---------------------------------------------------------------------------------------------
// The predictor.

TEST(UniformStrainPredictor, PredictsForcesAndRestrictedJacobian) {
  const MaterialParameters k = canvas();
  TensileSetup setup;
  setup.angle_deg = 67.5;
  const std::vector<double> extensions = {1.0, 3.0, 5.0};
  UniformStrainPredictor predictor("a67.5", setup, extensions, Eigen::VectorXd::Ones(3));
  const std::vector<int> flat = {FlatLayout::kThickness, FlatLayout::kG12, k.index_of("eta3.alpha[2]")};
  Eigen::VectorXd values;
  Eigen::MatrixXd jacobian;
  std::string message;
  ASSERT_TRUE(predictor.predict(k, flat, &values, &jacobian, &message)) << message;
  ASSERT_EQ(jacobian.rows(), 3);
  ASSERT_EQ(jacobian.cols(), 3);
  const MaterialLaw law(k);
  for (int i = 0; i < 3; ++i) {
    const UniformStrainPoint p = uniform_strain_tension(law, predictor.strip(), extensions[static_cast<size_t>(i)], true);
    EXPECT_NEAR(values[i] / p.force_N - 1.0, 0.0, 1e-13);
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(jacobian(i, j), p.dforce_dk[flat[static_cast<size_t>(j)]],
                  1e-12 * std::abs(p.dforce_dk[flat[static_cast<size_t>(j)]]));
  }
  EXPECT_EQ(predictor.equilibrium_solves(), 3);
  EXPECT_THROW(UniformStrainPredictor("bad", setup, {1.0, 2.0}, Eigen::VectorXd::Ones(3)),
               std::invalid_argument);
  setup.width_mm = 0;
  EXPECT_THROW(UniformStrainPredictor("bad", setup, {1.0}, Eigen::VectorXd::Ones(1)),
               std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// (c) Against the clamped shell.

DiscretizationFactory catmull_clark() {
  return [](const StripSpec& s, const MaterialParameters& p) -> std::unique_ptr<Discretization> {
    return std::make_unique<CatmullClarkKL>(s, p);
  };
}

TEST(UniformStrainVsShell, CanvasWarpWeftBiasOnTheCoarseGrid) {
  // The shell's jaws hold the full width (no lateral contraction, no shear at the clamp
  // lines): near them the strip is stiffer than the laterally free uniform state, most of all
  // in bias, where the clamps also block the shear that carries the load. Extensions: 8
  // points up to the canvas reference curves' largest (warp 9, weft 11, bias 20 mm).
  const MaterialParameters k = canvas();
  const MaterialLaw law(k);
  struct Direction {
    const char* label;
    double angle_deg, max_mm;
  };
  for (const Direction d : {Direction{"warp", 90.0, 9.0}, Direction{"weft", 0.0, 11.0},
                            Direction{"bias", 45.0, 20.0}}) {
    TensileSetup setup;
    setup.angle_deg = d.angle_deg;  // 8×12 cells by default
    std::vector<double> extensions;
    for (int i = 1; i <= 8; ++i) extensions.push_back(d.max_mm * i / 8.0);
    TensileExperiment shell(setup, catmull_clark(), k);
    const TensileCurve curve = shell.run(extensions);
    ASSERT_TRUE(curve.completed) << d.label << ": " << curve.message;
    const UniformStrainStrip strip = UniformStrainStrip::from(setup);
    std::printf("[measured] uniform strain vs 8x12 shell, canvas %s:", d.label);
    for (size_t i = 0; i < extensions.size(); ++i) {
      const UniformStrainPoint p = uniform_strain_tension(law, strip, extensions[i], false);
      ASSERT_TRUE(p.converged) << p.message;
      const double shell_force = curve.points[i].force_N;
      const double relative = p.force_N / shell_force - 1.0;
      std::printf(" %.4g mm %+.2f%% (lat %.4f vs %.4f);", extensions[i], 100.0 * relative,
                  p.lateral_strain, curve.points[i].lateral_strain);
      // The paper (§5.3) reports uniform-strain warp/weft forces within ~1 %, worst ~3 %, of
      // its full solves; on this coarse clamped strip we measure −1.4 % … −3.3 %. The bound
      // 4 % with the sign (below the shell: the jaws only add constraint) is what we assert.
      // Bias: the paper calls the approximation unreliable; it is far below the shell here.
      EXPECT_LT(p.force_N, shell_force) << d.label << " at " << extensions[i] << " mm";
      if (d.angle_deg != 45.0) {
        EXPECT_GT(relative, -0.04) << d.label << " at " << extensions[i] << " mm";
      }
    }
    std::printf("\n");
    if (d.angle_deg == 45.0) {
      // Holding the shear at zero hardly changes bias (a11 ≈ a22 makes E_xy ≈ 0 anyway).
      std::printf("[measured] bias with held shear:");
      for (size_t i = 0; i < extensions.size(); ++i) {
        const UniformStrainPoint p = uniform_strain_tension(
            law, UniformStrainStrip::from(setup, UniformStrainShear::Held), extensions[i], false);
        std::printf(" %+.2f%%", 100.0 * (p.force_N / curve.points[i].force_N - 1.0));
      }
      std::printf("\n");
    }
  }
}

TEST(UniformStrainVsShell, CanvasAgainstTheConvergedReferenceCurves) {
  // The same comparison against ../shared/data/reference/canvas (independent planar membrane
  // solutions, converged to ~0.1 % for warp/weft): separates the clamp effect from the coarse
  // mesh's. Every point of each curve; warp/weft bounded as above. Off axis, free and held
  // shear bracket the clamped strip at small strain (measured: free −80 … −94 %, held +49 …
  // −30 % at 22.5°), so only the free-shear bound is asserted there.
  const std::string dir = std::string(TWILL_SHARED_DIR) + "/data/reference/canvas/";
  const MaterialLaw law(canvas());
  struct Direction {
    const char* label;
    double angle_deg;
  };
  for (const Direction d : {Direction{"warp", 90.0}, Direction{"weft", 0.0},
                            Direction{"bias", 45.0}, Direction{"a22.5", 22.5},
                            Direction{"a67.5", 67.5}}) {
    const TensileRun run = read_tensile_run_csv(dir + "tensile-" + d.label + ".csv");
    ASSERT_FALSE(run.force_N.empty());
    double lowest = 1e300, highest = -1e300, held_lowest = 1e300, held_highest = -1e300;
    for (size_t i = 0; i < run.force_N.size(); ++i) {
      const UniformStrainPoint p =
          uniform_strain_tension(law, strip_at(d.angle_deg), run.extension_mm[i], false);
      const UniformStrainPoint held = uniform_strain_tension(
          law, strip_at(d.angle_deg, UniformStrainShear::Held), run.extension_mm[i], false);
      ASSERT_TRUE(p.converged && held.converged) << p.message << held.message;
      const double relative = p.force_N / run.force_N[i] - 1.0;
      const double held_relative = held.force_N / run.force_N[i] - 1.0;
      lowest = std::min(lowest, relative), highest = std::max(highest, relative);
      held_lowest = std::min(held_lowest, held_relative);
      held_highest = std::max(held_highest, held_relative);
      EXPECT_LT(p.force_N, run.force_N[i]) << d.label << " at " << run.extension_mm[i] << " mm";
      if (d.angle_deg == 0.0 || d.angle_deg == 90.0) {
        EXPECT_GT(relative, -0.04) << d.label << " at " << run.extension_mm[i] << " mm";
      }
    }
    std::printf("[measured] uniform strain vs converged reference, canvas %-5s (%zu points): "
                "free shear %+.1f%% … %+.1f%%, held shear %+.1f%% … %+.1f%%\n",
                d.label, run.force_N.size(), 100.0 * highest, 100.0 * lowest,
                100.0 * held_highest, 100.0 * held_lowest);
  }
}

// ---------------------------------------------------------------------------------------------
// (d) Recovery through the fit objective.

TEST(UniformStrainPredictor, GaussNewtonRecoversWarpParametersFromItsOwnData) {
  // Paper §5.3: the uniform-strain problem is solved with a full Newton-type method (here
  // Gauss–Newton on Eq. 3) to give k0. Data: the model's own warp forces for canvas (η1 of
  // degree 2); start: a11 ×1.2, α ×0.85, μ[1] + 0.05, as in test_parameter_recovery.cpp.
  const MaterialParameters truth = canvas();
  TensileSetup setup;
  setup.angle_deg = 90.0;
  std::vector<double> extensions;
  for (int i = 1; i <= 10; ++i) extensions.push_back(0.9 * i);
  UniformStrainPredictor generator("generator", setup, extensions, Eigen::VectorXd::Ones(10));
  Eigen::VectorXd forces;
  std::string message;
  ASSERT_TRUE(generator.predict(truth, {}, &forces, nullptr, &message)) << message;

  MaterialParameters start = truth;
  start.a11_Pa *= 1.2;
  for (double& a : start.eta1.alpha) a *= 0.85;
  start.eta1.mu[1] += 0.05;
  start.eta1.mu[0] -= 0.05;
  ParameterMap::Options map_options;
  map_options.tie_a12 = false;  // canvas has a12 ≠ ½ min(a11, a22): keep it as given
  ParameterMap map(start, {"a11_Pa", "eta1.*"}, map_options);
  auto predictor = std::make_shared<UniformStrainPredictor>("warp (uniform strain)", setup,
                                                            extensions, forces);
  FitObjective objective(map, {predictor});
  std::unique_ptr<Optimizer> optimizer = testing::create_registered<OptimizerFactories>(
      registry_category::kOptimizer, "gauss-newton", {"max_iterations=200"});
  const OptimizerResult result = optimizer->minimize(objective, map.initial_x());
  const MaterialParameters fitted = map.parameters(result.x);
  objective.evaluate(result.x, nullptr);

  // The η1 curve over the strains of the data (Ẽ11 up to E_xx(9 mm) ≈ 0.127).
  double curve_error = 0, curve_scale = 0;
  for (int i = 1; i <= 20; ++i) {
    const double e = 0.13 * i / 20.0;
    const double fit = evaluate_curve(fitted.eta1, e * e).value;
    const double ref = evaluate_curve(truth.eta1, e * e).value;
    curve_error += std::abs(fit - ref);
    curve_scale += std::abs(ref);
  }
  const double a11_error = fitted.a11_Pa / truth.a11_Pa - 1.0;
  std::printf("[measured] uniform-strain recovery (gauss-newton): %s, %d its, %d evals, %ld "
              "lateral solves, a11 %+.2e, η1 curve error %.2e, force error %.2e, ε %.3e\n",
              to_string(result.status).c_str(), result.summary.iterations,
              result.summary.objective_evaluations, objective.equilibrium_solves(), a11_error,
              curve_error / curve_scale, objective.average_relative_error(0),
              result.summary.final_value);
  EXPECT_TRUE(result.converged()) << result.message;
  // The data are the model's own: recovery is exact up to the optimiser's tolerances.
  EXPECT_LT(std::abs(a11_error), 1e-6);
  EXPECT_LT(curve_error / curve_scale, 1e-6);
  // Gauss–Newton stops at its default tolerances (gradient 1e-8 in scaled x), where the forces
  // agree to ~1e-8: 1e-6 leaves room for the stopping point to move with round-off.
  EXPECT_LT(objective.average_relative_error(0), 1e-6);
}

}  // namespace
}  // namespace twill
