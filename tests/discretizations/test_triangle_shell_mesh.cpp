// Meshes, options, clamps, point evaluation, masses and OBJ output of the triangle shell
// (discretizations/triangle_shell/strip_triangulation.hpp, triangle_shell.hpp,
// core/obj_writer.hpp).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include "core/config.hpp"
#include "core/input_error.hpp"
#include "core/obj_writer.hpp"
#include "discretizations/triangle_shell/hinge_bending.hpp"
#include "discretizations/triangle_shell/strip_triangulation.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"
#include "tests/discretizations/test_triangle_shell_support.hpp"

namespace twill {
namespace {

using namespace triangle_shell_test;

/// The InputError key thrown by f, or "" when nothing (or something else) is thrown.
template <class F>
std::string input_error_key(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.where().key;
  } catch (...) {
    return "(other exception)";
  }
  return "";
}

TEST(StripTriangulation, CountsOfEveryPattern) {
  const int nx = 7, ny = 5;
  const StripSpec s = strip(ny, nx);
  for (TrianglePattern pattern : all_triangle_patterns()) {
    const StripTriangulation t = triangulate_strip(s, pattern, 0.2, 3);
    const bool cross = pattern == TrianglePattern::Cross;
    const int V = (nx + 1) * (ny + 1) + (cross ? nx * ny : 0);
    const int F = (cross ? 4 : 2) * nx * ny;
    const int E = nx * (ny + 1) + ny * (nx + 1) + (cross ? 4 : 1) * nx * ny;
    EXPECT_EQ(t.num_vertices(), V) << to_string(pattern);
    EXPECT_EQ(t.num_faces(), F) << to_string(pattern);
    EXPECT_EQ(static_cast<int>(t.hinges.size()), E - 2 * (nx + ny)) << to_string(pattern);
    EXPECT_EQ(static_cast<int>(t.mesh.n_vertices()), V);
    EXPECT_EQ(static_cast<int>(t.mesh.n_faces()), F);
    // Every triangle counter-clockwise; hinge triangles as documented.
    for (int f = 0; f < F; ++f) {
      const Eigen::Vector2d a = t.reference_xy.row(t.faces(f, 0)),
                            b = t.reference_xy.row(t.faces(f, 1)),
                            c = t.reference_xy.row(t.faces(f, 2));
      EXPECT_GT((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x(), 0.0);
    }
    for (const Hinge& h : t.hinges) {
      const HingeReference r = hinge_reference(
          t.reference_xy.row(h.v[0]).transpose(), t.reference_xy.row(h.v[1]).transpose(),
          t.reference_xy.row(h.v[2]).transpose(), t.reference_xy.row(h.v[3]).transpose());
      EXPECT_GT(r.weight, 0.0);
    }
    // Hinge classes: three modes per pattern; hinges per cell 1+1+1, or 2+2+2 for cross.
    const HingeClasses classes = classify_hinges(t);
    EXPECT_EQ(classes.response.size(), 3u) << to_string(pattern);
    int per_cell = 0;
    for (int n : classes.hinges_per_cell) per_cell += n;
    EXPECT_EQ(per_cell, cross ? 6 : 3) << to_string(pattern);
    EXPECT_EQ(classes.class_of_hinge.size(), t.hinges.size());
  }
}

TEST(StripTriangulation, IrregularPatternIsSeededAndKeepsTheOutline) {
  const StripSpec s = strip(6, 9);
  const StripTriangulation a = triangulate_strip(s, TrianglePattern::Irregular, 0.2, 7);
  const StripTriangulation b = triangulate_strip(s, TrianglePattern::Irregular, 0.2, 7);
  const StripTriangulation c = triangulate_strip(s, TrianglePattern::Irregular, 0.2, 8);
  EXPECT_EQ((a.reference_xy - b.reference_xy).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT((a.reference_xy - c.reference_xy).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::MatrixXd offset = a.reference_xy - a.base_xy;
  double largest = 0;
  for (int v = 0; v < a.num_vertices(); ++v) {
    const bool boundary = a.mesh.is_boundary(a.mesh.vertex_handle(static_cast<unsigned>(v)));
    if (boundary) {
      EXPECT_EQ(offset.row(v).norm(), 0.0);
    }
    EXPECT_LE(std::abs(offset(v, 0)), 0.2 * a.cell_length_m);
    EXPECT_LE(std::abs(offset(v, 1)), 0.2 * a.cell_width_m);
    largest = std::max(largest, std::abs(offset(v, 0)) / a.cell_length_m);
  }
  EXPECT_GT(largest, 0.15);  // the offsets really use the range
}

TEST(TriangleShellOptions, ValidationNamesTheField) {
  TriangleShellOptions o;
  std::string error;
  EXPECT_TRUE(o.validate(&error)) << error;
  o.perturbation = 0.3;
  EXPECT_FALSE(o.validate(&error));
  EXPECT_EQ(error.rfind("perturbation", 0), 0u) << error;
  o.perturbation = 0.1;
  o.threads = -1;
  EXPECT_FALSE(o.validate(&error));
  EXPECT_EQ(error.rfind("threads", 0), 0u) << error;

  EXPECT_EQ(triangle_pattern_from_string("cross"), TrianglePattern::Cross);
  try {
    triangle_pattern_from_string("diagonal");
    ADD_FAILURE() << "unknown pattern accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "pattern");
    EXPECT_NE(std::string(e.what()).find("right, left, alternating, cross, irregular"),
              std::string::npos)
        << e.what();
  }

  const MaterialParameters p = physical_parameters();
  TriangleShellOptions bad;
  bad.perturbation = 0.25;
  EXPECT_EQ(input_error_key([&] { TriangleShell(strip(4, 6), p, bad); }), "perturbation");
  StripSpec s = strip(4, 6);
  s.cells_along = 0;
  EXPECT_EQ(input_error_key([&] { TriangleShell(s, p); }), "strip.cells_along");
  s = strip(4, 6);
  s.width_m = -1;
  EXPECT_EQ(input_error_key([&] { TriangleShell(s, p); }), "strip.width_m");
  MaterialParameters q = p;
  q.thickness_m = 0;
  EXPECT_EQ(input_error_key([&] { TriangleShell(strip(4, 6), q); }), "thickness_m");
  TriangleShell shell(strip(4, 6), p);
  q = p;
  q.eta3 = Curve{{0.5, 0.5}, {2.0}};
  EXPECT_EQ(input_error_key([&] { shell.set_parameters(q); }), "eta3");
  EXPECT_EQ(shell.name(), "triangle-shell");
}

TEST(TriangleShellOptions, RegistrySchemaMatchesTheOptions) {
  const OptionSchema schema = option_schema(triangle_shell_option_bindings());
  const auto triangle_shell_options = [](const Options& resolved) {
    return options_from(triangle_shell_option_bindings(), resolved, "triangle-shell");
  };
  Options o = default_options(schema, nullptr);
  const TriangleShellOptions d = triangle_shell_options(o), defaults;
  EXPECT_EQ(d.pattern, defaults.pattern);
  EXPECT_EQ(d.perturbation, defaults.perturbation);
  EXPECT_EQ(d.seed, defaults.seed);
  EXPECT_EQ(d.threads, defaults.threads);
  EXPECT_EQ(d.hinge_model, defaults.hinge_model);
  EXPECT_EQ(d.hinge_model, HingeModel::ShapeOperator);
  for (HingeModel m : {HingeModel::ShapeOperator, HingeModel::Directional, HingeModel::Cylinders}) {
    Options chosen = default_options(schema, nullptr);
    apply_override(chosen, schema, nullptr, "hinge_model=" + to_string(m));
    EXPECT_EQ(triangle_shell_options(chosen).hinge_model, m);
  }
  EXPECT_THROW(apply_override(o, schema, nullptr, "hinge_model=midedge"), InputError);
  EXPECT_EQ(input_error_key([] { hinge_model_from_string("midedge"); }), "hinge_model");
  apply_override(o, schema, nullptr, "pattern=cross");
  EXPECT_EQ(triangle_shell_options(o).pattern, TrianglePattern::Cross);
  EXPECT_THROW(apply_override(o, schema, nullptr, "pattern=diagonal"), InputError);
  EXPECT_THROW(apply_override(o, schema, nullptr, "perturbation=0.25"), InputError);
}

TEST(TriangleShell, ClampedNodesAreTheEndColumns) {
  const int nx = 6, ny = 4;
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShell shell(strip(ny, nx), physical_parameters(), options(pattern));
    const Eigen::VectorXd& X = shell.rest_positions();
    const double L = shell.strip().length_m, hx = L / nx;
    const bool cross = pattern == TrianglePattern::Cross;
    for (StripEnd end : {StripEnd::Start, StripEnd::End}) {
      const double x_end = end == StripEnd::Start ? 0.0 : L;
      const std::vector<int> line = shell.clamped_nodes(end, false);
      EXPECT_EQ(static_cast<int>(line.size()), ny + 1);
      for (int v : line) EXPECT_EQ(X[3 * v], x_end);
      const std::vector<int> slope = shell.clamped_nodes(end, true);
      EXPECT_EQ(static_cast<int>(slope.size()), 2 * (ny + 1) + (cross ? ny : 0))
          << to_string(pattern);
      const std::set<int> slope_set(slope.begin(), slope.end());
      for (int v : line) EXPECT_TRUE(slope_set.count(v));
      // The extra nodes are the next column (centres of the end cells for cross); interior
      // vertices of the irregular mesh are perturbed by less than a quarter cell.
      for (int v : slope) EXPECT_LT(std::abs(X[3 * v] - x_end), 1.25 * hx);
    }
  }
}

TEST(TriangleShell, ClampHingesHoldTheSlopeInsteadOfTheNextColumn) {
  // With clamp hinges on the start only, a slope clamp there holds the end line alone (the
  // hinges hold the slope); the other end still holds its first cell column.
  const int nx = 6, ny = 4;
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShellOptions o = options(pattern);
    o.clamp_hinges = StripEnds::Start;
    TriangleShell shell(strip(ny, nx), physical_parameters(), o);
    const bool cross = pattern == TrianglePattern::Cross;
    EXPECT_EQ(shell.clamped_nodes(StripEnd::Start, true), shell.clamped_nodes(StripEnd::Start, false));
    EXPECT_EQ(static_cast<int>(shell.clamped_nodes(StripEnd::End, true).size()),
              2 * (ny + 1) + (cross ? ny : 0));
    // One clamp hinge per boundary edge of the start line, none elsewhere.
    EXPECT_EQ(shell.clamp_hinge_energies(shell.rest_positions()).size(), ny) << to_string(pattern);
  }
  EXPECT_EQ(strip_ends_from_string("both"), StripEnds::Both);
  EXPECT_EQ(input_error_key([] { strip_ends_from_string("left"); }), "clamp_hinges");
  const auto bindings = triangle_shell_option_bindings();
  const OptionSchema schema = option_schema(bindings);
  Options o = default_options(schema, nullptr);
  EXPECT_EQ(options_from(bindings, o, "triangle-shell").clamp_hinges, TriangleShellOptions{}.clamp_hinges);
  apply_override(o, schema, nullptr, "clamp_hinges=start");
  EXPECT_EQ(options_from(bindings, o, "triangle-shell").clamp_hinges, StripEnds::Start);
  EXPECT_THROW(apply_override(o, schema, nullptr, "clamp_hinges=middle"), InputError);
}

TEST(TriangleShell, PointEvaluationInterpolatesAffineFieldsExactly) {
  std::mt19937_64 rng(4);
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShell shell(strip(5, 7, 30.0), physical_parameters(), options(pattern));
    const StripSpec& s = shell.strip();
    std::uniform_real_distribution<double> ux(0.0, s.length_m),
        uy(-0.5 * s.width_m, 0.5 * s.width_m);
    std::vector<Eigen::Vector2d> points = {
        {0.0, -0.5 * s.width_m}, {s.length_m, 0.5 * s.width_m}, {0.5 * s.length_m, 0.0}};
    for (int i = 0; i < 50; ++i) points.emplace_back(ux(rng), uy(rng));
    // Every vertex maps to itself.
    const Eigen::VectorXd& X = shell.rest_positions();
    for (int v = 0; v < shell.num_nodes(); v += 3) points.emplace_back(X[3 * v], X[3 * v + 1]);
    const SparseMatrix P = shell.point_evaluation(points);
    ASSERT_EQ(P.rows(), static_cast<Eigen::Index>(3 * points.size()));
    ASSERT_EQ(P.cols(), shell.num_dofs());
    Eigen::Matrix3d A;
    A << 1.1, 0.2, 0, -0.3, 0.9, 0, 0.4, 0.5, 0;
    const Eigen::Vector3d b(0.01, -0.02, 0.03);
    Eigen::VectorXd q(X.size());
    for (int v = 0; v < shell.num_nodes(); ++v) q.segment<3>(3 * v) = A * X.segment<3>(3 * v) + b;
    const Eigen::VectorXd x = P * q;
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d expected = A * Eigen::Vector3d(points[i].x(), points[i].y(), 0) + b;
      EXPECT_LT((x.segment<3>(3 * static_cast<Eigen::Index>(i)) - expected).norm(), 1e-15)
          << to_string(pattern) << " point " << i;
    }
    // Rows are partitions of unity with non-negative weights.
    const Eigen::VectorXd ones = P * Eigen::VectorXd::Ones(shell.num_dofs());
    EXPECT_LT((ones - Eigen::VectorXd::Ones(ones.size())).cwiseAbs().maxCoeff(), 1e-13);
    EXPECT_GE(SparseMatrix(P).coeffs().minCoeff(), -1e-12);
    EXPECT_EQ(input_error_key([&] {
                shell.point_evaluation({{0.01, 0.0}, {-0.001, 0.0}});
              }),
              "points[1]");
  }
}

