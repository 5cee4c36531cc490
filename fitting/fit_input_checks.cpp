#include "fitting/fit_input_checks.hpp"

#include <cmath>

#include "core/input_limits.hpp"
#include "core/yaml_reader.hpp"

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
  const Options& res = config.get_section("resolution");
  // In doubles: an absurd coarse_cells_across (up to 2^63) shifted by the levels must not wrap.
  const double levels = static_cast<double>(res.get_int("levels"));
  const double across = static_cast<double>(res.get_int("coarse_cells_across")) * std::exp2(levels - 1);
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
