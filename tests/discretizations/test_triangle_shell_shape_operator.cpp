// Shape-operator bending of the triangle shell (shape_operator_bending.hpp;
// docs/triangle_shell.md §4.7, §6): consistency for every uniform curvature, telescoping (no
// mesh-scale mode changes the mean curvature), the free-edge condition, pure bending against
// Kirchhoff–Love on cylinders and doubly curved states, clamps, parameter derivatives.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <string>

#include "core/input_error.hpp"
#include "discretizations/triangle_shell/shape_operator_bending.hpp"
#include "discretizations/triangle_shell/strip_triangulation.hpp"
#include "discretizations/triangle_shell/triangle_shell.hpp"
#include "tests/discretizations/test_triangle_shell_support.hpp"

namespace twill {
namespace {

using namespace triangle_shell_test;

/// ẽ = (d1ᵀKd1, d2ᵀKd2, d1ᵀKd2) for K in mesh coordinates.
Eigen::Vector3d material_curvature(const Eigen::Matrix2d& K, double angle_deg) {
  const Eigen::Vector2d d1 = material_direction(angle_deg, 0), d2 = material_direction(angle_deg, 1);
  return {d1.dot(K * d1), d2.dot(K * d2), d1.dot(K * d2)};
}

/// KL bending energy per area τ³/24 ẽᵀCẽ.
double kirchhoff_love_density(const MaterialParameters& p, const Eigen::Vector3d& e) {
  return std::pow(p.thickness_m, 3) / 24 * e.dot(ShapeOperatorBending::law_stiffness(p) * e);
}

std::vector<Eigen::Matrix2d> curvature_states() {
  const double k = 2.0;  // 1/m
  return {k * Eigen::Matrix2d::Identity(),                                    // sphere
          (Eigen::Matrix2d() << k, 0, 0, -k).finished(),                      // saddle
          (Eigen::Matrix2d() << 0, k, k, 0).finished(),                       // pure twist
          (Eigen::Matrix2d() << k, 0, 0, 0).finished(),                       // cylinder along x
          (Eigen::Matrix2d() << 0.3 * k, -0.7 * k, -0.7 * k, 1.1 * k).finished()};  // general
}

bool has_free_edge(const ShapeOperatorBending::Face& face) { return face.measured.size() < 3; }

TEST(ShapeOperatorBending, ReproducesEveryUniformCurvatureOnEveryPattern) {
  // Linearised: φ_h = μ_h·(Kxx, Kyy, Kxy) per hinge (the hinge's stencil mode), no clamp
  // hinges. Every face whose three edges are hinges must return K exactly: its own split is
  // consistent, and each shared edge takes the consistent split of at least one side.
  const MaterialParameters p = physical_parameters();
  for (TrianglePattern pattern : all_triangle_patterns())
    for (double angle : {90.0, 30.0}) {
      TriangleShell shell(strip(6, 8, angle), p, options(pattern));
      const ShapeOperatorBending& b = *shell.shape_operator();
      int checked = 0;
      for (const Eigen::Matrix2d& K : curvature_states()) {
        const Eigen::Vector3d k(K(0, 0), K(1, 1), K(0, 1));
        const Eigen::VectorXd phi = b.hinge_modes() * k;
        const auto e = b.curvatures(phi, shell.shape_operator_stiffness());
        const Eigen::Vector3d expected = material_curvature(K, angle);
        for (size_t f = 0; f < b.faces().size(); ++f) {
          if (has_free_edge(b.faces()[f])) continue;
          ASSERT_TRUE(b.faces()[f].complete);
          EXPECT_LT((e.row(static_cast<Eigen::Index>(f)).transpose() - expected).norm(),
                    1e-10 * K.norm())
              << to_string(pattern) << " at " << angle << ", face " << f;
          ++checked;
        }
      }
      EXPECT_GT(checked, 0) << to_string(pattern);
    }
}

TEST(ShapeOperatorBending, FreeEdgesCarryNoNormalMoment) {
  // The rotation of a free edge is the minimiser of W_T: the moment conjugate to it,
  // n·M·n with M = τ³/12 C ẽ (M12 = ½ ∂W/∂K̃12), vanishes, the KL free-edge condition.
  const MaterialParameters p = physical_parameters();
  for (TrianglePattern pattern : all_triangle_patterns()) {
    const double angle = 30.0;
    TriangleShell shell(strip(4, 6, angle), p, options(pattern));
    const ShapeOperatorBending& b = *shell.shape_operator();
    const StripTriangulation& t = shell.triangulation();
    const Eigen::Matrix3d C = ShapeOperatorBending::law_stiffness(p);
    const Eigen::Matrix2d K = curvature_states()[4];
    const Eigen::VectorXd phi = b.hinge_modes() * Eigen::Vector3d(K(0, 0), K(1, 1), K(0, 1));
    const auto e = b.curvatures(phi, shell.shape_operator_stiffness());
    int free_edges = 0;
    for (size_t f = 0; f < b.faces().size(); ++f) {
      const auto& face = b.faces()[f];
      const Eigen::Vector3d m = C * e.row(static_cast<Eigen::Index>(f)).transpose();
      for (int k = 0; k < 3; ++k) {
        if (std::find(face.measured.begin(), face.measured.end(), k) != face.measured.end()) continue;
        const Eigen::Vector2d a = t.reference_xy.row(t.faces(static_cast<Eigen::Index>(f), k));
        const Eigen::Vector2d c = t.reference_xy.row(t.faces(static_cast<Eigen::Index>(f), (k + 1) % 3));
        const Eigen::Vector2d n = Eigen::Vector2d((c - a).y(), -(c - a).x()).normalized();
        const double n1 = n.dot(material_direction(angle, 0)), n2 = n.dot(material_direction(angle, 1));
        const double mnn = m[0] * n1 * n1 + m[1] * n2 * n2 + m[2] * n1 * n2;
        EXPECT_LT(std::abs(mnn), 1e-10 * m.norm()) << to_string(pattern) << " face " << f;
        ++free_edges;
      }
    }
    EXPECT_GT(free_edges, 0);
  }
}

TEST(ShapeOperatorBending, MeshScaleModesCannotChangeTheMeanCurvature) {
  // Telescoping: Σ_T Ā_T K_T = Σ_e |ē| φ_e n_e n_eᵀ, which vanishes for any field supported
  // away from the boundary. Random out-of-plane perturbations of the interior vertices (three
  // cells from the boundary, so every face they reach has all its edges measured), small so
  // that the angles are linear in them.
  const MaterialParameters p = physical_parameters();
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShell shell(strip(10, 12, 30.0), p, options(pattern));
    const StripTriangulation& t = shell.triangulation();
    const ShapeOperatorBending& b = *shell.shape_operator();
    Eigen::VectorXd q = shell.rest_positions();
    const double hx = t.cell_length_m, hy = t.cell_width_m, W = shell.strip().width_m;
    const double amplitude = 1e-9;  // m: angles ~1e-7, quadratic terms ~1e-14 relative
    for (int v = 0; v < t.num_vertices(); ++v) {
      const Eigen::Vector2d X = t.base_xy.row(v);
      if (X.x() > 3 * hx * (1 - 1e-9) && X.x() < shell.strip().length_m - 3 * hx * (1 - 1e-9) &&
          std::abs(X.y()) < 0.5 * W - 3 * hy * (1 - 1e-9))
        q[3 * v + 2] = amplitude * n(rng);
    }
    const auto e = shell.face_curvatures(q);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), magnitude = Eigen::Vector3d::Zero();
    for (size_t f = 0; f < b.faces().size(); ++f) {
      sum += b.faces()[f].area * e.row(static_cast<Eigen::Index>(f)).transpose();
      magnitude += b.faces()[f].area * e.row(static_cast<Eigen::Index>(f)).transpose().cwiseAbs();
    }
    std::printf("[measured] %s: |Σ A K| / Σ A |K| = %.1e\n", to_string(pattern).c_str(),
                sum.norm() / magnitude.norm());
    EXPECT_GT(magnitude.norm(), 0.0);
    EXPECT_LT(sum.norm(), 1e-6 * magnitude.norm()) << to_string(pattern);
  }
}

