// Tests of the Catmull–Clark Kirchhoff–Love discretisation at physical canvas sizes
// (L = 75 mm, W = 50 mm, τ = 0.45 mm, a11 = 3e7 Pa, …, density 0.294 kg/m²) on small meshes.
// Every patch of a rectangular grid is a regular B-spline patch (no Gregory patches), so the
// derivative checks cover exactly the patch types this discretisation can produce.
//
// Scales: forces are O(1–100 N) and the bending stiffness is ~1e-7 of the stretching one, so
// finite-difference steps are relative to the strip length (positions) or to each parameter,
// and errors are relative to the size of the derivative being checked. The bending kernel is
// checked on its own, where it is not drowned by membrane terms, in
// test_catmull_clark_kl_kernel.cpp.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/bending_scale.hpp"
#include "core/input_error.hpp"
#include "core/material_law.hpp"
#include "discretizations/catmull_clark_kl/catmull_clark_kl.hpp"
#include "discretizations/catmull_clark_kl/gauss_legendre.hpp"
#include "tests/discretizations/discretization_checks.hpp"
#include "tests/support/test_materials.hpp"

namespace twill {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using testing::canvas_stvk;
using testing::distorted_state;
using testing::smooth_direction;

constexpr double kLength = 0.075, kWidth = 0.050;

StripSpec small_strip(double angle_deg, int across = 3, int along = 4) {
  StripSpec s;
  s.length_m = kLength;
  s.width_m = kWidth;
  s.cells_across = across;
  s.cells_along = along;
  s.angle_deg = angle_deg;
  return s;
}

/// Degree-2 curves and a validity box that the distorted state leaves (compression below
/// E_min = 0 and stretch above the maxima).
MaterialParameters canvas_nonlinear() {
  MaterialParameters p = testing::canvas_degree2();
  p.cutoffs.E11_min = 0.0;
  p.cutoffs.E11_max = 0.03;
  p.cutoffs.E22_min = 0.0;
  p.cutoffs.E22_max = 0.04;
  p.cutoffs.E12_max = 0.02;
  return p;
}

Eigen::Matrix3d material_frame(double angle_deg) {
  const double t = angle_deg * M_PI / 180.0;
  Eigen::Matrix3d D = Eigen::Matrix3d::Zero();
  D.col(0) << -std::sin(t), std::cos(t), 0;  // d1 warp
  D.col(1) << std::cos(t), std::sin(t), 0;   // d2 weft
  D(2, 2) = 1.0;
  return D;
}

CatmullClarkKLOptions two_threads() {
  CatmullClarkKLOptions o;
  o.threads = 2;
  return o;
}

/// Every fibre-strain treatment the option accepts (the one list in kirchhoff_love_face).
std::vector<FibreStrain> all_fibre_strains() {
  std::vector<FibreStrain> all;
  for (const auto& [value, name] : fibre_strain_names()) all.push_back(value);
  return all;
}

/// Two threads, and the fibre-strain treatment under test.
CatmullClarkKLOptions two_threads(FibreStrain fibre_strain) {
  CatmullClarkKLOptions o = two_threads();
  o.fibre_strain = fibre_strain;
  return o;
}

/// Orthotropic strain (Ẽ11, Ẽ22, |Ẽ12|) at every through-thickness point of every Gauss
/// point: the arguments at which the law is evaluated.
std::array<std::vector<double>, 3> law_arguments(const CatmullClarkKL& d, const VectorXd& q) {
  const GaussLegendreRule rule = GaussLegendreRule::make(d.options().thickness_points);
  const double h = 0.5 * d.parameters().thickness_m;
  const Vector3d scale = bending_scale(d.parameters()).diagonal;  // the law sees S e_b
  std::array<std::vector<double>, 3> values;
  for (const auto& point : d.quadrature_strains(q))
    for (double s : rule.nodes) {
      const Vector3d e = point.membrane - h * s * scale.cwiseProduct(point.bending);
      values[0].push_back(e[0]);
      values[1].push_back(e[1]);
      values[2].push_back(std::abs(e[2]));
    }
  return values;
}

/// Cutoffs placed in the widest gaps of the law arguments at q (lower bounds among the lower
/// third of the values, upper bounds among the upper third): many points lie outside the
/// box, many inside, and none within `margin` of a box face. ψ is only C² across a face, so
/// a central difference of the gradient whose stencil crosses one loses an order; with the
/// cutoffs in gaps, a step that moves no argument by more than `margin` stays smooth.
struct CutoffDesign {
  Cutoffs cutoffs;
  double margin = 0.0;
};

CutoffDesign cutoffs_in_gaps(const std::array<std::vector<double>, 3>& arguments) {
  CutoffDesign design;
  design.margin = std::numeric_limits<double>::infinity();
  auto widest_gap = [&](std::vector<double> v, double from, double to) {
    std::sort(v.begin(), v.end());
    const auto first = static_cast<size_t>(from * static_cast<double>(v.size()));
    const auto last = static_cast<size_t>(to * static_cast<double>(v.size()));
    double best = 0.0, at = 0.0;
    for (size_t k = first; k < last; ++k)
      if (v[k + 1] - v[k] > best) {
        best = v[k + 1] - v[k];
        at = 0.5 * (v[k] + v[k + 1]);
      }
    design.margin = std::min(design.margin, 0.5 * best);
    return at;
  };
  design.cutoffs.E11_min = widest_gap(arguments[0], 0.05, 0.35);
  design.cutoffs.E11_max = widest_gap(arguments[0], 0.65, 0.95);
  design.cutoffs.E22_min = widest_gap(arguments[1], 0.05, 0.35);
  design.cutoffs.E22_max = widest_gap(arguments[1], 0.65, 0.95);
  design.cutoffs.E12_max = widest_gap(arguments[2], 0.55, 0.95);
  return design;
}

/// Largest change of any law argument between two states.
double largest_argument_change(const CatmullClarkKL& d, const VectorXd& q1, const VectorXd& q2) {
  const auto a = law_arguments(d, q1), b = law_arguments(d, q2);
  double change = 0.0;
  for (int c = 0; c < 3; ++c)
    for (size_t k = 0; k < a[static_cast<size_t>(c)].size(); ++k)
      change = std::max(change, std::abs(a[static_cast<size_t>(c)][k] - b[static_cast<size_t>(c)][k]));
  return change;
}

TEST(CatmullClarkKLOptions, ValidateNamesTheOffendingField) {
  std::string error;
  EXPECT_TRUE(CatmullClarkKLOptions{}.validate(&error)) << error;
  auto message_for = [](auto mutate) {
    CatmullClarkKLOptions o;
    mutate(o);
    std::string message;
    EXPECT_FALSE(o.validate(&message));
    return message;
  };
  EXPECT_NE(message_for([](auto& o) { o.gauss_points_per_direction = 0; }).find("gauss_points_per_direction"), std::string::npos);
  EXPECT_NE(message_for([](auto& o) { o.thickness_points = 1; }).find("thickness_points"), std::string::npos);
  EXPECT_NE(message_for([](auto& o) { o.threads = -1; }).find("threads"), std::string::npos);
  EXPECT_NE(message_for([](auto& o) { o.surface_samples_per_face = 0; }).find("surface_samples_per_face"), std::string::npos);
  // The cross-field rule (validate() itself, not a binding's range).
  EXPECT_EQ(message_for([](auto& o) {
              o.gauss_points_per_direction = 1;
              o.fibre_strain = FibreStrain::FaceLinear;
            }).rfind("gauss_points_per_direction must be >= 2 for fibre_strain=face-linear", 0),
            0u);
  CatmullClarkKLOptions bad;
  bad.thickness_points = 1;
  try {
    CatmullClarkKL d(small_strip(0), canvas_stvk(), bad);
    FAIL() << "invalid options accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "thickness_points");
  }
  StripSpec strip = small_strip(0);
  strip.cells_across = 0;
  try {
    CatmullClarkKL d(strip, canvas_stvk());
    FAIL() << "invalid strip accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "cells_across");
  }
}

TEST(CatmullClarkKL, MeshLayoutAndRestState) {
  for (FibreStrain fibre_strain : all_fibre_strains()) {
  SCOPED_TRACE(fibre_strain_name(fibre_strain));
  CatmullClarkKLOptions options;
  options.fibre_strain = fibre_strain;
  const CatmullClarkKL d(small_strip(90), canvas_stvk(), options);
  EXPECT_EQ(d.name(), "catmull-clark-kl");
  EXPECT_EQ(d.num_nodes(), 5 * 4);
  EXPECT_EQ(d.num_faces(), 12);
  EXPECT_EQ(d.num_quadrature_points(), 12 * 16);
  VectorXd g;
  SparseMatrix H;
  EXPECT_EQ(d.energy(d.rest_positions(), &g, &H), 0.0);  // a = A, b = B bit for bit
  EXPECT_EQ(g.cwiseAbs().maxCoeff(), 0.0);
  // At rest the Hessian is the small-strain stiffness: positive semi-definite with exactly
  // the six rigid motions as zero modes (no spurious zero-energy mode of the quadrature).
  // Bending eigenvalues are ~(τ/h)² ~ 1e-4 of the membrane ones, far above round-off.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen((Eigen::MatrixXd(H)));
  const VectorXd& lambda = eigen.eigenvalues();
  const double largest = lambda.cwiseAbs().maxCoeff();
  for (int k = 0; k < 6; ++k) EXPECT_LT(std::abs(lambda[k]), 1e-12 * largest) << k;
  EXPECT_GT(lambda[6], 1e-8 * largest);
  EXPECT_THROW(d.energy(VectorXd::Zero(7), nullptr, nullptr), std::invalid_argument);
  }
}

// The patch test's energy (L·W·τ·ψ(Ẽ)) is checked for every registered part in
// test_every_discretization.cpp; here, the strains the law sees at every Gauss point.
TEST(CatmullClarkKL, PatchTestStrainsAreUniformAtEveryAngle) {
  for (FibreStrain fibre_strain : all_fibre_strains())
  for (double angle : {0.0, 22.5, 45.0, 67.5, 90.0}) {
    const MaterialParameters parameters = canvas_nonlinear();
    const CatmullClarkKL d(small_strip(angle), parameters, two_threads(fibre_strain));
    // In-plane affine map: stretch, contraction, shear, then a rigid rotation about z.
    Eigen::Matrix2d F;
    F << 1.03, 0.012, -0.004, 0.985;
    const Eigen::Matrix2d R = Eigen::Rotation2Dd(0.3).toRotationMatrix();
    const Eigen::Matrix2d RF = R * F;
    VectorXd q = d.rest_positions();
    for (int i = 0; i < d.num_nodes(); ++i) {
      q.segment<2>(3 * i) = RF * q.segment<2>(3 * i) + Vector2d(0.01, -0.02);
      q[3 * i + 2] = 0.003;
    }
    Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
    E.topLeftCorner<2, 2>() = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
    const Eigen::Matrix3d D = material_frame(angle);
    const Eigen::Matrix3d Et = D.transpose() * E * D;
    const Vector3 expected(Et(0, 0), Et(1, 1), Et(0, 1));

    for (const auto& point : d.quadrature_strains(q)) {
      EXPECT_LT((point.membrane - expected).cwiseAbs().maxCoeff(), 1e-14) << "angle " << angle;
      EXPECT_LT(point.bending.cwiseAbs().maxCoeff(), 1e-10);  // [1/m]; κ = 0 up to round-off
    }
  }
}

TEST(CatmullClarkKL, ProjectionReplacesOnlyTheFibreStretchesByTheirFaceProjection) {
  // docs/catmull_clark_kl.md §12: with a projecting FibreStrain the law sees, at every Gauss
  // point of a face, the weighted least-squares fit of Ẽ11 and Ẽ22 over the face's points by
  // the space's polynomials in (u, v) (on this affine grid |A1×A2| is constant, so the weights
  // are the tensor Gauss weights, point p = ng·b + a), and the point's own Ẽ12 and bending
  // strain. The fit is computed here independently, by a normal-equation solve.
  const std::map<FibreStrain, int> modes = {{FibreStrain::FaceMean, 1}, {FibreStrain::FaceLinear, 3},
                                            {FibreStrain::FaceBilinear, 4}};
  for (FibreStrain fibre_strain : all_fibre_strains()) {
    if (fibre_strain == FibreStrain::Pointwise) continue;
    SCOPED_TRACE(fibre_strain_name(fibre_strain));
    ASSERT_EQ(projection_modes(fibre_strain), modes.at(fibre_strain));
    CatmullClarkKLOptions pointwise, projected;
    pointwise.fibre_strain = FibreStrain::Pointwise;
    projected.fibre_strain = fibre_strain;
    const CatmullClarkKL a(small_strip(30), canvas_nonlinear(), pointwise);
    const CatmullClarkKL b(small_strip(30), canvas_nonlinear(), projected);
    const VectorXd q = distorted_state(a);
    const auto own = a.quadrature_strains(q), seen = b.quadrature_strains(q);
    ASSERT_EQ(own.size(), seen.size());
    const size_t per_face = own.size() / static_cast<size_t>(a.num_faces());
    const GaussLegendreRule rule = GaussLegendreRule::make(a.options().gauss_points_per_direction);
    const size_t ng = rule.nodes.size();
    ASSERT_EQ(ng * ng, per_face);
    const int m = modes.at(fibre_strain);
    Eigen::MatrixXd P(per_face, m);  // the space's polynomials at the points
    VectorXd w(per_face);
    for (size_t p = 0; p < per_face; ++p) {
      const double u = 0.5 * (1 + rule.nodes[p % ng]), v = 0.5 * (1 + rule.nodes[p / ng]);
      const double row[4] = {1.0, u, v, u * v};
      for (int k = 0; k < m; ++k) P(static_cast<Eigen::Index>(p), k) = row[k];
      w[static_cast<Eigen::Index>(p)] = 0.25 * rule.weights[p % ng] * rule.weights[p / ng];
    }
    const Eigen::MatrixXd normal = P.transpose() * w.asDiagonal() * P;
    double spread = 0.0, residual = 0.0;  // how far Ẽ11 is from the space: the projection must remove it
    for (size_t face = 0; face < static_cast<size_t>(a.num_faces()); ++face) {
      Eigen::MatrixXd fibre(per_face, 2);
      for (size_t p = 0; p < per_face; ++p)
        fibre.row(static_cast<Eigen::Index>(p)) = own[face * per_face + p].membrane.head<2>().transpose();
      const Eigen::MatrixXd fitted = P * normal.ldlt().solve(P.transpose() * w.asDiagonal() * fibre);
      for (size_t p = 0; p < per_face; ++p) {
        const auto& o = own[face * per_face + p];
        const auto& s = seen[face * per_face + p];
        spread = std::max(spread, std::abs(o.membrane[0] - fitted(static_cast<Eigen::Index>(p), 0)));
        residual = std::max(residual, (s.membrane.head<2>().transpose() - fitted.row(static_cast<Eigen::Index>(p))).cwiseAbs().maxCoeff());
        EXPECT_EQ(s.membrane[2], o.membrane[2]);
        EXPECT_EQ(s.bending, o.bending);
      }
    }
    EXPECT_LT(residual, 1e-14);
    EXPECT_GT(spread, 1e-6);  // the state is not in the space, so the check above has teeth
    EXPECT_NE(a.energy(q, nullptr, nullptr), b.energy(q, nullptr, nullptr));
  }
}

// Every derivative check runs for every fibre-strain treatment: a projection couples all
// Gauss points of a face (docs/catmull_clark_kl.md §12), so its Hessian and ∂g/∂k
// have terms the pointwise energy does not.
class CatmullClarkKLDerivatives : public ::testing::TestWithParam<FibreStrain> {
 protected:
  CatmullClarkKLDerivatives()
      : d_(small_strip(30), canvas_nonlinear(), two_threads(GetParam())), q_(distorted_state(d_)) {
    design_ = cutoffs_in_gaps(law_arguments(d_, q_));
    MaterialParameters p = d_.parameters();
    p.cutoffs = design_.cutoffs;
    d_.set_parameters(p);
  }

