#pragma once
// The optimiser interface: minimise a Problem (core/problem.hpp) from a starting point and
// return the solution, a status with a message, and a summary (Ceres' Solver::Summary).
//
// An optimiser that stops early returns a status and a message, never an exception
// (style.md §5); exceptions thrown by the problem are caught and reported as `failed`.
// Only broken preconditions throw std::invalid_argument from minimize(): x0 of the wrong size,
// non-finite or outside the bounds, inconsistent bounds, or a method that needs the
// least-squares form given a problem without it.
//
// Norms used throughout (and in the stopping tests):
//   gradient norm  ‖x − P(x − ∇f)‖∞, P the projection onto the box (= ‖∇f‖∞ without bounds);
//   step length    ‖x_{k+1} − x_k‖∞.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/option_binding.hpp"
#include "core/problem.hpp"
#include "core/registry.hpp"

namespace twill {

enum class OptimizerStatus {
  converged,           ///< a stopping tolerance was met (the message says which)
  stalled,             ///< no further progress possible although no tolerance was met
  iteration_limit,     ///< max_iterations or max_evaluations reached
  line_search_failed,  ///< no acceptable step along a descent direction
  failed,              ///< evaluation failed at x0, the problem threw, or the library failed
};
std::string to_string(OptimizerStatus status);

/// The data of one accepted line-search step along the direction p, φ(α) = f(x + α p)
/// (filled by line-search methods, one per accepted step, so tests can check the Wolfe
/// conditions: φ(α) ≤ φ(0) + c1 α φ'(0) and |φ'(α)| ≤ c2 |φ'(0)|).
struct LineSearchRecord {
  int iteration = 0;          ///< the iteration this step produced (≥ 1)
  double alpha = 0.0;         ///< accepted step length α
  double phi_0 = 0.0;         ///< φ(0) = f(x_k)
  double dphi_0 = 0.0;        ///< φ'(0) = ∇f(x_k)ᵀp  (< 0: a descent direction)
  double phi_alpha = 0.0;     ///< φ(α) = f(x_{k+1})
  double dphi_alpha = 0.0;    ///< φ'(α) = ∇f(x_{k+1})ᵀp
  int evaluations = 0;        ///< evaluations spent on this step (with a failed attempt
                              ///< before a Hessian reset, bfgs.hpp)
  bool step_limited = false;  ///< α is the largest step inside the bounds (curvature not required)
};

struct OptimizerSummary {
  int iterations = 0;             ///< accepted steps
  int objective_evaluations = 0;  ///< every call of evaluate() or residuals()
  int gradient_evaluations = 0;   ///< those calls that asked for the gradient / Jacobian
  double wall_time_s = 0.0;
  double final_value = 0.0;            ///< f(x) at the returned x (NaN if never finite)
  double final_gradient_norm = 0.0;    ///< projected-gradient ∞-norm at x; NaN when not known
                                       ///< without another evaluation (derivative-free methods)
  std::vector<IterationRecord> trace;  ///< iteration 0 (start) … last
  std::vector<LineSearchRecord> line_searches;  ///< line-search methods only
};

struct OptimizerResult {
  Eigen::VectorXd x;  ///< the solution (on failure: the best point evaluated, or x0)
  OptimizerStatus status = OptimizerStatus::failed;
  std::string message;
  OptimizerSummary summary;

  bool converged() const { return status == OptimizerStatus::converged; }
};

/// Stopping tolerances shared by every optimiser (each may add its own).
struct OptimizerOptions {
  /// Converged when ‖x − P(x − ∇f)‖∞ ≤ gradient_tolerance.
  double gradient_tolerance = 1e-8;
  /// Converged when |f_k − f_{k+1}| ≤ function_tolerance · max(|f_k|, |f_{k+1}|).
  double function_tolerance = 1e-12;
  /// Converged when ‖x_{k+1} − x_k‖∞ ≤ step_tolerance · (‖x_{k+1}‖∞ + step_tolerance).
  double step_tolerance = 1e-12;
  int max_iterations = 1000;
  /// Hard cap on objective evaluations (each may be expensive, see core/problem.hpp).
  int max_evaluations = 5000;

  /// Ceres IsValid style: false with the violated constraint in `error` (may be null).
  bool validate(std::string* error) const;

  /// The stopping tests every iterative method makes at the top of iteration k (≥ 1), in this
  /// order: gradient tolerance (converged), max_iterations, max_evaluations (iteration_limit).
  /// nullopt when none applies; otherwise the status and the message for the result.
  struct Stop {
    OptimizerStatus status;
    std::string message;
  };
  std::optional<Stop> iteration_stop(int k, double gradient_norm, int evaluations) const;
};

/// Bindings of the common options, to prepend to each optimiser's own.
template <class Struct>
std::vector<OptionBinding<Struct>> common_option_bindings() {
  const OptionConstraint non_negative = [](OptionSpec& s) { s.at_least(0.0); };
  const OptionConstraint positive = [](OptionSpec& s) { s.at_least(1); };
  return {
      real_option<Struct>("gradient_tolerance", &Struct::gradient_tolerance,
                          "stop when the projected-gradient inf-norm is at most this",
                          non_negative),
      real_option<Struct>("function_tolerance", &Struct::function_tolerance,
                          "stop when the relative change of f in one iteration is at most this",
                          non_negative),
      real_option<Struct>(
          "step_tolerance", &Struct::step_tolerance,
          "stop when the step inf-norm is at most this times (inf-norm of x + this)", non_negative),
      integer_option<Struct>("max_iterations", &Struct::max_iterations,
                             "maximum number of iterations", positive),
      integer_option<Struct>("max_evaluations", &Struct::max_evaluations,
                             "maximum number of objective evaluations (a hard cap)", positive),
  };
}

/// The Problem as one minimize() call sees it: counts evaluations into the summary, keeps the
/// best finite point, records the trace and forwards progress to Problem::on_iteration().
/// Bounds are read once (they are fixed for a run).
class CountedProblem {
 public:
  CountedProblem(Problem& problem, OptimizerSummary& summary);

