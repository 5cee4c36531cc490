// The assembly machinery both discretisations share (discretizations/assembly/): Hessian
// pattern and slot tables, block scatter, conflict-free schedules, the parallel runner, nodal
// gravity and element scratch. The discretisations' own derivative tests cover them in use;
// these check each piece against a plain reference on small random meshes.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cstring>
#include <random>
#include <vector>

#include "discretizations/assembly/block_scatter.hpp"
#include "discretizations/assembly/element_nodes.hpp"
#include "discretizations/assembly/element_schedule.hpp"
#include "discretizations/assembly/element_scratch.hpp"
#include "discretizations/assembly/hessian_pattern.hpp"
#include "discretizations/assembly/nodal_gravity.hpp"
#include "discretizations/assembly/parallel_runner.hpp"

namespace twill {
namespace {

/// Random elements of 2…6 nodes over `num_nodes` nodes; every 7th repeats a node (as a
/// Catmull–Clark boundary patch's phantom points do).
ElementNodes random_elements(int num_nodes, int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> node(0, num_nodes - 1), size(2, 6);
  ElementNodes elements;
  for (int e = 0; e < count; ++e) {
    std::vector<int> nodes(static_cast<size_t>(size(rng)));
    for (int& n : nodes) n = node(rng);
    if (e % 7 == 0) nodes.back() = nodes.front();
    elements.add(nodes);
  }
  return elements;
}

/// A random symmetric 3m × 3m block per element.
std::vector<Eigen::MatrixXd> random_blocks(const ElementNodes& elements, unsigned seed) {
  std::srand(seed);
  std::vector<Eigen::MatrixXd> blocks;
  for (int e = 0; e < elements.size(); ++e) {
    const auto m = static_cast<Eigen::Index>(3 * elements[e].size());
    const Eigen::MatrixXd A = Eigen::MatrixXd::Random(m, m);
    blocks.push_back(A + A.transpose());
  }
  return blocks;
}

/// Σ_e P_eᵀ H_e P_e as a dense matrix (the reference for the scatter).
Eigen::MatrixXd dense_sum(int num_nodes, const ElementNodes& elements,
                          const std::vector<Eigen::MatrixXd>& blocks) {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * num_nodes, 3 * num_nodes);
  for (int e = 0; e < elements.size(); ++e) {
    const auto nodes = elements[e];
    for (size_t a = 0; a < nodes.size(); ++a)
      for (size_t b = 0; b < nodes.size(); ++b)
        H.block<3, 3>(3 * nodes[a], 3 * nodes[b]) +=
            blocks[static_cast<size_t>(e)].block<3, 3>(3 * static_cast<Eigen::Index>(a),
                                                        3 * static_cast<Eigen::Index>(b));
  }
  return H;
}

TEST(HessianPattern, MatchesTheFullBlockPatternAndItsSlotsAddress) {
  const int num_nodes = 40;
  const ElementNodes elements = random_elements(num_nodes, 60, 1);
  const HessianPattern pattern(num_nodes, elements);
  // Reference: full 3×3 blocks of every node pair of an element, from triplets.
  std::vector<Eigen::Triplet<double>> triplets;
  for (int e = 0; e < elements.size(); ++e)
    for (int a : elements[e])
      for (int b : elements[e])
        for (int r = 0; r < 3; ++r)
          for (int s = 0; s < 3; ++s) triplets.emplace_back(3 * a + r, 3 * b + s, 1.0);
  SparseMatrix reference(3 * num_nodes, 3 * num_nodes);
  reference.setFromTriplets(triplets.begin(), triplets.end());
  const SparseMatrix M = pattern.matrix();
  ASSERT_EQ(M.nonZeros(), reference.nonZeros());
  EXPECT_TRUE(std::equal(M.outerIndexPtr(), M.outerIndexPtr() + M.cols() + 1, reference.outerIndexPtr()));
  EXPECT_TRUE(std::equal(M.innerIndexPtr(), M.innerIndexPtr() + M.nonZeros(), reference.innerIndexPtr()));
  // Slot (a m + b) 3 + s addresses row 3 n_a of column 3 n_b + s.
  for (int e = 0; e < elements.size(); ++e) {
    const auto nodes = elements[e];
    const int m = static_cast<int>(nodes.size());
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b)
        for (int s = 0; s < 3; ++s) {
          const int slot = pattern.slots(e)[(a * m + b) * 3 + s];
          const int column = 3 * nodes[static_cast<size_t>(b)] + s;
          ASSERT_GE(slot, M.outerIndexPtr()[column]);
          ASSERT_LT(slot + 2, M.outerIndexPtr()[column + 1]);
          EXPECT_EQ(M.innerIndexPtr()[slot], 3 * nodes[static_cast<size_t>(a)]);
        }
  }
}

