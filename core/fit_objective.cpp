#include "core/fit_objective.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "core/params_io.hpp"
#include "core/specimen_scale.hpp"

namespace twill {

namespace {

bool matches(const std::string& pattern, const std::string& name) {
  if (!pattern.empty() && pattern.back() == '*')
    return name.compare(0, pattern.size() - 1, pattern, 0, pattern.size() - 1) == 0;
  return pattern == name;
}

constexpr int kStiffnesses[] = {FlatLayout::kA11, FlatLayout::kA12, FlatLayout::kA22,
                                FlatLayout::kG12};

}  // namespace

ParameterMap::ParameterMap(const MaterialParameters& start,
                           const std::vector<std::string>& free_names, const Options& options)
    : start_(start), options_(options), k0_(start.to_flat()) {
  const std::vector<std::string> names = start.parameter_names();
  for (const std::string& pattern : free_names) {
    bool any = false;
    for (size_t j = 0; j < names.size(); ++j)
      if (matches(pattern, names[j])) {
        any = true;
        if (std::find(free_.begin(), free_.end(), static_cast<int>(j)) == free_.end())
          free_.push_back(static_cast<int>(j));
      }
    if (!any) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw std::invalid_argument("free parameter '" + pattern + "' matches no parameter; known: " +
                                  known);
    }
  }
  if (free_.empty()) throw std::invalid_argument("no free parameter to fit");
  if (options_.tie_a12 &&
      std::find(free_.begin(), free_.end(), FlatLayout::kA12) != free_.end())
    throw std::invalid_argument(
        "a12_Pa cannot be free while tied to ½ min(a11, a22) (paper §5.2); untie it first");
  const bool thickness_free =
      std::find(free_.begin(), free_.end(), FlatLayout::kThickness) != free_.end();
  if (options_.rescale_with_thickness && !thickness_free)
    throw std::invalid_argument("thickness rescaling needs thickness_m among the free parameters");
  if (options_.rescale_with_thickness)
    for (int j : kStiffnesses)
      if (std::find(free_.begin(), free_.end(), j) != free_.end())
        throw std::invalid_argument(
            "thickness rescaling sets the stiffnesses from τ (paper §5.2 step 7); " +
            start.parameter_names()[static_cast<size_t>(j)] + " cannot be free with it");

  scale_.resize(dimension());
  for (int i = 0; i < dimension(); ++i) {
    const double v = k0_[free_[static_cast<size_t>(i)]];
    const ParameterRange* range = range_of(free_[static_cast<size_t>(i)]);
    scale_[i] = range && range->typical > 0 ? range->typical : v != 0 ? std::abs(v) : 1.0;
  }
  dependent_ = free_;
  auto add_dependent = [this](int j) {
    if (std::find(dependent_.begin(), dependent_.end(), j) == dependent_.end())
      dependent_.push_back(j);
  };
  if (options_.rescale_with_thickness)
    for (int j : kStiffnesses) add_dependent(j);
  if (options_.tie_a12) {
    const bool a11_or_a22_moves =
        std::find(dependent_.begin(), dependent_.end(), FlatLayout::kA11) != dependent_.end() ||
        std::find(dependent_.begin(), dependent_.end(), FlatLayout::kA22) != dependent_.end();
    if (a11_or_a22_moves) {
      add_dependent(FlatLayout::kA12);
      tie_active_ = true;
    }
  }
}

std::vector<std::string> ParameterMap::free_names() const {
  const std::vector<std::string> names = start_.parameter_names();
  std::vector<std::string> out;
  for (int j : free_) out.push_back(names[static_cast<size_t>(j)]);
  return out;
}

Eigen::VectorXd ParameterMap::initial_x() const {
  Eigen::VectorXd x(dimension());
  for (int i = 0; i < dimension(); ++i) x[i] = k0_[free_[static_cast<size_t>(i)]] / scale_[i];
  return x;
}

