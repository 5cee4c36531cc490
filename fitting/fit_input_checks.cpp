#include "fitting/fit_input_checks.hpp"

#include <cmath>

#include "core/input_limits.hpp"
#include "core/yaml_reader.hpp"
#include "fitting/fit_config.hpp"

namespace twill {

namespace {

// The cantilever's cells are the bend experiment's options (experiments.bend); checked even
// when the dataset has no bend test: the key is wrong either way.
void check_bend_size(const Options& config, const ConfigKeyLocator& locate) {
  const Options& bend = config.get_section("experiments").get_component("bend").options;
  if (!bend.has("cells_across") || !bend.has("cells_along")) return;  // another kind of bend experiment
  const double across = static_cast<double>(bend.get_int("cells_across"));
  const double along = static_cast<double>(bend.get_int("cells_along"));
  const std::string violation = mesh_size_violation(across, along);
  if (!violation.empty())
    throw InputError(locate(across > along ? "experiments.bend.cells_across" : "experiments.bend.cells_along"),
                     "the cantilever: " + violation);
}

}  // namespace

void check_fit_sizes(const Dataset& dataset, const Options& config, const ConfigKeyLocator& locate) {
  const FitResolution res = read_fit_config(config).resolution;
  // In doubles: a large coarse_cells_across shifted by the levels must not wrap.
  const double levels = res.levels;
  const double across = res.coarse_cells_across * std::exp2(levels - 1);
  for (std::size_t i = 0; i < dataset.tensile.size(); ++i) {
    const TensileTest& t = dataset.tensile[i];
    const double along = std::max(1.0, std::round(across * t.gauge_length_mm / t.width_mm));
    const std::string violation = mesh_size_violation(across, along);
    if (!violation.empty())
      throw InputError(locate("resolution.coarse_cells_across"),
                       "the finest level (" + format_double(levels) + " levels) of tensile[" + std::to_string(i) +
                           "] (" + t.label + ", " + format_double(t.width_mm) + " x " +
                           format_double(t.gauge_length_mm) + " mm): " + violation);
  }
  check_bend_size(config, locate);
}

}  // namespace twill
