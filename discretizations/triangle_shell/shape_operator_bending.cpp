#include "discretizations/triangle_shell/shape_operator_bending.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "discretizations/triangle_shell/hinge_bending.hpp"
#include "discretizations/triangle_shell/strip_triangulation.hpp"

namespace twill {
namespace {

/// Z_T is accepted when M_T (three hinge modes) is this well conditioned; a degenerate stencil
/// makes the face incomplete (one-sided split, still telescoping).
constexpr double kModeConditionFloor = 1e-8;

/// The map from curvature in mesh coordinates k = (Kxx, Kyy, Kxy) to the material-frame
/// ẽ = (d1ᵀKd1, d2ᵀKd2, d1ᵀKd2) (core/discretization.hpp: d2 = (cos θ, sin θ),
/// d1 = (−sin θ, cos θ)).
Eigen::Matrix3d material_frame_map(double angle_deg) {
  const double t = angle_deg * std::numbers::pi / 180.0;
  const Eigen::Vector2d d2(std::cos(t), std::sin(t)), d1(-std::sin(t), std::cos(t));
  Eigen::Matrix3d m;
  m << d1.x() * d1.x(), d1.y() * d1.y(), 2.0 * d1.x() * d1.y(),  //
      d2.x() * d2.x(), d2.y() * d2.y(), 2.0 * d2.x() * d2.y(),    //
      d1.x() * d2.x(), d1.y() * d2.y(), d1.x() * d2.y() + d1.y() * d2.x();
  return m;
}

/// ∂C/∂(a11, a12, a22, G12) for C of (2).
std::array<Eigen::Matrix3d, 4> law_stiffness_derivatives() {
  std::array<Eigen::Matrix3d, 4> d;
  for (auto& m : d) m.setZero();
  d[0](0, 0) = 1.0;
  d[1](0, 1) = d[1](1, 0) = 1.0;
  d[2](1, 1) = 1.0;
  d[3](2, 2) = 2.0;
  return d;
}

}  // namespace

Eigen::Matrix3d ShapeOperatorBending::law_stiffness(const MaterialParameters& p) {
  Eigen::Matrix3d C;
  C << p.a11_Pa, p.a12_Pa, 0.0,  //
      p.a12_Pa, p.a22_Pa, 0.0,   //
      0.0, 0.0, 2.0 * p.G12_Pa;
  return C;
}

namespace {

using Face = ShapeOperatorBending::Face;
using HingeModes = Eigen::Matrix<double, Eigen::Dynamic, 3>;

/// Per hinge, φ's mode: hinge_reference's mode m pairs with vec(K) = (K11, K22, √2 K12):
/// θ ≈ m0 Kxx + m1 Kyy + √2 m2 Kxy, and φ = −θ.
HingeModes reference_hinge_modes(const StripTriangulation& tri) {
  HingeModes modes(static_cast<Eigen::Index>(tri.hinges.size()), 3);
  for (size_t h = 0; h < tri.hinges.size(); ++h) {
    const Eigen::Vector3d m = hinge_reference(tri.reference_xy, tri.hinges[h]).mode;
    modes.row(static_cast<Eigen::Index>(h)) << -m[0], -m[1], -std::sqrt(2.0) * m[2];
  }
  return modes;
}

/// Per face and local edge: the angle id on it (−1: free boundary edge) and, for interior
/// hinges, the face and local edge on the other side.
struct EdgeAngles {
  std::vector<std::array<int, 3>> angle;
  std::vector<std::array<std::pair<int, int>, 3>> other_side;
};

EdgeAngles edge_angles(const StripTriangulation& tri, const std::vector<ClampEdge>& clamp_edges) {
  const int nf = tri.num_faces(), nv = tri.num_vertices();
  // Directed edge (a, b) → (face, local edge k) with (a, b) = (v_k, v_{k+1}) counter-clockwise.
  std::unordered_map<long long, std::pair<int, int>> directed;
  auto key = [nv](int a, int b) { return static_cast<long long>(a) * nv + b; };
  for (int f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) directed[key(tri.faces(f, k), tri.faces(f, (k + 1) % 3))] = {f, k};
  EdgeAngles out{std::vector<std::array<int, 3>>(static_cast<size_t>(nf), {-1, -1, -1}),
                 std::vector<std::array<std::pair<int, int>, 3>>(static_cast<size_t>(nf))};
  const auto at = [](auto& table, std::pair<int, int> e) -> auto& {
    return table[static_cast<size_t>(e.first)][static_cast<size_t>(e.second)];
  };
  const int num_hinges = static_cast<int>(tri.hinges.size());
  for (int h = 0; h < num_hinges; ++h) {
    const Hinge& hinge = tri.hinges[static_cast<size_t>(h)];
    const auto a = directed.at(key(hinge.v[0], hinge.v[1]));  // triangle (v0, v1, v2)
    const auto b = directed.at(key(hinge.v[1], hinge.v[0]));  // triangle (v1, v0, v3)
    at(out.angle, a) = at(out.angle, b) = h;
    at(out.other_side, a) = b;
    at(out.other_side, b) = a;
  }
  for (size_t c = 0; c < clamp_edges.size(); ++c) {
    int& angle = at(out.angle, std::pair<int, int>{clamp_edges[c].face, clamp_edges[c].local_edge});
    if (angle >= 0) throw std::logic_error("ShapeOperatorBending: a clamp edge is an interior hinge");
    angle = num_hinges + static_cast<int>(c);
  }
  return out;
}

/// Face f's geometry of (1): its area and curvature map; N (k = N s, columns |ē_k|/Ā (n_x²,
/// n_y², n_x n_y)) into `normal_map`.
Face face_geometry(const StripTriangulation& tri, int f, const Eigen::Matrix3d& frame, Eigen::Matrix3d* normal_map) {
  Face face;
  const auto X = [&](int k) { return Eigen::Vector2d(tri.reference_xy.row(tri.faces(f, k % 3))); };
  const Eigen::Vector2d e1 = X(1) - X(0), e2 = X(2) - X(0);
  face.area = 0.5 * (e1.x() * e2.y() - e1.y() * e2.x());
  Eigen::Matrix3d& N = *normal_map;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d e = X(k + 1) - X(k);
    const double len = e.norm();
    const Eigen::Vector2d n(e.y() / len, -e.x() / len);  // outward for counter-clockwise
    N.col(k) << n.x() * n.x(), n.y() * n.y(), n.x() * n.y();
    N.col(k) *= len / face.area;
  }
  face.curvature_map = frame * N;
  return face;
}

/// The consistent split Z_T of a face whose three edges are interior hinges (`angles`), or
/// nothing (and the face incomplete) when it has another edge or a degenerate stencil.
Eigen::Matrix3d consistent_split(const std::array<int, 3>& angles, int num_hinges, const HingeModes& modes,
                                 const Eigen::Matrix3d& normal_map, Face* face) {
  face->complete = std::all_of(angles.begin(), angles.end(), [&](int a) { return a >= 0 && a < num_hinges; });
  if (!face->complete) return Eigen::Matrix3d::Zero();
  Eigen::Matrix3d M;
  for (int k = 0; k < 3; ++k) M.row(k) = modes.row(angles[static_cast<size_t>(k)]);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(M), lu_n(normal_map);
  if (lu.rcond() > kModeConditionFloor && lu_n.rcond() > kModeConditionFloor) return lu_n.solve(lu.inverse());
  face->complete = false;
  return Eigen::Matrix3d::Zero();
}

/// Face f's sources and edge map, split (3): each measured edge's rotation from its own angle
/// and the consistent splits of the complete faces on either side.
void split_sources(int f, const EdgeAngles& edges, const std::vector<Eigen::Matrix3d>& Z, int num_hinges,
                   std::vector<Face>& faces) {
  Face& face = faces[static_cast<size_t>(f)];
  const auto fu = static_cast<size_t>(f);
  std::vector<std::array<double, 3>> rows;  // per source: coefficient on s_0, s_1, s_2
  auto add = [&](int angle, int k, double c) {
    size_t j = 0;
    while (j < face.sources.size() && face.sources[j] != angle) ++j;
    if (j == face.sources.size()) {
      face.sources.push_back(angle);
      rows.push_back({0.0, 0.0, 0.0});
    }
    rows[j][static_cast<size_t>(k)] += c;
  };
  // s^c_{g,k'} = Σ_j Z_g(k', j) φ(angle on edge j of g), times `scale`.
  auto add_consistent = [&](int g, int k_g, int k, double scale) {
    const auto gu = static_cast<size_t>(g);
    for (int j = 0; j < 3; ++j) add(edges.angle[gu][static_cast<size_t>(j)], k, scale * Z[gu](k_g, j));
  };
  for (int k = 0; k < 3; ++k) {
    const int angle = edges.angle[fu][static_cast<size_t>(k)];
    if (angle < 0) continue;  // free edge
    face.measured.push_back(k);
    if (angle >= num_hinges) {
      add(angle, k, 1.0);  // clamp: s = φ_b, the tilt against the platform
      continue;
    }
    const auto [g, k_g] = edges.other_side[fu][static_cast<size_t>(k)];
    const bool mine = face.complete, theirs = faces[static_cast<size_t>(g)].complete;
    if (mine && theirs) {
      add(angle, k, 0.5);
      add_consistent(f, k, k, 0.5);
      add_consistent(g, k_g, k, -0.5);
    } else if (mine) {
      add_consistent(f, k, k, 1.0);
    } else if (theirs) {
      add(angle, k, 1.0);
      add_consistent(g, k_g, k, -1.0);
    } else {
      add(angle, k, 0.5);
    }
  }
  face.edge_map.resize(static_cast<Eigen::Index>(face.measured.size()), static_cast<Eigen::Index>(face.sources.size()));
  for (size_t r = 0; r < face.measured.size(); ++r)
    for (size_t j = 0; j < face.sources.size(); ++j)
      face.edge_map(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(j)) =
          rows[j][static_cast<size_t>(face.measured[r])];
}

}  // namespace

