#pragma once
// The Hessian sparsity pattern of a mesh and, per assembly element, where its dense block
// lands (written once for every discretisation; IPC Toolkit style: the topology-dependent
// work is done once per mesh, never inside the Newton loop).
//
// Dofs are 3 per node, q = [x0 y0 z0 x1 …] (core/discretization.hpp). The pattern holds a
// full 3 × 3 block (n_a, n_b) for every ordered pair of nodes of some element, both
// triangles, in compressed column storage with sorted row indices: column 3 b + s lists the
// rows 3 a, 3 a + 1, 3 a + 2 of every node a coupled to b, in increasing a.
//
// Slot table of element e with nodes n_0 … n_{m−1}: m² · 3 value indices; entry
// (a m + b) 3 + s is the index of (3 n_a, 3 n_b + s) in the value array, and rows 3 n_a + 1,
// + 2 follow it directly. scatter_hessian() (block_scatter.hpp) adds a local block through it.
#include <Eigen/SparseCore>
#include <cstddef>
#include <vector>

#include "core/discretization.hpp"
#include "discretizations/assembly/element_nodes.hpp"

namespace twill {

class HessianPattern {
 public:
  HessianPattern() = default;
  /// Pattern of `elements` over `num_nodes` nodes, and every element's slot table.
  HessianPattern(int num_nodes, const ElementNodes& elements);

  int num_dofs() const { return static_cast<int>(outer_.size()) - 1; }
  std::size_t num_nonzeros() const { return inner_.size(); }
  /// Slot table of `element` (layout above).
  const int* slots(int element) const {
    return slots_.data() + slot_start_[static_cast<std::size_t>(element)];
  }

  /// Gives `hessian` this pattern with zero values and returns its value array. A matrix that
  /// has the pattern already (from an earlier call) keeps its storage: no allocation.
  double* prepare(SparseMatrix* hessian) const;
  /// The pattern as a matrix with zero values.
  SparseMatrix matrix() const;

  /// Bytes held (pattern and slot tables).
  std::size_t bytes() const;

 private:
  std::vector<int> outer_ = {0}, inner_;
  std::vector<int> slots_;
  std::vector<std::size_t> slot_start_;  // per element, into slots_
};

}  // namespace twill
