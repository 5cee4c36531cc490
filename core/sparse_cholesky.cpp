#include "core/sparse_cholesky.hpp"

#include <cholmod.h>
#include <dlfcn.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace twill {
namespace {

// CHOLMOD reports warnings (e.g. "not positive definite") through this hook; the caller sees
// them as return values, so they are only worth a debug line. Printing is off (print = 0).
void log_cholmod_message(int status, const char* file, int line, const char* message) {
  spdlog::debug("CHOLMOD status {} at {}:{}: {}", status, file ? file : "?", line,
                message ? message : "");
}

// Whether long double arithmetic is really wider than double here. It is not on MSVC or
// Apple arm64 (long double = double), nor under valgrind (which emulates x87 in 64 bits).
// Checked at run time, once.
bool long_double_is_extended() {
  static const bool extended = [] {
    volatile long double one = 1.0L;
    volatile long double quarter_ulp =
        static_cast<long double>(std::numeric_limits<double>::epsilon()) / 4.0L;
    return one + quarter_ulp != one;
  }();
  return extended;
}

const char* ordering_name(int ordering) {
  switch (ordering) {
    case CHOLMOD_NATURAL:
      return "natural";
    case CHOLMOD_GIVEN:
      return "given";
    case CHOLMOD_AMD:
      return "amd";
    case CHOLMOD_METIS:
      return "metis";
    case CHOLMOD_NESDIS:
      return "nesdis";
    case CHOLMOD_COLAMD:
      return "colamd";
    case CHOLMOD_POSTORDERED:
      return "postordered";
    default:
      return "unknown";
  }
}

}  // namespace

bool SparseCholeskyOptions::validate(std::string* error) const {
  std::string message;
  if (refinement_steps < 0) {
    message = "refinement_steps must be >= 0 (got " + std::to_string(refinement_steps) + ")";
  }
  if (error) *error = message;
  return message.empty();
}

struct SparseCholesky::Impl {
  SparseCholeskyOptions options;
  cholmod_common common{};
  cholmod_factor* factor = nullptr;
  int n = -1;  // −1: not analysed
  bool factor_valid = false;
  int failed_column = -1;

  // The analysed pattern as given (full or lower storage), to check factorize() inputs.
  std::vector<int> pattern_outer, pattern_inner;
  // Lower triangle in CSC, handed to CHOLMOD (stype = −1) and used by the residual.
  std::vector<int> lower_outer, lower_inner, lower_source;
  std::vector<double> lower_values;

  // Solve workspace, reused across calls (cholmod_solve2 reallocates only on size change).
  mutable cholmod_dense* x_work = nullptr;
  mutable cholmod_dense* y_work = nullptr;
  mutable cholmod_dense* e_work = nullptr;
  mutable std::vector<long double> accumulator;
  mutable std::vector<double> high, low;
  mutable Eigen::MatrixXd residual, trial_x, trial_residual;
  mutable Eigen::VectorXd residual_norm, trial_residual_norm, rhs_norm;
  mutable Eigen::VectorXi steps_kept;

  explicit Impl(const SparseCholeskyOptions& o) : options(o) {
    cholmod_start(&common);
    common.print = 0;
    common.error_handler = &log_cholmod_message;
    common.supernodal = options.supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_AUTO;
    // LLᵀ also for a simplicial factor: its pivots must be positive, so an indefinite
    // matrix is always reported (an LDLᵀ would silently accept negative pivots).
    common.final_ll = 1;
    switch (options.ordering) {
      case SparseCholeskyOptions::Ordering::kAuto:
        common.nmethods = 0;
        break;
      case SparseCholeskyOptions::Ordering::kAmd:
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_AMD;
        break;
      case SparseCholeskyOptions::Ordering::kMetis:
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_METIS;
        break;
      case SparseCholeskyOptions::Ordering::kNatural:
        common.nmethods = 1;
        common.method[0].ordering = CHOLMOD_NATURAL;
        common.postorder = 0;
        break;
    }
  }

