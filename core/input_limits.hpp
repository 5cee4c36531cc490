#pragma once
// The one place where twill's input limits live: the physical range of every lab quantity a
// dataset or a command line gives, and the memory estimate that bounds mesh resolutions.
//
// Every reader checks its numbers here (core/dataset.cpp for fabric.yaml and run CSVs,
// `twill simulate` / `twill bench` for their arguments, `twill fit` for the resolutions its
// config implies), so a typo such as `thickness_mm: 1e6` or `--resolution 100000x100000` is
// rejected where it is read, with the unit and the range in the message, instead of failing
// deep in a solver or allocating until std::bad_alloc. The ranges are deliberately wide (they
// catch impossible values, not unusual fabrics); docs/reliability.md gives the reason of each.
#include <cstdint>
#include <string>

namespace twill {

/// A closed or half-open range of a physical quantity in lab units.
struct PhysicalRange {
  const char* quantity;   ///< what it is, e.g. "a strip width"
  const char* unit;       ///< "mm", "g/m²", "deg", ...
  double lo = 0;
  double hi = 0;
  bool lo_exclusive = false;  ///< (lo, hi] instead of [lo, hi]
  const char* why;        ///< the reason for the bounds, quoted in the message
};

namespace limits {

/// Areal density: (0, 5000] g/m². The lightest nonwovens are ~10 g/m², heavy canvas and
/// conveyor fabrics ~2000 g/m²; 5000 leaves room and still catches a kg/m² or mg/m² mix-up.
extern const PhysicalRange kArealDensity;
/// Fabric thickness: (0, 20] mm. Woven fabrics are 0.05–3 mm thick, felts up to ~10 mm; a
/// thin-shell model is meaningless beyond that (the 1e6 mm is a unit slip).
extern const PhysicalRange kThickness;
/// Strip width: (0, 1000] mm. ASTM D5035 uses 25/50 mm, wide-width tests (ISO 10319) 200 mm.
extern const PhysicalRange kStripWidth;
/// Gauge, bend-strip and overhang lengths: (0, 5000] mm (tensile frames travel < 2 m).
extern const PhysicalRange kStripLength;
/// Strip angles vs the weft: [-180, 180] deg (any orientation, written either way round).
extern const PhysicalRange kAngle;
/// Crosshead rate: (0, 1e5] mm/min (ASTM D5035: 300 mm/min; fast testers reach ~1e4).
extern const PhysicalRange kCrossheadRate;
/// |force| in a run CSV: at most 1e6 N (a 50 mm strip of the strongest aramid webbing breaks
/// below 1e5 N; beyond this the column is not in newtons).
extern const PhysicalRange kForceMagnitude;
/// Engineering strain of an extension (extension / gauge length): [-1, 10]. Woven fabrics
/// break below 1 (100 %), knits and elastane blends below ~6; -1 is the clamps touching.
extern const PhysicalRange kEngineeringStrain;

/// Memory limit of one simulated strip, bytes (4 GiB). A fit runs one strip per core at a
/// time (validation curves in parallel), so 2 cores need up to 8 GiB at this limit.
constexpr double kMeshMemoryLimitBytes = 4.0 * 1024 * 1024 * 1024;
/// Estimated bytes per mesh cell (64 KiB): measured peak memory grows by 35 kB per cell from
/// 8x12 to 32x48 on either discretisation (README bench tables: 19 → 69 MB); ×1.8 covers the
/// n log n growth of the Cholesky factor's fill up to the limit (log 65536 / log 1536 ≈ 1.5).
constexpr double kEstimatedBytesPerCell = 64.0 * 1024;
/// Estimated fixed memory of a run, bytes (16 MiB: the bench tables' intercept).
constexpr double kEstimatedBaseBytes = 16.0 * 1024 * 1024;

}  // namespace limits

/// Empty when `value` is finite and in `range`; otherwise the violation in words with the
/// unit, range and reason, e.g. "a fabric thickness must be in (0, 20] mm (…), got 1e+06 mm".
std::string range_violation(double value, const PhysicalRange& range);

/// Estimated peak memory [bytes] of simulating one strip of `cells_across` × `cells_along`
/// cells (doubles, so that absurd requests do not overflow).
double estimated_mesh_bytes(double cells_across, double cells_along);

/// Empty when the mesh fits the memory limit (and both counts are ≥ 1); otherwise what it
/// would need and what the limit is, e.g. "a 100000x100000 mesh would need ~596 TiB
/// (64 KiB per cell), the limit is 4 GiB per strip".
std::string mesh_size_violation(double cells_across, double cells_along);

/// "4 GiB", "596 TiB", "71.5 MiB": a byte count for messages.
std::string format_bytes(double bytes);

}  // namespace twill
