#include "optimizers/nlopt_optimizer.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>
#include <nlopt.hpp>
#include <optional>

namespace twill {
namespace {

struct Algorithm {
  const char* name;
  nlopt::algorithm id;
};

constexpr Algorithm kAlgorithms[] = {
    {"LD_LBFGS", nlopt::LD_LBFGS},
    {"LD_SLSQP", nlopt::LD_SLSQP},
    {"LD_MMA", nlopt::LD_MMA},
    {"LD_CCSAQ", nlopt::LD_CCSAQ},
    {"LD_TNEWTON_PRECOND_RESTART", nlopt::LD_TNEWTON_PRECOND_RESTART},
    {"LD_VAR2", nlopt::LD_VAR2},
    {"LN_BOBYQA", nlopt::LN_BOBYQA},
    {"LN_COBYLA", nlopt::LN_COBYLA},
    {"LN_NELDERMEAD", nlopt::LN_NELDERMEAD},
    {"LN_SBPLX", nlopt::LN_SBPLX},
};

nlopt::algorithm algorithm_id(const std::string& name) {
  for (const auto& a : kAlgorithms)
    if (name == a.name) return a.id;
  // Unreachable for validated options.
  throw std::logic_error("unsupported NLopt algorithm '" + name + "'");
}

// The objective NLopt calls. Catches everything: NLopt's C code must never see an exception
// other than nlopt::forced_stop, which its C++ wrapper turns into a graceful stop.
class Objective {
 public:
  struct Stop {
    OptimizerStatus status;
    std::string message;
    Eigen::VectorXd x;
    double value;
    double gradient_norm;
    bool non_finite_trial = false;  ///< the evaluation at x failed (see run())
  };

  Objective(CountedProblem& problem, const NloptOptions& options)
      : problem_(problem),
        options_(options),
        gradient_based_(options.algorithm.rfind("LD_", 0) == 0) {}

  static double call(const std::vector<double>& x, std::vector<double>& gradient, void* self) {
    return static_cast<Objective*>(self)->evaluate(x, gradient);
  }

  const std::string& error() const { return error_; }
  const std::optional<Stop>& stop() const { return stop_; }
  /// Forget the stop of the previous NLopt run (the best point is kept across restarts).
  void reset_stop() { stop_.reset(); }
  bool has_best() const { return best_x_.size() > 0; }
  const Eigen::VectorXd& best_x() const { return best_x_; }
  double best_value() const { return best_value_; }
  double best_gradient_norm() const { return best_gradient_norm_; }

 private:
  double evaluate(const std::vector<double>& x, std::vector<double>& gradient) {
    // A run we stopped gets no further evaluation: LD_TNEWTON_PRECOND_RESTART calls the
    // objective once more after a forced stop.
    if (!error_.empty() || stop_) throw nlopt::forced_stop();
    try {
      // NLopt's maxeval may let one more evaluation through (LD_LBFGS does); the budget is a
      // hard cap here, as for every optimiser.
      if (problem_.evaluations() >= options_.max_evaluations)
        stop_here(OptimizerStatus::iteration_limit,
                  fmt::format("max_evaluations = {} reached", options_.max_evaluations), best_x_,
                  best_value_, best_gradient_norm_);
      const Eigen::VectorXd xv =
          Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
      // Gradient-based algorithms (SLSQP) sometimes ask for the value alone; the gradient is
      // computed anyway, as it is cheap next to the value in twill (core/problem.hpp), and it
      // lets every improving point report its gradient norm.
      Eigen::VectorXd g;
      const double f = problem_.evaluate(xv, gradient_based_ ? &g : nullptr);
      if (!std::isfinite(f)) {
        stop_here(OptimizerStatus::failed, "evaluation failed (non-finite value) at a trial point",
                  xv, f, std::numeric_limits<double>::quiet_NaN());
      }
      double gradient_norm = std::numeric_limits<double>::quiet_NaN();
      if (gradient_based_) {
        if (!gradient.empty()) Eigen::Map<Eigen::VectorXd>(gradient.data(), g.size()) = g;
        gradient_norm = projected_gradient_norm(xv, g, problem_.lower(), problem_.upper());
      }
      if (!has_best() || f < best_value_) {
        const double step = has_best() ? (xv - best_x_).lpNorm<Eigen::Infinity>() : 0.0;
        best_x_ = xv;
        best_value_ = f;
        best_gradient_norm_ = gradient_norm;
        problem_.record_iteration(xv, f, gradient_norm, step);
      }
      if (gradient_norm <= options_.gradient_tolerance)
        stop_here(OptimizerStatus::converged,
                  fmt::format("gradient norm {:.3g} <= gradient_tolerance {:.3g}", gradient_norm,
                              options_.gradient_tolerance),
                  xv, f, gradient_norm);
      return f;
    } catch (const nlopt::forced_stop&) {
      throw;
    } catch (const std::exception& e) {
      error_ = e.what()[0] ? e.what() : "an exception without a message";
    } catch (...) {
      error_ = "an exception not derived from std::exception";
    }
    throw nlopt::forced_stop();
  }