  ~Impl() {
    if (factor) cholmod_free_factor(&factor, &common);
    if (x_work) cholmod_free_dense(&x_work, &common);
    if (y_work) cholmod_free_dense(&y_work, &common);
    if (e_work) cholmod_free_dense(&e_work, &common);
    cholmod_finish(&common);
  }

  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  // A non-owning CHOLMOD view of the lower triangle. CHOLMOD's struct has non-const
  // pointers, but analyze/factorize only read A.
  cholmod_sparse lower_view() {
    cholmod_sparse a{};
    a.nrow = static_cast<size_t>(n);
    a.ncol = static_cast<size_t>(n);
    a.nzmax = lower_values.size();
    a.p = lower_outer.data();
    a.i = lower_inner.data();
    a.nz = nullptr;
    a.x = lower_values.data();
    a.z = nullptr;
    a.stype = -1;
    a.itype = CHOLMOD_INT;
    a.xtype = CHOLMOD_REAL;
    a.dtype = CHOLMOD_DOUBLE;
    a.sorted = 1;
    a.packed = 1;
    return a;
  }

  // r = b − A x for `ncol` columns in extended precision (A from its lower triangle), rounded
  // to double into r; per-column ‖r‖∞ into norms.
  void compute_residual(const double* b, const double* x, int ncol, double* r,
                        double* norms) const {
    if (options.residual_precision == SparseCholeskyOptions::ResidualPrecision::kDoubleDouble ||
        !long_double_is_extended()) {
      compute_residual_double_double(b, x, ncol, r, norms);
    } else {
      compute_residual_long_double(b, x, ncol, r, norms);
    }
  }

  void compute_residual_long_double(const double* b, const double* x, int ncol, double* r,
                                    double* norms) const {
    const auto nn = static_cast<size_t>(n);
    accumulator.resize(nn);
    for (int c = 0; c < ncol; ++c) {
      const double* bc = b + static_cast<size_t>(c) * nn;
      const double* xc = x + static_cast<size_t>(c) * nn;
      double* rc = r + static_cast<size_t>(c) * nn;
      for (size_t i = 0; i < nn; ++i) accumulator[i] = static_cast<long double>(bc[i]);
      for (size_t j = 0; j < nn; ++j) {
        const long double xj = xc[j];
        long double column_sum = 0.0L;  // contributions of the mirrored upper entries to row j
        for (int p = lower_outer[j]; p < lower_outer[j + 1]; ++p) {
          const auto i = static_cast<size_t>(lower_inner[static_cast<size_t>(p)]);
          const long double v = lower_values[static_cast<size_t>(p)];
          accumulator[i] -= v * xj;
          if (i != j) column_sum += v * static_cast<long double>(xc[i]);
        }
        accumulator[j] -= column_sum;
      }
      long double norm = 0.0L;
      for (size_t i = 0; i < nn; ++i) {
        rc[i] = static_cast<double>(accumulator[i]);
        norm = std::max(norm, std::fabs(accumulator[i]));
      }
      norms[c] = static_cast<double>(norm);
    }
  }

  // Each row keeps an unevaluated sum hi + lo. A product a·x is split exactly into
  // p + e with e = fma(a, x, −p); TwoSum (Knuth) adds −p to hi exactly, the rounding errors
  // collect in lo. The result equals the residual computed in ~2× double precision.
  void compute_residual_double_double(const double* b, const double* x, int ncol, double* r,
                                      double* norms) const {
    const auto nn = static_cast<size_t>(n);
    high.resize(nn);
    low.resize(nn);
    const auto add = [&](size_t row, double a, double y) {
      const double p = a * y;
      const double e = std::fma(a, y, -p);
      const double s = high[row] - p;
      const double t = s - high[row];
      const double err = (high[row] - (s - t)) + (-p - t);
      high[row] = s;
      low[row] += err - e;
    };
    for (int c = 0; c < ncol; ++c) {
      const double* bc = b + static_cast<size_t>(c) * nn;
      const double* xc = x + static_cast<size_t>(c) * nn;
      double* rc = r + static_cast<size_t>(c) * nn;
      std::copy(bc, bc + nn, high.begin());
      std::fill(low.begin(), low.end(), 0.0);
      for (size_t j = 0; j < nn; ++j) {
        const double xj = xc[j];
        for (int p = lower_outer[j]; p < lower_outer[j + 1]; ++p) {
          const auto i = static_cast<size_t>(lower_inner[static_cast<size_t>(p)]);
          const double v = lower_values[static_cast<size_t>(p)];
          add(i, v, xj);
          if (i != j) add(j, v, xc[i]);
        }
      }
      double norm = 0.0;
      for (size_t i = 0; i < nn; ++i) {
        rc[i] = high[i] + low[i];
        norm = std::max(norm, std::fabs(rc[i]));
      }
      norms[c] = norm;
    }
  }

