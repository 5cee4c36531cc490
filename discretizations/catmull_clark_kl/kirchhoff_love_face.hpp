#pragma once
// One face of the Catmull–Clark Kirchhoff–Love shell: its Gauss points summed, with the exact
// local gradient, Hessian and parameter Jacobian in the face's 16 control points
// (docs/catmull_clark_kl.md §4 and §12). Written once, used by every assembly of
// catmull_clark_kl.cpp; the per-point maths is kirchhoff_love_kernel.hpp.
//
// Local dof layout: component-major, index 16 c + k for component c ∈ {x, y, z} of the face's
// control point k; the jet of a point is y = (D ⊗ I₃) x with D the 5 × 16 derivative rows of the
// basis (rows 1–5 of PatchBasis::weights).
//
// Fibre-strain projection (FibreStrain, an option; the default is decided by measurement in
// docs/catmull_clark_kl.md §12): the fibre stretches Ẽ11, Ẽ22 of the mid-surface are replaced
// at every Gauss point of the face by their L² projection (area-weighted over the face's Gauss
// points) onto a small polynomial space in the face parameters (u, v): constants (FaceMean),
// {1, u, v} (FaceLinear) or {1, u, v, uv} (FaceBilinear). This is a selective B-bar method
// (Hughes 1980; Elguedj et al. 2008 for splines) applied to the two stiff fibre strains in the
// material frame; the shear Ẽ12 and the bending strain keep their pointwise values. The energy
// stays a function of the control points, so its gradient, Hessian and ∂g/∂k are exact
// derivatives of it. Constants are in every space, so uniform strain is still exact.
#include <Eigen/Core>
#include <array>
#include <string>
#include <utility>

#include "core/material_law.hpp"
#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"
#include "discretizations/catmull_clark_kl/kirchhoff_love_kernel.hpp"

namespace twill {

/// How the membrane fibre stretches enter the energy at the Gauss points of a face.
enum class FibreStrain {
  Pointwise,     ///< every Gauss point its own strain (paper §6.3)
  FaceMean,      ///< Ẽ11, Ẽ22 projected onto constants per face (1 mode)
  FaceLinear,    ///< ... onto {1, u, v} per face (3 modes)
  FaceBilinear,  ///< ... onto {1, u, v, uv} per face (4 modes)
};

/// Modes of the projection space (0 for Pointwise: no projection).
int projection_modes(FibreStrain fibre_strain);
/// Every treatment with its option name, in enum order: the one list the option schema, the
/// parser and the tests use.
const std::array<std::pair<FibreStrain, const char*>, 4>& fibre_strain_names();
/// The treatment called `name`; throws std::invalid_argument naming the known ones.
FibreStrain fibre_strain_from_name(const std::string& name);
const char* fibre_strain_name(FibreStrain fibre_strain);

using FaceCoordinates = Eigen::Matrix<double, 16, 3>;  ///< row k: control point k [m]
using JetBasis = Eigen::Matrix<double, 16, 5>;         ///< Dᵀ: column r = jet row r's weights
using Matrix16 = Eigen::Matrix<double, 16, 16>;
/// Upper component blocks (a, b), a ≤ b, of the 48 × 48 local Hessian, in the order
/// (0,0), (0,1), (0,2), (1,1), (1,2), (2,2) (face_block_index).
using FaceHessianBlocks = std::array<Matrix16, 6>;
/// ∂(local gradient)/∂k: row 16 c + k, one column per model parameter.
using FaceParameterJacobian = Eigen::Matrix<double, 48, Eigen::Dynamic>;

constexpr int face_block_index(int a, int b) { return a == 0 ? b : (a == 1 ? 2 + b : 5); }

/// Surface jet y = (a1, a2, x,11, x,22, x,12) of a point from its Dᵀ and the face's control
/// points. The rest data are computed by this same function, so that the rest state has
/// ε = κ = 0 bit for bit.
SurfaceJet face_jet(const JetBasis& Dt, const FaceCoordinates& X);

/// What a face needs besides its control points; the pointers address points_per_face entries.
struct FaceQuadrature {
  int points_per_face = 0;
  const JetBasis* jet_basis = nullptr;          ///< per point, Dᵀ (16 × 5)
  const ReferencePoint* reference = nullptr;    ///< per point
  const Eigen::Vector2d* gauss_uv = nullptr;    ///< per point, (u, v) in [0, 1]² of the face
  FibreStrain fibre_strain = FibreStrain::Pointwise;
};

/// Elastic energy of one face [J] at control points X; optional local gradient (16 × 3, row k =
/// node k) [N] and upper Hessian blocks [N/m] (each set, not added). points_per_face ≤ 256.
double kirchhoff_love_face(const MaterialLaw& law, double thickness_m,
                           const GaussLegendreRule& rule, const FaceQuadrature& face,
                           const FaceCoordinates& X, FaceCoordinates* gradient,
                           FaceHessianBlocks* hessian);

/// The orthotropic strains (e_m, e_b) every Gauss point of the face hands to the law, i.e. with
/// the fibre-strain projection applied; `strains` addresses points_per_face entries.
void kirchhoff_love_face_strains(const FaceQuadrature& face, const FaceCoordinates& X,
                                 Vector6* strains);

/// ∂(local gradient)/∂k of one face (48 × num_parameters, rows 16 c + k). Resized.
void kirchhoff_love_face_parameter_jacobian(const MaterialLaw& law, double thickness_m,
                                            const GaussLegendreRule& rule,
                                            const FaceQuadrature& face, const FaceCoordinates& X,
                                            FaceParameterJacobian* dgradient_dk);

}  // namespace twill
