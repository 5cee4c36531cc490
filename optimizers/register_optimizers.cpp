#include "optimizers/register_optimizers.hpp"

#include "optimizers/bfgs.hpp"
#include "optimizers/gauss_newton.hpp"
#include "optimizers/ipopt_optimizer.hpp"
#include "optimizers/nlopt_optimizer.hpp"

namespace twill {

void register_optimizers(Registry& registry) {
  registry.category<OptimizerFactories>(registry_category::kOptimizer)
      .add_bound<Bfgs>("bfgs",
                       "dense BFGS with a strong Wolfe line search (Nocedal & Wright Alg. 6.1, 3.5, 3.6)",
                       bfgs_option_bindings())
      .add_bound<GaussNewton>("gauss-newton",
                              "Gauss-Newton on the residuals, with backtracking or Levenberg-Marquardt damping",
                              gauss_newton_option_bindings())
      .add_bound<IpoptOptimizer>("ipopt",
                                 "Ipopt interior-point method with a limited-memory Hessian approximation",
                                 ipopt_option_bindings())
      .add_bound<NloptOptimizer>("nlopt",
                                 "an NLopt algorithm chosen by its NLopt name (gradient-based or derivative-free)",
                                 nlopt_option_bindings());
}

}  // namespace twill