ShapeOperatorBending::ShapeOperatorBending(const StripTriangulation& tri, const std::vector<ClampEdge>& clamp_edges,
                                           double angle_deg) {
  const int nf = tri.num_faces();
  num_hinges_ = static_cast<int>(tri.hinges.size());
  num_angles_ = num_hinges_ + static_cast<int>(clamp_edges.size());
  modes_ = reference_hinge_modes(tri);
  const EdgeAngles edges = edge_angles(tri, clamp_edges);
  const Eigen::Matrix3d frame = material_frame_map(angle_deg);
  // Every face's geometry and split first: a face's sources read its neighbours' completeness.
  faces_.resize(static_cast<size_t>(nf));
  std::vector<Eigen::Matrix3d> Z(static_cast<size_t>(nf));
  for (int f = 0; f < nf; ++f) {
    Eigen::Matrix3d N;
    faces_[static_cast<size_t>(f)] = face_geometry(tri, f, frame, &N);
    Z[static_cast<size_t>(f)] = consistent_split(edges.angle[static_cast<size_t>(f)], num_hinges_, modes_, N,
                                                 &faces_[static_cast<size_t>(f)]);
  }
  for (int f = 0; f < nf; ++f) split_sources(f, edges, Z, num_hinges_, faces_);
}

ShapeOperatorStiffness ShapeOperatorBending::solve(const MaterialParameters& p) const {
  if (!(p.a11_Pa > 0.0 && p.a22_Pa > 0.0 && p.G12_Pa > 0.0 &&
        p.a11_Pa * p.a22_Pa > p.a12_Pa * p.a12_Pa))
    throw std::invalid_argument(
        "shape-operator bending needs a positive definite small-strain stiffness: a11 > 0, "
        "a22 > 0, G12 > 0 and a12² < a11·a22 (got a11 = " +
        std::to_string(p.a11_Pa) + ", a12 = " + std::to_string(p.a12_Pa) +
        ", a22 = " + std::to_string(p.a22_Pa) + ")");
  const Eigen::Matrix3d C = law_stiffness(p);
  const double tau = p.thickness_m, c = tau * tau * tau / 24.0;
  ShapeOperatorStiffness out;
  out.form.resize(faces_.size());
  out.completion.resize(faces_.size());
  for (size_t f = 0; f < faces_.size(); ++f) {
    const Face& face = faces_[f];
    const Eigen::Matrix3d Q =
        c * face.area * face.curvature_map.transpose() * C * face.curvature_map;
    const auto nm = static_cast<Eigen::Index>(face.measured.size());
    std::vector<int> free;
    for (int k = 0; k < 3; ++k)
      if (std::find(face.measured.begin(), face.measured.end(), k) == face.measured.end())
        free.push_back(k);
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(3, nm);
    for (Eigen::Index r = 0; r < nm; ++r) T(face.measured[static_cast<size_t>(r)], r) = 1.0;
    if (!free.empty() && nm > 0) {
      const auto nfree = static_cast<Eigen::Index>(free.size());
      Eigen::MatrixXd Qff(nfree, nfree), Qfm(nfree, nm);
      for (Eigen::Index a = 0; a < nfree; ++a) {
        for (Eigen::Index b = 0; b < nfree; ++b)
          Qff(a, b) = Q(free[static_cast<size_t>(a)], free[static_cast<size_t>(b)]);
        for (Eigen::Index b = 0; b < nm; ++b)
          Qfm(a, b) = Q(free[static_cast<size_t>(a)], face.measured[static_cast<size_t>(b)]);
      }
      // The free rotations at their minimiser: Q_ff u = −Q_fm s_m (Q_ff is positive definite
      // for positive definite C and non-degenerate triangles).
      const Eigen::MatrixXd X = Qff.ldlt().solve(Qfm);
      for (Eigen::Index a = 0; a < nfree; ++a) T.row(free[static_cast<size_t>(a)]) = -X.row(a);
    }
    out.form[f] = T.transpose() * Q * T;
    out.completion[f] = std::move(T);
  }
  return out;
}

