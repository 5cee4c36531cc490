#pragma once
// The simulated ASTM D1388 cantilever bend test (paper §4, §5.1; docs/model.md §7).
//
// Geometry: a strip of width W whose overhang of length L projects past the platform edge
// and bends under its own weight. The platform edge is the line x = 0; the strip's part on
// the platform is modelled as a clamp at that line: position and tangent plane held
// (Discretization::clamped_nodes(Start, clamp_slope = true)). The overhang is meshed
// x ∈ [0, L], y ∈ [−W/2, W/2]; gravity is g = (0, 0, −9.81) m/s² times the areal density.
//
// Observable: the chord angle below horizontal of the line from the platform edge (0, 0, 0)
// to the free tip at mid-width (L, 0): atan2(−z_tip, x_tip) [deg]. The standard's measured
// overhang is the one at which that angle is 41.5°.
//
// Loading: from the flat rest state gravity is applied in `gravity_steps` equal steps
// (default 1: measured on canvas at 4×64, one step took 61 Newton iterations, a 4-step ramp
// 111 in total; the line search and the backward-Euler failsafe handle the large rotation).
// Later solves of the same experiment start from the previous equilibrium rescaled to the new
// overhang (the overhang search takes 3–5 solves).
//
// Classical check (Peirce 1930, ASTM D1388): for an inextensible linear strip, the 41.5°
// overhang is L = 2 (B/w)^{1/3}, with B the bending rigidity per unit width and w = ρ_A g;
// an elastica shooting computation gives w L³/B = 8.0042 at 41.5°, so the relation is exact
// to 0.02 %.
#include <memory>
#include <string>
#include <vector>

#include "core/discretization.hpp"
#include "core/equilibrium_solver.hpp"
#include "experiments/strip_factory.hpp"

namespace twill {

inline constexpr double kStandardGravity_m_s2 = 9.81;
inline constexpr double kD1388ChordAngle_deg = 41.5;

struct CantileverSetup {
  double angle_deg = 90.0;  ///< strip axis vs weft
  double width_mm = 25.0;   ///< W
  int cells_across = 4;     ///< resolution across W
  int cells_along = 64;     ///< resolution along the overhang (kept fixed while L varies)
  int gravity_steps = 1;    ///< load ramp from flat, ≥ 1 (measured: 1 step 61 Newton its, 4 steps 111)

  bool validate(std::string* error) const;
};

struct CantileverResult {
  double overhang_mm = 0;
  double chord_angle_deg = 0;
  double tip_deflection_mm = 0;  ///< −z of the tip
  bool converged = false;
  std::string message;
  int newton_iterations = 0;
  double wall_time_s = 0;
  /// d(chord angle)/dk [deg per parameter unit] for the parameters chosen by
  /// set_sensitivity_parameters() (paper Eq. 6); empty when none are chosen.
  Eigen::VectorXd dchord_angle_dk;
};

struct OverhangSearchResult {
  double overhang_mm = 0;        ///< the overhang whose chord angle is the target
  double chord_angle_deg = 0;    ///< at that overhang
  bool converged = false;
  int evaluations = 0;           ///< cantilever solves
  std::string message;
  double wall_time_s = 0;
};

class CantileverExperiment {
 public:
  CantileverExperiment(const CantileverSetup& setup, DiscretizationFactory factory,
                       const MaterialParameters& parameters, const EquilibriumOptions& solver = {});

  /// Solves the cantilever with overhang L [mm] (> 0) and returns its chord angle. Starts from
  /// the previous solve's equilibrium rescaled to L when there is one (same mesh topology).
  CantileverResult solve(double overhang_mm) const;

  /// Finds the overhang whose chord angle is `target_deg` (bracketing secant / Illinois on
  /// the monotone angle(L), started from Peirce's estimate with the small-strain stiffness
  /// along the strip axis), to |angle − target| ≤ tolerance_deg.
  OverhangSearchResult find_overhang(double target_deg = kD1388ChordAngle_deg,
                                     double tolerance_deg = 1e-3) const;

  /// Small-strain bending rigidity per unit width along the strip axis for a plate with the
  /// lateral curvature free: B = τ³/12 · (C_xxxx − C_xxyy²/C_yyyy) [N·m], and with it held:
  /// τ³/12 · C_xxxx. C is ∂²ψ/∂E² at zero strain scaled by the bending ratios (S C S,
  /// core/bending_scale.hpp) and rotated to the strip axes.
  double bending_rigidity_free_Nm() const;
  double bending_rigidity_plate_Nm() const;
  /// Peirce's overhang for a rigidity B: 2 (B/w)^{1/3} [mm].
  double peirce_overhang_mm(double rigidity_Nm) const;

  const CantileverSetup& setup() const { return setup_; }
  const MaterialParameters& parameters() const { return parameters_; }
  void set_parameters(const MaterialParameters& parameters) { parameters_ = parameters; }
  /// Flat parameter indices (parameters.hpp) whose chord-angle derivatives solve() reports
  /// (empty: none). Density enters through gravity, thickness and stiffnesses through Ψ.
  void set_sensitivity_parameters(const std::vector<int>& flat_indices) {
    sensitivity_parameters_ = flat_indices;
  }
  /// Forget the previous equilibrium: the next solve starts from the flat strip.
  void reset_warm_start() { last_overhang_mm_ = 0; }

  /// The last solve's mesh and equilibrium (for OBJ export and sensitivities).
  const Discretization* last_discretization() const { return last_discretization_.get(); }
  const Eigen::VectorXd& last_positions() const { return last_q_; }

 private:
  CantileverSetup setup_;
  DiscretizationFactory factory_;
  MaterialParameters parameters_;
  EquilibriumOptions solver_options_;
  mutable std::unique_ptr<Discretization> last_discretization_;
  mutable Eigen::VectorXd last_q_;
  mutable double last_overhang_mm_ = 0;  ///< 0: no reusable equilibrium
  std::vector<int> sensitivity_parameters_;
};

}  // namespace twill
