#pragma once
// The config of `twill simulate -c FILE` and of a study's `command: simulate` runs
// (docs/studies.md §7): one registered experiment simulated from a params.yaml, optionally
// against a reference curve.
//
//   experiment: {name: tensile, cells_across: 16, cells_along: 24}  # geometry and resolution
//   discretization: {name: catmull-clark-kl, fibre_strain: face-mean}
//   angle_deg: 45                  # strip axis vs weft (model.md §7)
//   schedule: [0.5, 1, 2]          # clamp extensions (tensile) or overhangs (bend) [mm]
//   reference: ../shared/data/reference/poplin/tensile-bias.csv
//   rate_mm_min: 0                 # crosshead speed, the clock of rate effects (0: not known)
//
// A reference is a tensile run CSV (docs/dataset-format.md): without a schedule its
// extensions are the schedule, and the run's result holds its errors against the forces
// (experiments/reference_errors.hpp).
#include <string>
#include <vector>

#include "core/config.hpp"
#include "core/input_error.hpp"
#include "core/registry.hpp"

namespace twill {

OptionSchema simulate_config_schema();

/// A reference curve: the schedule [mm] and the forces [N] (read_tensile_run_csv's checks).
struct ReferenceCurve {
  std::vector<double> schedule, values;
};
ReferenceCurve read_reference_curve(const std::string& path);

/// The schedule a config gives: `schedule`, else the reference's; InputError (at `schedule`,
/// located by `locate`) when neither, or when both and they differ in length.
std::vector<double> simulate_schedule(const Options& config, const ConfigKeyLocator& locate);

/// Checks that need files: the params file reads under the registry's effects, the reference
/// reads, a schedule exists. InputError located by `locate` (or the params file itself).
void check_simulate_config(const Options& config, const std::string& params_path, const Registry& registry,
                           const ConfigKeyLocator& locate);

}  // namespace twill
