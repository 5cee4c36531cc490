#include "effects/strip_path.hpp"

#include <cmath>

#include "core/input_error.hpp"

namespace twill {
namespace {

constexpr double kSecondsPerMinute = 60.0;

// The clock at the path points (0, then each entry), per the header.
std::vector<double> path_clock(const RunConditions& run, const std::string& effect) {
  const std::vector<double>& x = run.schedule;
  std::vector<double> t(x.size() + 1, 0.0);
  const double speed_mm_s = run.rate_mm_min / kSecondsPerMinute;
  if (run.time_s.size() == x.size() && !x.empty()) {
    double first_speed = speed_mm_s;
    if (!(first_speed > 0) && x.size() >= 2 && run.time_s[1] > run.time_s[0])
      first_speed = std::abs(x[1] - x[0]) / (run.time_s[1] - run.time_s[0]);
    if (!(first_speed > 0))
      throw InputError({"", 0, "rate_mm_min"}, effect + ": the run's first rows do not give the crosshead speed");
    const double start = run.time_s[0] - std::abs(x[0]) / first_speed;
    for (size_t i = 0; i < x.size(); ++i) t[i + 1] = run.time_s[i] - start;
    return t;
  }
  if (!(speed_mm_s > 0))
    throw InputError({"", 0, "rate_mm_min"},
                     effect + " needs the run's clock: rate_mm_min in fabric.yaml or a time_s column "
                              "(twill simulate: --rate-mm-min)");
  double previous = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    t[i + 1] = t[i] + std::abs(x[i] - previous) / speed_mm_s;
    previous = x[i];
  }
  return t;
}

}  // namespace

bool is_pulled_strip(const RunConditions& run) {
  return run.observable == "force_N" && run.schedule_quantity == "extension_mm" && run.gauge_length_mm > 0 &&
         run.width_mm > 0;
}

StripPath strip_path(const RunConditions& run, const std::string& effect, bool with_clock) {
  if (!is_pulled_strip(run))
    throw InputError({"", 0, "effects." + effect},
                     effect + " acts on tensile strips pulled by extensions, not on '" + run.observable + "' per '" +
                         run.schedule_quantity + "'");
  StripPath path;
  path.width_m = 1e-3 * run.width_mm;
  path.strain.push_back(0.0);
  for (double x : run.schedule) path.strain.push_back(x / run.gauge_length_mm);
  if (with_clock) path.time_s = path_clock(run, effect);
  return path;
}

}  // namespace twill
