// SparseCholesky: CHOLMOD solves against dense Eigen LLT, positive-definiteness detection,
// multiple right-hand sides, and the long-double iterative refinement (paper §6.3).
#include "core/sparse_cholesky.hpp"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace twill {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
using Triplets = std::vector<Eigen::Triplet<double>>;

// 5-point grid Laplacian on nx × ny nodes. dirichlet = true: 4 on every diagonal (SPD);
// false: the graph Laplacian (degree on the diagonal, singular with the constant vector).
SparseMatrix grid_laplacian(int nx, int ny, bool dirichlet, double diagonal_shift) {
  Triplets t;
  const auto id = [nx](int i, int j) { return j * nx + i; };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      int degree = 0;
      const int neighbours[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
      for (const auto& nb : neighbours) {
        if (nb[0] < 0 || nb[0] >= nx || nb[1] < 0 || nb[1] >= ny) continue;
        t.emplace_back(id(i, j), id(nb[0], nb[1]), -1.0);
        ++degree;
      }
      t.emplace_back(id(i, j), id(i, j), (dirichlet ? 4.0 : degree) + diagonal_shift);
    }
  }
  SparseMatrix a(nx * ny, nx * ny);
  a.setFromTriplets(t.begin(), t.end());
  a.makeCompressed();
  return a;
}

// Laplacian + a random symmetric sparse perturbation, shifted to stay diagonally dominant:
// SPD with an irregular pattern and values.
SparseMatrix random_spd(int nx, int ny, unsigned seed) {
  const SparseMatrix laplacian = grid_laplacian(nx, ny, true, 0.0);
  const int n = nx * ny;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> index(0, n - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  Triplets t;
  Eigen::VectorXd row_sum = Eigen::VectorXd::Zero(n);
  for (int k = 0; k < 3 * n; ++k) {
    const int i = index(rng), j = index(rng);
    if (i == j) continue;
    const double v = value(rng);
    t.emplace_back(i, j, v);
    t.emplace_back(j, i, v);
    row_sum[i] += std::fabs(v);
    row_sum[j] += std::fabs(v);
  }
  for (int i = 0; i < n; ++i) t.emplace_back(i, i, row_sum[i] + 0.5);
  SparseMatrix perturbation(n, n);
  perturbation.setFromTriplets(t.begin(), t.end());
  SparseMatrix a = laplacian + perturbation;
  a.makeCompressed();
  return a;
}

double relative_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& reference) {
  return (x - reference).lpNorm<Eigen::Infinity>() / reference.lpNorm<Eigen::Infinity>();
}

TEST(SparseCholesky, SolvesSpdSystemLikeDenseLlt) {
  const SparseMatrix a = random_spd(12, 10, 7);
  const int n = static_cast<int>(a.rows());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) b[i] = normal(rng);
  const Eigen::VectorXd reference = Eigen::MatrixXd(a).llt().solve(b);

  for (bool supernodal : {true, false}) {
    SparseCholeskyOptions options;
    options.supernodal = supernodal;
    SparseCholesky cholesky(options);
    ASSERT_TRUE(cholesky.compute(a));
    EXPECT_EQ(cholesky.failed_column(), -1);
    // supernodal = false lets CHOLMOD pick by flop count: simplicial for a system this small.
    EXPECT_EQ(cholesky.is_supernodal(), supernodal);
    EXPECT_GT(cholesky.factor_nonzeros(), 0.0);
    Eigen::VectorXd x;
    SolveReport report;
    cholesky.solve(b, &x, &report);
    EXPECT_LT(relative_error(x, reference), 1e-13) << "supernodal = " << supernodal;
    EXPECT_LT(report.residual_after, 1e-15);
    EXPECT_LE(report.residual_after, report.residual_before);
  }
}

