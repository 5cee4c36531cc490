#pragma once
// The fit objective of paper Eq. 3 and the map from an optimiser's unknowns to material
// parameters (paper §5.1, §5.2, §5.5; model.md §8).
//
//     ε(k) = Σ_i w_i (p̂_i(k) − p̆_i)² / p̆_i²
//
// over the selected measurements p̆_i (clamp forces [N], chord angles [deg], …), with p̂_i(k)
// the simulated observables. Residual form: r_i = √w_i (p̂_i − p̆_i)/p̆_i, ε = Σ r_i² (no ½;
// core/problem.hpp). The gradient is exact: ∂p̂/∂k comes from the predictors (implicit
// differentiation of the equilibria, core/sensitivity.hpp) and the chain rule through the
// parameter map, ∇ε = 2 Jᵀ r with J = diag(√w/p̆) · ∂p̂/∂k · ∂k/∂x.
//
// Who does what:
//   - Predictor (implemented in experiments/): one simulated test and its measured values; it
//     returns predictions and their derivatives in any requested flat parameters.
//   - ParameterMap: which parameters are free (by name; the paper's stages solve for subsets),
//     their scaling, the ties the protocol imposes (a12 = ½ min(a11, a22), §5.2; the bend
//     stage's thickness rescaling a ← a·τ0/τ, §5.2 step 7).
//   - FitObjective: a Problem (optimizers know nothing of cloth) summing over predictors.
#include <Eigen/Core>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/parameters.hpp"
#include "core/problem.hpp"

namespace twill {

/// One simulated test with its measured values (m of them, fixed for the predictor's life).
class Predictor {
 public:
  virtual ~Predictor() = default;
  /// For messages and reports, e.g. "warp run 2 (90°)".
  virtual std::string label() const = 0;
  /// Measured values p̆ (m entries, none zero).
  virtual const Eigen::VectorXd& measured() const = 0;
  /// Predictions p̂(k) (m) and, when `jacobian` is non-null, ∂p̂/∂k restricted to the flat
  /// indices `flat` (m × #flat). Returns false with a message when the simulation failed (an
  /// equilibrium did not converge): the objective is then NaN at this k.
  virtual bool predict(const MaterialParameters& k, const std::vector<int>& flat,
                       Eigen::VectorXd* values, Eigen::MatrixXd* jacobian,
                       std::string* message) = 0;
  /// Equilibrium solves so far (for optimiser summaries and benchmarks).
  virtual long equilibrium_solves() const = 0;
};

/// Bounds and scale of a flat entry the map does not know by itself, e.g. an effect's
/// parameter (effects/effect.hpp: effect_parameters() has its bounds from the schema).
struct ParameterRange {
  std::string name;  ///< flat name, e.g. "hysteresis.warp_friction_N_m"
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
  /// The magnitude x = 1 stands for; 0: from the start value as for any entry (below).
  double typical = 0;
};

/// Maps the optimiser's unknowns x (n) to material parameters k(x) and gives ∂k/∂x.
///   k_j = s_j · x_j for the free flat entries j (s_j = |k0_j|, or 1 where k0_j = 0, so x
///   starts at ±1 or 0: well scaled for every optimiser; a range's `typical` when given), k0
///   elsewhere; bounds from `ranges` where given;
///   tie_a12: a12 = ½ min(a11, a22) after the above (paper §5.2), when a11 or a22 moves;
///   rescale_with_thickness: a11, a12, a22, G12 = k0 · τ0/τ (paper §5.2 step 7: the bend
///   stage changes τ without changing τ·a, so the tensile fits stay exact).
class ParameterMap {
 public:
  struct Options {
    bool tie_a12 = true;
    bool rescale_with_thickness = false;
    std::vector<ParameterRange> ranges;  ///< by flat name; names not in the flat vector are ignored
  };
  /// `free_names`: flat-entry names (parameters.hpp, e.g. "a11_Pa", "eta1.alpha[0]") or
  /// patterns ending in '*' ("eta1.*"). Throws std::invalid_argument for a name that matches
  /// nothing (the message lists the known names), for a12 while tied, or for no free entry.
  ParameterMap(const MaterialParameters& start, const std::vector<std::string>& free_names,
               const Options& options);
  ParameterMap(const MaterialParameters& start, const std::vector<std::string>& free_names)
      : ParameterMap(start, free_names, Options{}) {}

  int dimension() const { return static_cast<int>(free_.size()); }
  /// Flat indices of the free entries, in x order.
  const std::vector<int>& free_indices() const { return free_; }
  std::vector<std::string> free_names() const;
  /// Flat indices k depends on through x (free entries + tied/rescaled ones).
  const std::vector<int>& dependent_indices() const { return dependent_; }
  /// x of the start parameters.
  Eigen::VectorXd initial_x() const;
  /// k(x); throws std::invalid_argument (from validation) if k(x) is not a valid material.
  MaterialParameters parameters(const Eigen::VectorXd& x) const;
  /// ∂k/∂x restricted to dependent_indices(): #dependent × n.
  Eigen::MatrixXd jacobian(const Eigen::VectorXd& x) const;
  /// Physical bounds in x (thickness, density and stiffnesses a11, a22, G12 > 0: a lower
  /// bound of 1e-6 of the start value; −∞/+∞ elsewhere).
  Eigen::VectorXd lower_bounds() const;
  Eigen::VectorXd upper_bounds() const;
  const MaterialParameters& start() const { return start_; }

