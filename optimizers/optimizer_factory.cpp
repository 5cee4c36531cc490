#include "optimizers/optimizer_factory.hpp"

#include "optimizers/bfgs.hpp"
#include "optimizers/gauss_newton.hpp"
#include "optimizers/ipopt_optimizer.hpp"
#include "optimizers/nlopt_optimizer.hpp"

namespace twill {

std::vector<OptimizerInfo> optimizer_catalogue() {
  return {
      {"bfgs", "dense BFGS with a strong Wolfe line search (Nocedal & Wright Alg. 6.1, 3.5, 3.6)",
       describe_options(bfgs_option_bindings())},
      {"gauss-newton",
       "Gauss-Newton on the residuals, with backtracking or Levenberg-Marquardt damping",
       describe_options(gauss_newton_option_bindings())},
      {"ipopt", "Ipopt interior-point method with a limited-memory Hessian approximation",
       describe_options(ipopt_option_bindings())},
      {"nlopt", "an NLopt algorithm chosen by its NLopt name (gradient-based or derivative-free)",
       describe_options(nlopt_option_bindings())},
  };
}

std::vector<std::string> optimizer_names() {
  std::vector<std::string> names;
  for (const auto& info : optimizer_catalogue()) names.push_back(info.name);
  return names;
}

std::unique_ptr<Optimizer> make_optimizer(const std::string& name, const OptionValues& options) {
  if (name == "bfgs")
    return std::make_unique<Bfgs>(options_from_values(bfgs_option_bindings(), options));
  if (name == "gauss-newton")
    return std::make_unique<GaussNewton>(
        options_from_values(gauss_newton_option_bindings(), options));
  if (name == "ipopt")
    return std::make_unique<IpoptOptimizer>(options_from_values(ipopt_option_bindings(), options));
  if (name == "nlopt")
    return std::make_unique<NloptOptimizer>(options_from_values(nlopt_option_bindings(), options));
  std::string known;
  for (const auto& n : optimizer_names()) known.append(known.empty() ? "" : ", ").append(n);
  throw InputError({"", 0, "optimizer"}, "unknown optimizer '" + name + "'; known: " + known);
}

}  // namespace twill
