#pragma once
// The angle offset Δθ of strips (paper §7's validation offsets; the misalignment effect's
// per-run parameter, effects/misalignment.hpp, docs/effects/misalignment.md), searched run by
// run at one level with the context's parameters. Used by the validation stage (its strips)
// and by the misalignment effect-fit (the fit runs).
//
// A 1-D search on the run's error e(Δθ) = Σ|F(θ0 + Δθ) − F̆| / Σ|F̆|: the nominal strip with
// the exact dF/dθ (Eq. 6, TensileExperiment::set_angle_sensitivity); a probe at the linearised
// step (t minimising Σ|F + t F' − F̆|, a weighted median) when that lies within ±kProbeDeg and
// beyond the grid — where F is linear in Δθ (the 22.5°/67.5° validation strips) it is the
// answer — else at ±kProbeDeg on the side the slope points to (where F'(0) vanishes, the
// linearised step is 0 or far out); then per step a quadratic model of every point's force in
// Δθ — Hermite through F(0), F'(0) and the probe, later through the nominal and the last two
// samples — whose L1 misfit Σ|F_model(Δθ) − F̆| is minimised on a grid over ±max_offset_deg;
// the minimiser, rounded to resolution_deg, is simulated next, at most `iterations` times,
// until it repeats an evaluated offset. The best evaluated offset wins (Δθ = 0 is always
// evaluated, first). Quadratic, not linear, because the strips that matter most are nearly
// symmetric in Δθ:
//
// - on a material axis (θ0 ≡ 0 mod 90°: warp, weft) the orthotropic law is mirror-symmetric
//   about the strip's axis, F(θ0 + Δθ) = F(θ0 − Δθ): dF/dθ = 0 at the nominal angle (a
//   Newton step would never leave it), every cut lowers the force by ½|F''|Δθ², and the
//   sign of Δθ is not identified (+ by convention);
// - a bias strip of a stiff-yarn weave deforms by shear, which is symmetric about 45° up to
//   the small a11 − a22 imbalance: F is nearly even there too.
// Runs of one test share their simulations (StripCurves): the nominal angle costs one curve
// per test, each later step one per distinct offset, warm-started from the nominal strip's
// q + Δθ dq/dθ.
#include <memory>
#include <vector>

#include "effects/effect.hpp"
#include "effects/misalignment.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/strip_curves.hpp"

namespace twill {

struct OffsetSearchOptions {
  double max_offset_deg = Misalignment::kMaxOffsetDeg;
  /// Steps after the nominal strip: the probe, the Hermite model's minimiser, and one model
  /// through three samples to confirm or correct it.
  int iterations = 3;
  /// Runs sharing an offset share a simulation; 0.05° is far below a cut's 1–2° error.
  double resolution_deg = 0.05;
  /// Each run's own force scale profiled out of its misfit, e(Δθ) = min_s Σ|s F − F̆| / Σ|F̆|
  /// (the misalignment effect-fit with `repeats.scale: per-run`): on a nearly even test a cut
  /// and a lighter specimen both lower the whole curve, and with the scale held at its last
  /// fit the offsets and the scales, searched in turn, crawl along that valley (measured:
  /// offsets at ~60 % of the drawn ones after 3 rounds, papers/hidden_effects/README.md).
  bool free_scale = false;
};

class OffsetSearch {
 public:
  struct Sample {
    double offset_deg, error;
    StripCurves::Simulated simulated;
  };
  /// The probe where the linearised step is no guide: within the 1–2° of a careful cut, and
  /// large enough that F(θ0 ± 1°) − F(θ0) is far above the solver's tolerance (a few % of F
  /// for a stiff-yarn weave on an axis, where 1/E(θ) ≈ 1/E1 + θ²/G12).
  static constexpr double kProbeDeg = 1.0;
  /// A test whose force extremum lies this close to the nominal angle has strips cut on both
  /// sides of it (a careful cut is off by 1–2°), so an offset's sign is not identified.
  static constexpr double kEvenVertexDeg = 2.0;

  /// `offset_effect`: the effect whose set-up hook turns a strip by its offset.
  OffsetSearch(OffsetSearchOptions options, std::shared_ptr<const Effect> offset_effect);

  /// Searches each run's offset at `level`; per run its samples, Δθ = 0 first (none when the
  /// nominal strip did not converge).
  std::vector<std::vector<Sample>> search(const FitContext& context, const std::vector<const RunData*>& runs,
                                          int level);

  /// The angle a strip cut at `nominal_deg` with `offset_deg` lies at (the effect's hook).
  double turned_angle(double nominal_deg, double offset_deg) const;
  /// Whether the forces of a test's runs (their samples, nominal and probe first) are nearly
  /// even in the offset: their sum, modelled as a quadratic in Δθ (Hermite through the probe),
  /// has its extremum within ±kEvenVertexDeg of the nominal angle — warp and weft on the
  /// material axes (extremum at 0), the bias of a stiff-yarn weave (near 0: poplin −0.2°).
  /// Runs without a probe count for nothing.
  static bool nearly_even(const std::vector<std::vector<Sample>>& test_samples);
  static const Sample* nominal(const std::vector<Sample>& samples);
  static const Sample* best(const std::vector<Sample>& samples);
  /// Where F is nearly even, F ≈ F0 + c Δθ² is linear in v = Δθ²: the v minimising the
  /// run's L1 misfit along the line through the nominal and the last sample, negative when
  /// the run's forces lie above the nominal strip's (an offset no strip can have, but the
  /// gauge of the misalignment effect-fit shifts every v of a test by the smallest).
  /// With a free scale (`free_scale`), the v of the least-squares fit s (F0 + v D) ≈ F̆ over s
  /// and v (linear in s and s v; L1 has no closed form in two unknowns).
  static double unconstrained_squared_offset(const RunData& d, const std::vector<Sample>& samples,
                                             bool free_scale = false);
  /// The L1 misfit Σ|s F − F̆| of forces F against measured F̆, with s = 1 or, for a free
  /// scale, its minimiser (the weighted median of F̆/F with weights |F|).
  static double misfit(const Eigen::VectorXd& forces, const Eigen::VectorXd& measured, bool free_scale);
  /// The s of misfit(): 1, or for a free scale the weighted median of F̆/F (the L1-best).
  static double scale(const Eigen::VectorXd& forces, const Eigen::VectorXd& measured, bool free_scale);
  /// The strips simulated so far (their nominal angles are anchors with their strain range).
  const StripCurves& curves() const { return curves_; }

 private:
  void sample(const FitContext& context, const std::vector<const RunData*>& runs,
              const std::vector<std::pair<size_t, double>>& wanted, int level, bool angle_derivative,
              std::vector<std::vector<Sample>>* samples);
  /// F(Δθ) ≈ f0 + f1 Δθ + f2 Δθ², per point.
  struct ForceModel {
    Eigen::VectorXd f0, f1, f2;
  };
  static ForceModel force_model(const std::vector<Sample>& samples);  ///< nominal first
  double model_minimiser(const ForceModel& model, const Eigen::VectorXd& measured) const;
  double on_grid(double offset_deg) const;  ///< rounded to resolution_deg (0: as it is)
  double next_offset(const RunData& d, const std::vector<Sample>& samples) const;

  OffsetSearchOptions options_;
  std::shared_ptr<const Effect> offset_effect_;
  StripCurves curves_;
};

}  // namespace twill