TEST(TriangleShell, LumpedMassAndGravity) {
  const MaterialParameters p = physical_parameters();
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShell shell(strip(4, 6), p, options(pattern));
    const Eigen::VectorXd m = shell.lumped_mass();
    const double total = p.density_kg_m2 * shell.strip().length_m * shell.strip().width_m;
    EXPECT_NEAR(m.sum(), 3 * total, 1e-14 * total);
    for (int v = 0; v < shell.num_nodes(); ++v) {
      EXPECT_GT(m[3 * v], 0.0);
      EXPECT_EQ(m[3 * v], m[3 * v + 2]);
    }
    // A uniform translation d changes only gravity: ΔΨ = −ρ_A L W g·d, and ∂Ψ/∂q = −m g.
    const Eigen::Vector3d g(0.0, 0.0, -9.81), d(0.01, 0.02, 0.3);
    shell.set_gravity(g);
    const Eigen::VectorXd& X = shell.rest_positions();
    Eigen::VectorXd Xd = X;
    for (int v = 0; v < shell.num_nodes(); ++v) Xd.segment<3>(3 * v) += d;
    Eigen::VectorXd grad;
    const double E0 = shell.energy(X, &grad, nullptr);
    EXPECT_NEAR(shell.energy(Xd, nullptr, nullptr) - E0, -total * g.dot(d), 1e-12 * total * 3);
    for (int v = 0; v < shell.num_nodes(); ++v)
      // Up to the membrane forces of the rest state's round-off strain (~1e-16).
      EXPECT_LT((grad.segment<3>(3 * v) + m[3 * v] * g).norm(), 1e-8 * m[3 * v] * g.norm());
  }
}

