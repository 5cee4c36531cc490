#include "experiments/shared_schedule.hpp"

#include <algorithm>

namespace twill {

ScheduleUnion schedule_union(const std::vector<std::vector<double>>& schedules) {
  ScheduleUnion u;
  for (const auto& s : schedules) u.entries.insert(u.entries.end(), s.begin(), s.end());
  std::sort(u.entries.begin(), u.entries.end());
  u.entries.erase(std::unique(u.entries.begin(), u.entries.end()), u.entries.end());
  for (const auto& s : schedules) {
    std::vector<int> rows;
    for (double x : s)
      rows.push_back(static_cast<int>(std::lower_bound(u.entries.begin(), u.entries.end(), x) - u.entries.begin()));
    u.rows.push_back(std::move(rows));
  }
  return u;
}

bool shares_enough(const ScheduleUnion& u, const std::vector<std::vector<double>>& schedules) {
  size_t together = 0;
  for (const auto& s : schedules) together += s.size();
  return static_cast<double>(u.entries.size()) <= kShareAtMost * static_cast<double>(together);
}

SharedSchedule::Prediction SharedSchedule::predict(const MaterialParameters& k, const std::vector<int>& flat,
                                                   bool with_jacobian) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The values do not depend on which derivatives were asked for; a Jacobian does.
  if (has_last_ && last_k_ == k && (!with_jacobian || (last_with_jacobian_ && last_flat_ == flat))) return last_;
  Prediction p;
  p.ok = inner_->predict(k, flat, &p.values, with_jacobian ? &p.jacobian : nullptr, &p.message);
  has_last_ = true;
  last_with_jacobian_ = with_jacobian;
  last_k_ = k;
  last_flat_ = flat;
  last_ = p;
  return p;
}

ScheduleView::ScheduleView(std::shared_ptr<SharedSchedule> shared, std::string label, std::vector<double> schedule,
                           Eigen::VectorXd measured, std::vector<int> rows, bool counts_solves)
    : shared_(std::move(shared)),
      label_(std::move(label)),
      schedule_(std::move(schedule)),
      measured_(std::move(measured)),
      rows_(std::move(rows)),
      counts_solves_(counts_solves) {}

namespace {

// The rows of `all` at `rows`.
Eigen::MatrixXd picked(const Eigen::MatrixXd& all, const std::vector<int>& rows) {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(rows.size()), all.cols());
  for (size_t i = 0; i < rows.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = all.row(rows[i]);
  return out;
}

}  // namespace

bool ScheduleView::predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
                           Eigen::MatrixXd* jacobian, std::string* message) {
  const SharedSchedule::Prediction p = shared_->predict(k, flat, jacobian != nullptr);
  if (!p.ok) {
    if (message) *message = p.message;
    return false;
  }
  *values = picked(p.values, rows_);
  if (jacobian) *jacobian = picked(p.jacobian, rows_);
  return true;
}

ExperimentRun ScheduleView::simulate(const MaterialParameters& k) {
  ExperimentRun all = shared_->inner().simulate(k);
  // The union's converged prefix: this schedule's entries up to the first one beyond it.
  const int converged = static_cast<int>(all.schedule.size());
  size_t kept = 0;
  while (kept < rows_.size() && rows_[kept] < converged) ++kept;
  const std::vector<int> rows(rows_.begin(), rows_.begin() + static_cast<std::ptrdiff_t>(kept));
  ExperimentRun run;
  run.schedule.assign(schedule_.begin(), schedule_.begin() + static_cast<std::ptrdiff_t>(kept));
  run.values = picked(all.values, rows);
  for (const auto& [name, column] : all.extras) {
    std::vector<double> own;
    for (int r : rows) own.push_back(column[static_cast<size_t>(r)]);
    run.extras.emplace_back(name, std::move(own));
  }
  run.completed = kept == rows_.size();
  run.message = run.completed ? "" : all.message;
  run.newton_iterations = all.newton_iterations;
  run.wall_time_s = all.wall_time_s;
  return run;
}

bool ScheduleView::predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                             Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                             std::string* message) {
  Eigen::VectorXd all_values;
  Eigen::MatrixXd all_jacobian;
  if (!shared_->inner().predict_setup_derivatives(k, quantities, &all_values, &all_jacobian, message)) return false;
  *values = picked(all_values, rows_);
  *jacobian = picked(all_jacobian, rows_);
  return true;
}

}  // namespace twill
