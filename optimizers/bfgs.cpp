#include "optimizers/bfgs.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "optimizers/box_line_search.hpp"

namespace twill {
namespace {

// The quasi-Newton direction with the variables in `held` fixed: p_F = −[(H⁻¹)_FF]⁻¹ g_F, the
// minimiser of the quadratic model over the free variables. With B = H⁻¹, the inverse of the
// block B_FF is the Schur complement H_FF − H_FH H_HH⁻¹ H_HF, so no inverse of H is formed.
// Using H_FF alone would ignore the curvature coupling to the held variables and converge only
// linearly along a bound.
Eigen::VectorXd reduced_direction(const Eigen::MatrixXd& H, const Eigen::VectorXd& g,
                                  const std::vector<int>& free, const std::vector<int>& held) {
  Eigen::VectorXd p = Eigen::VectorXd::Zero(g.size());
  if (held.empty()) return -(H * g);
  if (free.empty()) return p;
  const Eigen::MatrixXd H_ff = H(free, free), H_fh = H(free, held), H_hh = H(held, held);
  const Eigen::MatrixXd reduced = H_ff - H_fh * H_hh.llt().solve(H_fh.transpose());
  p(free) = -(reduced * g(free));
  return p;
}

// The inverse-Hessian approximation H and its scaling state (Nocedal & Wright §6.1).
struct InverseHessian {
  Eigen::MatrixXd H;
  double gamma = 1.0;   // latest yᵀs / yᵀy: the scale of H after a reset
  bool scaled = false;  // eq. 6.20 has been applied
  bool fresh = true;    // H is a multiple of I (no curvature pairs): a retry would not help

  explicit InverseHessian(Eigen::Index n) : H(Eigen::MatrixXd::Identity(n, n)) {}

  void reset() {
    H = gamma * Eigen::MatrixXd::Identity(H.rows(), H.cols());
    fresh = true;
  }

