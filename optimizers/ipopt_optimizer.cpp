#include "optimizers/ipopt_optimizer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>
#include <deque>
#include <limits>
#include <optional>

namespace twill {
namespace {

using Ipopt::Index;
using Ipopt::Number;

constexpr double kIpoptInfinity = 1e19;  // Ipopt's default nlp_{lower,upper}_bound_inf
constexpr std::size_t kCacheSize = 8;
// Ipopt's nlp_scaling_max_gradient default, set explicitly: the first step's length below
// depends on it.
constexpr double kScalingMaxGradient = 100.0;

std::string status_name(Ipopt::ApplicationReturnStatus status) {
  switch (status) {
    case Ipopt::Solve_Succeeded:
      return "Solve_Succeeded";
    case Ipopt::Solved_To_Acceptable_Level:
      return "Solved_To_Acceptable_Level";
    case Ipopt::Infeasible_Problem_Detected:
      return "Infeasible_Problem_Detected";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "Search_Direction_Becomes_Too_Small";
    case Ipopt::Diverging_Iterates:
      return "Diverging_Iterates";
    case Ipopt::User_Requested_Stop:
      return "User_Requested_Stop";
    case Ipopt::Feasible_Point_Found:
      return "Feasible_Point_Found";
    case Ipopt::Maximum_Iterations_Exceeded:
      return "Maximum_Iterations_Exceeded";
    case Ipopt::Restoration_Failed:
      return "Restoration_Failed";
    case Ipopt::Error_In_Step_Computation:
      return "Error_In_Step_Computation";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "Maximum_CpuTime_Exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::Invalid_Problem_Definition:
      return "Invalid_Problem_Definition";
    case Ipopt::Invalid_Option:
      return "Invalid_Option";
    case Ipopt::Invalid_Number_Detected:
      return "Invalid_Number_Detected";
    case Ipopt::Unrecoverable_Exception:
      return "Unrecoverable_Exception";
    case Ipopt::NonIpopt_Exception_Thrown:
      return "NonIpopt_Exception_Thrown";
    case Ipopt::Insufficient_Memory:
      return "Insufficient_Memory";
    case Ipopt::Internal_Error:
      return "Internal_Error";
  }
  return "unknown Ipopt status " + std::to_string(static_cast<int>(status));
}

OptimizerStatus map_status(Ipopt::ApplicationReturnStatus status) {
  switch (status) {
    case Ipopt::Solve_Succeeded:
    case Ipopt::Solved_To_Acceptable_Level:
      return OptimizerStatus::converged;
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return OptimizerStatus::stalled;
    case Ipopt::Maximum_Iterations_Exceeded:
    case Ipopt::Maximum_CpuTime_Exceeded:
      return OptimizerStatus::iteration_limit;
    case Ipopt::Restoration_Failed:
      return OptimizerStatus::line_search_failed;
    default:
      return OptimizerStatus::failed;
  }
}

// The TNLP seen by Ipopt. Every override is noexcept in effect: guard() catches everything.
class ProblemTnlp : public Ipopt::TNLP {
 public:
  struct Evaluation {
    Eigen::VectorXd x, gradient;
    double value = 0.0;
  };
  struct Stop {
    OptimizerStatus status;
    std::string message;
  };

  ProblemTnlp(CountedProblem& problem, Eigen::VectorXd x0, const IpoptOptions& options)
      : problem_(problem), x0_(std::move(x0)), options_(options) {}

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = problem_.dimension();
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = 0;
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* x_l, Number* x_u, Index /*m*/, Number* /*g_l*/,
                       Number* /*g_u*/) override {
    return guard([&] {
      for (Index i = 0; i < n; ++i) {
        x_l[i] = std::max(problem_.lower()[i], -kIpoptInfinity);
        x_u[i] = std::min(problem_.upper()[i], kIpoptInfinity);
      }
      return true;
    });
  }

  bool get_starting_point(Index n, bool init_x, Number* x, bool init_z, Number* /*z_L*/,
                          Number* /*z_U*/, Index /*m*/, bool init_lambda,
                          Number* /*lambda*/) override {
    return guard([&] {
      if (!init_x || init_z || init_lambda) return false;  // no warm start offered
      std::copy(x0_.data(), x0_.data() + n, x);
      return true;
    });
  }

  bool eval_f(Index n, const Number* x, bool /*new_x*/, Number& obj_value) override {
    return guard([&] {
      const Evaluation* e = evaluation_at(n, x);
      if (!e) return false;
      obj_value = e->value;
      return true;
    });
  }

