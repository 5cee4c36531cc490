#include "core/score_test.hpp"

#include <Eigen/SVD>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

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

namespace {

// The noise's lag-one correlation is clipped here: nearer 1 a run's residual is a trend, not
// noise, and an AR(1) that close to a random walk would make the null as wide as any signal.
constexpr double kMaxCorrelation = 0.95;

// The profile's weight w is searched on a grid of this many steps over [0, 1].
constexpr int kProfileSteps = 100;

}  // namespace

double noise_correlation(const Eigen::Ref<const Eigen::VectorXd>& run) {
  const Eigen::Index size = run.size();
  if (size < 3) return 0;
  const double lagged = run.head(size - 1).squaredNorm();
  const double raw = lagged > 0 ? run.tail(size - 1).dot(run.head(size - 1)) / lagged : 0.0;
  return std::clamp(raw + (1 + 3 * raw) / static_cast<double>(size), 0.0, kMaxCorrelation);
}

Eigen::VectorXd draw_ar1(Eigen::Index rows, double phi, std::mt19937_64* engine) {
  std::normal_distribution<double> normal;
  Eigen::VectorXd e(rows);
  if (rows == 0) return e;
  const double innovation = std::sqrt(1 - phi * phi);
  e[0] = normal(*engine);
  for (Eigen::Index i = 1; i < rows; ++i) e[i] = phi * e[i - 1] + innovation * normal(*engine);
  return e;
}

NoiseProfile fit_noise_profile(const Eigen::VectorXd& u, const Eigen::VectorXd& magnitude,
                               const std::vector<Eigen::Index>& run_rows) {
  if (magnitude.size() != u.size() || std::accumulate(run_rows.begin(), run_rows.end(), Eigen::Index{0}) != u.size() ||
      u.size() == 0 || !(magnitude.minCoeff() > 0))
    throw std::invalid_argument("fit_noise_profile: the readings' magnitudes or the runs' rows do not match the noise");
  std::vector<double> all(magnitude.data(), magnitude.data() + magnitude.size());
  std::nth_element(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(all.size() / 2), all.end());
  NoiseProfile best{0, all[all.size() / 2]};
  double best_likelihood = -std::numeric_limits<double>::infinity();
  for (int k = 0; k <= kProfileSteps; ++k) {
    const NoiseProfile profile{static_cast<double>(k) / kProfileSteps, best.median};
    double likelihood = 0;
    Eigen::Index row = 0;
    for (const Eigen::Index rows : run_rows) {
      double squares = 0;
      for (Eigen::Index i = row; i < row + rows; ++i) {
        const double s = profile.at(magnitude[i]);
        squares += std::pow(u[i] / s, 2);
        likelihood -= std::log(s);
      }
      if (squares > 0) likelihood -= 0.5 * static_cast<double>(rows) * std::log(squares / static_cast<double>(rows));
      row += rows;
    }
    if (likelihood > best_likelihood) best_likelihood = likelihood, best = profile;
  }
  return best;
}

namespace {

// What T needs of the baseline and the candidate, computed once for the data and every
// replicate of the calibration.
struct ScoreBasis {
  Eigen::MatrixXd q;           ///< orthonormal basis of the baseline's directions
  Eigen::MatrixXd signature;   ///< S = P J_e
  Eigen::MatrixXd directions;  ///< eigenvectors of SᵀS kept as directions (d columns)
  Eigen::VectorXd lambda;      ///< their eigenvalues
  Eigen::Index remaining = 0;  ///< m − n_b − d
  /// A candidate whose neutral value sits on a bound (score_test.hpp, `sides`): the least-squares
  /// fits with every subset of its bounded columns held at zero, each kept when its bounded
  /// coefficients point into the range.
  struct Face {
    Eigen::MatrixXd q;             ///< orthonormal basis of the free columns' span
    Eigen::MatrixXd coefficients;  ///< their least-squares coefficients of a residual (k × m)
    std::vector<Eigen::Index> bounded;  ///< rows of `coefficients` that must have the sign of
    std::vector<int> sign;              ///< ... these
  };
  std::vector<Face> faces;  ///< empty: two-sided