TEST(SparseCholesky, ReadsOnlyTheLowerTriangle) {
  const SparseMatrix a = random_spd(9, 8, 11);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(a.rows(), -1.0, 2.0);
  SparseCholesky full;
  ASSERT_TRUE(full.compute(a));
  const Eigen::VectorXd x_full = full.solve(b);

  // Lower-triangle storage gives the same factor.
  SparseMatrix lower = a.triangularView<Eigen::Lower>();
  lower.makeCompressed();
  SparseCholesky from_lower;
  ASSERT_TRUE(from_lower.compute(lower));
  EXPECT_EQ((from_lower.solve(b) - x_full).lpNorm<Eigen::Infinity>(), 0.0);

  // Garbage in the strict upper triangle is never read (same pattern, bit-identical result).
  SparseMatrix scrambled = a;
  for (int j = 0; j < scrambled.outerSize(); ++j) {
    for (SparseMatrix::InnerIterator it(scrambled, j); it; ++it) {
      if (it.row() < it.col()) it.valueRef() = 1e6;
    }
  }
  ASSERT_TRUE(full.factorize(scrambled));
  EXPECT_EQ((full.solve(b) - x_full).lpNorm<Eigen::Infinity>(), 0.0);
}

TEST(SparseCholesky, DetectsNotPositiveDefiniteWithoutThrowing) {
  // λ_min of the Dirichlet grid Laplacian is 4 − 4cos(π/(n+1)) ≈ 0.08 here: a shift of −1
  // makes it indefinite.
  const SparseMatrix spd = grid_laplacian(10, 10, true, 0.0);
  const SparseMatrix indefinite = grid_laplacian(10, 10, true, -1.0);
  SparseCholesky cholesky;
  cholesky.analyze(spd);
  EXPECT_FALSE(cholesky.factorize(indefinite));
  EXPECT_FALSE(cholesky.factorized());
  EXPECT_GE(cholesky.failed_column(), 0);
  EXPECT_LT(cholesky.failed_column(), spd.rows());
  Eigen::VectorXd x;
  EXPECT_THROW(cholesky.solve(Eigen::VectorXd::Ones(spd.rows()), &x), std::logic_error);

  // The symbolic analysis survives a failed factorisation.
  ASSERT_TRUE(cholesky.factorize(spd));
  EXPECT_EQ(cholesky.failed_column(), -1);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(spd.rows());
  cholesky.solve(b, &x);
  EXPECT_LT((spd * x - b).lpNorm<Eigen::Infinity>(), 1e-13);

  // The failing column is reported in the matrix's own numbering, whatever the ordering.
  for (auto ordering :
       {SparseCholeskyOptions::Ordering::kAuto, SparseCholeskyOptions::Ordering::kAmd,
        SparseCholeskyOptions::Ordering::kNatural, SparseCholeskyOptions::Ordering::kMetis}) {
    // Strongly diagonally dominant except for a negative pivot at column 17: only that
    // column can fail, wherever the ordering puts it.
    SparseMatrix diagonal = grid_laplacian(6, 5, true, 0.0);
    for (int i = 0; i < diagonal.rows(); ++i) diagonal.coeffRef(i, i) = i == 17 ? -4.0 : 100.0;
    SparseCholeskyOptions options;
    options.ordering = ordering;
    SparseCholesky c(options);
    EXPECT_FALSE(c.compute(diagonal));
    EXPECT_EQ(c.failed_column(), 17) << "ordering " << static_cast<int>(ordering);
    if (ordering == SparseCholeskyOptions::Ordering::kAmd) {
      EXPECT_EQ(c.selected_ordering(), "amd");
    }
    if (ordering == SparseCholeskyOptions::Ordering::kMetis) {
      EXPECT_EQ(c.selected_ordering(), "metis");
    }
    if (ordering == SparseCholeskyOptions::Ordering::kNatural) {
      EXPECT_EQ(c.selected_ordering(), "natural");
    }
  }
}

TEST(SparseCholesky, RejectsAChangedPattern) {
  SparseCholesky cholesky;
  cholesky.analyze(grid_laplacian(5, 5, true, 0.0));
  EXPECT_THROW(cholesky.factorize(grid_laplacian(5, 6, true, 0.0)), std::invalid_argument);
  EXPECT_THROW(cholesky.factorize(random_spd(5, 5, 1)), std::invalid_argument);
  EXPECT_THROW(SparseCholesky().factorize(grid_laplacian(3, 3, true, 0.0)), std::logic_error);
}