TEST(ShapeOperatorBending, CheckerboardOfTheAlternatingMeshIsDecoupledFromTheBend) {
  // The mode that breaks the hinge models (docs §10): δ(−1)^{i+j} on grid vertex (i, j). Here
  // the energy of bend + checkerboard is the sum of the two (no cross term), so the smooth
  // bend is the cheapest state with its mean curvature.
  const StripSpec s = checkerboard_strip();
  TriangleShellOptions o = options(TrianglePattern::Alternating, 1);
  TriangleShell shell(s, physical_parameters(), o);
  const StripTriangulation& t = shell.triangulation();
  const double K = 1.0, hx = s.length_m / s.cells_along, hy = s.width_m / s.cells_across;
  auto state = [&](double bend, double delta) {
    Eigen::VectorXd q = shell.rest_positions();
    for (int v = 0; v < shell.num_nodes(); ++v) {
      const double x = t.base_xy(v, 0), y = t.base_xy(v, 1) + 0.5 * s.width_m;
      const long i = std::lround(x / hx), j = std::lround(y / hy);
      q[3 * v + 2] = 0.5 * bend * K * x * x + ((i + j) % 2 == 0 ? delta : -delta);
    }
    return q;
  };
  const double delta = -K * hx * hx / 4;  // the amplitude that unbends the hinge models
  const double A = shell.face_bending_energies(state(1, 0)).sum();
  const double B = shell.face_bending_energies(state(0, delta)).sum();
  const double AB = shell.face_bending_energies(state(1, delta)).sum();
  std::printf("[measured] shape operator: bend %.4e J, checkerboard %.4e J, both %.4e J "
              "(cross term %.2e of the bend)\n", A, B, AB, (AB - A - B) / A);
  EXPECT_NEAR(AB, A + B, 1e-4 * A);
  // The interior of the bend carries the KL energy: the strip minus its free-edge and end
  // faces (O(h) boundary layer, relaxed to M_nn = 0) is within the interior faces' error.
  const double KL = kirchhoff_love_density(physical_parameters(), Eigen::Vector3d(K, 0, 0)) *
                    s.length_m * s.width_m;
  EXPECT_GT(A, 0.8 * KL);
  EXPECT_LT(A, 1.001 * KL);
}

