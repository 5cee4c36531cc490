#pragma once
// Discrete-shell hinge bending (Grinspun, Hirani, Desbrun & Schröder 2003, "Discrete
// shells"), made orthotropic by a per-hinge-class stiffness derived from the law's
// small-strain stiffnesses (docs/triangle_shell.md §3–4).
//
// Hinge energy, flat rest state (θ̄ = 0):
//     W_e = k_c(e) · g_e · θ_e²,     g_e = |ē|² / Ā_e,   Ā_e = (Ā1 + Ā2)/3        [J]
// with |ē| the reference edge length and Ā1, Ā2 the reference areas of its two triangles
// (Grinspun et al.'s |ē|/h̄_e with h̄_e a sixth of the summed heights), θ_e the dihedral
// angle and k_c [J] the stiffness of the hinge's class c.
//
// Orthotropy: for a small uniform curvature K (2×2, reference frame), θ_e ≈ ℓ_e : K, with
// ℓ_e the hinge's "mode" fixed by its reference stencil (hinge_reference()). The hinges of a
// strip pattern fall into a few classes of equal mode (three for each regular pattern). The
// class stiffnesses are solved so that the homogenised hinge energy of a cylinder,
// Σ_c k_c (vec K)ᵀ S_c (vec K) per unit area, equals the Kirchhoff–Love bending energy
//     W_b = τ³/24 · ẽᵀ C ẽ,   ẽ = (K̃11, K̃22, K̃12),   C = ∂²ψ/∂ẽ²(0)
// (model.md §6: a11, a12, a22 and 2·G12 on the diagonal, since ψ has G12·Ẽ12²) for a
// cylinder bent along warp, along weft and at 45° between them (HingeCalibration).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/material_law.hpp"
#include "core/parameters.hpp"

