#include "core/material_law.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>
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

/// One curve at u: η, η', η'' and, with parameters, their derivatives in the curve's flat
/// entries [mu[1..d-1], alpha[0..d-1]] (parameters.hpp; μ_0 = 1 − Σ_{j≥1} μ_j is dependent).
struct CurveDerivatives {
  double eta = 0, eta1 = 0, eta2 = 0;  // η, η', η''
  std::vector<double> d[3];            // ∂/∂entry of η, η', η''
};

CurveDerivatives curve_at(const Curve& curve, double u, bool want_parameters) {
  const double L = std::log1p(u);
  const int d = curve.degree();
  CurveDerivatives out;
  for (int i = 0; i < d; ++i) {
    const double mu = curve.mu[static_cast<size_t>(i)], al = curve.alpha[static_cast<size_t>(i)];
    const double p = std::exp((al - 1.0) * L);  // (1+u)^(α−1)
    out.eta += mu * L * phi1(al * L);
    out.eta1 += mu * p;
    out.eta2 += mu * (al - 1.0) * p / (1.0 + u);
  }
  if (!want_parameters) return out;
  const int n = 2 * d - 1;
  for (auto& v : out.d) v.assign(static_cast<size_t>(n), 0.0);
  // Per-term pieces of η, η', η'' with unit weight: g_i, p_i, (α_i − 1) p_i / (1+u).
  auto g = [&](int i) { return L * phi1(curve.alpha[static_cast<size_t>(i)] * L); };
  auto p = [&](int i) { return std::exp((curve.alpha[static_cast<size_t>(i)] - 1.0) * L); };
  auto q = [&](int i) { return (curve.alpha[static_cast<size_t>(i)] - 1.0) * p(i) / (1.0 + u); };
  // μ_j for j ≥ 1 with μ_0 = 1 − Σ_{j≥1} μ_j: ∂η/∂μ_j = g_j − g_0 (likewise η', η'').
  for (int j = 1; j < d; ++j) {
    const auto k = static_cast<size_t>(j - 1);
    out.d[0][k] = g(j) - g(0);
    out.d[1][k] = p(j) - p(0);
    out.d[2][k] = q(j) - q(0);
  }
  // α_i: ∂g/∂α = L² φ2(αL), ∂p/∂α = L p, ∂q/∂α = (p + (α − 1) L p)/(1+u).
  for (int i = 0; i < d; ++i) {
    const auto k = static_cast<size_t>(d - 1 + i);
    const double mu = curve.mu[static_cast<size_t>(i)], al = curve.alpha[static_cast<size_t>(i)];
    const double pi = p(i);
    out.d[0][k] = mu * L * L * phi2(al * L);
    out.d[1][k] = mu * L * pi;
    out.d[2][k] = mu * (pi + (al - 1.0) * L * pi) / (1.0 + u);
  }
  return out;
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
  CurveDerivatives h = curve_at(curve, s, want_parameters);
  TermDerivatives t;
  t.value = c * h.eta;
  t.d1 = 2.0 * c * x * h.eta1;
  t.d2 = 2.0 * c * (h.eta1 + 2.0 * s * h.eta2);
  if (!want_parameters) return t;

  t.dcoef[0] = coef_scale * h.eta;
  t.dcoef[1] = coef_scale * 2.0 * x * h.eta1;
  t.dcoef[2] = coef_scale * 2.0 * (h.eta1 + 2.0 * s * h.eta2);
  for (int k = 0; k < 3; ++k) t.dcurve[k] = std::move(h.d[k]);  // chained in place: no copies
  for (size_t k = 0; k < t.dcurve[0].size(); ++k) {
    const double de1 = t.dcurve[1][k], de2 = t.dcurve[2][k];
    t.dcurve[0][k] = c * t.dcurve[0][k];
    t.dcurve[1][k] = 2.0 * c * x * de1;
    t.dcurve[2][k] = 2.0 * c * (de1 + 2.0 * s * de2);
  }
  return t;
}

/// The second-order Taylor polynomial at a bound b, evaluated δ past it (§3.2): from
/// (f, f', f'') at b, f ← f + f' δ + ½ f'' δ² and f' ← f' + f'' δ (f'' is unchanged). Every
/// extrapolated quantity — a term, a curve of u, and their parameter derivatives — uses it.
void taylor_past_bound(double delta, double& f, double& f1, double f2) {
  f += f1 * delta + 0.5 * f2 * delta * delta;
  f1 += f2 * delta;
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
  taylor_past_bound(delta, t.value, t.d1, t.d2);
  if (want_parameters) {
    taylor_past_bound(delta, t.dcoef[0], t.dcoef[1], t.dcoef[2]);
    for (size_t k = 0; k < t.dcurve[0].size(); ++k)
      taylor_past_bound(delta, t.dcurve[0][k], t.dcurve[1][k], t.dcurve[2][k]);
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
  const CurveDerivatives h = curve_at(c, x, false);
  return {h.eta, h.eta1, h.eta2};
}

MaterialLaw::MaterialLaw(const MaterialParameters& parameters)
    : parameters_(parameters),
      layout_(parameters),
      bending_scale_(twill::bending_scale(parameters)),
      coupling_shape_(parameters) {}

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

/// A function of (Ẽ11, Ẽ22) at one strain: value, gradient and Hessian.
struct Bivariate {
  double value = 0;
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
  Eigen::Matrix2d hessian = Eigen::Matrix2d::Zero();
};

/// The interval of u = Ẽ11·Ẽ22 over the validity box: its extreme corner products (u is
/// bilinear). An "off" bound is ±∞; a zero bound keeps its products at 0 (0·∞ counts as 0).
std::pair<double, double> product_interval(const Cutoffs& box) {
  const double e11[2] = {lower(box.E11_min), upper(box.E11_max)};
  const double e22[2] = {lower(box.E22_min), upper(box.E22_max)};
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const double x : e11)
    for (const double y : e22) {
      const double product = (x == 0.0 || y == 0.0) ? 0.0 : x * y;
      lo = std::min(lo, product);
      hi = std::max(hi, product);
    }
  return {lo, hi};
}

}  // namespace

