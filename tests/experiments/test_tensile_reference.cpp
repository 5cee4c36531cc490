// Tensile strips on the Catmull–Clark Kirchhoff–Love shell against the independent planar
// membrane references of ../shared/data/reference/ (README there: converged to ~0.1 % for
// warp/weft; off-axis recomputed on 2026-12-01 to convergence, Richardson with the observed
// order ≈ 1.1), and their convergence under refinement 8×12 → 16×24 → 32×48. The default
// fibre-strain treatment is the face-mean projection (docs/catmull_clark_kl.md §12); the
// paper's pointwise 4 × 4 treatment locks off-axis, which one case below keeps in view.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <string>

#include "core/dataset.hpp"
#include "core/params_io.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"
#include "experiments/reference_errors.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {
namespace {

const std::string kReference = std::string(TWILL_SHARED_DIR) + "/data/reference/";

struct Case {
  std::string material, label;
  double angle_deg;
  double tolerance;  // issue #3: 2 % warp/weft, 4 % off-axis
};
// Printed by gtest (ctest shows the parameter) instead of the struct's bytes.
void PrintTo(const Case& c, std::ostream* os) {
  *os << c.material << " " << c.label << " (" << c.angle_deg << " deg, tolerance " << c.tolerance << ")";
}

DiscretizationFactory catmull_clark(FibreStrain fibre_strain) {
  return [fibre_strain](const StripSpec& s, const MaterialParameters& p) -> std::unique_ptr<Discretization> {
    CatmullClarkKLOptions options;
    options.fibre_strain = fibre_strain;
    return std::make_unique<CatmullClarkKL>(s, p, options);
  };
}

/// Simulated force at every reference extension, at a resolution, with the default fibre
/// strain unless told (cached: several tests share the 32×48 curves).
const TensileCurve& simulate(const Case& c, int across, int along,
                             FibreStrain fibre_strain = CatmullClarkKLOptions{}.fibre_strain) {
  static std::map<std::string, TensileCurve> cache;
  const std::string key = c.material + c.label + std::to_string(across) + fibre_strain_name(fibre_strain);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  const MaterialParameters p = read_params_file(kReference + c.material + "/params.yaml");
  const TensileRun ref = read_tensile_run_csv(kReference + c.material + "/tensile-" + c.label + ".csv");
  TensileSetup setup;
  setup.angle_deg = c.angle_deg;
  setup.cells_across = across;
  setup.cells_along = along;
  TensileExperiment experiment(setup, catmull_clark(fibre_strain), p);
  return cache[key] = experiment.run(ref.extension_mm);
}

/// Largest relative deviation from the reference over points above 1 N.
double worst_relative_error(const Case& c, const TensileCurve& curve) {
  const TensileRun ref = read_tensile_run_csv(kReference + c.material + "/tensile-" + c.label + ".csv");
  EXPECT_EQ(curve.points.size(), ref.size());
  return std::abs(reference_errors(curve, ref.force_N).worst);
}

class TensileReference : public ::testing::TestWithParam<Case> {};

TEST_P(TensileReference, AgreesAt32x48) {
  const Case& c = GetParam();
  const TensileCurve& curve = simulate(c, 32, 48);
  ASSERT_TRUE(curve.completed) << curve.message;
  const double worst = worst_relative_error(c, curve);
  std::printf("[measured] %s %s (%.1f deg) 32x48: worst force error %.3f %% over points > 1 N, %.2f s, %d Newton its\n",
              c.material.c_str(), c.label.c_str(), c.angle_deg, 100 * worst, curve.wall_time_s,
              curve.newton_iterations);
  EXPECT_LT(worst, c.tolerance);
}

// The bars (2 % warp/weft, 4 % off-axis at every point above 1 N), all ten curves, at
// the paper's 32×48. Measured with the face-mean default (2026-12-01, corrected references):
// canvas −0.09 / −0.10 / −1.21 / … %, poplin −0.08 / −0.10 / −2.0 / … % (docs §12 table).
std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string label = info.param.label;
  std::replace(label.begin(), label.end(), '.', '_');
  return info.param.material + "_" + label;
}

