#pragma once
// The triangle shell: linear membrane triangles plus orthotropic Kirchhoff–Love bending from
// discrete-shell hinge angles on an OpenMesh triangulation of the strip (docs/triangle_shell.md;
// docs/model.md §1–2, §6). Registered name "triangle-shell".
//
// Nodes are the mesh vertices (strip_triangulation.hpp: numbering and patterns), dofs their
// positions q = [x0 y0 z0 x1 …] [m] (core/discretization.hpp). Energy [J]:
//
//   Ψ(q) = Σ_T τ Ā_T ψ(ẽ_T)                      membrane, constant-strain triangles
//        + Ψ_bending(θ)                            bending, flat rest state, θ = dihedral angles
//        − Σ_i m_i g·x_i                           gravity, m_i = ρ_A Σ_{T∋i} Ā_T/3
//
// ẽ_T = (Ẽ11, Ẽ22, Ẽ12) is the orthotropic Green strain of triangle T
// (constant_strain_triangle.hpp); m_i is also the consistent load of linear triangles
// (∫ρ_A g·x dA over T is Ā_T g·(x0 + x1 + x2)/3 exactly). Bending models (HingeModel):
//   shape-operator (default)  Σ_T Ā_T τ³/24 ẽ_Tᵀ C ẽ_T with a per-triangle curvature ẽ_T from
//                             the hinge angles of the triangle and its neighbours, consistent
//                             and telescoping (shape_operator_bending.hpp; §4.7): the law's
//                             own bending energy, a12 and twist included, and no mesh-scale
//                             mode can soften a bend.
//   directional, cylinders    Σ_e k_e |ē|²/Ā_e θ_e² (Grinspun et al. 2003) with hinge
//                             stiffnesses k_e ∝ τ³ from (a11, a22, a12 + G12)
//                             (hinge_bending.hpp; §4.4–4.6): exact only for some cylinders,
//                             and soft mesh-scale modes break the cantilever (§10).
// Every bending model sees C scaled to S C S by the law-side bending ratios
// (bending_parameters(), hinge_bending.hpp; 1 in the paper's model).
// The membrane is the paper's law exactly; the through-thickness integral is split as
// τψ(ε) + (bending at zero strain), i.e. the second-order expansion of model.md §6 with the
// bending term evaluated at ε = 0.
//
// Gradient and Hessian are exact (no projection). The Hessian pattern (3×3 blocks for every
// vertex pair sharing a triangle, a hinge or, for the shape operator, a face's bending stencil:
// the face, its neighbours and theirs) is built once; assembly writes values only,
// elements in parallel (TBB) by slabs of cell columns: even slabs, then odd ones (slabs of one
// parity share no vertex, so writes never collide and results are bitwise deterministic for
// any thread count).
//
// Clamps (clamped_nodes): the vertices on the end line. A linear triangle's slope across the
// end line is set by its apex one cell in, so holding the slope by vertices alone
// (clamp_hinges = none: clamp_slope also holds the next vertex column; for the cross pattern
// every vertex of the end cell column, centres included) makes the first cell column rigid:
// the effective clamp sits one cell in, an O(h) shortening of a cantilever's overhang. With
// clamp_hinges on an end, only the end line is held and the slope is held by *clamp hinges*:
// every boundary edge on that end line is a hinge against a ghost triangle fixed in the rest
// plane (the platform or jaw). Hinge models give it stiffness k_b = W_cyl(x̂)/3 with W_cyl the
// KL energy per area of a unit cylinder across the end line and Ā_e = Ā_T/3 (its one real
// triangle), which gives the KL energy of that cylinder in the half cell next to the clamp for
// any apex position (docs/triangle_shell.md §8); the shape operator uses its angle as the
// rotation of that boundary edge in the face's curvature (§4.7). The ghost is fixed in space:
// clamp hinges assume the held end line only translates in the rest plane (tensile jaws, the
// cantilever platform).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/discretization.hpp"
#include "core/material_law.hpp"
#include "core/parameters.hpp"
#include "discretizations/triangle_shell/hinge_bending.hpp"
#include "core/option_binding.hpp"
#include "discretizations/triangle_shell/shape_operator_bending.hpp"
#include "discretizations/triangle_shell/triangle_pattern.hpp"

