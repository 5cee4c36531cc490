// The repeats of a tensile test without a model: each run's loading branch on the rows every run
// covers, and each run's specimen scale onto their mean (docs/discovery.md §2, "The repeats'
// scatter"). What `twill discover` judges `unexplained` against (the repeat floor), and the
// scatter of a direction's curve level that bending-anisotropy's chord angles inherit
// (docs/effects/bending-anisotropy.md).
#pragma once

#include <Eigen/Dense>
#include <optional>
#include <vector>

#include "core/dataset.hpp"

namespace twill {

struct RepeatBranches {
  std::vector<Eigen::VectorXd> forces;  ///< each run's loading forces on the shared rows [N]
  std::vector<double> scales;           ///< each run's L1-best scale onto the mean
  Eigen::VectorXd mean;                 ///< the scaled runs' mean
};

/// The runs of `test` on the extensions of its first run's loading branch that every run covers
/// (interpolated linearly, positive forces), each run's scale and the mean refined by a few
/// sweeps; nullopt with fewer than two runs or too few shared rows to tell a scale from scatter.
std::optional<RepeatBranches> repeat_branches(const TensileTest& test);

}  // namespace twill
