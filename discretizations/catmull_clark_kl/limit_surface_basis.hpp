#pragma once
// The Catmull–Clark limit surface of a regular rectangular control grid, through OpenSubdiv
// Far (the OpenSubdiv part of the Catmull–Clark Kirchhoff–Love shell; paper §2 and §6.3,
// docs/catmull_clark_kl.md §1).
//
// Grid: (cells_along + 1) × (cells_across + 1) control points (nodes). Node (i, j), i along
// the strip (x), j across it (y), has index j·(cells_along + 1) + i; face (i, j) has corners
// (i, j), (i+1, j), (i+1, j+1), (i, j+1) and index j·cells_along + i.
//
// Boundary rule: VTX_BOUNDARY_EDGE_AND_CORNER (boundary edges and valence-2 corners are
// infinitely sharp). Then every face of the grid, including boundary and corner faces, is one
// *regular bicubic B-spline patch* (the boundary ones with linearly extrapolated phantom
// points), so the limit surface reproduces affine maps exactly: the limit surface of a flat
// uniform grid is exactly its rectangle, and a boundary curve depends only on the control
// points of that boundary row. A rectangular grid has no extraordinary vertices, so no
// Gregory or end-cap patch ever appears; the constructor checks this (every patch REGULAR,
// at depth 0, on base-level control points) and throws std::logic_error otherwise.
//
// The basis comes from Far::PatchTable::EvaluateBasis in double precision on an adaptively
// refined table (uniform tables have no second derivatives; ../shared/docs/build-notes.md).
#include <Eigen/Core>
#include <array>
#include <memory>

namespace twill {

/// Weights of the 16 control points of one face's bicubic patch at a parametric point
/// (u, v) ∈ [0, 1]² and their parametric derivatives: x(u, v) = Σ_k weights(0, k) x_nodes[k].
struct PatchBasis {
  /// Control-point indices. On boundary faces, the slots of the (eliminated) phantom points
  /// repeat some node with weight 0 in every row, so scatter-adding over all 16 is exact.
  std::array<int, 16> nodes{};
  /// Rows: N, ∂N/∂u, ∂N/∂v, ∂²N/∂u², ∂²N/∂v², ∂²N/∂u∂v. Rows 1–5 are in the order of the
  /// surface jet (a1, a2, x,11, x,22, x,12) of kirchhoff_love_kernel.hpp.
  Eigen::Matrix<double, 6, 16> weights = Eigen::Matrix<double, 6, 16>::Zero();
};

class LimitSurfaceBasis {
 public:
  /// Builds the refiner and patch table once (cells_along, cells_across ≥ 1; throws
  /// std::invalid_argument otherwise).
  LimitSurfaceBasis(int cells_along, int cells_across);
  ~LimitSurfaceBasis();
  LimitSurfaceBasis(const LimitSurfaceBasis&) = delete;
  LimitSurfaceBasis& operator=(const LimitSurfaceBasis&) = delete;

  int cells_along() const { return cells_along_; }
  int cells_across() const { return cells_across_; }
  int num_nodes() const { return (cells_along_ + 1) * (cells_across_ + 1); }
  int num_faces() const { return cells_along_ * cells_across_; }
  int node_index(int i_along, int j_across) const { return j_across * (cells_along_ + 1) + i_along; }
  int face_index(int i_along, int j_across) const { return j_across * cells_along_ + i_along; }

  /// Basis of face `face` at (u, v) ∈ [0, 1]²: (0, 0) is the face's node (i, j), u runs
  /// towards node (i+1, j) and v towards node (i, j+1). Derivatives are per unit of u, v.
  PatchBasis evaluate(int face, double u, double v) const;

 private:
  struct Impl;
  int cells_along_ = 0, cells_across_ = 0;
  std::unique_ptr<Impl> impl_;
};

}  // namespace twill
