#pragma once
// Gravity and lumped mass from nodal areas, written once for every discretisation.
//
// With positions linear in q, x(X) = Σ_i N_i(X) x_i, the gravity energy of model.md §6 is
//   Ψ_g = −∫ ρ_A g·x dA = −ρ_A Σ_i a_i g·x_i,   a_i = ∫ N_i dA [m²]
// exactly (a Catmull–Clark control point's ∫N_i dA by the face Gauss rule; a triangle
// vertex's Σ_{T∋i} Ā_T/3). The lumped mass of node i is ρ_A a_i on each of its 3 dofs.
// node_area: #nodes [m²]; q, gradient: #dofs [m, N]; g [m/s²]; ρ_A [kg/m²].
#include <Eigen/Core>

namespace twill {

/// `energy` − ρ_A Σ_i a_i g·x_i [J], subtracted node by node in node order; when given,
/// ρ_A a_i g is subtracted from each node's gradient. Nothing to do (and nothing done) for g = 0.
double subtract_gravity(const Eigen::VectorXd& node_area, double density_kg_m2,
                        const Eigen::Vector3d& g_m_s2, const Eigen::VectorXd& q, double energy,
                        Eigen::VectorXd* gradient);

/// ∂(∂Ψ_g/∂q)/∂ρ_A = −a_i g per node, subtracted from column `column` of `dgradient_dk`.
void subtract_gravity_density_column(const Eigen::VectorXd& node_area, const Eigen::Vector3d& g_m_s2,
                                     int column, Eigen::MatrixXd* dgradient_dk);

/// ρ_A a_i repeated on the node's 3 dofs [kg] (#dofs).
Eigen::VectorXd lumped_mass(const Eigen::VectorXd& node_area, double density_kg_m2);

}  // namespace twill
