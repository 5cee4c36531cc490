#pragma once
// Bending from a per-triangle shape operator built out of hinge angles, with the full
// orthotropic Kirchhoff–Love law applied to it (docs/triangle_shell.md §4.7, §10).
//
// Why not hinges: a sum of squared hinge angles measures one linear functional of the
// curvature per hinge (hinge_bending.hpp), cannot represent the a12·K̃11·K̃22 term or twist,
// and on the alternating mesh a mesh-scale checkerboard cancels the hinges across a bend
// (§10). Here every triangle T gets a curvature tensor
//
//     K_T = (1/Ā_T) Σ_k |ē_k| s_k n_k n_kᵀ                                    (1)
//
// (k: its three edges, n_k the outward unit normal of reference edge k in the plane) from edge
// rotations s_k [rad]: s_k is the normal-slope difference between the surface at the midpoint
// of edge k and the triangle itself; (1) is the divergence theorem (1/Ā)∮ n ⊗ ∇z over T with
// the triangle's own constant slope subtracted. The energy is
//
//     W_T = Ā_T τ³/24 · ẽ_Tᵀ C ẽ_T,   ẽ_T = (K̃11, K̃22, K̃12) = (d1ᵀK_T d1, d2ᵀK_T d2, d1ᵀK_T d2),
//     C = ∂²ψ/∂ẽ²(0) = [[a11, a12, 0], [a12, a22, 0], [0, 0, 2 G12]]                 (2)
//
// (model.md §6), i.e. the law itself, with a12 and twist, not a calibration.
//
// The edge rotations come from the dihedral angles. With φ_e = −θ_e (θ from dihedral_angle(),
// so that φ > 0 where z = ½κx², κ > 0), the two triangles T, T' of an interior edge must share
// it: s_{T,e} + s_{T',e} = φ_e (the slope jump across the edge). Then Σ_T Ā_T K_T telescopes to
// Σ_e |ē| φ_e n_e n_eᵀ, the integrated distributional Hessian of the piecewise-linear surface,
// which for any field that vanishes near the boundary (any mesh-scale mode) is zero: a
// periodic perturbation cannot change the mean curvature, so by Jensen's inequality it cannot
// lower the energy of a uniform bend below ẽᵀCẽ. How φ_e is split must also be *consistent*:
// for z = ½XᵀKX every interior K_T must equal K. Each hinge measures φ_e ≈ μ_e·(Kxx, Kyy, Kxy)
// with a mode μ_e fixed by its stencil (hinge_reference()); a triangle whose three edges are
// hinges ("complete") can therefore solve for K from its own three angles and give the
// consistent split s^c_{T,k} = (Z_T φ_T)_k, Z_T = N_T⁻¹ M_T⁻¹ (M_T: rows μ_e, N_T: columns
// |ē_k|/Ā_T (n_k n_kᵀ) of (1)). For quadratic fields s^c_{T,e} + s^c_{T',e} = φ_e exactly (both
// sides are the slope jump of the linear interpolant). The split used is
//
//     both complete:    s_{T,e} = ½φ_e + ½(s^c_{T,e} − s^c_{T',e})                    (3)
//     only T complete:  s_{T,e} = s^c_{T,e},        s_{T',e} = φ_e − s^c_{T,e}
//     neither:          s_{T,e} = ½φ_e                (inconsistent; corners of tiny meshes)
//
// which shares φ_e exactly (telescoping) and equals s^c for quadratics (consistency): the
// homogenised energy of every periodic mesh, alternating and cross included, is the KL energy
// for every uniform curvature, and no mesh-scale mode lowers it.
//
// Boundary edges. On a clamped end line with a clamp hinge (ghost triangle fixed in the rest
// plane, triangle_shell.hpp), the surface beyond is the flat platform: s_k = φ_b = −θ_b, the
// tilt of the triangle against the platform (exact for clamped quadratics, whose slope at the
// line is zero). On a free edge s_k is not measured: W_T is minimised over it, i.e. the
// moment n_kᵀ M n_k conjugate to that edge's rotation vanishes, the Kirchhoff–Love free-edge
// condition M_nn = 0 (the mid-edge normal left free, as in Grinspun, Gingold, Reisman & Zorin
// 2006, "Computing discrete shape operators on general meshes"). Per triangle this is a Schur
// complement of the 3×3 form: with s = T s_m (T: identity on the measured edges, the
// minimiser −Q_ff⁻¹Q_fm on the free ones),
//
//     W_T = s_mᵀ S_T s_m,   S_T = Tᵀ Q_T T,   Q_T = Ā_T τ³/24 P_Tᵀ C P_T,   ẽ_T = P_T s,   (4)
//
// and by the envelope theorem ∂S_T/∂p = Tᵀ (∂Q_T/∂p) T. S_T ∝ τ³ and is homogeneous of
// degree 1 in C; it needs C positive definite (a11 a22 > a12², G12 > 0).
//
// Geometric nonlinearity enters only through the dihedral angles (rotation invariant, exact
// for any fold); all coefficients are reference-state constants.
#include <Eigen/Core>
#include <array>
#include <vector>

