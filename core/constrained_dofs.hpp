#pragma once
// Free / fixed degree-of-freedom bookkeeping for the equilibrium solver (paper Eq. 4, §6.1).
//
// The paper's linear constraints Bq = b are, for clamps and supports, "dof i takes a
// prescribed value". twill eliminates them instead of adding Lagrange multipliers: the
// unknowns are the free dofs q_f, the fixed dofs q_c are data. At a stable equilibrium the
// free–free Hessian block K_ff is then symmetric positive definite and the supernodal LLᵀ of
// SparseCholesky applies (an indefinite KKT matrix would not; build-notes.md "CHOLMOD").
// The reaction at the supports is the gradient at the fixed dofs (no multiplier needed), and
// the paper's Eq. 6 becomes K_ff ∂q_f/∂k = −∂g_f/∂k.
//
// Shapes: full vectors have num_dofs() entries in the Discretization's layout
// (q = [x0 y0 z0 x1 …]); free vectors num_free() entries in increasing dof order; fixed
// vectors num_fixed() entries in increasing dof order.
//
// Blocks of a full Hessian H (#dofs × #dofs, compressed, same pattern every call):
//   K_ff = H[free, free]   (#free × #free, both triangles, diagonal always stored),
//   K_fc = H[free, fixed]  (#free × #fixed), the coupling through which moving supports
//                           move the free dofs: ∂q_f/∂q_c = −K_ff⁻¹ K_fc.
// analyze() computes, once per pattern, the blocks' patterns and a map from each block entry
// to H's value array; extract_*() then only copy values (no allocation inside Newton loops).
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

namespace twill {

class ConstrainedDofs {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;

  ConstrainedDofs() = default;
  /// `fixed_dofs` may be unsorted and contain duplicates; each must lie in [0, num_dofs)
  /// (std::invalid_argument naming the offending entry otherwise).
  ConstrainedDofs(int num_dofs, std::vector<int> fixed_dofs);
  /// The 3 dofs (x, y, z) of each node, for holding whole nodes: {3n, 3n+1, 3n+2, …}.
  static std::vector<int> node_dofs(const std::vector<int>& nodes);

  int num_dofs() const { return num_dofs_; }
  int num_free() const { return static_cast<int>(free_dofs_.size()); }
  int num_fixed() const { return static_cast<int>(fixed_dofs_.size()); }
  const std::vector<int>& free_dofs() const { return free_dofs_; }
  const std::vector<int>& fixed_dofs() const { return fixed_dofs_; }
  bool is_fixed(int dof) const { return fixed_index_[static_cast<size_t>(dof)] >= 0; }
  /// Position of `dof` in free vectors, −1 when it is fixed.
  int free_index(int dof) const { return free_index_[static_cast<size_t>(dof)]; }
  /// Position of `dof` in fixed vectors, −1 when it is free.
  int fixed_index(int dof) const { return fixed_index_[static_cast<size_t>(dof)]; }

  /// free = full[free dofs]; fixed = full[fixed dofs]. Outputs are resized.
  void gather_free(const Eigen::VectorXd& full, Eigen::VectorXd* free) const;
  void gather_fixed(const Eigen::VectorXd& full, Eigen::VectorXd* fixed) const;
  /// Writes the free (fixed) entries of `full`, leaving the others untouched.
  void scatter_free(const Eigen::VectorXd& free, Eigen::VectorXd* full) const;
  void scatter_fixed(const Eigen::VectorXd& fixed, Eigen::VectorXd* full) const;
  /// full += alpha · free-vector (on the free entries only), without a temporary.
  void add_to_free(double alpha, const Eigen::VectorXd& free, Eigen::VectorXd* full) const;
  /// Rows of `full` (#dofs × m) at the free dofs: #free × m (e.g. ∂g/∂k → ∂g_f/∂k).
  void gather_free_rows(const Eigen::MatrixXd& full, Eigen::MatrixXd* free) const;

  /// Prepares the block maps for `hessian`'s pattern (#dofs × #dofs, compressed; values are
  /// not read). Throws std::invalid_argument on a size mismatch or an uncompressed matrix.
  void analyze(const SparseMatrix& hessian);
  bool analyzed() const { return analyzed_; }
  /// True when `hessian` has exactly the analysed pattern (O(nnz) comparison).
  bool same_pattern(const SparseMatrix& hessian) const;

  /// K_ff from `hessian` (which must have the analysed pattern; sizes and nnz are checked).
  /// The first call (or a k_ff of another shape) sets k_ff's pattern; later calls only write
  /// values, so pass the same output matrix each time (or an empty one). Diagonal entries absent
  /// from `hessian` are stored as explicit zeros, so a diagonal shift (backward Euler's M/h²) never
  /// changes the pattern.
  void extract_free_free(const SparseMatrix& hessian, SparseMatrix* k_ff) const;
  /// K_fc, with the same allocation behaviour.
  void extract_free_fixed(const SparseMatrix& hessian, SparseMatrix* k_fc) const;
  /// For each free index i, the position of K_ff(i, i) in k_ff's value array.
  const std::vector<int>& free_free_diagonal() const { return free_free_diagonal_; }

 private:
  void check_analyzed_shape(const SparseMatrix& hessian, const char* caller) const;

  int num_dofs_ = 0;
  std::vector<int> free_dofs_, fixed_dofs_;
  std::vector<int> free_index_, fixed_index_;

  bool analyzed_ = false;
  std::vector<int> hessian_outer_, hessian_inner_;       // the analysed pattern
  SparseMatrix free_free_pattern_, free_fixed_pattern_;  // values zero, patterns final
  std::vector<int> free_free_source_;  // index into H's values, −1 for an added diagonal
  std::vector<int> free_fixed_source_;
  std::vector<int> free_free_diagonal_;
};

}  // namespace twill