TEST(ShapeOperatorBending, CheckerboardIsAnAlternatingTwistOnSquareCells) {
  // docs/triangle_shell.md §4.7, worked example: on square cells the split turns the
  // checkerboard δ(−1)^{i+j} into (Kxx, Kyy, Kxy) = (0, 0, ±4δ/h²), the sign alternating with
  // the cell's diagonal: zero mean curvature, and orthogonal to bends for aligned material.
  const double delta = 1e-9;
  TriangleShell shell(strip(8, 12, 90.0), physical_parameters(), options(TrianglePattern::Alternating));
  const StripTriangulation& t = shell.triangulation();
  const double h = t.cell_length_m;
  ASSERT_NEAR(t.cell_width_m, h, 1e-15);
  Eigen::VectorXd q = shell.rest_positions();
  for (int v = 0; v < shell.num_nodes(); ++v) {
    const long i = std::lround(t.base_xy(v, 0) / h);
    const long j = std::lround((t.base_xy(v, 1) + 0.5 * shell.strip().width_m) / h);
    q[3 * v + 2] = (i + j) % 2 == 0 ? delta : -delta;
  }
  const auto e = shell.face_curvatures(q);  // material frame at 90°: K̃11 = Kxx, K̃12 = −Kxy
  int checked = 0;
  for (int f = 0; f < t.num_faces(); ++f) {
    const auto& face = shell.shape_operator()->faces()[static_cast<size_t>(f)];
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) c += t.base_xy.row(t.faces(f, k)).transpose() / 3.0;
    // Faces two cells from the boundary: every split on their edges is the two-sided one.
    if (!face.complete || c.x() < 2 * h || c.x() > shell.strip().length_m - 2 * h ||
        std::abs(c.y()) > 0.5 * shell.strip().width_m - 2 * h)
      continue;
    const long i = static_cast<long>(std::floor(c.x() / h));
    const long j = static_cast<long>(std::floor((c.y() + 0.5 * shell.strip().width_m) / h));
    // Kxy = +4δ/h² in "/" cells (i + j even), −4δ/h² in "\" cells; K̃12 = −Kxy at 90°.
    const double Kxy = ((i + j) % 2 == 0 ? 1.0 : -1.0) * 4 * delta / (h * h);
    EXPECT_LT(std::abs(e(f, 0)) + std::abs(e(f, 1)), 1e-6 * std::abs(Kxy)) << "face " << f;
    EXPECT_NEAR(e(f, 2), -Kxy, 1e-6 * std::abs(Kxy)) << "face " << f;
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

TEST(ShapeOperatorBending, NeitherTheHalfSplitNorPerFaceConsistencyAloneSuffices) {
  // docs/triangle_shell.md §4.7 "Why both", on the interior faces of the aligned alternating
  // mesh (square cells): with K_T from the same hinge angles,
  //   half split s = φ/2 (BST):               telescopes, not consistent: twist far too stiff;
  //   K^c_T = M_T⁻¹ φ_T alone (6-node patch):  consistent, not telescoping: a bend plus the
  //                                           checkerboard costs a quarter of the bend;
  //   the split of shape_operator_bending.hpp: both, exact.
  const MaterialParameters p = physical_parameters();
  TriangleShell shell(strip(8, 12, 90.0), p, options(TrianglePattern::Alternating));
  const StripTriangulation& t = shell.triangulation();
  const ShapeOperatorBending& b = *shell.shape_operator();
  const double h = t.cell_length_m, L = shell.strip().length_m, W = shell.strip().width_m;
  const Eigen::Matrix3d C = ShapeOperatorBending::law_stiffness(p);
  std::map<std::pair<int, int>, int> hinge_of_edge;
  for (size_t k = 0; k < t.hinges.size(); ++k) {
    hinge_of_edge[{t.hinges[k].v[0], t.hinges[k].v[1]}] = static_cast<int>(k);
    hinge_of_edge[{t.hinges[k].v[1], t.hinges[k].v[0]}] = static_cast<int>(k);
  }
  struct Energies {
    double half = 0, consistent = 0, split = 0, area = 0;  // Σ Ā ẽᵀCẽ, interior faces
  };
  auto energies = [&](const Eigen::VectorXd& q) {
    Eigen::VectorXd phi = Eigen::VectorXd::Zero(b.num_angles());
    for (size_t k = 0; k < t.hinges.size(); ++k) {
      const auto& v = t.hinges[k].v;
      phi[static_cast<Eigen::Index>(k)] =
          -dihedral_angle(q.segment<3>(3 * v[0]), q.segment<3>(3 * v[1]),
                          q.segment<3>(3 * v[2]), q.segment<3>(3 * v[3]));
    }
    const auto split = b.curvatures(phi, shell.shape_operator_stiffness());
    Energies out;
    for (int f = 0; f < t.num_faces(); ++f) {
      const auto& face = b.faces()[static_cast<size_t>(f)];
      Eigen::Vector2d c = Eigen::Vector2d::Zero();
      for (int k = 0; k < 3; ++k) c += t.base_xy.row(t.faces(f, k)).transpose() / 3.0;
      if (!face.complete || c.x() < 2 * h || c.x() > L - 2 * h || std::abs(c.y()) > 0.5 * W - 2 * h)
        continue;
      Eigen::Matrix3d M;
      Eigen::Vector3d own;
      for (int k = 0; k < 3; ++k) {
        const int hk = hinge_of_edge.at({t.faces(f, k), t.faces(f, (k + 1) % 3)});
        M.row(k) = b.hinge_modes().row(hk);
        own[k] = phi[hk];
      }
      const Eigen::Vector3d k = M.inverse() * own;  // (Kxx, Kyy, Kxy)
      const Eigen::Vector3d consistent(k[0], k[1], -k[2]);  // material frame at 90°
      const Eigen::Vector3d half = face.curvature_map * (0.5 * own);
      const Eigen::Vector3d full = split.row(f).transpose();
      out.consistent += face.area * consistent.dot(C * consistent);
      out.half += face.area * half.dot(C * half);
      out.split += face.area * full.dot(C * full);
      out.area += face.area;
    }
    return out;
  };
  auto state = [&](const Eigen::Matrix2d& K, double delta) {
    Eigen::VectorXd q = shell.rest_positions();
    for (int v = 0; v < shell.num_nodes(); ++v) {
      const Eigen::Vector2d X(t.base_xy(v, 0) - 0.5 * L, t.base_xy(v, 1));
      const long i = std::lround(t.base_xy(v, 0) / h), j = std::lround((t.base_xy(v, 1) + 0.5 * W) / h);
      q[3 * v + 2] = 0.5 * X.dot(K * X) + ((i + j) % 2 == 0 ? delta : -delta);
    }
    return q;
  };
  const double kappa = 1.0, delta = kappa * h * h / 4;
  const Eigen::Matrix2d bend = (Eigen::Matrix2d() << kappa, 0, 0, 0).finished();
  const Eigen::Matrix2d twist = (Eigen::Matrix2d() << 0, kappa, kappa, 0).finished();
  // Smallest energy of bend + f·checkerboard over f, relative to the bend alone (a parabola
  // through f = −1, 0, 1).
  const Energies e0 = energies(state(bend, 0)), ep = energies(state(bend, delta)),
                 em = energies(state(bend, -delta));
  auto softening = [](double a0, double ap, double am) {
    const double A = 0.5 * (ap + am) - a0, B = 0.5 * (ap - am);
    return (a0 - B * B / (4 * A)) / a0;
  };
  const double kl_bend = Eigen::Vector3d(kappa, 0, 0).dot(C * Eigen::Vector3d(kappa, 0, 0));
  const double kl_twist = Eigen::Vector3d(0, 0, kappa).dot(C * Eigen::Vector3d(0, 0, kappa));
  const Energies et = energies(state(twist, 0));
  std::printf("[measured] bend + best checkerboard / bend: half split %.3f, consistent alone %.3f, "
              "split %.3f; twist / KL: half split %.1f, consistent alone %.3f, split %.3f\n",
              softening(e0.half, ep.half, em.half), softening(e0.consistent, ep.consistent, em.consistent),
              softening(e0.split, ep.split, em.split), et.half / (kl_twist * et.area),
              et.consistent / (kl_twist * et.area), et.split / (kl_twist * et.area));
  EXPECT_NEAR(e0.split / (kl_bend * e0.area), 1.0, 1e-3);
  EXPECT_NEAR(softening(e0.split, ep.split, em.split), 1.0, 1e-3);
  EXPECT_NEAR(et.split / (kl_twist * et.area), 1.0, 1e-3);
  EXPECT_LT(softening(e0.consistent, ep.consistent, em.consistent), 0.3);
  EXPECT_NEAR(et.consistent / (kl_twist * et.area), 1.0, 1e-3);
  EXPECT_NEAR(softening(e0.half, ep.half, em.half), 1.0, 1e-3);
  EXPECT_GT(et.half / (kl_twist * et.area), 50.0);
}

// ---------------------------------------------------------------------------------------
// Pure bending: vertices exactly on a cylinder (isometric), against KL

struct CylinderResult {
  double total_error, interior_error, membrane_ratio;
};

CylinderResult bend_on_cylinder(const TriangleShell& shell, const Eigen::Vector2d& u) {
  const double R = 0.04;
  const StripSpec& s = shell.strip();
  const Eigen::VectorXd q = cylinder_positions(shell.rest_positions(), u, R, s.length_m);
  const double density = kirchhoff_love_cylinder_density(shell.parameters(), s.angle_deg, u, R);
  const Eigen::VectorXd w = shell.face_bending_energies(q);
  const StripTriangulation& t = shell.triangulation();
  // Interior: faces whose (unperturbed) centroid lies in [L/4, 3L/4) × [−W/4, W/4).
  double interior = 0, interior_area = 0;
  for (int f = 0; f < t.num_faces(); ++f) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) c += t.base_xy.row(t.faces(f, k)).transpose() / 3.0;
    if (c.x() >= 0.25 * s.length_m && c.x() < 0.75 * s.length_m && c.y() >= -0.25 * s.width_m &&
        c.y() < 0.25 * s.width_m) {
      interior += w[f];
      interior_area += shell.shape_operator()->faces()[static_cast<size_t>(f)].area;
    }
  }
  const double area = s.length_m * s.width_m;
  return {w.sum() / (density * area) - 1, interior / (density * interior_area) - 1,
          shell.energy_parts(q).membrane / w.sum()};
}

