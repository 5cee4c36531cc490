#pragma once
// Triangulations of the reference strip for the triangle shell (docs/triangle_shell.md §1).
//
// The strip x ∈ [0, length_m], y ∈ [−width_m/2, width_m/2] (core/discretization.hpp) is cut
// into cells_along × cells_across rectangular cells of size hx × hy, hx = length/cells_along,
// hy = width/cells_across. Grid vertex (i, j), i = 0…cells_along, j = 0…cells_across, sits at
// (i·hx, −width/2 + j·hy) with index j·(cells_along + 1) + i. Each cell is split by the
// pattern:
//   right        one diagonal per cell from (i, j) to (i+1, j+1)   ("/" for y up)
//   left         one diagonal per cell from (i+1, j) to (i, j+1)   ("\")
//   alternating  "/" where i + j is even, "\" where it is odd (a checkerboard)
//   cross        4 triangles per cell around a centre vertex; centre vertices are numbered
//                after the grid vertices, cell (i, j) → grid count + j·cells_along + i
//   irregular    the alternating pattern with every interior vertex moved by an independent
//                uniform random offset in [−p·hx, p·hx] × [−p·hy, p·hy] (p = perturbation,
//                seeded); boundary vertices stay on the boundary lines, so clamps and the
//                strip's outline are the same as for the regular patterns.
// Triangles are counter-clockwise seen from +z (normals +z in the reference state).
//
// The mesh is an OpenMesh TriMesh with double-precision points (OpenMesh::Vec3d): its
// connectivity gives the hinges (interior edges with their two opposite vertices).
#include <Eigen/Core>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/discretization.hpp"
#include "discretizations/triangle_shell/triangle_pattern.hpp"

namespace twill {

/// OpenMesh traits: double-precision points and normals (the default is float, which would
/// lose ~1e-7 relative accuracy in the rest state).
struct DoubleTriMeshTraits : public OpenMesh::DefaultTraits {
  using Point = OpenMesh::Vec3d;
  using Normal = OpenMesh::Vec3d;
};
using DoubleTriMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTriMeshTraits>;

/// One hinge: the interior edge (v[0], v[1]) and the opposite vertices v[2] (triangle
/// (v0, v1, v2), counter-clockwise) and v[3] (triangle (v1, v0, v3), counter-clockwise).
struct Hinge {
  std::array<int, 4> v{};
};

struct StripTriangulation {
  TrianglePattern pattern = TrianglePattern::Alternating;
  int cells_along = 0, cells_across = 0;
  double cell_length_m = 0, cell_width_m = 0;  ///< hx, hy

  DoubleTriMesh mesh;  ///< reference mesh, z = 0 (perturbed for the irregular pattern)
  /// Reference vertex positions (#V × 2) [m], the same as the mesh points.
  Eigen::Matrix<double, Eigen::Dynamic, 2> reference_xy;
  /// Unperturbed positions (#V × 2): equal to reference_xy except for the irregular pattern.
  Eigen::Matrix<double, Eigen::Dynamic, 2> base_xy;
  Eigen::MatrixXi faces;  ///< #F × 3 vertex indices, counter-clockwise from +z
  std::vector<Hinge> hinges;
  /// Twice the column coordinate of each vertex: 2i for grid vertices of column i, 2i + 1
  /// for the centre vertex of a cell of column i (cross pattern).
  std::vector<int> half_column;

  int num_vertices() const { return static_cast<int>(reference_xy.rows()); }
  int num_faces() const { return static_cast<int>(faces.rows()); }
};

/// Builds the triangulation. `perturbation` and `seed` are used by the irregular pattern
/// only. The strip and perturbation must already be valid (TriangleShellOptions::validate).
StripTriangulation triangulate_strip(const StripSpec& strip, TrianglePattern pattern,
                                     double perturbation, std::uint64_t seed);

}  // namespace twill