namespace {

// Flat vector k(x) without validation, and ∂k/∂x over all flat entries (flat × n) on request.
Eigen::VectorXd map_flat(const Eigen::VectorXd& k0, const std::vector<int>& free,
                         const Eigen::VectorXd& scale, bool tie_a12, bool rescale,
                         const Eigen::VectorXd& x, Eigen::MatrixXd* dk_dx) {
  const int n = static_cast<int>(free.size());
  Eigen::VectorXd k = k0;
  if (dk_dx) dk_dx->setZero(k0.size(), n);
  int thickness_column = -1;
  for (int i = 0; i < n; ++i) {
    const int j = free[static_cast<size_t>(i)];
    k[j] = scale[i] * x[i];
    if (dk_dx) (*dk_dx)(j, i) = scale[i];
    if (j == FlatLayout::kThickness) thickness_column = i;
  }
  if (rescale) {
    // a = a0 τ0/τ ⇒ ∂a/∂x_τ = −a0 τ0/τ² · s_τ.
    const double tau0 = k0[FlatLayout::kThickness], tau = k[FlatLayout::kThickness];
    for (int j : kStiffnesses) {
      k[j] = k0[j] * tau0 / tau;
      if (dk_dx) (*dk_dx)(j, thickness_column) = -k0[j] * tau0 / (tau * tau) * scale[thickness_column];
    }
  }
  if (tie_a12) {
    // a12 = ½ min(a11, a22): the derivative follows the smaller one (one-sided at a tie).
    const bool a11_smaller = k[FlatLayout::kA11] <= k[FlatLayout::kA22];
    const int source = a11_smaller ? FlatLayout::kA11 : FlatLayout::kA22;
    k[FlatLayout::kA12] = 0.5 * k[source];
    if (dk_dx) dk_dx->row(FlatLayout::kA12) = 0.5 * dk_dx->row(source);
  }
  return k;
}

}  // namespace

MaterialParameters ParameterMap::parameters(const Eigen::VectorXd& x) const {
  if (x.size() != dimension())
    throw std::invalid_argument("ParameterMap: x has " + std::to_string(x.size()) +
                                " entries, expected " + std::to_string(dimension()));
  MaterialParameters p = start_;
  p.set_from_flat(map_flat(k0_, free_, scale_, tie_active_, options_.rescale_with_thickness,
                           x, nullptr));
  validate_parameters(p, "fit iterate");
  return p;
}

Eigen::MatrixXd ParameterMap::jacobian(const Eigen::VectorXd& x) const {
  Eigen::MatrixXd full;
  map_flat(k0_, free_, scale_, tie_active_, options_.rescale_with_thickness, x, &full);
  Eigen::MatrixXd out(static_cast<Eigen::Index>(dependent_.size()), dimension());
  for (size_t r = 0; r < dependent_.size(); ++r)
    out.row(static_cast<Eigen::Index>(r)) = full.row(dependent_[r]);
  return out;
}

const ParameterRange* ParameterMap::range_of(int flat) const {
  const std::string name = start_.parameter_names()[static_cast<size_t>(flat)];
  for (const ParameterRange& r : options_.ranges)
    if (r.name == name) return &r;
  return nullptr;
}

Eigen::VectorXd ParameterMap::lower_bounds() const {
  Eigen::VectorXd lower =
      Eigen::VectorXd::Constant(dimension(), -std::numeric_limits<double>::infinity());
  for (int i = 0; i < dimension(); ++i) {
    const int j = free_[static_cast<size_t>(i)];
    if (const ParameterRange* range = range_of(j))
      lower[i] = range->lower / scale_[i];
    else if (j == FlatLayout::kDensity || j == FlatLayout::kThickness || j == FlatLayout::kA11 ||
             j == FlatLayout::kA22 || j == FlatLayout::kG12)
      lower[i] = 1e-6 * k0_[j] / scale_[i];
  }
  return lower;
}

Eigen::VectorXd ParameterMap::upper_bounds() const {
  Eigen::VectorXd upper = Eigen::VectorXd::Constant(dimension(), std::numeric_limits<double>::infinity());
  for (int i = 0; i < dimension(); ++i)
    if (const ParameterRange* range = range_of(free_[static_cast<size_t>(i)])) upper[i] = range->upper / scale_[i];
  return upper;
}

// ---------------------------------------------------------------------------------------------

