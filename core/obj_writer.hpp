#pragma once
// Wavefront OBJ output of a triangulated surface, for every discretisation's surface_mesh().
//
// Coordinates are written with 17 significant digits ("%.17g"), so a double survives the
// round trip exactly: OpenMesh's OBJ/OFF/PLY writers go through float even for double meshes
// (docs/build-notes.md), which loses ~1e-7 relative and makes a written state unusable for
// restarting a solve. Units are those of V (metres in twill).
#include <Eigen/Core>
#include <string>

namespace twill {

/// Writes `V` (#V × 3 vertex positions) and `F` (#F × 3 zero-based vertex indices; written
/// one-based as OBJ requires) to `path`, replacing the file. Throws InputError (file = path)
/// when the file cannot be written, std::invalid_argument for a face index out of range or
/// arrays of the wrong width.
void write_obj(const std::string& path, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

}  // namespace twill