TEST(ShapeOperatorPureBending, MatchesKirchhoffLoveOnCylindersInEveryDirection) {
  // Warp, weft, +45° and −45° cylinders (R = 40 mm) at 90° and 0°: the interior is exact
  // (consistency), the total converges as the O(h) free-edge/end layer (M_nn = 0 in the faces
  // on the boundary, the cylinder's imposed curvature there is not a minimiser) shrinks:
  // within 5 % at 32×48.
  const MaterialParameters p = physical_parameters();
  const int resolutions[3][2] = {{8, 12}, {16, 24}, {32, 48}};
  const char* names[4] = {"warp", "weft", "+45", "-45"};
  std::printf("shape operator, pure bending R = 40 mm: relative error vs KL\n");
  std::printf("%-6s %-12s %-5s %9s %9s %9s | %9s | %8s\n", "angle", "pattern", "dir", "8x12",
              "16x24", "32x48", "int16x24", "memb/bend");
  for (double angle : {90.0, 0.0})
    for (TrianglePattern pattern : all_triangle_patterns()) {
      CylinderResult r[3][4];
      for (int level = 0; level < 3; ++level) {
        TriangleShell shell(strip(resolutions[level][0], resolutions[level][1], angle), p,
                            options(pattern));
        const Eigen::Vector2d d1 = material_direction(angle, 0), d2 = material_direction(angle, 1);
        const Eigen::Vector2d u[4] = {d1, d2, (d1 + d2).normalized(), (d1 - d2).normalized()};
        for (int j = 0; j < 4; ++j) r[level][j] = bend_on_cylinder(shell, u[j]);
      }
      for (int j = 0; j < 4; ++j) {
        std::printf("%-6.0f %-12s %-5s %8.2f%% %8.2f%% %8.2f%% | %8.3f%% | %8.1e\n", angle,
                    to_string(pattern).c_str(), names[j], 100 * r[0][j].total_error,
                    100 * r[1][j].total_error, 100 * r[2][j].total_error,
                    100 * r[1][j].interior_error, r[1][j].membrane_ratio);
        const std::string what = to_string(pattern) + " " + names[j] + " at " + std::to_string(angle);
        // Interior: consistency up to the finite fold angles (h/R up to 0.2 rad at 8×12);
        // the irregular mesh's faces scatter around it.
        EXPECT_LT(std::abs(r[1][j].interior_error),
                  pattern == TrianglePattern::Irregular ? 0.02 : 0.005)
            << what;
        EXPECT_LT(std::abs(r[2][j].total_error), 0.05) << what << " (32×48 within 5 %)";
        EXPECT_LT(std::abs(r[1][j].total_error), std::abs(r[0][j].total_error)) << what;
        EXPECT_LT(std::abs(r[2][j].total_error), std::abs(r[1][j].total_error)) << what;
        EXPECT_LT(r[1][j].membrane_ratio, 0.05) << what;
      }
    }
}