TEST(ObjWriter, WritesTheSurfaceWithFullDoublePrecision) {
  TriangleShell shell(strip(3, 4), physical_parameters(), options(TrianglePattern::Cross));
  Eigen::VectorXd q = shell.rest_positions();
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  for (Eigen::Index i = 0; i < q.size(); ++i) q[i] += 1e-3 * n(rng) + 1.0 / 3.0;
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  shell.surface_mesh(q, &V, &F);
  ASSERT_EQ(V.rows(), shell.num_nodes());
  EXPECT_EQ((F - shell.triangulation().faces).cwiseAbs().maxCoeff(), 0);
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("twill_triangle_shell_" + std::to_string(::getpid()) + ".obj");
  write_obj(path.string(), V, F);
  std::ifstream in(path);
  std::string line;
  int nv = 0, nf = 0;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string tag;
    ls >> tag;
    if (tag == "v") {
      std::string a, b, c;
      ls >> a >> b >> c;
      // strtod of "%.17g" text returns the identical double.
      EXPECT_EQ(std::strtod(a.c_str(), nullptr), V(nv, 0));
      EXPECT_EQ(std::strtod(b.c_str(), nullptr), V(nv, 1));
      EXPECT_EQ(std::strtod(c.c_str(), nullptr), V(nv, 2));
      ++nv;
    } else if (tag == "f") {
      int a, b, c;
      ls >> a >> b >> c;
      EXPECT_EQ(a - 1, F(nf, 0));
      EXPECT_EQ(b - 1, F(nf, 1));
      EXPECT_EQ(c - 1, F(nf, 2));
      ++nf;
    }
  }
  EXPECT_EQ(nv, V.rows());
  EXPECT_EQ(nf, F.rows());
  std::filesystem::remove(path);

  Eigen::MatrixXi bad = F;
  bad(0, 0) = static_cast<int>(V.rows());
  EXPECT_THROW(write_obj(path.string(), V, bad), std::invalid_argument);
  try {
    write_obj("/nonexistent-dir/x.obj", V, F);
    ADD_FAILURE() << "writing into a missing folder succeeded";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().file, "/nonexistent-dir/x.obj");
  }
}

}  // namespace
}  // namespace twill
