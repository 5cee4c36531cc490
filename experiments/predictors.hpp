#pragma once
// The simulated tests as Predictors of the fit objective (core/fit_objective.hpp, paper Eq. 3).
//
// TensilePredictor: a tensile strip run at the measured extensions; predictions are the clamp
// forces [N] (paper §5.5.1), derivatives by implicit differentiation at every point (Eq. 6).
// Warm start across evaluations (paper §5.5.3 "reuse"): after an evaluation with derivatives,
// each point's equilibrium q_i and ∂q_i/∂k are kept; a later evaluation at k starts point i
// from q_i + ∂q_i/∂k (k − k_anchor) instead of continuing from the previous point, which
// typically leaves one or two Newton iterations per point. A point whose solve fails from the
// prediction is retried by continuation (tensile_strip.hpp run_from).
//
// CantileverPredictor: the D1388 cantilever at measured overhangs; the prediction is the
// chord angle [deg] at each, measured 41.5° (paper §4, §5.2 step 7).
//
// Both are the registered experiments "tensile", "validation" and "bend" (experiment.hpp,
// register_experiments.cpp); the fit and `twill simulate` create them through the registry.
#include <memory>
#include <string>
#include <vector>

#include "experiments/cantilever.hpp"
#include "experiments/experiment.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {

/// What a tensile strip reports as its observable: the clamp force (the paper's), or the
/// lateral strain at mid-gauge (a video extensometer's; tensile_strip.hpp).
enum class StripObservable { Force, LateralStrain };

class TensilePredictor : public Experiment {
 public:
  /// extensions_mm and forces_N: the measured points (same size, forces ≠ 0), or no forces
  /// (an empty vector: simulation only).
  TensilePredictor(std::string label, const TensileSetup& setup,
                   const DiscretizationFactory& factory, const MaterialParameters& start,
                   std::vector<double> extensions_mm, const Eigen::VectorXd& forces_N,
                   const EquilibriumOptions& solver = {});

  std::string observable() const override {
    return observable_ == StripObservable::Force ? "force_N" : "lateral_strain";
  }
  std::string schedule_quantity() const override { return "extension_mm"; }
  const std::vector<double>& schedule() const override { return extensions_mm_; }
  /// Extras: the other observable per point (lateral_strain, or force_N), and
  /// dforce_dangle_N_per_deg with report_angle_derivative.
  ExperimentRun simulate(const MaterialParameters& k) override;
  /// dF/dθ for the force; none for the lateral strain.
  std::vector<std::string> setup_sensitivities() const override {
    return observable_ == StripObservable::Force ? std::vector<std::string>{setup_quantity::kAngle}
                                                 : std::vector<std::string>{};
  }
  /// The observable predict() and simulate() report (the measured values are of this one).
  void set_observable(StripObservable observable) { observable_ = observable; }
  bool predict_setup_derivatives(const MaterialParameters& k, const std::vector<std::string>& quantities,
                                 Eigen::VectorXd* values, Eigen::MatrixXd* jacobian, std::string* message) override;
  bool last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const override;
  /// simulate() also reports dF/dθ per point (the validation experiment, paper §7).
  void set_report_angle_derivative(bool on) { report_angle_derivative_ = on; }
  /// The extra column of simulate() with report_angle_derivative.
  static constexpr const char* kAngleDerivativeColumn = "dforce_dangle_N_per_deg";

