#pragma once
// The orthotropic hyperelastic law of Clyde, Teran & Tamstorf 2017 (paper Eq. 2, §3.1–3.2;
// docs/model.md §2–4; derivation in docs/material_law.md).
//
//   ψ(Ẽ; k) = a11/2 η1(Ẽ11²) + a12 η2(Ẽ11Ẽ22) + a22/2 η3(Ẽ22²) + G12 η4(Ẽ12²)   [Pa = J/m³]
//
// The paper keeps η2(x) = x (§5.2), the default (Curve::linear()); the poisson effect frees
// its curvature (docs/effects/poisson.md). The orthotropic strain is passed as the 3-vector
// e = (Ẽ11, Ẽ22, Ẽ12): warp stretch, weft stretch, and the *tensor* shear component
// Ẽ12 = d1·E·d2 (not the engineering shear 2Ẽ12).
//
// Structure used throughout: ψ = F1(e1) + F3(e2) + F4(e3) + C(u), u = e1 e2, is a sum of
// univariate terms in e1, e2, e3 and u. The extrapolation of §3.2 (second-order Taylor
// expansion about the nearest point of the validity box) therefore acts on each term
// separately: outside [min_i, max_i], F_i is replaced by its quadratic Taylor polynomial at the
// violated bound, and η2 outside u's interval over the box by its own — for η2(x) = x the
// bilinear C is its own Taylor polynomial. Value, gradient and Hessian are continuous across
// the box (C²), which Newton and the sensitivities need. docs/material_law.md §3a.
#include <Eigen/Core>

#include "core/bending_scale.hpp"
#include "core/parameters.hpp"

namespace twill {

using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
/// ∂²ψ/∂e∂k: 3 rows (e1, e2, e3) × flat-parameter columns.
using StrainParameterMatrix = Eigen::Matrix<double, 3, Eigen::Dynamic>;

/// Value and derivatives of one curve η at x ≥ −1 (paper §3.1). α → 0 is the limit
/// μ·log(1 + x), evaluated without division by zero.
struct CurveValue {
  double value = 0, d1 = 0, d2 = 0;  ///< η, η', η''
};
CurveValue evaluate_curve(const Curve& c, double x);

/// What the coupling term needs of the parameters at every strain, computed once per law: whether
/// η2 is the paper's η2(x) = x (evaluated as the bilinear term) and the interval of u = Ẽ11 Ẽ22
/// over the validity box, outside which η2 is extrapolated (docs/material_law.md §3a).
struct CouplingShape {
  explicit CouplingShape(const MaterialParameters& p);
  bool linear = true;
  double product_lo = 0, product_hi = 0;
};

class MaterialLaw {
 public:
  explicit MaterialLaw(const MaterialParameters& parameters);

  const MaterialParameters& parameters() const { return parameters_; }
  /// Number of columns of every parameter derivative (= parameters().flat_size()).
  int num_parameters() const { return layout_.size; }
  /// Offsets of the flat vector's blocks for these parameters.
  const FlatLayout& layout() const { return layout_; }
  /// The shells' bending-strain scale S from the law-side bending ratios
  /// (core/bending_scale.hpp), computed once here. ψ does not depend on the ratios (their
  /// columns of parameter_derivatives() are zero); the shells' bending terms do.
  const BendingScale& bending_scale() const { return bending_scale_; }

  /// ψ(e) [Pa]. Optional ∂ψ/∂e (3) and ∂²ψ/∂e² (3×3, symmetric); pass nullptr to skip.
  double energy_density(const Vector3& e, Vector3* gradient = nullptr,
                        Matrix3* hessian = nullptr) const;

  /// Parameter derivatives at strain e in the flat layout of parameters.hpp:
  /// ∂ψ/∂k (num_parameters()) and the mixed ∂²ψ/∂e∂k (3 × num_parameters()).
  /// Columns of density, thickness and the bending ratios are zero (they do not enter ψ);
  /// either output may be nullptr. Outputs are resized.
  void parameter_derivatives(const Vector3& e, Eigen::VectorXd* dpsi_dk,
                             StrainParameterMatrix* d2psi_de_dk) const;

 private:
  MaterialParameters parameters_;
  FlatLayout layout_;
  BendingScale bending_scale_;
  CouplingShape coupling_shape_;
};

}  // namespace twill
