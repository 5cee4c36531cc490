#include "discretizations/assembly/nodal_gravity.hpp"

namespace twill {

double subtract_gravity(const Eigen::VectorXd& node_area, double density_kg_m2,
                        const Eigen::Vector3d& g_m_s2, const Eigen::VectorXd& q, double energy,
                        Eigen::VectorXd* gradient) {
  if (g_m_s2.squaredNorm() == 0) return energy;
  for (Eigen::Index i = 0; i < node_area.size(); ++i) {
    const double mass = density_kg_m2 * node_area[i];
    energy -= mass * g_m_s2.dot(q.segment<3>(3 * i));
    if (gradient) gradient->segment<3>(3 * i) -= mass * g_m_s2;
  }
  return energy;
}

void subtract_gravity_density_column(const Eigen::VectorXd& node_area, const Eigen::Vector3d& g_m_s2,
                                     int column, Eigen::MatrixXd* dgradient_dk) {
  for (Eigen::Index i = 0; i < node_area.size(); ++i)
    dgradient_dk->block<3, 1>(3 * i, column) -= node_area[i] * g_m_s2;
}

Eigen::VectorXd lumped_mass(const Eigen::VectorXd& node_area, double density_kg_m2) {
  Eigen::VectorXd mass(3 * node_area.size());
  for (Eigen::Index i = 0; i < node_area.size(); ++i)
    mass.segment<3>(3 * i).setConstant(density_kg_m2 * node_area[i]);
  return mass;
}

}  // namespace twill
