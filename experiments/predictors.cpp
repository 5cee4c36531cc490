#include "experiments/predictors.hpp"

#include <stdexcept>

namespace twill {

TensilePredictor::TensilePredictor(std::string label, const TensileSetup& setup,
                                   const DiscretizationFactory& factory,
                                   const MaterialParameters& start,
                                   std::vector<double> extensions_mm,
                                   const Eigen::VectorXd& forces_N,
                                   const EquilibriumOptions& solver)
    : label_(std::move(label)),
      experiment_(setup, factory, start, solver),
      extensions_mm_(std::move(extensions_mm)),
      measured_(forces_N) {
  if (static_cast<Eigen::Index>(extensions_mm_.size()) != measured_.size())
    throw std::invalid_argument(label_ + ": " + std::to_string(extensions_mm_.size()) +
                                " extensions but " + std::to_string(measured_.size()) + " forces");
  if (extensions_mm_.empty()) throw std::invalid_argument(label_ + ": no measured points");
}

bool TensilePredictor::predict(const MaterialParameters& k, const std::vector<int>& flat,
                               Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                               std::string* message) {
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters(jacobian ? flat : std::vector<int>{});
  experiment_.set_keep_states(jacobian != nullptr && warm_start_);

  const Eigen::VectorXd k_flat = k.to_flat();
  TensileCurve curve;
  const bool anchored = warm_start_ && anchor_q_.size() == extensions_mm_.size() &&
                        anchor_k_.size() == k_flat.size();
  if (anchored) {
    // First-order predictor q_i + ∂q_i/∂k Δk over the anchor's columns; entries outside them
    // (none in a fit: the free set is fixed per stage) only make the guess less accurate.
    Eigen::VectorXd dk(static_cast<Eigen::Index>(anchor_flat_.size()));
    for (size_t j = 0; j < anchor_flat_.size(); ++j)
      dk[static_cast<Eigen::Index>(j)] = k_flat[anchor_flat_[j]] - anchor_k_[anchor_flat_[j]];
    std::vector<Eigen::VectorXd> guesses(anchor_q_.size());
    for (size_t i = 0; i < anchor_q_.size(); ++i)
      guesses[i] = anchor_dq_[i].cols() == dk.size() ? Eigen::VectorXd(anchor_q_[i] + anchor_dq_[i] * dk)
                                                     : anchor_q_[i];
    curve = experiment_.run_from(extensions_mm_, guesses);
    if (!curve.completed) {
      // The warm start is only an acceleration: a first-order guess from a distant anchor (an
      // optimiser's rejected trial, or NLopt's restart at its best point after one) can leave
      // the basin. Whether a point is evaluable must not depend on the path to it, so retry
      // along the loading schedule from the flat strip.
      for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
      curve = experiment_.run(extensions_mm_);
    }
  } else {
    curve = experiment_.run(extensions_mm_);
  }
  for (const TensilePoint& p : curve.points) solves_ += 1 + p.solve.fallbacks;
  if (!curve.completed) {
    if (message) *message = curve.message;
    return false;
  }
  values->resize(measured_.size());
  if (jacobian) jacobian->resize(measured_.size(), static_cast<Eigen::Index>(flat.size()));
  for (size_t i = 0; i < curve.points.size(); ++i) {
    (*values)[static_cast<Eigen::Index>(i)] = curve.points[i].force_N;
    if (jacobian) jacobian->row(static_cast<Eigen::Index>(i)) = curve.points[i].dforce_dk.transpose();
  }
  if (jacobian && warm_start_) {
    anchor_k_ = k_flat;
    anchor_flat_ = flat;
    anchor_q_.resize(curve.points.size());
    anchor_dq_.resize(curve.points.size());
    for (size_t i = 0; i < curve.points.size(); ++i) {
      anchor_q_[i] = std::move(curve.points[i].q);
      anchor_dq_[i] = std::move(curve.points[i].dq_dk);
    }
  }
  last_curve_ = std::move(curve);
  return true;
}

CantileverPredictor::CantileverPredictor(std::string label, const CantileverSetup& setup,
                                         const DiscretizationFactory& factory,
                                         const MaterialParameters& start, double overhang_mm,
                                         double measured_angle_deg,
                                         const EquilibriumOptions& solver)
    : label_(std::move(label)),
      experiment_(setup, factory, start, solver),
      overhang_mm_(overhang_mm),
      measured_(Eigen::VectorXd::Constant(1, measured_angle_deg)) {
  if (!(overhang_mm > 0)) throw std::invalid_argument(label_ + ": overhang must be > 0 mm");
}

bool CantileverPredictor::predict(const MaterialParameters& k, const std::vector<int>& flat,
                                  Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                                  std::string* message) {
  experiment_.set_parameters(k);
  experiment_.set_sensitivity_parameters(jacobian ? flat : std::vector<int>{});
  const CantileverResult r = experiment_.solve(overhang_mm_);
  ++solves_;
  if (!r.converged) {
    if (message) *message = r.message;
    experiment_.reset_warm_start();
    return false;
  }
  *values = Eigen::VectorXd::Constant(1, r.chord_angle_deg);
  if (jacobian) *jacobian = r.dchord_angle_dk.transpose();
  return true;
}

}  // namespace twill