  int dimension() const { return dimension_; }
  const Eigen::VectorXd& lower() const { return lower_; }
  const Eigen::VectorXd& upper() const { return upper_; }
  bool bounded() const { return bounded_; }
  bool has_residuals() const { return problem_.has_residuals(); }

  /// Problem::evaluate, counted.
  double evaluate(const Eigen::VectorXd& x, Eigen::VectorXd* gradient);
  /// Problem::residuals, counted; returns f = Σ r² (NaN if any r_i is non-finite) and, when
  /// `gradient` is non-null (requires `jacobian`), ∇f = 2 Jᵀr.
  double residuals(const Eigen::VectorXd& x, Eigen::VectorXd* r, Eigen::MatrixXd* jacobian,
                   Eigen::VectorXd* gradient);

  int evaluations() const { return summary_.objective_evaluations; }
  bool has_best() const;
  const Eigen::VectorXd& best_x() const { return best_x_; }
  double best_value() const { return best_value_; }

  /// Appends to the trace (iteration = trace size) and calls Problem::on_iteration.
  void record_iteration(const Eigen::VectorXd& x, double value, double gradient_norm,
                        double step_length);
  void record_line_search(const LineSearchRecord& record);

 private:
  void note(const Eigen::VectorXd& x, double value);

  Problem& problem_;
  OptimizerSummary& summary_;
  int dimension_;
  Eigen::VectorXd lower_, upper_;
  bool bounded_;
  Eigen::VectorXd best_x_;
  double best_value_;
};

/// ‖x − P(x − g)‖∞ with P the projection onto [lower, upper].
double projected_gradient_norm(const Eigen::VectorXd& x, const Eigen::VectorXd& gradient,
                               const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);

/// The variables a step may move: all but those at a bound that the gradient pushes outward
/// (x_i = lower_i and g_i > 0, or x_i = upper_i and g_i < 0), which go to `held` when given.
std::vector<int> free_variables(const Eigen::VectorXd& x, const Eigen::VectorXd& gradient,
                                const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                                std::vector<int>* held = nullptr);

/// Zeroes the components of direction p that would leave the box at a bound x already
/// touches (x_i = lower_i and p_i < 0, or x_i = upper_i and p_i > 0).
void drop_blocked_components(const Eigen::VectorXd& x, const Eigen::VectorXd& lower,
                             const Eigen::VectorXd& upper, Eigen::VectorXd& p);

/// The largest α ≥ 0 with lower ≤ x + α p ≤ upper (+∞ when no bound limits p).
double max_feasible_step(const Eigen::VectorXd& x, const Eigen::VectorXd& p,
                         const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);

/// x + α p projected onto the box, with components that land within a relative 1e-12 of a
/// bound put exactly on it (so drop_blocked_components() sees them as touching it).
Eigen::VectorXd take_step(const Eigen::VectorXd& x, const Eigen::VectorXd& p, double alpha,
                          const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);

/// The common stopping tests after an accepted step x_prev → x: a message naming the test met
/// (gradient, then function change, then step), or nullopt.
std::optional<std::string> check_convergence(const OptimizerOptions& options, double f_prev,
                                             double f, const Eigen::VectorXd& x_prev,
                                             const Eigen::VectorXd& x, double gradient_norm);

class Optimizer;

/// The registry category of optimisers (core/registry.hpp): a factory receives only its
/// resolved options. register_optimizers.hpp's register_optimizers() fills it.
using OptimizerFactories = FactoryCategory<Optimizer>;

class Optimizer {
 public:
  virtual ~Optimizer() = default;

  /// Registered name, e.g. "bfgs".
  virtual std::string name() const = 0;
  /// Every option with its current value (defaults included): the resolved config to save
  /// next to a result (core/config.hpp's write_config_file).
  virtual Options resolved_options() const = 0;
  /// True when the method works on Problem::residuals() (least-squares methods).
  virtual bool requires_residuals() const { return false; }

  /// Minimises `problem` from x0 (see the file comment for what throws and what returns a
  /// status). An Optimizer holds only its options, so one object may serve several threads,
  /// each with its own Problem (Ipopt 3.11's own thread safety with MUMPS is not established:
  /// run parallel Ipopt fits in separate processes).
  OptimizerResult minimize(Problem& problem, Eigen::VectorXd x0) const;

 protected:
  /// The method itself: fills result.x, status, message, summary.final_value and
  /// final_gradient_norm; the counters, trace and wall time are filled by minimize() and the
  /// CountedProblem. x0 is finite and inside the bounds.
  virtual void run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const = 0;
};

}  // namespace twill
