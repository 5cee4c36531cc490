#include "core/score_test.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace twill {

namespace {

// A direction whose singular value is below this fraction of the largest is not a direction
// (the baseline's or the candidate's Jacobian is rank-deficient there: e.g. a specimen scale
// and the test's stiffness on a curve linear in it).
constexpr double kRankTolerance = 1e-10;
// The incomplete gamma's series and continued fraction stop at this relative change; 300
// terms reach it for any argument a χ² with a few degrees of freedom meets.
constexpr double kGammaTolerance = 1e-15;
constexpr int kGammaTerms = 300;

// Regularised lower incomplete gamma P(a, x) by its series (x < a + 1).
double gamma_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < kGammaTerms && std::abs(term) > kGammaTolerance * std::abs(sum); ++n) {
    term *= x / (a + n);
    sum += term;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Regularised upper incomplete gamma Q(a, x) by its continued fraction (x ≥ a + 1), evaluated
// with the modified Lentz method.
double gamma_continued_fraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kGammaTerms; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kGammaTolerance) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

// The continued fraction of the regularised incomplete beta I_x(a, b) (modified Lentz;
// converges fast for x < (a + 1)/(a + b + 2)).
double beta_continued_fraction(double a, double b, double x) {
  constexpr double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m < kGammaTerms; ++m) {
    const double m2 = 2.0 * m;
    double an = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + an * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    an = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + an * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kGammaTolerance) break;
  }
  return h;
}

// I_x(a, b), by the continued fraction on the side where it converges.
double incomplete_beta(double a, double b, double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  const double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) +
                                b * std::log1p(-x));
  return x < (a + 1.0) / (a + b + 2.0) ? front * beta_continued_fraction(a, b, x) / a
                                       : 1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b;
}

// An orthonormal basis of the columns' span (column-pivoting QR, rank by kRankTolerance).
Eigen::MatrixXd orthonormal_basis(const Eigen::MatrixXd& columns) {
  if (columns.cols() == 0) return Eigen::MatrixXd(columns.rows(), 0);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(columns);
  qr.setThreshold(kRankTolerance);
  const Eigen::Index rank = qr.rank();
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(columns.rows(), rank);
  return q;
}

}  // namespace

double chi_squared_upper_tail(double t, int dof) {
  if (dof <= 0) return 1.0;
  if (!(t > 0)) return 1.0;
  const double a = 0.5 * dof, x = 0.5 * t;
  return x < a + 1.0 ? 1.0 - gamma_series(a, x) : gamma_continued_fraction(a, x);
}

double f_upper_tail(double f, int d1, int d2) {
  if (d1 <= 0 || d2 <= 0 || !(f > 0)) return 1.0;
  // P(F > f) = I_{d2/(d2 + d1 f)}(d2/2, d1/2).
  return incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f));
}

ScoreTest score_test(FitObjective& objective, const Eigen::VectorXd& x, int n_baseline) {
  const int n = objective.dimension();
  if (n_baseline < 0 || n_baseline >= n)
    throw std::invalid_argument("score_test: " + std::to_string(n_baseline) + " baseline unknowns of " +
                                std::to_string(n) + ": the candidate has none");
  Eigen::VectorXd r;
  Eigen::MatrixXd jacobian;
  objective.residuals(x, &r, &jacobian);
  if (!std::isfinite(r.sum()))
    throw std::runtime_error("score_test: the baseline could not be evaluated: " + objective.last_failure());
  const Eigen::MatrixXd scales = objective.scale_columns();
  Eigen::MatrixXd baseline(r.size(), n_baseline + scales.cols());
  baseline << jacobian.leftCols(n_baseline), scales;
  const Eigen::MatrixXd q = orthonormal_basis(baseline);
  const auto project = [&q](const Eigen::MatrixXd& v) -> Eigen::MatrixXd { return v - q * (q.transpose() * v); };

  ScoreTest out;
  const Eigen::MatrixXd candidate = jacobian.rightCols(n - n_baseline);
  out.signature = project(candidate);
  const Eigen::VectorXd free_residual = project(r);
  const Eigen::VectorXd g = out.signature.transpose() * free_residual;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> information(out.signature.transpose() * out.signature);
  const Eigen::VectorXd lambda = information.eigenvalues();
  // Relative to the candidate's own columns before the projection (eigenvalues are squared
  // singular values): a direction the baseline absorbs leaves round-off, not a direction.
  const double reference = (candidate.transpose() * candidate).trace();
  double explained = 0;
  for (Eigen::Index k = 0; k < lambda.size(); ++k) {
    if (!(lambda[k] > kRankTolerance * kRankTolerance * reference)) continue;
    const double along = information.eigenvectors().col(k).dot(g);
    explained += along * along / lambda[k];
    ++out.dof;
  }
  // The noise the baseline and the candidate both leave: under the alternative the baseline's
  // residual holds the candidate's signal too, and a variance estimated from it caps T at m.
  const Eigen::Index remaining = r.size() - q.cols() - out.dof;
  out.sigma2 = remaining > 0 ? (free_residual.squaredNorm() - explained) / static_cast<double>(remaining)
                             : std::numeric_limits<double>::quiet_NaN();
  if (out.dof > 0 && remaining <= 0) {  // nothing left to judge the noise by
    out.statistic = out.p_value_iid = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  out.statistic = out.dof > 0 && out.sigma2 > 0 ? explained / out.sigma2 : 0.0;
  out.p_value_iid = out.dof > 0 ? f_upper_tail(out.statistic / out.dof, out.dof, static_cast<int>(remaining)) : 1.0;
  return out;
}

}  // namespace twill
