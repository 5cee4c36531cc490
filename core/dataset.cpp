#include "core/dataset.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <system_error>

#include "core/input_error.hpp"
#include "core/input_limits.hpp"
#include "core/yaml_reader.hpp"

namespace twill {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------
// CSV columns

enum class Quantity { Extension, Force, Time, LateralStrain };
constexpr int kNumQuantities = 4;

const char* quantity_name(Quantity q) {
  switch (q) {
    case Quantity::Extension: return "extension";
    case Quantity::Force: return "force";
    case Quantity::Time: return "time";
    case Quantity::LateralStrain: return "lateral strain";
  }
  return "";
}

struct UnitFactor {
  const char* unit;  // lower case
  double to_lab;     // multiply by this to get mm, N, s or strain (fraction)
};

// Units a column may carry, per quantity. Lower case, because headers are compared
// case-insensitively ("force_N", "Load (n)"); "mn" is therefore millinewton: nobody tests
// fabric strips in meganewtons.
const std::vector<UnitFactor>& units_of(Quantity q) {
  static const std::vector<UnitFactor> length = {{"mm", 1.0}, {"cm", 10.0}, {"m", 1000.0}, {"in", 25.4}};
  static const std::vector<UnitFactor> force = {{"n", 1.0}, {"kn", 1000.0}, {"mn", 1e-3}, {"lbf", 4.4482216152605}};
  static const std::vector<UnitFactor> time = {{"s", 1.0}, {"ms", 1e-3}, {"min", 60.0}};
  static const std::vector<UnitFactor> strain = {{"-", 1.0}, {"mm/mm", 1.0}, {"%", 0.01}};
  switch (q) {
    case Quantity::Extension: return length;
    case Quantity::Force: return force;
    case Quantity::Time: return time;
    case Quantity::LateralStrain: return strain;
  }
  return strain;
}

const std::vector<std::string>& names_of(Quantity q) {
  const auto& n = tensile_column_names();
  switch (q) {
    case Quantity::Extension: return n.extension;
    case Quantity::Force: return n.force;
    case Quantity::Time: return n.time;
    case Quantity::LateralStrain: return n.lateral_strain;
  }
  return n.time;
}

std::string trim(std::string_view s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string_view::npos) return {};
  const auto end = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(begin, end - begin + 1));
}