TEST(HessianPattern, PrepareKeepsAMatrixThatHasThePattern) {
  const ElementNodes elements = random_elements(20, 15, 2);
  const HessianPattern pattern(20, elements);
  SparseMatrix H;
  double* values = pattern.prepare(&H);
  std::fill(values, values + H.nonZeros(), 1.5);
  EXPECT_EQ(pattern.prepare(&H), values);  // same storage: no allocation
  EXPECT_EQ(H.coeffs().cwiseAbs().maxCoeff(), 0.0);
}

TEST(BlockScatter, HessianAndNodalScatterEqualTheDenseSums) {
  const int num_nodes = 30;
  const ElementNodes elements = random_elements(num_nodes, 50, 3);
  const HessianPattern pattern(num_nodes, elements);
  const std::vector<Eigen::MatrixXd> blocks = random_blocks(elements, 3);
  SparseMatrix H;
  double* values = pattern.prepare(&H);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(3 * num_nodes), g_reference = g;
  for (int e = 0; e < elements.size(); ++e) {
    const Eigen::MatrixXd& B = blocks[static_cast<size_t>(e)];
    scatter_hessian(values, pattern.slots(e), static_cast<int>(elements[e].size()), node_major_blocks(B));
    const Eigen::VectorXd local = B.col(0);
    scatter_nodal(g.data(), elements[e], node_major(local));
    for (size_t k = 0; k < elements[e].size(); ++k)
      g_reference.segment<3>(3 * elements[e][k]) += local.segment<3>(3 * static_cast<Eigen::Index>(k));
  }
  EXPECT_LT((Eigen::MatrixXd(H) - dense_sum(num_nodes, elements, blocks)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((g - g_reference).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(ElementSchedule, ColouringIsConflictFreeAndCoversEveryElementOnce) {
  const int num_nodes = 50;
  const ElementNodes elements = random_elements(num_nodes, 80, 4);
  const ElementSchedule schedule = ElementSchedule::colouring(elements, num_nodes);
  EXPECT_TRUE(schedule.conflict_free(elements, num_nodes));
  std::vector<int> all = schedule.elements();
  std::sort(all.begin(), all.end());
  std::vector<int> expected(static_cast<size_t>(elements.size()));
  for (int e = 0; e < elements.size(); ++e) expected[static_cast<size_t>(e)] = e;
  EXPECT_EQ(all, expected);
}

TEST(ElementSchedule, AlternatingSlabsAreCheckedForConflicts) {
  // A strip of nodes 0 … 11; element i joins nodes i and i + 1.
  ElementNodes chain;
  for (int i = 0; i < 11; ++i) chain.add(std::vector<int>{i, i + 1});
  // Slabs of 3 elements: slabs of equal parity are 3 elements apart, sharing no node.
  const std::vector<std::vector<int>> slabs = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}, {9, 10}};
  EXPECT_TRUE(ElementSchedule::alternating(slabs).conflict_free(chain, 12));
  // Elements 0 and 1 share node 1: as two groups of one phase they conflict.
  ElementSchedule bad;
  bad.add_phase({{0}, {1}});
  EXPECT_FALSE(bad.conflict_free(chain, 12));
}

TEST(ParallelRunner, ScheduledScatterIsBitwiseTheSameForAnyThreadCount) {
  const int num_nodes = 200;
  const ElementNodes elements = random_elements(num_nodes, 600, 5);
  const HessianPattern pattern(num_nodes, elements);
  const ElementSchedule schedule = ElementSchedule::colouring(elements, num_nodes);
  const std::vector<Eigen::MatrixXd> blocks = random_blocks(elements, 5);
  auto assemble = [&](int threads) {
    const ParallelRunner runner(threads);
    SparseMatrix H;
    double* values = pattern.prepare(&H);
    runner.run(schedule, [&](std::span<const int> ids) {
      for (int e : ids)
        scatter_hessian(values, pattern.slots(e), static_cast<int>(elements[e].size()),
                        node_major_blocks(blocks[static_cast<size_t>(e)]));
    });
    return H;
  };
  const SparseMatrix serial = assemble(1);
  for (int threads : {0, 2, 3}) {
    const SparseMatrix parallel = assemble(threads);
    EXPECT_EQ(std::memcmp(serial.valuePtr(), parallel.valuePtr(),
                          sizeof(double) * static_cast<size_t>(serial.nonZeros())), 0)
        << threads << " threads";
  }
  EXPECT_LT((Eigen::MatrixXd(serial) - dense_sum(num_nodes, elements, blocks)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(ParallelRunner, RangesCoverEveryIndexOnceAndPrivateCopiesSum) {
  for (int threads : {1, 2}) {
    const ParallelRunner runner(threads);
    const int n = 5000;
    std::vector<std::atomic<int>> visits(static_cast<size_t>(n));
    runner.for_each_range(n, 64, 1024, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) ++visits[static_cast<size_t>(i)];
    });
    for (const auto& v : visits) ASSERT_EQ(v.load(), 1);
    std::vector<double> target(10, 1.0);
    runner.run_with_private_copies(n, {{target.data(), target.size()}},
                                   [&](int begin, int end, double* const* outputs) {
                                     for (int i = begin; i < end; ++i) outputs[0][i % 10] += 1.0;
                                   });
    for (double t : target) EXPECT_EQ(t, 1.0 + n / 10) << threads << " threads";
  }
}

TEST(NodalGravity, EnergyGradientDensityColumnAndLumpedMass) {
  const Eigen::VectorXd area = Eigen::VectorXd::LinSpaced(5, 1e-4, 5e-4);  // m²
  const Eigen::VectorXd q = Eigen::VectorXd::Random(15);
  const Eigen::Vector3d g(0.5, -1.0, -9.81);
  const double rho = 0.3;  // kg/m²
  Eigen::VectorXd gradient = Eigen::VectorXd::Zero(15);
  const double E = subtract_gravity(area, rho, g, q, 2.0, &gradient);
  double expected = 2.0;
  for (int i = 0; i < 5; ++i) {
    expected -= rho * area[i] * g.dot(q.segment<3>(3 * i));
    EXPECT_LT((gradient.segment<3>(3 * i) + rho * area[i] * g).norm(), 1e-15);
  }
  EXPECT_NEAR(E, expected, 1e-15);
  EXPECT_EQ(subtract_gravity(area, rho, Eigen::Vector3d::Zero(), q, 2.0, nullptr), 2.0);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(15, 3);
  subtract_gravity_density_column(area, g, 1, &J);
  EXPECT_LT((J.col(1) - gradient / rho).norm(), 1e-15);  // ∂g/∂ρ_A = g/ρ_A (linear in ρ_A)
  const Eigen::VectorXd mass = lumped_mass(area, rho);
  for (int i = 0; i < 15; ++i) EXPECT_EQ(mass[i], rho * area[i / 3]);
}

TEST(ElementScratch, ProductsIntoScratchAreBitwiseThoseIntoTemporaries) {
  // The triangle shell's face Hessian 2 Yᵀ (S Y) for several stencil sizes, once through
  // temporaries and once through one reused scratch set (largest size first, then smaller).
  ScratchMatrix SY_storage, H_storage;
  for (int n : {12, 4, 7, 10}) {
    const Eigen::MatrixXd Y = Eigen::MatrixXd::Random(3, 3 * n);
    const Eigen::MatrixXd S = Eigen::MatrixXd::Random(3, 3);
    const Eigen::MatrixXd reference = 2.0 * Y.transpose() * (S * Y);
    auto SY = SY_storage(3, 3 * n);
    SY.noalias() = S * Y;
    auto H = H_storage(3 * n, 3 * n);
    H.noalias() = 2.0 * Y.transpose() * SY;
    EXPECT_EQ(std::memcmp(H.data(), reference.data(), sizeof(double) * static_cast<size_t>(H.size())), 0) << n;
  }
}

}  // namespace
}  // namespace twill