  [[noreturn]] void stop_here(OptimizerStatus status, std::string message, const Eigen::VectorXd& x,
                              double value, double gradient_norm) {
    stop_ = Stop{status, std::move(message), x, value, gradient_norm, !std::isfinite(value)};
    throw nlopt::forced_stop();
  }

  CountedProblem& problem_;
  const NloptOptions& options_;
  bool gradient_based_;
  std::string error_;
  std::optional<Stop> stop_;
  Eigen::VectorXd best_x_;
  double best_value_ = std::numeric_limits<double>::quiet_NaN();
  double best_gradient_norm_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace

std::vector<std::string> supported_nlopt_algorithms() {
  std::vector<std::string> names;
  for (const auto& a : kAlgorithms) names.emplace_back(a.name);
  return names;
}

std::vector<OptionBinding<NloptOptions>> nlopt_option_bindings() {
  auto bindings = common_option_bindings<NloptOptions>();
  set_option_doc(bindings, "max_iterations",
                 "not used: NLopt has no iterations (max_evaluations is the budget)");
  bindings.push_back(choice_option<NloptOptions>("algorithm", &NloptOptions::algorithm,
                                                 supported_nlopt_algorithms(),
                                                 "the NLopt algorithm, by its NLopt name"));
  bindings.push_back(real_option<NloptOptions>(
      "initial_step", &NloptOptions::initial_step,
      "initial step of derivative-free algorithms in units of x (0: NLopt's choice)",
      [](OptionSpec& s) { s.at_least(0.0); }));
  bindings.push_back(integer_option<NloptOptions>(
      "vector_storage", &NloptOptions::vector_storage,
      "stored vectors of LD_LBFGS / LD_VAR2 / LD_TNEWTON (0: NLopt's choice)",
      [](OptionSpec& s) { s.range(0, 1000); }));
  return bindings;
}

bool NloptOptions::validate(std::string* error) const {
  // An unknown algorithm fails the choice check, whose message lists the supported names.
  return check_options(nlopt_option_bindings(), *this, error);
}

NloptOptimizer::NloptOptimizer(NloptOptions options) : options_(std::move(options)) {
  require_valid(options_, "nlopt");
}

Options NloptOptimizer::resolved_options() const {
  return options_of(nlopt_option_bindings(), options_);
}

namespace {

// Failed evaluations (core/problem.hpp: an equilibrium that does not converge, an invalid
// material) must be rejected points, but NLopt's algorithms cannot backtrack from one. The
// adapter therefore restarts NLopt from the best point inside a box of half-width r around
// it, r = half the distance to the failed trial (a trust region the library respects as
// bounds). When a boxed run ends on the box's edge (not on a real bound) the box is grown
// kBoxGrowth-fold and the run continues; at most kMaxRestarts restarts, all within
// max_evaluations.
constexpr int kMaxRestarts = 20;
constexpr double kBoxGrowth = 4;
// A point is on a box edge within this fraction of max(1, |x_i|).
constexpr double kEdgeTolerance = 1e-9;

std::vector<double> as_vector(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

struct Box {
  Eigen::VectorXd lo, hi;
};

// The problem's bounds (±∞ when it has none), cut to the box of half-width `radius` around
// `centre` when the radius is finite.
Box trust_box(const Box& bounds, const Eigen::VectorXd& centre, double radius) {
  if (!std::isfinite(radius)) return bounds;
  return {bounds.lo.cwiseMax((centre.array() - radius).matrix()), bounds.hi.cwiseMin((centre.array() + radius).matrix())};
}

// Whether `x` lies on an edge of `box` that is not one of the problem's own bounds.
bool on_artificial_edge(const Eigen::VectorXd& x, const Box& box, const Box& bounds) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const double tol = kEdgeTolerance * std::max(1.0, std::abs(x[i]));
    if ((x[i] - box.lo[i] <= tol && box.lo[i] > bounds.lo[i]) || (box.hi[i] - x[i] <= tol && box.hi[i] < bounds.hi[i]))
      return true;
  }
  return false;
}

// How one NLopt run ended, as far as the library says.
struct RunEnd {
  std::optional<nlopt::result> code;  ///< empty when the run threw
  std::string library_error;
  bool roundoff_limited = false;
};

// One NLopt run from `start` within `box` (bounds set when the problem has them or the box
// is a trust region), the evaluations left as its budget.
RunEnd run_once(const NloptOptions& options, CountedProblem& problem, Objective& objective, const Box& box,
                bool boxed, const Eigen::VectorXd& start) {
  const auto n = static_cast<unsigned>(problem.dimension());
  nlopt::opt opt(algorithm_id(options.algorithm), n);
  if (boxed) {
    opt.set_lower_bounds(as_vector(box.lo));
    opt.set_upper_bounds(as_vector(box.hi));
  }
  opt.set_ftol_rel(options.function_tolerance);
  opt.set_xtol_rel(options.step_tolerance);
  opt.set_maxeval(std::max(1, options.max_evaluations - problem.evaluations()));
  if (options.initial_step > 0.0) opt.set_initial_step(options.initial_step);
  if (options.vector_storage > 0) opt.set_vector_storage(static_cast<unsigned>(options.vector_storage));
  opt.set_min_objective(&Objective::call, &objective);

  std::vector<double> x = as_vector(start);
  double value = 0.0;
  objective.reset_stop();
  RunEnd end;
  try {
    end.code = opt.optimize(x, value);
  } catch (const nlopt::forced_stop&) {
    // Our objective asked for it; objective.stop() or objective.error() says why.
  } catch (const nlopt::roundoff_limited&) {
    end.roundoff_limited = true;
  } catch (const std::exception& e) {
    end.library_error = e.what();
  }
  // When our objective stopped the run, that is the reason, whatever NLopt then reports:
  // LD_LBFGS answers a forced stop inside its line search with a generic "nlopt failure".
  if (objective.stop()) end.library_error.clear();
  return end;
}

// The status and message of NLopt's own return code.
void describe_code(nlopt::result code, const NloptOptions& options, OptimizerResult& result) {
  switch (code) {
    case nlopt::SUCCESS:
    case nlopt::STOPVAL_REACHED:
      result.status = OptimizerStatus::converged;
      result.message = "NLopt " + options.algorithm + ": success";
      break;
    case nlopt::FTOL_REACHED:
      result.status = OptimizerStatus::converged;
      result.message = fmt::format("NLopt {}: relative function change <= function_tolerance {:.3g}",
                                   options.algorithm, options.function_tolerance);
      break;
    case nlopt::XTOL_REACHED:
      result.status = OptimizerStatus::converged;
      result.message =
          fmt::format("NLopt {}: relative step <= step_tolerance {:.3g}", options.algorithm, options.step_tolerance);
      break;
    case nlopt::MAXEVAL_REACHED:
    case nlopt::MAXTIME_REACHED:
      result.status = OptimizerStatus::iteration_limit;
      result.message = fmt::format("max_evaluations = {} reached", options.max_evaluations);
      break;
    default:
      result.status = OptimizerStatus::failed;
      result.message = fmt::format("NLopt {} returned code {}", options.algorithm, static_cast<int>(code));
      break;
  }
}

// The result from the best point and the last run's end: an exception in the problem, then
// our objective's stop, then round-off, a library failure, and last NLopt's code.
void finish(const Objective& objective, const RunEnd& end, const NloptOptions& options, OptimizerResult& result) {
  if (objective.has_best()) {
    result.x = objective.best_x();
    result.summary.final_value = objective.best_value();
    result.summary.final_gradient_norm = objective.best_gradient_norm();
  }
  if (!objective.error().empty()) {
    result.status = OptimizerStatus::failed;
    result.message = "the problem threw: " + objective.error();
  } else if (const auto& stop = objective.stop()) {
    result.status = stop->status;
    result.message = stop->message;
    if (stop->status != OptimizerStatus::failed) {
      result.x = stop->x;
      result.summary.final_value = stop->value;
      result.summary.final_gradient_norm = stop->gradient_norm;
    }
  } else if (end.roundoff_limited) {
    result.status = OptimizerStatus::stalled;
    result.message = "NLopt " + options.algorithm + ": halted by round-off";
  } else if (!end.library_error.empty() || !end.code) {
    result.status = OptimizerStatus::failed;
    result.message = "NLopt " + options.algorithm +
                     " failed: " + (end.library_error.empty() ? std::string("forced stop") : end.library_error);
  } else {
    describe_code(*end.code, options, result);
  }
}

}  // namespace

void NloptOptimizer::run(CountedProblem& problem, Eigen::VectorXd x0, OptimizerResult& result) const {
  const double inf = std::numeric_limits<double>::infinity();
  const Eigen::Index n = problem.dimension();
  const Box bounds = problem.bounded() ? Box{problem.lower(), problem.upper()}
                                       : Box{Eigen::VectorXd::Constant(n, -inf), Eigen::VectorXd::Constant(n, inf)};
  Objective objective(problem, options_);
  RunEnd end;
  double radius = inf;  // of the trust box (kMaxRestarts above)
  for (int attempt = 0; attempt <= kMaxRestarts; ++attempt) {
    const Eigen::VectorXd centre = objective.has_best() ? objective.best_x() : x0;
    const Box box = trust_box(bounds, centre, radius);
    end = run_once(options_, problem, objective, box, problem.bounded() || std::isfinite(radius), centre);
    if (!objective.error().empty() || !objective.has_best() || !end.library_error.empty()) break;
    const auto& stop = objective.stop();
    if (stop && stop->non_finite_trial) {
      radius = 0.5 * (stop->x - objective.best_x()).lpNorm<Eigen::Infinity>();
      if (!(radius > 0)) break;
      continue;
    }
    if (stop || !std::isfinite(radius) || !end.code) break;
    // Converged inside the box: done unless the best point sits on an artificial edge.
    if (!on_artificial_edge(objective.best_x(), box, bounds)) break;
    radius *= kBoxGrowth;
  }
  finish(objective, end, options_, result);
}

}  // namespace twill
