#pragma once
// The problem an optimiser minimises: a smooth objective f: ℝⁿ → ℝ, optionally over a box.
//
// Optimisers know nothing of cloth (style.md: PolySolve's Problem, Ceres' cost function). In
// twill, x is the active subset of the flat material-parameter vector (parameters.hpp) in the
// scaling the fitting protocol chose, and f is the relative squared error of paper Eq. 3,
//     ε(k) = Σ_i (p̂_i(k) − p̆_i)² / p̆_i²,
// which is also offered in least-squares form with r_i = (p̂_i − p̆_i) / p̆_i (no ½ factor, so
// that f = Σ r² is the paper's ε exactly).
//
// Cost. An evaluation may be very expensive: in twill one evaluation runs the quasistatic
// equilibrium solver along the extension schedule of every selected experiment (hundreds of
// sparse Newton solves), while the gradient then costs only one back-substitution per
// parameter with factorisations already at hand (implicit differentiation, paper Eq. 6).
// Optimisers therefore
//   - count every call (OptimizerSummary::objective_evaluations / gradient_evaluations),
//   - ask for the value and the gradient in one call whenever the gradient may be needed,
//   - never spend an evaluation only to report something.
//
// Failure contract. An evaluation that cannot be completed at x (the equilibrium solve
// diverged, a strain left the model's validity box, …) returns a non-finite value (NaN) from
// evaluate(), or non-finite entries in the residuals. Optimisers treat such a point as
// rejected: line searches shrink the step, trust-region methods shrink the region; a
// non-finite value at the starting point ends the run with status `failed`. An exception
// thrown by any member below ends the run: Optimizer::minimize() catches it and returns status
// `failed` with the exception's message (it never propagates through Ipopt's or NLopt's code).
#include <Eigen/Core>

namespace twill {

/// One line of an optimiser's progress: reported to Problem::on_iteration() and kept in
/// OptimizerSummary::trace. Iteration 0 is the starting point.
struct IterationRecord {
  int iteration = 0;
  double value = 0.0;          ///< f at the iterate
  double gradient_norm = 0.0;  ///< ∞-norm of the projected gradient x − P(x − ∇f) (= ‖∇f‖∞
                               ///< without bounds); NaN when the method has not computed it
  double step_length = 0.0;  ///< ‖x_k − x_{k−1}‖∞ (0 at iteration 0)
  int evaluations = 0;       ///< objective evaluations so far (including this iterate's)
};

class Problem {
 public:
  virtual ~Problem() = default;

  /// Number of unknowns n (≥ 1).
  virtual int dimension() const = 0;

  /// f(x) for x of size n. When `gradient` is non-null it is resized to n and set to ∇f(x).
  /// Returns a non-finite value when the evaluation failed at x (the gradient is then
  /// unspecified). Must be deterministic: the same x gives the same f.
  virtual double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) = 0;

  /// True when residuals() is implemented; then evaluate(x) must equal Σ_i r_i(x)².
  virtual bool has_residuals() const { return false; }

  /// Residuals r (m entries, m fixed for the problem) and, when `jacobian` is non-null, the
  /// m × n Jacobian J_ij = ∂r_i/∂x_j. A failed evaluation shows as a non-finite entry of r.
  /// The default throws std::logic_error (call only when has_residuals()).
  virtual void residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r, Eigen::MatrixXd* jacobian);

  /// Box constraints lower ≤ x ≤ upper, each of size n; −∞/+∞ where a side is free (the
  /// default: no bounds). lower_i = upper_i fixes x_i.
  virtual Eigen::VectorXd lower_bounds() const;
  virtual Eigen::VectorXd upper_bounds() const;
  /// True when any bound is finite.
  bool has_bounds() const;

  /// Progress hook, called once at the start (iteration 0) and after every iteration with the
  /// current iterate x. Default: nothing. Must not change the problem.
  virtual void on_iteration(const IterationRecord& progress, const Eigen::VectorXd& x);
};

}  // namespace twill
