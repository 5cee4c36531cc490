#include "experiments/uniform_strain.hpp"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>

namespace twill {

bool UniformStrainStrip::validate(std::string* error) const {
  // The same constraints as the tensile setup's geometry (its default cells are valid).
  TensileSetup setup;
  setup.angle_deg = angle_deg;
  setup.width_mm = width_mm;
  setup.gauge_length_mm = gauge_length_mm;
  return setup.validate(error);
}

UniformStrainStrip UniformStrainStrip::from(const TensileSetup& setup, UniformStrainShear shear) {
  UniformStrainStrip s;
  s.angle_deg = setup.angle_deg;
  s.width_mm = setup.width_mm;
  s.gauge_length_mm = setup.gauge_length_mm;
  s.shear = shear;
  return s;
}

Matrix3 strip_to_material_strain(double angle_deg) {
  const double theta = angle_deg * std::numbers::pi / 180.0;
  const double c = std::cos(theta), s = std::sin(theta);
  // Ẽ11 = d1·E·d1, Ẽ22 = d2·E·d2, Ẽ12 = d1·E·d2 with d1 = (−s, c), d2 = (c, s) and the
  // symmetric E = [[E_xx, E_xy], [E_xy, E_yy]]; columns are (E_xx, E_yy, E_xy).
  Matrix3 t;
  t << s * s, c * c, -2.0 * s * c,  //
      c * c, s * s, 2.0 * s * c,    //
      -s * c, s * c, c * c - s * s;
  return t;
}

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// ψ's strip-frame gradient g = Tᵀ ∂ψ/∂e and Hessian H = Tᵀ ∂²ψ/∂e² T at E.
struct StripFrameLaw {
  const MaterialLaw& law;
  Matrix3 t;
  int evaluations = 0;

  Vector3 e = Vector3::Zero(), ge = Vector3::Zero();  ///< law strain and ∂ψ/∂e of the last call

