#pragma once
// Material parameters of the Clyde–Teran–Tamstorf model (paper Table 1, docs/model.md §5)
// and their flat-vector view for optimisers and derivatives.
//
// Units: SI everywhere in this struct (Pa, m, kg/m²). Parameter *files* use the same SI
// units with the unit in the key name (see params_io.hpp).
//
// Flat vector layout (the order of every ∂/∂k in twill; `parameter_names()` spells it out):
//
//   0 density_kg_m2   1 thickness_m
//   2 a11_Pa          3 a12_Pa          4 a22_Pa          5 G12_Pa
//   then for each curve c in (eta1, eta3, eta4, eta2), degree d:
//     c.mu[1] … c.mu[d-1]      (d − 1 entries; mu[0] = 1 − Σ_{i≥1} mu[i] is *dependent*)
//     c.alpha[0] … c.alpha[d-1] (d entries)
//   then the two law-side bending ratios "bending.warp_ratio", "bending.weft_ratio" (b_w, b_f:
//     factors on the small-curvature bending stiffness along warp and weft, 1 = the paper's
//     model; core/bending_scale.hpp). ψ does not depend on them (zero columns of the law's
//     derivatives); the shells' bending terms do. params.yaml does not carry them: the
//     bending-anisotropy effect's law hook sets them from its own parameters
//     (docs/effects/bending-anisotropy.md), so in a file they are always 1;
//   then for each effect in `effects` (in order), each of its double options in their
//   resolved (schema) order, named "<effect>.<option>", e.g. "hysteresis.warp_friction_N_m"
//   (effects/effect.hpp: the effects' parameters; integer, bool and text options are choices,
//   not parameters, and stay out). The law does not depend on them (their columns of every
//   law derivative are zero); effects' hooks do (effects/effect_experiment.hpp).
//
// Σμ = 1 (η'(0) = 1, paper §3.1) therefore holds by construction for every flat vector.
// Strain cutoffs are not in the flat vector: the protocol sets them by rule (§5.2 steps 4, 6),
// they are never solved for.
#include <Eigen/Core>
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "core/config.hpp"

namespace twill {

/// Flat names of the law-side bending ratios (layout above).
inline constexpr const char* kBendingWarpRatioName = "bending.warp_ratio";
inline constexpr const char* kBendingWeftRatioName = "bending.weft_ratio";

/// One Ogden-like curve η(x) = Σ_i μ_i/α_i ((x+1)^α_i − 1) (paper §3.1). Degree = size.
struct Curve {
  std::vector<double> mu;     ///< weights, Σ mu = 1
  std::vector<double> alpha;  ///< exponents, ≠ 0

  int degree() const { return static_cast<int>(mu.size()); }
  /// The linear curve η(x) = x (degree 1, μ = 1, α = 1): orthotropic St. Venant–Kirchhoff.
  static Curve linear() { return Curve{{1.0}, {1.0}}; }
  bool operator==(const Curve& other) const = default;
};

/// Validity box of the orthotropic strain (paper §3.2, model.md §4). nullopt = "off" (±∞).
/// The shear box is symmetric: Ẽ12 ∈ [−E12_max, E12_max].
struct Cutoffs {
  std::optional<double> E11_min = 0.0;
  std::optional<double> E11_max;
  std::optional<double> E22_min = 0.0;
  std::optional<double> E22_max;
  std::optional<double> E12_max;
  bool operator==(const Cutoffs& other) const = default;
};

struct MaterialParameters {
  double density_kg_m2 = 0.1;  ///< areal mass ρ_A [kg/m²]
  double thickness_m = 5e-4;   ///< shell thickness τ [m]
  double a11_Pa = 1e7;         ///< warp small-strain stiffness [Pa]
  double a12_Pa = 5e6;         ///< coupling stiffness [Pa]; the paper sets ½ min(a11, a22) (§5.2)
  double a22_Pa = 1e7;         ///< weft small-strain stiffness [Pa]
  double G12_Pa = 1e5;         ///< shear small-strain stiffness [Pa]
  Curve eta1 = Curve::linear();  ///< warp stretch curve
  Curve eta3 = Curve::linear();  ///< weft stretch curve
  Curve eta4 = Curve::linear();  ///< shear curve
  /// Coupling curve of a12's term, η2(Ẽ11 Ẽ22) (Eq. 2). The paper keeps η2(x) = x (§5.2); its
  /// block comes after eta4's so that the three fitted curves keep their offsets.
  Curve eta2 = Curve::linear();
  Cutoffs cutoffs;
  /// Law-side bending ratios b_w, b_f (layout above; > 0): the shells scale the orthotropic
  /// bending strain by S = diag(√b_w, √b_f, (b_w b_f)^¼) before the through-thickness
  /// integral (core/bending_scale.hpp). Not in params.yaml: set by the bending-anisotropy
  /// effect's law hook.
  double bending_warp_ratio = 1.0;
  double bending_weft_ratio = 1.0;
  /// The model's effects (effects/effect.hpp) with their parameters, as params.yaml's
  /// `effects:` carries them (docs/dataset-format.md): registered name and resolved options.
  /// Empty: the paper's model. Their double options are the last block of the flat vector
  /// (layout above).
  std::vector<ComponentChoice> effects;

  /// Number of entries of the flat vector (depends on the curves' degrees).
  int flat_size() const;
  /// Flat vector in the layout documented above.
  Eigen::VectorXd to_flat() const;
  /// Sets every flat-vector entry (degrees, cutoffs unchanged); mu[0] of each curve becomes
  /// 1 − Σ of the others. `flat.size()` must equal flat_size().
  void set_from_flat(const Eigen::VectorXd& flat);
  /// Names of the flat entries, e.g. "a11_Pa", "eta1.mu[1]", "eta4.alpha[0]".
  std::vector<std::string> parameter_names() const;
  /// Index of a named flat entry; throws std::invalid_argument listing the known names.
  int index_of(const std::string& name) const;

  /// a12 = ½ min(a11, a22): the paper's choice, since the standard tests do not identify a12.
  static double tied_a12(double a11, double a22) { return 0.5 * std::min(a11, a22); }
  /// Every member equal (exactly: a cache's key, experiments/shared_schedule.hpp).
  bool operator==(const MaterialParameters& other) const = default;
};

/// Offsets of the blocks in the flat vector (used by the law's derivative code).
struct FlatLayout {
  static constexpr int kDensity = 0, kThickness = 1, kA11 = 2, kA12 = 3, kA22 = 4, kG12 = 5;
  static constexpr int kFirstCurve = 6;
  /// Entries of the bending block: warp ratio, then weft ratio.
  static constexpr int kBendingRatios = 2;
  int eta1 = 0, eta3 = 0, eta4 = 0, eta2 = 0;  ///< offset of each curve's block (its mu[1] entry)
  int bending = 0;  ///< offset of the bending ratios (bending.warp_ratio; weft at bending + 1)
  int effects = 0;  ///< offset of the effects' parameters (= the law's parameter count)
  int size = 0;
  explicit FlatLayout(const MaterialParameters& p);
  /// Offset of a curve block's first alpha entry.
  static int alpha_offset(int curve_offset, int degree) { return curve_offset + degree - 1; }
};

}  // namespace twill