std::string unquote(std::string s) {
  if (s.size() >= 2 && ((s.front() == '"' && s.back() == '"') || (s.front() == '\'' && s.back() == '\'')))
    return trim(s.substr(1, s.size() - 2));
  return s;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// "Tensile extension (mm)" -> name "tensile_extension", unit "mm"; "force_N" -> "force_n", "".
struct HeaderName {
  std::string name;
  std::string unit;
  bool unit_given = false;
};

HeaderName split_header(const std::string& raw) {
  HeaderName h;
  std::string text = lower(unquote(trim(raw)));
  if (!text.empty() && (text.back() == ')' || text.back() == ']')) {
    const char open = text.back() == ')' ? '(' : '[';
    const auto at = text.rfind(open);
    if (at != std::string::npos) {
      h.unit = trim(text.substr(at + 1, text.size() - at - 2));
      h.unit_given = true;
      text = trim(text.substr(0, at));
    }
  }
  std::string name;
  for (char c : text) {
    const char mapped = (c == ' ' || c == '-' || c == '\t') ? '_' : c;
    if (mapped == '_' && (name.empty() || name.back() == '_')) continue;
    name += mapped;
  }
  while (!name.empty() && name.back() == '_') name.pop_back();
  h.name = name;
  return h;
}

// Whether the header names quantity q; sets the factor that converts to lab units.
bool matches(const HeaderName& h, Quantity q, double& factor) {
  const auto& units = units_of(q);
  for (const auto& base : names_of(q)) {
    if (h.name == base) {
      if (!h.unit_given) {
        factor = 1.0;  // unit-less: lab units (mm, N, s, fraction)
        return true;
      }
      for (const auto& u : units)
        if (h.unit == u.unit) {
          factor = u.to_lab;
          return true;
        }
      return false;
    }
    // Unit as a suffix: "extension_mm", "force_n", "time_s".
    if (!h.unit_given && h.name.size() > base.size() + 1 && h.name.compare(0, base.size(), base) == 0 &&
        h.name[base.size()] == '_') {
      const std::string suffix = h.name.substr(base.size() + 1);
      for (const auto& u : units)
        if (suffix == u.unit) {
          factor = u.to_lab;
          return true;
        }
    }
  }
  return false;
}

std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    cells.push_back(trim(std::string_view(line).substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

std::optional<double> parse_cell(std::string cell) {
  cell = unquote(cell);
  if (!cell.empty() && cell.front() == '+') cell.erase(0, 1);
  if (cell.empty()) return std::nullopt;
  double value = 0;
  const auto [end, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), value);
  if (ec != std::errc() || end != cell.data() + cell.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

bool skipped_line(const std::string& line) {
  const std::string t = trim(line);
  return t.empty() || t.front() == '#';
}

void find_loading_peak(TensileRun& run) {
  const auto& e = run.extension_mm;
  const auto [lo, hi] = std::minmax_element(e.begin(), e.end());
  run.peak_index = static_cast<std::size_t>(std::distance(e.begin(), hi));
  const double tolerance = 0.005 * (*hi - *lo);
  run.has_unloading = false;
  for (std::size_t i = run.peak_index + 1; i < e.size(); ++i)
    if (e[i] < *hi - tolerance && *hi > *lo) run.has_unloading = true;
}

// A run the fit could use: at least two rows of the loading branch pull the strip (positive
// extension and force). All-zero or all-negative forces (a sign or a column mix-up) are an
// error here, not a run the repeat selection silently passes over.
void check_usable(const TensileRun& run) {
  std::size_t pulling = 0;
  bool any_positive_force = false;
  for (std::size_t i = 0; i < run.size(); ++i) {
    any_positive_force = any_positive_force || run.force_N[i] > 0;
    if (i <= run.peak_index && run.force_N[i] > 0 && run.extension_mm[i] > 0) ++pulling;
  }
  if (!any_positive_force)
    throw InputError({run.path, run.row_line.front(), "force"},
                     "no positive force in " + std::to_string(run.size()) +
                         " rows (all zero or negative): a tensile run pulls the strip; check the force column's sign");
  if (pulling < 2)
    throw InputError({run.path, run.row_line.front(), ""},
                     "fewer than 2 rows of the loading branch with positive extension and force: the run cannot be fitted");
}

// ---------------------------------------------------------------------------------------
// fabric.yaml

// A number in its physical range (core/input_limits.hpp), or an error with unit and range.
double quantity(const YamlValue& v, const PhysicalRange& range) {
  const double x = v.as_double();
  const std::string violation = range_violation(x, range);
  if (!violation.empty()) throw v.error(violation);
  return x;
}

double angle(const YamlValue& v) { return quantity(v, limits::kAngle); }

std::string label_or_default(YamlMap& map, double angle_deg) {
  if (auto label = map.find("label")) {
    std::string text = label->as_string();
    if (text.empty()) throw label->error("a label must not be empty");
    return text;
  }
  return default_test_label(angle_deg);
}

TestRole read_role(YamlMap& map) {
  auto role = map.find("role");
  if (!role) return TestRole::Fit;
  const std::string text = role->as_string();
  if (text == "fit") return TestRole::Fit;
  if (text == "validation") return TestRole::Validation;
  throw role->error("unknown role '" + text + "' (known roles: fit, validation)");
}

// A path listed in fabric.yaml, resolved inside the dataset folder. The contract says paths
// are relative to the folder; after resolving `..` and symlinks the file must still be in it,
// so a dataset can neither read nor make twill parse files elsewhere (`../../etc/passwd`).
// Every error is located at the listing line of fabric.yaml.
fs::path contained_path(const YamlValue& item, const fs::path& folder) {
  const std::string listed = item.as_string();
  const fs::path path(listed);
  if (listed.empty()) throw item.error("an empty path (paths are relative to the dataset folder)");
  if (path.is_absolute() || path.has_root_name() || path.has_root_directory())
    throw item.error("an absolute path '" + excerpt(listed) +
                     "': paths are relative to the dataset folder (dataset-format.md)");
  const fs::path resolved = folder / path;
  std::error_code ec;
  const fs::path root = fs::canonical(folder, ec);
  if (ec) throw item.error("cannot resolve the dataset folder " + folder.string() + ": " + ec.message());
  const fs::path target = fs::weakly_canonical(resolved, ec);
  if (ec) {
    check_readable_file(resolved.string(), item.location());  // names a symlink loop as such
    throw item.error("cannot resolve '" + excerpt(listed) + "': " + ec.message());
  }
  const fs::path inside = target.lexically_relative(root);
  if (inside.empty() || *inside.begin() == "..")
    throw item.error("the path '" + excerpt(listed) + "' leaves the dataset folder (it resolves to " +
                     target.string() + "); paths must stay inside " + root.string());
  check_readable_file(resolved.string(), item.location());
  return resolved;
}

// Extensions as engineering strains within limits::kEngineeringStrain of the test's gauge.
void check_strains(const TensileRun& run, double gauge_length_mm) {
  for (std::size_t i = 0; i < run.size(); ++i) {
    const std::string violation = range_violation(run.extension_mm[i] / gauge_length_mm, limits::kEngineeringStrain);
    if (!violation.empty())
      throw InputError({run.path, run.row_line[i], "extension"},
                       "extension " + format_double(run.extension_mm[i]) + " mm on a " + format_double(gauge_length_mm) +
                           " mm gauge: " + violation + " (is the column in mm?)");
  }
}

TensileTest read_tensile_test(const YamlValue& v, const fs::path& folder) {
  YamlMap map(v);
  map.expect({"angle_deg", "label", "width_mm", "gauge_length_mm", "rate_mm_min", "role", "runs"});
  TensileTest t;
  t.angle_deg = angle(map.get("angle_deg"));
  t.label = label_or_default(map, t.angle_deg);
  t.width_mm = quantity(map.get("width_mm"), limits::kStripWidth);
  t.gauge_length_mm = quantity(map.get("gauge_length_mm"), limits::kStripLength);
  if (auto rate = map.find("rate_mm_min")) t.rate_mm_min = quantity(*rate, limits::kCrossheadRate);
  t.role = read_role(map);
  const YamlValue runs = map.get("runs");
  map.finish();
  const auto items = runs.items();
  if (items.empty()) throw runs.error("a tensile test needs at least one run file");
  for (const auto& item : items) {
    const std::string listed = item.as_string();
    const fs::path file = contained_path(item, folder);
    TensileRun run;
    try {
      run = read_tensile_run_csv(file.string());
      check_strains(run, t.gauge_length_mm);
    } catch (const InputError& e) {
      // The CSV's own location first (file, line, column), then where fabric.yaml lists it.
      throw InputError(e.where(), e.reason() + " (run listed in " + item.file() + ":" +
                                      std::to_string(item.line()) + ", key '" + item.path() + "')");
    }
    run.listed_path = listed;
    t.runs.push_back(std::move(run));
  }
  return t;
}

BendTest read_bend_test(const YamlValue& v) {
  YamlMap map(v);
  map.expect({"angle_deg", "label", "width_mm", "length_mm", "chord_angle_deg", "overhang_mm"});
  BendTest b;
  b.angle_deg = angle(map.get("angle_deg"));
  b.label = label_or_default(map, b.angle_deg);
  b.width_mm = quantity(map.get("width_mm"), limits::kStripWidth);
  const YamlValue length = map.get("length_mm");
  b.length_mm = quantity(length, limits::kStripLength);
  const YamlValue chord = map.get("chord_angle_deg");
  b.chord_angle_deg = chord.as_double();
  if (!(b.chord_angle_deg > 0.0 && b.chord_angle_deg < 90.0))
    throw chord.error("must be between 0 and 90 degrees (41.5 by ASTM D1388), got " + format_double(b.chord_angle_deg));
  const YamlValue overhang = map.get("overhang_mm");
  map.finish();
  for (const auto& item : overhang.items()) {
    const double value = quantity(item, limits::kStripLength);
    if (value >= b.length_mm)
      throw item.error("an overhang of " + format_double(value) + " mm does not fit on a strip of length_mm " +
                       format_double(b.length_mm));
    b.overhang_mm.push_back(value);
  }
  if (b.overhang_mm.empty()) throw overhang.error("a bend test needs at least one overhang value");
  return b;
}

template <typename Test>
void check_unique_labels(const std::vector<Test>& tests, const std::vector<YamlValue>& items) {
  for (std::size_t i = 0; i < tests.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (tests[i].label == tests[j].label)
        throw items[i].error("label '" + tests[i].label + "' is already used by " + items[j].path() +
                             " (give the tests distinct `label:` values)");
}

}  // namespace

const char* to_string(TestRole role) { return role == TestRole::Fit ? "fit" : "validation"; }

std::string TensileRun::name() const { return fs::path(path).stem().string(); }

const TensileColumnNames& tensile_column_names() {
  static const TensileColumnNames names{
      {"extension", "elongation", "displacement", "tensile_extension", "crosshead_extension"},
      {"force", "load", "tensile_force", "tensile_load"},
      {"time", "elapsed_time", "test_time"},
      {"lateral_strain", "transverse_strain", "width_strain"}};
  return names;
}

std::string default_test_label(double angle_deg) {
  if (angle_deg == 90.0) return "warp";
  if (angle_deg == 0.0) return "weft";
  if (angle_deg == 45.0) return "bias";
  std::string label = "a";  // appended, not "a" + …: GCC 12 warns falsely (-Wrestrict) on the latter
  label += format_double(angle_deg);
  return label;
}

namespace {

// A tensile CSV's header: which column gives each quantity (-1: none) and its unit factor.
struct CsvColumns {
  std::vector<std::string> cells;
  int line = 0;
  int column[kNumQuantities] = {-1, -1, -1, -1};
  double factor[kNumQuantities] = {1, 1, 1, 1};
};

// The header at `line`: each quantity's column (a quantity given twice is an error), the
// extension and the force required.
CsvColumns read_csv_header(const std::string& path, std::vector<std::string> cells, int line) {
  CsvColumns h;
  h.cells = std::move(cells);
  h.line = line;
  for (int q = 0; q < kNumQuantities; ++q) {
    for (std::size_t c = 0; c < h.cells.size(); ++c) {
      double f = 1.0;
      if (!matches(split_header(h.cells[c]), static_cast<Quantity>(q), f)) continue;
      if (h.column[q] >= 0)
        throw InputError({path, line, h.cells[c]},
                         std::string("two columns give the ") + quantity_name(static_cast<Quantity>(q)) + ": '" +
                             h.cells[static_cast<std::size_t>(h.column[q])] + "' and '" + h.cells[c] + "'");
      h.column[q] = static_cast<int>(c);
      h.factor[q] = f;
    }
  }
  for (Quantity q : {Quantity::Extension, Quantity::Force}) {
    if (h.column[static_cast<int>(q)] >= 0) continue;
    std::string accepted;
    for (const auto& n : names_of(q)) accepted += (accepted.empty() ? "" : ", ") + n;
    throw InputError({path, line, ""}, std::string("missing required ") + quantity_name(q) +
                                           " column (header names accepted, " +
                                           "case-insensitive, unit as _suffix or in parentheses: " + accepted + ")");
  }
  return h;
}

// A data row at `line` into `run`: as many cells as the header, each read quantity a finite
// number (a force within limits::kForceMagnitude), in SI-like units (mm, N, s, 1).
void read_csv_row(const std::string& path, const CsvColumns& h, const std::vector<std::string>& cells, int line,
                  TensileRun* run) {
  std::vector<double>* target[kNumQuantities] = {&run->extension_mm, &run->force_N, &run->time_s, &run->lateral_strain};
  if (cells.size() != h.cells.size())
    throw InputError({path, line, ""}, "row has " + std::to_string(cells.size()) + " cells, the header (line " +
                                           std::to_string(h.line) + ") has " + std::to_string(h.cells.size()));
  for (int q = 0; q < kNumQuantities; ++q) {
    if (h.column[q] < 0) continue;
    const auto c = static_cast<std::size_t>(h.column[q]);
    const auto value = parse_cell(cells[c]);
    if (!value) throw InputError({path, line, excerpt(h.cells[c])}, "not a finite number: '" + excerpt(cells[c]) + "'");
    if (q == static_cast<int>(Quantity::Force)) {
      const std::string violation = range_violation(*value * h.factor[q], limits::kForceMagnitude);
      if (!violation.empty()) throw InputError({path, line, excerpt(h.cells[c])}, violation);
    }
    target[q]->push_back(*value * h.factor[q]);
  }
  run->row_line.push_back(line);
}

}  // namespace

TensileRun read_tensile_run_csv(const std::string& path) {
  check_readable_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError({path, 0, ""}, "cannot open file");
  TensileRun run;
  run.path = path;
  std::string line;
  int line_number = 0;
  std::optional<CsvColumns> header;
  while (std::getline(in, line)) {
    ++line_number;
    if (line_number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    if (skipped_line(line)) continue;
    if (!header)
      header = read_csv_header(path, split_cells(line), line_number);
    else
      read_csv_row(path, *header, split_cells(line), line_number, &run);
  }
  if (!header) throw InputError({path, 0, ""}, "empty file: no header line");
  if (run.extension_mm.empty()) throw InputError({path, header->line, ""}, "no data rows after the header");
  if (run.size() < 2)
    throw InputError({path, run.row_line[0], ""}, "only one data row: a force-extension curve needs at least 2");
  find_loading_peak(run);
  check_usable(run);
  return run;
}

Dataset read_dataset(const std::string& folder) {
  const fs::path dir(folder);
  const std::string fabric_file = (dir / "fabric.yaml").string();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError({folder, 0, ""}, "not a dataset folder (no such directory)");
  const YamlValue root = load_yaml_file(fabric_file);
  YamlMap map(root);
  map.expect({"name", "areal_density_g_m2", "thickness_mm", "weave", "tensile", "bend"});
  Dataset d;
  d.folder = folder;
  d.name = map.get("name").as_string();
  d.areal_density_g_m2 = quantity(map.get("areal_density_g_m2"), limits::kArealDensity);
  d.thickness_mm = quantity(map.get("thickness_mm"), limits::kThickness);
  if (auto weave = map.find("weave")) d.weave = weave->as_string();
  const auto tensile = map.find("tensile");
  const auto bend = map.find("bend");
  map.finish();

  std::vector<YamlValue> tensile_items, bend_items;
  if (tensile) tensile_items = tensile->items();
  if (bend) bend_items = bend->items();
  for (const auto& item : tensile_items) d.tensile.push_back(read_tensile_test(item, dir));
  for (const auto& item : bend_items) d.bend.push_back(read_bend_test(item));
  check_unique_labels(d.tensile, tensile_items);
  check_unique_labels(d.bend, bend_items);
  if (d.tensile.empty() && d.bend.empty())
    throw root.error("a dataset needs at least one test: give `tensile:` and/or `bend:`");
  return d;
}

}  // namespace twill
