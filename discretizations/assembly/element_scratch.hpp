#pragma once
// Scratch storage for a dynamic-size Eigen temporary of an element kernel (a bending
// stencil's Jacobian, its Hessian block), reused across the elements of one range
// (parallel_runner.hpp): it grows to the largest size asked and never shrinks, so a loop
// allocates only when an element needs more than every element before it. Owned by the loop
// body for the length of one call: no state is kept in the discretisation.
//
// The map is aligned like a fresh Eigen::MatrixXd and has its compile-time properties, so an
// expression evaluated into it runs the same kernels, in the same order, as into a
// temporary: the values are bitwise the same.
#include <Eigen/Core>

namespace twill {

class ScratchMatrix {
 public:
  using Map = Eigen::Map<Eigen::MatrixXd, Eigen::AlignedMax>;
  using VectorMap = Eigen::Map<Eigen::VectorXd, Eigen::AlignedMax>;
  /// A rows × cols matrix over the storage (contents unspecified).
  Map operator()(Eigen::Index rows, Eigen::Index cols) { return Map(reserve(rows * cols), rows, cols); }
  /// A vector of `size` entries over the storage (contents unspecified).
  VectorMap vector(Eigen::Index size) { return VectorMap(reserve(size), size); }

 private:
  double* reserve(Eigen::Index size) {
    if (storage_.size() < size) storage_.resize(size);
    return storage_.data();
  }

  Eigen::VectorXd storage_;
};

}  // namespace twill
