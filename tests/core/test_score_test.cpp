// The score test of a candidate extension at a baseline fit (core/score_test.hpp): the χ² and F tails
// against tabulated quantiles, the test's size under its own assumptions (iid noise, no
// effect: p < 5 % in about 5 % of replicates), its power when the candidate's term is in the
// data, and a candidate that only rescales runs scoring nothing once the specimen scales are
// in the baseline.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/score_test.hpp"
#include "tests/support/test_materials.hpp"
#include "tests/support/toy_predictor.hpp"

namespace twill {
namespace {

TEST(ScoreTest, ChiSquaredTailMatchesTabulatedQuantiles) {
  // 95 % and 99.9 % quantiles (any χ² table); dof 2 is exp(−t/2) exactly.
  EXPECT_NEAR(chi_squared_upper_tail(3.841459, 1), 0.05, 1e-6);
  EXPECT_NEAR(chi_squared_upper_tail(10.827566, 1), 0.001, 1e-8);
  EXPECT_NEAR(chi_squared_upper_tail(9.487729, 4), 0.05, 1e-6);
  EXPECT_NEAR(chi_squared_upper_tail(18.307038, 10), 0.05, 1e-6);
  EXPECT_NEAR(chi_squared_upper_tail(0.7, 2), std::exp(-0.35), 1e-14);
  EXPECT_NEAR(chi_squared_upper_tail(30.0, 2), std::exp(-15.0), 1e-20);
  EXPECT_EQ(chi_squared_upper_tail(0.0, 3), 1.0);
  // F: 95 % quantiles F(1, 22) = 4.3009, F(3, 10) = 3.7083; F(2, d2) has the closed form
  // (1 + 2f/d2)^(−d2/2).
  EXPECT_NEAR(f_upper_tail(4.300950, 1, 22), 0.05, 1e-6);
  EXPECT_NEAR(f_upper_tail(3.708265, 3, 10), 0.05, 1e-6);
  EXPECT_NEAR(f_upper_tail(1.7, 2, 9), std::pow(1 + 2 * 1.7 / 9, -4.5), 1e-13);
  EXPECT_EQ(f_upper_tail(0.0, 1, 5), 1.0);
}

const Eigen::VectorXd kStrains = Eigen::VectorXd::LinSpaced(12, 0.01, 0.12);

// How the toy's measurements are drawn: relative Gaussian noise of sd `noise`, AR(1) along
// each run with lag-one correlation `correlation` (0: iid), `points` strains per run.
struct Noise {
  double noise = 0.01;
  double correlation = 0;
  int points = 12;
};

// Runs of p = τ a11 e + τ² a22 e² measured from `truth` with relative noise.
std::vector<std::shared_ptr<Predictor>> noisy_runs(const MaterialParameters& truth, int runs, const Noise& noise,
                                                   std::mt19937_64* engine, const std::vector<double>& scatter = {}) {
  std::normal_distribution<double> normal(0.0, noise.noise);
  const Eigen::VectorXd strains = noise.points == kStrains.size()
                                      ? kStrains
                                      : Eigen::VectorXd::LinSpaced(noise.points, 0.01, 0.12).eval();
  const double innovation = std::sqrt(1 - noise.correlation * noise.correlation);
  std::vector<std::shared_ptr<Predictor>> out;
  for (int r = 0; r < runs; ++r) {
    testing::ToyPredictor generator("generator", strains, Eigen::VectorXd::Ones(strains.size()));
    Eigen::VectorXd measured;
    generator.predict(truth, {}, &measured, nullptr, nullptr);
    double e = normal(*engine);
    for (Eigen::Index i = 0; i < measured.size(); ++i) {
      if (i > 0) e = noise.correlation * e + innovation * normal(*engine);
      measured[i] *= (scatter.empty() ? 1.0 : scatter[static_cast<size_t>(r)]) * (1.0 + e);
    }
    out.push_back(std::make_shared<testing::ToyPredictor>("run " + std::to_string(r), strains, measured));
  }
  return out;
}

MaterialParameters start() {
  MaterialParameters k = testing::canvas_degree2();
  k.a22_Pa = 0.5 * k.a11_Pa / k.thickness_m;  // the quadratic term: a few % of the force at the largest strain
  return k;
}

// The baseline (a11 free) fitted exactly (its residuals are linear in it: one Gauss–Newton
// step), then the score of freeing a22 at its start value.
ScoreTest score_of_a22(const std::vector<std::shared_ptr<Predictor>>& runs, const ScoreCalibration& calibration = {}) {
  ParameterMap::Options options;
  options.tie_a12 = false;
  FitObjective baseline(ParameterMap(start(), {"a11_Pa"}, options), runs);
  Eigen::VectorXd x = baseline.map().initial_x(), r;
  Eigen::MatrixXd j;
  baseline.residuals(x, &r, &j);
  x -= (j.transpose() * j).ldlt().solve(j.transpose() * r);
  FitObjective candidate(ParameterMap(baseline.map().parameters(x), {"a11_Pa", "a22_Pa"}, options), runs);
  return score_test(candidate, candidate.map().initial_x(), 1, calibration);
}

// A calibration of b replicates (b = 0: none), the rest its defaults.
ScoreCalibration with_replicates(int b) {
  ScoreCalibration c;
  c.replicates = b;
  return c;
}

// How often the score test rejects at 5 % over `replicates` data sets without the effect.
struct NullRejections {
  int iid = 0, calibrated = 0;
  double mean_statistic = 0, mean_correlation = 0;
};

NullRejections null_rejections(int replicates, int runs, const Noise& noise, std::uint64_t seed) {
  std::mt19937_64 engine(seed);
  constexpr int kCalibrationReplicates = 199;  // p to 0.005: enough to count rejections at 5 %
  NullRejections out;
  for (int k = 0; k < replicates; ++k) {
    const ScoreTest t = score_of_a22(noisy_runs(start(), runs, noise, &engine), with_replicates(kCalibrationReplicates));
    EXPECT_EQ(t.dof, 1);
    out.iid += t.p_value_iid < 0.05;
    out.calibrated += t.p_value < 0.05;
    out.mean_statistic += t.statistic / replicates;
    out.mean_correlation += t.noise_correlation / replicates;
  }
  return out;
}

TEST(ScoreTest, HasItsNominalSizeUnderIidNoiseWithoutTheEffect) {
  constexpr int kReplicates = 400;
  const NullRejections n = null_rejections(kReplicates, 2, {}, 11);
  std::printf("[measured] score test, no effect, iid 1 %% noise: %d of %d rejected at 5 %% (calibrated: %d), mean T "
              "%.3f (F(1, 22): 1.1)\n",
              n.iid, kReplicates, n.calibrated, n.mean_statistic);
  // Binomial(400, 0.05): 20 ± 4.4; three standard deviations either side.
  EXPECT_GE(n.iid, 7);
  EXPECT_LE(n.iid, 33);
  // The calibration fits an AR(1) where there is none: its φ̂ is clipped at 0 or lands near it
  // (bias-corrected), so its size is the nominal one too, within the same band.
  EXPECT_GE(n.calibrated, 7);
  EXPECT_LE(n.calibrated, 33);
  EXPECT_NEAR(n.mean_statistic, 22.0 / 20.0, 0.25);  // the mean of F(1, 22), d2/(d2 − 2); sd over 400 draws ~0.08
}

// Noise correlated along each run (a strip's slip, the load cell's drift): the iid F tail is no
// longer the null distribution, the calibrated p-value is (score_test.hpp).
TEST(ScoreTest, CalibratedPValueKeepsItsSizeUnderNoiseCorrelatedAlongRuns) {
  constexpr int kReplicates = 300;
  const NullRejections n = null_rejections(kReplicates, 3, {0.01, 0.8, 40}, 14);
  std::printf("[measured] score test, no effect, AR(1) noise phi 0.8, 3 runs x 40 points: rejected at 5 %% %d of %d "
              "(iid F tail), %d (calibrated); mean fitted phi %.3f\n",
              n.iid, kReplicates, n.calibrated, n.mean_correlation);
  // Binomial(300, 0.05): 15 ± 3.8; the calibration's φ̂ is an estimate from 40 points per run
  // (sd ~0.1), so its size is not exactly 5 %: up to twice the nominal, against the iid
  // tail's several-fold excess.
  EXPECT_GT(n.iid, 3 * 15);
  EXPECT_LE(n.calibrated, 2 * 15 + 12);
  EXPECT_NEAR(n.mean_correlation, 0.8, 0.1);
}

TEST(ScoreTest, CalibratedPValueFindsTheTermUnderCorrelatedNoise) {
  std::mt19937_64 engine(15);
  MaterialParameters truth = start();
  truth.a22_Pa *= 3;
  const ScoreTest t = score_of_a22(noisy_runs(truth, 3, {0.01, 0.8, 40}, &engine));
  std::printf("[measured] score test, quadratic term x3, AR(1) noise phi 0.8: T %.1f, p %.2e (iid %.2e), fitted phi "
              "%.3f\n",
              t.statistic, t.p_value, t.p_value_iid, t.noise_correlation);
  EXPECT_EQ(t.replicates, ScoreCalibration{}.replicates);
  EXPECT_LT(t.p_value, 0.01);
}

TEST(ScoreTest, FindsTheCandidatesTermWhenTheDataHaveIt) {
  std::mt19937_64 engine(12);
  MaterialParameters truth = start();
  truth.a22_Pa *= 3;  // the quadratic term three times as large: 12 % of the force at the largest strain
  const ScoreTest t = score_of_a22(noisy_runs(truth, 2, {}, &engine));
  std::printf("[measured] score test, quadratic term ×3, 1 %% noise: T %.1f, p %.2e\n", t.statistic, t.p_value_iid);
  EXPECT_LT(t.p_value_iid, 1e-6);
  EXPECT_LT(t.p_value, 1e-3);  // none of B = 1999 replicates as large: p = 1/2000
  EXPECT_GT(t.signature.norm(), 0.0);
}

// A known direction (a pattern no unknown carries, e.g. the mesh's own error on the lateral
// strains) joins the baseline: the candidate's term found above scores nothing once its own
// pattern is known, and half of it still leaves the candidate its direction.
TEST(ScoreTest, AKnownDirectionJoinsTheBaselineAndCannotCountForTheCandidate) {
  std::mt19937_64 engine(12);
  MaterialParameters truth = start();
  truth.a22_Pa *= 3;
  const auto runs = noisy_runs(truth, 2, {}, &engine);
  ParameterMap::Options options;
  options.tie_a12 = false;
  FitObjective objective(ParameterMap(start(), {"a11_Pa", "a22_Pa"}, options), runs);
  Eigen::VectorXd r;
  Eigen::MatrixXd j;
  objective.residuals(objective.map().initial_x(), &r, &j);
  const Eigen::MatrixXd own = j.rightCols(1);
  Eigen::MatrixXd half_of_it = own;
  half_of_it.topRows(kStrains.size()).setZero();  // the pattern on the second run only
  const ScoreTest absorbed = score_test(objective, objective.map().initial_x(), 1, with_replicates(0), own);
  const ScoreTest kept = score_test(objective, objective.map().initial_x(), 1, with_replicates(0), half_of_it);
  EXPECT_EQ(absorbed.dof, 0);
  EXPECT_EQ(absorbed.statistic, 0.0);
  EXPECT_EQ(kept.dof, 1);
  EXPECT_LT(kept.p_value_iid, 1e-6);
  EXPECT_THROW(score_test(objective, objective.map().initial_x(), 1, with_replicates(0), own.topRows(3)), std::invalid_argument);
  // Where the score comes from: the runs' shares sum to T. Both runs carry the term; with its
  // pattern known on the second run, that run's share falls by more than half (the first
  // run's rows still reach it through a11's direction, which spans both) and the first's holds.
  const ScoreTest whole = score_test(objective, objective.map().initial_x(), 1, with_replicates(0));
  ASSERT_EQ(whole.run_share.size(), 2u);
  ASSERT_EQ(kept.run_share.size(), 2u);
  std::printf("[measured] run shares %.1f, %.1f of T %.1f; with the second run's pattern known %.1f, %.1f of %.1f\n",
              whole.run_share[0], whole.run_share[1], whole.statistic, kept.run_share[0], kept.run_share[1],
              kept.statistic);
  EXPECT_NEAR(whole.run_share[0] + whole.run_share[1], whole.statistic, 1e-9 * whole.statistic);
  EXPECT_NEAR(kept.run_share[0] + kept.run_share[1], kept.statistic, 1e-9 * kept.statistic);
  EXPECT_GT(whole.run_share[1], 0.25 * whole.statistic);
  EXPECT_LT(kept.run_share[1], 0.5 * whole.run_share[1]);
  EXPECT_GT(kept.run_share[0], 0.9 * whole.run_share[0]);
}

TEST(ScoreTest, ACandidateThatOnlyRescalesRunsScoresNothingWithSpecimenScales) {
  // The toy's density multiplies every prediction: with the runs' specimen scales in the
  // baseline it has no direction of its own; without them it has one.
  std::mt19937_64 engine(13);
  const auto runs = noisy_runs(start(), 3, {}, &engine, {1.1, 0.95, 1 / (1.1 * 0.95)});
  ParameterMap::Options options;
  options.tie_a12 = false;
  FitObjective objective(ParameterMap(start(), {"a11_Pa", "density_kg_m2"}, options), runs);
  const ScoreTest unscaled = score_test(objective, objective.map().initial_x(), 1);
  objective.set_scale_groups({0, 0, 0});
  const ScoreTest scaled = score_test(objective, objective.map().initial_x(), 1);
  EXPECT_EQ(unscaled.dof, 1);
  EXPECT_EQ(scaled.dof, 0);
  EXPECT_EQ(scaled.statistic, 0.0);
  EXPECT_EQ(scaled.p_value_iid, 1.0);
  EXPECT_EQ(scaled.p_value, 1.0);
}

// The test with the noise measured apart (score_test_with_known_noise: the cantilevers' chord
// angles against their repeated overhangs): three observations, a baseline direction and a
// candidate's, each observation's error estimated from ν = 4 degrees of freedom of repeats
// (pooled, so T/d is exactly F(d, ν) under Gaussian noise). Its size at 5 %, and its power
// when the candidate's term is 4 standard errors in the data.
TEST(ScoreTest, WithTheNoiseMeasuredApartHasItsNominalSizeAndFindsTheTerm) {
  constexpr int kReplicates = 4000, kNoiseDof = 4;
  Eigen::MatrixXd baseline(3, 1), candidate(3, 1);
  baseline << 1, 1, 1;
  candidate << 1, -1, 0.5;
  std::mt19937_64 engine(7);
  std::normal_distribution<double> normal;
  std::chi_squared_distribution<double> chi2(kNoiseDof);
  int null_rejected = 0, found = 0;
  for (int k = 0; k < kReplicates; ++k) {
    const double se = std::sqrt(chi2(engine) / kNoiseDof);  // the repeats' estimate of a true 1
    const Eigen::VectorXd noise = Eigen::Vector3d(normal(engine), normal(engine), normal(engine));
    null_rejected += score_test_with_known_noise((noise + 0.3 * baseline.col(0)) / se, baseline / se, candidate / se,
                                                 kNoiseDof).p_value < 0.05;
    found += score_test_with_known_noise((noise + 4 * candidate.col(0)) / se, baseline / se, candidate / se,
                                         kNoiseDof).p_value < 0.05;
  }
  std::printf("[measured] score test, noise measured apart (nu %d): %d of %d rejected at 5 %% without the term, "
              "%d with it\n", kNoiseDof, null_rejected, kReplicates, found);
  // Binomial(4000, 0.05): 200 ± 13.8; three standard deviations either side.
  EXPECT_GE(null_rejected, 159);
  EXPECT_LE(null_rejected, 241);
  EXPECT_GT(found, kReplicates * 3 / 4);
  EXPECT_THROW(score_test_with_known_noise(Eigen::VectorXd::Zero(2), baseline, candidate, kNoiseDof),
               std::invalid_argument);
}

// Noise shared by many rows (the curves' levels on the lateral strains: one draw moves every
// run's rows alike) is not the AR(1) noise of any run: left out of the calibration, a level
// that lines up with the candidate reads as the candidate; drawn with it (ScoreCalibration::
// shared_noise), the test keeps its size. Three runs of 20 rows, each with its own intercept
// (a specimen scale); the candidate a ramp over the last two runs; the level a ramp over the
// same runs with a different share per run, its sd 3 times the rows' noise.
TEST(ScoreTest, NoiseSharedByTheRunsIsDrawnInTheCalibrationAndKeepsTheSize) {
  constexpr int kRuns = 3, kRows = 20, kDraws = 400;
  constexpr double kLevelSd = 3, kTerm = 20;
  const Eigen::Index m = kRuns * kRows;
  Eigen::MatrixXd baseline = Eigen::MatrixXd::Zero(m, kRuns), candidate = Eigen::MatrixXd::Zero(m, 1),
                  level = Eigen::MatrixXd::Zero(m, 1);
  for (int r = 0; r < kRuns; ++r)
    for (int i = 0; i < kRows; ++i) {
      const Eigen::Index row = r * kRows + i;
      const double ramp = static_cast<double>(i) / kRows;
      baseline(row, r) = 1;
      if (r > 0) candidate(row, 0) = ramp;
      level(row, 0) = kLevelSd * ramp * (r == 0 ? 0.2 : r == 1 ? 1.0 : 0.7);
    }
  const std::vector<Eigen::Index> run_rows(kRuns, kRows);
  ScoreCalibration without, with;
  without.replicates = with.replicates = 199;
  with.shared_noise = level;
  std::mt19937_64 engine(13);
  std::normal_distribution<double> normal;
  int rejected_without = 0, rejected_with = 0, found = 0;
  for (int k = 0; k < kDraws; ++k) {
    const Eigen::VectorXd r =
        level * normal(engine) + Eigen::VectorXd::NullaryExpr(m, [&] { return normal(engine); });
    without.seed = with.seed = 100 + k;
    rejected_without += score_test(r, baseline, candidate, run_rows, without).p_value < 0.05;
    rejected_with += score_test(r, baseline, candidate, run_rows, with).p_value < 0.05;
    found += score_test(r + kTerm * candidate.col(0), baseline, candidate, run_rows, with).p_value < 0.05;
  }
  std::printf("[measured] score test with a shared level (sd %g x the noise): %d of %d rejected at 5 %% without it "
              "in the calibration, %d with it; a term of %g found in %d\n", kLevelSd, rejected_without, kDraws,
              rejected_with, kTerm, found);
  // Binomial(400, 0.05): 20 ± 4.4; three standard deviations above. Without the level the
  // test is not calibrated at all (a level of 3 sd lines up with the candidate). With it the
  // test is conservative (the runs' AR(1) noise is fitted to a residual that holds the level's
  // part off the candidate), but a term several times the level's size is still found.
  EXPECT_LE(rejected_with, 33);
  EXPECT_GT(rejected_without, 4 * 33);
  EXPECT_GT(found, kDraws * 3 / 4);
  with.shared_noise = Eigen::MatrixXd::Zero(m - 1, 1);
  EXPECT_THROW(score_test(Eigen::VectorXd::Zero(m), baseline, candidate, run_rows, with), std::invalid_argument);
}

// A load cell's noise, sd a + b|y|, is in relative residuals b(1 + (a/b)/|y|): large at the low
// readings. Drawn alike along each run, the calibration's noise there is a fraction of the
// data's, and a candidate whose signature sits at the low readings is "found" in null data;
// with the readings' magnitudes (ScoreCalibration::measured) the profile is fitted and drawn,
// and the test keeps its size. Three runs of 20 rows, |y| from 0.4 to 20 (a bias strip's
// newtons), a = 0.05, b = 0.005 (papers/hidden_effects' noise); each run its own intercept; the
// candidate 1/|y| on the first half of each run (a pattern of the low readings).
TEST(ScoreTest, NoiseThatGrowsAtLowReadingsIsProfiledInTheCalibrationAndKeepsTheSize) {
  constexpr int kRuns = 3, kRows = 20, kDraws = 300;
  constexpr double kAbsolute = 0.05, kRelative = 0.005, kLowest = 0.4, kHighest = 20, kTerm = 0.15;
  const Eigen::Index m = kRuns * kRows;
  Eigen::MatrixXd baseline = Eigen::MatrixXd::Zero(m, kRuns), candidate = Eigen::MatrixXd::Zero(m, 1);
  Eigen::VectorXd magnitude(m), sd(m);
  for (int r = 0; r < kRuns; ++r)
    for (int i = 0; i < kRows; ++i) {
      const Eigen::Index row = r * kRows + i;
      magnitude[row] = kLowest * std::pow(kHighest / kLowest, static_cast<double>(i) / (kRows - 1));
      sd[row] = (kAbsolute + kRelative * magnitude[row]) / magnitude[row];
      baseline(row, r) = 1;
      if (i < kRows / 2) candidate(row, 0) = 1 / magnitude[row];
    }
  const std::vector<Eigen::Index> run_rows(kRuns, kRows);
  ScoreCalibration alike, profiled;
  alike.replicates = profiled.replicates = 199;
  profiled.measured = magnitude;
  profiled.instruments.assign(kRuns, 0);
  std::mt19937_64 engine(17);
  std::normal_distribution<double> normal;
  int rejected_alike = 0, rejected_profiled = 0, found = 0;
  for (int k = 0; k < kDraws; ++k) {
    const Eigen::VectorXd r = sd.cwiseProduct(Eigen::VectorXd::NullaryExpr(m, [&] { return normal(engine); }));
    alike.seed = profiled.seed = 200 + k;
    rejected_alike += score_test(r, baseline, candidate, run_rows, alike).p_value < 0.05;
    rejected_profiled += score_test(r, baseline, candidate, run_rows, profiled).p_value < 0.05;
    found += score_test(r + kTerm * candidate.col(0), baseline, candidate, run_rows, profiled).p_value < 0.05;
  }
  std::printf("[measured] score test with noise a + b|y| (a/b = %g, |y| %g..%g): %d of %d rejected at 5 %% drawn "
              "alike along each run, %d profiled; a term of %g/|y| found in %d\n", kAbsolute / kRelative, kLowest,
              kHighest, rejected_alike, kDraws, rejected_profiled, kTerm, found);
  // Binomial(300, 0.05): 15 ± 3.8; three standard deviations above is 26.
  EXPECT_LE(rejected_profiled, 26);
  EXPECT_GT(rejected_alike, 2 * 26);
  EXPECT_GT(found, kDraws * 3 / 4);
  profiled.instruments.pop_back();
  EXPECT_THROW(score_test(Eigen::VectorXd::Zero(m), baseline, candidate, run_rows, profiled), std::invalid_argument);
}

// A candidate whose neutral value is on its bound (a friction of 0) can only move one way: a
// residual it would explain with a negative friction is no evidence for it. With `sides` T is
// the one-sided statistic (its least squares within the range), the same T as two-sided for a
// residual along the feasible direction and 0 against it; the calibration computes each T*
// the same way, so the test keeps its size. Two candidate columns, one bounded below and one
// free, on iid noise; the step that explains a residual r is −c, c r's coefficients.
TEST(ScoreTest, ACandidateOnItsBoundIsTestedOneSided) {
  constexpr int kRows = 60, kDraws = 300;
  const Eigen::Index m = kRows;
  Eigen::MatrixXd baseline = Eigen::MatrixXd::Ones(m, 1), candidate(m, 2);
  for (Eigen::Index i = 0; i < m; ++i) {
    const double x = static_cast<double>(i) / m;
    candidate(i, 0) = x * x;
    candidate(i, 1) = std::sin(6 * x);
  }
  const std::vector<Eigen::Index> run_rows(1, m);
  const std::vector<int> bounded_below = {1, 0};
  std::mt19937_64 engine(19);
  std::normal_distribution<double> normal;
  const Eigen::VectorXd noise = Eigen::VectorXd::NullaryExpr(m, [&] { return 0.01 * normal(engine); });
  ScoreCalibration calibration;
  calibration.replicates = 199;
  // r = −S δ: the residual a step δ explains. Feasible (δ₀ > 0): as two-sided; infeasible: the
  // free column's part only.
  const Eigen::VectorXd feasible = noise - candidate.col(0), infeasible = noise + candidate.col(0);
  const ScoreTest two = score_test(feasible, baseline, candidate, run_rows, calibration);
  EXPECT_NEAR(score_test(feasible, baseline, candidate, run_rows, calibration, bounded_below).statistic, two.statistic,
              1e-9 * two.statistic);
  // Against it, what the free column alone explains: its own test's T, whose σ² has one
  // residual degree of freedom more (m − 2 against m − 3), and far below the two-sided T.
  const double free_alone =
      score_test(infeasible, baseline, candidate.rightCols(1), run_rows, calibration).statistic * (m - 3.0) / (m - 2.0);
  const double one_sided = score_test(infeasible, baseline, candidate, run_rows, calibration, bounded_below).statistic;
  EXPECT_NEAR(one_sided, free_alone, 1e-9 * free_alone);
  EXPECT_LT(one_sided, 0.01 * score_test(infeasible, baseline, candidate, run_rows, calibration).statistic);
  int rejected = 0;
  for (int k = 0; k < kDraws; ++k) {
    calibration.seed = 300 + k;
    const Eigen::VectorXd r = Eigen::VectorXd::NullaryExpr(m, [&] { return normal(engine); });
    rejected += score_test(r, baseline, candidate, run_rows, calibration, bounded_below).p_value < 0.05;
  }
  std::printf("[measured] one-sided score test: %d of %d null draws rejected at 5 %%\n", rejected, kDraws);
  EXPECT_LE(rejected, 26);  // Binomial(300, 0.05) + 3 sd
  EXPECT_GE(rejected, 5);   // and not empty: the statistic is not always 0
  EXPECT_THROW(score_test(noise, baseline, candidate, run_rows, calibration, {1}), std::invalid_argument);
  // Every column on its bound: the face with every column held is the zero part (its SVD would
  // be of an empty matrix: a segfault in a Release build before session 31). Against both
  // columns' ranges only the noise's share is explained; a feasible residual gives the
  // two-sided T.
  const std::vector<int> both_bounded = {1, 1};
  const Eigen::VectorXd against_both = noise + candidate.col(0) + 0.5 * candidate.col(1);
  EXPECT_LT(score_test(against_both, baseline, candidate, run_rows, calibration, both_bounded).statistic,
            0.01 * score_test(against_both, baseline, candidate, run_rows, calibration).statistic);
  EXPECT_NEAR(score_test(feasible, baseline, candidate, run_rows, calibration, both_bounded).statistic, two.statistic,
              1e-9 * two.statistic);
}

// The candidate's directions beyond the baseline are counted from the signature's singular
// values, not from the eigenvalues of its Gram matrix, whose round-off (ε‖SᵀS‖) is far above
// the rank tolerance squared: with two observations and one baseline direction (the two
// cantilevers' chord angles beside the thickness) two candidate columns leave exactly one
// direction, whatever the columns. Found when the same bend data gave d = 1 or d = 2 with
// the chord angles computed two ways (2026-12-05).
TEST(ScoreTest, CountsTheCandidatesDirectionsBeyondTheBaselineWithoutRoundOff) {
  constexpr int kDraws = 200;
  std::mt19937_64 engine(11);
  std::normal_distribution<double> normal;
  int counted_one = 0;
  for (int k = 0; k < kDraws; ++k) {
    Eigen::MatrixXd baseline(2, 1), candidate(2, 2);
    baseline << normal(engine), normal(engine);
    candidate << normal(engine), normal(engine), normal(engine), normal(engine);
    const Eigen::VectorXd r = Eigen::Vector2d(normal(engine), normal(engine));
    counted_one += score_test_with_known_noise(r, baseline, candidate, 4).dof == 1;
  }
  EXPECT_EQ(counted_one, kDraws);
}

}  // namespace
}  // namespace twill
