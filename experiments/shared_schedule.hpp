#pragma once
// Runs that differ only in their schedule share one simulation.
//
// The repeats of a tensile test (and the tests of one angle at other crosshead speeds) are
// the same strip: same angle, width, gauge length and mesh. The elastic experiment's force at
// an extension does not depend on the path to it (tensile_strip.hpp: the law is elastic, each
// step starts from the previous equilibrium) nor on the clock (experiment.hpp: the elastic
// experiments ignore rate and time; what depends on them is added by the effects' observable
// hooks, per run, effects/effect_experiment.hpp). So one simulation along the union of the
// runs' extensions predicts every run at once, with the same Eq. 6 derivatives, and a fit of
// five specimens per angle costs one strip per angle instead of five.
//
// SharedSchedule holds the one experiment on the union and its last prediction; a
// ScheduleView is one run's Experiment: its own schedule, measured values and label, its rows
// of the union. The objective asks each view in turn at one k (core/fit_objective.cpp,
// predict_all): the first solves, the others read the cached result. The solves are counted
// once (by the group's first view).
//
// A run's path may come back down (unloading rows): its entries on the way down read the
// union's solves on the way up, which for the elastic strip are the same equilibria (a
// strip in tension between clamps has one; tested against the run's own solve in file order).
// Which runs share is the caller's choice (create_experiments in
// effects/effect_experiment.hpp): strips that agree, and a union that saves at least half the
// points (see shares_enough()).
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "experiments/experiment.hpp"

namespace twill {

/// The sorted union of schedules (exactly equal entries merged), and for each schedule the
/// index of each of its entries in the union.
struct ScheduleUnion {
  std::vector<double> entries;
  std::vector<std::vector<int>> rows;
};
ScheduleUnion schedule_union(const std::vector<std::vector<double>>& schedules);
/// Whether sharing is worth it: the union has at most kShareAtMost of the schedules' entries
/// together. Below that, the union's many small steps (each a warm-started solve and an Eq. 6
/// solve) cost about what the separate runs' fewer larger steps do, and nothing is gained.
inline constexpr double kShareAtMost = 0.5;
bool shares_enough(const ScheduleUnion& u, const std::vector<std::vector<double>>& schedules);

class SharedSchedule {
 public:
  /// `inner`: the experiment on the union's entries (no measured values).
  explicit SharedSchedule(std::unique_ptr<Experiment> inner) : inner_(std::move(inner)) {}
  Experiment& inner() { return *inner_; }

  struct Prediction {
    bool ok = false;
    std::string message;
    Eigen::VectorXd values;
    Eigen::MatrixXd jacobian;  ///< empty unless asked for
  };
  /// inner().predict at k, or the last result when k, `flat` and the Jacobian's need match it.
  Prediction predict(const MaterialParameters& k, const std::vector<int>& flat, bool with_jacobian);

 private:
  std::unique_ptr<Experiment> inner_;
  std::mutex mutex_;
  bool has_last_ = false, last_with_jacobian_ = false;
  MaterialParameters last_k_;
  std::vector<int> last_flat_;
  Prediction last_;
};

class ScheduleView final : public Experiment {
 public:
  /// `rows`: the union's index of each schedule entry; `counts_solves`: whether this view
  /// reports the shared experiment's solves (one view of a group does).
  ScheduleView(std::shared_ptr<SharedSchedule> shared, std::string label, std::vector<double> schedule,
               Eigen::VectorXd measured, std::vector<int> rows, bool counts_solves);

  std::string observable() const override { return shared_->inner().observable(); }
  std::string schedule_quantity() const override { return shared_->inner().schedule_quantity(); }
  const std::vector<double>& schedule() const override { return schedule_; }
  /// The union's run, cut to this schedule's entries (completed when all of them converged).
  ExperimentRun simulate(const MaterialParameters& k) override;
  std::vector<std::string> setup_sensitivities() const override { return shared_->inner().setup_sensitivities(); }
  bool predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                 Eigen::VectorXd* values, Eigen::MatrixXd* jacobian, std::string* message) override;
  bool last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const override { return shared_->inner().last_surface(V, F); }

  std::string label() const override { return label_; }
  const Eigen::VectorXd& measured() const override { return measured_; }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string* message) override;
  long equilibrium_solves() const override { return counts_solves_ ? shared_->inner().equilibrium_solves() : 0; }

 private:
  std::shared_ptr<SharedSchedule> shared_;
  std::string label_;
  std::vector<double> schedule_;
  Eigen::VectorXd measured_;
  std::vector<int> rows_;
  bool counts_solves_;
};

}  // namespace twill