namespace twill {

struct StripTriangulation;

/// A subset of the two strip ends (x = 0 and x = length).
enum class StripEnds { None, Start, End, Both };
std::string to_string(StripEnds ends);                        // "none", "start", "end", "both"
StripEnds strip_ends_from_string(const std::string& text);    // throws InputError for others
std::vector<StripEnds> all_strip_ends();                      ///< the one list, in option order
bool includes(StripEnds ends, StripEnd end);

/// The bending model (docs/triangle_shell.md §4, §10): how the dihedral angles become energy.
enum class HingeModel {
  /// Per-triangle shape operator from the hinge angles, split consistently and telescoping
  /// between neighbours, with the Kirchhoff–Love law τ³/24 ẽᵀCẽ applied to it
  /// (shape_operator_bending.hpp): exact for every uniform curvature on every pattern, free of
  /// mesh-scale modes, free edges with M_nn = 0. The default.
  ShapeOperator,
  /// Hinge energies k_e g_e θ_e² with k_e = λ · D(n_e)/6, the plate's bending stiffness across
  /// each edge (DirectionalHingeModel): warp and weft cylinders match KL, no hinge is softer
  /// than the plate in its direction; the alternating mesh's checkerboard halves the
  /// cantilever's stiffness (§10).
  Directional,
  /// Hinge energies with per-class stiffnesses solved so that warp, weft and 45° cylinders
  /// match KL exactly (HingeCalibration); leaves soft diagonal hinges on aligned meshes (§10).
  Cylinders,
};
/// "shape-operator", "directional", "cylinders".
std::string to_string(HingeModel model);
HingeModel hinge_model_from_string(const std::string& text);  // throws InputError for others
std::vector<HingeModel> all_hinge_models();                   ///< the one list, in option order

struct TriangleShellOptions {
  /// Mesh pattern (strip_triangulation.hpp). Alternating is the default: with the material
  /// axes along the strip (0°/90°) it reproduces cylinders bent in *every* direction, where
  /// right/left fail across their diagonals (docs/triangle_shell.md §5).
  TrianglePattern pattern = TrianglePattern::Alternating;
  /// Irregular pattern: largest vertex offset as a fraction of the cell size, in [0, 0.25)
  /// (a quarter cell can invert a triangle).
  double perturbation = 0.2;
  std::uint64_t seed = 1;  ///< irregular pattern: random seed
  int threads = 0;         ///< worker threads for assembly; 0 = TBB's choice, 1 = serial
  /// Strip ends whose slope clamp is modelled by clamp hinges (header comment) instead of
  /// holding the first cell column rigid. Off by default: a clamp hinge holds the end's slope
  /// whether or not the experiment holds that end (pure bending of free sheets must not have
  /// them); the cantilever wants `start`.
  StripEnds clamp_hinges = StripEnds::None;
  /// Bending model. The shape operator by default: it is exact for cylinders in every
  /// direction, doubly curved states and twist, and the only model whose cantilever matches
  /// the Catmull–Clark shell (docs/triangle_shell.md §10); the hinge models are kept for
  /// comparison (cylinders: soft diagonal folds; directional: the checkerboard mode).
  HingeModel hinge_model = HingeModel::ShapeOperator;

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null), the
  /// field's name first. The ranges are those of triangle_shell_option_bindings().
  bool validate(std::string* error) const;
};

/// The options of "triangle-shell" (pattern, perturbation, seed, threads, clamp_hinges,
/// hinge_model), each declared once (core/option_binding.hpp): the registered schema,
/// validate()'s ranges and the struct read from a config all come from here.
OptionBindings<TriangleShellOptions> triangle_shell_option_bindings();

/// The three parts of Ψ(q) [J].
struct TriangleShellEnergyParts {
  double membrane = 0, bending = 0, gravity = 0;
  double total() const { return membrane + bending + gravity; }
};

class TriangleShell final : public Discretization {
 public:
  /// Builds mesh, reference data, hinge classes and the Hessian pattern. Throws InputError
  /// (key = the offending field) for an invalid strip, parameters or options.
  TriangleShell(const StripSpec& strip, const MaterialParameters& parameters,
                const TriangleShellOptions& options = {});
  ~TriangleShell() override;
  TriangleShell(const TriangleShell&) = delete;
  TriangleShell& operator=(const TriangleShell&) = delete;

  std::string name() const override { return "triangle-shell"; }
  const StripSpec& strip() const override { return strip_; }
  int num_nodes() const override;
  const Eigen::VectorXd& rest_positions() const override { return rest_; }

