#include "fitting/repeat_branches.hpp"

#include <algorithm>
#include <limits>
#include <utility>

#include "fitting/fit_protocol.hpp"

namespace twill {
namespace {

// A repeat floor needs this many rows every run covers: fewer cannot tell a scale from scatter.
constexpr Eigen::Index kSharedRows = 5;
// Sweeps of (mean curve, each run's scale onto it): the scales settle in two (they are a few
// percent apart), the third confirms.
constexpr int kSweeps = 3;

// A run's loading branch (rows up to its peak), sorted by extension.
std::vector<std::pair<double, double>> loading_branch(const TensileRun& run) {
  std::vector<std::pair<double, double>> rows;
  for (size_t i = 0; i <= run.peak_index && i < run.size(); ++i) rows.emplace_back(run.extension_mm[i], run.force_N[i]);
  std::stable_sort(rows.begin(), rows.end());
  return rows;
}

// The branch's force at extension x by linear interpolation; nullopt outside its range.
std::optional<double> force_at(const std::vector<std::pair<double, double>>& branch, double x) {
  if (branch.empty() || x < branch.front().first || x > branch.back().first) return std::nullopt;
  const auto above = std::lower_bound(branch.begin(), branch.end(), std::make_pair(x, -std::numeric_limits<double>::infinity()));
  if (above->first == x || above == branch.begin()) return above->second;
  const auto below = above - 1;
  return below->second + (above->second - below->second) * (x - below->first) / (above->first - below->first);
}

}  // namespace

std::optional<RepeatBranches> repeat_branches(const TensileTest& test) {
  if (test.runs.size() < 2) return std::nullopt;
  std::vector<std::vector<std::pair<double, double>>> branches;
  for (const TensileRun& run : test.runs) branches.push_back(loading_branch(run));
  std::vector<std::vector<double>> forces(branches.size());
  for (const auto& [x, unused] : branches.front()) {
    std::vector<double> at;
    for (const auto& b : branches)
      if (const auto f = force_at(b, x); f && *f > 0) at.push_back(*f);
    if (x <= 0 || at.size() != branches.size()) continue;
    for (size_t r = 0; r < at.size(); ++r) forces[r].push_back(at[r]);
  }
  const auto k = static_cast<Eigen::Index>(forces.front().size());
  if (k < kSharedRows) return std::nullopt;
  RepeatBranches out;
  for (const auto& v : forces) out.forces.push_back(Eigen::Map<const Eigen::VectorXd>(v.data(), k));
  const double n = static_cast<double>(out.forces.size());
  out.scales.assign(out.forces.size(), 1.0);
  out.mean = Eigen::VectorXd::Zero(k);
  for (int sweep = 0; sweep < kSweeps; ++sweep) {
    out.mean.setZero();
    for (size_t r = 0; r < out.forces.size(); ++r) out.mean += out.scales[r] * out.forces[r] / n;
    for (size_t r = 0; r < out.forces.size(); ++r)
      out.scales[r] = linearised_l1_minimiser(Eigen::VectorXd::Zero(k), out.forces[r], out.mean);
  }
  return out;
}

}  // namespace twill
