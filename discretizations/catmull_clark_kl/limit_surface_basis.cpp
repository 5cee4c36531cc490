#include "discretizations/catmull_clark_kl/limit_surface_basis.hpp"

#include <opensubdiv/far/patchMap.h>
#include <opensubdiv/far/patchTable.h>
#include <opensubdiv/far/patchTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace twill {

namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

struct LimitSurfaceBasis::Impl {
  std::unique_ptr<Far::PatchTable> table;
  std::vector<Far::PatchTable::PatchHandle> face_patch;  // one regular patch per base face
};

namespace {

// Adaptive (not uniform) refinement: only its patch tables carry second derivatives. On a
// regular grid nothing needs isolating, so every patch stays at the base level.
constexpr int kIsolationLevel = 2;
// A patch evaluated at a face corner must give the corner's node on the integer grid within
// this (round-off of a partition of unity with weights of order 1).
constexpr double kCornerTolerance = 1e-12;

[[noreturn]] void invariant_failed(const std::string& what) {
  throw std::logic_error("LimitSurfaceBasis: " + what);
}

// OpenSubdiv's refiner of the grid's quads (Catmull–Clark, boundary edges and corners sharp).
std::unique_ptr<Far::TopologyRefiner> grid_refiner(const LimitSurfaceBasis& grid) {
  std::vector<int> vertices_per_face(static_cast<size_t>(grid.num_faces()), 4);
  std::vector<int> face_vertices;
  face_vertices.reserve(4 * static_cast<size_t>(grid.num_faces()));
  for (int j = 0; j < grid.cells_across(); ++j)
    for (int i = 0; i < grid.cells_along(); ++i)  // counter-clockwise seen from +z: normal +z
      for (int corner : {grid.node_index(i, j), grid.node_index(i + 1, j), grid.node_index(i + 1, j + 1),
                         grid.node_index(i, j + 1)})
        face_vertices.push_back(corner);

  Far::TopologyDescriptor descriptor;
  descriptor.numVertices = grid.num_nodes();
  descriptor.numFaces = grid.num_faces();
  descriptor.numVertsPerFace = vertices_per_face.data();
  descriptor.vertIndicesPerFace = face_vertices.data();

  Sdc::Options sdc_options;
  sdc_options.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_AND_CORNER);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> refiner(
      Factory::Create(descriptor, Factory::Options(Sdc::SCHEME_CATMARK, sdc_options)));
  if (!refiner) invariant_failed("OpenSubdiv could not build the topology of the grid");
  return refiner;
}

std::unique_ptr<Far::PatchTable> patch_table(Far::TopologyRefiner& refiner) {
  refiner.RefineAdaptive(Far::TopologyRefiner::AdaptiveOptions(kIsolationLevel));
  Far::PatchTableFactory::Options patch_options(kIsolationLevel);
  patch_options.SetPatchPrecision<double>();
  patch_options.SetEndCapType(Far::PatchTableFactory::Options::ENDCAP_BSPLINE_BASIS);
  std::unique_ptr<Far::PatchTable> table(Far::PatchTableFactory::Create(refiner, patch_options));
  if (!table) invariant_failed("OpenSubdiv could not build the patch table");
  return table;
}

// Every patch must be a regular B-spline patch of one base face on base control points.
void check_base_level_patches(const Far::PatchTable& table, const LimitSurfaceBasis& grid) {
  if (table.GetNumPatchesTotal() != grid.num_faces())
    invariant_failed(std::to_string(table.GetNumPatchesTotal()) + " patches for " + std::to_string(grid.num_faces()) +
                     " faces (a face was refined)");
  std::vector<bool> seen(static_cast<size_t>(grid.num_faces()), false);
  for (int array = 0; array < table.GetNumPatchArrays(); ++array) {
    const Far::PatchDescriptor descriptor_of_array = table.GetPatchArrayDescriptor(array);
    if (descriptor_of_array.GetType() != Far::PatchDescriptor::REGULAR)
      invariant_failed("patch array " + std::to_string(array) + " has type " +
                       std::to_string(static_cast<int>(descriptor_of_array.GetType())) + ", expected REGULAR");
    for (int patch = 0; patch < table.GetNumPatches(array); ++patch) {
      const Far::PatchParam param = table.GetPatchParam(array, patch);
      const int face = param.GetFaceId();
      if (!param.IsRegular() || param.GetDepth() != 0 || face < 0 || face >= grid.num_faces() ||
          seen[static_cast<size_t>(face)])
        invariant_failed("patch " + std::to_string(patch) + " of face " + std::to_string(face) +
                         " is not a single regular base-level patch");
      seen[static_cast<size_t>(face)] = true;
      const Far::ConstIndexArray cvs = table.GetPatchVertices(array, patch);
      if (cvs.size() != 16) invariant_failed("patch with " + std::to_string(cvs.size()) + " points");
      for (int k = 0; k < 16; ++k)
        if (cvs[k] < 0 || cvs[k] >= grid.num_nodes())
          invariant_failed("patch of face " + std::to_string(face) + " uses a refined or local point " +
                           std::to_string(cvs[k]));
    }
  }
}