TEST(ShapeOperatorPureBending, DoublyCurvedStatesAndTwistCarryTheKirchhoffLoveEnergy) {
  // z = ½ XᵀKX: the interior energy density is τ³/24 ẽᵀCẽ with a12 and 2 G12 (the hinge
  // models are off by −τ³/12 a12 det K̃ and up to +2747 % in twist, docs §5).
  const MaterialParameters p = physical_parameters();
  const char* names[5] = {"sphere", "saddle", "twist", "cylinder", "general"};
  std::printf("shape operator, uniform curvature (angle 90 and 30): interior energy / KL − 1\n");
  for (double angle : {90.0, 30.0})
    for (TrianglePattern pattern : all_triangle_patterns()) {
      TriangleShell shell(strip(16, 24, angle), p, options(pattern));
      const StripTriangulation& t = shell.triangulation();
      const StripSpec& s = shell.strip();
      std::printf("  %4.0f %-12s", angle, to_string(pattern).c_str());
      const auto states = curvature_states();
      for (size_t j = 0; j < states.size(); ++j) {
        const Eigen::Matrix2d& K = states[j];
        Eigen::VectorXd q = shell.rest_positions();
        for (int v = 0; v < shell.num_nodes(); ++v) {
          const Eigen::Vector2d X(q[3 * v] - 0.5 * s.length_m, q[3 * v + 1]);
          q[3 * v + 2] = 0.5 * X.dot(K * X);
        }
        const Eigen::VectorXd w = shell.face_bending_energies(q);
        double interior = 0, area = 0;
        for (int f = 0; f < t.num_faces(); ++f) {
          Eigen::Vector2d c = Eigen::Vector2d::Zero();
          for (int k = 0; k < 3; ++k) c += t.base_xy.row(t.faces(f, k)).transpose() / 3.0;
          if (c.x() >= 0.25 * s.length_m && c.x() < 0.75 * s.length_m &&
              c.y() >= -0.25 * s.width_m && c.y() < 0.25 * s.width_m) {
            interior += w[f];
            area += shell.shape_operator()->faces()[static_cast<size_t>(f)].area;
          }
        }
        const double expected = kirchhoff_love_density(p, material_curvature(K, angle));
        const double error = interior / (area * expected) - 1;
        std::printf("  %s %+7.3f%%", names[j], 100 * error);
        // Slopes up to 0.04 over the strip: the angles' nonlinearity is O(1e-3).
        EXPECT_LT(std::abs(error), 2e-3) << to_string(pattern) << " " << names[j] << " at " << angle;
      }
      std::printf("\n");
    }
}

