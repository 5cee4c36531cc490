#include "core/sensitivity.hpp"

#include <stdexcept>
#include <string>

namespace twill {

EquilibriumSensitivity::EquilibriumSensitivity(const EquilibriumSolver& solver,
                                               const Eigen::VectorXd& q,
                                               const std::vector<int>& parameters)
    : dofs_(solver.dofs()), parameters_(parameters) {
  const Discretization& disc = solver.discretization();
  if (q.size() != disc.num_dofs())
    throw std::invalid_argument("EquilibriumSensitivity: q has " + std::to_string(q.size()) +
                                " entries, the discretisation " +
                                std::to_string(disc.num_dofs()));
  const int flat = disc.parameters().flat_size();
  for (int p : parameters_)
    if (p < 0 || p >= flat)
      throw std::invalid_argument("EquilibriumSensitivity: parameter index " + std::to_string(p) +
                                  " outside the flat vector [0, " + std::to_string(flat) + ")");
  Eigen::MatrixXd dg_dk_all;
  solver.free_fixed_hessian();  // throws without a solution factor, before the assembly
  disc.gradient_parameter_jacobian(q, &dg_dk_all);
  Eigen::MatrixXd dg_dk(disc.num_dofs(), static_cast<Eigen::Index>(parameters_.size()));
  for (size_t j = 0; j < parameters_.size(); ++j)
    dg_dk.col(static_cast<Eigen::Index>(j)) = dg_dk_all.col(parameters_[j]);
  solve(solver, dg_dk);
}

EquilibriumSensitivity::EquilibriumSensitivity(const EquilibriumSolver& solver,
                                               const Eigen::MatrixXd& dg_dp)
    : dofs_(solver.dofs()) {
  if (dg_dp.rows() != solver.discretization().num_dofs())
    throw std::invalid_argument("EquilibriumSensitivity: dg/dp has " + std::to_string(dg_dp.rows()) +
                                " rows, the discretisation " +
                                std::to_string(solver.discretization().num_dofs()) + " dofs");
  solve(solver, dg_dp);
}

void EquilibriumSensitivity::solve(const EquilibriumSolver& solver, const Eigen::MatrixXd& dg_dk) {
  const SparseMatrix& k_fc = solver.free_fixed_hessian();  // throws without a solution factor
  const Eigen::Index m = dg_dk.cols();
  Eigen::MatrixXd rhs;
  dofs_.gather_free_rows(dg_dk, &rhs);
  rhs = -rhs;
  Eigen::MatrixXd x;
  solver.solve_free_free(rhs, &x);

  // Diagnostic residual in double precision (the solve itself refines in extended precision).
  const SparseMatrix& k_ff = solver.free_free_hessian();
  for (Eigen::Index j = 0; j < m; ++j) {
    const double scale = rhs.col(j).norm();
    if (scale > 0)
      relative_residual_ =
          std::max(relative_residual_, (k_ff * x.col(j) - rhs.col(j)).norm() / scale);
  }

  dq_dk_.setZero(dg_dk.rows(), m);
  const std::vector<int>& free = dofs_.free_dofs();
  for (size_t i = 0; i < free.size(); ++i) dq_dk_.row(free[i]) = x.row(static_cast<Eigen::Index>(i));

  // d g_c/dk = ∂g_c/∂k + K_cf ∂q_f/∂k.
  dreaction_dk_ = k_fc.transpose() * x;
  const std::vector<int>& fixed = dofs_.fixed_dofs();
  for (size_t i = 0; i < fixed.size(); ++i)
    dreaction_dk_.row(static_cast<Eigen::Index>(i)) += dg_dk.row(fixed[i]);
}

Eigen::VectorXd EquilibriumSensitivity::reaction_derivative(
    const std::vector<std::pair<int, double>>& dof_weights) const {
  Eigen::VectorXd d = Eigen::VectorXd::Zero(num_parameters());
  for (const auto& [dof, w] : dof_weights) {
    if (dof < 0 || dof >= dofs_.num_dofs() || !dofs_.is_fixed(dof))
      throw std::invalid_argument("reaction_derivative: dof " + std::to_string(dof) +
                                  " is not a held dof");
    d += w * dreaction_dk_.row(dofs_.fixed_index(dof)).transpose();
  }
  return d;
}

Eigen::VectorXd EquilibriumSensitivity::observable_derivative(const Eigen::VectorXd& dh_dq) const {
  if (dh_dq.size() != dq_dk_.rows())
    throw std::invalid_argument("observable_derivative: ∂h/∂q has " +
                                std::to_string(dh_dq.size()) + " entries, expected " +
                                std::to_string(dq_dk_.rows()));
  return dq_dk_.transpose() * dh_dq;
}

}  // namespace twill