TEST(SparseCholesky, SolvesManyRightHandSidesWithOneFactor) {
  const SparseMatrix a = random_spd(15, 12, 5);
  const int n = static_cast<int>(a.rows());
  std::mt19937 rng(9);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b(n, 7);
  for (int j = 0; j < b.cols(); ++j) {
    for (int i = 0; i < n; ++i) b(i, j) = normal(rng);
  }
  SparseCholesky cholesky;
  ASSERT_TRUE(cholesky.compute(a));
  Eigen::MatrixXd x;
  SolveReport report;
  cholesky.solve(b, &x, &report);
  ASSERT_EQ(x.rows(), n);
  ASSERT_EQ(x.cols(), 7);
  const Eigen::MatrixXd reference = Eigen::MatrixXd(a).llt().solve(b);
  EXPECT_LT(relative_error(x, reference), 1e-13);
  EXPECT_LT(report.residual_after, 1e-15);
  for (int j = 0; j < b.cols(); ++j) {
    Eigen::VectorXd column;
    cholesky.solve(Eigen::VectorXd(b.col(j)), &column);
    EXPECT_LT(relative_error(column, x.col(j)), 1e-14) << "column " << j;
  }
  // A different number of columns afterwards (CHOLMOD's workspace is resized, not stale).
  Eigen::MatrixXd x2;
  cholesky.solve(Eigen::MatrixXd(b.leftCols(2)), &x2);
  EXPECT_LT(relative_error(x2, reference.leftCols(2)), 1e-13);
}

// Paper §6.1/§6.3: cloth systems reach cond ≈ 1e10. Both residual precisions are checked. The
// Neumann grid Laplacian plus 2⁻³⁰·I has λ_min = 2⁻³⁰ ≈ 9.3e-10 and λ_max < 8: cond ≈ 8.6e9. With
// integer x* (|x*| ≤ 2¹⁶) b = A x* is exact in double (at most 50 significant bits), so x* is the
// exact solution of the system actually solved and the error can be measured without a reference
// solver.
TEST(SparseCholesky, ExtendedPrecisionRefinementFixesIllConditionedSolve) {
  const double epsilon = std::ldexp(1.0, -30);
  const SparseMatrix a = grid_laplacian(20, 20, false, epsilon);
  const int n = static_cast<int>(a.rows());
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> integer(-(1 << 16), 1 << 16);
  Eigen::VectorXd exact(n);
  for (int i = 0; i < n; ++i) exact[i] = integer(rng);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    long double sum = 0;
    for (SparseMatrix::InnerIterator it(a, i); it; ++it) {
      sum += static_cast<long double>(it.value()) * static_cast<long double>(exact[it.row()]);
    }
    b[i] = static_cast<double>(sum);
    ASSERT_EQ(static_cast<long double>(b[i]), sum) << "b is not exact at row " << i;
  }

  SparseCholeskyOptions plain_options;
  plain_options.refinement_steps = 0;
  SparseCholesky plain(plain_options);
  ASSERT_TRUE(plain.compute(a));
  EXPECT_LT(plain.reciprocal_condition_estimate(), 1e-3);
  Eigen::VectorXd x0;
  SolveReport report0;
  plain.solve(b, &x0, &report0);
  const double error0 = relative_error(x0, exact);

  // A refinement step with a residual in double, for comparison (build-notes.md: no gain).
  const Eigen::VectorXd x_double = x0 + plain.solve(Eigen::VectorXd(b - a * x0));
  const double error_double = relative_error(x_double, exact);

  SparseCholesky refined;  // default: 2 steps with a long-double residual
  ASSERT_TRUE(refined.compute(a));
  Eigen::VectorXd x2;
  SolveReport report2;
  refined.solve(b, &x2, &report2);
  const double error2 = relative_error(x2, exact);

  SparseCholeskyOptions dd_options;
  dd_options.residual_precision = SparseCholeskyOptions::ResidualPrecision::kDoubleDouble;
  SparseCholesky refined_dd(dd_options);
  ASSERT_TRUE(refined_dd.compute(a));
  Eigen::VectorXd x_dd;
  SolveReport report_dd;
  refined_dd.solve(b, &x_dd, &report_dd);
  const double error_dd = relative_error(x_dd, exact);

  std::printf(
      "cond ~ 8.6e9: error plain %.3e, double-residual step %.3e, long-double refinement "
      "(%d steps) %.3e, double-double (%d steps) %.3e; residual %.3e -> %.3e (ld), "
      "%.3e (dd)\n",
      error0, error_double, report2.refinement_steps, error2, report_dd.refinement_steps, error_dd,
      report2.residual_before, report2.residual_after, report_dd.residual_after);
  // Measured: plain 2.0e-9, double-residual step 2.2e-8 (worse), long double 2.5e-11,
  // double-double exact (0). Long double is limited to about cond·2⁻⁶⁴ ≈ 5e-10 relative,
  // so at cond ~1e10 it gains two orders; the double-double residual recovers full accuracy.
  EXPECT_GT(error0, 1e-10);                // the unrefined solve really is inaccurate
  EXPECT_LT(error2, 2e-2 * error0);        // long double: ≥ 50× better
  EXPECT_LT(error2, 1e-2 * error_double);  // a double residual does not do this
  EXPECT_GE(report2.refinement_steps, 1);
  // The residual starts at 2e-16 relative, near the floor set by rounding x itself to double
  // (~eps |A||x| / |b|), so how far it falls depends on the BLAS's rounding in the factor: 10×
  // on the first machine, 5.5× with Debian 12's libopenblas0-pthread 0.3.21 (fresh install,
  // 2026-12-01). The error bars above are what matters; here only a strict decrease.
  EXPECT_LT(report2.residual_after, report2.residual_before);
  EXPECT_LT(error_dd, 1e-15);  // double-double: exact to double precision
  EXPECT_LT(error_dd, 1e-3 * error0);
  EXPECT_LE(report_dd.residual_after, 1e-3 * report_dd.residual_before);
  EXPECT_EQ(report0.residual_before, report0.residual_after);
}