  // x = A⁻¹ b with the current factor, for `ncol` columns stored contiguously.
  void triangular_solves(const double* b, int ncol, double* x) const {
    cholmod_dense rhs{};
    rhs.nrow = static_cast<size_t>(n);
    rhs.ncol = static_cast<size_t>(ncol);
    rhs.nzmax = rhs.nrow * rhs.ncol;
    rhs.d = rhs.nrow;
    rhs.x = const_cast<double*>(b);  // read only, CHOLMOD's struct is not const-correct
    rhs.z = nullptr;
    rhs.xtype = CHOLMOD_REAL;
    rhs.dtype = CHOLMOD_DOUBLE;
    cholmod_common* c = const_cast<cholmod_common*>(&common);
    if (!cholmod_solve2(CHOLMOD_A, factor, &rhs, nullptr, &x_work, nullptr, &y_work, &e_work, c)) {
      throw std::runtime_error("SparseCholesky: cholmod_solve2 failed (status " +
                               std::to_string(common.status) + ")");
    }
    std::memcpy(x, x_work->x, sizeof(double) * rhs.nzmax);
  }

  void solve(const double* b, int ncol, double* x, SolveReport* report) const {
    if (!factor_valid) {
      throw std::logic_error(
          "SparseCholesky::solve: no valid factorization (call factorize() "
          "and check that it returned true)");
    }
    if (n == 0 || ncol == 0) {
      if (report) *report = SolveReport{};
      return;
    }
    triangular_solves(b, ncol, x);
    const int steps = options.refinement_steps;
    if (steps == 0 && report == nullptr) return;

    const Eigen::Index rows = n;
    residual.resize(rows, ncol);
    trial_x.resize(rows, ncol);
    trial_residual.resize(rows, ncol);
    residual_norm.resize(ncol);
    trial_residual_norm.resize(ncol);
    rhs_norm.resize(ncol);
    steps_kept.setZero(ncol);
    for (int c = 0; c < ncol; ++c) {
      const double* bc = b + static_cast<size_t>(c) * static_cast<size_t>(n);
      double m = 0;
      for (int i = 0; i < n; ++i) m = std::max(m, std::fabs(bc[i]));
      rhs_norm[c] = m;
    }
    compute_residual(b, x, ncol, residual.data(), residual_norm.data());
    const auto relative = [&](const Eigen::VectorXd& norms) {
      double worst = 0;
      for (int c = 0; c < ncol; ++c) {
        worst = std::max(worst, rhs_norm[c] > 0 ? norms[c] / rhs_norm[c] : norms[c]);
      }
      return worst;
    };
    const double before = relative(residual_norm);

    Eigen::Map<Eigen::MatrixXd> solution(x, rows, ncol);
    for (int step = 0; step < steps; ++step) {
      if (residual_norm.maxCoeff() == 0.0) break;
      // Correction from the double-rounded extended-precision residual (mixed-precision
      // refinement: the factor's error is divided down by ~cond·eps per step).
      triangular_solves(residual.data(), ncol, trial_x.data());
      trial_x += solution;
      compute_residual(b, trial_x.data(), ncol, trial_residual.data(), trial_residual_norm.data());
      bool improved = false;
      for (int c = 0; c < ncol; ++c) {
        if (trial_residual_norm[c] < residual_norm[c]) {
          solution.col(c) = trial_x.col(c);
          residual.col(c) = trial_residual.col(c);
          residual_norm[c] = trial_residual_norm[c];
          ++steps_kept[c];
          improved = true;
        }
      }
      if (!improved) break;  // stagnated at the precision the residual can resolve
    }
    if (report) {
      report->refinement_steps = steps_kept.maxCoeff();
      report->residual_before = before;
      report->residual_after = relative(residual_norm);
    }
  }
};

SparseCholesky::SparseCholesky(const SparseCholeskyOptions& options) {
  std::string error;
  if (!options.validate(&error)) throw std::invalid_argument("SparseCholeskyOptions: " + error);
  impl_ = std::make_unique<Impl>(options);
}

