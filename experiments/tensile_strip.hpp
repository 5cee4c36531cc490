#pragma once
// The simulated ASTM D5035-like strip tensile test (paper §4, §5.5.1; docs/model.md §7).
//
// Geometry: a strip of gauge length L (clamp separation at zero extension) and width W,
// clamped across its full width at both ends; the end at x = 0 is held, the end at x = L is
// displaced by u along the strip axis (+x). The material frame is at `angle_deg` between the
// strip axis and the weft (weft 0°, warp 90°, bias 45°).
//
// Clamp model: Discretization::clamped_nodes(end, clamp_slope = false) — every node that
// carries the surface along the clamp line is held at its rest position (Start) or its rest
// position + u·x̂ (End): the jaws hold the full width rigidly, with no lateral contraction.
//
// Observables (paper §5.5.1):
// - force_N: the axial force the strip exerts on the moving clamp, Σ_c ∂Ψ/∂q_c,x over the
//   moving clamp's nodes (positive in tension; discretization.hpp gives the sign argument);
// - lateral_strain: engineering strain of the width at mid-gauge, |p(L/2, W/2) − p(L/2, −W/2)|
//   / W − 1 (what a video extensometer reports; negative when the strip narrows).
//
// Out-of-plane motion: a flat strip pulled in its plane has no out-of-plane load, so its flat
// state is an equilibrium (the independent references are planar membranes). Its out-of-plane
// stiffness is bending only, about 1e-7 of the membrane's, and lateral compression near the
// jaws makes that block indefinite (the flat state is then a saddle: wrinkling). With
// `planar = true` (default) the z dofs are held, which selects the flat equilibrium exactly
// and halves the system; `planar = false` solves in 3-D (the solver's failsafe handles the
// indefinite block; forces agree with the planar solve while the strip stays flat).
//
// Continuation: the extensions are applied in the order given (loading then unloading rows
// are fine: the law is elastic); each step starts from the previous equilibrium, the first
// from the affine stretch x ← x·(1 + u/L), which is exact for a uniform strip without clamps.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/discretization.hpp"
#include "core/equilibrium_solver.hpp"
#include "core/sensitivity.hpp"
#include "experiments/strip_factory.hpp"

namespace twill {

struct TensileSetup {
  double angle_deg = 90.0;         ///< strip axis vs weft
  double width_mm = 50.0;          ///< W
  double gauge_length_mm = 75.0;   ///< L
  int cells_across = 8;            ///< resolution across W
  int cells_along = 12;            ///< resolution along L
  bool planar = true;              ///< hold the out-of-plane dofs (see header)

  /// Ceres-style check naming the first offending field.
  bool validate(std::string* error) const;
  StripSpec strip() const;
  bool operator==(const TensileSetup&) const = default;  ///< the same strip and mesh
};

struct TensilePoint {
  double extension_mm = 0;
  double force_N = 0;
  double lateral_strain = 0;
  EquilibriumSummary solve;  ///< what the equilibrium solve of this point did
  /// Total derivatives in the parameters chosen by set_sensitivity_parameters() (paper Eq. 6,
  /// core/sensitivity.hpp), one entry per chosen parameter [N resp. 1 per parameter unit];
  /// empty when none are chosen.
  Eigen::VectorXd dforce_dk;
  Eigen::VectorXd dlateral_strain_dk;
  /// dF/dθ [N per degree of material angle] with set_angle_sensitivity(true); 0 otherwise.
  double dforce_dangle = 0;
  /// ∂q/∂k at this point (#dofs × m), kept only with keep_states (warm starts of later runs).
  Eigen::MatrixXd dq_dk;
  /// The equilibrium (#dofs), kept only with keep_states.
  Eigen::VectorXd q;
  /// dq/dθ (#dofs) [m per degree], kept only with keep_states and the angle sensitivity: a
  /// strip at a slightly other angle starts from q + Δθ dq/dθ (the fit's validation offsets).
  Eigen::VectorXd dq_dangle;
};

struct TensileCurve {
  std::vector<TensilePoint> points;  ///< one per converged extension, in schedule order
  bool completed = false;            ///< every extension converged
  std::string message;               ///< why it stopped early, if it did
  double wall_time_s = 0;
  int newton_iterations = 0;         ///< total over the curve
};

class TensileExperiment {
 public:
  /// Called at each converged extension with the step index, the equilibrium q and the
  /// solver (its factorisation of K_ff at q is valid: the sensitivity solve hooks in here;
  /// run() keeps it, run_from() without derivatives does not, EquilibriumSolver::
  /// set_solution_factor_needed).
  using EquilibriumObserver =
      std::function<void(int step, const Eigen::VectorXd& q, const EquilibriumSolver& solver)>;

  /// Builds the mesh through `factory`. Throws std::invalid_argument if setup is invalid.
  TensileExperiment(const TensileSetup& setup, const DiscretizationFactory& factory,
                    const MaterialParameters& parameters, const EquilibriumOptions& solver = {});

