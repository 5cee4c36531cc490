#pragma once
// Quasistatic equilibrium of a Discretization with held dofs (paper Eq. 4, §6.1–6.3).
//
// Problem. Minimise the total energy Ψ(q) = Ψ_elastic(q; k) + Ψ_gravity(q) [J] over the free
// dofs q_f; the fixed dofs q_c keep the values they have in q on entry to solve(), so a
// loading schedule moves them between solves (clamp displacement, see solve_continuation).
//
// Method (paper §6.1). Newton's method on the free dofs: factorise K_ff = ∂²Ψ/∂q_f² (CHOLMOD
// supernodal LLᵀ with extended-precision iterative refinement, sparse_cholesky.hpp), direction
// d = −K_ff⁻¹ g_f, backtracking line search on Ψ with the Armijo condition
// Ψ(q + αd) ≤ Ψ(q) + c1·α·g_fᵀd (Nocedal & Wright Alg. 3.1). The paper's failsafe: when
//   (a) K_ff is not positive definite (the factorisation fails), or
//   (b) the Newton direction is not a descent direction (g_fᵀd ≥ 0, from round-off at
//       condition numbers near 1e10), or
//   (c) three consecutive Newton steps reduced Ψ by ≤ 0.1 % in total, or
//   (d) the line search finds no acceptable step,
// the solver takes `backward_euler_steps` backward-Euler steps, then resumes Newton.
//
// Backward Euler. From rest at q_prev, one step minimises the incremental potential
//     Φ(q) = Ψ(q) + ½ (q_f − q_prev,f)ᵀ M_f (q_f − q_prev,f) / h²
// (M: lumped mass from Discretization::lumped_mass() [kg]; h: time step [s]). Each step is
// one Newton iteration on Φ (Hessian K_ff + M_f/h², positive definite for small enough h)
// with the same Armijo line search on Φ, so Ψ never increases. The velocity is reset to
// zero at every step (fully damped dynamics): the purpose is to slide off a saddle or out of
// a region where Newton stalls, not to simulate motion. Choice and adaptation of h:
//   - start: `initial_time_step_s`, or if 0, h² = median_i(m_i / K_ii) over free dofs with
//     K_ii > 0 — the mass term then equals a typical diagonal stiffness, i.e. about half of
//     a Newton step along typical modes and a short gradient step along soft ones;
//   - if K_ff + M_f/h² is not positive definite or its line search fails: h ← h/2 and retry
//     (at most `max_time_step_reductions` times per step);
//   - after a step with a full step length (α = 1): h ← h·time_step_growth (towards Newton);
//     after a backtracked step: h ← h/time_step_growth.
//   h is kept between fallbacks of one solve and reported in the summary.
//
// Deviation from the paper, rule (c). The rule compares the decrease with |Ψ|, and |Ψ|
// includes the gravity potential −Σ m g·x, which depends on where the origin is: the same
// hanging chain 10 m higher has |Ψ| ≈ 51 J against an elastic change of 0.04 J, and the bare
// rule then interrupts a Newton iteration that is converging quadratically (test
// StallRuleDoesNotInterruptConvergingNewton). Near any solution, too, each Newton step lowers
// Ψ by a vanishing amount. The rule therefore also requires that ‖g_f‖∞ did not fall below
// `stall_gradient_fraction` (0.1) times its value three steps earlier: Newton converging
// quadratically or at a good linear rate is not a stall. stall_gradient_fraction = 0 gives
// the paper's rule unchanged.
//
// Convergence (scale-aware; both must hold at the same iterate):
//   ‖g_f‖∞ ≤ gradient_tolerance · F,   F = max(‖g_c‖∞, force_floor_N)   [N]
//   λ² = −g_fᵀd = g_fᵀ K_ff⁻¹ g_f ≤ decrement_tolerance · F · L           [J]
// g_c is the gradient at the fixed dofs (the support reactions, gravity included), so F is the
// largest force a support applies; force_floor_N keeps F meaningful when no support carries
// load. λ² (the squared Newton decrement, ≈ 2 × the energy still to gain) guards against soft
// modes where a small gradient still means a large displacement error; L is a length scale
// (default: diagonal of the rest positions' bounding box), so F·L is an energy scale.
// Round-off floor. Both tests are relative, but ‖g_f‖ and λ² cannot fall below the round-off
// of the positions times the stiffness (a strip far from the origin, a soft twist mode with a
// tiny decrement tolerance). When ‖g_f‖∞ already passes its test, the full Newton step changes
// Ψ by less than the energy round-off (energy_roundoff·|Ψ|) and it does not lower ‖g_f‖∞
// either, no further Newton step can change anything measurable: the solve ends converged at
// the current iterate (status kConverged, `at_roundoff_floor`, the message says so) instead of
// backtracking to steps that leave q unchanged and then falling back to backward Euler 20
// times (test ConvergesAtTheRoundoffFloorInsteadOfFallingBack). A backtracked trial that
// leaves q bitwise unchanged ends the line search at once.
//
// Convergence is tested right after K_ff has been factorised at the current iterate, so at a
// converged solution the factor of K_ff *at the returned q* is available (factorization(),
// solve_free_free()) for the sensitivity solve of paper Eq. 6: ∂q_f/∂k = −K_ff⁻¹ ∂g_f/∂k.
//
// A caller that needs no such factor (a curve evaluated without derivatives: validation
// offsets, final curves) says so with set_solution_factor_needed(false). Then the trial of a
// full Newton step is evaluated without the Hessian, and at the accepted iterate convergence
// is tested with the factor K̃ of the iterate the step came from: ‖g_f‖∞ as above and
// λ̃² = g_fᵀ K̃⁻¹ g_f ≤ decrement_tolerance·F·L (one back-substitution). K̃ differs from K_ff
// at q by O(‖step‖), and a full step that ends the solve is a converging Newton step, so λ̃²
// is λ² to that relative order — far inside the tolerance's meaning (≈ 2 × the energy still
// to gain). When either test fails the Hessian at q is assembled and Newton goes on as
// before. A converged solve then costs one Hessian assembly and one factorisation fewer (a
// warm-started point: one of two); the returned q is the iterate the default would return
// whenever both tests agree. has_solution_factorization() is false after such a solve.
//
// Saddles. Backward Euler from rest cannot leave a stationary point (its gradient is zero),
// and a symmetric start stays on its symmetric branch: a flat strip pulled until its
// contraction would wrinkle it is stationary and flat, a saddle. When ‖g_f‖∞ passes its test
// where K_ff is not positive definite, the solver steps off along the lowest mode of
// K_ff v = λ M_f v (M_f the lumped masses, so that λ is a squared frequency and the mode does
// not depend on the dofs' units): K_ff + σ M_f is factorised with the smallest σ ≥ 0 found that
// makes it positive definite (σ doubled from a small start, then bisected), and inverse
// iteration v ← (K_ff + σM_f)⁻¹ M_f v converges to the mode of the lowest λ. When λ < 0 the
// step is α v, its sign downhill (g_fᵀv ≤ 0), α from a step of 1e-4 L in the largest entry,
// halved while Ψ does not fall (down to 1e-10 L), then doubled while it keeps falling (at most
// L), the lowest Ψ kept; Newton resumes from there. A
// saddle is left in the direction the start vector (fixed, pseudo-random) leans to, so the
// result is reproducible; the two branches of a symmetric problem are mirror images. When no
// λ < 0 is found or no step lowers Ψ beyond its round-off, the solve ends kIndefiniteStationary
// (test EscapesASaddleAlongItsLowestMode; docs/solver.md "Saddles").
//
// Non-convergence never throws: solve() returns a summary with a status and a message.
// Bad arguments (wrong vector size, invalid options) throw std::invalid_argument.
// Logging: spdlog at debug level only.
// Allocation: the Hessian, K_ff, the shifted matrix, the symbolic factorisation and the work
// vectors are reused across iterations and solves (patterns are set up on the first solve).
// Threads: one solver per thread (it owns a SparseCholesky and work buffers); the
// Discretization is only read through its const interface.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/constrained_dofs.hpp"
#include "core/discretization.hpp"
#include "core/sparse_cholesky.hpp"

