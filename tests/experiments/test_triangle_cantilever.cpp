// The triangle shell's cantilever (issue #4, docs/triangle_shell.md §10): the 41.5° overhang
// against the Catmull–Clark shell for the same parameters (acceptance: within 3 %), and the
// mesh-scale mode that made the hinge models fail it.
//
// The hinge models (hinge_model = cylinders, directional) measure one hinge angle per edge: on
// the alternating mesh a checkerboard z-field, δ(−1)^{i+j}, bends every hinge across the strip
// by the same angle as a uniform curvature does, so a smooth bend plus a checkerboard of
// amplitude −h²K/4 leaves those hinges flat and the strip is about half as stiff as the plate.
// The shape operator (default) builds each face's curvature from the hinges with a split that
// telescopes between neighbours, so no mesh-scale field changes the mean curvature
// (test_triangle_shell_shape_operator.cpp), and its overhang agrees with Catmull–Clark.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/params_io.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"
#include "discretizations/triangle_shell/strip_triangulation.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"
#include "experiments/cantilever.hpp"
#include "tests/discretizations/test_triangle_shell_support.hpp"
#include "tests/support/test_materials.hpp"

namespace twill {
namespace {

TEST(TriangleCantilever, CheckerboardCancelsTheBendAcrossTheStripForHingeModels) {
  // The D1388 strip at the cantilever resolution (25 mm × 30 mm, 8 × 28 cells), warp along x.
  const StripSpec s = triangle_shell_test::checkerboard_strip();
  for (HingeModel model : {HingeModel::Cylinders, HingeModel::Directional}) {
    TriangleShellOptions o;
    o.hinge_model = model;
    o.threads = 1;
    // Canvas-like orthotropic StVK (a12 = 1.1e7, cutoffs off).
    TriangleShell shell(s, triangle_shell_test::physical_parameters(), o);
    const StripTriangulation& t = shell.triangulation();
    const double K = 1.0, hx = s.length_m / s.cells_along, hy = s.width_m / s.cells_across;
    // z = ½ K x² (small: slopes ≤ 0.03) plus δ(−1)^{i+j} on grid vertex (i, j).
    auto state = [&](double delta) {
      Eigen::VectorXd q = shell.rest_positions();
      for (int v = 0; v < shell.num_nodes(); ++v) {
        const double x = t.base_xy(v, 0), y = t.base_xy(v, 1) + 0.5 * s.width_m;
        const long i = std::lround(x / hx), j = std::lround(y / hy);
        q[3 * v + 2] = 0.5 * K * x * x + ((i + j) % 2 == 0 ? delta : -delta);
      }
      return q;
    };
    // Hinges across the strip: edges along y (normal along x, the warp bending direction).
    std::vector<size_t> across;
    for (size_t h = 0; h < t.hinges.size(); ++h)
      if (std::abs(t.base_xy(t.hinges[h].v[0], 0) - t.base_xy(t.hinges[h].v[1], 0)) < 1e-12)
        across.push_back(h);
    ASSERT_FALSE(across.empty());
    const double delta = -K * hx * hx / 4;
    const Eigen::VectorXd smooth = shell.hinge_energies(state(0.0));
    const Eigen::VectorXd relaxed = shell.hinge_energies(state(delta));
    double across_smooth = 0, across_relaxed = 0;
    for (size_t h : across) {
      across_smooth += smooth[static_cast<Eigen::Index>(h)];
      across_relaxed += relaxed[static_cast<Eigen::Index>(h)];
    }
    std::printf("[measured] %s: hinges across the strip carry %.3e J smooth, %.3e J with the "
                "checkerboard; total hinge energy %.3e -> %.3e J\n",
                to_string(model).c_str(), across_smooth, across_relaxed, smooth.sum(),
                relaxed.sum());
    // The checkerboard unbends every hinge across the strip (to second order in the slopes) …
    EXPECT_LT(across_relaxed, 1e-4 * across_smooth) << to_string(model);
    // … and the smooth bend is not the cheapest state with this mean curvature. The energy is
    // quadratic in the checkerboard fraction f: (1 − f)² A + f² B with A the smooth energy
    // (all in the hinges across) and B the full checkerboard's; its minimum AB/(A + B) at
    // f = A/(A + B) is the effective bending stiffness relative to the plate's.
    const double A = smooth.sum(), B = relaxed.sum(), f = A / (A + B);
    const double mixed = shell.hinge_energies(state(f * delta)).sum();
    std::printf("[measured] %s: best checkerboard fraction %.3f, bending energy / smooth %.3f\n",
                to_string(model).c_str(), f, mixed / A);
    EXPECT_NEAR(mixed, A * B / (A + B), 1e-3 * A) << to_string(model);
    EXPECT_LT(mixed, 0.9 * A) << to_string(model);
  }
}

DiscretizationFactory catmull_clark() {
  return [](const StripSpec& s, const MaterialParameters& p) -> std::unique_ptr<Discretization> {
    return std::make_unique<CatmullClarkKL>(s, p);
  };
}

DiscretizationFactory triangle_shell(StripEnds clamp_hinges) {
  TriangleShellOptions o;  // shape-operator bending, alternating pattern
  o.clamp_hinges = clamp_hinges;
  o.threads = 1;
  return [o](const StripSpec& s, const MaterialParameters& p) -> std::unique_ptr<Discretization> {
    return std::make_unique<TriangleShell>(s, p, o);
  };
}

TEST(TriangleCantilever, OverhangWithinThreePercentOfCatmullClark) {
  // Issue #4: "overhang at 41.5° within 3 % of the Catmull–Clark result for the same
  // parameters". Canvas reference parameters, warp along the strip, the bend test's default
  // resolution 4×64 for both. Measured: Catmull–Clark 86.16 mm; triangle shell 85.22 mm
  // (−1.09 %) with the default clamp (first cell column held) and 84.22 mm (−2.24 %) with clamp
  // hinges. Under refinement the triangle shell settles at 84.72 mm (16×128, every pattern),
  // Catmull–Clark comes down from above (85.20 mm at 16×128): docs/triangle_shell.md §10.
  const MaterialParameters p =
      read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/canvas/params.yaml");
  CantileverSetup setup;  // 90°, 25 mm wide, 4 × 64
  const OverhangSearchResult cc = CantileverExperiment(setup, catmull_clark(), p).find_overhang();
  ASSERT_TRUE(cc.converged) << cc.message;
  for (StripEnds clamp : {StripEnds::None, StripEnds::Start}) {
    const OverhangSearchResult tri =
        CantileverExperiment(setup, triangle_shell(clamp), p).find_overhang();
    ASSERT_TRUE(tri.converged) << tri.message;
    const double error = tri.overhang_mm / cc.overhang_mm - 1;
    std::printf("[measured] canvas 4x64, clamp_hinges=%s: triangle %.3f mm (%.2f s), "
                "Catmull-Clark %.3f mm (%.2f s): %+.2f %%\n",
                to_string(clamp).c_str(), tri.overhang_mm, tri.wall_time_s, cc.overhang_mm,
                cc.wall_time_s, 100 * error);
    EXPECT_NEAR(tri.chord_angle_deg, kD1388ChordAngle_deg, 1e-3);
    EXPECT_LT(std::abs(error), 0.03) << "clamp_hinges=" << to_string(clamp);
  }
}

TEST(TriangleCantilever, LinearMaterialMatchesPeirce) {
  // With a12 = 0 a strip and a plate have the same rigidity, and Peirce's L = 2 (B/w)^{1/3}
  // is exact to 0.02 % for the inextensible elastica (cantilever.hpp): an independent
  // reference. Clamp hinges (the clamp at the platform edge, not one cell in), 4 × 64:
  // measured 85.82 mm against 85.81 mm (+0.01 %; the same to 0.03 % from 4×32 to 16×128,
  // where Catmull–Clark is +1.7 … +0.4 %). Tolerance 0.5 %: Peirce's 0.02 % plus the
  // membrane's extensibility and the finite fold angles.
  MaterialParameters p = testing::canvas_stvk();
  p.a12_Pa = 0.0;
  p.cutoffs = Cutoffs{};  // the defaults (compression extrapolated from zero strain), as before
  CantileverSetup setup;
  CantileverExperiment experiment(setup, triangle_shell(StripEnds::Start), p);
  const double peirce = experiment.peirce_overhang_mm(experiment.bending_rigidity_plate_Nm());
  const OverhangSearchResult r = experiment.find_overhang();
  ASSERT_TRUE(r.converged) << r.message;
  const double error = r.overhang_mm / peirce - 1;
  std::printf("[measured] StVK a12 = 0, 4x64: triangle %.3f mm, Peirce %.3f mm: %+.2f %%\n",
              r.overhang_mm, peirce, 100 * error);
  EXPECT_LT(std::abs(error), 0.005);
}

}  // namespace
}  // namespace twill