  double operator()(const Vector3& strain, Vector3* g, Matrix3* h) {
    ++evaluations;
    Matrix3 he;
    e = t * strain;
    const double psi = law.energy_density(e, &ge, &he);
    *g = t.transpose() * ge;
    *h = t.transpose() * he * t;
    return psi;
  }
};

struct ScalarRoot {
  double x = 0;
  bool converged = false;
  std::string message;
};

/// One evaluation of a lateral residual: value f, derivative f' and the round-off scale of f
/// (the sum of the magnitudes of the terms f is computed from: f is only known to a few ε of
/// it, so |f| ≤ 4ε·noise_scale is zero to machine precision).
struct Residual {
  double value = 0, derivative = 0, noise_scale = 0;
};

/// Whether a residual is zero to machine precision.
bool at_root(const Residual& v) { return std::abs(v.value) <= 4.0 * kEps * v.noise_scale; }

/// Two points where f has opposite signs, with their residuals (safeguarded_newton's first
/// phase); `root` set where a trial was a root already, `failure` where none was found.
struct Bracket {
  double a = 0, b = 0;
  Residual va, vb;
  std::optional<double> root;
  std::string failure;
};

/// From x0 (f(x0) = v0, not a root) along the Newton direction: the first trial 1.5× the Newton
/// step (at least a few ulps of x0, so that it moves x), then the step doubles; a step past
/// lower_limit halves the gap to it instead.
template <class Function>
Bracket bracket_root(Function& f, double x0, const Residual& v0, double lower_limit) {
  const bool newton_ok = v0.derivative > 0 && std::isfinite(v0.derivative);
  double step = newton_ok ? -1.5 * v0.value / v0.derivative : std::copysign(std::max(std::abs(x0), 1e-3), -v0.value);
  step = std::copysign(std::max(std::abs(step), 8.0 * kEps * std::abs(x0)), step);
  Bracket br{x0, x0, v0, v0, std::nullopt, ""};
  for (int i = 0; i < 200; ++i) {
    br.b = br.a + step;
    if (br.b <= lower_limit) br.b = lower_limit + 0.5 * (br.a - lower_limit);
    br.vb = f(br.b);
    if (!std::isfinite(br.vb.value)) {
      br.failure = "non-finite residual while bracketing";
      return br;
    }
    if (at_root(br.vb)) {
      br.root = br.b;
      return br;
    }
    if ((br.vb.value > 0) != (br.va.value > 0)) return br;
    br.a = br.b, br.va = br.vb;
    step *= 2.0;
  }
  br.failure = "no sign change of the lateral traction found";
  return br;
}

/// Newton inside a bracket of f's root, taken when it stays inside and its step is at most half
/// the step before last (else bisection): the bracket then shrinks at least linearly. Starts at
/// the bracket's end of smaller |f|; `r` is returned with its x where f turns non-finite.
template <class Function>
ScalarRoot refine_in_bracket(Function& f, const Bracket& br, ScalarRoot r) {
  double lo = br.va.value < 0 ? br.a : br.b, hi = br.va.value < 0 ? br.b : br.a;
  const bool start_at_a = std::abs(br.va.value) < std::abs(br.vb.value);
  double x = start_at_a ? br.a : br.b;
  Residual vx = start_at_a ? br.va : br.vb;
  double step_before_last = hi - lo, last_step = hi - lo;
  for (int i = 0; i < 200; ++i) {
    const double newton = vx.derivative > 0 ? x - vx.value / vx.derivative : std::numeric_limits<double>::quiet_NaN();
    const bool use_newton = std::isfinite(newton) && newton > lo && newton < hi &&
                            std::abs(newton - x) <= 0.5 * std::abs(step_before_last);
    const double next = use_newton ? newton : lo + 0.5 * (hi - lo);
    step_before_last = last_step;
    last_step = next - x;
    if (next == x) {
      r.x = x;
      r.converged = true;
      return r;
    }
    x = next;
    vx = f(x);
    if (!std::isfinite(vx.value)) {
      r.message = "non-finite residual in the safeguarded Newton solve";
      return r;
    }
    if (at_root(vx) || std::abs(last_step) <= 2.0 * kEps * std::abs(x) ||
        hi - lo <= 2.0 * kEps * std::max(std::abs(lo), std::abs(hi))) {
      r.x = x;
      r.converged = true;
      return r;
    }
    (vx.value < 0 ? lo : hi) = x;
  }
  r.x = x;
  r.message = "lateral solve did not reach machine precision in 200 iterations";
  return r;
}

/// Root of f, increasing through it, on (lower_limit, ∞): Newton's method safeguarded by a
/// bisection bracket (Numerical Recipes §9.4 "rtsafe"). `f(x)` returns a Residual; a
/// non-finite value aborts. A bracket is found first by stepping from x0 along the Newton
/// direction (bracket_root), then narrowed (refine_in_bracket). Stops at machine precision:
/// |f| ≤ 4ε·noise_scale, a step below 2ε|x|, or a bracket of width 2ε|x|.
template <class Function>
ScalarRoot safeguarded_newton(Function&& f, double x0, double lower_limit) {
  ScalarRoot r;
  r.x = x0;
  const Residual v0 = f(x0);
  if (!std::isfinite(v0.value)) {
    r.message = "non-finite residual at the start";
    return r;
  }
  if (at_root(v0)) {
    r.converged = true;
    return r;
  }
  const Bracket br = bracket_root(f, x0, v0, lower_limit);
  if (br.root) {
    r.x = *br.root;
    r.converged = true;
    return r;
  }
  if (!br.failure.empty()) {
    r.message = br.failure;
    return r;
  }
  return refine_in_bracket(f, br, r);
}

/// The lateral equilibrium of a uniform-strain strip at a fixed axial strain E_xx: ∂ψ/∂E_yy = 0,
/// and ∂ψ/∂E_xy = 0 when the shear is free (nested scalar solves).
class LateralEquilibrium {
 public:
  LateralEquilibrium(StripFrameLaw& psi, double exx) : psi_(psi), a12_(psi.law.parameters().a12_Pa), exx_(exx) {}

  /// The strip-frame strain (E_xx, E_yy, E_xy) from `guess` (E_yy, E_xy), or nothing with the
  /// reason in `message`.
  std::optional<Vector3> solve(const Eigen::Vector2d& guess, bool free_shear, std::string* message) {
    eyy_ = guess[0];
    double exy = 0;
    if (free_shear) {
      const ScalarRoot r = solve_exy(guess[1]);
      if (!r.converged) {
        if (inner_ok_) *message = "E_xy: " + r.message;
        else *message = inner_message_;
        return std::nullopt;
      }
      exy = r.x;
    }
    // The converged E_yy belongs to the last inner solve, which ran at the final E_xy only if
    // the outer solve's last evaluation was there: solve once more at the final E_xy (one
    // evaluation when it already is).
    if (std::isnan(solve_eyy(exy))) {
      *message = inner_message_;
      return std::nullopt;
    }
    return Vector3(exx_, eyy_, exy);
  }

 private:
  // Round-off scale of g_l = Σ_i T_il ∂ψ/∂e_i: the sum of the magnitudes of its terms, where
  // ∂ψ/∂e1 = F1' + a12 e2 and ∂ψ/∂e2 = F3' + a12 e1 (material_law.hpp) count as two terms each.
  // Evaluated at the strain of psi's last call.
  double noise_scale(int l) const {
    const Vector3& e = psi_.e;
    const Vector3& ge = psi_.ge;
    const Vector3 terms(std::abs(ge[0] - a12_ * e[1]) + std::abs(a12_ * e[1]),
                        std::abs(ge[1] - a12_ * e[0]) + std::abs(a12_ * e[0]), std::abs(ge[2]));
    return psi_.t.col(l).cwiseAbs().dot(terms);
  }

