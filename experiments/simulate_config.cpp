// The config of `twill simulate -c` and of a study's simulate runs (experiments/simulate_config.hpp).
#include "experiments/simulate_config.hpp"

#include "core/dataset.hpp"
#include "core/input_limits.hpp"
#include "core/params_io.hpp"
#include "core/yaml_reader.hpp"

namespace twill {

OptionSchema simulate_config_schema() {
  OptionSchema s;
  s.add_component("experiment", registry_category::kExperiment, "tensile",
                  "the registered experiment with its options: geometry, resolution (twill list experiment)");
  s.add_component("discretization", registry_category::kDiscretization, "catmull-clark-kl",
                  "the shell model with its options (twill list discretization)");
  s.add_double("angle_deg", 90, "strip axis vs weft [deg]: 0 weft, 90 warp, 45 bias (model.md §7)")
      .range(limits::kAngle.lo, limits::kAngle.hi);
  s.add_double_list("schedule", {}, "clamp extensions (tensile) or overhangs (bend) [mm], in order; "
                                    "empty: the reference's extensions")
      .at_least(0);
  s.add_string("reference", "", "a tensile run CSV to compare with (its extensions are the default schedule)");
  s.add_double("rate_mm_min", 0, "crosshead speed [mm/min], the clock of rate effects (0: not known)")
      .range(0, limits::kCrossheadRate.hi);
  return s;
}

ReferenceCurve read_reference_curve(const std::string& path) {
  const TensileRun run = read_tensile_run_csv(path);
  return {run.extension_mm, run.force_N};
}

std::vector<double> simulate_schedule(const Options& config, const ConfigKeyLocator& locate) {
  const std::vector<double> schedule = config.get_double_list("schedule");
  const std::string reference = config.get_string("reference");
  if (reference.empty()) {
    if (schedule.empty()) throw InputError(locate("schedule"), "no schedule and no reference to take one from");
    return schedule;
  }
  const ReferenceCurve curve = read_reference_curve(reference);
  if (schedule.empty()) return curve.schedule;
  if (schedule != curve.schedule)
    throw InputError(locate("schedule"), "differs from the reference's extensions (" + reference +
                                             "): give one or the other");
  return schedule;
}

void check_simulate_config(const Options& config, const std::string& params_path, const Registry& registry,
                           const ConfigKeyLocator& locate) {
  read_params_file(params_path, &registry);
  // Experiments scheduled by clamp extensions have a gauge length (tensile, validation,
  // tensile-lateral); the others (bend) by overhangs, which a tensile reference cannot give.
  const Options& experiment = config.get_component("experiment").options;
  const double gauge_mm = experiment.has("gauge_length_mm") ? experiment.get_double("gauge_length_mm") : 0.0;
  const std::string reference = config.get_string("reference");
  if (!reference.empty()) {
    if (!(gauge_mm > 0))
      throw InputError(locate("reference"), "a tensile reference needs an experiment scheduled by extensions, not '" +
                                                config.get_component("experiment").name + "'");
    check_readable_file(reference, locate("reference"));  // read by simulate_schedule below
  }
  if (gauge_mm > 0)  // the same bound as `twill simulate --extensions-mm`
    for (const double e : simulate_schedule(config, locate)) {
      const std::string violation = range_violation(e / gauge_mm, limits::kEngineeringStrain);
      if (!violation.empty())
        throw InputError(locate("schedule"), "extension " + format_double(e) + " mm on a " + format_double(gauge_mm) +
                                                 " mm gauge: " + violation);
    }
  else
    simulate_schedule(config, locate);
}

}  // namespace twill