SparseCholesky::~SparseCholesky() = default;
SparseCholesky::SparseCholesky(SparseCholesky&&) noexcept = default;
SparseCholesky& SparseCholesky::operator=(SparseCholesky&&) noexcept = default;

const SparseCholeskyOptions& SparseCholesky::options() const { return impl_->options; }

void SparseCholesky::set_refinement_steps(int steps) {
  if (steps < 0) {
    throw std::invalid_argument("SparseCholesky: refinement_steps must be >= 0 (got " +
                                std::to_string(steps) + ")");
  }
  impl_->options.refinement_steps = steps;
}

void SparseCholesky::analyze(const SparseMatrix& a) {
  if (a.rows() != a.cols()) {
    throw std::invalid_argument("SparseCholesky::analyze: matrix is " + std::to_string(a.rows()) +
                                " x " + std::to_string(a.cols()) + ", not square");
  }
  if (!a.isCompressed()) {
    throw std::invalid_argument(
        "SparseCholesky::analyze: matrix must be compressed "
        "(call makeCompressed())");
  }
  Impl& s = *impl_;
  if (s.factor) cholmod_free_factor(&s.factor, &s.common);
  s.factor_valid = false;
  s.failed_column = -1;
  s.n = static_cast<int>(a.rows());
  const auto n = static_cast<size_t>(s.n);
  const auto nnz = static_cast<size_t>(a.nonZeros());
  s.pattern_outer.assign(a.outerIndexPtr(), a.outerIndexPtr() + n + 1);
  s.pattern_inner.assign(a.innerIndexPtr(), a.innerIndexPtr() + nnz);

  s.lower_outer.assign(n + 1, 0);
  s.lower_inner.clear();
  s.lower_source.clear();
  for (int j = 0; j < s.n; ++j) {
    for (int p = a.outerIndexPtr()[j]; p < a.outerIndexPtr()[j + 1]; ++p) {
      if (a.innerIndexPtr()[p] >= j) {
        s.lower_inner.push_back(a.innerIndexPtr()[p]);
        s.lower_source.push_back(p);
      }
    }
    s.lower_outer[static_cast<size_t>(j) + 1] = static_cast<int>(s.lower_inner.size());
  }
  s.lower_values.assign(s.lower_inner.size(), 0.0);
  if (s.n == 0) return;

  cholmod_sparse view = s.lower_view();
  s.factor = cholmod_analyze(&view, &s.common);
  if (!s.factor || s.common.status < CHOLMOD_OK) {
    const int status = s.common.status;
    if (s.factor) cholmod_free_factor(&s.factor, &s.common);
    s.n = -1;
    throw std::runtime_error("SparseCholesky::analyze: cholmod_analyze failed (status " +
                             std::to_string(status) + ")");
  }
  spdlog::debug(
      "SparseCholesky: analysed n = {}, nnz(lower A) = {}, nnz(L) = {:.0f}, "
      "ordering {}, {}",
      s.n, s.lower_values.size(), s.common.lnz, ordering_name(s.factor->ordering),
      s.factor->is_super ? "supernodal" : "simplicial");
}

bool SparseCholesky::factorize(const SparseMatrix& a) {
  Impl& s = *impl_;
  if (s.n < 0) throw std::logic_error("SparseCholesky::factorize: call analyze() first");
  const auto n = static_cast<size_t>(s.n);
  const bool same_pattern =
      a.rows() == s.n && a.cols() == s.n && a.isCompressed() &&
      static_cast<size_t>(a.nonZeros()) == s.pattern_inner.size() &&
      std::equal(s.pattern_outer.begin(), s.pattern_outer.end(), a.outerIndexPtr()) &&
      std::equal(s.pattern_inner.begin(), s.pattern_inner.end(), a.innerIndexPtr());
  if (!same_pattern) {
    throw std::invalid_argument(
        "SparseCholesky::factorize: the matrix pattern differs from the "
        "analysed one (call analyze() for a new pattern)");
  }
  for (size_t k = 0; k < s.lower_values.size(); ++k) {
    s.lower_values[k] = a.valuePtr()[s.lower_source[k]];
  }
  s.factor_valid = false;
  s.failed_column = -1;
  if (s.n == 0) {
    s.factor_valid = true;
    return true;
  }
  cholmod_sparse view = s.lower_view();
  cholmod_factorize(&view, s.factor, &s.common);
  if (s.common.status < CHOLMOD_OK) {
    throw std::runtime_error("SparseCholesky::factorize: cholmod_factorize failed (status " +
                             std::to_string(s.common.status) + ")");
  }
  if (s.common.status == CHOLMOD_NOT_POSDEF || s.factor->minor < n) {
    const size_t minor = std::min(static_cast<size_t>(s.factor->minor), n - 1);
    const int* perm = static_cast<const int*>(s.factor->Perm);
    s.failed_column = perm ? perm[minor] : static_cast<int>(minor);
    spdlog::debug("SparseCholesky: not positive definite, pivot {} of {} (column {})", minor, n,
                  s.failed_column);
    return false;
  }
  s.factor_valid = true;
  return true;
}

