#pragma once
// A conflict-free schedule of assembly elements: the order in which elements may add their
// blocks into shared arrays (gradient, Hessian values, ∂g/∂k) from several threads without
// write collisions, and so that every entry receives its contributions in the same order for
// any thread count (bitwise-deterministic results). ParallelRunner::run executes it.
//
// Phases run one after another. A phase is a list of groups; groups of one phase share no
// node, so they run concurrently; the elements of a group run one after another in their
// order. Two ways to build one:
//   greedy colouring   a phase per colour, every element its own group (Catmull–Clark faces);
//   alternating slabs  slabs of cell columns at least as wide as the widest element: the even
//                      slabs, then the odd ones (the triangle shell's elements).
#include <cstddef>
#include <span>
#include <vector>

#include "discretizations/assembly/element_nodes.hpp"

namespace twill {

class ElementSchedule {
 public:
  /// Appends a phase; groups in it must share no node (conflict_free() checks).
  void add_phase(const std::vector<std::vector<int>>& groups);

  /// Greedy colouring of `elements`: each takes the lowest colour that none of its nodes has
  /// seen yet; one phase per colour, one group per element. Throws std::logic_error beyond 64
  /// colours.
  static ElementSchedule colouring(const ElementNodes& elements, int num_nodes);
  /// Slabs whose members of equal parity share no node: the even slabs as one phase, then the
  /// odd ones, each slab a group.
  static ElementSchedule alternating(const std::vector<std::vector<int>>& slabs);

  int num_phases() const { return static_cast<int>(phases_.size()); }
  int num_groups(int phase) const {
    return static_cast<int>(phases_[static_cast<std::size_t>(phase)].group_start.size()) - 1;
  }
  /// Elements of groups [first, last) of `phase`, in their order (contiguous).
  std::span<const int> groups(int phase, int first, int last) const;
  /// Every element id once (in phase, group, member order).
  std::vector<int> elements() const;

  /// True when no two groups of one phase share a node of `nodes` (element id → node list).
  bool conflict_free(const ElementNodes& nodes, int num_nodes) const;
  std::size_t bytes() const;

 private:
  struct Phase {
    std::vector<int> elements;
    std::vector<int> group_start = {0};
  };
  std::vector<Phase> phases_;
};

}  // namespace twill