namespace twill {

struct StripTriangulation;
struct Hinge;

using Vector12 = Eigen::Matrix<double, 12, 1>;
using Matrix12 = Eigen::Matrix<double, 12, 12>;

/// Signed dihedral angle θ ∈ (−π, π] of the hinge with edge x0→x1, triangle A = (x0, x1, x2)
/// and triangle B = (x1, x0, x3): θ = atan2((nA × nB)·ê, nA·nB), nA = (x1−x0)×(x2−x0),
/// nB = (x3−x0)×(x1−x0), ê = (x1−x0)/|x1−x0|. θ = 0 when flat; θ < 0 when the apexes x2, x3
/// lie on the side of the common normal (a valley seen from +n). atan2 keeps it accurate for
/// every angle (no acos near 0 or π).
/// Optional gradient (12, stacked x0 x1 x2 x3) and Hessian (12×12, symmetric): the exact
/// derivatives, in the form of Bridson, Marino & Fedkiw 2003 (gradient) and Tamstorf &
/// Grinspun 2013 "Discrete bending forces and their Jacobians" (Hessian), written as
///   ∂θ/∂x2 = −|e| nA/|nA|²,  ∂θ/∂x3 = −|e| nB/|nB|²,
///   ∂θ/∂x0 = ((x1−x2)·ê) nA/|nA|² + ((x1−x3)·ê) nB/|nB|²,
///   ∂θ/∂x1 = ((x2−x0)·ê) nA/|nA|² + ((x3−x0)·ê) nB/|nB|²,
/// and differentiated once more term by term (docs/triangle_shell.md §3).
double dihedral_angle(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                      const Eigen::Vector3d& x2, const Eigen::Vector3d& x3,
                      Vector12* gradient = nullptr, Matrix12* hessian = nullptr);

/// Reference data of one hinge from its flat stencil X0…X3 (same order as dihedral_angle).
struct HingeReference {
  double weight = 0;  ///< g_e = |ē|²/Ā_e (dimensionless)
  /// ℓ_e as the 3-vector (ℓ11, ℓ22, √2·ℓ12) [m], so θ_e ≈ mode · vec(K) with
  /// vec(K) = (K11, K22, √2·K12) for a small uniform curvature K [1/m] (Frobenius-isometric).
  Eigen::Vector3d mode = Eigen::Vector3d::Zero();
};
HingeReference hinge_reference(const Eigen::Vector2d& X0, const Eigen::Vector2d& X1,
                               const Eigen::Vector2d& X2, const Eigen::Vector2d& X3);
/// The same for hinge `h` at the planar positions `xy` (#V × 2).
HingeReference hinge_reference(const Eigen::Matrix<double, Eigen::Dynamic, 2>& xy, const Hinge& h);

/// Every bending model of the triangle shell depends on the material through the five
/// parameters (a11, a12, a22, G12, τ): the columns of their derivatives, in this order.
inline constexpr int kBendingParameters = 5;
/// ∂(a11', a12', a22', G12', τ')/∂k: the bending models' columns in the flat vector.
using BendingParameterChain = Eigen::Matrix<double, kBendingParameters, Eigen::Dynamic>;

/// The material the bending models see: C = ∂²ψ/∂ẽ²(0) scaled to S C S by the law-side
/// bending ratios (core/bending_scale.hpp, the same S the Catmull–Clark shell applies to e_b;
/// docs/effects/bending-anisotropy.md), i.e. with C_ij scaled by s_i s_j:
///     a11' = b_w a11,  a12' = √(b_w b_f) a12,  a22' = b_f a22,  G12' = √(b_w b_f) G12,  τ' = τ,
/// the law's parameters otherwise (ratios 1: they are in the stiffnesses). `chain` (optional) receives ∂(a11', a12', a22', G12', τ')/∂k
/// (5 × law.num_parameters()). Ratios 1: the law's own parameters, the chain picks their columns.
MaterialParameters bending_parameters(const MaterialLaw& law, BendingParameterChain* chain);

/// Number of calibration cylinders and their order: bending along warp d1, along weft d2,
/// along (d1 + d2)/√2 and along (d1 − d2)/√2 ("along u": the curvature is u⊗u/R).
inline constexpr int kCalibrationCylinders = 4;
std::vector<std::string> calibration_cylinder_names();  // "warp", "weft", "+45", "-45"

/// Kirchhoff–Love bending energy per unit area of a cylinder at unit curvature, τ³/24 ẽᵀCẽ
/// [J/m² · m²], for its orthotropic curvature ẽ = (ũ1², ũ2², ũ1ũ2) (u the bending direction,
/// ũ its warp/weft components), and optionally its derivative in (a11, a12, a22, G12, τ).
double kirchhoff_love_cylinder_energy(const MaterialParameters& p, const Eigen::Vector3d& e,
                                      Eigen::Matrix<double, 1, 5>* derivative = nullptr);

/// Class stiffnesses and their derivatives (HingeCalibration::solve()).
struct HingeClassStiffness {
  Eigen::VectorXd stiffness;  ///< k_c per class [J]
  /// ∂k_c/∂(a11, a12, a22, G12, τ): #classes × 5 [J/Pa, J/Pa, J/Pa, J/Pa, J/m].
  Eigen::Matrix<double, Eigen::Dynamic, 5> derivative;
  /// true: warp, weft and one of ±45° are matched exactly (in the continuum limit);
  /// false: the pattern cannot, and the stiffnesses are the non-negative least-squares fit
  /// of all four cylinders in relative error.
  bool exact = false;
  /// Continuum-limit relative error (hinge − KL)/KL per calibration cylinder.
  Eigen::Vector4d relative_error = Eigen::Vector4d::Zero();
};

/// The homogenised hinge response of a mesh pattern and the solve for k_c.
///
/// class_response[c] = S_c: hinge energy per unit area of class c per unit stiffness as a
/// quadratic form in vec(K) (3×3) [1/m² · m² = dimensionless per m² of K]: a class with n_c
/// hinges per cell of area A_cell has S_c = n_c/A_cell · mean_{e∈c} g_e ℓ_e ℓ_eᵀ.
/// `angle_deg` is the strip's material angle (core/discretization.hpp).
class HingeCalibration {
 public:
  HingeCalibration(std::vector<Eigen::Matrix3d> class_response, double angle_deg);

  int num_classes() const { return static_cast<int>(response_.size()); }
  /// Kirchhoff–Love energy per unit area of each calibration cylinder at unit curvature,
  /// τ³/24 ẽᵀCẽ [J/m² · m²], and its derivatives in (a11, a12, a22, G12, τ) (4 × 5).
  Eigen::Vector4d kirchhoff_love_targets(const MaterialParameters& p,
                                         Eigen::Matrix<double, 4, 5>* derivative) const;
  /// Hinge energy per unit area of each calibration cylinder at unit curvature per unit
  /// class stiffness (4 × #classes).
  const Eigen::MatrixXd& cylinder_response() const { return cylinder_response_; }
  /// Solves for the class stiffnesses (see HingeClassStiffness).
  HingeClassStiffness solve(const MaterialParameters& p) const;