  /// Runs the loading schedule (mm, any order). Never throws for a failed solve: the curve
  /// then ends early with completed = false and a message.
  TensileCurve run(const std::vector<double>& extensions_mm,
                   const EquilibriumObserver& observer = {});
  /// As run(), but point i starts from initial_guesses[i] (#dofs each; its held dofs are
  /// overwritten by the schedule) instead of the previous point's equilibrium: used to warm
  /// start a re-run at nearby parameters from q_i + ∂q_i/∂k·Δk (fitting). A point whose solve
  /// from its guess fails is retried from the previous equilibrium.
  /// The points do not depend on each other, so they are solved in
  /// parallel: contiguous chunks, one per TBB worker, each with its own solver on the shared
  /// (const, thread-safe) discretisation; retries and the result are in schedule order, so
  /// the curve is the same for any number of threads (test TensileWarmStart.*). Measured
  /// (32×48 strip, 2 cores): two solves side by side take 1.1× one, while the assembly's
  /// own threads speed one solve up 1.1–1.4×.
  TensileCurve run_from(const std::vector<double>& extensions_mm,
                        const std::vector<Eigen::VectorXd>& initial_guesses);
  /// Flat parameter indices (parameters.hpp) whose derivatives run() reports per point
  /// (empty: none, the default). Throws std::invalid_argument for an index out of range.
  void set_sensitivity_parameters(const std::vector<int>& flat_indices);
  const std::vector<int>& sensitivity_parameters() const { return sensitivity_parameters_; }
  /// Report dF/dθ per point, the total derivative of the clamp force in the material angle
  /// (the validation offsets of paper §7): Eq. 6 with ∂g/∂θ by central differences of the
  /// gradient of two copies of the mesh at θ ± kAngleStepDeg (same nodes, only the material
  /// frame turns; truncation ~1e-10 and round-off ~1e-11 relative for this step).
  void set_angle_sensitivity(bool on);
  static constexpr double kAngleStepDeg = 1e-3;
  /// Keep each point's equilibrium and ∂q/∂k in the curve (memory: #dofs × (m + 1) per point).
  void set_keep_states(bool keep) { keep_states_ = keep; }

  /// Replaces the material (mesh and solver set-up are kept).
  void set_parameters(const MaterialParameters& parameters);

  const TensileSetup& setup() const { return setup_; }
  Discretization& discretization() { return *discretization_; }
  const Discretization& discretization() const { return *discretization_; }
  /// Nodes of the moving clamp (x = L) and the dofs held in total.
  const std::vector<int>& moving_clamp_nodes() const { return moving_nodes_; }
  const std::vector<int>& fixed_dofs() const { return fixed_dofs_; }
  /// Lateral-strain probe: positions of (L/2, ∓W/2) are P q (6 × #dofs).
  const SparseMatrix& lateral_probe() const { return lateral_probe_; }

  /// Observables of a configuration: force [N] from a gradient (#dofs), lateral strain from q.
  double force_from_gradient(const Eigen::VectorXd& gradient) const;
  double lateral_strain(const Eigen::VectorXd& q) const;
  /// |Ẽ11|, |Ẽ22|, |Ẽ12| (orthotropic Green strain, material frame, model.md §1) of the
  /// mid-surface at q on a grid of `samples_across` × proportional points, which covers the
  /// strip evenly (a share of samples is a share of its area; interior points: the deformation
  /// gradient comes from central differences of point_evaluation() positions at ±h, h = 1e-3
  /// of a cell). The strain cutoffs of paper §5.2 steps 4 and 6 ("the largest strain seen")
  /// and where a strip leaves them (fitting/fit_context.hpp strain_excess).
  std::vector<Eigen::Vector3d> material_strain_samples(const Eigen::VectorXd& q, int samples_across = 24) const;
  /// ∂(lateral strain)/∂q at q (#dofs).
  Eigen::VectorXd lateral_strain_gradient(const Eigen::VectorXd& q) const;

 private:
  TensileSetup setup_;
  DiscretizationFactory factory_;
  std::unique_ptr<Discretization> discretization_;
  std::unique_ptr<Discretization> angle_plus_, angle_minus_;  ///< at θ ± kAngleStepDeg
  std::vector<int> moving_nodes_;
  std::vector<int> fixed_dofs_;
  SparseMatrix lateral_probe_;
  EquilibriumSolver solver_;
  /// Solvers of run_from's further chunks (created on first use, kept for their patterns).
  std::vector<std::unique_ptr<EquilibriumSolver>> chunk_solvers_;
  EquilibriumSolver& chunk_solver(size_t chunk);
  /// Tells `solver` whether measure() will need its factor at the solution (derivatives);
  /// returns it. For run_from's independent points only (run() keeps the factor: its comment).
  EquilibriumSolver& use_solution_factor(EquilibriumSolver& solver) const;
  std::vector<int> sensitivity_parameters_;
  bool keep_states_ = false;
  /// dF/dθ and dq/dθ at the converged point q (set_angle_sensitivity) into p.
  void add_angle_derivative(const EquilibriumSolver& solver, const Eigen::VectorXd& q,
                            const std::vector<std::pair<int, double>>& clamp_x, TensilePoint* p) const;
  // Observables (and derivatives) of the point at q that `solver` converged to.
  TensilePoint measure(const EquilibriumSolver& solver, double extension_mm, const Eigen::VectorXd& q,
                       const EquilibriumSummary& summary) const;
};

}  // namespace twill