  // Inner solve: ∂ψ/∂E_yy = 0 at fixed (E_xx, E_xy), from the last E_yy. E_yy > −½ keeps the
  // lateral stretch √(1 + 2E_yy) real. NaN when it fails.
  double solve_eyy(double exy) {
    const ScalarRoot r = safeguarded_newton(
        [&](double y) {
          psi_(Vector3(exx_, y, exy), &g_, &h_);
          return Residual{g_[1], h_(1, 1), noise_scale(1)};
        },
        eyy_, -0.5);
    if (!r.converged) {
      inner_ok_ = false;
      inner_message_ = "E_yy: " + r.message;
      return std::numeric_limits<double>::quiet_NaN();
    }
    eyy_ = r.x;
    return eyy_;
  }

  // Outer solve: ∂ψ/∂E_xy = 0 along the inner solution E_yy*(E_xy). Its derivative is the
  // Schur complement H_ss − H_sy²/H_yy (dE_yy*/dE_xy = −H_ys/H_yy). Its round-off includes the
  // inner solution's: δE_yy ≈ 4ε·scale_y/H_yy moves it by H_sy δE_yy.
  ScalarRoot solve_exy(double guess) {
    return safeguarded_newton(
        [&](double s) {
          if (std::isnan(solve_eyy(s))) return Residual{std::numeric_limits<double>::quiet_NaN(), 0, 0};
          psi_(Vector3(exx_, eyy_, s), &g_, &h_);
          return Residual{g_[2], h_(2, 2) - h_(1, 2) * h_(1, 2) / h_(1, 1),
                          noise_scale(2) + std::abs(h_(1, 2) / h_(1, 1)) * noise_scale(1)};
        },
        guess, -std::numeric_limits<double>::infinity());
  }

  StripFrameLaw& psi_;
  double a12_, exx_;
  double eyy_ = 0;
  bool inner_ok_ = true;
  std::string inner_message_;
  Vector3 g_;
  Matrix3 h_;
};

/// The lateral block l = {E_yy} (held shear) or {E_yy, E_xy} (free) of the strip-frame Hessian
/// at equilibrium, factored, and the axial row's coupling H_xl to it.
struct LateralBlock {
  int size;
  Eigen::RowVectorXd hxl;
  Eigen::LDLT<Eigen::MatrixXd> factor;
  bool positive_definite() const { return factor.info() == Eigen::Success && factor.vectorD().minCoeff() > 0; }
};

LateralBlock lateral_block(const Matrix3& h, bool free_shear) {
  const int nl = free_shear ? 2 : 1;
  const Eigen::MatrixXd hll = h.block(1, 1, nl, nl);
  return {nl, h.block(0, 1, 1, nl), Eigen::LDLT<Eigen::MatrixXd>(hll)};
}

/// Implicit differentiation of ∂ψ/∂E_l = 0: dE_l/dk = −H_ll⁻¹ ∂²ψ/∂E_l∂k, then
/// dS_xx/dk = ∂²ψ/∂E_xx∂k + H_xl dE_l/dk, and F = W τ λ S_xx gives
/// dF/dk = W τ λ dS_xx/dk (+ W λ S_xx in the thickness column).
void add_parameter_derivatives(const MaterialLaw& law, const StripFrameLaw& psi, const LateralBlock& lateral,
                               double width_m, UniformStrainPoint* p) {
  const double tau = law.parameters().thickness_m;
  StrainParameterMatrix mixed_e;
  law.parameter_derivatives(psi.t * p->strain, nullptr, &mixed_e);
  const Eigen::MatrixXd mixed = psi.t.transpose() * mixed_e;  // 3 × n, strip frame
  const Eigen::MatrixXd dlateral = -lateral.factor.solve(mixed.middleRows(1, lateral.size));
  const Eigen::RowVectorXd dstress = mixed.row(0) + lateral.hxl * dlateral;
  p->dforce_dk = width_m * tau * p->stretch * dstress.transpose();
  p->dforce_dk[FlatLayout::kThickness] += width_m * p->stretch * p->stress_xx_Pa;
  p->dlateral_strain_dk = dlateral.row(0).transpose() / (1.0 + p->lateral_strain);
}

}  // namespace