TEST(ShapeOperatorBending, ClampEdgesMeasureTheTiltAgainstThePlatform) {
  // A cylinder tangent to the rest plane along x = 0 (zero slope at the clamp): every face
  // with an edge on the clamped line gets the cylinder's curvature, K̃ of u = x̂ over R, to
  // O(h/R) (the split's consistency plus s = φ_b, exact for clamped quadratics). Not checked:
  // the two corner cells, where an edge between two faces with a boundary edge each takes the
  // inconsistent ½φ split (shape_operator_bending.hpp (3)).
  const double R = 0.4;  // small folds: the comparison is with the linearised curvature
  const MaterialParameters p = physical_parameters();
  for (TrianglePattern pattern : all_triangle_patterns())
    for (double angle : {90.0, 30.0}) {
      TriangleShellOptions o = options(pattern);
      o.clamp_hinges = StripEnds::Start;
      TriangleShell shell(strip(6, 12, angle), p, o);
      Eigen::VectorXd q = shell.rest_positions();
      for (int v = 0; v < shell.num_nodes(); ++v) {
        const double X = q[3 * v];
        q[3 * v] = R * std::sin(X / R);
        q[3 * v + 2] = R * (1 - std::cos(X / R));
      }
      const auto e = shell.face_curvatures(q);
      const Eigen::Vector3d expected = material_curvature(
          (Eigen::Matrix2d() << 1.0 / R, 0, 0, 0).finished(), angle);
      const StripTriangulation& t = shell.triangulation();
      int checked = 0;
      for (int f = 0; f < t.num_faces(); ++f) {
        const auto& face = shell.shape_operator()->faces()[static_cast<size_t>(f)];
        int on_line = 0, on_side = 0;
        for (int k = 0; k < 3; ++k) {
          on_line += t.reference_xy(t.faces(f, k), 0) == 0.0;
          on_side += std::abs(t.reference_xy(t.faces(f, k), 1)) == 0.5 * shell.strip().width_m;
        }
        if (on_line != 2 || on_side > 0) continue;
        ASSERT_EQ(face.measured.size(), 3u);
        EXPECT_LT((e.row(f).transpose() - expected).norm(), 0.03 * expected.norm())
            << to_string(pattern) << " at " << angle << ", face " << f;
        ++checked;
      }
      EXPECT_GT(checked, 0) << to_string(pattern);
    }
}