const auto kAllCurves = [](const std::string& material) {
  return ::testing::Values(Case{material, "warp", 90, 0.02}, Case{material, "weft", 0, 0.02},
                           Case{material, "bias", 45, 0.04}, Case{material, "a22.5", 22.5, 0.04},
                           Case{material, "a67.5", 67.5, 0.04});
};
INSTANTIATE_TEST_SUITE_P(Canvas, TensileReference, kAllCurves("canvas"), case_name);
INSTANTIATE_TEST_SUITE_P(Poplin, TensileReference, kAllCurves("poplin"), case_name);

TEST(TensileReferenceLocking, PointwiseFibreStrainLocksInBias) {
  // Why the default is not the paper's 4 × 4 pointwise evaluation (docs §12): with the fibres
  // 367× stiffer than the shear (poplin) it is far too stiff at 32×48 in bias (measured
  // +11.6 %), while the face-mean default is within the 4 % bar on the same mesh.
  const Case c{"poplin", "bias", 45, 0.04};
  const TensileCurve& pointwise = simulate(c, 32, 48, FibreStrain::Pointwise);
  const TensileCurve& mean = simulate(c, 32, 48, FibreStrain::FaceMean);
  ASSERT_TRUE(pointwise.completed && mean.completed);
  const double locked = worst_relative_error(c, pointwise), relieved = worst_relative_error(c, mean);
  std::printf("[measured] poplin bias 32x48: pointwise %.2f %%, face-mean %.2f %%\n", 100 * locked, 100 * relieved);
  EXPECT_GT(locked, 2 * c.tolerance);
  EXPECT_LT(relieved, c.tolerance);
}

class TensileRefinement : public ::testing::TestWithParam<Case> {};

TEST_P(TensileRefinement, ForceConvergesUnderRefinement) {
  // Differences between successive resolutions at the largest common extension: they must
  // shrink, and the observed order log2(|f8 − f16| / |f16 − f32|) is reported.
  const Case& c = GetParam();
  const TensileCurve& f8 = simulate(c, 8, 12);
  const TensileCurve& f16 = simulate(c, 16, 24);
  const TensileCurve& f32 = simulate(c, 32, 48);
  ASSERT_TRUE(f8.completed && f16.completed && f32.completed);
  double d1 = 0, d2 = 0;
  for (size_t i = 0; i < f32.points.size(); ++i) {
    const double scale = std::abs(f32.points[i].force_N);
    if (scale <= 1.0) continue;
    d1 = std::max(d1, std::abs(f8.points[i].force_N - f16.points[i].force_N) / scale);
    d2 = std::max(d2, std::abs(f16.points[i].force_N - f32.points[i].force_N) / scale);
  }
  const double order = std::log2(d1 / d2);
  std::printf("[measured] %s %s: max rel. change 8x12->16x24 %.3e, 16x24->32x48 %.3e, observed order %.2f\n",
              c.material.c_str(), c.label.c_str(), d1, d2, order);
  EXPECT_LT(d2, d1);
  EXPECT_GT(order, 0.5);
}

INSTANTIATE_TEST_SUITE_P(Poplin, TensileRefinement,
                         ::testing::Values(Case{"poplin", "bias", 45, 0.04}, Case{"poplin", "a67.5", 67.5, 0.04}),
                         [](const auto& param_info) { return param_info.param.label == "a67.5" ? std::string("a67_5") : param_info.param.label; });

INSTANTIATE_TEST_SUITE_P(Canvas, TensileRefinement,
                         ::testing::Values(Case{"canvas", "warp", 90, 0.02}, Case{"canvas", "weft", 0, 0.02},
                                           Case{"canvas", "bias", 45, 0.04}),
                         [](const auto& param_info) { return param_info.param.label; });

}  // namespace
}  // namespace twill