namespace twill {

struct EquilibriumOptions {
  // Convergence (see the header comment).
  double gradient_tolerance = 1e-8;    ///< relative to the force scale F, > 0
  double force_floor_N = 1e-6;         ///< lower bound of F [N], > 0
  double decrement_tolerance = 1e-12;  ///< λ² ≤ decrement_tolerance·F·L, > 0
  double length_scale_m = 0.0;         ///< L [m]; 0 = bounding-box diagonal of the rest state
  int max_newton_iterations = 200;     ///< accepted Newton steps per solve, ≥ 1

  // Backtracking Armijo line search (Nocedal & Wright Alg. 3.1).
  double armijo_c1 = 1e-4;        ///< in (0, 0.5)
  double backtrack_factor = 0.5;  ///< step multiplier per backtrack, in (0, 1)
  int max_backtracks = 40;        ///< ≥ 1
  /// A full Newton step whose energy change is within this fraction of |Ψ| (round-off: Ψ
  /// is a sum of large terms, its change near the solution is below double precision) is
  /// accepted when it lowers ‖g_f‖∞. ≥ 0.
  double energy_roundoff = 1e-12;

  // Backward-Euler failsafe (paper §6.1).
  int stall_window = 3;                  ///< Newton steps of rule (c), ≥ 1
  double stall_energy_fraction = 1e-3;   ///< 0.1 % total energy reduction, ≥ 0
  double stall_gradient_fraction = 0.1;  ///< see "Deviation from the paper", in [0, 1]
  int backward_euler_steps = 5;          ///< steps per fallback, ≥ 1
  int max_fallbacks = 20;                ///< per solve, ≥ 0 (0: fail instead of falling back)
  double initial_time_step_s = 0.0;      ///< h at the first fallback [s]; 0 = automatic; ≥ 0
  double time_step_growth = 2.0;         ///< > 1
  int max_time_step_reductions = 40;     ///< halvings of h per backward-Euler step, ≥ 1

