#pragma once
// The Catmull–Clark subdivision Kirchhoff–Love shell of Clyde, Teran & Tamstorf 2017
// (paper §2, §6.3 and its supplemental document; docs/model.md §1, §6; derivation and clamp
// model in docs/catmull_clark_kl.md). name() is "catmull-clark-kl".
//
// Mesh: a regular grid of (cells_along + 1) × (cells_across + 1) control points over the
// reference rectangle (core/discretization.hpp), node (i, j) at
//   x = i·length/cells_along,  y = −width/2 + j·width/cells_across,  z = 0,
// with index j·(cells_along + 1) + i (limit_surface_basis.hpp). The surface is the
// Catmull–Clark limit surface with sharp boundary edges and corners; on this grid every face
// is a regular bicubic B-spline patch (no extraordinary vertices, so no Gregory patches:
// checked at construction), the rest limit surface is exactly the rectangle and each face's
// reference parametrisation is affine. The surface does not interpolate its control points
// (except the corners): every material point is a fixed linear combination of ≤ 16 of them.
//
// Energy (core/discretization.hpp conventions):
//   Ψ = Σ_faces Σ_{Gauss points} w dA ∫_{−τ/2}^{τ/2} ψ(Ẽ(ξ)) dξ  −  ρ_A Σ_i (∫N_i dA) g·x_i,
// Ẽ(ξ) = T(ε − ξκ) as in kirchhoff_love_kernel.hpp; per face n_g × n_g Gauss points (paper
// §6.3: 4×4), n_ξ Gauss–Legendre points through the thickness. Gradient and Hessian are
// exact (no projection or regularisation: the Hessian is indefinite where the state is).
//
// Clamp model (clamped_nodes): holding the boundary row of control points at an end fixes the
// limit boundary curve there exactly (it depends on that row only); adding the next row also
// fixes the cross tangent, i.e. the tangent plane along the end. This holds positions along
// the whole clamp line: the jaws allow no lateral contraction, as in the paper's tensile
// simulations (a clamped strip across its full width).
//
// Precomputation (once per mesh, never inside Newton): per face and Gauss point the 16
// control points with weights and first/second parametric derivatives (shared between faces
// with identical basis, i.e. the same boundary type), the reference data (metric, curvature,
// covariant → orthotropic map, weight × area); the Hessian pattern and, per face, where its
// 48×48 block lands in the CSC value array, so assembly only adds values.
//
// Threading: faces in parallel with TBB, either in colour classes (faces of one colour share
// no control point, so they write disjoint entries; results are bitwise deterministic) or
// with per-thread accumulators summed afterwards (CatmullClarkKLOptions::assembly). The
// pattern, slot tables, colouring, runner, scatter and gravity are the shared assembly
// machinery of discretizations/assembly/.
#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "core/discretization.hpp"
#include "core/material_law.hpp"
#include "core/option_binding.hpp"
#include "core/parameters.hpp"
#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"
#include "discretizations/catmull_clark_kl/kirchhoff_love_face.hpp"
#include "discretizations/catmull_clark_kl/limit_surface_basis.hpp"

namespace twill {

struct CatmullClarkKLOptions {
  /// How faces are assembled in parallel (see the header comment).
  enum class Assembly { Colouring, ThreadLocal };

  int gauss_points_per_direction = 4;  ///< per face direction (paper §6.3: 4 × 4)
  int thickness_points = 3;            ///< Gauss–Legendre points through τ (≥ 2)
  int threads = 0;                     ///< worker threads; 0 = TBB's choice
  int surface_samples_per_face = 4;    ///< surface_mesh(): samples per face edge
  Assembly assembly = Assembly::Colouring;
  /// Fibre stretches Ẽ11, Ẽ22 projected onto constants per face (a B-bar remedy for
  /// fibre-inextensibility locking), chosen by measurement over the paper's pointwise 4 × 4
  /// (§6.3), which locks off-axis, and the linear/bilinear projections, which lock too
  /// (docs/catmull_clark_kl.md §12).
  FibreStrain fibre_strain = FibreStrain::FaceMean;

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null), the
  /// field's name first. Ranges come from catmull_clark_kl_option_bindings(); the one
  /// cross-field rule is here (projections need two Gauss points per direction).
  bool validate(std::string* error) const;
};

