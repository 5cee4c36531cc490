#pragma once
// The score (Lagrange-multiplier) test of a candidate extension at a baseline fit (issue #16's
// "diagnose and rank"; docs/discover-design.md §3): does freeing the candidate's parameters θ_e
// from their neutral values lower Eq. 3 by more than the data's noise explains — judged at the
// baseline alone, without fitting the candidate.
//
// At the baseline optimum x̂ (the candidate at its neutral value), with r the residuals and
// J = [J_b, J_e] the Jacobian in the baseline's free unknowns and the candidate's:
//
//     g = J_eᵀ r                        (½ the gradient of ε in θ_e)
//     P = I − J_b (J_bᵀ J_b)⁺ J_bᵀ      (what the baseline can absorb, projected out)
//     I_e = J_eᵀ P J_e                  (the candidate's information, net of the baseline)
//     T·σ² = gᵀ I_e⁺ g                  (g is projected too: P r = r − J_b(...)J_bᵀ r)
//     σ² = (‖P r‖² − T σ²) / (m − n_b − d)   (the noise neither explains; estimated from the
//                                        baseline's residual alone it would hold the
//                                        candidate's signal and cap T below m)
//
// Under iid Gaussian residuals, no effect and a model linear near x̂, T/d ~ F(d, m − n_b − d),
// d = rank I_e (T → χ²(d) as m grows); p_value_iid is that F tail. The signature of the
// candidate is the columns P J_e: what its parameters change in the predictions that the
// baseline's cannot. The specimen scales (core/specimen_scale.hpp) are baseline directions
// too: their columns (s_r p̂_r/p̆_r on run r's rows) join J_b, so a candidate that only
// rescales a run scores nothing.
//
// Calibration: with specimen scatter and correlated residuals along a curve the χ² tail is not
// the null distribution (issue #16: an iid criterion "finds" effects in null data about half
// the time with 15 % scatter); p_value_iid is reported as what it is, and `p_value` compares T
// with its distribution over noise simulated like the data's (docs/discover-design.md §3a): a
// linearised parametric bootstrap. The specimen scales are baseline directions, so their
// scatter needs no draws (P removes it exactly to first order); what remains is the noise
// along each run, which a curve's measurements carry correlated (a strip's slip, the load
// cell's drift). Per run (each predictor's rows), an AR(1) process is fitted to the residual
// neither the baseline nor the candidate explains, u = P r − S (SᵀS)⁺ Sᵀ P r with S = P J_e:
// lag-one coefficient φ̂ = Σ u_i u_{i−1} / Σ u_{i−1}², corrected for its small-sample bias
// (Kendall: E φ̂ ≈ φ − (1 + 3φ)/n), clipped to [0, kMaxCorrelation]; innovation variance
// (1 − φ²) Σu²/n. Each replicate draws e* from those processes and computes T* exactly as T
// (P e*, its own σ*²); p = (1 + #{T* ≥ T}) / (B + 1). T is scale-free, so only each run's
// correlation and the runs' relative noise levels matter. Under the alternative, u is the
// noise as long as the candidate explains the signal; a misfit neither explains stays in u as
// correlation and makes the test conservative, not liberal. Along a run the noise need not be
// alike: with the readings' magnitudes (ScoreCalibration::measured) a profile per instrument
// is fitted and each run's AR(1) runs on u divided by it. A candidate on its bound is tested
// one-sided (`sides`, below).
#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

#include "core/fit_objective.hpp"