  /// Escapes from an indefinite stationary point along its lowest mode, per solve (header
  /// comment, "Saddles"), ≥ 0 (0: stop there with kIndefiniteStationary, as before).
  int max_saddle_escapes = 4;

  /// The K_ff factorisation (ordering, supernodal, refinement steps).
  SparseCholeskyOptions linear_solver;

  /// Ceres-style check: false with a message naming the first offending field.
  bool validate(std::string* error) const;
};

enum class EquilibriumStatus {
  kConverged,
  kMaxIterations,         ///< max_newton_iterations reached
  kFallbackLimit,         ///< a failsafe was needed but max_fallbacks were used up
  kFallbackFailed,        ///< backward Euler could not take a step (h reductions exhausted)
  kIndefiniteStationary,  ///< ‖g_f‖ converged but K_ff is not positive definite and no step
                          ///< along its lowest mode lowers Ψ (a degenerate minimum with
                          ///< singular K_ff), or max_saddle_escapes were used up
  kNonFinite,             ///< Ψ or its gradient is not finite at the initial guess
};
const char* to_string(EquilibriumStatus status);

/// What one solve() did.
struct EquilibriumSummary {
  EquilibriumStatus status = EquilibriumStatus::kNonFinite;
  bool converged = false;
  int newton_iterations = 0;       ///< accepted Newton steps
  int line_search_backtracks = 0;  ///< step halvings, Newton and backward Euler
  int fallbacks = 0;               ///< times the backward-Euler failsafe was entered
  int backward_euler_steps = 0;    ///< accepted backward-Euler steps in total
  int factorizations = 0;          ///< numeric factorisations (Newton and shifted, incl. failed)
  int failed_factorizations = 0;   ///< of which not positive definite
  int saddle_escapes = 0;          ///< steps off a saddle along its lowest mode
  int energy_evaluations = 0;      ///< calls of Discretization::energy
  double initial_energy_J = 0;
  double energy_J = 0;            ///< Ψ at the returned q
  double gradient_norm_N = 0;     ///< ‖g_f‖∞ at the returned q
  double force_scale_N = 0;       ///< F at the returned q
  double newton_decrement_J = 0;  ///< λ² at the last factorised Newton iterate (0 if none)
  bool at_roundoff_floor = false;  ///< converged by the round-off floor rule (header comment)
  /// converged with λ̃² from the previous iterate's factor (set_solution_factor_needed(false))
  bool decrement_from_previous_factor = false;
  double length_scale_m = 0;      ///< L used
  double time_step_s = 0;         ///< last backward-Euler h (0 when no fallback was taken)
  double wall_time_s = 0;
  std::string message;               ///< why it stopped
  std::string last_fallback_reason;  ///< what triggered the last failsafe (empty if none)
};

/// How solve_continuation starts each load step after the first (docs: header of this file).
enum class ContinuationPredictor {
  /// The previous equilibrium with the new fixed values.
  kPrevious,
  /// A linear extrapolation of the two previous equilibria, scaled by how far the fixed dofs
  /// moved (ρ = ⟨Δc_i, Δc_{i−1}⟩ / ‖Δc_{i−1}‖², or 1 when they did not move).
  kSecant,
  /// The equilibrium path's own tangent: the previous equilibrium moved by
  /// a_i = −K_ff⁻¹ K_fc Δc_i (the first-order response to the fixed dofs' move, from the factor
  /// at that equilibrium, one back-substitution), plus the second-order term ½ ρ (a_i − ρ a_{i−1})
  /// from the change of that response since the step before (ρ as above; exact to O(h³) for a
  /// proportional schedule, docs/solver.md "Continuation predictor").
  kTangent,
};

/// Options of EquilibriumSolver::solve_continuation.
struct ContinuationOptions {
  /// A predicted start is used only when its energy is lower than the plain guess (previous
  /// equilibrium with the new fixed values), so a poor prediction costs two energy evaluations
  /// and nothing else. Measured on the off-axis 32×48 strip: see docs/solver.md.
  ContinuationPredictor predictor = ContinuationPredictor::kTangent;
};

struct ContinuationSummary {
  bool completed = false;   ///< every step converged
  int steps_completed = 0;  ///< converged steps
  int failed_step = -1;     ///< first step that did not converge, −1 if none
  int total_newton_iterations = 0;
  int extrapolations_used = 0;            ///< steps started from the predicted guess
  std::vector<EquilibriumSummary> steps;  ///< one per attempted step
  double wall_time_s = 0;
  std::string message;
};

class EquilibriumSolver {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;
  /// Sets the fixed dofs of q (and anything else, e.g. gravity) for load step `step`.
  using LoadStepFunction = std::function<void(int step, Eigen::VectorXd* q)>;
  /// Called after each converged step with the equilibrium and its summary.
  using StepObserver =
      std::function<void(int step, const Eigen::VectorXd& q, const EquilibriumSummary& summary)>;