CouplingShape::CouplingShape(const MaterialParameters& p) : linear(p.eta2 == Curve::linear()) {
  std::tie(product_lo, product_hi) = product_interval(p.cutoffs);
}

namespace {

/// c·h(u), u = Ẽ11 Ẽ22, from (h, h', h'') at u: ∇ = c h' w, H = c (h'' w wᵀ + h' [[0, 1], [1, 0]]),
/// w = ∂u/∂(Ẽ11, Ẽ22) = (Ẽ22, Ẽ11).
Bivariate of_product(double c, double h, double h1, double h2, const Vector3& e) {
  const Eigen::Vector2d w(e[1], e[0]);
  Bivariate out;
  out.value = c * h;
  out.gradient = c * h1 * w;
  out.hessian = c * h2 * w * w.transpose();
  out.hessian(0, 1) += c * h1;
  out.hessian(1, 0) += c * h1;
  return out;
}

/// The coupling term a12·η2(Ẽ11·Ẽ22) of Eq. 2 and, with parameters, its derivatives in
/// [a12, η2's flat entries] (value and gradient; the Hessian's are unused). η2 is univariate in
/// u = Ẽ11 Ẽ22, so the §3.2 extrapolation acts on it as on the other curves: outside u's
/// interval over the box (product_interval), η2 is its quadratic Taylor polynomial at the
/// violated bound — C² in u, hence in Ẽ. Where one strain is compressed below its cutoff 0 and
/// the other inside the box (a strip's lateral contraction) this is the Taylor polynomial of ψ
/// about the clamped strain, as §3.2 has it, and there η2 enters through η2'(0) = 1 and η2''(0)
/// alone. The paper's η2(x) = x is evaluated as the bilinear a12 Ẽ11 Ẽ22, exactly as before η2
/// was a curve. docs/material_law.md §3a.
struct Coupling {
  Bivariate term;
  std::vector<Bivariate> parameters;
};

Coupling coupling_term(const MaterialParameters& p, const CouplingShape& shape, const Vector3& e,
                       bool want_parameters) {
  const bool linear = shape.linear;
  Coupling out;
  if (linear) {
    const double a12 = p.a12_Pa;
    out.term.value = a12 * e[0] * e[1];
    out.term.gradient << a12 * e[1], a12 * e[0];
    out.term.hessian << 0.0, a12, a12, 0.0;
    if (!want_parameters) return out;
  }
  // η2 at u, its quadratic Taylor polynomial past u's bound (δ = 0 inside).
  const double u = e[0] * e[1], b = std::clamp(u, shape.product_lo, shape.product_hi), delta = u - b;
  CurveDerivatives h = curve_at(p.eta2, b, want_parameters);
  taylor_past_bound(delta, h.eta, h.eta1, h.eta2);
  if (!linear) out.term = of_product(p.a12_Pa, h.eta, h.eta1, h.eta2, e);
  if (!want_parameters) return out;
  out.parameters.reserve(1 + h.d[0].size());
  // ∂/∂a12: η2(u); for the paper's η2 exactly the bilinear term's u (as before η2 was a curve).
  out.parameters.push_back(linear ? of_product(1.0, u, 1.0, 0.0, e) : of_product(1.0, h.eta, h.eta1, h.eta2, e));
  for (size_t k = 0; k < h.d[0].size(); ++k) {
    taylor_past_bound(delta, h.d[0][k], h.d[1][k], h.d[2][k]);
    out.parameters.push_back(of_product(p.a12_Pa, h.d[0][k], h.d[1][k], h.d[2][k], e));
  }
  return out;
}
}  // namespace

double MaterialLaw::energy_density(const Vector3& e, Vector3* gradient, Matrix3* hessian) const {
  const ThreeTerms t = evaluate_terms(parameters_, e, false);
  const Bivariate c = coupling_term(parameters_, coupling_shape_, e, false).term;
  if (gradient) *gradient << t.warp.d1 + c.gradient[0], t.weft.d1 + c.gradient[1], t.shear.d1;
  if (hessian) {
    *hessian << t.warp.d2 + c.hessian(0, 0), c.hessian(0, 1), 0.0,  //
        c.hessian(1, 0), t.weft.d2 + c.hessian(1, 1), 0.0,          //
        0.0, 0.0, t.shear.d2;
  }
  return t.warp.value + t.weft.value + t.shear.value + c.value;
}

void MaterialLaw::parameter_derivatives(const Vector3& e, Eigen::VectorXd* dpsi_dk,
                                        StrainParameterMatrix* d2psi_de_dk) const {
  const ThreeTerms t = evaluate_terms(parameters_, e, true);
  const int n = layout_.size;
  Eigen::VectorXd dpsi = Eigen::VectorXd::Zero(n);
  StrainParameterMatrix mixed = StrainParameterMatrix::Zero(3, n);

  // The coupling term: a12's column, then η2's entries (each depends on Ẽ11 and Ẽ22).
  const Coupling coupling = coupling_term(parameters_, coupling_shape_, e, true);
  for (size_t k = 0; k < coupling.parameters.size(); ++k) {
    const int column = k == 0 ? FlatLayout::kA12 : layout_.eta2 + static_cast<int>(k - 1);
    dpsi[column] = coupling.parameters[k].value;
    mixed.block<2, 1>(0, column) = coupling.parameters[k].gradient;
  }

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