namespace twill {

/// NaN statistic and p-value: the candidate has directions but no residual degree of freedom
/// is left to estimate the noise (as many observations as the baseline and the candidate have
/// unknowns, e.g. two ratios on two cantilevers): only held-out data can judge it.
struct ScoreTest {
  double statistic = 0;    ///< T
  int dof = 0;             ///< d: the rank of the candidate's net information
  double sigma2 = 0;       ///< σ², per residual
  double p_value_iid = 1;  ///< the F(d, m − n_b − d) upper tail of T/d (uncalibrated; see above)
  double p_value = 1;      ///< calibrated: the share of correlated-noise replicates with T* ≥ T (above)
  int replicates = 0;      ///< B, the bootstrap replicates behind p_value (0: not calibrated)
  double noise_correlation = 0;  ///< the runs' mean fitted lag-one correlation φ of the noise
  /// Per predictor (run): the mean |u| over its rows, u the residual neither the baseline nor
  /// the candidate explains — in relative-residual units, the average relative error the
  /// run's noise alone makes (`twill discover`'s floor). Empty when no residual degree of
  /// freedom is left; filled without calibration too (ScoreCalibration::replicates = 0).
  std::vector<double> run_noise;
  /// Per predictor (run), its rows' share of T: (P r)ᵀ on the run's rows times the candidate's
  /// least-squares part of P r there, over σ² — the shares sum to T. Where a score comes from
  /// (docs/discovery.md §2: on poisson's 1°-cut null twin the three warp lateral strips held
  /// 6.4 of T = 10.2, a pattern the baseline did not carry). Empty with run_noise.
  std::vector<double> run_share;
  Eigen::MatrixXd signature;  ///< P J_e: m × (candidate's unknowns), residual units
};

/// The calibration's draws (above). B = 1999 puts the p-value's resolution at 5e-4 and its
/// Monte Carlo sd at 0.005 near 0.05; a replicate costs two products with the m × (n_b + d)
/// bases, no solve. The seed is fixed so that a report can be regenerated to the digit.
struct ScoreCalibration {
  int replicates = 1999;
  std::uint64_t seed = 20170728;  ///< SCA 2017's first day; any fixed value
  /// Noise shared by many rows, drawn once per replicate beside each run's AR(1): e* += L z,
  /// z ~ N(0, I), L (m × k) the square root of its covariance on the residuals' rows — the
  /// curves' levels on the lateral strains (L = J_L V^(1/2), docs/discovery.md §2, "The lateral
  /// strains' noise beyond each run's"). No columns: none. A baseline direction
  /// would absorb it whole; this is a random effect of known size, which the data cannot refit.
  Eigen::MatrixXd shared_noise;
  /// The measurements' magnitudes |y_i| (m entries, none zero; empty: the noise is alike along
  /// each run) and each run's instrument (one entry per run; runs of one instrument share its
  /// noise law). A load cell's noise has an absolute part and a part relative to the reading,
  /// sd a + b|y|: relative to y, as the residuals are, b (1 + (a/b)/|y|) — on a bias strip
  /// at 10 % scatter 13 % at 0.4 N and 0.8 % at 19 N. The calibration fits that profile per
  /// instrument to the noise u (noise_profile in score_test.cpp), fits each run's AR(1) to u
  /// divided by it, and draws through it; drawn alike along a run, the low readings' noise was
  /// a fraction of the data's, and a candidate whose signature sits there (friction on the
  /// bias strips' last unloading rows) was significant on null data (docs/discovery.md §2).
  Eigen::VectorXd measured;
  std::vector<int> instruments;
};

/// The score test of the unknowns n_baseline… of `objective` (the candidate's) at x, where the
/// first n_baseline unknowns are the baseline's, fitted there. `known_directions` (m × q, or
/// none) join the baseline's: patterns in the residuals that no unknown carries and the data
/// cannot tell from the candidate, which must not count for it (the mesh's own error on the
/// lateral strains). Evaluates the objective's residuals and Jacobian once; throws
/// std::runtime_error when the evaluation fails.
ScoreTest score_test(FitObjective& objective, const Eigen::VectorXd& x, int n_baseline,
                     const ScoreCalibration& calibration = {}, const Eigen::MatrixXd& known_directions = {});
/// The same test from its parts, for directions no FitObjective unknown carries (the
/// misalignment effect's per-strip offsets on the validation strips): the residuals r (m), the
/// baseline's directions (m × n_b, the specimen scales' among them), the candidate's (m × d),
/// and each run's number of rows, in order (their sum m: each run's noise and its AR(1)).
/// `sides` (one per candidate column, or none: all 0): +1 where the candidate's unknown sits on
/// its lower bound at the baseline and can only rise (a friction, a Maxwell branch's ratio, 0
/// when neutral), −1 on its upper bound, 0 inside its range. T is then the one-sided score
/// statistic: the candidate's part of P r is its least squares within its range (the best
/// face, score_test.cpp), so a residual pattern the candidate could only fit with a negative
/// friction is not evidence for it (on friction's null twin 2 the loop effects' score
/// carried such a pattern). The calibration computes each T* the same way, so its null is
/// the χ̄²-like mixture this makes; p_value_iid stays the two-sided F tail, conservative here.
/// The FitObjective form takes the sides from the objective's bounds at x.
ScoreTest score_test(const Eigen::VectorXd& r, const Eigen::MatrixXd& baseline, const Eigen::MatrixXd& candidate,
                     const std::vector<Eigen::Index>& run_rows, const ScoreCalibration& calibration = {},
                     const std::vector<int>& sides = {});

/// The test where the noise's size is measured apart from the residuals — the cantilevers'
/// chord angles, one per direction, whose noise is the scatter of each direction's repeated
/// overhangs: r and the directions in units of each observation's standard error, that error
/// estimated with `noise_dof` degrees of freedom (Σ (repeats − 1)). T = the part of the
/// projected residual along the candidate's directions, squared; under no effect T/d ~
/// F(d, noise_dof) (χ²(d)/d as the repeats grow), which is p_value (and p_value_iid; no
/// bootstrap: one observation per direction has no correlation to model, replicates 0).
ScoreTest score_test_with_known_noise(const Eigen::VectorXd& r, const Eigen::MatrixXd& baseline,
                                     const Eigen::MatrixXd& candidate, int noise_dof);
/// The noise law of one instrument's readings relative to each reading (ScoreCalibration::
/// measured): sd_i / |y_i| ∝ (1 − w) + w M/|y_i|, M the median |y| of the rows it was fitted to
/// (w = 0: noise relative to the reading, w = 1: absolute) — a load cell's a + b|y|.
struct NoiseProfile {
  double absolute_weight = 0;  ///< w
  double median = 1;           ///< M, in the readings' unit
  double at(double magnitude) const { return (1 - absolute_weight) + absolute_weight * median / magnitude; }
};
/// w on a grid of 101 by the Gaussian likelihood of the relative noise `u` with each run's own
/// level profiled out, −Σ_r (n_r/2) log mean_r (u/s)² − Σ log s (an AR(1) ignored there: the
/// profile belongs to the readings, the correlation to their order). `magnitude` |y_i| > 0 per
/// row; `run_rows` each run's number of rows, in order. std::invalid_argument on a mismatch.
NoiseProfile fit_noise_profile(const Eigen::VectorXd& u, const Eigen::VectorXd& magnitude,
                               const std::vector<Eigen::Index>& run_rows);
/// A run's lag-one noise correlation: Σ u_i u_{i−1} / Σ u_{i−1}², Kendall-corrected
/// (E φ̂ ≈ φ − (1 + 3φ)/n), clipped to [0, 0.95]; 0 with fewer than three rows.
double noise_correlation(const Eigen::Ref<const Eigen::VectorXd>& run);
/// `rows` values of a stationary AR(1) with lag-one correlation `phi` and variance 1.
Eigen::VectorXd draw_ar1(Eigen::Index rows, double phi, std::mt19937_64* engine);
/// The upper tail P(χ²(dof) > t) (regularised upper incomplete gamma Q(dof/2, t/2)).
double chi_squared_upper_tail(double t, int dof);
/// The upper tail P(F(d1, d2) > f) (regularised incomplete beta).
double f_upper_tail(double f, int d1, int d2);

}  // namespace twill