  void set_parameters(const MaterialParameters& parameters) override;
  const MaterialParameters& parameters() const override { return law_->parameters(); }
  void set_gravity(const Eigen::Vector3d& g_m_s2) override { gravity_ = g_m_s2; }

  double energy(const Eigen::VectorXd& q, Eigen::VectorXd* gradient,
                SparseMatrix* hessian) const override;
  void gradient_parameter_jacobian(const Eigen::VectorXd& q,
                                   Eigen::MatrixXd* dgradient_dk) const override;
  std::vector<int> clamped_nodes(StripEnd end, bool clamp_slope) const override;
  /// Barycentric interpolation in the reference triangle containing each point (a point on
  /// an edge takes the triangle where it is most inside). Throws InputError (key
  /// "points[i]") for a point outside the strip.
  SparseMatrix point_evaluation(const std::vector<Eigen::Vector2d>& points) const override;
  Eigen::VectorXd lumped_mass() const override;
  /// The mesh triangles themselves: vertices = q as #V × 3, faces #F × 3.
  void surface_mesh(const Eigen::VectorXd& q, Eigen::MatrixXd* vertices,
                    Eigen::MatrixXi* faces) const override;

  /// Ψ split into membrane, bending and gravity (diagnostics and tests).
  TriangleShellEnergyParts energy_parts(const Eigen::VectorXd& q) const;
  /// Hinge models: bending energy of every hinge k_e g_e θ_e² [J], in triangulation().hinges
  /// order. Zero for the shape operator, whose energy lives on the faces (face_bending_energies).
  Eigen::VectorXd hinge_energies(const Eigen::VectorXd& q) const;
  /// Hinge models: bending energy of every clamp hinge k_b g_b θ_b² [J] (empty without clamp
  /// hinges; zero for the shape operator, where the clamp angle enters the face's K_T).
  Eigen::VectorXd clamp_hinge_energies(const Eigen::VectorXd& q) const;
  /// Shape operator: bending energy W_T of every face [J] (#faces; zero for the hinge models).
  Eigen::VectorXd face_bending_energies(const Eigen::VectorXd& q) const;
  /// Shape operator: ẽ_T = (K̃11, K̃22, K̃12) of every face [1/m] (#faces × 3), free-edge
  /// rotations at their minimiser. Throws std::logic_error for the hinge models.
  Eigen::Matrix<double, Eigen::Dynamic, 3> face_curvatures(const Eigen::VectorXd& q) const;
  /// Clamp-hinge stiffness k_b = W_cyl(x̂)/3 [J] and ∂k_b/∂(a11', a12', a22', G12', τ) (the
  /// bending models' parameters, bending_parameters()).
  double clamp_hinge_stiffness(Eigen::Matrix<double, 1, 5>* derivative = nullptr) const;

  const TriangleShellOptions& options() const { return options_; }
  const StripTriangulation& triangulation() const;
  /// Class of every hinge (same order as triangulation().hinges) and the calibration.
  const std::vector<int>& hinge_class() const;
  const HingeCalibration& hinge_calibration() const;
  /// Cylinder-calibrated class stiffnesses (recomputed by set_parameters()); solved only for
  /// hinge_model = cylinders (empty otherwise).
  const HingeClassStiffness& hinge_stiffness() const { return stiffness_; }
  /// The stiffness of every hinge in the active model, with derivatives and the model's
  /// continuum error on the four calibration cylinders (recomputed by set_parameters()).
  const HingeStiffness& hinge_stiffnesses() const { return hinges_; }
  /// The directional model's data (null unless hinge_model = directional).
  const DirectionalHingeModel* directional_model() const;
  /// The shape operator's reference data and its current stiffness (null / empty unless
  /// hinge_model = shape-operator).
  const ShapeOperatorBending* shape_operator() const;
  const ShapeOperatorStiffness& shape_operator_stiffness() const;

 private:
  struct Impl;
  StripSpec strip_;
  TriangleShellOptions options_;
  std::unique_ptr<MaterialLaw> law_;
  /// What the bending models see (bending_parameters(): stiffnesses scaled by the bending
  /// ratios) and its chain to the flat vector; recomputed by set_parameters().
  MaterialParameters bending_;
  BendingParameterChain bending_chain_;
  HingeClassStiffness stiffness_;
  HingeStiffness hinges_;
  Eigen::Vector3d gravity_ = Eigen::Vector3d::Zero();
  Eigen::VectorXd rest_;
  std::unique_ptr<Impl> impl_;

  void update_hinge_stiffness();
};

}  // namespace twill
