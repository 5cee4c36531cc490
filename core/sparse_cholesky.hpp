#pragma once
// Sparse Cholesky factorisation of a symmetric positive definite matrix (CHOLMOD, SuiteSparse
// 5.12), with mixed-precision iterative refinement (paper §6.2–6.3).
//
// What it is for: the Newton steps of the equilibrium solver (K_ff d = −g_f) and the
// sensitivity solve of paper Eq. 6 (K_ff X = −∂g_f/∂k, |k| right-hand sides sharing one
// factor). Cloth stiffness matrices reach condition numbers near 1e10 (paper §6.1), so every
// solve is followed by iterative refinement whose residual r = b − A x is computed in extended
// precision, then rounded to double for the correction solve (the paper used quad precision,
// §6.3). Two choices (SparseCholeskyOptions::residual_precision):
//   - long double (default): build-notes.md measured one step cutting the error from 5e-11 to
//     6e-14 at cond 2e8, while a residual in double gained nothing. Its 64-bit mantissa limits
//     the attainable relative error to about cond·5e-20 (test: 2.0e-9 → 2.5e-11 at cond 8.6e9).
//     Where long double is no wider than double (MSVC, Apple arm64, valgrind's x87
//     emulation; detected at run time) the double-double residual is used instead.
//   - double-double (compensated FMA/TwoSum accumulation): ≈ 106 bits on any IEEE platform;
//     same test: 2.0e-9 → exact. Cost: about 1.5× the long-double residual, both far below a
//     triangular solve (45k dofs, 6.5M nonzeros: ~15–25 ms vs ~40 ms solve, ~1.5 s factorise).
//
// Matrix convention: A is #n × #n, column-major `Eigen::SparseMatrix<double>` in compressed
// form. Full symmetric storage (both triangles, as Discretization::energy returns Hessians)
// is accepted; only the lower triangle (row ≥ column) is read, as CHOLMOD's stype = −1.
// A matrix stored as its upper triangle only would therefore be read as its diagonal.
//
// Life cycle: analyze() once per sparsity pattern (fill-reducing ordering and symbolic
// factorisation, kept), factorize() once per new set of values (supernodal LLᵀ by default:
// it needs positive definiteness and reports its absence by returning false, never by
// throwing), then any number of solve() calls reusing the factor.
//
// Allocation: the symbolic factor, the numeric factor's storage, CHOLMOD's solve workspace
// (cholmod_solve2) and the refinement buffers are kept and reused; after the first call with
// a given number of right-hand sides the only allocation left is the temporary update matrix
// that CHOLMOD's supernodal factorisation creates internally per factorize().
//
// Threads: one object per thread. Even the const solve() writes internal workspace.
// CHOLMOD's supernodal kernels call BLAS; blas_library() says which one was loaded
// (OpenBLAS is 4–7× faster than the reference BLAS here, build-notes.md). Debian's CHOLMOD
// also runs OpenMP threads, and OpenBLAS its own pthreads: when the cores are already busy
// (parallel fits, a shared machine) these oversubscribe. Measured on the 2-core build machine
// under load: a 19,683-dof Newton solve took 2.4 s with default threading and 0.44 s with
// OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1. Thread counts are process-wide settings, so they
// belong to the program's entry point, not to this class: `twill` sets OpenBLAS to one thread
// unless the environment names a count (app/main.cpp; a whole canvas validation stage took
// 92 s with OpenBLAS's default threads and 46 s with one, sys time 74 s → 8 s).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <string>

namespace twill {

struct SparseCholeskyOptions {
  /// Fill-reducing ordering used by analyze().
  enum class Ordering {
    kAuto,     ///< CHOLMOD's default: AMD, then METIS if AMD's fill is poor; keeps the best
    kAmd,      ///< approximate minimum degree only (cheapest analysis)
    kMetis,    ///< METIS nested dissection
    kNatural,  ///< no permutation (for tests and debugging)
  };
  Ordering ordering = Ordering::kAuto;
  /// true: always supernodal LLᵀ (BLAS-3, fastest on shell stencils). false: CHOLMOD chooses
  /// simplicial or supernodal by flop count; the factor is LLᵀ either way, so a matrix that is
  /// not positive definite is always detected.
  bool supernodal = true;
  /// Iterative refinement steps after each solve (0 = none). A step is kept only when it
  /// lowers the residual, so extra steps cost time but never accuracy.
  int refinement_steps = 2;
  /// Arithmetic of the refinement residual r = b − A x.
  enum class ResidualPrecision {
    /// x87 80-bit long double (64-bit mantissa, u ≈ 5.4e-20): refinement can reach a
    /// relative error of about cond·u (≈ 5e-10 at cond 1e10). Falls back to kDoubleDouble
    /// where long double arithmetic is not wider than double.
    kLongDouble,
    /// Compensated double-double accumulation (error-free products by FMA and TwoSum,
    /// Ogita–Rump–Oishi "Dot2"): ≈ 106-bit residual, full double accuracy up to cond ~1e15,
    /// the role quad precision plays in the paper (§6.3).
    kDoubleDouble,
  };
  ResidualPrecision residual_precision = ResidualPrecision::kLongDouble;