TEST(SparseCholesky, OptionsSayWhatIsWrong) {
  SparseCholeskyOptions options;
  std::string error;
  EXPECT_TRUE(options.validate(&error));
  EXPECT_TRUE(error.empty());
  options.refinement_steps = -1;
  EXPECT_FALSE(options.validate(&error));
  EXPECT_NE(error.find("refinement_steps"), std::string::npos) << error;
  EXPECT_THROW(SparseCholesky{options}, std::invalid_argument);
  SparseCholesky cholesky;
  EXPECT_THROW(cholesky.set_refinement_steps(-2), std::invalid_argument);
}

TEST(SparseCholesky, ReportsTheBlasInUse) {
  std::string blas = SparseCholesky::blas_library();
  std::printf("BLAS: %s\n", blas.c_str());
  std::transform(blas.begin(), blas.end(), blas.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  EXPECT_NE(blas.find("blas"), std::string::npos) << blas;
}

// twill's entry point sets OpenBLAS to one thread through this (app/main.cpp).
TEST(SparseCholesky, SetsOpenBlasThreadsAtRunTime) {
  if (SparseCholesky::blas_library().find("OpenBLAS") == std::string::npos)
    GTEST_SKIP() << "the loaded BLAS is not OpenBLAS: " << SparseCholesky::blas_library();
  const int before = SparseCholesky::blas_threads();
  ASSERT_TRUE(SparseCholesky::set_blas_threads(2));
  EXPECT_EQ(SparseCholesky::blas_threads(), 2);
  ASSERT_TRUE(SparseCholesky::set_blas_threads(1));
  EXPECT_EQ(SparseCholesky::blas_threads(), 1);
  SparseCholesky::set_blas_threads(before);
}

}  // namespace
}  // namespace twill
