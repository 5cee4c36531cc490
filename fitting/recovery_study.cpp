#include "fitting/recovery_study.hpp"

#include <stdexcept>

#include "core/discretization_registry.hpp"
#include "core/fit_objective.hpp"
#include "experiments/predictors.hpp"
#include "optimizers/optimizer.hpp"

namespace twill {

namespace {

Curve curve_of_degree(int degree) {
  switch (degree) {
    case 1: return Curve{{1.0}, {6.0}};
    case 2: return Curve{{0.6, 0.4}, {5.0, 120.0}};
    case 3: return Curve{{0.5, 0.3, 0.2}, {1.0, 40.0, 160.0}};
    default: throw std::invalid_argument("recovery: degree must be 1, 2 or 3");
  }
}

}  // namespace

RecoveryResult run_recovery(const RecoveryCase& c, const MaterialParameters& truth_base,
                            const Registry& registry) {
  if (c.test != "warp" && c.test != "bias")
    throw std::invalid_argument("recovery: test must be warp or bias, got '" + c.test + "'");
  const bool warp = c.test == "warp";
  MaterialParameters truth = truth_base;
  (warp ? truth.eta1 : truth.eta4) = curve_of_degree(c.degree);

  const ComponentChoice disc = registry.choice(registry_category::kDiscretization, c.discretization);
  const DiscretizationFactory factory = [&registry, disc](const StripSpec& s, const MaterialParameters& p) {
    return registry.create<DiscretizationFactories>(registry_category::kDiscretization, disc, s, p);
  };
  TensileSetup setup;
  setup.angle_deg = warp ? 90.0 : 45.0;
  setup.cells_across = c.cells_across;
  setup.cells_along = c.cells_along;
  const double max_mm = warp ? 6.0 : 16.0;
  std::vector<double> extensions;
  for (int i = 1; i <= c.points; ++i) extensions.push_back(max_mm * i / c.points);
  TensileExperiment generator(setup, factory, truth);
  const TensileCurve data = generator.run(extensions);
  if (!data.completed) throw std::runtime_error("recovery: generating the data failed: " + data.message);
  Eigen::VectorXd forces(static_cast<Eigen::Index>(extensions.size()));
  for (size_t i = 0; i < extensions.size(); ++i) forces[static_cast<Eigen::Index>(i)] = data.points[i].force_N;

  MaterialParameters start = truth;
  Curve& curve = warp ? start.eta1 : start.eta4;
  for (double& a : curve.alpha) a *= 0.85;
  for (size_t i = 1; i < curve.mu.size(); ++i) {
    curve.mu[i] += 0.05;
    curve.mu[0] -= 0.05;
  }
  (warp ? start.a11_Pa : start.G12_Pa) *= 1.2;
  // The canvas truth has a12 ≠ ½ min(a11, a22): a12 stays as given (untied) here.
  ParameterMap::Options map_options;
  map_options.tie_a12 = false;
  ParameterMap map(start, {warp ? "a11_Pa" : "G12_Pa", warp ? "eta1.*" : "eta4.*"}, map_options);
  auto predictor = std::make_shared<TensilePredictor>(c.test + " (simulated)", setup, factory, start,
                                                      extensions, forces);
  FitObjective objective(map, {predictor});
  const std::unique_ptr<Optimizer> optimizer = registry.create<OptimizerFactories>(
      registry_category::kOptimizer,
      registry.choice(registry_category::kOptimizer, c.optimizer, c.optimizer_overrides));
  const OptimizerResult r = optimizer->minimize(objective, map.initial_x());

  RecoveryResult out;
  out.status = to_string(r.status);
  out.message = r.message;
  out.iterations = r.summary.iterations;
  out.evaluations = r.summary.objective_evaluations;
  out.equilibrium_solves = objective.equilibrium_solves();
  out.wall_time_s = r.summary.wall_time_s;
  out.final_value = r.summary.final_value;
  const MaterialParameters fitted = map.parameters(r.x);
  objective.evaluate(r.x, nullptr);
  out.curve_error = objective.average_relative_error(0);
  out.stiffness_error = warp ? fitted.a11_Pa / truth.a11_Pa - 1.0 : fitted.G12_Pa / truth.G12_Pa - 1.0;
  if (!objective.last_failure().empty())
    out.message += " (failed evaluations: " + std::to_string(objective.failed_evaluations()) +
                   ", last: " + objective.last_failure() + ")";
  return out;
}

}  // namespace twill
