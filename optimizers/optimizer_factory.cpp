#include "optimizers/optimizer_factory.hpp"

#include "optimizers/bfgs.hpp"
#include "optimizers/gauss_newton.hpp"
#include "optimizers/ipopt_optimizer.hpp"
#include "optimizers/nlopt_optimizer.hpp"

namespace twill {
namespace {

OptimizerInfo info_of(const std::string& name) {
  for (auto& info : optimizer_catalogue())
    if (info.name == name) return info;
  std::string known;
  for (const auto& n : optimizer_names()) known.append(known.empty() ? "" : ", ").append(n);
  throw InputError({"", 0, "optimizer"}, "unknown optimizer '" + name + "'; known: " + known);
}

}  // namespace

std::vector<OptimizerInfo> optimizer_catalogue() {
  return {
      {"bfgs", "dense BFGS with a strong Wolfe line search (Nocedal & Wright Alg. 6.1, 3.5, 3.6)",
       option_schema(bfgs_option_bindings())},
      {"gauss-newton",
       "Gauss-Newton on the residuals, with backtracking or Levenberg-Marquardt damping",
       option_schema(gauss_newton_option_bindings())},
      {"ipopt", "Ipopt interior-point method with a limited-memory Hessian approximation",
       option_schema(ipopt_option_bindings())},
      {"nlopt", "an NLopt algorithm chosen by its NLopt name (gradient-based or derivative-free)",
       option_schema(nlopt_option_bindings())},
  };
}

std::vector<std::string> optimizer_names() {
  std::vector<std::string> names;
  for (const auto& info : optimizer_catalogue()) names.push_back(info.name);
  return names;
}

std::unique_ptr<Optimizer> make_optimizer(const std::string& name, const Options& resolved) {
  if (name == "bfgs")
    return std::make_unique<Bfgs>(options_from(bfgs_option_bindings(), resolved, name));
  if (name == "gauss-newton")
    return std::make_unique<GaussNewton>(
        options_from(gauss_newton_option_bindings(), resolved, name));
  if (name == "ipopt")
    return std::make_unique<IpoptOptimizer>(options_from(ipopt_option_bindings(), resolved, name));
  if (name == "nlopt")
    return std::make_unique<NloptOptimizer>(options_from(nlopt_option_bindings(), resolved, name));
  info_of(name);  // throws, listing the known names
  return nullptr;
}

std::unique_ptr<Optimizer> make_optimizer(const std::string& name) {
  return make_optimizer(name, optimizer_options(name));
}

Options optimizer_options(const std::string& name, const std::vector<std::string>& overrides) {
  const OptimizerInfo info = info_of(name);
  Options options = default_options(info.options, nullptr);
  apply_overrides(options, info.options, nullptr, overrides);
  return options;
}

void register_optimizers(Registry& registry) {
  auto& category = registry.category<OptimizerFactories>(registry_category::kOptimizer);
  for (auto& info : optimizer_catalogue()) {
    const std::string name = info.name;
    category.add(info.name, info.description, std::move(info.options),
                 [name](const Options& options) { return make_optimizer(name, options); });
  }
}

}  // namespace twill
