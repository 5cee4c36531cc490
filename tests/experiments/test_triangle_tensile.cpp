// Tensile strips on the triangle shell (issue #4) against the independent planar-membrane
// references of ../shared/data/reference/ (README there: warp/weft converged to ~0.1 %,
// off-axis recomputed to convergence on 2026-12-01), their convergence under refinement,
// and the effect of the diagonal pattern on the bias strip (constant-strain triangles lock when
// stiff fibres cross the triangles' edges; docs/triangle_shell.md §9).
//
// Cheap on purpose (CI budget): resolutions up to 16×24 except the bias agreement and the
// locking and irregular refinement rows (32×48, ~2–4 s each). The full study up to 64×96 for every pattern is
// papers/triangle_transfer/ (its table is in docs/triangle_shell.md §9).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <ostream>
#include <string>

#include "core/dataset.hpp"
#include "core/params_io.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"
#include "experiments/reference_errors.hpp"
#include "experiments/tensile_strip.hpp"

namespace twill {
namespace {

const std::string kReference = std::string(TWILL_SHARED_DIR) + "/data/reference/";

struct Strip {
  std::string material, label;
  double angle_deg;
  TrianglePattern pattern = TrianglePattern::Alternating;
};

std::string describe(const Strip& s, int across, int along) {
  return s.material + " " + s.label + " " + to_string(s.pattern) + " " + std::to_string(across) + "x" +
         std::to_string(along);
}

/// Worst relative force error over reference points above 1 N (the criterion),
/// signed (+: stiffer than the reference). Cached: several tests share curves.
double worst_error(const Strip& s, int across, int along) {
  static std::map<std::string, double> cache;
  const std::string key = describe(s, across, along);
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  const MaterialParameters p = read_params_file(kReference + s.material + "/params.yaml");
  const TensileRun ref = read_tensile_run_csv(kReference + s.material + "/tensile-" + s.label + ".csv");
  TensileSetup setup;
  setup.angle_deg = s.angle_deg;
  setup.cells_across = across;
  setup.cells_along = along;
  TriangleShellOptions options;
  options.pattern = s.pattern;
  options.threads = 1;
  TensileExperiment experiment(
      setup,
      [options](const StripSpec& strip, const MaterialParameters& m) -> std::unique_ptr<Discretization> {
        return std::make_unique<TriangleShell>(strip, m, options);
      },
      p);
  const TensileCurve curve = experiment.run(ref.extension_mm);
  EXPECT_TRUE(curve.completed) << key << ": " << curve.message;
  EXPECT_EQ(curve.points.size(), ref.extension_mm.size());
  const double worst = reference_errors(curve, ref.force_N).worst;
  std::printf("[measured] triangle %s: worst force error %+.3f %% over points > 1 N, %.2f s\n", key.c_str(),
              100 * worst, curve.wall_time_s);
  return cache[key] = worst;
}

// Agreement at the coarsest resolution within the targets (2 % warp/weft, 4 % bias)
// for the default alternating pattern, against the corrected references (2026-12-01): warp
// and weft at 8×12 (measured canvas +0.88 / +0.94 %, poplin +0.78 / +0.87 %), bias at 32×48.
// Bias was asserted at 16×24 against the old off-axis curves, which were 1.7–5.2 % too stiff;
// against the corrected ones the alternating pattern is +4.21 % (canvas) and +8.19 % (poplin)
// there: linear triangles lock partly when fibres 75–367× stiffer than the shear cross them,
// and 16×24 is not yet enough. The bar is unchanged; the resolution it holds at is what moved.
struct AgreementCase {
  Strip strip;
  int across, along;
  double tolerance;
};
void PrintTo(const AgreementCase& c, std::ostream* os) {
  *os << describe(c.strip, c.across, c.along) << ", tolerance " << c.tolerance;
}

class TriangleTensileReference : public ::testing::TestWithParam<AgreementCase> {};

TEST_P(TriangleTensileReference, WithinTheTargetAtTheStudysResolution) {
  const AgreementCase& c = GetParam();
  EXPECT_LT(std::abs(worst_error(c.strip, c.across, c.along)), c.tolerance);
}

INSTANTIATE_TEST_SUITE_P(
    Alternating, TriangleTensileReference,
    ::testing::Values(AgreementCase{{"canvas", "warp", 90}, 8, 12, 0.02}, AgreementCase{{"canvas", "weft", 0}, 8, 12, 0.02},
                      AgreementCase{{"canvas", "bias", 45}, 32, 48, 0.04},
                      AgreementCase{{"poplin", "warp", 90}, 8, 12, 0.02}, AgreementCase{{"poplin", "weft", 0}, 8, 12, 0.02},
                      AgreementCase{{"poplin", "bias", 45}, 32, 48, 0.04},
                      // The cross pattern (both diagonals) locks less: +2.91 % at 16×24.
                      AgreementCase{{"canvas", "bias", 45, TrianglePattern::Cross}, 16, 24, 0.04}),
    [](const auto& param_info) {
      return param_info.param.strip.material + "_" + param_info.param.strip.label + "_" + to_string(param_info.param.strip.pattern);
    });

TEST(TriangleTensileRefinement, WarpWeftAndBiasConvergeFrom4x6To16x24) {
  // The worst error's change between successive resolutions shrinks; observed order
  // log2(|e4 − e8| / |e8 − e16|) measured 1.3 (warp/weft) and 1.65 (bias), asserted > 1 for
  // warp/weft and > 0.5 for bias (the linear triangles' membrane converges at first order in
  // h in the strain near the clamp corners; bias also carries the shear boundary layer).
  for (const Strip& s : {Strip{"canvas", "warp", 90}, Strip{"canvas", "weft", 0}, Strip{"canvas", "bias", 45}}) {
    const double e4 = worst_error(s, 4, 6), e8 = worst_error(s, 8, 12), e16 = worst_error(s, 16, 24);
    const double order = std::log2(std::abs(e4 - e8) / std::abs(e8 - e16));
    std::printf("[measured] %s: 4x6 %+.3f %%, 8x12 %+.3f %%, 16x24 %+.3f %%, observed order %.2f\n", s.label.c_str(),
                100 * e4, 100 * e8, 100 * e16, order);
    EXPECT_LT(std::abs(e8 - e16), std::abs(e4 - e8)) << s.label;
    EXPECT_GT(order, s.label == "bias" ? 0.5 : 1.0) << s.label;
  }
}

TEST(TriangleTensileLocking, OneDiagonalPatternsLockInBiasAndConvergeSlowly) {
  // Bias strip, canvas: fibres at ±45° to the strip. In `right` (`left`) every cell's diagonal
  // lies along one fibre family; the other family crosses the triangles, and a constant-strain
  // triangle cannot stretch it without extending that stiff fibre (locking). Measured worst
  // errors 8×12 / 16×24 / 32×48 (corrected reference): right +105 / +47.3 / +18.9 %, alternating
  // +10.9 / +4.2 / +1.85 %.
  // Asserted: the locked pattern is far stiffer at 16×24 (> 20 %, ten times alternating) and
  // still converges (its error falls by > 1.5× per refinement).
  const Strip right{"canvas", "bias", 45, TrianglePattern::Right};
  const Strip alternating{"canvas", "bias", 45};
  const double r8 = worst_error(right, 8, 12), r16 = worst_error(right, 16, 24), r32 = worst_error(right, 32, 48);
  const double a16 = worst_error(alternating, 16, 24);
  EXPECT_GT(r16, 0.20);
  EXPECT_GT(std::abs(r16), 10 * std::abs(a16));
  EXPECT_GT(r8 / r16, 1.5);
  EXPECT_GT(r16 / r32, 1.5);
}

TEST(TriangleTensileLocking, IrregularMeshNeedsOneMoreRefinementInBias) {
  // Perturbed alternating mesh (p = 0.2): the edges no longer follow the fibres, so it
  // partly locks: measured +7.57 / +3.40 % at 16×24 / 32×48 against the corrected reference
  // (alternating +4.21 % at 16×24). Within the 4 % target from 32×48 on.
  const Strip irregular{"canvas", "bias", 45, TrianglePattern::Irregular};
  const double i16 = worst_error(irregular, 16, 24), i32 = worst_error(irregular, 32, 48);
  EXPECT_GT(i16, worst_error(Strip{"canvas", "bias", 45}, 16, 24));
  EXPECT_LT(std::abs(i32), 0.04);
}

}  // namespace
}  // namespace twill
