#pragma once
// Which repeats of a tensile test to fit (paper §6.4, model.md §8 "Repeated runs").
//
// The paper's rule: repeats of one tensile test differ by up to 20 %, mostly because the strip
// was cut slightly off the target angle. A warp or weft strip cut off-axis is softer, so for
// warp/weft the repeat with the largest forces is taken as the best aligned. For other angles
// (bias, 22.5°, 67.5°) there is no such criterion, and one repeat is drawn at random.
//
// "Largest forces", precisely: the largest integral of force over extension, ∫ F dx [N·mm],
// over the extension range common to all repeats, [max_r min x_r, min_r max x_r], using each
// repeat's loading branch (rows 0..peak_index) linearly interpolated. Why not the largest
// maximum force: the maximum is one noisy point at the end of a test, and it depends on where
// each run happened to stop; the paper compares repeats at fixed elongation, and the integral
// over a shared range compares whole curves at equal elongations. Ties go to the earlier run.
//
// Randomness: std::mt19937_64 seeded with the given seed; the draw is `engine() % n` (not
// std::uniform_int_distribution, whose algorithm differs between standard libraries), so a
// seed gives the same run on every platform. For a whole dataset, each test gets its own
// engine seeded with splitmix64(seed ^ fnv1a(label)), so tests with the same number of runs do
// not all draw the same index, and adding a test does not change the others' draws.
#include <cstdint>
#include <string>
#include <vector>

#include "core/dataset.hpp"

namespace twill {

enum class RepeatRule {
  Paper,    ///< largest forces for warp/weft (angle ≡ 0 mod 90), one random run otherwise
  Largest,  ///< largest forces, whatever the angle
  Random,   ///< one random run, whatever the angle
  All,      ///< every run
  /// Largest forces for warp/weft (the paper's), every run otherwise: where the paper has no
  /// alignment criterion and draws one run, every run with its specimen scale
  /// (`repeats.scale: per-run`) fits the geometric-mean specimen, whose offset from the
  /// population's is the scatter over √n instead of one draw's (docs/fitting.md §3b).
  LargestOrAll,
};

/// "paper", "largest", "random", "all", "largest-or-all".
const char* to_string(RepeatRule rule);
/// Parses the names above; throws InputError listing them otherwise.
RepeatRule repeat_rule_from_string(const std::string& name);
/// Every rule with its name (for option bindings: enum_option).
std::vector<std::pair<std::string, RepeatRule>> repeat_rule_names();

struct RepeatSelection {
  std::vector<std::size_t> runs;  ///< indices into TensileTest::runs, ascending
  /// ∫ F dx over the common range per run [N·mm] (filled by the largest-force rule, else empty).
  std::vector<double> force_integral_Nmm;
  double common_min_mm = 0, common_max_mm = 0;  ///< the common range used (largest-force rule)
  std::string reason;  ///< one line for reports, e.g. "largest forces: warp-1 (2051 N·mm over 0.225–9 mm)"
};

/// Whether the paper treats this angle as warp/weft (0° or 90° modulo 90°, within 1e-9°).
bool is_principal_direction(double angle_deg);

/// Selects the runs of one test. `seed` is used by the random draw only. Throws InputError
/// (file = the first run) when the largest-force rule is asked for runs that share no
/// extension range.
RepeatSelection select_repeats(const TensileTest& test, RepeatRule rule, std::uint64_t seed);

/// select_repeats() for every tensile test of a dataset, each with its own seed derived from
/// `seed` and the test's label (see above). Same order as dataset.tensile.
std::vector<RepeatSelection> select_repeats(const Dataset& dataset, RepeatRule rule, std::uint64_t seed);

/// ∫ F dx [N·mm] of a run's loading branch over [from_mm, to_mm] (linear interpolation;
/// extension outside the run's range is not extrapolated: the caller passes a range inside it).
double loading_force_integral(const TensileRun& run, double from_mm, double to_mm);

}  // namespace twill
