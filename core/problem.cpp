#include "core/problem.hpp"

#include <limits>
#include <stdexcept>

namespace twill {

void Problem::residuals(const Eigen::VectorXd& /*x*/, Eigen::VectorXd* /*r*/,
                        Eigen::MatrixXd* /*jacobian*/) {
  throw std::logic_error(
      "Problem::residuals() called on a problem without the least-squares form "
      "(has_residuals() is false)");
}

Eigen::VectorXd Problem::lower_bounds() const {
  return Eigen::VectorXd::Constant(dimension(), -std::numeric_limits<double>::infinity());
}

Eigen::VectorXd Problem::upper_bounds() const {
  return Eigen::VectorXd::Constant(dimension(), std::numeric_limits<double>::infinity());
}

bool Problem::has_bounds() const {
  return lower_bounds().array().isFinite().any() || upper_bounds().array().isFinite().any();
}

void Problem::on_iteration(const IterationRecord& /*progress*/, const Eigen::VectorXd& /*x*/) {}

}  // namespace twill
