#pragma once
// The discretisation interface: a shell mesh of a flat rectangular strip and its energy.
//
// Geometry and conventions (shared by every discretisation and experiment):
// - The reference strip lies in the plane z = 0, x ∈ [0, length_m] along the strip's long
//   axis, y ∈ [−width_m/2, width_m/2] across it. Units: metres.
// - Degrees of freedom are node positions (control points for Catmull–Clark, vertices for
//   triangles), 3 per node, flattened as q = [x0 y0 z0 x1 y1 z1 …] (#dofs = 3 #nodes).
//   Every material point's position is *linear* in q (see point_evaluation()).
// - Material frame: `angle_deg` θ is the angle between the strip axis (x) and the weft
//   direction d2 (model.md §7: weft 0°, warp 90°, bias 45°):
//       d2 = (cos θ, sin θ, 0),   d1 = (−sin θ, cos θ, 0)   (warp, d1 ⟂ d2).
// - Energy: Ψ(q) = Ψ_elastic(q; k) + Ψ_gravity(q), Ψ_gravity = −∫ ρ_A g·x dA (model.md §6) [J].
// - Sign of forces: the gradient ∂Ψ/∂q is minus the internal force. At equilibrium with held
//   nodes, the force the cloth exerts on a clamp along direction a is −Σ_c ∂Ψ/∂q_c·a; the
//   tensile force reported by a tester pulling in +x at the x = length end is +Σ_c ∂Ψ/∂q_c,x.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <string>
#include <vector>

#include "core/material_law.hpp"

namespace twill {

using SparseMatrix = Eigen::SparseMatrix<double>;  // column-major, int indices

/// A flat rectangular strip to mesh.
struct StripSpec {
  double length_m = 0.075;  ///< along x (the strip axis)
  double width_m = 0.050;   ///< along y
  int cells_across = 8;     ///< resolution across the width (the "8" of 8×12)
  int cells_along = 12;     ///< resolution along the length (the "12" of 8×12)
  double angle_deg = 90.0;  ///< strip axis vs weft (θ above)
};

enum class StripEnd { Start, End };  ///< x = 0 and x = length_m

class Discretization {
 public:
  virtual ~Discretization() = default;

  /// Registered name, e.g. "catmull-clark-kl".
  virtual std::string name() const = 0;
  virtual const StripSpec& strip() const = 0;

  virtual int num_nodes() const = 0;
  int num_dofs() const { return 3 * num_nodes(); }
  /// Reference configuration (#dofs) [m].
  virtual const Eigen::VectorXd& rest_positions() const = 0;

  /// Replaces the material parameters (degrees may change). Mesh precomputation is kept.
  virtual void set_parameters(const MaterialParameters& parameters) = 0;
  virtual const MaterialParameters& parameters() const = 0;
  /// Gravitational acceleration [m/s²]; zero by default (tensile tests ignore gravity).
  virtual void set_gravity(const Eigen::Vector3d& g_m_s2) = 0;

  /// Ψ(q) [J], optional gradient (#dofs) [N] and Hessian (#dofs × #dofs, both triangles
  /// stored) [N/m]. The Hessian's sparsity pattern is the same for every q: when `hessian`
  /// already has it (from an earlier call), only values are overwritten, no allocation.
  virtual double energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                        SparseMatrix* hessian) const = 0;

  /// ∂(∂Ψ/∂q)/∂k at q: #dofs × flat_size() (parameters.hpp layout), dense.
  virtual void gradient_parameter_jacobian(const Eigen::VectorXd& q,
                                           Eigen::MatrixXd* dgradient_dk) const = 0;

  /// Nodes to hold so that a strip end is clamped across its full width: the surface along
  /// the end line is then fixed, and with `clamp_slope` its tangent plane across it too.
  virtual std::vector<int> clamped_nodes(StripEnd end, bool clamp_slope) const = 0;

  /// Linear map from q to the positions of reference points (x, y) on the strip:
  /// a (3·#points × #dofs) matrix P with positions = P q, stacked [x y z] per point.
  virtual SparseMatrix point_evaluation(const std::vector<Eigen::Vector2d>& points) const = 0;

  /// Lumped mass per dof [kg] (#dofs), from the areal density: the backward-Euler fallback
  /// of the solver and the gravity load use it.
  virtual Eigen::VectorXd lumped_mass() const = 0;

  /// A triangulated surface sampled for output (OBJ export): vertices (#V×3) and faces (#F×3).
  virtual void surface_mesh(const Eigen::VectorXd& q, Eigen::MatrixXd* vertices,
                            Eigen::MatrixXi* faces) const = 0;
};

}  // namespace twill
