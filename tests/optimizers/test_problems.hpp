#pragma once
// Test problems with known minima for the optimiser tests (every optimiser × every problem).
// All are least-squares problems f = Σ r², so the Gauss–Newton variants can run on them too;
// evaluate() is derived from the residuals and checked against them in problems_test.cpp.
#include <Eigen/Core>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/problem.hpp"
#include "optimizers/optimizer.hpp"

namespace twill::testing {

/// A least-squares problem that counts its own calls and progress reports (to check the
/// optimisers' bookkeeping) and offers optional bounds.
class LeastSquaresTestProblem : public Problem {
 public:
  explicit LeastSquaresTestProblem(int n)
      : lower_(Eigen::VectorXd::Constant(n, -std::numeric_limits<double>::infinity())),
        upper_(Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity())) {}

  int dimension() const override { return static_cast<int>(lower_.size()); }
  bool has_residuals() const override { return true; }

  double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient) override {
    ++calls;
    if (gradient) ++gradient_calls;
    Eigen::VectorXd r;
    Eigen::MatrixXd J;
    compute(x, r, gradient ? &J : nullptr);
    if (gradient) *gradient = 2.0 * J.transpose() * r;
    return r.squaredNorm();
  }

  void residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r, Eigen::MatrixXd* jacobian) override {
    ++calls;
    if (jacobian) ++gradient_calls;
    compute(x, *r, jacobian);
  }

  Eigen::VectorXd lower_bounds() const override { return lower_; }
  Eigen::VectorXd upper_bounds() const override { return upper_; }
  void set_bounds(Eigen::VectorXd lower, Eigen::VectorXd upper) {
    lower_ = std::move(lower);
    upper_ = std::move(upper);
  }

  void on_iteration(const IterationRecord& progress, const Eigen::VectorXd& x) override {
    progress_reports.push_back(progress);
    iterates.push_back(x);
  }

  /// r (m) and optionally J (m × n).
  virtual void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const = 0;

  int calls = 0, gradient_calls = 0;
  std::vector<IterationRecord> progress_reports;
  std::vector<Eigen::VectorXd> iterates;  ///< x of each progress report

 private:
  Eigen::VectorXd lower_, upper_;
};

/// Extended Rosenbrock (Moré, Garbow & Hillstrom 1981, problem 21), n even:
/// f = Σ_{i<n/2} 100 (x_{2i+1} − x_{2i}²)² + (1 − x_{2i})², minimum f = 0 at x = (1, …, 1).
/// Standard start (−1.2, 1, −1.2, 1, …).
class Rosenbrock : public LeastSquaresTestProblem {
 public:
  explicit Rosenbrock(int n) : LeastSquaresTestProblem(n) {}
  void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    const Eigen::Index n = x.size();
    r.resize(n);
    if (J) J->setZero(n, n);
    for (Eigen::Index i = 0; i < n; i += 2) {
      r[i] = 10.0 * (x[i + 1] - x[i] * x[i]);
      r[i + 1] = 1.0 - x[i];
      if (J) {
        (*J)(i, i) = -20.0 * x[i];
        (*J)(i, i + 1) = 10.0;
        (*J)(i + 1, i) = -1.0;
      }
    }
  }
  static Eigen::VectorXd start(int n) {
    Eigen::VectorXd x(n);
    for (int i = 0; i < n; i += 2) x.segment(i, 2) << -1.2, 1.0;
    return x;
  }
  static Eigen::VectorXd minimum(int n) { return Eigen::VectorXd::Ones(n); }
};

/// Badly scaled, rotated quadratic f = Σ_i λ_i (q_iᵀ(x − x*))², λ log-spaced from 1 to
/// `condition` (the Hessian's condition number), Q a fixed random orthogonal matrix.
/// Minimum f = 0 at x* = (1, 2, …, n) / n. Start 0.
class ScaledQuadratic : public LeastSquaresTestProblem {
 public:
  ScaledQuadratic(int n, double condition) : LeastSquaresTestProblem(n), scale_(n), x_star_(n) {
    std::mt19937 generator(12345);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    Eigen::MatrixXd A(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) A(i, j) = uniform(generator);
    const Eigen::MatrixXd Q = Eigen::HouseholderQR<Eigen::MatrixXd>(A).householderQ();
    for (int i = 0; i < n; ++i) {
      scale_[i] = std::sqrt(std::pow(condition, static_cast<double>(i) / (n - 1)));
      x_star_[i] = static_cast<double>(i + 1) / n;
    }
    jacobian_ = scale_.asDiagonal() * Q.transpose();
  }
  void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    r = jacobian_ * (x - x_star_);
    if (J) *J = jacobian_;
  }
  const Eigen::VectorXd& minimum() const { return x_star_; }

 private:
  Eigen::VectorXd scale_, x_star_;
  Eigen::MatrixXd jacobian_;
};

/// Curve fit of y(t) = a e^{b t} + c to noiseless samples of (a, b, c) = (2, −1.5, 0.5) at
/// t = 0, 0.1, …, 3: residuals r_i = a e^{b t_i} + c − y_i, minimum f = 0 at (2, −1.5, 0.5).
/// Start (1, −0.5, 0).
class ExponentialFit : public LeastSquaresTestProblem {
 public:
  ExponentialFit() : LeastSquaresTestProblem(3), t_(31), y_(31) {
    for (int i = 0; i < 31; ++i) {
      t_[i] = 0.1 * i;
      y_[i] = 2.0 * std::exp(-1.5 * t_[i]) + 0.5;
    }
  }
  void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    const Eigen::ArrayXd e = (x[1] * t_.array()).exp();
    r = (x[0] * e + x[2] - y_.array()).matrix();
    if (J) {
      J->resize(t_.size(), 3);
      J->col(0) = e.matrix();
      J->col(1) = (x[0] * t_.array() * e).matrix();
      J->col(2).setOnes();
    }
  }
  static Eigen::VectorXd start() { return Eigen::Vector3d(1.0, -0.5, 0.0); }
  static Eigen::VectorXd minimum() { return Eigen::Vector3d(2.0, -1.5, 0.5); }

 private:
  Eigen::VectorXd t_, y_;
};

// f = 100 ‖x − x*‖² with x* = (1000, 1000, 1000): far from the start 0 and steep (‖∇f‖∞ 2e5),
// so a long first step along −∇f is still downhill and a line search accepts all of it.
class FarSteepBowl : public LeastSquaresTestProblem {
 public:
  FarSteepBowl() : LeastSquaresTestProblem(3) {}
  void compute(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* J) const override {
    r = kSlope * (x - minimum());
    if (J) *J = kSlope * Eigen::MatrixXd::Identity(3, 3);
  }
  static Eigen::VectorXd minimum() { return Eigen::VectorXd::Constant(3, 1000.0); }

 private:
  static constexpr double kSlope = 10.0;
};

/// The length (∞-norm) of a run's first accepted step; NaN when it took none.
inline double first_step_length(const OptimizerResult& result) {
  return result.summary.trace.size() < 2 ? std::numeric_limits<double>::quiet_NaN()
                                         : result.summary.trace[1].step_length;
}

}  // namespace twill::testing