std::array<Eigen::MatrixXd, 5> ShapeOperatorBending::form_derivative(
    int face_index, const MaterialParameters& p, const ShapeOperatorStiffness& s) const {
  const Face& face = faces_[static_cast<size_t>(face_index)];
  const Eigen::MatrixXd& T = s.completion[static_cast<size_t>(face_index)];
  const double tau = p.thickness_m, c = tau * tau * tau / 24.0;
  const auto dC = law_stiffness_derivatives();
  std::array<Eigen::MatrixXd, 5> out;
  // Envelope theorem: the completion is stationary, so only Q's explicit dependence counts.
  for (size_t i = 0; i < 4; ++i) {
    const Eigen::Matrix3d dQ =
        c * face.area * face.curvature_map.transpose() * dC[i] * face.curvature_map;
    out[i] = T.transpose() * dQ * T;
  }
  out[4] = 3.0 / tau * s.form[static_cast<size_t>(face_index)];
  return out;
}

Eigen::Matrix<double, Eigen::Dynamic, 3> ShapeOperatorBending::curvatures(
    const Eigen::VectorXd& phi, const ShapeOperatorStiffness& s) const {
  Eigen::Matrix<double, Eigen::Dynamic, 3> out(static_cast<Eigen::Index>(faces_.size()), 3);
  for (size_t f = 0; f < faces_.size(); ++f) {
    const Face& face = faces_[f];
    Eigen::VectorXd source(static_cast<Eigen::Index>(face.sources.size()));
    for (size_t j = 0; j < face.sources.size(); ++j)
      source[static_cast<Eigen::Index>(j)] = phi[face.sources[j]];
    const Eigen::Vector3d rotations = s.completion[f] * (face.edge_map * source);
    out.row(static_cast<Eigen::Index>(f)) = (face.curvature_map * rotations).transpose();
  }
  return out;
}

}  // namespace twill
