// ConstrainedDofs and EquilibriumSolver on the spring-network toy (toy_discretization.hpp):
// analytic hanging chain, force balance of a hanging net, the backward-Euler failsafe from an
// indefinite start (paper §6.1), the clamp-displacement derivative −K_ff⁻¹K_fc (second-order
// central differences), continuation along a schedule, and options/status handling.
#include "core/equilibrium_solver.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/constrained_dofs.hpp"
#include "tests/core/toy_discretization.hpp"

namespace twill {
namespace {

using testing::SpringNetwork;
using SparseMatrix = Eigen::SparseMatrix<double>;
constexpr double kG = 9.81;

// ---------------------------------------------------------------------------------------
// ConstrainedDofs

TEST(ConstrainedDofs, MapsVectorsAndExtractsBlocksWithoutReallocating) {
  const int n = 12;
  // Random symmetric pattern in which some diagonal entries are missing.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> t;
  for (int k = 0; k < 30; ++k) {
    const int i = static_cast<int>(rng() % n), j = static_cast<int>(rng() % n);
    if (i == j) continue;
    const double v = value(rng);
    t.emplace_back(i, j, v);
    t.emplace_back(j, i, v);
  }
  for (int i = 0; i < n; i += 2) t.emplace_back(i, i, 3.0 + i);
  SparseMatrix h(n, n);
  h.setFromTriplets(t.begin(), t.end());
  h.makeCompressed();
  const Eigen::MatrixXd dense = Eigen::MatrixXd(h);

  const ConstrainedDofs dofs_unsorted(n, {9, 2, 5, 2});
  ConstrainedDofs dofs = dofs_unsorted;
  EXPECT_EQ(dofs.fixed_dofs(), (std::vector<int>{2, 5, 9}));
  EXPECT_EQ(dofs.num_free(), 9);
  EXPECT_TRUE(dofs.is_fixed(5));
  EXPECT_EQ(dofs.free_index(3), 2);
  EXPECT_EQ(dofs.fixed_index(9), 2);
  EXPECT_EQ(dofs.free_index(9), -1);

  const Eigen::VectorXd full = Eigen::VectorXd::LinSpaced(n, 0.0, 11.0);
  Eigen::VectorXd free, fixed, rebuilt = Eigen::VectorXd::Zero(n);
  dofs.gather_free(full, &free);
  dofs.gather_fixed(full, &fixed);
  EXPECT_EQ(fixed, Eigen::Vector3d(2, 5, 9));
  dofs.scatter_free(free, &rebuilt);
  dofs.scatter_fixed(fixed, &rebuilt);
  EXPECT_EQ(rebuilt, full);
  dofs.add_to_free(2.0, free, &rebuilt);
  EXPECT_EQ(rebuilt[5], 5.0);
  EXPECT_EQ(rebuilt[4], 12.0);

  dofs.analyze(h);
  EXPECT_TRUE(dofs.same_pattern(h));
  SparseMatrix k_ff, k_fc;
  dofs.extract_free_free(h, &k_ff);
  dofs.extract_free_fixed(h, &k_fc);
  const auto& free_dofs = dofs.free_dofs();
  const auto& fixed_dofs = dofs.fixed_dofs();
  for (int i = 0; i < dofs.num_free(); ++i) {
    for (int j = 0; j < dofs.num_free(); ++j) {
      EXPECT_EQ(k_ff.coeff(i, j), dense(free_dofs[i], free_dofs[j]));
    }
    for (int j = 0; j < dofs.num_fixed(); ++j) {
      EXPECT_EQ(k_fc.coeff(i, j), dense(free_dofs[i], fixed_dofs[j]));
    }
    // Every diagonal entry is stored (explicit zeros where H has none).
    const int slot = dofs.free_free_diagonal()[static_cast<size_t>(i)];
    ASSERT_GE(slot, 0);
    EXPECT_EQ(k_ff.innerIndexPtr()[slot], i);
    EXPECT_GE(slot, k_ff.outerIndexPtr()[i]);
    EXPECT_LT(slot, k_ff.outerIndexPtr()[i + 1]);
  }

  // New values, same pattern: values change, storage does not move.
  const double* storage = k_ff.valuePtr();
  SparseMatrix h2 = h * 2.0;
  dofs.extract_free_free(h2, &k_ff);
  EXPECT_EQ(k_ff.valuePtr(), storage);
  EXPECT_EQ(k_ff.coeff(0, 0), 2.0 * dense(free_dofs[0], free_dofs[0]));

  SparseMatrix other(n, n);
  other.setIdentity();
  EXPECT_FALSE(dofs.same_pattern(other));
  EXPECT_THROW(dofs.extract_free_free(other, &k_ff), std::invalid_argument);

  EXPECT_EQ(ConstrainedDofs::node_dofs({0, 2}), (std::vector<int>{0, 1, 2, 6, 7, 8}));
  try {
    ConstrainedDofs bad(6, {1, 6});
    FAIL() << "an out-of-range dof was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fixed_dofs[1]"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------
// Hanging chain: analytic equilibrium

// Spring length at which the StVK spring's tension k E l / L0 equals `tension` (Newton on a
// monotone cubic, l > L0/√3).
double stretched_length(double tension, double rest_length, double stiffness) {
  double l = 1.5 * rest_length;
  for (int it = 0; it < 100; ++it) {
    const double f =
        stiffness / (2 * rest_length) * (l * l * l / (rest_length * rest_length) - l) - tension;
    const double df = stiffness / (2 * rest_length) * (3 * l * l / (rest_length * rest_length) - 1);
    const double step = f / df;
    l -= step;
    if (std::fabs(step) < 1e-16 * l) break;
  }
  return l;
}

struct VerticalChain {
  static constexpr int kSegments = 10;
  static constexpr double kRest = 0.1, kStiffness = 50.0, kMass = 0.05;
  SpringNetwork network =
      SpringNetwork::chain(kSegments, Eigen::Vector3d::Zero(),
                           Eigen::Vector3d(0, 0, -kSegments* kRest), kRest, kStiffness, kMass);
  VerticalChain() { network.set_gravity(Eigen::Vector3d(0, 0, -kG)); }

  // Node i sits below node i−1 by the length of spring i−1, which carries nodes i … N.
  Eigen::VectorXd analytic() const {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(3 * (kSegments + 1));
    double z = 0;
    for (int s = 0; s < kSegments; ++s) {
      z -= stretched_length((kSegments - s) * kMass * kG, kRest, kStiffness);
      q[3 * (s + 1) + 2] = z;
    }
    return q;
  }
};

TEST(EquilibriumSolver, HangingChainMatchesAnalyticSolution) {
  VerticalChain chain;
  const Eigen::VectorXd exact = chain.analytic();
  // The strain reaches E ≈ 0.08 at the top: a genuinely nonlinear spring problem.
  EXPECT_GT(-exact[3 * VerticalChain::kSegments + 2], 1.04 * VerticalChain::kSegments * 0.1);

  EquilibriumSolver solver(chain.network, ConstrainedDofs::node_dofs({0}));
  // Start slightly stretched (every spring in tension, K_ff positive definite) and perturbed
  // sideways, so Newton works in 3D.
  Eigen::VectorXd q = 1.02 * chain.network.rest_positions();
  for (int i = 1; i <= VerticalChain::kSegments; ++i) q[3 * i] = 1e-3 * std::sin(i);
  const Eigen::Vector3d top = q.head<3>();
  const EquilibriumSummary summary = solver.solve(&q);
  ASSERT_TRUE(summary.converged) << summary.message;
  EXPECT_EQ(summary.status, EquilibriumStatus::kConverged);
  EXPECT_EQ(summary.fallbacks, 0);
  EXPECT_LE(summary.newton_iterations, 15);
  std::printf(
      "hanging chain: %d Newton iterations, %d backtracks, %d factorisations, "
      "|g_f| = %.2e N (F = %.2e N), %.2e s\n",
      summary.newton_iterations, summary.line_search_backtracks, summary.factorizations,
      summary.gradient_norm_N, summary.force_scale_N, summary.wall_time_s);
  EXPECT_LT((q - exact).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_EQ(q.head<3>(), top);  // the held node is never written

  // Reaction: the support carries the whole weight (its own node included), pointing up —
  // to within the free-force residual left by the convergence test (N × tol × F).
  const Eigen::VectorXd reaction = solver.reaction();
  ASSERT_EQ(reaction.size(), 3);
  const double residual_bound = VerticalChain::kSegments * summary.gradient_norm_N;
  EXPECT_NEAR(reaction[2], chain.network.total_mass_kg() * kG, residual_bound);
  EXPECT_NEAR(reaction[0], 0.0, residual_bound);
  EXPECT_LE(summary.gradient_norm_N, solver.options().gradient_tolerance * summary.force_scale_N);
}

TEST(EquilibriumSolver, ExposesTheFactorAndHessianAtTheSolution) {
  VerticalChain chain;
  EquilibriumSolver solver(chain.network, ConstrainedDofs::node_dofs({0}));
  EXPECT_FALSE(solver.has_solution_factorization());
  EXPECT_THROW(solver.factorization(), std::logic_error);
  Eigen::VectorXd q = 1.02 * chain.network.rest_positions();
  ASSERT_TRUE(solver.solve(&q).converged);
  ASSERT_TRUE(solver.has_solution_factorization());

  // K_ff and K_fc are the blocks of the Hessian at the returned q.
  SparseMatrix h;
  Eigen::VectorXd g;
  chain.network.energy(q, &g, &h);
  const Eigen::MatrixXd dense_h(h);
  const auto& free = solver.dofs().free_dofs();
  const auto& fixed = solver.dofs().fixed_dofs();
  const Eigen::MatrixXd k_ff(solver.free_free_hessian());
  const Eigen::MatrixXd k_fc(solver.free_fixed_hessian());
  ASSERT_EQ(k_ff.rows(), static_cast<Eigen::Index>(free.size()));
  ASSERT_EQ(k_fc.cols(), static_cast<Eigen::Index>(fixed.size()));
  for (size_t i = 0; i < free.size(); ++i) {
    for (size_t j = 0; j < free.size(); ++j) {
      EXPECT_EQ(k_ff(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)),
                dense_h(free[i], free[j]));
    }
    for (size_t j = 0; j < fixed.size(); ++j) {
      EXPECT_EQ(k_fc(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)),
                dense_h(free[i], fixed[j]));
    }
  }
  EXPECT_EQ(solver.gradient(), g);

  // Many right-hand sides through the kept factor (the shape of the sensitivity solve).
  std::mt19937 rng(1);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b(k_ff.rows(), 6);
  for (Eigen::Index j = 0; j < b.cols(); ++j) {
    for (Eigen::Index i = 0; i < b.rows(); ++i) b(i, j) = normal(rng);
  }
  Eigen::MatrixXd x;
  SolveReport report;
  solver.solve_free_free(b, &x, &report);
  const Eigen::MatrixXd reference = k_ff.llt().solve(b);
  EXPECT_LT((x - reference).lpNorm<Eigen::Infinity>() / reference.lpNorm<Eigen::Infinity>(), 1e-12);
  EXPECT_LT(report.residual_after, 1e-14);
}

// ---------------------------------------------------------------------------------------
// Backward-Euler failsafe (paper §6.1)

// A slack chain (rest length 1.25 m) between anchors 1 m apart, started on the straight
// line: every spring is compressed to 0.8 L0, so its transverse stiffness is negative and
// K_ff is indefinite. Newton cannot start; the failsafe must move the chain off the line,
// and Newton then converges to the hanging (stable) configuration.
struct SlackChain {
  static constexpr int kSegments = 12;
  static constexpr double kSpan = 1.0, kRestTotal = 1.25, kStiffness = 100.0, kMass = 0.01;
  SpringNetwork network =
      SpringNetwork::chain(kSegments, Eigen::Vector3d::Zero(), Eigen::Vector3d(kSpan, 0, 0),
                           kRestTotal / kSegments, kStiffness, kMass);
  SlackChain() { network.set_gravity(Eigen::Vector3d(0, 0, -kG)); }
  std::vector<int> anchors() const { return ConstrainedDofs::node_dofs({0, kSegments}); }
  // A guess below the anchors with every spring stretched: nodes equally spaced on a circular
  // arc of length 1.35 m (> 1.25 m) through the anchors.
  Eigen::VectorXd hanging_guess() const {
    const double arc = 1.35;
    double lo = 1e-3, hi = 3.0;  // half-angle θ with sin θ / θ = span / arc
    for (int it = 0; it < 200; ++it) {
      const double mid = 0.5 * (lo + hi);
      (std::sin(mid) / mid > kSpan / arc ? lo : hi) = mid;
    }
    const double theta = 0.5 * (lo + hi), radius = 0.5 * kSpan / std::sin(theta);
    Eigen::VectorXd q = network.rest_positions();
    for (int i = 0; i <= kSegments; ++i) {
      const double phi = -theta + 2.0 * theta * i / kSegments;
      q.segment<3>(3 * i) = Eigen::Vector3d(0.5 * kSpan + radius * std::sin(phi), 0.0,
                                            radius * (std::cos(theta) - std::cos(phi)));
    }
    q.head<3>().setZero();  // the anchors exactly where the schedule holds them
    q.segment<3>(3 * kSegments) = Eigen::Vector3d(kSpan, 0, 0);
    return q;
  }
};

TEST(EquilibriumSolver, BackwardEulerFailsafeEscapesAnIndefiniteStart) {
  SlackChain chain;
  EquilibriumSolver solver(chain.network, chain.anchors());
  Eigen::VectorXd q = chain.network.rest_positions();  // straight, compressed: indefinite

  // Confirm the premise: K_ff at the start is indefinite.
  {
    SparseMatrix h;
    Eigen::VectorXd g;
    chain.network.energy(q, &g, &h);
    ConstrainedDofs dofs(chain.network.num_dofs(), chain.anchors());
    dofs.analyze(h);
    SparseMatrix k_ff;
    dofs.extract_free_free(h, &k_ff);
    EXPECT_LT(
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Eigen::MatrixXd(k_ff)).eigenvalues()[0],
        -1.0);
  }

  const EquilibriumSummary summary = solver.solve(&q);
  std::printf(
      "slack chain: %s; %d Newton iterations, %d fallbacks, %d BE steps (last h = %.2e s), "
      "%d factorisations (%d not PD), %d backtracks, %.2e s\n",
      summary.message.c_str(), summary.newton_iterations, summary.fallbacks,
      summary.backward_euler_steps, summary.time_step_s, summary.factorizations,
      summary.failed_factorizations, summary.line_search_backtracks, summary.wall_time_s);
  ASSERT_TRUE(summary.converged) << summary.message;
  EXPECT_GE(summary.fallbacks, 1);
  EXPECT_GE(summary.backward_euler_steps, 1);
  EXPECT_GE(summary.failed_factorizations, 1);
  EXPECT_GT(summary.time_step_s, 0.0);
  EXPECT_LT(summary.energy_J, summary.initial_energy_J);

  // A minimum, not a saddle: K_ff at the solution is positive definite.
  const double lowest =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Eigen::MatrixXd(solver.free_free_hessian()))
          .eigenvalues()[0];
  EXPECT_GT(lowest, 0.0);
  // It hangs below the anchors, mirror-symmetric about x = span/2, in the plane y = 0.
  for (int i = 1; i < SlackChain::kSegments; ++i) {
    EXPECT_LT(q[3 * i + 2], -0.05);
    const int mirror = SlackChain::kSegments - i;
    EXPECT_NEAR(q[3 * i + 2], q[3 * mirror + 2], 1e-9);
    EXPECT_NEAR(q[3 * i], SlackChain::kSpan - q[3 * mirror], 1e-9);
    EXPECT_NEAR(q[3 * i + 1], 0.0, 1e-12);
  }
  // The same equilibrium as a plain Newton solve from a hanging guess.
  Eigen::VectorXd reference = chain.hanging_guess();
  EquilibriumSolver reference_solver(chain.network, chain.anchors());
  const EquilibriumSummary reference_summary = reference_solver.solve(&reference);
  ASSERT_TRUE(reference_summary.converged) << reference_summary.message;
  EXPECT_EQ(reference_summary.fallbacks, 0) << reference_summary.last_fallback_reason;
  EXPECT_LT((q - reference).lpNorm<Eigen::Infinity>(), 1e-9);
}

// A free node P held by three springs to anchors: two along x at ±a, longer at rest than a
// (compressed), and one up to (0, 0, h), at rest and stiff enough to hold z. No gravity: P at the
// origin is stationary by symmetry and K_ff is negative along y (the compressed springs'
// geometric stiffness 2 k ε / L, ε < 0): a saddle, the toy form of a flat strip that should
// wrinkle. `at_rest_along_x` makes the x springs exactly as long as a instead: K_ff is then singular
// along y and z and Ψ rises quartically there, a degenerate minimum with no lower point near.
struct CompressedStar {
  static constexpr double kHalfSpan = 0.8, kRest = 1.0, kStiffness = 100.0;
  static constexpr double kHeight = 0.5, kHoldStiffness = 100.0, kMass = 0.01;
  SpringNetwork network;
  explicit CompressedStar(bool at_rest_along_x = false)
      : network(rest_positions(), springs(at_rest_along_x), Eigen::VectorXd::Constant(4, kMass)) {}
  static Eigen::VectorXd rest_positions() {
    Eigen::VectorXd rest(12);
    rest << -kHalfSpan, 0, 0, kHalfSpan, 0, 0, 0, 0, kHeight, 0, 0, 0;  // A, B, C, then P
    return rest;
  }
  static std::vector<SpringNetwork::Spring> springs(bool at_rest_along_x) {
    const double along_x = at_rest_along_x ? kHalfSpan : kRest;
    return {{0, 3, along_x, kStiffness}, {1, 3, along_x, kStiffness}, {2, 3, kHeight, kHoldStiffness}};
  }
  static std::vector<int> anchors() { return ConstrainedDofs::node_dofs({0, 1, 2}); }
};

TEST(EquilibriumSolver, EscapesASaddleAlongItsLowestMode) {
  CompressedStar star;
  Eigen::VectorXd start = star.network.rest_positions();
  {  // The premise: stationary, and K_ff has a negative eigenvalue.
    SparseMatrix h;
    Eigen::VectorXd g;
    star.network.energy(start, &g, &h);
    EXPECT_LT(g.segment<3>(9).lpNorm<Eigen::Infinity>(), 1e-12);
    EXPECT_LT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(Eigen::MatrixXd(h).block<3, 3>(9, 9)).eigenvalues()[0], 0.0);
  }
  EquilibriumOptions stop_there;
  stop_there.max_saddle_escapes = 0;
  Eigen::VectorXd q = start;
  const EquilibriumSummary before = EquilibriumSolver(star.network, star.anchors(), stop_there).solve(&q);
  EXPECT_EQ(before.status, EquilibriumStatus::kIndefiniteStationary) << before.message;