FitObjective::FitObjective(ParameterMap map, std::vector<std::shared_ptr<Predictor>> predictors,
                           std::vector<double> weights)
    : map_(std::move(map)), predictors_(std::move(predictors)), weights_(std::move(weights)) {
  if (predictors_.empty()) throw std::invalid_argument("FitObjective: no predictors");
  if (weights_.empty()) weights_.assign(predictors_.size(), 1.0);
  if (weights_.size() != predictors_.size())
    throw std::invalid_argument("FitObjective: " + std::to_string(weights_.size()) +
                                " weights for " + std::to_string(predictors_.size()) +
                                " predictors");
  for (size_t i = 0; i < predictors_.size(); ++i) {
    if (!(weights_[i] > 0))
      throw std::invalid_argument("FitObjective: weight of " + predictors_[i]->label() +
                                  " must be > 0");
    const Eigen::VectorXd& m = predictors_[i]->measured();
    for (Eigen::Index j = 0; j < m.size(); ++j)
      if (!(std::abs(m[j]) > 0) || !std::isfinite(m[j]))
        throw std::invalid_argument("FitObjective: " + predictors_[i]->label() + " measurement " +
                                    std::to_string(j) + " is zero or not finite (relative error)");
  }
  predictions_.resize(predictors_.size());
  scales_.assign(predictors_.size(), 1.0);
}

int FitObjective::num_residuals() const {
  int m = 0;
  for (const auto& p : predictors_) m += static_cast<int>(p->measured().size());
  return m;
}

void FitObjective::set_scale_groups(std::vector<int> groups) {
  if (!groups.empty() && groups.size() != predictors_.size())
    throw std::invalid_argument("FitObjective: " + std::to_string(groups.size()) + " scale groups for " +
                                std::to_string(predictors_.size()) + " predictors");
  scale_groups_ = std::move(groups);
  cache_valid_ = false;
}

bool FitObjective::predict_all(const MaterialParameters& k, bool want_jacobian, std::vector<Eigen::VectorXd>* values,
                               std::vector<Eigen::MatrixXd>* jacobians) {
  values->assign(predictors_.size(), Eigen::VectorXd());
  jacobians->assign(predictors_.size(), Eigen::MatrixXd());
  for (size_t i = 0; i < predictors_.size(); ++i) {
    Predictor& p = *predictors_[i];
    std::string message;
    bool ok = false;
    try {
      ok = p.predict(k, map_.dependent_indices(), &(*values)[i], want_jacobian ? &(*jacobians)[i] : nullptr,
                     &message);
    } catch (const std::exception& e) {
      message = e.what();
    }
    if (!ok) {
      failure_ = p.label() + ": " + message;
      ++failed_evaluations_;
      return false;
    }
  }
  return true;
}

std::vector<double> FitObjective::profiled_scales(const std::vector<Eigen::VectorXd>& values) const {
  std::vector<double> scales(predictors_.size(), 1.0);
  std::map<int, std::vector<size_t>> members;
  for (size_t i = 0; i < scale_groups_.size(); ++i)
    if (scale_groups_[i] >= 0) members[scale_groups_[i]].push_back(i);
  for (const auto& [group, indices] : members) {
    std::vector<Eigen::VectorXd> relative;
    for (size_t i : indices) relative.push_back(values[i].cwiseQuotient(predictors_[i]->measured()));
    std::vector<ScaledRun> runs;
    for (size_t j = 0; j < indices.size(); ++j) runs.push_back({&relative[j], weights_[indices[j]]});
    const std::vector<double> s = profiled_group_scales(runs);
    for (size_t j = 0; j < indices.size(); ++j) scales[indices[j]] = s[j];
  }
  return scales;
}

bool FitObjective::compute(const Eigen::VectorXd& x, bool want_jacobian) {
  if (cache_valid_ && x.size() == cache_x_.size() && x == cache_x_ &&
      (cache_has_jacobian_ || !want_jacobian))
    return std::isfinite(cache_r_.sum());
  ++evaluations_;
  cache_valid_ = true;
  cache_x_ = x;
  cache_has_jacobian_ = want_jacobian;
  const int m = num_residuals();
  cache_r_ = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::quiet_NaN());
  cache_j_.resize(0, 0);

  MaterialParameters k;
  try {
    k = map_.parameters(x);
  } catch (const std::exception& e) {
    failure_ = e.what();
    ++failed_evaluations_;
    return false;
  }
  std::vector<Eigen::VectorXd> values;
  std::vector<Eigen::MatrixXd> dvalues;
  if (!predict_all(k, want_jacobian, &values, &dvalues)) return false;
  const std::vector<double> scales = profiled_scales(values);
  const Eigen::MatrixXd dk_dx = want_jacobian ? map_.jacobian(x) : Eigen::MatrixXd();
  if (want_jacobian) cache_j_.setZero(m, dimension());
  Eigen::VectorXd r(m);
  int row = 0;
  for (size_t i = 0; i < predictors_.size(); ++i) {
    const Eigen::VectorXd& measured = predictors_[i]->measured();
    const double sqrt_w = std::sqrt(weights_[i]);
    const Eigen::Index n = measured.size();
    predictions_[i] = scales[i] * values[i];
    r.segment(row, n) = sqrt_w * (predictions_[i] - measured).cwiseQuotient(measured);
    // Scales held here; projected below (core/specimen_scale.hpp).
    if (want_jacobian)
      cache_j_.middleRows(row, n) =
          (sqrt_w * scales[i] * measured.cwiseInverse()).asDiagonal() * (dvalues[i] * dk_dx);
    row += static_cast<int>(n);
  }
  scales_ = scales;
  cache_r_ = r;
  if (want_jacobian) project_out_scale_directions(&cache_j_);
  return std::isfinite(r.sum());
}