  std::string label() const override { return label_; }
  const Eigen::VectorXd& measured() const override { return measured_; }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string* message) override;
  long equilibrium_solves() const override { return solves_; }
  /// Warm-started runs solved again from the flat strip because they left the anchor's branch.
  long branch_retries() const { return branch_retries_; }

  /// Turn warm starts across evaluations off (for comparisons; on by default).
  void set_warm_start(bool on) { warm_start_ = on; }
  const std::vector<double>& extensions_mm() const { return extensions_mm_; }
  /// The last successful curve (predictions and solver summaries).
  const TensileCurve& last_curve() const { return last_curve_; }
  TensileExperiment& experiment() { return experiment_; }

 private:
  std::string label_;
  TensileExperiment experiment_;
  std::vector<double> extensions_mm_;
  Eigen::VectorXd measured_;
  bool warm_start_ = true;
  bool report_angle_derivative_ = false;
  StripObservable observable_ = StripObservable::Force;
  bool angle_sensitivity_on_ = false;  ///< whether experiment_ holds its turned meshes
  /// Turns the engine's angle sensitivity on or off, rebuilding nothing when it already is.
  void use_angle_sensitivity(bool on);
  // The steps of predict(): the curve at k (warm-started from the anchor where there is one,
  // checked, else from the flat strip), and the evaluation kept as the next anchor.
  TensileCurve solve_curve(const MaterialParameters& k, const Eigen::VectorXd& k_flat, bool force);
  void keep_anchor(const Eigen::VectorXd& k_flat, const std::vector<int>& flat, const Eigen::VectorXd& values,
                   const Eigen::MatrixXd& jacobian, TensileCurve* curve);
  long solves_ = 0;
  long branch_retries_ = 0;
  TensileCurve last_curve_;
  Eigen::VectorXd last_q_;  ///< the last simulate()'s final equilibrium (last_surface)
  // Anchor of the warm start: flat k, the indices of dq/dk's columns, states per point.
  Eigen::VectorXd anchor_k_;
  std::vector<int> anchor_flat_;
  std::vector<Eigen::VectorXd> anchor_q_;
  std::vector<Eigen::MatrixXd> anchor_dq_;
  Eigen::VectorXd anchor_values_;    ///< the observables at the anchor
  Eigen::MatrixXd anchor_jacobian_;  ///< and their derivatives in its columns
  /// Whether k differs from the anchor's parameters in a law entry (the first `law_size`)
  /// outside its columns.
  bool moved_outside_columns(const Eigen::VectorXd& k_flat, int law_size) const;
  /// Whether a completed warm run left the anchor's first-order prediction (predictors.cpp).
  bool left_the_anchors_branch(const TensileCurve& warm, bool force, const Eigen::VectorXd& dk) const;
};

class CantileverPredictor : public Experiment {
 public:
  /// One overhang [mm] (> 0) with its measured chord angle.
  CantileverPredictor(std::string label, const CantileverSetup& setup,
                      const DiscretizationFactory& factory, const MaterialParameters& start,
                      double overhang_mm, double measured_angle_deg = kD1388ChordAngle_deg,
                      const EquilibriumOptions& solver = {});
  /// Several overhangs with their measured chord angles (same size), or none (simulation).
  CantileverPredictor(std::string label, const CantileverSetup& setup,
                      const DiscretizationFactory& factory, const MaterialParameters& start,
                      std::vector<double> overhangs_mm, const Eigen::VectorXd& measured_angles_deg,
                      const EquilibriumOptions& solver = {});

  std::string observable() const override { return "chord_angle_deg"; }
  std::string schedule_quantity() const override { return "overhang_mm"; }
  const std::vector<double>& schedule() const override { return overhangs_mm_; }
  /// Extras: tip_deflection_mm per overhang.
  ExperimentRun simulate(const MaterialParameters& k) override;
  bool last_surface(Eigen::MatrixXd* V, Eigen::MatrixXi* F) const override;

  std::string label() const override { return label_; }
  const Eigen::VectorXd& measured() const override { return measured_; }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string* message) override;
  long equilibrium_solves() const override { return solves_; }
  CantileverExperiment& experiment() { return experiment_; }

 private:
  std::string label_;
  CantileverExperiment experiment_;
  std::vector<double> overhangs_mm_;
  Eigen::VectorXd measured_;
  long solves_ = 0;
};

}  // namespace twill