  /// Ceres-style check: false with a message naming the offending field.
  bool validate(std::string* error) const;
};

/// Residuals of one solve() call: ‖b − A x‖∞ / ‖b‖∞, the maximum over right-hand sides,
/// computed in long double (0 when b = 0, then x = 0 exactly).
struct SolveReport {
  int refinement_steps = 0;    ///< steps kept (for several right-hand sides: the maximum)
  double residual_before = 0;  ///< after the plain triangular solves
  double residual_after = 0;   ///< after refinement (= residual_before when no step kept)
};

class SparseCholesky {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;

  /// Throws std::invalid_argument when `options` do not validate. Movable (a moved-from
  /// object may only be destroyed or assigned to), not copyable (it owns CHOLMOD state).
  explicit SparseCholesky(const SparseCholeskyOptions& options = {});
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  const SparseCholeskyOptions& options() const;
  /// Changes the refinement steps for later solves (≥ 0, else std::invalid_argument).
  void set_refinement_steps(int steps);

  /// Ordering and symbolic factorisation for a's pattern (values are not read). Throws
  /// std::invalid_argument when a is not square or not compressed, std::runtime_error when
  /// CHOLMOD fails (out of memory). Discards any numeric factor.
  void analyze(const SparseMatrix& a);
  /// Numeric factorisation of a, which must have exactly the analysed pattern (checked, O(nnz);
  /// std::invalid_argument otherwise). Returns false when a is not positive definite:
  /// failed_column() then says where. No exception for that. Re-factorising with new values
  /// reuses the symbolic analysis whether or not the previous attempt failed.
  bool factorize(const SparseMatrix& a);
  /// analyze(a) then factorize(a).
  bool compute(const SparseMatrix& a);

  bool analyzed() const;
  /// True after a successful factorize().
  bool factorized() const;
  /// −1 after a successful factorize(); otherwise the column of a (a's own numbering) whose
  /// pivot CHOLMOD found non-positive, eliminating in the fill-reducing order.
  int failed_column() const;
  int rows() const;

  /// Solves A x = b (b: rows() entries). x is resized; it must not alias b.
  /// Throws std::logic_error when there is no valid factor.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd* x, SolveReport* report = nullptr) const;
  /// Solves A X = B for all columns of B at once (rows() × #rhs). X is resized.
  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x, SolveReport* report = nullptr) const;
  /// Convenience form (allocates the result).
  Eigen::VectorXd solve(const Eigen::VectorXd& b) const;

  /// Nonzeros of L (CHOLMOD's count after analysis; 0 before).
  double factor_nonzeros() const;
  /// The ordering CHOLMOD selected, e.g. "amd", "metis", "nesdis", "natural".
  std::string selected_ordering() const;
  /// Whether the current factor is supernodal.
  bool is_supernodal() const;
  /// CHOLMOD's rough reciprocal condition estimate from diag(L) (cholmod_rcond): cheap, not a
  /// bound; 0 without a valid factor.
  double reciprocal_condition_estimate() const;

  /// The shared library that provides the BLAS `dgemm_` symbol in this process, plus
  /// OpenBLAS's configuration string when it is OpenBLAS; "unknown" if it cannot be told.
  static std::string blas_library();
  /// Sets OpenBLAS's thread count when OpenBLAS is the loaded BLAS (openblas_set_num_threads,
  /// looked up at run time: no link dependency); false when it is not. Process-wide.
  static bool set_blas_threads(int threads);
  /// OpenBLAS's thread count (openblas_get_num_threads), or 0 when OpenBLAS is not loaded.
  static int blas_threads();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace twill
