// The load cell's noise as the fit tests' repeats show it, and the misfit test `unexplained`
// rests on (docs/discovery.md §2, "The noise floor from the repeats"). One test's repeats give
// its scatter from a handful of rows that matter: with two specimens and a stiffening curve whose
// last rows carry most of Σ|F|, a test's own repeat scatter is an estimate with about two
// degrees of freedom — on the null-20 twins it put a perfect fit at up to 4× it (papers/discovery,
// session 36). Every test's repeats measure the same instrument, so its law is fitted once over
// all of them, and what a perfect model would miss on each test is drawn from that law.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "core/score_test.hpp"
#include "fitting/discovery.hpp"
#include "fitting/repeat_branches.hpp"

namespace twill {

namespace {

// Each run's scale onto the runs' mean is its weighted least squares in relative terms,
// Σ w_i ((s f_i − m_i)/m_i)², w_i = 1/profile(m_i)², refined with the mean by these many sweeps:
// unweighted, the noisy low readings set every run's scale and their noise spreads into the quiet
// rows as a shift shared along the run (a load cell's b came out 40 % high, its rows correlated).
constexpr int kScaleSweeps = 5;
// The law is fitted this many times, each time with the scales weighted by the last profile
// (iteratively reweighted least squares; the second settles it to a few per cent).
constexpr int kLawSweeps = 3;

// The relative deviations of each run about the runs' mean on their shared loading rows, the
// mean's magnitude, and the degrees of freedom left: a test of n runs on k rows fits k means and
// n − 1 scales beside a common factor, (k − 1)(n − 1).
struct Deviations {
  std::vector<double> u, magnitude;
  std::vector<Eigen::Index> run_rows;
  double dof = 0;
};

void add_deviations(const RepeatBranches& b, const NoiseProfile* profile, Deviations* out) {
  const size_t n = b.forces.size();
  std::vector<double> scale(n, 1.0);
  Eigen::VectorXd mean = b.mean;
  for (int sweep = 0; sweep < kScaleSweeps; ++sweep) {
    mean.setZero();
    for (size_t r = 0; r < n; ++r) mean += scale[r] * b.forces[r] / static_cast<double>(n);
    const Eigen::ArrayXd weight =
        profile ? mean.array().abs().unaryExpr([&](double m) { return 1 / std::pow(profile->at(m), 2); }).eval()
                : Eigen::ArrayXd::Ones(mean.size()).eval();
    for (size_t r = 0; r < n; ++r) {
      const Eigen::ArrayXd ratio = b.forces[r].array() / mean.array();
      scale[r] = (weight * ratio).sum() / (weight * ratio.square()).sum();
    }
  }
  for (size_t r = 0; r < n; ++r) {
    for (Eigen::Index i = 0; i < mean.size(); ++i) {
      out->u.push_back((scale[r] * b.forces[r][i] - mean[i]) / mean[i]);
      out->magnitude.push_back(std::abs(mean[i]));
    }
    out->run_rows.push_back(mean.size());
  }
  out->dof += static_cast<double>((mean.size() - 1) * static_cast<Eigen::Index>(n - 1));
}

Eigen::VectorXd as_vector(const std::vector<double>& v) { return Eigen::Map<const Eigen::VectorXd>(v.data(), v.size()); }

// One run's average relative error at its least-squares relative scale (the fit's residuals).
double scaled_error(const Eigen::ArrayXd& predicted, const Eigen::ArrayXd& measured) {
  const Eigen::ArrayXd ratio = predicted / measured;
  const double s = ratio.sum() / ratio.square().sum();
  return (s * predicted - measured).abs().sum() / measured.abs().sum();
}

}  // namespace

namespace {

// The deviations of every fit test with repeats, the scales weighted by `profile` (none: alike).
Deviations all_deviations(const std::vector<RepeatBranches>& tests, const NoiseProfile* profile) {
  Deviations d;
  for (const RepeatBranches& b : tests) add_deviations(b, profile, &d);
  return d;
}

}  // namespace

std::optional<RepeatNoise> repeat_noise(const Dataset& dataset) {
  std::vector<RepeatBranches> tests;
  for (const TensileTest& test : dataset.tensile)
    if (test.role == TestRole::Fit && test.runs.size() >= 2)
      if (std::optional<RepeatBranches> b = repeat_branches(test)) tests.push_back(std::move(*b));
  if (tests.empty()) return std::nullopt;
  RepeatNoise noise;
  Deviations d;
  for (int sweep = 0; sweep < kLawSweeps; ++sweep) {
    d = all_deviations(tests, sweep == 0 ? nullptr : &noise.profile);
    const Eigen::VectorXd u = as_vector(d.u), magnitude = as_vector(d.magnitude);
    if (!(magnitude.minCoeff() > 0) || !(d.dof > 0)) return std::nullopt;
    noise.profile = fit_noise_profile(u, magnitude, d.run_rows);
  }
  Eigen::VectorXd standardised(static_cast<Eigen::Index>(d.u.size()));
  for (Eigen::Index i = 0; i < standardised.size(); ++i) standardised[i] = d.u[i] / noise.profile.at(d.magnitude[i]);
  noise.level = std::sqrt(standardised.squaredNorm() / d.dof);
  Eigen::Index row = 0;
  for (const Eigen::Index rows : d.run_rows) {
    noise.correlation += noise_correlation(standardised.segment(row, rows)) / static_cast<double>(d.run_rows.size());
    row += rows;
  }
  noise.runs = static_cast<int>(d.run_rows.size());
  noise.rows = static_cast<int>(d.u.size());
  return noise;
}

NoiseFloorTest noise_floor_test(const RepeatNoise& noise, const std::vector<RunReadings>& runs, double offset,
                                const ScoreCalibration& draws) {
  NoiseFloorTest out;
  std::vector<Eigen::ArrayXd> predicted, measured, sd;
  for (const RunReadings& run : runs) {
    if (run.measured.size() != run.predicted.size() || run.measured.empty())
      throw std::invalid_argument("noise_floor_test: a run's measured and predicted readings differ in length");
    predicted.push_back(as_vector(run.predicted).array());
    measured.push_back(as_vector(run.measured).array());
    if (!(measured.back().abs().minCoeff() > 0) || !(predicted.back().abs().minCoeff() > 0)) return out;
    sd.push_back(predicted.back().unaryExpr([&](double y) { return noise.sd(y); }));
  }
  if (runs.empty()) return out;
  out.observed = 0;
  for (size_t r = 0; r < runs.size(); ++r) out.observed += scaled_error(predicted[r], measured[r]) / runs.size();
  std::mt19937_64 engine(draws.seed);
  double sum = 0;
  int as_large = 0;
  for (int b = 0; b < draws.replicates; ++b) {
    double error = 0;
    for (size_t r = 0; r < runs.size(); ++r) {
      const Eigen::ArrayXd drawn = predicted[r] + sd[r] * draw_ar1(predicted[r].size(), noise.correlation, &engine).array();
      error += scaled_error(predicted[r], drawn) / runs.size();
    }
    sum += error;
    as_large += error + offset >= out.observed;
  }
  out.floor = sum / draws.replicates;
  out.p_value = (1.0 + as_large) / (1.0 + draws.replicates);
  return out;
}

}  // namespace twill
