#include "core/material_law.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

namespace twill {
namespace {

// φ1(z) = (e^z − 1)/z and φ2(z) = dφ1/dz = (z e^z − e^z + 1)/z², both analytic at z = 0.
// g(α, s) = ((1+s)^α − 1)/α = L φ1(αL) and ∂g/∂α = L² φ2(αL) with L = log(1+s): this is how
// α → 0 (the limit μ log(1+s)) is evaluated without dividing by zero.
constexpr double kSeriesBelow = 1e-3;

double phi1(double z) {
  if (std::abs(z) < kSeriesBelow) return 1.0 + z / 2.0 + z * z / 6.0 + z * z * z / 24.0;
  return std::expm1(z) / z;
}

double phi2(double z) {
  if (std::abs(z) < kSeriesBelow) return 0.5 + z / 3.0 + z * z / 8.0 + z * z * z / 30.0;
  return (z * std::exp(z) - std::expm1(z)) / (z * z);
}

/// One term F(x) = c·η(x²) of ψ (c = a11/2, a22/2 or G12) and its parameter derivatives,
/// before extrapolation. Derivative blocks: [coefficient, mu[1..d-1], alpha[0..d-1]].
struct TermDerivatives {
  double value = 0, d1 = 0, d2 = 0;  // F, F', F''
  // ∂/∂(coefficient parameter) and ∂/∂(curve parameters) of F, F', F''.
  double dcoef[3] = {0, 0, 0};
  std::vector<double> dcurve[3];
};

/// F(x) = c·η(s), s = x²: F' = 2c·x·η'(s), F'' = 2c·(η'(s) + 2s·η''(s)).
/// `coef_scale` is ∂c/∂(stiffness parameter): ½ for a11, a22 and 1 for G12.
TermDerivatives term_at(const Curve& curve, double c, double coef_scale, double x,
                        bool want_parameters) {
  const double s = x * x;
  const double L = std::log1p(s);
  const int d = curve.degree();
  double eta = 0, eta1 = 0, eta2 = 0;
  for (int i = 0; i < d; ++i) {
    const double mu = curve.mu[static_cast<size_t>(i)], al = curve.alpha[static_cast<size_t>(i)];
    const double p = std::exp((al - 1.0) * L);  // (1+s)^(α−1)
    eta += mu * L * phi1(al * L);
    eta1 += mu * p;
    eta2 += mu * (al - 1.0) * p / (1.0 + s);
  }
  TermDerivatives t;
  t.value = c * eta;
  t.d1 = 2.0 * c * x * eta1;
  t.d2 = 2.0 * c * (eta1 + 2.0 * s * eta2);
  if (!want_parameters) return t;

  t.dcoef[0] = coef_scale * eta;
  t.dcoef[1] = coef_scale * 2.0 * x * eta1;
  t.dcoef[2] = coef_scale * 2.0 * (eta1 + 2.0 * s * eta2);
  const int n = 2 * d - 1;
  for (auto& v : t.dcurve) v.assign(static_cast<size_t>(n), 0.0);
  // Per-term pieces of η, η', η'' with unit weight: g_i, p_i, (α_i − 1) p_i / (1+s).
  auto g = [&](int i) { return L * phi1(curve.alpha[static_cast<size_t>(i)] * L); };
  auto p = [&](int i) { return std::exp((curve.alpha[static_cast<size_t>(i)] - 1.0) * L); };
  auto q = [&](int i) { return (curve.alpha[static_cast<size_t>(i)] - 1.0) * p(i) / (1.0 + s); };
  // μ_j for j ≥ 1 with μ_0 = 1 − Σ_{j≥1} μ_j: ∂η/∂μ_j = g_j − g_0 (likewise η', η'').
  for (int j = 1; j < d; ++j) {
    const auto k = static_cast<size_t>(j - 1);
    const double de = g(j) - g(0), de1 = p(j) - p(0), de2 = q(j) - q(0);
    t.dcurve[0][k] = c * de;
    t.dcurve[1][k] = 2.0 * c * x * de1;
    t.dcurve[2][k] = 2.0 * c * (de1 + 2.0 * s * de2);
  }
  // α_i: ∂g/∂α = L² φ2(αL), ∂p/∂α = L p, ∂q/∂α = (p + (α − 1) L p)/(1+s).
  for (int i = 0; i < d; ++i) {
    const auto k = static_cast<size_t>(d - 1 + i);
    const double mu = curve.mu[static_cast<size_t>(i)], al = curve.alpha[static_cast<size_t>(i)];
    const double pi = p(i);
    const double de = mu * L * L * phi2(al * L);
    const double de1 = mu * L * pi;
    const double de2 = mu * (pi + (al - 1.0) * L * pi) / (1.0 + s);
    t.dcurve[0][k] = c * de;
    t.dcurve[1][k] = 2.0 * c * x * de1;
    t.dcurve[2][k] = 2.0 * c * (de1 + 2.0 * s * de2);
  }
  return t;
}

/// Applies the second-order Taylor extrapolation of §3.2 to one univariate term: outside
/// [lo, hi] the term is F(b) + F'(b) δ + ½F''(b) δ² about the violated bound b, δ = x − b.
/// Every derivative (in x and in the parameters) follows from the same expansion.
TermDerivatives extrapolated_term(const Curve& curve, double c, double coef_scale, double x,
                                  double lo, double hi, bool want_parameters) {
  const double b = std::clamp(x, lo, hi);
  TermDerivatives t = term_at(curve, c, coef_scale, b, want_parameters);
  if (b == x) return t;
  const double delta = x - b;
  auto expand = [delta](double& f, double& f1, double f2) {
    f += f1 * delta + 0.5 * f2 * delta * delta;
    f1 += f2 * delta;
  };
  expand(t.value, t.d1, t.d2);
  if (want_parameters) {
    expand(t.dcoef[0], t.dcoef[1], t.dcoef[2]);
    for (size_t k = 0; k < t.dcurve[0].size(); ++k)
      expand(t.dcurve[0][k], t.dcurve[1][k], t.dcurve[2][k]);
  }
  return t;
}

double lower(const std::optional<double>& v) {
  return v ? *v : -std::numeric_limits<double>::infinity();
}
double upper(const std::optional<double>& v) {
  return v ? *v : std::numeric_limits<double>::infinity();
}

}  // namespace

CurveValue evaluate_curve(const Curve& c, double x) {
  assert(x > -1.0);
  const double L = std::log1p(x);
  CurveValue v;
  for (int i = 0; i < c.degree(); ++i) {
    const double mu = c.mu[static_cast<size_t>(i)], al = c.alpha[static_cast<size_t>(i)];
    const double p = std::exp((al - 1.0) * L);
    v.value += mu * L * phi1(al * L);
    v.d1 += mu * p;
    v.d2 += mu * (al - 1.0) * p / (1.0 + x);
  }
  return v;
}

MaterialLaw::MaterialLaw(const MaterialParameters& parameters)
    : parameters_(parameters), layout_(parameters), bending_scale_(twill::bending_scale(parameters)) {}

namespace {
struct ThreeTerms {
  TermDerivatives warp, weft, shear;
};

ThreeTerms evaluate_terms(const MaterialParameters& p, const Vector3& e, bool want_parameters) {
  const Cutoffs& box = p.cutoffs;
  const double shear_max = upper(box.E12_max);
  return {extrapolated_term(p.eta1, 0.5 * p.a11_Pa, 0.5, e[0], lower(box.E11_min),
                            upper(box.E11_max), want_parameters),
          extrapolated_term(p.eta3, 0.5 * p.a22_Pa, 0.5, e[1], lower(box.E22_min),
                            upper(box.E22_max), want_parameters),
          extrapolated_term(p.eta4, p.G12_Pa, 1.0, e[2], -shear_max, shear_max, want_parameters)};
}
}  // namespace

double MaterialLaw::energy_density(const Vector3& e, Vector3* gradient, Matrix3* hessian) const {
  const ThreeTerms t = evaluate_terms(parameters_, e, false);
  const double a12 = parameters_.a12_Pa;
  // η2(x) = x: the coupling term a12·Ẽ11·Ẽ22 is bilinear, so it is its own Taylor expansion.
  if (gradient) *gradient << t.warp.d1 + a12 * e[1], t.weft.d1 + a12 * e[0], t.shear.d1;
  if (hessian) {
    *hessian << t.warp.d2, a12, 0.0,  //
        a12, t.weft.d2, 0.0,          //
        0.0, 0.0, t.shear.d2;
  }
  return t.warp.value + t.weft.value + t.shear.value + a12 * e[0] * e[1];
}

void MaterialLaw::parameter_derivatives(const Vector3& e, Eigen::VectorXd* dpsi_dk,
                                        StrainParameterMatrix* d2psi_de_dk) const {
  const ThreeTerms t = evaluate_terms(parameters_, e, true);
  const int n = layout_.size;
  Eigen::VectorXd dpsi = Eigen::VectorXd::Zero(n);
  StrainParameterMatrix mixed = StrainParameterMatrix::Zero(3, n);

  dpsi[FlatLayout::kA12] = e[0] * e[1];
  mixed(0, FlatLayout::kA12) = e[1];
  mixed(1, FlatLayout::kA12) = e[0];

  // Each univariate term depends on one strain component (row) and its own parameter block.
  auto scatter = [&](const TermDerivatives& term, int row, int coef_index, int curve_offset) {
    dpsi[coef_index] = term.dcoef[0];
    mixed(row, coef_index) = term.dcoef[1];
    for (size_t k = 0; k < term.dcurve[0].size(); ++k) {
      dpsi[curve_offset + static_cast<int>(k)] = term.dcurve[0][k];
      mixed(row, curve_offset + static_cast<int>(k)) = term.dcurve[1][k];
    }
  };
  scatter(t.warp, 0, FlatLayout::kA11, layout_.eta1);
  scatter(t.weft, 1, FlatLayout::kA22, layout_.eta3);
  scatter(t.shear, 2, FlatLayout::kG12, layout_.eta4);

  if (dpsi_dk) *dpsi_dk = std::move(dpsi);
  if (d2psi_de_dk) *d2psi_de_dk = std::move(mixed);
}

}  // namespace twill