  /// FD step along q: no law argument moves by more than half the margin over the stencil.
  static constexpr double kStep = 2e-5;

  CatmullClarkKL d_;
  VectorXd q_;
  CutoffDesign design_;
};

TEST_P(CatmullClarkKLDerivatives, StateLeavesTheCutoffBoxAwayFromItsFaces) {
  const Cutoffs& box = d_.parameters().cutoffs;
  int outside = 0, inside = 0;
  for (const auto& point : d_.quadrature_strains(q_)) {
    const Vector3d& e = point.membrane;
    const bool out = e[0] < *box.E11_min || e[0] > *box.E11_max || e[1] < *box.E22_min ||
                     e[1] > *box.E22_max || std::abs(e[2]) > *box.E12_max;
    (out ? outside : inside)++;
  }
  EXPECT_GT(outside, 0);
  EXPECT_GT(inside, 0);
  // Every box face has law arguments on both sides, at least `margin` away.
  const auto arguments = law_arguments(d_, q_);
  auto count_below = [](const std::vector<double>& v, double bound) {
    return std::count_if(v.begin(), v.end(), [&](double x) { return x < bound; });
  };
  for (auto [c, bound] : {std::pair{0, *box.E11_min}, std::pair{0, *box.E11_max},
                          std::pair{1, *box.E22_min}, std::pair{1, *box.E22_max},
                          std::pair{2, *box.E12_max}}) {
    const auto& v = arguments[static_cast<size_t>(c)];
    EXPECT_GT(count_below(v, bound), 0);
    EXPECT_LT(count_below(v, bound), static_cast<long>(v.size()));
    for (double x : v) EXPECT_GE(std::abs(x - bound), 0.999 * design_.margin);
  }
  EXPECT_GT(design_.margin, 1e-4);
  EXPECT_LT(*box.E11_min, 0.0);  // compression outside the data, as with the paper's E_min = 0
}

TEST_P(CatmullClarkKLDerivatives, GradientMatchesFiniteDifferencesAtSecondOrder) {
  for (unsigned seed : {11u, 12u}) testing::expect_gradient_converges(d_, q_, smooth_direction(d_, seed), 1e-3, 4, 1e-6);
}

TEST_P(CatmullClarkKLDerivatives, HessianMatchesFiniteDifferencesOfTheGradient) {
  for (unsigned seed : {21u, 22u}) {
    const VectorXd v = smooth_direction(d_, seed);
    ASSERT_LT(largest_argument_change(d_, q_, q_ + kStep * v), 0.5 * design_.margin);
    ASSERT_LT(largest_argument_change(d_, q_, q_ - kStep * v), 0.5 * design_.margin);
    testing::expect_hessian_converges(d_, q_, v, kStep, 3, 1e-6, 1e-12);
  }
  SparseMatrix H;
  d_.energy(q_, nullptr, &H);
  const Eigen::MatrixXd dense = H;
  // Every entry, not only directions: one FD column per dof against the matrix (tolerance
  // relative to the largest stiffness, at a step inside the second-order range above).
  const double h = 0.5 * kStep;  // unit steps: smaller than kStep · |v| (v ~ strip length)
  auto gradient_at = [&](const VectorXd& x) {
    VectorXd g;
    d_.energy(x, &g, nullptr);
    return g;
  };
  double worst = 0.0;
  for (int column = 0; column < d_.num_dofs(); ++column) {
    VectorXd plus = q_, minus = q_;
    plus[column] += h;
    minus[column] -= h;
    const VectorXd fd = (gradient_at(plus) - gradient_at(minus)) / (2 * h);
    worst = std::max(worst, (fd - dense.col(column)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6 * dense.cwiseAbs().maxCoeff());
}

TEST_P(CatmullClarkKLDerivatives, ParameterJacobianMatchesFiniteDifferencesForEveryParameter) {
  d_.set_gravity(Vector3d(0.4, -0.3, -9.81));  // so that density enters the gradient
  // Degree-2 curves: one mu and two alphas each; the linear coupling curve's alpha; then the
  // two bending ratios. (A nonlinear coupling curve: EveryDiscretization.CouplingCurve….)
  ASSERT_EQ(d_.parameters().to_flat().size(), 6 + 3 * 3 + 1 + FlatLayout::kBendingRatios);
  const testing::ParameterStepRule step = testing::relative_parameter_step;
  // τ and the bending ratios move the through-thickness points: no law argument may cross a
  // cutoff over the stencil.
  const MaterialParameters p0 = d_.parameters();
  const Eigen::VectorXd k0 = p0.to_flat();
  for (const char* name : {"thickness_m", kBendingWarpRatioName, kBendingWeftRatioName}) {
    const int column = p0.index_of(name);
    const double h0 = step(name, k0[column])->h0;
    for (double sign : {-1.0, 1.0}) {
      MaterialParameters moved = p0;
      moved.set_from_flat(k0 + sign * h0 * VectorXd::Unit(k0.size(), column));
      const auto before = law_arguments(d_, q_);
      const auto after = law_arguments(CatmullClarkKL(d_.strip(), moved, d_.options()), q_);
      for (int c = 0; c < 3; ++c)
        for (size_t k = 0; k < before[static_cast<size_t>(c)].size(); ++k)
          ASSERT_LT(std::abs(after[static_cast<size_t>(c)][k] - before[static_cast<size_t>(c)][k]),
                    0.5 * design_.margin) << name;
    }
  }
  testing::expect_parameter_jacobian_converges(d_, q_, step, 4, 1e-6);
}

// Pattern reuse is checked for every registered part in test_every_discretization.cpp.
TEST_P(CatmullClarkKLDerivatives, AssemblyStrategiesAgree) {
  VectorXd g1;
  SparseMatrix H1;
  const double e1 = d_.energy(q_, &g1, &H1);

  for (auto assembly : {CatmullClarkKLOptions::Assembly::Colouring, CatmullClarkKLOptions::Assembly::ThreadLocal})
    for (int threads : {1, 2}) {
      CatmullClarkKLOptions o = d_.options();
      o.assembly = assembly;
      o.threads = threads;
      const CatmullClarkKL other(d_.strip(), d_.parameters(), o);
      VectorXd g2;
      SparseMatrix H2;
      const double e2 = other.energy(q_, &g2, &H2);
      if (assembly == CatmullClarkKLOptions::Assembly::Colouring) {
        // Colouring fixes the summation order: bitwise equal for any thread count.
        EXPECT_EQ(e2, e1);
        EXPECT_EQ((g2 - g1).cwiseAbs().maxCoeff(), 0.0);
        EXPECT_EQ(Eigen::MatrixXd(H2 - H1).cwiseAbs().maxCoeff(), 0.0);
      }
      EXPECT_NEAR(e2, e1, 1e-14 * e1);
      EXPECT_LT((g2 - g1).cwiseAbs().maxCoeff(), 1e-13 * g1.cwiseAbs().maxCoeff());
      EXPECT_LT(Eigen::MatrixXd(H2 - H1).cwiseAbs().maxCoeff(),
                1e-13 * Eigen::MatrixXd(H1).cwiseAbs().maxCoeff());
      Eigen::MatrixXd dk1, dk2;
      d_.gradient_parameter_jacobian(q_, &dk1);
      other.gradient_parameter_jacobian(q_, &dk2);
      EXPECT_LT((dk2 - dk1).cwiseAbs().maxCoeff(), 1e-13 * dk1.cwiseAbs().maxCoeff());
    }
}

INSTANTIATE_TEST_SUITE_P(FibreStrain, CatmullClarkKLDerivatives,
                         ::testing::ValuesIn(all_fibre_strains()),
                         [](const auto& param) {
                           std::string name = fibre_strain_name(param.param);
                           std::replace(name.begin(), name.end(), '-', '_');
                           return name;
                         });

TEST(CatmullClarkKL, ThroughThicknessQuadratureIsExactForStVKAndConvergesOtherwise) {
  // StVK: Ψ does not depend on n_ξ ≥ 2 (the ξ-integrand is a quadratic polynomial).
  const StripSpec strip = small_strip(30);
  const CatmullClarkKL reference_mesh(strip, canvas_stvk());
  const VectorXd q = distorted_state(reference_mesh);
  std::vector<double> stvk;
  for (int n : {2, 3, 6}) {
    CatmullClarkKLOptions o;
    o.thickness_points = n;
    stvk.push_back(CatmullClarkKL(strip, canvas_stvk(), o).energy(q, nullptr, nullptr));
  }
  EXPECT_NEAR(stvk[1], stvk[0], 1e-14 * stvk[0]);
  EXPECT_NEAR(stvk[2], stvk[0], 1e-14 * stvk[0]);

  // Nonlinear law (no cutoffs, so the integrand is smooth; the kernel test covers cutoffs):
  // the n_ξ-dependent part of Ψ, i.e. the bending energy, converges geometrically.
  MaterialParameters smooth = canvas_nonlinear();
  smooth.cutoffs = Cutoffs{std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  auto energy_with = [&](const MaterialParameters& p, int n) {
    CatmullClarkKLOptions o;
    o.thickness_points = n;
    return CatmullClarkKL(strip, p, o).energy(q, nullptr, nullptr);
  };
  MaterialParameters thin = smooth;
  thin.thickness_m *= 1e-3;  // bending scales as τ³, membrane as τ: this isolates the membrane
  const double converged = energy_with(smooth, 24);
  const double bending = converged - 1e3 * energy_with(thin, 2);
  ASSERT_GT(bending, 1e-4 * converged);
  std::vector<double> errors;
  for (int n : {2, 3, 4, 5}) errors.push_back(std::abs(energy_with(smooth, n) - converged) / bending);
  // At physical sizes τκ/2 ~ 1e-3: two points leave a small error that the quartic and higher
  // terms of η cause, three points (the default) are converged to round-off.
  EXPECT_GT(errors[0], 1e-9);  // the integrand is not a polynomial
  for (size_t k = 1; k < errors.size(); ++k) EXPECT_LT(errors[k], std::max(1e-3 * errors[0], 1e-10));
}

TEST(CatmullClarkKL, ClampedBoundaryRowMakesTheEndRigid) {
  const CatmullClarkKL d(small_strip(45), canvas_stvk());
  const int nx = d.strip().cells_along, ny = d.strip().cells_across;
  for (StripEnd end : {StripEnd::Start, StripEnd::End}) {
    const double x_end = end == StripEnd::Start ? 0.0 : kLength;
    const std::vector<int> row = d.clamped_nodes(end, false);
    const std::vector<int> rows = d.clamped_nodes(end, true);
    EXPECT_EQ(static_cast<int>(row.size()), ny + 1);
    EXPECT_EQ(static_cast<int>(rows.size()), 2 * (ny + 1));
    for (int node : row)
      EXPECT_EQ(d.rest_positions()[3 * node], x_end);

    // Move every unclamped control point randomly (large, out of plane too).
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> uniform(-0.01, 0.01);
    auto perturbed = [&](const std::vector<int>& held) {
      VectorXd q = d.rest_positions();
      for (int i = 0; i < d.num_nodes(); ++i)
        if (!std::binary_search(held.begin(), held.end(), i))
          for (int c = 0; c < 3; ++c) q[3 * i + c] += uniform(rng);
      return q;
    };
    std::vector<Vector2d> points;
    for (int k = 0; k <= 20; ++k) points.emplace_back(x_end, -0.5 * kWidth + kWidth * k / 20.0);
    const SparseMatrix P = d.point_evaluation(points);
    const VectorXd rest_line = P * d.rest_positions();
    const VectorXd moved_line = P * perturbed(row);
    EXPECT_LT((moved_line - rest_line).cwiseAbs().maxCoeff(), 1e-17);  // exactly rigid
    for (size_t k = 0; k < points.size(); ++k)
      EXPECT_LT((rest_line.segment<3>(3 * static_cast<Eigen::Index>(k)) -
                 Vector3d(points[k].x(), points[k].y(), 0)).norm(), 1e-16);

    // With the slope clamped, the cross derivative ∂x/∂u along the end is fixed as well.
    const VectorXd q_slope = perturbed(rows);
    for (int j = 0; j < ny; ++j) {
      const int face = d.basis().face_index(end == StripEnd::Start ? 0 : nx - 1, j);
      for (double v : {0.0, 0.3, 0.8}) {
        const PatchBasis b = d.basis().evaluate(face, end == StripEnd::Start ? 0.0 : 1.0, v);
        Vector3d du_rest = Vector3d::Zero(), du_moved = Vector3d::Zero();
        for (int k = 0; k < 16; ++k) {
          const int node = b.nodes[static_cast<size_t>(k)];
          du_rest += b.weights(1, k) * d.rest_positions().segment<3>(3 * node);
          du_moved += b.weights(1, k) * q_slope.segment<3>(3 * node);
        }
        EXPECT_LT((du_moved - du_rest).norm(), 1e-15);
      }
    }
  }
}

TEST(CatmullClarkKL, PointEvaluationReproducesTheRestRectangle) {
  const CatmullClarkKL d(small_strip(0, 3, 5), canvas_stvk());
  std::vector<Vector2d> points = {{0, -kWidth / 2},          {kLength, -kWidth / 2},
                                  {kLength, kWidth / 2},     {0, kWidth / 2},
                                  {kLength / 2, -kWidth / 2}, {kLength, 0},
                                  {kLength / 2, kWidth / 2},  {0, 0}};
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> ux(0, kLength), uy(-kWidth / 2, kWidth / 2);
  for (int k = 0; k < 10; ++k) points.emplace_back(ux(rng), uy(rng));
  const SparseMatrix P = d.point_evaluation(points);
  ASSERT_EQ(P.rows(), 3 * static_cast<Eigen::Index>(points.size()));
  const VectorXd x = P * d.rest_positions();
  for (size_t k = 0; k < points.size(); ++k) {
    const Vector3d expected(points[k].x(), points[k].y(), 0.0);
    EXPECT_LT((x.segment<3>(3 * static_cast<Eigen::Index>(k)) - expected).norm(), 2e-17)
        << "point " << k;
  }
  // Rows are partitions of unity (translations move every point alike).
  for (Eigen::Index r = 0; r < P.rows(); ++r) EXPECT_NEAR(P.row(r).sum(), 1.0, 1e-15);
  EXPECT_THROW(d.point_evaluation({Vector2d(kLength * 1.01, 0)}), InputError);
}

TEST(CatmullClarkKL, LumpedMassAndGravity) {
  const MaterialParameters p = canvas_stvk();
  const CatmullClarkKL d(small_strip(0), p);
  const VectorXd m = d.lumped_mass();
  ASSERT_EQ(m.size(), d.num_dofs());
  EXPECT_NEAR(m.sum() / 3.0, p.density_kg_m2 * kLength * kWidth, 1e-15);
  EXPECT_GT(m.minCoeff(), 0.0);

  CatmullClarkKL with_gravity(small_strip(0), p);
  const Vector3d g(0, 0, -9.81);
  with_gravity.set_gravity(g);
  VectorXd lifted = d.rest_positions();
  for (int i = 0; i < d.num_nodes(); ++i) lifted[3 * i + 2] += 0.1;
  const double potential = with_gravity.energy(lifted, nullptr, nullptr);
  EXPECT_NEAR(potential, p.density_kg_m2 * kLength * kWidth * 9.81 * 0.1, 1e-15);
  VectorXd gradient;
  with_gravity.energy(lifted, &gradient, nullptr);
  for (int i = 0; i < d.num_nodes(); ++i)
    EXPECT_NEAR(gradient[3 * i + 2], m[3 * i] * 9.81, 1e-15);  // weight pulls down: ∂Ψ/∂z > 0
}

TEST(CatmullClarkKL, SurfaceMeshSamplesTheLimitSurface) {
  CatmullClarkKLOptions o;
  o.surface_samples_per_face = 3;
  const CatmullClarkKL d(small_strip(0, 2, 3), canvas_stvk(), o);
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  d.surface_mesh(d.rest_positions(), &V, &F);
  const int cols = 3 * 3, rows = 2 * 3;
  ASSERT_EQ(V.rows(), (cols + 1) * (rows + 1));
  ASSERT_EQ(F.rows(), 2 * cols * rows);
  EXPECT_LT(V.col(2).cwiseAbs().maxCoeff(), 1e-17);
  EXPECT_NEAR(V(cols, 0), kLength, 1e-16);
  EXPECT_NEAR(V(V.rows() - 1, 1), kWidth / 2, 1e-16);
  double area = 0.0;
  for (int t = 0; t < F.rows(); ++t) {
    const Vector3d a = V.row(F(t, 0)), b = V.row(F(t, 1)), c = V.row(F(t, 2));
    const Vector3d n = (b - a).cross(c - a);
    EXPECT_GT(n.z(), 0.0);  // counter-clockwise seen from +z
    area += 0.5 * n.norm();
  }
  EXPECT_NEAR(area, kLength * kWidth, 1e-15);
}

}  // namespace
}  // namespace twill