bool SparseCholesky::compute(const SparseMatrix& a) {
  analyze(a);
  return factorize(a);
}

bool SparseCholesky::analyzed() const { return impl_->n >= 0; }
bool SparseCholesky::factorized() const { return impl_->factor_valid; }
int SparseCholesky::failed_column() const { return impl_->failed_column; }
int SparseCholesky::rows() const { return std::max(impl_->n, 0); }

void SparseCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd* x,
                           SolveReport* report) const {
  if (b.size() != rows()) {
    throw std::invalid_argument("SparseCholesky::solve: right-hand side has " +
                                std::to_string(b.size()) + " rows, matrix has " +
                                std::to_string(rows()));
  }
  if (x == &b) throw std::invalid_argument("SparseCholesky::solve: x must not alias b");
  x->resize(b.size());
  impl_->solve(b.data(), 1, x->data(), report);
}

void SparseCholesky::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd* x,
                           SolveReport* report) const {
  if (b.rows() != rows()) {
    throw std::invalid_argument("SparseCholesky::solve: right-hand sides have " +
                                std::to_string(b.rows()) + " rows, matrix has " +
                                std::to_string(rows()));
  }
  if (x == &b) throw std::invalid_argument("SparseCholesky::solve: x must not alias b");
  x->resize(b.rows(), b.cols());
  impl_->solve(b.data(), static_cast<int>(b.cols()), x->data(), report);
}

Eigen::VectorXd SparseCholesky::solve(const Eigen::VectorXd& b) const {
  Eigen::VectorXd x;
  solve(b, &x);
  return x;
}

double SparseCholesky::factor_nonzeros() const { return impl_->factor ? impl_->common.lnz : 0.0; }

std::string SparseCholesky::selected_ordering() const {
  return impl_->factor ? ordering_name(impl_->factor->ordering) : "none";
}

bool SparseCholesky::is_supernodal() const {
  return impl_->factor != nullptr && impl_->factor->is_super != 0;
}

double SparseCholesky::reciprocal_condition_estimate() const {
  if (!impl_->factor_valid || impl_->n <= 0) return 0.0;
  return cholmod_rcond(impl_->factor, &impl_->common);
}

namespace {

// A function of the loaded BLAS by name, or nullptr (dlsym's void* to a function pointer).
template <typename Function>
Function blas_function(const char* name) {
  void* symbol = dlsym(RTLD_DEFAULT, name);
  Function function = nullptr;
  static_assert(sizeof(function) == sizeof(symbol));
  if (symbol) std::memcpy(&function, &symbol, sizeof(function));
  return function;
}

}  // namespace

bool SparseCholesky::set_blas_threads(int threads) {
  const auto set = blas_function<void (*)(int)>("openblas_set_num_threads");
  if (!set) return false;
  set(threads);
  return true;
}

int SparseCholesky::blas_threads() {
  const auto get = blas_function<int (*)()>("openblas_get_num_threads");
  return get ? get() : 0;
}

std::string SparseCholesky::blas_library() {
  void* dgemm = dlsym(RTLD_DEFAULT, "dgemm_");
  if (!dgemm) return "unknown";
  std::string name = "unknown";
  Dl_info info{};
  if (dladdr(dgemm, &info) != 0 && info.dli_fname) name = info.dli_fname;
  // OpenBLAS exports its build description; the reference BLAS has no such symbol.
  if (const auto config = blas_function<char* (*)()>("openblas_get_config"))
    if (const char* text = config()) name += std::string(" (") + text + ")";
  return name;
}

}  // namespace twill