  // The step s and gradient change y of an accepted line search: γ from a pair with enough
  // curvature (H = γ I before the first update, eq. 6.20), then the update (eq. 6.17).
  void update(const Eigen::VectorXd& s, const Eigen::VectorXd& y, double skip_threshold) {
    const double ys = y.dot(s);
    if (ys > skip_threshold * s.norm() * y.norm()) {
      gamma = ys / y.squaredNorm();
      if (!scaled) {
        H = gamma * Eigen::MatrixXd::Identity(H.rows(), H.cols());
        scaled = true;
      }
    }
    if (bfgs_update(H, s, y, skip_threshold)) fresh = false;
  }
};

// The search direction at x: variables at a bound that the gradient pushes outward are held,
// blocked components dropped; once more from a reset H when it is not a descent direction
// (unless H is fresh already). Its slope gᵀp into *slope.
Eigen::VectorXd descent_direction(InverseHessian& inverse, const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                                  const Eigen::VectorXd& lower, const Eigen::VectorXd& upper, double* slope) {
  std::vector<int> held;
  const std::vector<int> free = free_variables(x, g, lower, upper, &held);
  Eigen::VectorXd p = reduced_direction(inverse.H, g, free, held);
  drop_blocked_components(x, lower, upper, p);
  *slope = g.dot(p);
  if (!(*slope < 0.0) && !inverse.fresh) {
    inverse.reset();
    p = reduced_direction(inverse.H, g, free, held);
    drop_blocked_components(x, lower, upper, p);
    *slope = g.dot(p);
  }
  return p;
}

}  // namespace

std::vector<OptionBinding<BfgsOptions>> bfgs_option_bindings() {
  const OptionConstraint unit_interval = [](OptionSpec& s) { s.greater_than(0.0).less_than(1.0); };
  auto bindings = common_option_bindings<BfgsOptions>();
  bindings.push_back(real_option<BfgsOptions>("c1", &BfgsOptions::c1,
                                              "strong Wolfe sufficient-decrease constant (c1 < c2)",
                                              unit_interval));
  bindings.push_back(real_option<BfgsOptions>(
      "c2", &BfgsOptions::c2, "strong Wolfe curvature constant (c1 < c2)", unit_interval));
  bindings.push_back(integer_option<BfgsOptions>(
      "max_line_search_evaluations", &BfgsOptions::max_line_search_evaluations,
      "evaluations allowed per line search", [](OptionSpec& s) { s.range(1, 1000); }));
  bindings.push_back(
      real_option<BfgsOptions>("update_skip_threshold", &BfgsOptions::update_skip_threshold,
                               "skip the BFGS update when y's <= this * norm(s) * norm(y)",
                               [](OptionSpec& s) { s.at_least(0.0).less_than(1.0); }));
  return bindings;
}

bool BfgsOptions::validate(std::string* error) const {
  if (!check_options(bfgs_option_bindings(), *this, error)) return false;
  if (!(c1 < c2)) {
    if (error) *error = fmt::format("c1 = {} must be smaller than c2 = {} (c1 < c2)", c1, c2);
    return false;
  }
  return true;
}

LineSearchOptions BfgsOptions::line_search() const {
  LineSearchOptions o;
  o.c1 = c1;
  o.c2 = c2;
  o.max_evaluations = max_line_search_evaluations;
  return o;
}

bool bfgs_update(Eigen::MatrixXd& H, const Eigen::VectorXd& s, const Eigen::VectorXd& y,
                 double epsilon) {
  const double ys = y.dot(s);
  if (!(ys > epsilon * s.norm() * y.norm())) return false;
  const double rho = 1.0 / ys;
  const Eigen::VectorXd Hy = H * y;
  // Expanded eq. 6.17: H − ρ (s (Hy)ᵀ + Hy sᵀ) + (ρ² yᵀHy + ρ) s sᵀ; O(n²) instead of O(n³).
  H.noalias() -= rho * (s * Hy.transpose() + Hy * s.transpose());
  H.noalias() += (rho * rho * y.dot(Hy) + rho) * (s * s.transpose());
  return true;
}

Bfgs::Bfgs(BfgsOptions options) : options_(std::move(options)) {
  require_valid(options_, "bfgs");
}

Options Bfgs::resolved_options() const { return options_of(bfgs_option_bindings(), options_); }

void Bfgs::run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const {
  LineSearchIterate at;
  if (!at.start(problem, std::move(x0), result)) return;
  const Eigen::VectorXd& x = at.x;
  const Eigen::VectorXd& g = at.g;
  auto finish = [&](OptimizerStatus status, std::string message) { at.finish(result, status, std::move(message)); };

  InverseHessian inverse(problem.dimension());
  int spent_on_failed_attempt = 0;  // evaluations of a failed search before the reset
  const LineSearchOptions line_search = options_.line_search();
  for (int k = 1;; ++k) {
    if (const auto stop = options_.iteration_stop(k, at.gradient_norm, problem.evaluations()))
      return finish(stop->status, stop->message);
    double dphi0 = 0;
    const Eigen::VectorXd p = descent_direction(inverse, x, g, problem.lower(), problem.upper(), &dphi0);
    if (!(dphi0 < 0.0))
      return finish(OptimizerStatus::stalled,
                    fmt::format("no descent direction at iteration {} (g'p = {:.3g})", k, dphi0));

    const double alpha_initial = inverse.scaled ? 1.0 : std::min(1.0, 1.0 / p.norm());
    const BoxLineSearch search =
        box_line_search(problem, x, at.f, dphi0, p, alpha_initial, line_search, options_.max_evaluations);
    const LineSearchOutcome& outcome = search.outcome;
    if (outcome.status == LineSearchOutcome::Status::failed) {
      if (problem.evaluations() >= options_.max_evaluations)
        return finish(
            OptimizerStatus::iteration_limit,
            fmt::format("max_evaluations = {} reached in a line search", options_.max_evaluations));
      if (!inverse.fresh) {  // retry the iteration from a reset H
        inverse.reset();
        spent_on_failed_attempt = outcome.evaluations;
        --k;
        continue;
      }
      return finish(OptimizerStatus::line_search_failed,
                    fmt::format("line search failed at iteration {}: {}", k, outcome.message));
    }
    inverse.update(search.x - x, search.gradient - g, options_.update_skip_threshold);
    problem.record_line_search(line_search_record(k, at.f, dphi0, outcome, spent_on_failed_attempt));
    spent_on_failed_attempt = 0;
    if (auto reason = at.advance(problem, search, options_)) return finish(OptimizerStatus::converged, *reason);
  }
}

}  // namespace twill
