#include "core/input_limits.hpp"

#include <fmt/format.h>

#include <cmath>

#include "core/yaml_reader.hpp"

namespace twill {
namespace limits {

const PhysicalRange kArealDensity{"an areal density", "g/m²", 0.0, 5000.0, true,
                                  "fabrics weigh ~10 to ~2000 g/m²"};
const PhysicalRange kThickness{"a fabric thickness", "mm", 0.0, 20.0, true,
                               "fabrics are 0.05 to ~10 mm thick; a thin shell model needs far less than the width"};
const PhysicalRange kStripWidth{"a strip width", "mm", 0.0, 1000.0, true,
                                "strip tests use 25 to 200 mm wide strips"};
const PhysicalRange kStripLength{"a strip length", "mm", 0.0, 5000.0, true,
                                 "tensile frames and cantilever tables are shorter than 5 m"};
const PhysicalRange kAngle{"an angle vs the weft", "deg", -180.0, 180.0, false,
                           "0 weft, 90 warp, 45 bias"};
const PhysicalRange kCrossheadRate{"a crosshead rate", "mm/min", 0.0, 1e5, true,
                                   "ASTM D5035 uses 300 mm/min"};
const PhysicalRange kForceMagnitude{"a force", "N", -1e6, 1e6, false,
                                    "fabric strips break far below 1e5 N; check the column's unit"};
const PhysicalRange kEngineeringStrain{"an engineering strain (extension / gauge length)", "", -1.0, 10.0, false,
                                       "fabrics break below 600 % strain; -1 is the clamps touching"};

}  // namespace limits

std::string range_violation(double value, const PhysicalRange& r) {
  const bool low_ok = r.lo_exclusive ? value > r.lo : value >= r.lo;
  if (std::isfinite(value) && low_ok && value <= r.hi) return {};
  const std::string unit = *r.unit ? std::string(" ") + r.unit : std::string();
  return fmt::format("{} must be in {}{}, {}]{} ({}), got {}{}", r.quantity, r.lo_exclusive ? "(" : "[",
                     format_double(r.lo), format_double(r.hi), unit, r.why, format_double(value), unit);
}

double estimated_mesh_bytes(double cells_across, double cells_along) {
  return limits::kEstimatedBaseBytes + limits::kEstimatedBytesPerCell * cells_across * cells_along;
}

std::string format_bytes(double bytes) {
  static const char* const units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024 && u < 6) {
    bytes /= 1024;
    ++u;
  }
  return fmt::format("{:.3g} {}", bytes, units[u]);
}

std::string mesh_size_violation(double cells_across, double cells_along) {
  if (!(cells_across >= 1 && cells_along >= 1))
    return fmt::format("a mesh needs at least 1 cell each way, got {}x{}", format_double(cells_across),
                       format_double(cells_along));
  const double bytes = estimated_mesh_bytes(cells_across, cells_along);
  if (bytes <= limits::kMeshMemoryLimitBytes) return {};
  return fmt::format("a {}x{} mesh would need ~{} ({} per cell), the limit is {} per strip (at most {:.0f} cells)",
                     format_double(cells_across), format_double(cells_along), format_bytes(bytes),
                     format_bytes(limits::kEstimatedBytesPerCell), format_bytes(limits::kMeshMemoryLimitBytes),
                     std::floor((limits::kMeshMemoryLimitBytes - limits::kEstimatedBaseBytes) /
                                limits::kEstimatedBytesPerCell));
}

}  // namespace twill