  Eigen::MatrixXd project(const Eigen::MatrixXd& v) const { return v - q * (q.transpose() * v); }
};

struct Statistic {
  double t = 0, sigma2 = 0;
  Eigen::VectorXd noise;  ///< u: the residual neither the baseline nor the candidate explains
  Eigen::VectorXd part;   ///< the candidate's least-squares part of P r (P r = part + noise)
};

// The candidate's least-squares part of a projected residual within its range: the best of
// the faces whose bounded coefficients point into it (the constrained least squares is the
// unconstrained one on its own face, and every such feasible fit is a point of the range).
Eigen::VectorXd part_within_range(const ScoreBasis& basis, const Eigen::VectorXd& free_residual) {
  Eigen::VectorXd best = Eigen::VectorXd::Zero(free_residual.size());
  double most = 0;
  for (const ScoreBasis::Face& face : basis.faces) {
    const Eigen::VectorXd c = face.coefficients * free_residual;
    bool inside = true;
    // r + S δ is what remains after a step δ, so the candidate's step is −c.
    for (size_t k = 0; k < face.bounded.size(); ++k) inside = inside && face.sign[k] * c[face.bounded[k]] <= 0;
    if (!inside) continue;
    const Eigen::VectorXd along = face.q.transpose() * free_residual;
    if (along.squaredNorm() > most) most = along.squaredNorm(), best = face.q * along;
  }
  return best;
}

Statistic statistic_of(const ScoreBasis& basis, const Eigen::VectorXd& r) {
  const Eigen::VectorXd free_residual = basis.project(r);
  Statistic out;
  if (basis.faces.empty()) {
    const Eigen::VectorXd along = basis.directions.transpose() * (basis.signature.transpose() * free_residual);
    out.part = basis.signature * (basis.directions * along.cwiseQuotient(basis.lambda));
  } else {
    out.part = part_within_range(basis, free_residual);
  }
  const double explained = out.part.squaredNorm();  // (P r)ᵀ part: part is P r's projection
  out.noise = free_residual - out.part;
  // The noise the baseline and the candidate both leave: under the alternative the baseline's
  // residual holds the candidate's signal too, and a variance estimated from it caps T at m.
  out.sigma2 = (free_residual.squaredNorm() - explained) / static_cast<double>(basis.remaining);
  out.t = basis.directions.cols() > 0 && out.sigma2 > 0 ? explained / out.sigma2 : 0.0;
  return out;
}

// Each row's share of T (ScoreTest::run_share sums it per run): P r = part + noise, and
// (P r)ᵀ part is the explained sum, T σ².
Eigen::VectorXd row_shares(const Statistic& at) {
  if (!(at.t > 0)) return Eigen::VectorXd::Zero(at.part.size());
  return (at.noise + at.part).cwiseProduct(at.part) / at.sigma2;
}

// The baseline's basis and the candidate's directions net of it (score_test.hpp), their
// number in out->dof and the signature P J_e in out->signature.
ScoreBasis basis_of(const Eigen::MatrixXd& baseline, const Eigen::MatrixXd& candidate, ScoreTest* out) {
  ScoreBasis basis;
  basis.q = orthonormal_basis(baseline);
  basis.signature = out->signature = basis.project(candidate);
  // The directions are S's right singular vectors, λ its squared singular values (SᵀS's
  // eigenpairs), taken from S itself: the eigenvalues of SᵀS formed in floating point carry
  // round-off of ε‖SᵀS‖, far above the tolerance squared, and counted a direction the
  // baseline absorbs in 79 of 200 draws (test CountsTheCandidatesDirectionsBeyondTheBaseline…).
  // Relative to the candidate's own columns before the projection: what the baseline absorbs
  // leaves round-off, not a direction.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(basis.signature, Eigen::ComputeThinV);
  const double reference = candidate.norm();
  std::vector<Eigen::Index> kept;
  for (Eigen::Index k = 0; k < svd.singularValues().size(); ++k)
    if (svd.singularValues()[k] > kRankTolerance * reference) kept.push_back(k);
  out->dof = static_cast<int>(kept.size());
  basis.directions = svd.matrixV()(Eigen::all, kept);
  basis.lambda = svd.singularValues()(kept).cwiseAbs2();
  return basis;
}

// The faces of a candidate with bounded columns (ScoreBasis::faces; none when every side is 0):
// for each subset of the bounded columns held at zero, the rest's least squares.
void add_faces(const std::vector<int>& sides, double reference, ScoreBasis* basis) {
  std::vector<Eigen::Index> bounded;
  for (size_t j = 0; j < sides.size(); ++j)
    if (sides[j] != 0) bounded.push_back(static_cast<Eigen::Index>(j));
  if (bounded.empty()) return;
  const Eigen::Index n = basis->signature.cols();
  for (unsigned held = 0; held < (1u << bounded.size()); ++held) {
    std::vector<Eigen::Index> columns;
    ScoreBasis::Face face;
    for (Eigen::Index j = 0; j < n; ++j) {
      const auto at = std::find(bounded.begin(), bounded.end(), j);
      const bool is_bounded = at != bounded.end();
      if (is_bounded && (held >> (at - bounded.begin())) & 1u) continue;
      if (is_bounded) {
        face.bounded.push_back(static_cast<Eigen::Index>(columns.size()));
        face.sign.push_back(sides[static_cast<size_t>(j)]);
      }
      columns.push_back(j);
    }
    // Every column held: the face's part is zero, part_within_range's default. Its SVD would be
    // of an empty matrix, which Eigen does not support (a segfault in a Release build: a
    // discover's reversed refit of the 75 mm five-specimen dataset, session 31).
    if (columns.empty()) continue;
    const Eigen::MatrixXd s = basis->signature(Eigen::all, columns);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(s, Eigen::ComputeThinU | Eigen::ComputeThinV);
    std::vector<Eigen::Index> kept;
    for (Eigen::Index k = 0; k < svd.singularValues().size(); ++k)
      if (svd.singularValues()[k] > kRankTolerance * reference) kept.push_back(k);
    face.q = svd.matrixU()(Eigen::all, kept);
    face.coefficients = svd.matrixV()(Eigen::all, kept) *
                        svd.singularValues()(kept).cwiseInverse().asDiagonal() * face.q.transpose();
    basis->faces.push_back(std::move(face));
  }
}

// One run's rows of the residual vector and the AR(1) noise fitted to them (score_test.hpp).
struct RunNoise {
  Eigen::Index begin = 0, size = 0;
  double phi = 0, sd = 0;  ///< lag-one coefficient, stationary standard deviation
};

RunNoise fit_run_noise(const Eigen::VectorXd& u, Eigen::Index begin, Eigen::Index size) {
  const auto rows = u.segment(begin, size);
  return {begin, size, noise_correlation(rows), std::sqrt(rows.squaredNorm() / static_cast<double>(size))};
}

// The rows of one instrument's runs (`run_begin`, `run_rows`) gathered in order.
Eigen::VectorXd gathered(const Eigen::VectorXd& v, const std::vector<Eigen::Index>& run_rows,
                         const std::vector<Eigen::Index>& run_begin) {
  Eigen::VectorXd out(std::accumulate(run_rows.begin(), run_rows.end(), Eigen::Index{0}));
  Eigen::Index row = 0;
  for (size_t r = 0; r < run_rows.size(); row += run_rows[r], ++r) out.segment(row, run_rows[r]) = v.segment(run_begin[r], run_rows[r]);
  return out;
}

// Each row's noise profile (ones without magnitudes): fit_noise_profile per instrument.
Eigen::VectorXd noise_profile(const Eigen::VectorXd& u, const std::vector<Eigen::Index>& run_rows,
                              const ScoreCalibration& calibration) {
  if (calibration.measured.size() == 0) return Eigen::VectorXd::Ones(u.size());
  if (calibration.measured.size() != u.size() || calibration.instruments.size() != run_rows.size() ||
      !(calibration.measured.minCoeff() > 0))
    throw std::invalid_argument("score_test: the measurements' magnitudes or the runs' instruments do not match");
  std::map<int, std::pair<std::vector<Eigen::Index>, std::vector<Eigen::Index>>> by_instrument;  // rows, begins
  Eigen::Index row = 0;
  for (size_t r = 0; r < run_rows.size(); ++r) {
    auto& [rows, begins] = by_instrument[calibration.instruments[r]];
    rows.push_back(run_rows[r]);
    begins.push_back(row);
    row += run_rows[r];
  }
  Eigen::VectorXd s = Eigen::VectorXd::Ones(u.size());
  for (const auto& [instrument, runs] : by_instrument) {
    const NoiseProfile profile = fit_noise_profile(gathered(u, runs.first, runs.second),
                                                   gathered(calibration.measured, runs.first, runs.second), runs.first);
    for (size_t r = 0; r < runs.first.size(); ++r)
      for (Eigen::Index i = runs.second[r]; i < runs.second[r] + runs.first[r]; ++i) s[i] = profile.at(calibration.measured[i]);
  }
  return s;
}

Eigen::VectorXd draw_noise(const std::vector<RunNoise>& runs, Eigen::Index m, std::mt19937_64* engine) {
  Eigen::VectorXd e(m);
  for (const RunNoise& run : runs) e.segment(run.begin, run.size) = run.sd * draw_ar1(run.size, run.phi, engine);
  return e;
}

// The calibrated p-value of `observed` (score_test.hpp): AR(1) noise per predictor's rows and the shared noise,
// B replicates of T*.
void calibrate(const ScoreBasis& basis, const Statistic& observed, const std::vector<Eigen::Index>& run_rows,
               const ScoreCalibration& calibration, ScoreTest* out) {
  const Eigen::VectorXd profile = noise_profile(observed.noise, run_rows, calibration);
  const Eigen::VectorXd standardised = observed.noise.cwiseQuotient(profile);
  std::vector<RunNoise> runs;
  Eigen::Index row = 0;
  double correlation = 0;
  for (const Eigen::Index size : run_rows) {
    runs.push_back(fit_run_noise(standardised, row, size));
    correlation += runs.back().phi / static_cast<double>(run_rows.size());
    row += size;
  }
  if (row != observed.noise.size()) throw std::logic_error("score_test: the predictions do not cover the residuals");
  const Eigen::MatrixXd& shared = calibration.shared_noise;
  std::mt19937_64 engine(calibration.seed);
  std::normal_distribution<double> normal;
  int as_large = 0;
  for (int b = 0; b < calibration.replicates; ++b) {
    Eigen::VectorXd e = draw_noise(runs, row, &engine).cwiseProduct(profile);
    if (shared.cols() > 0) e += shared * Eigen::VectorXd::NullaryExpr(shared.cols(), [&] { return normal(engine); });
    as_large += statistic_of(basis, e).t >= observed.t;
  }
  out->replicates = calibration.replicates;
  out->noise_correlation = correlation;
  out->p_value = (1.0 + as_large) / (1.0 + calibration.replicates);
}

// Each candidate unknown's side (score_test.hpp): +1 at its lower bound, −1 at its upper, 0
// inside its range.
std::vector<int> sides_at_bounds(const FitObjective& objective, const Eigen::VectorXd& x, int n_baseline) {
  const Eigen::VectorXd lower = objective.lower_bounds(), upper = objective.upper_bounds();
  std::vector<int> sides;
  for (Eigen::Index j = n_baseline; j < x.size(); ++j)
    sides.push_back(x[j] <= lower[j] ? 1 : x[j] >= upper[j] ? -1 : 0);
  return sides;
}

}  // namespace