UniformStrainPoint uniform_strain_tension(const MaterialLaw& law, const UniformStrainStrip& strip,
                                          double extension_mm, bool want_parameter_derivatives,
                                          const Eigen::Vector2d& lateral_guess) {
  std::string error;
  if (!strip.validate(&error)) throw std::invalid_argument("uniform-strain strip: " + error);
  if (!(extension_mm > -strip.gauge_length_mm))
    throw std::invalid_argument("uniform-strain strip: extension " + std::to_string(extension_mm) +
                                " mm must exceed −gauge_length_mm");
  UniformStrainPoint p;
  p.extension_mm = extension_mm;
  p.stretch = 1.0 + extension_mm / strip.gauge_length_mm;
  const bool free_shear = strip.shear == UniformStrainShear::Free;

  StripFrameLaw psi{law, strip_to_material_strain(strip.angle_deg)};
  LateralEquilibrium equilibrium(psi, 0.5 * (p.stretch * p.stretch - 1.0));
  const std::optional<Vector3> strain = equilibrium.solve(lateral_guess, free_shear, &p.message);
  p.lateral_iterations = psi.evaluations;
  if (!strain) return p;
  p.strain = *strain;

  Vector3 g;
  Matrix3 h;
  const double psi_value = psi(p.strain, &g, &h);
  const double width_m = 1e-3 * strip.width_mm, length_m = 1e-3 * strip.gauge_length_mm;
  const double tau = law.parameters().thickness_m;
  p.stress_xx_Pa = g[0];
  // Clamp force from the first Piola–Kirchhoff stress P = F S on the clamp face (reference
  // normal x̂, area W τ): F_def = [[λ, a], [0, μ]] keeps the axis along x, so
  // (P x̂)_x = λ S_xx + a S_xy = λ S_xx (S_xy = 0 when shear is free; a = 0 when held).
  p.force_N = width_m * tau * p.stretch * p.stress_xx_Pa;
  p.lateral_strain = std::sqrt(1.0 + 2.0 * p.strain[1]) - 1.0;
  p.energy_J = width_m * length_m * tau * psi_value;

  // Reduced axial stiffness K = H_xx − H_xl H_ll⁻¹ H_lx.
  const LateralBlock lateral = lateral_block(h, free_shear);
  if (!lateral.positive_definite()) {
    p.message = "lateral stiffness ∂²ψ/∂E_lat² is not positive definite (unstable state)";
    return p;
  }
  const double reduced = h(0, 0) - (lateral.hxl * lateral.factor.solve(lateral.hxl.transpose()))(0, 0);
  p.dforce_dextension_N_per_mm =
      width_m * tau * (p.stress_xx_Pa + p.stretch * p.stretch * reduced) / strip.gauge_length_mm;
  p.converged = true;
  if (want_parameter_derivatives) add_parameter_derivatives(law, psi, lateral, width_m, &p);
  return p;
}

UniformStrainPredictor::UniformStrainPredictor(std::string label, const TensileSetup& setup,
                                               std::vector<double> extensions_mm,
                                               const Eigen::VectorXd& forces_N,
                                               UniformStrainShear shear)
    : label_(std::move(label)),
      strip_(UniformStrainStrip::from(setup, shear)),
      extensions_mm_(std::move(extensions_mm)),
      measured_(forces_N) {
  std::string error;
  if (!strip_.validate(&error)) throw std::invalid_argument(label_ + ": " + error);
  if (static_cast<Eigen::Index>(extensions_mm_.size()) != measured_.size())
    throw std::invalid_argument(label_ + ": " + std::to_string(extensions_mm_.size()) +
                                " extensions but " + std::to_string(measured_.size()) + " forces");
  if (extensions_mm_.empty()) throw std::invalid_argument(label_ + ": no measured points");
  for (double u : extensions_mm_)
    if (!(u > -strip_.gauge_length_mm))
      throw std::invalid_argument(label_ + ": extension " + std::to_string(u) +
                                  " mm must exceed −gauge_length_mm");
}

bool UniformStrainPredictor::predict(const MaterialParameters& k, const std::vector<int>& flat,
                                     Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                     std::string* message) {
  const MaterialLaw law(k);
  std::vector<UniformStrainPoint> points;
  points.reserve(extensions_mm_.size());
  Eigen::Vector2d guess = Eigen::Vector2d::Zero();
  for (double u : extensions_mm_) {
    UniformStrainPoint p = uniform_strain_tension(law, strip_, u, jacobian != nullptr, guess);
    ++solves_;
    if (!p.converged) {
      if (message) *message = label_ + ": uniform strain at " + std::to_string(u) + " mm: " + p.message;
      return false;
    }
    guess = p.strain.tail<2>();
    points.push_back(std::move(p));
  }
  values->resize(measured_.size());
  if (jacobian) jacobian->resize(measured_.size(), static_cast<Eigen::Index>(flat.size()));
  for (size_t i = 0; i < points.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    (*values)[row] = points[i].force_N;
    if (jacobian)
      for (size_t j = 0; j < flat.size(); ++j)
        (*jacobian)(row, static_cast<Eigen::Index>(j)) = points[i].dforce_dk[flat[j]];
  }
  last_points_ = std::move(points);
  return true;
}

}  // namespace twill