  bool eval_grad_f(Index n, const Number* x, bool /*new_x*/, Number* grad_f) override {
    return guard([&] {
      const Evaluation* e = evaluation_at(n, x);
      if (!e) return false;
      std::copy(e->gradient.data(), e->gradient.data() + n, grad_f);
      latest_gradient_ = *e;
      return true;
    });
  }

  bool eval_g(Index /*n*/, const Number* /*x*/, bool /*new_x*/, Index /*m*/,
              Number* /*g*/) override {
    return true;  // no constraints
  }

  bool eval_jac_g(Index /*n*/, const Number* /*x*/, bool /*new_x*/, Index /*m*/, Index /*nele_jac*/,
                  Index* /*iRow*/, Index* /*jCol*/, Number* /*values*/) override {
    return true;  // no constraints, so no Jacobian entries
  }

  void finalize_solution(Ipopt::SolverReturn /*status*/, Index n, const Number* x,
                         const Number* /*z_L*/, const Number* /*z_U*/, Index /*m*/,
                         const Number* /*g*/, const Number* /*lambda*/, Number obj_value,
                         const Ipopt::IpoptData* /*ip_data*/,
                         Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {
    guard([&] {
      final_x_ = Eigen::Map<const Eigen::VectorXd>(x, n);
      final_value_ = obj_value;
      return true;
    });
  }

  bool intermediate_callback(Ipopt::AlgorithmMode mode, Index iter, Number obj_value,
                             Number /*inf_pr*/, Number /*inf_du*/, Number /*mu*/, Number /*d_norm*/,
                             Number /*regularization_size*/, Number /*alpha_du*/,
                             Number /*alpha_pr*/, Index /*ls_trials*/,
                             const Ipopt::IpoptData* /*ip_data*/,
                             Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {
    return guard([&] {
      // A callback threw, or the evaluation budget is spent: stop as soon as Ipopt lets us.
      if (!error_.empty() || stop_) return false;
      if (!latest_gradient_) return true;
      const Evaluation& at = *latest_gradient_;
      const double gradient_norm =
          projected_gradient_norm(at.x, at.gradient, problem_.lower(), problem_.upper());
      const double step = previous_x_ ? (at.x - *previous_x_).lpNorm<Eigen::Infinity>() : 0.0;
      problem_.record_iteration(at.x, at.value, gradient_norm, step);
      const double previous_value = previous_value_;
      previous_x_ = at.x;
      previous_value_ = at.value;
      current_ = at;

      if (gradient_norm <= options_.gradient_tolerance) {
        stop_ = Stop{OptimizerStatus::converged,
                     fmt::format("gradient norm {:.3g} <= gradient_tolerance {:.3g}", gradient_norm,
                                 options_.gradient_tolerance)};
        return false;
      }
      const double change = std::abs(previous_value - obj_value);
      if (iter > 0 && mode == Ipopt::RegularMode &&
          change <= options_.function_tolerance *
                        std::max(std::abs(previous_value), std::abs(obj_value))) {
        stop_ = Stop{
            OptimizerStatus::converged,
            fmt::format("relative function change {:.3g} <= function_tolerance {:.3g}",
                        change / std::max({std::abs(previous_value), std::abs(obj_value), 1e-300}),
                        options_.function_tolerance)};
        return false;
      }
      return true;
    });
  }

  /// The B0 = σI that makes Ipopt's first quasi-Newton step, −(s·∇f(x0))/σ, no longer than 1
  /// in x (Euclidean), as BFGS's first step (bfgs.hpp): σ = max(1, s·‖∇f(x0)‖₂) with s the
  /// objective scale Ipopt's gradient-based scaling applies (1 without scaling). Ipopt's own
  /// B0 = I took a step of length 100 on the poplin bias (|∇f| 632, scaled to 100): its line
  /// search accepted 3 % of it, a jump of 3 in x (x = k/|k0|), into a basin at 62.9 % error where it
  /// converged (GN, BFGS and NLopt: 0.68 %). 1 when ∇f(x0) cannot be evaluated.
  double first_step_init_val(bool gradient_scaling) {
    double value = 1.0;
    guard([&] {
      const Evaluation* e = evaluation_at(static_cast<Index>(x0_.size()), x0_.data());
      if (!e) return false;
      const double inf_norm = e->gradient.lpNorm<Eigen::Infinity>();
      const double scale = gradient_scaling && inf_norm > kScalingMaxGradient ? kScalingMaxGradient / inf_norm : 1.0;
      value = std::max(1.0, scale * e->gradient.norm());
      return true;
    });
    return value;
  }

  const std::string& error() const { return error_; }
  const std::optional<Stop>& stop() const { return stop_; }
  const std::optional<Eigen::VectorXd>& final_x() const { return final_x_; }
  double final_value() const { return final_value_; }
  const std::optional<Evaluation>& current() const { return current_; }

  /// The cached evaluation at x, if any (no new evaluation).
  const Evaluation* cached(const Eigen::VectorXd& x) const {
    for (const auto& e : cache_)
      if (e.x == x) return &e;
    return nullptr;
  }

 private:
  template <class Body>
  bool guard(Body&& body) {
    try {
      return body();
    } catch (const std::exception& e) {
      if (error_.empty()) error_ = e.what()[0] ? e.what() : "an exception without a message";
    } catch (...) {
      if (error_.empty()) error_ = "an exception not derived from std::exception";
    }
    return false;
  }

  // Value and gradient at x, from the cache or one new evaluation; null when not finite.
  const Evaluation* evaluation_at(Index n, const Number* x) {
    const Eigen::Map<const Eigen::VectorXd> xv(x, n);
    const Evaluation* hit = cached(xv);
    if (!hit && problem_.evaluations() >= options_.max_evaluations) {
      if (!stop_)
        stop_ = Stop{OptimizerStatus::iteration_limit,
                     fmt::format("max_evaluations = {} reached", options_.max_evaluations)};
      return nullptr;
    }
    if (!hit) {
      Evaluation e;
      e.x = xv;
      e.value = problem_.evaluate(e.x, &e.gradient);
      cache_.push_front(std::move(e));
      if (cache_.size() > kCacheSize) cache_.pop_back();
      hit = &cache_.front();
    }
    return std::isfinite(hit->value) ? hit : nullptr;
  }

  CountedProblem& problem_;
  Eigen::VectorXd x0_;
  const IpoptOptions& options_;
  std::deque<Evaluation> cache_;
  std::optional<Evaluation> latest_gradient_, current_;
  std::optional<Eigen::VectorXd> previous_x_;
  double previous_value_ = std::numeric_limits<double>::quiet_NaN();
  std::optional<Eigen::VectorXd> final_x_;
  double final_value_ = std::numeric_limits<double>::quiet_NaN();
  std::optional<Stop> stop_;
  std::string error_;
};

}  // namespace

std::vector<OptionBinding<IpoptOptions>> ipopt_option_bindings() {
  auto bindings = common_option_bindings<IpoptOptions>();
  set_option_doc(bindings, "step_tolerance", "not used: Ipopt applies its own tiny-step test");
  bindings.push_back(integer_option<IpoptOptions>("print_level", &IpoptOptions::print_level,
                                                  "Ipopt's print_level (0: silent)",
                                                  [](OptionSpec& s) { s.range(0, 12); }));
  bindings.push_back(integer_option<IpoptOptions>(
      "limited_memory_max_history", &IpoptOptions::limited_memory_max_history,
      "number of L-BFGS correction pairs Ipopt keeps", [](OptionSpec& s) { s.range(1, 1000); }));
  bindings.push_back(choice_option<IpoptOptions>("mu_strategy", &IpoptOptions::mu_strategy,
                                                 {"monotone", "adaptive"},
                                                 "Ipopt's barrier-parameter update strategy"));
  bindings.push_back(choice_option<IpoptOptions>(
      "nlp_scaling_method", &IpoptOptions::nlp_scaling_method, {"gradient-based", "none"},
      "Ipopt's objective scaling (gradient-based scales f when its gradient exceeds 100)"));
  return bindings;
}

bool IpoptOptions::validate(std::string* error) const {
  return check_options(ipopt_option_bindings(), *this, error);
}

IpoptOptimizer::IpoptOptimizer(IpoptOptions options) : options_(std::move(options)) {
  require_valid(options_, "ipopt");
}

Options IpoptOptimizer::resolved_options() const {
  return options_of(ipopt_option_bindings(), options_);
}

namespace {

// Ipopt's options from twill's (false where Ipopt rejects one).
bool set_ipopt_options(Ipopt::OptionsList& ipopt, const IpoptOptions& options, ProblemTnlp& tnlp) {
  // Ipopt requires positive tolerances; a zero gradient_tolerance means "as tight as possible".
  const double tolerance = std::max(options.gradient_tolerance, 1e-300);
  bool ok = true;
  ok &= ipopt.SetStringValue("sb", "yes");  // no banner
  ok &= ipopt.SetIntegerValue("print_level", options.print_level);
  ok &= ipopt.SetStringValue("hessian_approximation", "limited-memory");
  ok &= ipopt.SetIntegerValue("limited_memory_max_history", options.limited_memory_max_history);
  ok &= ipopt.SetNumericValue("tol", tolerance);
  ok &= ipopt.SetNumericValue("dual_inf_tol", tolerance);
  // No "acceptable" early exit: tolerances mean what the options say.
  ok &= ipopt.SetIntegerValue("acceptable_iter", 0);
  ok &= ipopt.SetIntegerValue("max_iter", options.max_iterations);
  // Ipopt relaxes bounds by 1e-8 (relative) by default; twill's problems may be undefined
  // outside their box (e.g. a negative stiffness), so evaluations stay inside it.
  ok &= ipopt.SetNumericValue("bound_relax_factor", 0.0);
  ok &= ipopt.SetStringValue("mu_strategy", options.mu_strategy);
  ok &= ipopt.SetStringValue("nlp_scaling_method", options.nlp_scaling_method);
  ok &= ipopt.SetNumericValue("nlp_scaling_max_gradient", kScalingMaxGradient);
  ok &= ipopt.SetNumericValue("limited_memory_init_val",
                              tnlp.first_step_init_val(options.nlp_scaling_method == "gradient-based"));
  return ok;
}

// The status, message and point of a finished solve: a stop twill asked for (with its current
// point), else Ipopt's own status and final point; the best evaluated point where there is none.
void take_outcome(const ProblemTnlp& tnlp, Ipopt::ApplicationReturnStatus status, const CountedProblem& problem,
                  OptimizerResult& result) {
  if (tnlp.stop()) {
    result.status = tnlp.stop()->status;
    result.message = tnlp.stop()->message;
    if (tnlp.current()) {
      result.x = tnlp.current()->x;
    } else if (problem.has_best()) {
      result.x = problem.best_x();
    }
  } else {
    result.status = map_status(status);
    result.message = "Ipopt: " + status_name(status);
    if (tnlp.final_x()) {
      result.x = *tnlp.final_x();
    } else if (problem.has_best()) {
      result.x = problem.best_x();
    }
  }
}

// The final value and projected gradient norm at result.x. Ipopt can end at a trial point whose
// evaluation failed (no value, no gradient; seen on the poplin example, where it crashed here):
// the best evaluated point is reported instead.
void summarise_final_point(const ProblemTnlp& tnlp, const CountedProblem& problem, OptimizerResult& result) {
  const auto* at = tnlp.cached(result.x);
  if (at && !std::isfinite(at->value) && problem.has_best()) {
    result.x = problem.best_x();
    at = tnlp.cached(result.x);
  }
  if (at && std::isfinite(at->value) && at->gradient.size() == at->x.size()) {
    result.summary.final_value = at->value;
    result.summary.final_gradient_norm = projected_gradient_norm(at->x, at->gradient, problem.lower(), problem.upper());
  } else if (tnlp.final_x() && result.x == *tnlp.final_x()) {
    result.summary.final_value = tnlp.final_value();
  }
}

}  // namespace

void IpoptOptimizer::run(CountedProblem& problem, Eigen::VectorXd x0,
                         OptimizerResult& result) const {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  Ipopt::SmartPtr<ProblemTnlp> tnlp = new ProblemTnlp(problem, x0, options_);
  const bool options_ok = set_ipopt_options(*app->Options(), options_, *tnlp);
  const Ipopt::ApplicationReturnStatus init = app->Initialize();
  if (!options_ok || init != Ipopt::Solve_Succeeded) {
    result.status = OptimizerStatus::failed;
    result.message =
        "Ipopt rejected its options or failed to initialise (" + status_name(init) + ")";
    return;
  }

  const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(Ipopt::GetRawPtr(tnlp));

  if (!tnlp->error().empty()) {
    result.status = OptimizerStatus::failed;
    result.message = "the problem threw: " + tnlp->error();
    if (problem.has_best()) {
      result.x = problem.best_x();
      result.summary.final_value = problem.best_value();
    }
    return;
  }
  take_outcome(*tnlp, status, problem, result);
  summarise_final_point(*tnlp, problem, result);
}

}  // namespace twill