  q = start;
  EquilibriumSolver solver(star.network, star.anchors());
  const EquilibriumSummary summary = solver.solve(&q);
  std::printf("compressed star: %s; %d saddle escapes, %d Newton iterations, P at (%.6f, %.6f, %.6f), Psi %.6e -> %.6e J\n",
              summary.message.c_str(), summary.saddle_escapes, summary.newton_iterations, q[9], q[10], q[11],
              summary.initial_energy_J, summary.energy_J);
  ASSERT_TRUE(summary.converged) << summary.message;
  EXPECT_GE(summary.saddle_escapes, 1);
  EXPECT_LT(summary.energy_J, summary.initial_energy_J);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Eigen::MatrixXd(solver.free_free_hessian())).eigenvalues()[0],
            0.0);
  // Buckled sideways (the x springs would be at rest at |y| = 0.6 without the hold) and the
  // same minimum a plain Newton solve reaches from a guess on that side.
  EXPECT_GT(std::fabs(q[10]), 0.3);
  Eigen::VectorXd reference = start;
  reference[10] = std::copysign(0.5, q[10]);
  EquilibriumSolver reference_solver(star.network, star.anchors());
  const EquilibriumSummary plain = reference_solver.solve(&reference);
  ASSERT_TRUE(plain.converged) << plain.message;
  EXPECT_EQ(plain.saddle_escapes, 0);
  EXPECT_LT((q - reference).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(EquilibriumSolver, ADegenerateMinimumIsNotEscapedFrom) {
  CompressedStar star(/*at_rest_along_x=*/true);
  Eigen::VectorXd q = star.network.rest_positions();
  const EquilibriumSummary summary = EquilibriumSolver(star.network, star.anchors()).solve(&q);
  EXPECT_EQ(summary.status, EquilibriumStatus::kIndefiniteStationary) << summary.message;
  EXPECT_EQ(summary.saddle_escapes, 0);
  EXPECT_EQ(q, star.network.rest_positions());
  const std::string escapes = "0 of " + std::to_string(EquilibriumOptions{}.max_saddle_escapes) + " saddle escapes";
  EXPECT_NE(summary.message.find(escapes), std::string::npos) << summary.message;
}

// Springs without stiffness: Ψ, g and K_ff all zero. The escape finds no shift to start from and
// the solve ends at once, reported (a zero start for the shift's doubling never grew).
TEST(EquilibriumSolver, NoStiffnessAtAllEndsReportedInsteadOfSearching) {
  SpringNetwork limp = SpringNetwork::chain(3, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.3, 0, 0), 0.1, 0.0, 0.01);
  Eigen::VectorXd q = limp.rest_positions();
  const EquilibriumSummary summary = EquilibriumSolver(limp, ConstrainedDofs::node_dofs({0, 3})).solve(&q);
  EXPECT_EQ(summary.status, EquilibriumStatus::kIndefiniteStationary) << summary.message;
  EXPECT_EQ(summary.saddle_escapes, 0);
}

