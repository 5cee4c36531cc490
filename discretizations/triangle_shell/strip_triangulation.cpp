#include "discretizations/triangle_shell/strip_triangulation.hpp"

#include <random>
#include <stdexcept>

namespace twill {

namespace {

/// Uniform double in [−1, 1) from 53 random bits: std::uniform_real_distribution is
/// implementation-defined, and a seeded mesh must be the same with every standard library.
double symmetric_unit(std::mt19937_64& rng) {
  const double u = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return 2.0 * u - 1.0;
}

double signed_area(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return 0.5 * ((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
}

// Grid vertex (i, j) of a strip nx cells along.
int grid_vertex(int nx, int i, int j) { return j * (nx + 1) + i; }

// The vertices at rest: the (nx + 1) × (ny + 1) grid, then (cross pattern) the cell centres;
// each with its half-column (2i on grid column i, 2i + 1 at a centre of cell column i).
void place_vertices(const StripSpec& strip, bool cross, StripTriangulation* t) {
  const int nx = t->cells_along, ny = t->cells_across;
  const double hx = t->cell_length_m, hy = t->cell_width_m, y0 = -0.5 * strip.width_m;
  const int num_grid = (nx + 1) * (ny + 1);
  const int num_vertices = num_grid + (cross ? nx * ny : 0);
  t->base_xy.resize(num_vertices, 2);
  t->half_column.resize(static_cast<size_t>(num_vertices));
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      // The last row and column are placed exactly on the far boundary lines (no i·hx
      // round-off), so clamps and point lookups see the strip's exact outline.
      const double x = i == nx ? strip.length_m : i * hx;
      const double y = j == ny ? 0.5 * strip.width_m : y0 + j * hy;
      t->base_xy.row(grid_vertex(nx, i, j)) << x, y;
      t->half_column[static_cast<size_t>(grid_vertex(nx, i, j))] = 2 * i;
    }
  if (cross)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int c = num_grid + j * nx + i;
        t->base_xy.row(c) << (i + 0.5) * hx, y0 + (j + 0.5) * hy;
        t->half_column[static_cast<size_t>(c)] = 2 * i + 1;
      }
}

// The irregular pattern's interior grid vertices moved by up to `perturbation` of a cell each
// way (boundary vertices stay on the outline).
void perturb_interior(double perturbation, std::uint64_t seed, StripTriangulation* t) {
  std::mt19937_64 rng(seed);
  const int nx = t->cells_along, ny = t->cells_across;
  for (int j = 1; j < ny; ++j)
    for (int i = 1; i < nx; ++i) {
      const double dx = symmetric_unit(rng) * perturbation * t->cell_length_m;
      const double dy = symmetric_unit(rng) * perturbation * t->cell_width_m;
      t->reference_xy(grid_vertex(nx, i, j), 0) += dx;
      t->reference_xy(grid_vertex(nx, i, j), 1) += dy;
    }
}

// Each cell's triangles (counter-clockwise): four around its centre (cross), or two split by
// the pattern's diagonal.
std::vector<std::array<int, 3>> cell_triangles(int nx, int ny, TrianglePattern pattern) {
  const bool cross = pattern == TrianglePattern::Cross;
  const int num_grid = (nx + 1) * (ny + 1);
  std::vector<std::array<int, 3>> faces;
  faces.reserve(static_cast<size_t>(nx * ny * (cross ? 4 : 2)));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = grid_vertex(nx, i, j), b = grid_vertex(nx, i + 1, j), c = grid_vertex(nx, i + 1, j + 1),
                d = grid_vertex(nx, i, j + 1);
      if (cross) {
        const int m = num_grid + j * nx + i;
        faces.push_back({a, b, m});
        faces.push_back({b, c, m});
        faces.push_back({c, d, m});
        faces.push_back({d, a, m});
        continue;
      }
      bool slash = true;  // "/" diagonal a–c
      if (pattern == TrianglePattern::Left) slash = false;
      if (pattern == TrianglePattern::Alternating || pattern == TrianglePattern::Irregular)
        slash = (i + j) % 2 == 0;
      if (slash) {
        faces.push_back({a, b, c});
        faces.push_back({a, c, d});
      } else {
        faces.push_back({a, b, d});
        faces.push_back({b, c, d});
      }
    }
  return faces;
}

// The OpenMesh mesh and the face table from the triangles, each checked counter-clockwise.
void build_mesh(const std::vector<std::array<int, 3>>& faces, StripTriangulation* t) {
  const auto num_vertices = static_cast<int>(t->reference_xy.rows());
  t->faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  std::vector<DoubleTriMesh::VertexHandle> vh;
  vh.reserve(static_cast<size_t>(num_vertices));
  for (int v = 0; v < num_vertices; ++v)
    vh.push_back(t->mesh.add_vertex(DoubleTriMesh::Point(t->reference_xy(v, 0), t->reference_xy(v, 1), 0.0)));
  for (size_t f = 0; f < faces.size(); ++f) {
    const auto& tri = faces[f];
    // Perturbations below a quarter cell keep every triangle positively oriented
    // (docs/triangle_shell.md §1); TriangleShellOptions::validate() enforces that bound.
    if (!(signed_area(t->reference_xy.row(tri[0]), t->reference_xy.row(tri[1]), t->reference_xy.row(tri[2])) > 0.0))
      throw std::logic_error("triangulate_strip: a reference triangle is not counter-clockwise");
    t->faces.row(static_cast<Eigen::Index>(f)) << tri[0], tri[1], tri[2];
    t->mesh.add_face(vh[static_cast<size_t>(tri[0])], vh[static_cast<size_t>(tri[1])], vh[static_cast<size_t>(tri[2])]);
  }
}

// Every interior edge's hinge: (x0, x1) the edge, x2 and x3 the apexes on its two sides.
std::vector<Hinge> interior_hinges(const DoubleTriMesh& mesh) {
  std::vector<Hinge> hinges;
  for (const auto eh : mesh.edges()) {
    if (eh.is_boundary()) continue;
    const auto h0 = eh.h0(), h1 = eh.h1();
    Hinge hinge;
    hinge.v = {h0.from().idx(), h0.to().idx(), h0.next().to().idx(), h1.next().to().idx()};
    hinges.push_back(hinge);
  }
  return hinges;
}

}  // namespace

StripTriangulation triangulate_strip(const StripSpec& strip, TrianglePattern pattern,
                                     double perturbation, std::uint64_t seed) {
  StripTriangulation t;
  t.pattern = pattern;
  t.cells_along = strip.cells_along;
  t.cells_across = strip.cells_across;
  t.cell_length_m = strip.length_m / strip.cells_along;
  t.cell_width_m = strip.width_m / strip.cells_across;
  place_vertices(strip, pattern == TrianglePattern::Cross, &t);
  t.reference_xy = t.base_xy;
  if (pattern == TrianglePattern::Irregular && perturbation > 0.0) perturb_interior(perturbation, seed, &t);
  build_mesh(cell_triangles(strip.cells_along, strip.cells_across, pattern), &t);
  t.hinges = interior_hinges(t.mesh);
  return t;
}

}  // namespace twill