  /// `discretization` must outlive the solver; its parameters and gravity may change between
  /// solves (its Hessian pattern may not). `fixed_dofs` index q (see
  /// ConstrainedDofs::node_dofs to hold whole nodes). Throws std::invalid_argument for invalid
  /// options or dofs out of range.
  EquilibriumSolver(const Discretization& discretization, std::vector<int> fixed_dofs,
                    const EquilibriumOptions& options = {});

  /// Minimises Ψ over the free dofs of *q (#dofs), starting from *q; on return *q is the last
  /// iterate (the equilibrium when converged). Fixed entries are never written.
  EquilibriumSummary solve(Eigen::VectorXd* q);

  /// Solves one equilibrium per load step 0 … num_steps−1, each starting from the previous
  /// one (see ContinuationOptions); `apply_step` sets the step's fixed dofs in *q. Stops at
  /// the first step that does not converge (failed_step, message), leaving *q at its last
  /// iterate. The observer (optional) sees each converged step.
  ContinuationSummary solve_continuation(int num_steps, const LoadStepFunction& apply_step,
                                         Eigen::VectorXd* q, const StepObserver& observer = {},
                                         const ContinuationOptions& options = {});

  /// false: the caller will not ask for the factor at the solution, so convergence may be
  /// certified with the previous iterate's factor (header comment). Default true.
  void set_solution_factor_needed(bool needed) { solution_factor_needed_ = needed; }

  const EquilibriumOptions& options() const { return options_; }
  const ConstrainedDofs& dofs() const { return dofs_; }
  const Discretization& discretization() const { return discretization_; }
  /// L used by the decrement test [m].
  double length_scale_m() const { return length_scale_m_; }

