#pragma once
// Simulated forces of several runs at given strip angles at one level, for the stages that
// evaluate rather than fit (final curves, validation). Requests on the same test and angle
// share the strip, so one continuation over the union of their extensions serves them all (a
// quasistatic equilibrium does not depend on the loading path); the distinct curves run in
// parallel (TBB tasks, each with its own discretisation and solver; assembly inside nests in
// the same scheduler). A request gets nullopt when its curve stopped before its largest
// extension. Completed curves are kept: a later request on the same test, angle and level
// with the same parameters covered by a kept curve is answered from it (an offset search
// proposes an offset for one run that an earlier iteration simulated for another).
#include <Eigen/Core>
#include <map>
#include <optional>
#include <vector>

#include "experiments/tensile_strip.hpp"
#include "fitting/fit_context.hpp"

namespace twill {

class StripCurves {
 public:
  struct Request {
    const RunData* run;
    double angle_deg;
  };
  /// A run's simulated forces at its extensions [N], and dF/dθ [N/°] when asked for.
  struct Simulated {
    Eigen::VectorXd force_N, dforce_dangle;
  };

  /// Simulates every request at `level` with the context's parameters. With
  /// `angle_derivative`, dF/dθ is reported and each curve becomes its test's angle anchor:
  /// later requests of that test at other angles start each point from q + Δθ dq/dθ
  /// (TensileExperiment::run_from) instead of continuing.
  std::vector<std::optional<Simulated>> simulate(const FitContext& context, const std::vector<Request>& requests,
                                                 int level, bool angle_derivative = false);

  /// The strain field |Ẽ11|, |Ẽ22|, |Ẽ12| over the strip
  /// (TensileExperiment::material_strain_samples) of `test`'s angle anchor at its largest
  /// extension [mm]; nullopt when the test has no anchor. Where a validation strip leaves the
  /// fitted strain box, the model extrapolates (paper §3.2).
  struct StrainField {
    double extension_mm;
    std::vector<Eigen::Vector3d> samples;
  };
  std::optional<StrainField> anchor_strain_field(const TensileTest& test) const;

 private:
  /// A test's equilibria at one angle with dq/dθ per point.
  struct AngleAnchor {
    double angle_deg = 0;
    std::vector<double> extensions;
    std::vector<Eigen::VectorXd> q, dq_dangle;
    std::vector<Eigen::Vector3d> strain_samples;  ///< at the largest extension
  };
  /// Curve of `experiment` over `extensions`: warm-started from the test's angle anchor when
  /// it covers every extension (all points in parallel), by continuation otherwise or when a
  /// warm start fails.
  TensileCurve run_anchored(TensileExperiment& experiment, const TensileTest& test,
                            const std::vector<double>& extensions) const;

  /// A completed curve, with what it was simulated for (the reuse key and its coverage).
  struct KeptCurve {
    const TensileTest* test;
    double angle_deg;
    int level;
    MaterialParameters params;
    std::vector<TensilePoint> points;  ///< without states (anchors keep those)
  };
  /// The kept curve that answers `extensions` of `test` at `angle_deg` and `level` with
  /// `params`, or nullptr.
  const KeptCurve* kept(const TensileTest* test, double angle_deg, int level, const MaterialParameters& params,
                        const std::vector<double>& extensions) const;

  std::map<const TensileTest*, AngleAnchor> anchors_;
  std::vector<KeptCurve> kept_;
};

}  // namespace twill
