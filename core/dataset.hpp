#pragma once
// Fabric datasets: a folder with fabric.yaml and CSV tensile runs (docs/dataset-format.md).
//
// Units are the lab's, as in the files (mm, N, g/m², degrees); conversion to SI happens where
// the data meets the simulation. Angles: `angle_deg` is the strip axis vs the weft direction
// (0 weft, 90 warp, 45 bias; model.md §7).
//
// fabric.yaml keys (anything else is an InputError naming file, line and key):
//   name (text), areal_density_g_m2 (> 0), thickness_mm (> 0), weave (optional text),
//   tensile: list of {angle_deg, label?, width_mm > 0, gauge_length_mm > 0, rate_mm_min? > 0,
//                     role? fit|validation (default fit), runs: non-empty list of CSV paths}
//   bend:    list of {angle_deg, label?, width_mm > 0, length_mm > 0,
//                     chord_angle_deg in (0, 90), overhang_mm: non-empty list of values > 0}
// `tensile` and `bend` are each optional, but a dataset needs at least one test. Run paths are
// relative to the folder and must stay inside it after resolving `..` and symlinks; each must
// be a regular file. Every number is checked against its physical range
// (core/input_limits.hpp: widths, lengths, thickness, density, angles, rate; per CSV row the
// force and the extension as a strain of the gauge); text must be valid UTF-8. A run needs
// at least 2 rows, and 2 in its loading branch that pull the strip (positive extension and
// force): anything else is an error naming the CSV and where fabric.yaml lists it. Labels default from the angle: 90 "warp", 0 "weft", 45 "bias",
// otherwise "a<angle>" (e.g. "a22.5"); the labels of the tensile tests must differ (reports
// and repeat selection refer to tests by label), likewise those of the bend tests.
//
// Tensile run CSV: one header line, then comma-separated numbers; blank lines and lines
// starting with `#` are skipped anywhere (also before the header). Columns are found by name,
// case-insensitively, with the unit either as a suffix (`extension_mm`, `force_N`, `time_s`)
// or in parentheses/brackets (`Extension (mm)`, `Load [N]`); see tensile_column_names() for
// the accepted names. Required: extension and force; optional: time and lateral strain.
// A unit-less column is taken in lab units (mm, N, s, strain as a fraction). Other columns
// (a tester's stress or strain exports) are ignored, but every row must have as many cells
// as the header. Rows are kept in file order, including an unloading branch.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace twill {

enum class TestRole { Fit, Validation };
/// "fit" / "validation".
const char* to_string(TestRole role);

/// One tensile run (one CSV file): rows in file order.
struct TensileRun {
  std::string path;                  ///< the file as opened (dataset folder / listed path)
  std::string listed_path;           ///< as written in fabric.yaml, e.g. "tensile/warp-1.csv"
  std::vector<double> extension_mm;  ///< clamp separation minus gauge length [mm]
  std::vector<double> force_N;       ///< clamp force along the strip axis [N]
  std::vector<double> time_s;        ///< [s]; empty when the file has no time column
  std::vector<double> lateral_strain;  ///< engineering strain across the width; empty if absent
  std::vector<int> row_line;         ///< 1-based file line of each row (for messages)
  /// Index of the first row at the largest extension: rows [0, peak_index] are the loading
  /// branch.
  std::size_t peak_index = 0;
  /// Whether rows after the peak go back down (an unloading branch): some later extension is
  /// below the peak by more than 0.5 % of the extension range (tolerance so that jitter of a
  /// held crosshead does not count as unloading).
  bool has_unloading = false;

  std::size_t size() const { return extension_mm.size(); }
  bool has_time() const { return !time_s.empty(); }
  bool has_lateral_strain() const { return !lateral_strain.empty(); }
  /// File name without folder and extension, e.g. "warp-1".
  std::string name() const;
};

struct TensileTest {
  double angle_deg = 90;  ///< strip axis vs weft [deg]
  std::string label;      ///< given, or defaulted from the angle
  double width_mm = 50;
  double gauge_length_mm = 75;
  std::optional<double> rate_mm_min;  ///< crosshead speed [mm/min], when given
  TestRole role = TestRole::Fit;
  std::vector<TensileRun> runs;  ///< repeats, in the order listed
};

/// ASTM D1388 cantilever: the overhang at which the tip chord is `chord_angle_deg` below
/// horizontal (41.5° by the standard).
struct BendTest {
  double angle_deg = 90;  ///< strip axis vs weft [deg]
  std::string label;
  double width_mm = 25;
  double length_mm = 200;
  double chord_angle_deg = 41.5;
  std::vector<double> overhang_mm;  ///< one per repeat
};

struct Dataset {
  std::string folder;  ///< as given to read_dataset
  std::string name;
  double areal_density_g_m2 = 0;
  double thickness_mm = 0;
  std::string weave;  ///< free text; empty when not given
  std::vector<TensileTest> tensile;
  std::vector<BendTest> bend;
};

/// Reads `<folder>/fabric.yaml` and every run CSV it lists. Throws InputError naming the file,
/// line and key (or column) of the first problem.
Dataset read_dataset(const std::string& folder);

/// Reads one tensile run CSV (the `path` field is set to `path`, `listed_path` left empty).
TensileRun read_tensile_run_csv(const std::string& path);

/// The default label of a test at this angle: "warp", "weft", "bias" or "a<angle>".
std::string default_test_label(double angle_deg);

/// Accepted column names (after lower-casing, unit removal, and spaces/hyphens becoming
/// underscores), per quantity, for documentation and error messages.
struct TensileColumnNames {
  std::vector<std::string> extension, force, time, lateral_strain;
};
const TensileColumnNames& tensile_column_names();

}  // namespace twill