TEST(ShapeOperatorBending, FormIsHomogeneousInTheLawAndCubicInThickness) {
  const MaterialParameters p = physical_parameters();
  for (TrianglePattern pattern : all_triangle_patterns()) {
    TriangleShellOptions o = options(pattern);
    o.clamp_hinges = StripEnds::Both;
    TriangleShell shell(strip(4, 6, 30.0), p, o);
    const ShapeOperatorBending& b = *shell.shape_operator();
    const ShapeOperatorStiffness& s = shell.shape_operator_stiffness();
    for (int f = 0; f < static_cast<int>(b.faces().size()); ++f) {
      const auto d = b.form_derivative(f, p, s);
      const Eigen::MatrixXd& S = s.form[static_cast<size_t>(f)];
      if (S.size() == 0) continue;
      // Euler for degree 1 in C (the Schur complement is homogeneous) and 3 in τ.
      const Eigen::MatrixXd euler =
          p.a11_Pa * d[0] + p.a12_Pa * d[1] + p.a22_Pa * d[2] + p.G12_Pa * d[3];
      EXPECT_LT((euler - S).cwiseAbs().maxCoeff(), 1e-10 * S.cwiseAbs().maxCoeff());
      EXPECT_LT((p.thickness_m * d[4] - 3 * S).cwiseAbs().maxCoeff(), 1e-10 * S.cwiseAbs().maxCoeff());
      // Positive semi-definite (a minimum over the free rotations of a positive form).
      EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(S).eigenvalues().minCoeff(),
                -1e-12 * S.norm());
    }
  }
  // The Schur complement needs C positive definite: a12² ≥ a11 a22 is rejected by name.
  MaterialParameters bad = p;
  bad.a12_Pa = 1.01 * std::sqrt(p.a11_Pa * p.a22_Pa);
  try {
    TriangleShell shell(strip(4, 6), bad);
    ADD_FAILURE() << "indefinite C accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "a12_Pa");
  }
}