void FitObjective::project_out_scale_directions(Eigen::MatrixXd* jacobian) const {
  std::map<int, std::vector<int>> members;  // group -> its columns in scale_columns()
  int column = 0;
  for (int group : scale_groups_)
    if (group >= 0) members[group].push_back(column++);
  if (column == 0) return;
  const Eigen::MatrixXd columns = scale_columns();
  // The directions the constrained scales can move the residuals in: Σ_r du_r = 0 per group,
  // spanned by each run's column minus its group's mean column. Those n sum to zero, so one is
  // left out: a basis, whose QR needs no rank decision (an exactly deficient one had pivots at
  // round-off and amplified it).
  Eigen::Index n_directions = 0;
  for (const auto& [group, indices] : members) n_directions += static_cast<Eigen::Index>(indices.size()) - 1;
  if (n_directions == 0) return;
  Eigen::MatrixXd span(columns.rows(), n_directions);
  Eigen::Index d = 0;
  for (const auto& [group, indices] : members) {
    const Eigen::VectorXd mean = columns(Eigen::all, indices).rowwise().mean();
    for (size_t i = 0; i + 1 < indices.size(); ++i) span.col(d++) = columns.col(indices[i]) - mean;
  }
  *jacobian -= span * span.householderQr().solve(*jacobian);
}

Eigen::MatrixXd FitObjective::scale_columns() const {
  std::vector<int> grouped;
  for (size_t i = 0; i < scale_groups_.size(); ++i)
    if (scale_groups_[i] >= 0) grouped.push_back(static_cast<int>(i));
  Eigen::MatrixXd columns = Eigen::MatrixXd::Zero(num_residuals(), static_cast<Eigen::Index>(grouped.size()));
  int row = 0, column = 0;
  for (size_t i = 0; i < predictors_.size(); ++i) {
    const Eigen::VectorXd& measured = predictors_[i]->measured();
    if (column < columns.cols() && grouped[static_cast<size_t>(column)] == static_cast<int>(i))
      columns.col(column++).segment(row, measured.size()) =
          std::sqrt(weights_[i]) * predictions_[i].cwiseQuotient(measured);
    row += static_cast<int>(measured.size());
  }
  return columns;
}

double FitObjective::evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) {
  if (!compute(x, gradient != nullptr)) return std::numeric_limits<double>::quiet_NaN();
  if (gradient) *gradient = 2.0 * cache_j_.transpose() * cache_r_;
  return cache_r_.squaredNorm();
}

void FitObjective::residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r,
                             Eigen::MatrixXd* jacobian) {
  compute(x, jacobian != nullptr);
  *r = cache_r_;
  if (jacobian) *jacobian = cache_j_;
}

void FitObjective::on_iteration(const IterationRecord& progress, const Eigen::VectorXd& x) {
  if (progress_) progress_(progress, x);
}

double FitObjective::average_relative_error(int predictor) const {
  const Eigen::VectorXd& measured = predictors_.at(static_cast<size_t>(predictor))->measured();
  const Eigen::VectorXd& predicted = predictions_.at(static_cast<size_t>(predictor));
  if (predicted.size() != measured.size()) return std::numeric_limits<double>::quiet_NaN();
  return (predicted - measured).cwiseAbs().sum() / measured.cwiseAbs().sum();
}

long FitObjective::equilibrium_solves() const {
  long n = 0;
  for (const auto& p : predictors_) n += p->equilibrium_solves();
  return n;
}

}  // namespace twill
