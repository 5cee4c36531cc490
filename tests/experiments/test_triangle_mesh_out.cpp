// `twill simulate --mesh-out FILE.obj` (issue #4): the OBJ written for an equilibrium of every
// registered discretisation holds surface_mesh()'s triangles, which tile the strip, at the
// equilibrium's positions.
// The check is the path the command takes (TensileExperiment observer → surface_mesh →
// write_obj) on a 2-point tensile curve, read back from the file.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/obj_writer.hpp"
#include "core/params_io.hpp"
#include "core/discretization_registry.hpp"
#include "experiments/tensile_strip.hpp"
#include "tests/support/program_registry.hpp"

namespace twill {
namespace {

struct Obj {
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
};

Obj read_obj(const std::string& path) {
  std::ifstream in(path);
  std::vector<Eigen::Vector3d> v;
  std::vector<Eigen::Vector3i> f;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      Eigen::Vector3d p;
      ls >> p.x() >> p.y() >> p.z();
      v.push_back(p);
    } else if (tag == "f") {
      Eigen::Vector3i t;
      ls >> t.x() >> t.y() >> t.z();
      f.push_back(t - Eigen::Vector3i::Ones());  // OBJ is one-based
    }
  }
  Obj o;
  o.V.resize(static_cast<Eigen::Index>(v.size()), 3);
  o.F.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (size_t i = 0; i < v.size(); ++i) o.V.row(static_cast<Eigen::Index>(i)) = v[i].transpose();
  for (size_t i = 0; i < f.size(); ++i) o.F.row(static_cast<Eigen::Index>(i)) = f[i].transpose();
  return o;
}

class MeshOut : public ::testing::TestWithParam<std::string> {};

TEST_P(MeshOut, ObjHoldsTheEquilibrium) {
  const MaterialParameters p =
      read_params_file(std::string(TWILL_SHARED_DIR) + "/data/reference/canvas/params.yaml");
  const std::string name = GetParam();
  TensileSetup setup;
  setup.angle_deg = 45;  // bias: a non-uniform equilibrium (the strip narrows at mid-gauge)
  setup.cells_across = 4;
  setup.cells_along = 6;
  TensileExperiment experiment(
      setup,
      [name](const StripSpec& s, const MaterialParameters& m) {
        return testing::create_registered<DiscretizationFactories>(registry_category::kDiscretization, name, {}, s, m);
      },
      p);
  Eigen::VectorXd q;
  const TensileCurve curve =
      experiment.run({1.0, 3.0}, [&](int, const Eigen::VectorXd& x, const EquilibriumSolver&) { q = x; });
  ASSERT_TRUE(curve.completed) << curve.message;
  const Discretization& d = experiment.discretization();

  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("twill_mesh_out_" + name + std::to_string(::getpid()) + ".obj");
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  d.surface_mesh(q, &V, &F);
  write_obj(path.string(), V, F);
  const Obj obj = read_obj(path.string());
  std::filesystem::remove(path);

  // The file holds surface_mesh() exactly.
  ASSERT_EQ(obj.V.rows(), V.rows());
  ASSERT_EQ(obj.F.rows(), F.rows());
  ASSERT_GT(F.rows(), 0);
  EXPECT_EQ((obj.F - F).cwiseAbs().maxCoeff(), 0);
  EXPECT_EQ((obj.V - V).cwiseAbs().maxCoeff(), 0.0);  // "%.17g" round-trips every double

  // Coordinates are the equilibrium's: every OBJ vertex is the surface point of its reference
  // position (point_evaluation, independent of surface_mesh's sampling), the moving clamp line
  // sits at x = L + 3 mm, and the strip is narrowed at mid-gauge by the reported lateral strain.
  const double L = 1e-3 * setup.gauge_length_mm, W = 1e-3 * setup.width_mm, u = 3e-3;
  std::vector<Eigen::Vector2d> reference;
  Eigen::MatrixXd rest_V;
  Eigen::MatrixXi rest_F;
  d.surface_mesh(d.rest_positions(), &rest_V, &rest_F);
  EXPECT_EQ((rest_F - F).cwiseAbs().maxCoeff(), 0);
  // At rest the triangles tile the strip, counter-clockwise seen from +z: their signed areas
  // sum to L·W.
  double area = 0;
  for (Eigen::Index t = 0; t < rest_F.rows(); ++t) {
    const Eigen::Vector3d a = rest_V.row(rest_F(t, 0)), b = rest_V.row(rest_F(t, 1)), c = rest_V.row(rest_F(t, 2));
    const Eigen::Vector3d ab = b - a, ac = c - a;
    const double signed_area = 0.5 * (ab.x() * ac.y() - ab.y() * ac.x());
    EXPECT_GT(signed_area, 0.0) << "triangle " << t;
    area += signed_area;
  }
  for (Eigen::Index i = 0; i < rest_V.rows(); ++i) reference.emplace_back(rest_V(i, 0), rest_V(i, 1));
  const Eigen::VectorXd expected = d.point_evaluation(reference) * q;
  double worst = 0;
  for (Eigen::Index i = 0; i < obj.V.rows(); ++i) {
    worst = std::max(worst, (obj.V.row(i).transpose() - expected.segment<3>(3 * i)).norm());
    if (std::abs(rest_V(i, 0) - L) < 1e-12) {
      EXPECT_NEAR(obj.V(i, 0), L + u, 1e-12);
    }
    if (std::abs(rest_V(i, 0)) < 1e-12) {
      EXPECT_NEAR(obj.V(i, 0), 0.0, 1e-12);
    }
  }
  EXPECT_LT(worst, 1e-12 * L);
  EXPECT_NEAR(area, L * W, 1e-12 * L * W);
  const Eigen::VectorXd mid = d.point_evaluation({{0.5 * L, -0.5 * W}, {0.5 * L, 0.5 * W}}) * q;
  EXPECT_NEAR((mid.segment<3>(3) - mid.segment<3>(0)).norm() / W - 1.0, curve.points.back().lateral_strain, 1e-12);
  EXPECT_LT(curve.points.back().lateral_strain, -0.05);  // bias at 4 % strain narrows visibly
}

INSTANTIATE_TEST_SUITE_P(EveryDiscretization, MeshOut,
                         ::testing::ValuesIn(testing::registered_names(registry_category::kDiscretization)),
                         [](const auto& test_info) {
                           std::string name = test_info.param;
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

}  // namespace
}  // namespace twill
