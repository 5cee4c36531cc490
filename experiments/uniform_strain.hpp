#pragma once
// The uniform-strain approximation of the tensile strip (paper §5.3, "Initial guesses"): the
// whole strip is assumed to undergo one homogeneous strain, so the clamp force is a closed-form
// function of the material law plus one scalar (two with free shear) lateral solve. The fit
// uses it to obtain initial parameters k0 cheaply before any shell solve (§5.2 step 1, §5.4).
// Derivation: docs/material_law.md §"Uniform-strain tensile strip".
//
// Strip frame: x along the strip axis, y across (core/discretization.hpp); the material frame
// is at θ = angle_deg between the axis and the weft, d2 = (cos θ, sin θ), d1 = (−sin θ, cos θ).
// The strain in the strip frame is the 3-vector E = (E_xx, E_yy, E_xy), E_xy the *tensor*
// shear component (like the law's Ẽ12), and the law's orthotropic strain is e = T(θ)·E.
//
// The homogeneous state at clamp extension u [mm] (gauge L [mm], width W [mm], τ = thickness):
//   λ = 1 + u/L,   E_xx = (λ² − 1)/2 (imposed by the clamps),
//   lateral components free, with zero lateral traction:  ∂ψ/∂E_yy = 0, and with
//   UniformStrainShear::Free also ∂ψ/∂E_xy = 0 (uniaxial stress); with ::Held, E_xy = 0.
//   force  F = W τ λ S_xx,  S_xx = ∂ψ/∂E_xx   [N]  (= ∂Ψ/∂u with Ψ = W L τ ψ, paper §5.3)
//   lateral engineering strain √(1 + 2 E_yy) − 1.
// At θ = 0° and 90° (the warp and weft tests the paper applies §5.3 to) orthotropy makes
// ∂ψ/∂E_xy vanish at E_xy = 0, so both shear choices give the same state.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/fit_objective.hpp"
#include "core/material_law.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {

/// Whether the in-plane shear E_xy of the strip frame is free (zero shear traction: the strip
/// is in uniaxial stress, the least-energy homogeneous state) or held at zero (the clamp lines
/// stay perpendicular to the axis; the clamps then carry a lateral force W τ μ S_xy).
enum class UniformStrainShear { Free, Held };

struct UniformStrainStrip {
  double angle_deg = 90.0;        ///< strip axis vs weft (θ)
  double width_mm = 50.0;         ///< W
  double gauge_length_mm = 75.0;  ///< L
  UniformStrainShear shear = UniformStrainShear::Free;

  /// Ceres-style check naming the first offending field.
  bool validate(std::string* error) const;
  /// The strip of a tensile setup (its cells and planar flag do not matter here).
  static UniformStrainStrip from(const TensileSetup& setup,
                                 UniformStrainShear shear = UniformStrainShear::Free);
};

/// The map e = T E from strip-frame strain E = (E_xx, E_yy, E_xy) to the law's orthotropic
/// strain e = (Ẽ11, Ẽ22, Ẽ12) (both with tensor shear) for θ = angle_deg. ∂ψ/∂E = Tᵀ ∂ψ/∂e.
Matrix3 strip_to_material_strain(double angle_deg);

/// One extension of the uniform-strain strip.
struct UniformStrainPoint {
  double extension_mm = 0;
  double stretch = 1;                    ///< λ = 1 + u/L
  Vector3 strain = Vector3::Zero();      ///< (E_xx, E_yy, E_xy), strip frame
  double stress_xx_Pa = 0;               ///< S_xx = ∂ψ/∂E_xx (second Piola–Kirchhoff)
  double force_N = 0;                    ///< W τ λ S_xx, positive in tension
  double lateral_strain = 0;             ///< √(1 + 2E_yy) − 1 (negative when narrowing)
  double energy_J = 0;                   ///< Ψ = W L τ ψ (∂Ψ/∂u = force_N, u in m)
  double dforce_dextension_N_per_mm = 0; ///< tangent stiffness dF/du (lateral state follows)
  /// Total derivatives in every flat parameter (parameters.hpp layout, flat_size() entries),
  /// lateral strains following by implicit differentiation; empty unless requested.
  Eigen::VectorXd dforce_dk;
  Eigen::VectorXd dlateral_strain_dk;
  int lateral_iterations = 0;            ///< function evaluations of the lateral solve
  bool converged = false;
  std::string message;                   ///< why the lateral solve failed, if it did
};

/// The uniform-strain state of `strip` at extension u = extension_mm (> −L) for the law
/// (thickness from law.parameters()). The lateral condition is solved by Newton's method
/// safeguarded by a bisection bracket, to machine precision; `lateral_guess` (E_yy, E_xy)
/// only sets the start (e.g. the previous extension's state). Never throws for a failed
/// solve (converged = false, message); throws std::invalid_argument for an invalid strip or
/// an extension ≤ −L.
UniformStrainPoint uniform_strain_tension(const MaterialLaw& law, const UniformStrainStrip& strip,
                                          double extension_mm, bool want_parameter_derivatives,
                                          const Eigen::Vector2d& lateral_guess = Eigen::Vector2d::Zero());

/// The uniform-strain clamp forces as a Predictor (core/fit_objective.hpp): the paper's §5.3
/// cheap model of a tensile test, interchangeable with TensilePredictor in a FitObjective.
/// Each predict() is a pure function of k (every curve starts its lateral solves from the
/// unstrained state and continues through the extensions in the order given).
class UniformStrainPredictor : public Predictor {
 public:
  /// extensions_mm and forces_N: the measured points (same size, non-empty). Uses the setup's
  /// angle_deg, width_mm and gauge_length_mm; its cells are ignored. Throws
  /// std::invalid_argument on mismatched sizes or an invalid setup.
  UniformStrainPredictor(std::string label, const TensileSetup& setup,
                         std::vector<double> extensions_mm, const Eigen::VectorXd& forces_N,
                         UniformStrainShear shear = UniformStrainShear::Free);

  std::string label() const override { return label_; }
  const Eigen::VectorXd& measured() const override { return measured_; }
  bool predict(const MaterialParameters& k, const std::vector<int>& flat, Eigen::VectorXd* values,
               Eigen::MatrixXd* jacobian, std::string* message) override;
  /// Lateral solves so far (one per extension per prediction): the analogue of equilibria.
  long equilibrium_solves() const override { return solves_; }

  const UniformStrainStrip& strip() const { return strip_; }
  const std::vector<double>& extensions_mm() const { return extensions_mm_; }
  /// The points of the last successful prediction.
  const std::vector<UniformStrainPoint>& last_points() const { return last_points_; }

 private:
  std::string label_;
  UniformStrainStrip strip_;
  std::vector<double> extensions_mm_;
  Eigen::VectorXd measured_;
  long solves_ = 0;
  std::vector<UniformStrainPoint> last_points_;
};

}  // namespace twill