  // Results of the last solve() ------------------------------------------------------------
  /// True when the last solve converged: the factor of K_ff at the returned q is available.
  bool has_solution_factorization() const { return factor_at_solution_; }
  /// The factor of K_ff at the solution (std::logic_error if !has_solution_factorization()).
  const SparseCholesky& factorization() const;
  /// Solves K_ff X = B (#free × m right-hand sides), reusing the factor at the solution, with
  /// the configured iterative refinement (paper Eq. 6: B = −∂g_f/∂k gives ∂q_f/∂k).
  void solve_free_free(const Eigen::MatrixXd& b, Eigen::MatrixXd* x,
                       SolveReport* report = nullptr) const;
  /// K_ff (#free × #free) and K_fc (#free × #fixed) at the solution [N/m]
  /// (std::logic_error if !has_solution_factorization()).
  const SparseMatrix& free_free_hessian() const;
  const SparseMatrix& free_fixed_hessian() const;
  /// ∂Ψ/∂q (#dofs) [N] at the q returned by the last solve.
  const Eigen::VectorXd& gradient() const { return gradient_; }
  /// ∂Ψ/∂q at the fixed dofs (#fixed, in dofs().fixed_dofs() order) [N]: the force each
  /// support applies to the cloth (the cloth pulls the support with the opposite force);
  /// discretization.hpp explains the tensile-tester sign.
  Eigen::VectorXd reaction() const;

 private:
  double evaluate(const Eigen::VectorXd& q, Eigen::VectorXd* gradient, SparseMatrix* hessian,
                  EquilibriumSummary* summary) const;
  void prepare_patterns();
  double automatic_time_step() const;
  double force_scale() const;
  // What a full step whose Ψ change is below the energy round-off is judged by: nothing
  // (Armijo only), ‖g_f‖∞ (accepted if it falls), or ‖g_f‖∞ with the round-off floor rule
  // (header comment) when ‖g_f‖∞ already passes its test at q.
  enum class RoundoffRule { kArmijoOnly, kByGradient, kByGradientOrFloor };
  enum class SearchResult { kAccepted, kFailed, kRoundoffFloor };
  // Backtracking Armijo search on Φ(α) = Ψ(q + αd) + quadratic·α² from Ψ(q) = psi with
  // slope g_fᵀd < 0; when accepted q, psi, gradient_ and hessian_ are at the accepted point
  // and *alpha is the step length; at the round-off floor q and psi are unchanged and
  // hessian_ no longer belongs to q.
  // `trial_hessian` false: the full step's trial is evaluated without the Hessian, and an
  // accepted full step leaves hessian_ (and K_ff's factor) at the previous iterate.
  SearchResult line_search(Eigen::VectorXd* q, double* psi, double slope, double quadratic,
                           RoundoffRule rule, bool trial_hessian, double* alpha,
                           EquilibriumSummary* summary);
  // At an iterate reached by a full step without the Hessian: both convergence tests, λ² from
  // the previous iterate's factor (header comment); the message when they pass, else empty.
  std::string converged_with_previous_factor(EquilibriumSummary* summary);
  bool backward_euler(Eigen::VectorXd* q, double* psi, double* time_step_s,
                      EquilibriumSummary* summary);
  // k_shifted_ = K_ff + σ M_f (k_ff_ as it is), factorised; false when not positive definite.
  bool factorise_shifted(double sigma, EquilibriumSummary* summary);
  // The saddle escape (header comment, "Saddles"): true when q moved off the stationary point
  // (Ψ lower, gradient_ and hessian_ at the new q).
  bool escape_saddle(Eigen::VectorXd* q, double* psi, EquilibriumSummary* summary);
  // K_ff + σ M_f factorised with the smallest σ ≥ 0 found that makes it positive definite, the
  // factor left in cholesky_ (k_shifted_ holding the matrix); false when none up to the
  // stiffest dof's is.
  bool factorise_shifted_above_lowest_mode(EquilibriumSummary* summary);
  // Inverse iteration with the factor of K_ff + σ M_f: the lowest mode v (M_f-normalised) and
  // its λ = vᵀ K_ff v.
  double lowest_mode(Eigen::VectorXd* v) const;
  // Ψ lowered along ±v (header comment); false when no length lowers it beyond round-off.
  bool step_along_mode(const Eigen::VectorXd& v, Eigen::VectorXd* q, double* psi, EquilibriumSummary* summary);