std::vector<Far::PatchTable::PatchHandle> face_patches(const Far::PatchTable& table, int num_faces) {
  std::vector<Far::PatchTable::PatchHandle> out(static_cast<size_t>(num_faces));
  Far::PatchMap map(table);
  for (int face = 0; face < num_faces; ++face) {
    const Far::PatchTable::PatchHandle* handle = map.FindPatch(face, 0.5, 0.5);
    if (!handle) invariant_failed("no patch for face " + std::to_string(face));
    out[static_cast<size_t>(face)] = *handle;
  }
  return out;
}

// The documented (u, v) orientation: evaluated at the corners on the integer node grid, the
// patch must give the face's corner nodes (exactly, up to round-off).
void check_corner_orientation(const LimitSurfaceBasis& grid) {
  const int row = grid.cells_along() + 1;
  for (int face = 0; face < grid.num_faces(); ++face) {
    const int i = face % grid.cells_along(), j = face / grid.cells_along();
    const double corners[3][4] = {{0, 0, 0, 0}, {1, 0, 1, 0}, {0, 1, 0, 1}};
    for (const auto& c : corners) {
      const PatchBasis basis = grid.evaluate(face, c[0], c[1]);
      double gi = 0, gj = 0;
      for (int k = 0; k < 16; ++k) {
        gi += basis.weights(0, k) * (basis.nodes[static_cast<size_t>(k)] % row);
        gj += basis.weights(0, k) * (basis.nodes[static_cast<size_t>(k)] / row);
      }
      if (std::abs(gi - (i + c[2])) > kCornerTolerance || std::abs(gj - (j + c[3])) > kCornerTolerance) {
        std::ostringstream message;
        message << "face " << face << " at (u, v) = (" << c[0] << ", " << c[1] << ") evaluates to grid point (" << gi
                << ", " << gj << "), expected (" << i + c[2] << ", " << j + c[3] << ")";
        invariant_failed(message.str());
      }
    }
  }
}

}  // namespace

LimitSurfaceBasis::LimitSurfaceBasis(int cells_along, int cells_across)
    : cells_along_(cells_along), cells_across_(cells_across), impl_(std::make_unique<Impl>()) {
  if (cells_along < 1 || cells_across < 1)
    throw std::invalid_argument("LimitSurfaceBasis: needs at least one cell each way, got " +
                                std::to_string(cells_along) + " x " + std::to_string(cells_across));
  const std::unique_ptr<Far::TopologyRefiner> refiner = grid_refiner(*this);
  impl_->table = patch_table(*refiner);
  check_base_level_patches(*impl_->table, *this);
  impl_->face_patch = face_patches(*impl_->table, num_faces());
  check_corner_orientation(*this);
}

LimitSurfaceBasis::~LimitSurfaceBasis() = default;

PatchBasis LimitSurfaceBasis::evaluate(int face, double u, double v) const {
  if (face < 0 || face >= num_faces())
    throw std::out_of_range("LimitSurfaceBasis::evaluate: face " + std::to_string(face) +
                            " of " + std::to_string(num_faces()));
  const Far::PatchTable& table = *impl_->table;
  const Far::PatchTable::PatchHandle& handle = impl_->face_patch[static_cast<size_t>(face)];
  double w[6][16];
  table.EvaluateBasis(handle, u, v, w[0], w[1], w[2], w[3], w[5], w[4]);  // Duv → row 5
  PatchBasis basis;
  const Far::ConstIndexArray cvs = table.GetPatchVertices(handle);
  for (int k = 0; k < 16; ++k) {
    basis.nodes[static_cast<size_t>(k)] = cvs[k];
    for (int row = 0; row < 6; ++row) basis.weights(row, k) = w[row][k];
  }
  return basis;
}

}  // namespace twill