 private:
  std::vector<Eigen::Matrix3d> response_;
  Eigen::Matrix<double, 4, 3> cylinder_strain_;  ///< per cylinder ẽ = (ũ1², ũ2², ũ1ũ2)
  Eigen::MatrixXd cylinder_response_;            ///< 4 × #classes
};

/// The hinges of a strip triangulation grouped by mode, with each class's homogenised
/// response S_c (the input of HingeCalibration).
struct HingeClasses {
  std::vector<int> class_of_hinge;        ///< per hinge of the triangulation
  std::vector<Eigen::Matrix3d> response;  ///< S_c per class
  std::vector<int> hinges_per_cell;       ///< n_c: class-c hinges per cell of the pattern
  std::vector<double> density;            ///< n_c/A_cell: class-c hinges per unit area [1/m²]
};

/// Classes are the distinct modes (up to sign) of the *unperturbed* pattern (base_xy); the
/// hinge density n_c/A_cell comes from a 4 × 4-cell patch of that pattern (every pattern has
/// period ≤ 2 cells), and the mean of g_e ℓ_e ℓ_eᵀ is taken over the hinges of the actual
/// reference mesh, so for the irregular pattern S_c is the homogenised response of the
/// perturbed hinges (docs/triangle_shell.md §4).
HingeClasses classify_hinges(const StripTriangulation& triangulation);

/// Per-hinge stiffnesses k_e of the active bending model and their derivatives.
struct HingeStiffness {
  Eigen::VectorXd per_hinge;  ///< k_e [J], in triangulation().hinges order
  /// ∂k_e/∂(a11, a12, a22, G12, τ): #hinges × 5 [J/Pa, J/Pa, J/Pa, J/Pa, J/m].
  Eigen::Matrix<double, Eigen::Dynamic, 5> derivative;
  /// Continuum-limit relative error (hinge − KL)/KL per calibration cylinder (warp, weft,
  /// +45, −45; calibration_cylinder_names()).
  Eigen::Vector4d relative_error = Eigen::Vector4d::Zero();
  /// Directional model: the calibration factor λ and ∂λ/∂(a11, a12, a22, G12, τ); 1 and 0
  /// for the cylinder calibration.
  double scale = 1.0;
  Eigen::Matrix<double, 1, 5> scale_derivative = Eigen::Matrix<double, 1, 5>::Zero();
};

/// Directional plate stiffness for bending with curvature n⊗n (n unit, in-plane):
/// D(n) = τ³/12 · C(n,n,n,n) = τ³/12 · (a11 ñ1⁴ + 2(a12 + G12) ñ1²ñ2² + a22 ñ2⁴), ñ = (n·d1, n·d2)
/// [J]. It is twice the KL energy per area of the unit cylinder n⊗n (kirchhoff_love_cylinder_
/// energy): D(n)/2 = τ³/24 ẽᵀCẽ with ẽ = (ñ1², ñ2², ñ1ñ2). Written as D = τ³/12 · w(n)·P with
/// P = (a11, a12 + G12, a22) and the weights returned here, w = (ñ1⁴, 2ñ1²ñ2², ñ2⁴).
Eigen::Vector3d directional_weights(const Eigen::Vector2d& n, double angle_deg);

/// The directional hinge model (docs/triangle_shell.md §4.6): every hinge gets the plate's
/// bending stiffness across its edge, with Grinspun's weight,
///     k_e = λ · D(n_e)/6,   W_e = k_e g_e θ_e²,
/// n_e the in-plane unit normal of the reference edge (the bending direction a fold along the
/// edge has). D(n)/6 makes a crease along any straight line of hinges cost the KL energy of the
/// cylinder across it spread over the adjacent triangle heights, so no hinge is softer than the
/// plate in its own direction (the cylinder calibration leaves the diagonal hinges of aligned
/// meshes with only a12 + G12, a soft mesh-scale fold mode: §10). λ is one factor per mesh,
/// the least-squares fit in relative error of the warp and weft cylinders' homogenised hinge
/// energy to KL: λ = 1 exactly wherever the hinges across the fibres alone carry those
/// cylinders (alternating, right, left with aligned material). The ±45° cylinders are not
/// fitted: their error is reported in HingeStiffness::relative_error.
class DirectionalHingeModel {
 public:
  DirectionalHingeModel(const StripTriangulation& triangulation, const HingeClasses& classes,
                        double angle_deg);
  HingeStiffness solve(const MaterialParameters& p) const;
  /// w(n_e) per hinge (#hinges × 3).
  const Eigen::Matrix<double, Eigen::Dynamic, 3>& hinge_weights() const { return weights_; }
  /// Homogenised hinge energy per area of each calibration cylinder at unit curvature per unit
  /// λ, as R_j·P τ³/72 (R: 4 × 3), and the KL targets τ³/24 s_j·P (s: 4 × 3).
  const Eigen::Matrix<double, 4, 3>& cylinder_response() const { return response_; }
  const Eigen::Matrix<double, 4, 3>& cylinder_target() const { return target_; }

 private:
  Eigen::Matrix<double, Eigen::Dynamic, 3> weights_;
  Eigen::Matrix<double, 4, 3> response_, target_;
};

}  // namespace twill