  // The steps of solve().
  // One Newton iterate's tests and direction: ‖g_f‖∞ against its tolerance, K_ff factorised,
  // and where it is positive definite d = −K_ff⁻¹g_f (direction_), its slope g_fᵀd and λ² = −slope.
  struct NewtonIterate {
    double gradient_norm = 0, force = 0, slope = 0;
    bool small_gradient = false, positive_definite = false, small_decrement = false;
    int failed_column = -1;  ///< where K_ff's factorisation failed (−1: it did not)
  };
  NewtonIterate newton_direction(double psi, EquilibriumSummary* summary);
  // M_f, the free dofs' lumped masses for backward Euler (a massless dof given the mean mass).
  void prepare_free_masses();
  // Converged at the round-off floor (header comment): the Hessian and K_fc made q's, `evidence`
  // the message's reason.
  EquilibriumSummary converged_at_floor(const Eigen::VectorXd& q, double* psi, const NewtonIterate& it,
                                        const std::string& evidence, std::chrono::steady_clock::time_point start,
                                        EquilibriumSummary* summary);
  // The iterate's end when it has one: converged, an indefinite stationary point, or the
  // iteration limit.
  std::optional<EquilibriumSummary> stop_at_iterate(const NewtonIterate& it, double psi,
                                                    std::chrono::steady_clock::time_point start,
                                                    EquilibriumSummary* summary);
  // One Newton step along direction_ (line search) from an iterate that did not stop. `done`
  // when it ends at the round-off floor (`energy_flat`: the stall window's Ψ changed by less than
  // energy_roundoff); else a non-empty `fallback_reason` when backward Euler must take over
  // (K_ff indefinite, an ascent direction, `stall`, or no decrease); else the step was taken.
  struct StepOutcome {
    std::optional<EquilibriumSummary> done;
    std::string fallback_reason;
  };
  StepOutcome newton_step(Eigen::VectorXd* q, double* psi, const NewtonIterate& it, bool energy_flat,
                          std::string stall, std::chrono::steady_clock::time_point start,
                          EquilibriumSummary* summary);
  // The backward-Euler failsafe for `reason`; the solve's end when the fallbacks are used up or
  // it fails.
  std::optional<EquilibriumSummary> fall_back(Eigen::VectorXd* q, double* psi, double* time_step_s,
                                              const std::string& reason,
                                              std::chrono::steady_clock::time_point start,
                                              EquilibriumSummary* summary);
  // The steps of solve_continuation(): the history its predictors read, the ratio ρ of this
  // step's clamp move to the last one's, and the predicted start of a step (false: none applies,
  // the plain start is solved from).
  struct ContinuationHistory;
  double step_ratio(ContinuationHistory& history) const;
  bool predict(ContinuationPredictor predictor, const Eigen::VectorXd& q, ContinuationHistory& history,
               Eigen::VectorXd* guess);
  // `summary` completed with the status, message, Ψ, the final ‖g_f‖∞ and F, and the wall time
  // since `start`.
  EquilibriumSummary finish(EquilibriumStatus status, std::string message, double psi,
                            std::chrono::steady_clock::time_point start, EquilibriumSummary* summary);

  const Discretization& discretization_;
  EquilibriumOptions options_;
  ConstrainedDofs dofs_;
  SparseCholesky cholesky_;
  double length_scale_m_ = 1.0;

  bool patterns_ready_ = false;
  bool factor_at_solution_ = false;
  // The factor and K_fc belong to the solution or to the iterate one converging Newton step
  // before it: good enough for the continuation's tangent predictor.
  bool predictor_factor_ = false;
  bool hessian_at_q_ = false;  // gradient_ and hessian_ belong to the current iterate
  bool solution_factor_needed_ = true;

  // Work buffers, sized once per pattern.
  SparseMatrix hessian_, k_ff_, k_fc_, k_shifted_;
  Eigen::VectorXd gradient_, trial_gradient_, q_trial_;
  Eigen::VectorXd g_f_, g_c_, direction_, mass_f_;
};

}  // namespace twill
