#pragma once
// A test-only Discretization: a network of nonlinear springs with point masses under gravity.
//
// It implements what the equilibrium solver uses (rest positions, energy with gradient and
// fixed-pattern Hessian, lumped mass, gravity); the shell-specific methods throw
// std::logic_error("not used by this toy").
//
// Spring law (St. Venant–Kirchhoff spring): with x = x_b − x_a, l = |x|, rest length L0,
// stiffness k [N] and Green strain E = ½((l/L0)² − 1),
//     ψ = ½ k L0 E²                                   [J]
//     ∂ψ/∂x_b = −∂ψ/∂x_a = (k E / L0) x                [N]   (tension T = dψ/dl = k E l / L0)
//     ∂²ψ/∂x_b² = (k / L0) (E I + x xᵀ / L0²)          [N/m]
// so a compressed spring (E < 0) has negative transverse stiffness: a straight chain held
// shorter than its rest length has an indefinite Hessian (the buckling used to force the
// solver's backward-Euler failsafe). Gravity: Ψ_g = −Σ_i m_i g·x_i.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/discretization.hpp"

namespace twill::testing {

class SpringNetwork final : public Discretization {
 public:
  struct Spring {
    int a = 0, b = 0;
    double rest_length_m = 1.0;
    double stiffness_N = 1.0;
  };

  /// rest: #nodes × 3 flattened [x0 y0 z0 …] [m]; masses: per node [kg].
  SpringNetwork(Eigen::VectorXd rest, std::vector<Spring> springs, Eigen::VectorXd node_mass_kg)
      : rest_(std::move(rest)), springs_(std::move(springs)), node_mass_(std::move(node_mass_kg)) {
    if (rest_.size() % 3 != 0 || node_mass_.size() != rest_.size() / 3) {
      throw std::invalid_argument("SpringNetwork: sizes of rest positions and masses disagree");
    }
    build_pattern();
  }

  /// A chain of `segments` springs from node 0 to node `segments`, rest positions on the
  /// segment from `start` to `end`, each spring of rest length `rest_length_m`.
  static SpringNetwork chain(int segments, const Eigen::Vector3d& start, const Eigen::Vector3d& end,
                             double rest_length_m, double stiffness_N, double node_mass_kg) {
    Eigen::VectorXd rest(3 * (segments + 1));
    std::vector<Spring> springs;
    for (int i = 0; i <= segments; ++i) {
      rest.segment<3>(3 * i) = start + (end - start) * (static_cast<double>(i) / segments);
      if (i < segments) springs.push_back({i, i + 1, rest_length_m, stiffness_N});
    }
    return SpringNetwork(rest, springs, Eigen::VectorXd::Constant(segments + 1, node_mass_kg));
  }

  /// A (nx+1) × (ny+1) grid net in the z = 0 plane with spacing `spacing_m`, springs along
  /// grid lines at their rest spacing; node (i, j) has index j (nx+1) + i.
  static SpringNetwork net(int nx, int ny, double spacing_m, double stiffness_N,
                           double node_mass_kg) {
    Eigen::VectorXd rest(3 * (nx + 1) * (ny + 1));
    std::vector<Spring> springs;
    const auto id = [nx](int i, int j) { return j * (nx + 1) + i; };
    for (int j = 0; j <= ny; ++j) {
      for (int i = 0; i <= nx; ++i) {
        rest.segment<3>(3 * id(i, j)) = Eigen::Vector3d(i * spacing_m, j * spacing_m, 0.0);
        if (i < nx) springs.push_back({id(i, j), id(i + 1, j), spacing_m, stiffness_N});
        if (j < ny) springs.push_back({id(i, j), id(i, j + 1), spacing_m, stiffness_N});
      }
    }
    return SpringNetwork(rest, springs,
                         Eigen::VectorXd::Constant((nx + 1) * (ny + 1), node_mass_kg));
  }

  const std::vector<Spring>& springs() const { return springs_; }
  const Eigen::Vector3d& gravity() const { return gravity_; }
  /// Σ m_i [kg].
  double total_mass_kg() const { return node_mass_.sum(); }

  std::string name() const override { return "toy-spring-network"; }
  const StripSpec& strip() const override { return strip_; }
  int num_nodes() const override { return static_cast<int>(node_mass_.size()); }
  const Eigen::VectorXd& rest_positions() const override { return rest_; }
  void set_parameters(const MaterialParameters& parameters) override { parameters_ = parameters; }
  const MaterialParameters& parameters() const override { return parameters_; }
  void set_gravity(const Eigen::Vector3d& g_m_s2) override { gravity_ = g_m_s2; }

