#pragma once
// Parameter sensitivities of a quasistatic equilibrium (paper §5.5.2, Eq. 6; model.md §8).
//
// At a converged equilibrium q(k) with held dofs q_c (prescribed, independent of k), the free
// dofs satisfy g_f(q(k); k) = 0 with g = ∂Ψ/∂q. Differentiating in a model parameter k_j:
//
//     K_ff ∂q_f/∂k_j = −∂g_f/∂k_j          (K_ff = ∂²Ψ/∂q_f², paper Eq. 6 with the
//                                           constraints Bq = b eliminated, constrained_dofs.hpp)
//
// and the reactions at the held dofs (the forces a tester measures) change by
//
//     d g_c/dk_j = ∂g_c/∂k_j + K_cf ∂q_f/∂k_j,      K_cf = K_fcᵀ.
//
// Direct rather than adjoint. The adjoint method needs one solve per *observable*, the direct
// method one per *parameter*. Per equilibrium twill has 2 observables (force, lateral strain)
// and 1–10 active parameters, so the counts are comparable; direct wins because
//   - the solves reuse the factor of K_ff that Newton computed at the solution (no extra
//     factorisation), and a block of m right-hand sides costs about one supernodal sweep;
//   - ∂q/∂k itself is useful: it gives every observable's derivative at once (Gauss–Newton
//     needs the full Jacobian, not one gradient), and q + ∂q/∂k·Δk is a first-order predictor
//     of the equilibrium at the optimiser's next trial parameters (warm start).
//
// Requires: the solver's last solve() converged at q (has_solution_factorization()), and the
// discretisation still carries the parameters of that solve.
#include <Eigen/Core>
#include <vector>
#include "core/equilibrium_solver.hpp"

namespace twill {

class EquilibriumSensitivity {
 public:
  /// Solves Eq. 6 at the solver's last equilibrium q (#dofs) for the flat parameter indices
  /// `parameters` (parameters.hpp layout; m of them, any order, no duplicates).
  /// Throws std::logic_error when the solver has no factor at a solution,
  /// std::invalid_argument for an index out of range or a q of the wrong size.
  EquilibriumSensitivity(const EquilibriumSolver& solver, const Eigen::VectorXd& q,
                         const std::vector<int>& parameters);
  /// The same for any m quantities p the gradient depends on, given ∂g/∂p (#dofs × m) by the
  /// caller (e.g. the material angle, experiments/tensile_strip.hpp); parameters() is empty.
  EquilibriumSensitivity(const EquilibriumSolver& solver, const Eigen::MatrixXd& dg_dp);

  int num_parameters() const { return static_cast<int>(dq_dk_.cols()); }
  const std::vector<int>& parameters() const { return parameters_; }

  /// ∂q/∂k: #dofs × m [m per parameter unit]; rows of held dofs are zero.
  const Eigen::MatrixXd& position_derivatives() const { return dq_dk_; }

  /// d g_c/dk: #fixed × m, rows in the solver's fixed-dof order [N per parameter unit]: the
  /// total derivative of each support reaction (EquilibriumSolver::reaction()).
  const Eigen::MatrixXd& reaction_derivatives() const { return dreaction_dk_; }

  /// Total derivative of Σ_i w_i g_i over held dofs i (a clamp force): wᵀ dg_c/dk (m).
  /// `dof_weights` pairs (dof, w); each dof must be held (std::invalid_argument otherwise).
  Eigen::VectorXd reaction_derivative(const std::vector<std::pair<int, double>>& dof_weights) const;

  /// Derivative of a smooth function of the positions with gradient ∂h/∂q (#dofs): (∂h/∂q)ᵀ ∂q/∂k.
  Eigen::VectorXd observable_derivative(const Eigen::VectorXd& dh_dq) const;

  /// Largest relative residual ‖K_ff x + ∂g_f/∂k‖ / ‖∂g_f/∂k‖ over the columns (diagnostic).
  double relative_residual() const { return relative_residual_; }

 private:
  /// Eq. 6 for the columns of dg_dk (#dofs × m): ∂q/∂k and the reactions' derivatives.
  void solve(const EquilibriumSolver& solver, const Eigen::MatrixXd& dg_dk);

  const ConstrainedDofs& dofs_;
  std::vector<int> parameters_;
  Eigen::MatrixXd dq_dk_;
  Eigen::MatrixXd dreaction_dk_;
  double relative_residual_ = 0;
};

}  // namespace twill
