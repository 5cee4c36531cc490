#pragma once
// A Predictor (core/fit_objective.hpp) with no equilibrium behind it, for tests of what sits on
// top of predictors (scales, score tests): nonlinear in its parameters, so that central
// differences show truncation error.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/fit_objective.hpp"
#include "core/parameters.hpp"

namespace twill::testing {

// A predictor nonlinear in its parameters, so that central differences show truncation error:
// p_i = ρ_A (τ a11 e_i + τ² a22 e_i²) (units immaterial here; the density ρ_A only rescales
// every prediction, as a specimen scale does).
class ToyPredictor final : public Predictor {
 public:
  ToyPredictor(std::string label, Eigen::VectorXd strains, Eigen::VectorXd measured)
      : label_(std::move(label)), e_(std::move(strains)), measured_(std::move(measured)) {}
  std::string label() const override { return label_; }
  const Eigen::VectorXd& measured() const override { return measured_; }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string*) override {
    const double t = k.thickness_m, a = k.a11_Pa, b = k.a22_Pa, rho = k.density_kg_m2;
    const Eigen::ArrayXd e = e_.array(), e2 = e * e;
    const Eigen::ArrayXd shape = t * a * e + t * t * b * e2;
    *values = (rho * shape).matrix();
    if (jacobian) {
      jacobian->setZero(e_.size(), static_cast<Eigen::Index>(flat.size()));
      for (size_t j = 0; j < flat.size(); ++j) {
        const auto col = static_cast<Eigen::Index>(j);
        if (flat[j] == FlatLayout::kDensity) jacobian->col(col) = shape.matrix();
        if (flat[j] == FlatLayout::kThickness) jacobian->col(col) = (rho * (a * e + 2 * t * b * e2)).matrix();
        if (flat[j] == FlatLayout::kA11) jacobian->col(col) = (rho * t * e).matrix();
        if (flat[j] == FlatLayout::kA22) jacobian->col(col) = (rho * t * t * e2).matrix();
      }
    }
    return true;
  }
  long equilibrium_solves() const override { return 0; }

 private:
  std::string label_;
  Eigen::VectorXd e_, measured_;
};

}  // namespace twill::testing