/// The options of "catmull-clark-kl", each declared once (core/option_binding.hpp): its
/// registered schema, validate()'s ranges and the struct read from a config all come from here.
/// `assembly` is not an option (a diagnostic choice for tests).
OptionBindings<CatmullClarkKLOptions> catmull_clark_kl_option_bindings();

class CatmullClarkKL final : public Discretization {
 public:
  /// Builds the mesh and the whole precomputation. Throws InputError (key = the offending
  /// field) for an invalid strip, parameters or options (options.validate()).
  CatmullClarkKL(const StripSpec& strip, const MaterialParameters& parameters,
                 const CatmullClarkKLOptions& options = {});
  ~CatmullClarkKL() override;

  std::string name() const override { return "catmull-clark-kl"; }
  const StripSpec& strip() const override { return strip_; }
  int num_nodes() const override { return basis_->num_nodes(); }
  const Eigen::VectorXd& rest_positions() const override { return rest_; }

  void set_parameters(const MaterialParameters& parameters) override;
  const MaterialParameters& parameters() const override { return law_.parameters(); }
  void set_gravity(const Eigen::Vector3d& g_m_s2) override { gravity_ = g_m_s2; }

  double energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                SparseMatrix* hessian) const override;
  void gradient_parameter_jacobian(const Eigen::VectorXd& q,
                                   Eigen::MatrixXd* dgradient_dk) const override;
  /// The control points of the end's boundary row (x = 0 or x = length), and with
  /// `clamp_slope` the next row inwards too; see the clamp model above.
  std::vector<int> clamped_nodes(StripEnd end, bool clamp_slope) const override;
  /// Points must lie in the reference rectangle (within 1e-9 of its size; throws InputError
  /// with key `points[k]` otherwise).
  SparseMatrix point_evaluation(const std::vector<Eigen::Vector2d>& points) const override;
  /// ρ_A ∫ N_i dA per node (by the same Gauss rule), repeated on its 3 dofs [kg].
  Eigen::VectorXd lumped_mass() const override;
  /// The limit surface sampled on a grid of surface_samples_per_face² cells per face,
  /// two triangles per cell, counter-clockwise seen from +z in the reference.
  void surface_mesh(const Eigen::VectorXd& q, Eigen::MatrixXd* vertices,
                    Eigen::MatrixXi* faces) const override;

  // Diagnostics (tests, studies).
  const CatmullClarkKLOptions& options() const { return options_; }
  const LimitSurfaceBasis& basis() const { return *basis_; }
  int num_faces() const { return basis_->num_faces(); }
  int num_quadrature_points() const;
  /// Strain at one Gauss point: reference position, orthotropic membrane strain
  /// (Ẽ11, Ẽ22, Ẽ12) at the mid-surface and bending strain e_b [1/m] (Ẽ(ξ) = e_m − ξ e_b).
  struct PointStrain {
    Eigen::Vector2d reference_point;
    Eigen::Vector3d membrane;
    Eigen::Vector3d bending;
  };
  /// Every Gauss point's strains at q, face by face, as the law sees them (with
  /// FibreStrain::FaceMean, Ẽ11 and Ẽ22 are the face means).
  std::vector<PointStrain> quadrature_strains(const Eigen::VectorXd& q) const;
  /// Bytes held by the mesh precomputation (basis tables, reference data, Hessian pattern and
  /// block positions, colouring), excluding OpenSubdiv's own patch table.
  std::size_t precomputation_bytes() const;

 private:
  struct Mesh;

  void check_positions(const Eigen::VectorXd& q, const char* caller) const;
  /// The precomputed quadrature of one face (basis, reference data, projection choice).
  FaceQuadrature face_quadrature(int face) const;

  StripSpec strip_;
  CatmullClarkKLOptions options_;
  MaterialLaw law_;
  GaussLegendreRule thickness_rule_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();
  std::unique_ptr<LimitSurfaceBasis> basis_;
  Eigen::VectorXd rest_;
  std::unique_ptr<const Mesh> mesh_;
};

}  // namespace twill
