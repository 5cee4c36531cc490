// Tests of the material law (paper Eq. 2, §3.1–3.2; docs/model.md §2–4).
#include "core/material_law.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/support/finite_difference.hpp"

namespace twill {
namespace {

using testing::check_directional_derivative;

/// A nonlinear law with curves of degree 2, 3 and 2, a negative μ, a tiny α (series path)
/// and a large one, a nonlinear coupling curve η2 (degree 2, a negative α), and cutoffs on.
MaterialParameters nonlinear_parameters() {
  MaterialParameters p;
  p.a11_Pa = 3e7;
  p.a12_Pa = 1.1e7;
  p.a22_Pa = 2.2e7;
  p.G12_Pa = 4e5;
  p.eta1 = Curve{{1.3, -0.3}, {2.0, 40.0}};
  p.eta3 = Curve{{0.5, 0.3, 0.2}, {1e-7, 12.0, 30.0}};
  p.eta4 = Curve{{0.7, 0.3}, {5.0, -3.0}};
  p.eta2 = Curve{{0.8, 0.2}, {25.0, -4.0}};
  p.cutoffs = Cutoffs{0.0, 0.06, 0.0, 0.08, 0.2};
  return p;
}

/// The interval of u = Ẽ11 Ẽ22 over nonlinear_parameters()' box (the coupling curve's own
/// cutoffs, material_law.hpp): its corner products.
constexpr double kProductMin = 0.0, kProductMax = 0.06 * 0.08;

/// Strains inside the box, outside each bound, and outside several at once.
std::vector<Vector3> strain_samples() {
  std::vector<Vector3> out = {
      {0.03, 0.05, 0.1},     // inside
      {0.09, 0.05, 0.1},     // above E11_max
      {-0.02, 0.04, -0.15},  // below E11_min (compression)
      {0.03, 0.12, 0.05},    // above E22_max
      {0.02, -0.03, 0.3},    // below E22_min, above E12_max
      {0.1, 0.11, -0.35},    // outside in all three
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.15), s(-0.35, 0.35);
  for (int i = 0; i < 6; ++i) out.push_back({u(rng), u(rng), s(rng)});
  return out;
}

/// Steps away from each sample whose central difference does not cross a cutoff: the law is
/// only C² there, so a difference across the bound is not O(h²) (its third derivative jumps).
double safe_step(const MaterialParameters& p, const Vector3& e) {
  double h = 1e-3;
  auto keep_away = [&h](double x, const std::optional<double>& b) {
    if (b) h = std::min(h, 0.25 * std::abs(x - *b));
  };
  keep_away(e[0], p.cutoffs.E11_min);
  keep_away(e[0], p.cutoffs.E11_max);
  keep_away(e[1], p.cutoffs.E22_min);
  keep_away(e[1], p.cutoffs.E22_max);
  keep_away(e[2], p.cutoffs.E12_max);
  if (p.cutoffs.E12_max) h = std::min(h, 0.25 * std::abs(e[2] + *p.cutoffs.E12_max));
  // u = Ẽ11 Ẽ22 moves by about (|Ẽ11| + |Ẽ22|) h.
  const double speed = std::abs(e[0]) + std::abs(e[1]);
  for (const double bound : {kProductMin, kProductMax})
    if (speed > 0) h = std::min(h, 0.25 * std::abs(e[0] * e[1] - bound) / speed);
  return h;
}

TEST(MaterialLaw, GradientAndHessianConvergeAtSecondOrder) {
  const MaterialParameters p = nonlinear_parameters();
  const MaterialLaw law(p);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  int genuinely_nonlinear = 0;
  for (const Vector3& e : strain_samples()) {
    const Eigen::VectorXd v = Vector3(n(rng), n(rng), n(rng)).normalized();
    Vector3 g;
    Matrix3 H;
    law.energy_density(e, &g, &H);
    const double h = safe_step(p, e);
    auto value = [&](const Eigen::VectorXd& x) {
      return Eigen::VectorXd::Constant(1, law.energy_density(x));
    };
    auto gradient = [&](const Eigen::VectorXd& x) {
      Vector3 gx;
      law.energy_density(x, &gx);
      return Eigen::VectorXd(gx);
    };
    const auto cg = check_directional_derivative(value, e, v, Eigen::VectorXd::Constant(1, g.dot(v)), h);
    EXPECT_TRUE(cg.ok) << "gradient at " << e.transpose() << ": " << cg.report;
    const auto ch = check_directional_derivative(gradient, e, v, H * v, h);
    EXPECT_TRUE(ch.ok) << "Hessian at " << e.transpose() << ": " << ch.report;
    if (!ch.roundoff_only) ++genuinely_nonlinear;
  }
  // Outside the box in every component the law is its quadratic Taylor polynomial, which
  // central differences reproduce exactly; most samples must exercise the nonlinear curves.
  EXPECT_GE(genuinely_nonlinear, 8);
}

TEST(MaterialLaw, ParameterDerivativesConvergeAtSecondOrder) {
  const MaterialParameters p = nonlinear_parameters();
  const MaterialLaw law(p);
  const Eigen::VectorXd k0 = p.to_flat();
  const auto names = p.parameter_names();
  for (const Vector3& e : strain_samples()) {
    Eigen::VectorXd dpsi;
    StrainParameterMatrix mixed;
    law.parameter_derivatives(e, &dpsi, &mixed);
    ASSERT_EQ(dpsi.size(), k0.size());
    ASSERT_EQ(mixed.cols(), k0.size());
    for (int j = 2; j < k0.size(); ++j) {  // density and thickness do not enter ψ
      // The law's response to each parameter, as a function of that parameter alone.
      auto at = [&](double kj) {
        Eigen::VectorXd k = k0;
        k[j] = kj;
        MaterialParameters pj = p;
        pj.set_from_flat(k);
        return MaterialLaw(pj);
      };
      auto value = [&](const Eigen::VectorXd& x) {
        return Eigen::VectorXd::Constant(1, at(x[0]).energy_density(e));
      };
      auto gradient = [&](const Eigen::VectorXd& x) {
        Vector3 g;
        at(x[0]).energy_density(e, &g);
        return Eigen::VectorXd(g);
      };
      const Eigen::VectorXd x0 = Eigen::VectorXd::Constant(1, k0[j]);
      const Eigen::VectorXd one = Eigen::VectorXd::Ones(1);
      // Step relative to the parameter's size; linear parameters (the stiffnesses, a12 and
      // the μ's) are differenced exactly, so only their error level is checked there.
      const double h = 1e-2 * std::max(std::abs(k0[j]), 1.0);
      const auto cv = check_directional_derivative(value, x0, one, Eigen::VectorXd::Constant(1, dpsi[j]), h);
      EXPECT_TRUE(cv.ok) << names[static_cast<size_t>(j)] << " at " << e.transpose() << ": " << cv.report;
      const auto cm = check_directional_derivative(gradient, x0, one, mixed.col(j), h);
      EXPECT_TRUE(cm.ok) << "mixed " << names[static_cast<size_t>(j)] << " at " << e.transpose() << ": " << cm.report;
    }
  }
}

TEST(MaterialLaw, AlphaDerivativesAreNonlinearAndChecked) {
  // Guard against the parameter test passing only through exactly-differenced entries:
  // α enters nonlinearly, so its finite differences must show genuine second-order decay.
  const MaterialParameters p = nonlinear_parameters();
  const MaterialLaw law(p);
  const Vector3 e(0.03, 0.05, 0.1);
  Eigen::VectorXd dpsi;
  law.parameter_derivatives(e, &dpsi, nullptr);
  const int j = p.index_of("eta1.alpha[1]");
  auto value = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd k = p.to_flat();
    k[j] = x[0];
    MaterialParameters pj = p;
    pj.set_from_flat(k);
    return Eigen::VectorXd::Constant(1, MaterialLaw(pj).energy_density(e));
  };
  const auto c = check_directional_derivative(value, Eigen::VectorXd::Constant(1, 40.0),
                                              Eigen::VectorXd::Ones(1),
                                              Eigen::VectorXd::Constant(1, dpsi[j]), 0.5);
  EXPECT_TRUE(c.ok) << c.report;
  EXPECT_FALSE(c.roundoff_only) << c.report;
}

TEST(MaterialLaw, ValueGradientHessianContinuousAcrossEachCutoff) {
  const MaterialParameters p = nonlinear_parameters();
  const MaterialLaw law(p);
  const Vector3 base(0.03, 0.05, 0.1);
  struct Bound {
    int component;
    double value;
  };
  // ... and the coupling curve's upper bound in u = Ẽ11 Ẽ22, crossed along Ẽ11 at Ẽ22 = 0.05.
  const std::vector<Bound> bounds = {{0, 0.0}, {0, 0.06}, {1, 0.0}, {1, 0.08}, {2, 0.2}, {2, -0.2},
                                     {0, kProductMax / base[1]}};
  for (const Bound& b : bounds) {
    double previous_jump = std::numeric_limits<double>::infinity();
    for (double delta : {1e-4, 1e-6, 1e-8}) {
      Vector3 below = base, above = base;
      below[b.component] = b.value - delta;
      above[b.component] = b.value + delta;
      Vector3 gb, ga;
      Matrix3 Hb, Ha;
      const double vb = law.energy_density(below, &gb, &Hb);
      const double va = law.energy_density(above, &ga, &Ha);
      const double scale = Hb.cwiseAbs().maxCoeff();
      // Jumps across the bound: value and gradient differ by the O(δ) change over 2δ, the
      // Hessian by O(δ) only because the inside curve's third derivative is finite (C²).
      EXPECT_LE(std::abs(va - vb), 2.0 * delta * std::max(ga.norm(), gb.norm()) * 1.01 + 1e-12)
          << "value jump at component " << b.component << " bound " << b.value;
      const double column = std::max(Ha.col(b.component).norm(), Hb.col(b.component).norm());
      EXPECT_LE((ga - gb).norm(), 2.0 * delta * column * 1.01 + 1e-9)
          << "gradient jump at component " << b.component << " bound " << b.value;
      const double hessian_jump = (Ha - Hb).norm() / scale;
      EXPECT_LT(hessian_jump, 1e3 * delta + 1e-12)
          << "Hessian jump at component " << b.component << " bound " << b.value;
      EXPECT_LE(hessian_jump, previous_jump);
      previous_jump = hessian_jump;
    }
  }
}

TEST(MaterialLaw, OrthotropicSymmetryInShear) {
  const MaterialLaw law(nonlinear_parameters());
  for (const Vector3& e : strain_samples()) {
    Vector3 mirrored = e;
    mirrored[2] = -e[2];
    Vector3 g, gm;
    Matrix3 H, Hm;
    const double v = law.energy_density(e, &g, &H);
    const double vm = law.energy_density(mirrored, &gm, &Hm);
    EXPECT_DOUBLE_EQ(v, vm);
    EXPECT_DOUBLE_EQ(g[0], gm[0]);
    EXPECT_DOUBLE_EQ(g[1], gm[1]);
    EXPECT_DOUBLE_EQ(g[2], -gm[2]);
    EXPECT_DOUBLE_EQ(H(2, 2), Hm(2, 2));
  }
}

double stvk_closed_form(const MaterialParameters& p, const Vector3& e) {
  return 0.5 * p.a11_Pa * e[0] * e[0] + p.a12_Pa * e[0] * e[1] + 0.5 * p.a22_Pa * e[1] * e[1] +
         p.G12_Pa * e[2] * e[2];
}

TEST(MaterialLaw, LinearCurvesAreOrthotropicStVenantKirchhoff) {
  MaterialParameters p = nonlinear_parameters();
  p.eta1 = p.eta3 = p.eta4 = p.eta2 = Curve::linear();
  p.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  const MaterialLaw law(p);
  for (const Vector3& e : strain_samples()) {
    Vector3 g;
    Matrix3 H;
    const double v = law.energy_density(e, &g, &H);
    EXPECT_NEAR(v, stvk_closed_form(p, e), 1e-12 * std::abs(stvk_closed_form(p, e)) + 1e-9);
    Matrix3 C;
    C << p.a11_Pa, p.a12_Pa, 0, p.a12_Pa, p.a22_Pa, 0, 0, 0, 2 * p.G12_Pa;
    EXPECT_LT((H - C).norm(), 1e-9 * C.norm());
    EXPECT_LT((g - C * e).norm(), 1e-9 * (C * e).norm() + 1e-9);
  }
  // The same holds with the default compression cutoffs (E11_min = E22_min = 0): the
  // quadratic extrapolation of a quadratic term is the term itself.
  p.cutoffs = Cutoffs{};
  const MaterialLaw with_box(p);
  for (const Vector3& e : strain_samples())
    EXPECT_NEAR(with_box.energy_density(e), stvk_closed_form(p, e), 1e-9 * std::abs(stvk_closed_form(p, e)) + 1e-9);
}

TEST(MaterialLaw, DegreeOneAlphaOneAndRepeatedAlphaOneAreStVK) {
  MaterialParameters p = nonlinear_parameters();
  p.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  p.eta1 = Curve{{1.0}, {1.0}};
  p.eta3 = Curve{{0.4, 0.6}, {1.0, 1.0}};  // any split of Σμ = 1 over α = 1 is linear
  p.eta4 = Curve{{1.0}, {1.0}};
  p.eta2 = Curve{{0.3, 0.7}, {1.0, 1.0}};  // linear, but not Curve::linear(): the general coupling path
  const MaterialLaw law(p);
  for (const Vector3& e : strain_samples())
    EXPECT_NEAR(law.energy_density(e), stvk_closed_form(p, e), 1e-12 * std::abs(stvk_closed_form(p, e)) + 1e-9);
}

TEST(MaterialLaw, CurveSlopeAtZeroIsOne) {
  // Σμ = 1 ⇔ η'(0) = 1 (paper §3.1): the a's are the small-strain stiffnesses.
  const MaterialParameters p = nonlinear_parameters();
  for (const Curve& c : {p.eta1, p.eta3, p.eta4, p.eta2}) {
    const CurveValue v = evaluate_curve(c, 0.0);
    EXPECT_NEAR(v.value, 0.0, 1e-15);
    EXPECT_NEAR(v.d1, 1.0, 1e-14);
  }
}

TEST(MaterialLaw, AlphaToZeroIsTheLogarithmLimit) {
  // η(x) = μ/α((x+1)^α − 1) → μ log(1+x) as α → 0; no division by zero at α = 0 exactly,
  // and no jump where the evaluation switches to the series.
  for (double x : {0.01, 0.3, 2.0}) {
    const double L = std::log1p(x);
    const CurveValue at_zero = evaluate_curve(Curve{{1.0}, {0.0}}, x);
    EXPECT_NEAR(at_zero.value, L, 1e-15);
    EXPECT_NEAR(at_zero.d1, 1.0 / (1.0 + x), 1e-15);
    EXPECT_NEAR(at_zero.d2, -1.0 / ((1.0 + x) * (1.0 + x)), 1e-15);
    for (double z : {0.999e-3, 1.001e-3}) {  // either side of the series threshold |αL| = 1e-3
      const double alpha = z / L;
      const double exact = (std::pow(1.0 + x, alpha) - 1.0) / alpha;
      EXPECT_NEAR(evaluate_curve(Curve{{1.0}, {alpha}}, x).value, exact, 1e-13 * std::abs(exact));
    }
  }
}

// The coupling term's extrapolation (material_law.hpp, docs/material_law.md §3a): η2 is
// univariate in u = Ẽ11 Ẽ22, extrapolated outside u's interval over the box. Where one strain is
// compressed below its cutoff 0 and the other inside the box — a strip's lateral contraction —
// u < 0 and η2 enters only through η2'(0) = 1 and η2''(0) = Σ μ(α − 1): two curves with the same
// η2''(0) give the same law there, and differ where u lies inside its interval. This is why a
// strip's lateral strain can identify η2's curvature at 0 but not a higher degree.
TEST(MaterialLaw, BelowTheCompressionCutoffTheCouplingSeesOnlyItsCurvatureAtZero) {
  MaterialParameters a = nonlinear_parameters(), b = a;
  a.eta2 = Curve{{1.0}, {4.0}};             // η2''(0) = 3
  b.eta2 = Curve{{0.5, 0.5}, {2.0, 6.0}};   // η2''(0) = 0.5·1 + 0.5·5 = 3
  const MaterialLaw la(a), lb(b);
  auto expect_same = [&](const Vector3& e, bool same) {
    Vector3 ga, gb;
    Matrix3 Ha, Hb;
    const double va = la.energy_density(e, &ga, &Ha), vb = lb.energy_density(e, &gb, &Hb);
    const double gap = std::abs(va - vb) + (ga - gb).norm() + (Ha - Hb).norm();
    if (same)
      EXPECT_LT(gap, 1e-12 * Ha.norm()) << e.transpose();
    else
      EXPECT_GT(gap, 1e-6 * Ha.norm()) << e.transpose();
  };
  expect_same(Vector3(0.05, -0.02, 0.1), true);   // a warp strip's contraction
  expect_same(Vector3(-0.03, 0.07, -0.1), true);  // a weft strip's
  expect_same(Vector3(0.05, 0.07, 0.1), false);   // both stretched: u inside (0, 0.0048)
}

TEST(MaterialLaw, SmallStrainStiffnessesAreTheAs) {
  // ∂²ψ/∂e² at e = 0 is the orthotropic StVK stiffness for any curves (η'(0) = 1).
  const MaterialParameters p = nonlinear_parameters();
  const MaterialLaw law(p);
  Matrix3 H;
  Vector3 g;
  law.energy_density(Vector3::Zero(), &g, &H);
  EXPECT_EQ(g.norm(), 0.0);
  EXPECT_NEAR(H(0, 0), p.a11_Pa, 1e-9 * p.a11_Pa);
  EXPECT_NEAR(H(1, 1), p.a22_Pa, 1e-9 * p.a22_Pa);
  EXPECT_NEAR(H(0, 1), p.a12_Pa, 1e-9 * p.a12_Pa);
  EXPECT_NEAR(H(2, 2), 2.0 * p.G12_Pa, 1e-9 * p.G12_Pa);
}

}  // namespace
}  // namespace twill