ScoreTest score_test(FitObjective& objective, const Eigen::VectorXd& x, int n_baseline,
                     const ScoreCalibration& calibration, const Eigen::MatrixXd& known_directions) {
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
  if (known_directions.cols() > 0 && known_directions.rows() != r.size())
    throw std::invalid_argument("score_test: the known directions' rows do not match the residuals'");
  Eigen::MatrixXd baseline(r.size(), n_baseline + scales.cols() + known_directions.cols());
  baseline.leftCols(n_baseline) = jacobian.leftCols(n_baseline);
  baseline.middleCols(n_baseline, scales.cols()) = scales;
  if (known_directions.cols() > 0) baseline.rightCols(known_directions.cols()) = known_directions;  // none: 0 × 0
  std::vector<Eigen::Index> run_rows;
  for (const Eigen::VectorXd& p : objective.last_predictions()) run_rows.push_back(p.size());
  return score_test(r, baseline, jacobian.rightCols(n - n_baseline), run_rows, calibration,
                    sides_at_bounds(objective, x, n_baseline));
}

ScoreTest score_test(const Eigen::VectorXd& r, const Eigen::MatrixXd& baseline, const Eigen::MatrixXd& candidate,
                     const std::vector<Eigen::Index>& run_rows, const ScoreCalibration& calibration,
                     const std::vector<int>& sides) {
  if (baseline.rows() != r.size() || candidate.rows() != r.size() ||
      std::accumulate(run_rows.begin(), run_rows.end(), Eigen::Index{0}) != r.size() ||
      (!sides.empty() && sides.size() != static_cast<size_t>(candidate.cols())))
    throw std::invalid_argument("score_test: the residuals, the directions, the runs' rows and the sides do not match");
  if (calibration.shared_noise.cols() > 0 && calibration.shared_noise.rows() != r.size())
    throw std::invalid_argument("score_test: the shared noise's rows do not match the residuals'");
  ScoreTest out;
  ScoreBasis basis = basis_of(baseline, candidate, &out);
  add_faces(sides, candidate.norm(), &basis);
  basis.remaining = r.size() - basis.q.cols() - out.dof;
  if (basis.remaining <= 0) {  // nothing left to judge the noise by
    out.sigma2 = std::numeric_limits<double>::quiet_NaN();
    if (out.dof > 0) out.statistic = out.p_value_iid = out.p_value = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  const Statistic observed = statistic_of(basis, r);
  out.sigma2 = observed.sigma2;
  out.statistic = observed.t;
  const Eigen::VectorXd shares = row_shares(observed);
  Eigen::Index row = 0;
  for (const Eigen::Index size : run_rows) {
    out.run_noise.push_back(size > 0 ? observed.noise.segment(row, size).cwiseAbs().mean() : 0.0);
    out.run_share.push_back(shares.segment(row, size).sum());
    row += size;
  }
  if (out.dof == 0) return out;
  out.p_value_iid = f_upper_tail(out.statistic / out.dof, out.dof, static_cast<int>(basis.remaining));
  if (calibration.replicates > 0) calibrate(basis, observed, run_rows, calibration, &out);
  return out;
}

ScoreTest score_test_with_known_noise(const Eigen::VectorXd& r, const Eigen::MatrixXd& baseline,
                                     const Eigen::MatrixXd& candidate, int noise_dof) {
  if (baseline.rows() != r.size() || candidate.rows() != r.size())
    throw std::invalid_argument("score_test_with_known_noise: the residuals and the directions do not match");
  if (noise_dof < 1) throw std::invalid_argument("score_test_with_known_noise: no degree of freedom for the noise");
  ScoreTest out;
  const ScoreBasis basis = basis_of(baseline, candidate, &out);
  const Eigen::VectorXd along = basis.directions.transpose() * (basis.signature.transpose() * basis.project(r));
  out.statistic = along.dot(along.cwiseQuotient(basis.lambda));
  out.sigma2 = 1;
  if (out.dof == 0) return out;
  out.p_value_iid = out.p_value = f_upper_tail(out.statistic / out.dof, out.dof, noise_dof);
  return out;
}

}  // namespace twill