TEST(ShapeOperatorBending, ThreadCountDoesNotChangeResults) {
  // 24 cell columns: several bending slabs (face stencils span up to 5 columns), so the
  // parallel assembly path runs; every entry must be summed in the same order.
  const MaterialParameters p = nonlinear_parameters();
  for (TrianglePattern pattern : {TrianglePattern::Alternating, TrianglePattern::Cross}) {
    TriangleShellOptions o1 = options(pattern, 1), o2 = options(pattern, 2);
    o1.clamp_hinges = o2.clamp_hinges = StripEnds::Start;
    TriangleShell serial(strip(6, 24), p, o1), parallel(strip(6, 24), p, o2);
    const Eigen::VectorXd q =
        cylinder_positions(serial.rest_positions(), Eigen::Vector2d(1, 0.4), 0.05, 0.075);
    Eigen::VectorXd g1, g2;
    SparseMatrix H1, H2;
    EXPECT_EQ(serial.energy(q, &g1, &H1), parallel.energy(q, &g2, &H2)) << to_string(pattern);
    EXPECT_EQ((g1 - g2).cwiseAbs().maxCoeff(), 0.0) << to_string(pattern);
    EXPECT_EQ(SparseMatrix(H1 - H2).coeffs().cwiseAbs().maxCoeff(), 0.0) << to_string(pattern);
    Eigen::MatrixXd J1, J2;
    serial.gradient_parameter_jacobian(q, &J1);
    parallel.gradient_parameter_jacobian(q, &J2);
    EXPECT_EQ((J1 - J2).cwiseAbs().maxCoeff(), 0.0) << to_string(pattern);
  }
}

}  // namespace
}  // namespace twill