#include "core/parameters.hpp"

namespace twill {

struct StripTriangulation;

/// A boundary edge k = (v_k, v_{k+1}) of face `face` that lies on a clamped end line and is
/// hinged against a ghost triangle fixed in the rest plane.
struct ClampEdge {
  int face = 0;
  int local_edge = 0;
};

/// Parameter-dependent part of ShapeOperatorBending: per face the form S_T of (4) (#measured ×
/// #measured) [J/rad²] and the completion T (3 × #measured) that fills in the free edges.
struct ShapeOperatorStiffness {
  std::vector<Eigen::MatrixXd> form;
  std::vector<Eigen::MatrixXd> completion;
};

class ShapeOperatorBending {
 public:
  /// Reference data of one face (fixed by the mesh).
  struct Face {
    double area = 0;            ///< Ā_T [m²]
    /// Angle ids the face depends on: interior hinge h → h, clamp edge c → #hinges + c.
    std::vector<int> sources;
    std::vector<int> measured;  ///< local edges k whose rotation s_k is measured (not free)
    /// s_measured = edge_map · φ(sources) (#measured × #sources), φ = −θ [rad].
    Eigen::MatrixXd edge_map;
    /// ẽ = curvature_map · s (3 × 3; s over all three edges) [1/m per rad].
    Eigen::Matrix3d curvature_map = Eigen::Matrix3d::Zero();
    bool complete = false;      ///< all three edges are interior hinges (Z_T exists)
  };

  /// `clamp_edges[c]` is the edge of clamp hinge c. `angle_deg` is the strip's material angle
  /// (core/discretization.hpp).
  ShapeOperatorBending(const StripTriangulation& triangulation,
                       const std::vector<ClampEdge>& clamp_edges, double angle_deg);

  int num_hinges() const { return num_hinges_; }
  /// #hinges + #clamp edges: the length of the angle vector φ.
  int num_angles() const { return num_angles_; }
  const std::vector<Face>& faces() const { return faces_; }
  /// Mode of every interior hinge: φ_h ≈ mode_h · (Kxx, Kyy, Kxy) for z = ½ XᵀKX (#hinges × 3).
  const Eigen::Matrix<double, Eigen::Dynamic, 3>& hinge_modes() const { return modes_; }

  /// S_T and T of (4) for every face. Throws std::invalid_argument unless C is positive
  /// definite (a11 > 0, a22 > 0, a11 a22 > a12², G12 > 0).
  ShapeOperatorStiffness solve(const MaterialParameters& p) const;
  /// ∂S_T/∂(a11, a12, a22, G12, τ) of one face, from the stiffness `s` solved at `p`.
  std::array<Eigen::MatrixXd, 5> form_derivative(int face, const MaterialParameters& p,
                                                 const ShapeOperatorStiffness& s) const;
  /// ẽ_T = (K̃11, K̃22, K̃12) [1/m] of every face (#faces × 3) for the angles φ = −θ (per angle
  /// id), free edges at their minimiser.
  Eigen::Matrix<double, Eigen::Dynamic, 3> curvatures(const Eigen::VectorXd& phi,
                                                      const ShapeOperatorStiffness& s) const;

  /// C = ∂²ψ/∂ẽ²(0) of (2) and its derivatives in (a11, a12, a22, G12).
  static Eigen::Matrix3d law_stiffness(const MaterialParameters& p);

 private:
  int num_hinges_ = 0, num_angles_ = 0;
  std::vector<Face> faces_;
  Eigen::Matrix<double, Eigen::Dynamic, 3> modes_;
};

}  // namespace twill