  double energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                SparseMatrix* hessian) const override {
    if (gradient) gradient->setZero(q.size());
    if (hessian) {
      if (hessian->rows() != pattern_.rows() || hessian->nonZeros() != pattern_.nonZeros() ||
          !hessian->isCompressed()) {
        *hessian = pattern_;
      }
      std::fill(hessian->valuePtr(), hessian->valuePtr() + hessian->nonZeros(), 0.0);
    }
    double total = 0;
    for (size_t s = 0; s < springs_.size(); ++s) {
      const Spring& spring = springs_[s];
      const Eigen::Vector3d x = q.segment<3>(3 * spring.b) - q.segment<3>(3 * spring.a);
      const double L0 = spring.rest_length_m;
      const double strain = 0.5 * (x.squaredNorm() / (L0 * L0) - 1.0);
      total += 0.5 * spring.stiffness_N * L0 * strain * strain;
      if (gradient) {
        const Eigen::Vector3d force = (spring.stiffness_N * strain / L0) * x;
        gradient->segment<3>(3 * spring.b) += force;
        gradient->segment<3>(3 * spring.a) -= force;
      }
      if (hessian) {
        const Eigen::Matrix3d block =
            (spring.stiffness_N / L0) *
            (strain * Eigen::Matrix3d::Identity() + x * x.transpose() / (L0 * L0));
        const std::array<int, 36>& slots = block_slots_[s];
        double* values = hessian->valuePtr();
        // Blocks in the order (a,a), (b,b), (a,b), (b,a); signs +, +, −, −.
        for (int blk = 0; blk < 4; ++blk) {
          const double sign = blk < 2 ? 1.0 : -1.0;
          for (int c = 0; c < 3; ++c) {
            for (int r = 0; r < 3; ++r)
              values[slots[static_cast<size_t>(9 * blk + 3 * c + r)]] += sign * block(r, c);
          }
        }
      }
    }
    for (int i = 0; i < num_nodes(); ++i) {
      total -= node_mass_[i] * gravity_.dot(q.segment<3>(3 * i));
      if (gradient) gradient->segment<3>(3 * i) -= node_mass_[i] * gravity_;
    }
    return total;
  }

  void gradient_parameter_jacobian(const Eigen::VectorXd&, Eigen::MatrixXd*) const override {
    throw std::logic_error("not used by this toy");
  }
  std::vector<int> clamped_nodes(StripEnd, bool) const override {
    throw std::logic_error("not used by this toy");
  }
  SparseMatrix point_evaluation(const std::vector<Eigen::Vector2d>&) const override {
    throw std::logic_error("not used by this toy");
  }
  Eigen::VectorXd lumped_mass() const override {
    Eigen::VectorXd m(3 * num_nodes());
    for (int i = 0; i < num_nodes(); ++i) m.segment<3>(3 * i).setConstant(node_mass_[i]);
    return m;
  }
  void surface_mesh(const Eigen::VectorXd&, Eigen::MatrixXd*, Eigen::MatrixXi*) const override {
    throw std::logic_error("not used by this toy");
  }

 private:
  // Pattern: every spring's four 3×3 blocks plus every node's diagonal block, built once;
  // block_slots_ maps each spring's block entries to positions in the value array.
  void build_pattern() {
    const int n = static_cast<int>(rest_.size());
    std::vector<Eigen::Triplet<double>> triplets;
    const auto add_block = [&](int ra, int cb) {
      for (int c = 0; c < 3; ++c) {
        for (int r = 0; r < 3; ++r) triplets.emplace_back(3 * ra + r, 3 * cb + c, 0.0);
      }
    };
    for (int i = 0; i < num_nodes(); ++i) add_block(i, i);
    for (const Spring& s : springs_) {
      add_block(s.a, s.b);
      add_block(s.b, s.a);
    }
    pattern_.resize(n, n);
    pattern_.setFromTriplets(triplets.begin(), triplets.end());
    pattern_.makeCompressed();
    const auto slot = [&](int row, int col) {
      const int* begin = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[col];
      const int* end = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[col + 1];
      return static_cast<int>(std::lower_bound(begin, end, row) - pattern_.innerIndexPtr());
    };
    block_slots_.clear();
    for (const Spring& s : springs_) {
      std::array<int, 36> slots{};
      const std::array<std::pair<int, int>, 4> blocks{
          {{s.a, s.a}, {s.b, s.b}, {s.a, s.b}, {s.b, s.a}}};
      for (int blk = 0; blk < 4; ++blk) {
        for (int c = 0; c < 3; ++c) {
          for (int r = 0; r < 3; ++r) {
            slots[static_cast<size_t>(9 * blk + 3 * c + r)] =
                slot(3 * blocks[static_cast<size_t>(blk)].first + r,
                     3 * blocks[static_cast<size_t>(blk)].second + c);
          }
        }
      }
      block_slots_.push_back(slots);
    }
  }

  Eigen::VectorXd rest_;
  std::vector<Spring> springs_;
  Eigen::VectorXd node_mass_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();
  MaterialParameters parameters_;
  StripSpec strip_;
  SparseMatrix pattern_;
  std::vector<std::array<int, 36>> block_slots_;
};

}  // namespace twill::testing