// The paper's stall rule (≤ 0.1 % energy reduction in 3 Newton steps) measures the decrease
// against |Ψ|, which with gravity depends on where the origin is. The same hanging chain
// 10 m higher has |Ψ| ≈ 51 J against an elastic change of 0.04 J, so the bare rule
// (stall_gradient_fraction = 0) interrupts a Newton iteration that is converging
// quadratically; the default guard (‖g_f‖ did not drop 10× in those steps) does not.
TEST(EquilibriumSolver, StallRuleDoesNotInterruptConvergingNewton) {
  const double offset = 10.0;
  SpringNetwork network = SpringNetwork::chain(
      VerticalChain::kSegments, Eigen::Vector3d(0, 0, offset),
      Eigen::Vector3d(0, 0, offset - VerticalChain::kSegments * VerticalChain::kRest),
      VerticalChain::kRest, VerticalChain::kStiffness, VerticalChain::kMass);
  network.set_gravity(Eigen::Vector3d(0, 0, -kG));
  Eigen::VectorXd start = network.rest_positions();
  for (int i = 1; i <= VerticalChain::kSegments; ++i) {
    start[3 * i + 2] = offset + 1.02 * (start[3 * i + 2] - offset);
    start[3 * i] = 1e-3 * std::sin(i);
  }
  const Eigen::VectorXd exact =
      VerticalChain().analytic() + Eigen::VectorXd::NullaryExpr(start.size(), [&](Eigen::Index i) {
        return i % 3 == 2 ? offset : 0.0;
      });

  EquilibriumSolver guarded(network, ConstrainedDofs::node_dofs({0}));
  Eigen::VectorXd q = start;
  const EquilibriumSummary with_guard = guarded.solve(&q);
  ASSERT_TRUE(with_guard.converged) << with_guard.message;
  EXPECT_EQ(with_guard.fallbacks, 0) << with_guard.last_fallback_reason;
  EXPECT_LT((q - exact).lpNorm<Eigen::Infinity>(), 1e-9);

  EquilibriumOptions bare;
  bare.stall_gradient_fraction = 0.0;
  EquilibriumSolver unguarded(network, ConstrainedDofs::node_dofs({0}), bare);
  q = start;
  const EquilibriumSummary without_guard = unguarded.solve(&q);
  ASSERT_TRUE(without_guard.converged) << without_guard.message;
  EXPECT_GE(without_guard.fallbacks, 1);
  EXPECT_NE(without_guard.last_fallback_reason.find("stall"), std::string::npos);
  EXPECT_LT((q - exact).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(EquilibriumSolver, ConvergesAtTheRoundoffFloorInsteadOfFallingBack) {
  // The hanging chain 1 km up: the spring vectors are differences of coordinates near 1e3 m,
  // so ‖g_f‖ and λ² bottom out at the round-off of the positions (λ² ≈ 6e-24 J here), and
  // Ψ ≈ 5e3 J resolves nothing below ~1e-12 J. With a decrement tolerance below that floor
  // the solver used to backtrack to steps that left q unchanged and then take 20 backward-
  // Euler fallbacks before failing; now it stops converged at the floor (header comment).
  const double height = 1e3;
  SpringNetwork network = SpringNetwork::chain(
      VerticalChain::kSegments, Eigen::Vector3d(0, 0, height),
      Eigen::Vector3d(0, 0, height - VerticalChain::kSegments * VerticalChain::kRest),
      VerticalChain::kRest, VerticalChain::kStiffness, VerticalChain::kMass);
  network.set_gravity(Eigen::Vector3d(0, 0, -kG));
  Eigen::VectorXd start = network.rest_positions();
  for (int i = 1; i <= VerticalChain::kSegments; ++i) {
    start[3 * i + 2] = height + 1.02 * (start[3 * i + 2] - height);
    start[3 * i] = 1e-3 * std::sin(i);
  }
  const Eigen::VectorXd exact =
      VerticalChain().analytic() + Eigen::VectorXd::NullaryExpr(start.size(), [&](Eigen::Index i) {
        return i % 3 == 2 ? height : 0.0;
      });

  EquilibriumOptions tight;
  tight.decrement_tolerance = 1e-26;  // λ² ≤ ~5e-26 J: below the floor of this chain
  EquilibriumSolver solver(network, ConstrainedDofs::node_dofs({0}), tight);
  Eigen::VectorXd q = start;
  const EquilibriumSummary summary = solver.solve(&q);
  std::printf("chain at 1 km, decrement tolerance 1e-26: %s, %d Newton iterations, %d fallbacks, "
              "lambda^2 = %.3e J: %s\n",
              to_string(summary.status), summary.newton_iterations, summary.fallbacks,
              summary.newton_decrement_J, summary.message.c_str());
  ASSERT_TRUE(summary.converged) << summary.message;
  EXPECT_TRUE(summary.at_roundoff_floor);
  EXPECT_EQ(summary.fallbacks, 0) << summary.last_fallback_reason;
  EXPECT_LE(summary.newton_iterations, 10);
  EXPECT_NE(summary.message.find("round-off floor"), std::string::npos) << summary.message;
  EXPECT_LT((q - exact).lpNorm<Eigen::Infinity>(), 1e-9);
  EXPECT_TRUE(solver.has_solution_factorization());
  EXPECT_EQ(solver.reaction().size(), 3);

  // At the default tolerances the same chain converges by the ordinary tests.
  EquilibriumSolver ordinary(network, ConstrainedDofs::node_dofs({0}));
  q = start;
  const EquilibriumSummary normal = ordinary.solve(&q);
  ASSERT_TRUE(normal.converged) << normal.message;
  EXPECT_FALSE(normal.at_roundoff_floor);
  EXPECT_LT((q - exact).lpNorm<Eigen::Infinity>(), 1e-9);
}

TEST(EquilibriumSolver, ReportsInsteadOfThrowingWhenTheFailsafeIsDisabled) {
  SlackChain chain;
  EquilibriumOptions options;
  options.max_fallbacks = 0;
  EquilibriumSolver solver(chain.network, chain.anchors(), options);
  Eigen::VectorXd q = chain.network.rest_positions();
  EquilibriumSummary summary;
  ASSERT_NO_THROW(summary = solver.solve(&q));
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(summary.status, EquilibriumStatus::kFallbackLimit);
  EXPECT_NE(summary.message.find("positive definite"), std::string::npos) << summary.message;
  EXPECT_FALSE(solver.has_solution_factorization());
  EXPECT_EQ(q, chain.network.rest_positions());  // nothing was accepted

  q[4] = std::nan("");
  ASSERT_NO_THROW(summary = solver.solve(&q));
  EXPECT_EQ(summary.status, EquilibriumStatus::kNonFinite);
}

// ---------------------------------------------------------------------------------------
// Hanging net: force balance, symmetry, and the clamp-displacement derivative

struct HangingNet {
  static constexpr int kCells = 6;
  static constexpr double kSpacing = 0.1, kStiffness = 20.0, kMass = 0.002, kPrestretch = 1.1;
  SpringNetwork network = SpringNetwork::net(kCells, kCells, kSpacing, kStiffness, kMass);
  HangingNet() { network.set_gravity(Eigen::Vector3d(0, 0, -kG)); }
  static int id(int i, int j) { return j * (kCells + 1) + i; }
  std::vector<int> corners() const {
    return ConstrainedDofs::node_dofs({id(0, 0), id(kCells, 0), id(0, kCells), id(kCells, kCells)});
  }
  // Pre-stretched flat start: all springs in tension, so K_ff is positive definite.
  Eigen::VectorXd start() const { return kPrestretch * network.rest_positions(); }
};

TEST(EquilibriumSolver, HangingNetBalancesGravityAndKeepsSymmetry) {
  HangingNet net;
  EquilibriumSolver solver(net.network, net.corners());
  Eigen::VectorXd q = net.start();
  const Eigen::VectorXd start = q;
  const EquilibriumSummary summary = solver.solve(&q);
  std::printf("hanging net (%d free dofs): %d Newton iterations, %d fallbacks, %.2e s\n",
              solver.dofs().num_free(), summary.newton_iterations, summary.fallbacks,
              summary.wall_time_s);
  ASSERT_TRUE(summary.converged) << summary.message;
  for (int dof : solver.dofs().fixed_dofs()) EXPECT_EQ(q[dof], start[dof]);

  // Σ reactions = total weight (vertical), 0 horizontally (elastic forces cancel in sum).
  const Eigen::VectorXd reaction = solver.reaction();
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int c = 0; c < 4; ++c) total += reaction.segment<3>(3 * c);
  const double weight = net.network.total_mass_kg() * kG;
  EXPECT_NEAR(total.z(), weight, 1e-9 * weight);
  EXPECT_NEAR(total.x(), 0.0, 1e-9 * weight);
  EXPECT_NEAR(total.y(), 0.0, 1e-9 * weight);

  // Mirror symmetry in x and y about the centre of the square, and it sags.
  const double side = HangingNet::kPrestretch * HangingNet::kCells * HangingNet::kSpacing;
  for (int j = 0; j <= HangingNet::kCells; ++j) {
    for (int i = 0; i <= HangingNet::kCells; ++i) {
      const int a = HangingNet::id(i, j), b = HangingNet::id(HangingNet::kCells - i, j),
                c = HangingNet::id(i, HangingNet::kCells - j);
      EXPECT_NEAR(q[3 * a + 2], q[3 * b + 2], 1e-10);
      EXPECT_NEAR(q[3 * a + 2], q[3 * c + 2], 1e-10);
      EXPECT_NEAR(q[3 * a], side - q[3 * b], 1e-10);
      EXPECT_NEAR(q[3 * a + 1], side - q[3 * c + 1], 1e-10);
    }
  }
  EXPECT_LT(q[3 * HangingNet::id(3, 3) + 2], -0.01);
}

// Moving held dofs by δ moves the free ones by ∂q_f/∂q_c δ = −K_ff⁻¹ K_fc δ (the clamp analogue
// of paper Eq. 6, built from the exposed factor and K_fc). Central differences of re-solved
// equilibria must approach it at second order.
TEST(EquilibriumSolver, ClampDisplacementDerivativeMatchesCentralDifferencesAtSecondOrder) {
  HangingNet net;
  EquilibriumOptions options;
  options.gradient_tolerance = 1e-12;
  EquilibriumSolver solver(net.network, net.corners(), options);
  Eigen::VectorXd q0 = net.start();
  ASSERT_TRUE(solver.solve(&q0).converged);
  // Direction: pull the two x = side corners outward in x.
  Eigen::VectorXd direction = Eigen::VectorXd::Zero(solver.dofs().num_fixed());
  direction[solver.dofs().fixed_index(3 * HangingNet::id(HangingNet::kCells, 0))] = 1.0;
  direction[solver.dofs().fixed_index(3 * HangingNet::id(HangingNet::kCells, HangingNet::kCells))] =
      1.0;
  Eigen::MatrixXd rhs = -(solver.free_fixed_hessian() * direction);
  Eigen::MatrixXd predicted;
  solver.solve_free_free(rhs, &predicted);

  const auto solve_moved = [&](double delta) {
    Eigen::VectorXd q = q0;
    Eigen::VectorXd fixed;
    solver.dofs().gather_fixed(q, &fixed);
    solver.dofs().scatter_fixed(fixed + delta * direction, &q);
    const EquilibriumSummary s = solver.solve(&q);
    EXPECT_TRUE(s.converged) << s.message;
    Eigen::VectorXd free;
    solver.dofs().gather_free(q, &free);
    return free;
  };
  std::vector<double> errors;
  for (double delta : {8e-3, 4e-3, 2e-3}) {
    const Eigen::VectorXd central = (solve_moved(delta) - solve_moved(-delta)) / (2 * delta);
    errors.push_back((central - predicted.col(0)).lpNorm<Eigen::Infinity>());
  }
  const double ratio1 = errors[0] / errors[1], ratio2 = errors[1] / errors[2];
  std::printf(
      "clamp derivative: |∂q_f/∂q_c| = %.3e, central-difference errors %.3e %.3e %.3e, "
      "ratios %.2f %.2f\n",
      predicted.lpNorm<Eigen::Infinity>(), errors[0], errors[1], errors[2], ratio1, ratio2);
  EXPECT_GT(errors[2], 1e-12);  // still in the truncation regime, not round-off
  EXPECT_NEAR(ratio1, 4.0, 0.4);
  EXPECT_NEAR(ratio2, 4.0, 0.4);
}

// ---------------------------------------------------------------------------------------
// Continuation

// A chain of 10 springs (rest length 1 m in total) under gravity, its right end pulled from
// x = 1.05 m to 1.23 m in 10 equal steps.
struct PulledChain {
  static constexpr int kSegments = 10, kSteps = 10;
  static constexpr double kStiffness = 30.0, kMass = 0.02;
  SpringNetwork network = SpringNetwork::chain(kSegments, Eigen::Vector3d::Zero(),
                                               Eigen::Vector3d(1.0, 0, 0), 0.1, kStiffness, kMass);
  PulledChain() { network.set_gravity(Eigen::Vector3d(0, 0, -kG)); }
  std::vector<int> ends() const { return ConstrainedDofs::node_dofs({0, kSegments}); }
  static double end_x(int step) { return 1.05 + 0.02 * step; }
  // Straight and uniformly stretched to the first end position (tension: K_ff is SPD).
  Eigen::VectorXd start() const { return end_x(0) * network.rest_positions(); }
  static void apply(int step, Eigen::VectorXd* q) { (*q)[3 * kSegments] = end_x(step); }
};

TEST(EquilibriumSolver, ContinuationFollowsTheScheduleFromEquilibriumToEquilibrium) {
  PulledChain chain;
  const ContinuationPredictor predictors[] = {ContinuationPredictor::kPrevious, ContinuationPredictor::kSecant,
                                              ContinuationPredictor::kTangent};
  const char* names[] = {"previous equilibrium", "secant", "tangent"};
  int total_iterations[3] = {0, 0, 0};
  Eigen::VectorXd final_q[3];
  for (int k = 0; k < 3; ++k) {
    EquilibriumSolver solver(chain.network, chain.ends());
    Eigen::VectorXd q = chain.start();
    std::vector<int> observed_steps;
    std::vector<double> sag, pull;
    const auto observer = [&](int step, const Eigen::VectorXd& equilibrium,
                              const EquilibriumSummary& s) {
      EXPECT_TRUE(s.converged);
      EXPECT_EQ(s.fallbacks, 0) << s.last_fallback_reason;
      EXPECT_EQ(equilibrium[3 * PulledChain::kSegments], PulledChain::end_x(step));
      EXPECT_EQ(equilibrium.head<3>(), Eigen::Vector3d::Zero());
      observed_steps.push_back(step);
      sag.push_back(equilibrium[3 * (PulledChain::kSegments / 2) + 2]);
      pull.push_back(solver.reaction()[3]);  // x-force the right support applies
    };
    ContinuationOptions options;
    options.predictor = predictors[k];
    const ContinuationSummary summary =
        solver.solve_continuation(PulledChain::kSteps, &PulledChain::apply, &q, observer, options);
    ASSERT_TRUE(summary.completed) << summary.message;
    EXPECT_EQ(summary.steps_completed, PulledChain::kSteps);
    EXPECT_EQ(summary.failed_step, -1);
    EXPECT_EQ(static_cast<int>(summary.steps.size()), PulledChain::kSteps);
    ASSERT_EQ(static_cast<int>(observed_steps.size()), PulledChain::kSteps);
    for (int i = 0; i < PulledChain::kSteps; ++i)
      EXPECT_EQ(observed_steps[static_cast<size_t>(i)], i);
    // Pulling the end out lifts the middle and raises the tension.
    for (size_t i = 1; i < sag.size(); ++i) {
      EXPECT_GT(sag[i], sag[i - 1]);
      EXPECT_GT(pull[i], pull[i - 1]);
    }
    EXPECT_LT(sag.back(), 0.0);
    total_iterations[k] = summary.total_newton_iterations;
    final_q[k] = q;
    if (k > 0) {
      EXPECT_GE(summary.extrapolations_used, 1);
    }
    std::printf(
        "continuation (%s): %d steps, %d Newton iterations, %d predicted starts, "
        "%.2e s\n",
        names[k], summary.steps_completed,
        summary.total_newton_iterations, summary.extrapolations_used, summary.wall_time_s);
  }
  // Measured: each predictor saves Newton iterations over the one before on this schedule,
  // and all three end at the same equilibrium.
  EXPECT_LT(total_iterations[1], total_iterations[0]);
  EXPECT_LE(total_iterations[2], total_iterations[1]);
  EXPECT_LT((final_q[0] - final_q[1]).lpNorm<Eigen::Infinity>(), 1e-10);
  EXPECT_LT((final_q[0] - final_q[2]).lpNorm<Eigen::Infinity>(), 1e-10);

  // The last equilibrium equals a direct solve at the last end position.
  EquilibriumSolver direct(chain.network, chain.ends());
  Eigen::VectorXd q = PulledChain::end_x(PulledChain::kSteps - 1) * chain.network.rest_positions();
  ASSERT_TRUE(direct.solve(&q).converged);
  EXPECT_LT((q - final_q[1]).lpNorm<Eigen::Infinity>(), 1e-10);
}

// set_solution_factor_needed(false): the full step's trial skips the Hessian and convergence
// is certified with the previous iterate's factor (equilibrium_solver.hpp). Same equilibria,
// one factorisation fewer per converged solve, the tangent predictor still used.
TEST(EquilibriumSolver, WithoutTheSolutionFactorConvergesWithOneFactorisationFewer) {
  VerticalChain chain;
  Eigen::VectorXd start = 1.02 * chain.network.rest_positions();
  for (int i = 1; i <= VerticalChain::kSegments; ++i) start[3 * i] = 1e-3 * std::sin(i);
  EquilibriumSolver exact(chain.network, ConstrainedDofs::node_dofs({0}));
  EquilibriumSolver lazy(chain.network, ConstrainedDofs::node_dofs({0}));
  lazy.set_solution_factor_needed(false);
  Eigen::VectorXd q_exact = start, q_lazy = start;
  const EquilibriumSummary a = exact.solve(&q_exact);
  const EquilibriumSummary b = lazy.solve(&q_lazy);
  ASSERT_TRUE(a.converged && b.converged) << a.message << " / " << b.message;
  EXPECT_FALSE(a.decrement_from_previous_factor);
  EXPECT_TRUE(b.decrement_from_previous_factor) << b.message;
  EXPECT_EQ(b.newton_iterations, a.newton_iterations);
  EXPECT_EQ(b.factorizations, a.factorizations - 1);
  EXPECT_EQ(q_lazy, q_exact);  // the same iterate is returned
  EXPECT_FALSE(lazy.has_solution_factorization());
  EXPECT_THROW(lazy.factorization(), std::logic_error);

  // Along a schedule: the same equilibria, the tangent predictor used as often, fewer factors.
  PulledChain pulled;
  int factorizations[2] = {0, 0}, extrapolations[2] = {0, 0};
  Eigen::VectorXd final_q[2];
  for (int k = 0; k < 2; ++k) {
    EquilibriumSolver solver(pulled.network, pulled.ends());
    solver.set_solution_factor_needed(k == 0);
    Eigen::VectorXd q = pulled.start();
    const ContinuationSummary summary = solver.solve_continuation(PulledChain::kSteps, &PulledChain::apply, &q);
    ASSERT_TRUE(summary.completed) << summary.message;
    for (const EquilibriumSummary& step : summary.steps) factorizations[k] += step.factorizations;
    extrapolations[k] = summary.extrapolations_used;
    final_q[k] = q;
  }
  EXPECT_LT(factorizations[1], factorizations[0]);
  EXPECT_EQ(extrapolations[1], extrapolations[0]);
  EXPECT_LT((final_q[0] - final_q[1]).lpNorm<Eigen::Infinity>(), 1e-10);
}

TEST(EquilibriumSolver, ContinuationStopsAtTheFirstFailedStep) {
  PulledChain chain;
  chain.network.set_gravity(Eigen::Vector3d::Zero());
  EquilibriumOptions options;
  options.max_newton_iterations = 1;  // step 0 is already in equilibrium, step 1 is not
  EquilibriumSolver solver(chain.network, chain.ends(), options);
  Eigen::VectorXd q = chain.start();
  int observed = 0;
  const auto schedule = [](int step, Eigen::VectorXd* x) {
    (*x)[3 * PulledChain::kSegments] = step == 0 ? PulledChain::end_x(0) : 1.3;
  };
  // The plain start: the tangent predictor would land step 1 within one Newton iteration of
  // this chain's equilibrium, and this test is about what happens when a step fails.
  ContinuationOptions plain;
  plain.predictor = ContinuationPredictor::kPrevious;
  const ContinuationSummary summary = solver.solve_continuation(
      3, schedule, &q, [&](int, const Eigen::VectorXd&, const EquilibriumSummary&) { ++observed; }, plain);
  EXPECT_FALSE(summary.completed);
  EXPECT_EQ(summary.failed_step, 1);
  EXPECT_EQ(summary.steps_completed, 1);
  EXPECT_EQ(summary.steps.size(), 2u);
  EXPECT_EQ(summary.steps[1].status, EquilibriumStatus::kMaxIterations);
  EXPECT_EQ(observed, 1);
  EXPECT_NE(summary.message.find("step 1"), std::string::npos) << summary.message;
}

TEST(EquilibriumSolver, AllDofsFixedIsTriviallyConverged) {
  VerticalChain chain;
  std::vector<int> all(static_cast<size_t>(chain.network.num_dofs()));
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  EquilibriumSolver solver(chain.network, all);
  Eigen::VectorXd q = chain.network.rest_positions();
  const EquilibriumSummary summary = solver.solve(&q);
  EXPECT_TRUE(summary.converged) << summary.message;
  EXPECT_EQ(summary.newton_iterations, 0);
  EXPECT_EQ(solver.reaction().size(), chain.network.num_dofs());
}

// ---------------------------------------------------------------------------------------
// Options

TEST(EquilibriumOptions, ValidateNamesTheOffendingField) {
  std::string error;
  EXPECT_TRUE(EquilibriumOptions{}.validate(&error)) << error;
  EXPECT_TRUE(error.empty());

  struct Case {
    const char* field;
    void (*breaker)(EquilibriumOptions*);
  };
  const Case cases[] = {
      {"gradient_tolerance", [](EquilibriumOptions* o) { o->gradient_tolerance = 0; }},
      {"force_floor_N", [](EquilibriumOptions* o) { o->force_floor_N = -1; }},
      {"decrement_tolerance", [](EquilibriumOptions* o) { o->decrement_tolerance = std::nan(""); }},
      {"length_scale_m", [](EquilibriumOptions* o) { o->length_scale_m = -0.1; }},
      {"max_newton_iterations", [](EquilibriumOptions* o) { o->max_newton_iterations = 0; }},
      {"armijo_c1", [](EquilibriumOptions* o) { o->armijo_c1 = 0.7; }},
      {"backtrack_factor", [](EquilibriumOptions* o) { o->backtrack_factor = 1.0; }},
      {"max_backtracks", [](EquilibriumOptions* o) { o->max_backtracks = 0; }},
      {"stall_window", [](EquilibriumOptions* o) { o->stall_window = 0; }},
      {"stall_gradient_fraction", [](EquilibriumOptions* o) { o->stall_gradient_fraction = 2; }},
      {"backward_euler_steps", [](EquilibriumOptions* o) { o->backward_euler_steps = 0; }},
      {"max_fallbacks", [](EquilibriumOptions* o) { o->max_fallbacks = -1; }},
      {"initial_time_step_s", [](EquilibriumOptions* o) { o->initial_time_step_s = -1; }},
      {"time_step_growth", [](EquilibriumOptions* o) { o->time_step_growth = 1.0; }},
      {"max_time_step_reductions", [](EquilibriumOptions* o) { o->max_time_step_reductions = 0; }},
      {"max_saddle_escapes", [](EquilibriumOptions* o) { o->max_saddle_escapes = -1; }},
      {"linear_solver.refinement_steps",
       [](EquilibriumOptions* o) { o->linear_solver.refinement_steps = -1; }},
  };
  VerticalChain chain;
  for (const Case& c : cases) {
    EquilibriumOptions options;
    c.breaker(&options);
    EXPECT_FALSE(options.validate(&error)) << c.field;
    EXPECT_EQ(error.rfind(c.field, 0), 0u)
        << "expected the message to start with " << c.field << ", got: " << error;
    try {
      EquilibriumSolver solver(chain.network, {0, 1, 2}, options);
      ADD_FAILURE() << "invalid " << c.field << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
  Eigen::VectorXd wrong_size(5);
  EquilibriumSolver solver(chain.network, {0, 1, 2});
  EXPECT_THROW(solver.solve(&wrong_size), std::invalid_argument);
}

}  // namespace
}  // namespace twill