 private:
  MaterialParameters start_;
  Options options_;
  Eigen::VectorXd k0_;
  std::vector<int> free_;
  std::vector<int> dependent_;
  Eigen::VectorXd scale_;
  bool tie_active_ = false;  ///< tie_a12 and a11 or a22 moves (a12 is otherwise left as given)
  /// The range given for flat entry `flat`, or nullptr.
  const ParameterRange* range_of(int flat) const;
};

/// ε(x) of Eq. 3 over a set of predictors, as a Problem for any optimiser.
class FitObjective : public Problem {
 public:
  /// `predictors` are shared with the caller (who may read their state between runs);
  /// `weights` (one per predictor, > 0) default to 1.
  FitObjective(ParameterMap map, std::vector<std::shared_ptr<Predictor>> predictors,
               std::vector<double> weights = {});

  int dimension() const override { return map_.dimension(); }
  double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) override;
  bool has_residuals() const override { return true; }
  void residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r, Eigen::MatrixXd* jacobian) override;
  Eigen::VectorXd lower_bounds() const override { return map_.lower_bounds(); }
  Eigen::VectorXd upper_bounds() const override { return map_.upper_bounds(); }
  void on_iteration(const IterationRecord& progress, const Eigen::VectorXd& x) override;

  /// Progress callback (stage reporting); called from on_iteration.
  using ProgressFunction = std::function<void(const IterationRecord&, const Eigen::VectorXd& x)>;
  void set_progress(ProgressFunction progress) { progress_ = std::move(progress); }

  const ParameterMap& map() const { return map_; }
  int num_residuals() const;
  /// Specimen scales (core/specimen_scale.hpp): groups[i] is predictor i's group (the runs of
  /// one test), −1 for none; each group's scales are profiled out at every evaluation with
  /// their geometric mean held at 1. Without groups every scale is 1 (the paper's Eq. 3).
  void set_scale_groups(std::vector<int> groups);
  /// Per-predictor scale at the last successful evaluation (1 outside a group).
  const std::vector<double>& scales() const { return scales_; }
  /// The residuals' derivatives in each grouped predictor's log-scale at the last successful
  /// evaluation, √w s_r p̂_r/p̆_r on run r's rows: num_residuals() × (predictors in a group).
  Eigen::MatrixXd scale_columns() const;
  /// Per-predictor predictions at the last successful evaluation, times their scales (what
  /// the residuals compare with the measurements; for reports).
  const std::vector<Eigen::VectorXd>& last_predictions() const { return predictions_; }
  /// Average relative error Σ|p̂ − p̆| / Σ|p̆| of predictor i at the last evaluation (model.md §8).
  double average_relative_error(int predictor) const;
  long equilibrium_solves() const;
  long evaluations() const { return evaluations_; }
  /// Why the most recent failed evaluation failed (empty when none failed), and how many did.
  const std::string& last_failure() const { return failure_; }
  long failed_evaluations() const { return failed_evaluations_; }

 private:
  // Evaluates residuals (and Jacobian when wanted) at x, reusing the cache when x repeats.
  bool compute(const Eigen::VectorXd& x, bool want_jacobian);
  // Every predictor's raw predictions (and ∂/∂k on the dependent entries when wanted) at k;
  // false with failure_ set when one fails.
  bool predict_all(const MaterialParameters& k, bool want_jacobian, std::vector<Eigen::VectorXd>* values,
                   std::vector<Eigen::MatrixXd>* jacobians);
  // Kaufman's variable-projection Jacobian: the scales-held Jacobian minus its projection onto
  // the residual directions the (constrained) scales can move (core/specimen_scale.hpp).
  void project_out_scale_directions(Eigen::MatrixXd* jacobian) const;
  // The profiled specimen scales of the raw predictions (1 outside a group).
  std::vector<double> profiled_scales(const std::vector<Eigen::VectorXd>& values) const;

  ParameterMap map_;
  std::vector<std::shared_ptr<Predictor>> predictors_;
  std::vector<double> weights_;
  std::vector<int> scale_groups_;  ///< empty: no scales
  std::vector<double> scales_;
  ProgressFunction progress_;
  std::vector<Eigen::VectorXd> predictions_;
  long evaluations_ = 0;
  long failed_evaluations_ = 0;
  std::string failure_;
  // Cache of the last evaluation.
  bool cache_valid_ = false;
  bool cache_has_jacobian_ = false;
  Eigen::VectorXd cache_x_, cache_r_;
  Eigen::MatrixXd cache_j_;
};

}  // namespace twill
