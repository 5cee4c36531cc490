#pragma once
// Checks of a fit's inputs that need the dataset and the config together, run by `twill fit`
// before any work (issue #13): every strip the protocol will simulate must fit the memory
// limit of core/input_limits.hpp. The config schema bounds each key alone; only here are the
// finest level's cells (coarse_cells_across · 2^(levels−1) across, × gauge/width along, as
// the protocol's resolution ladder builds them) known; the cantilever's cells are the bend
// stage's own check (fitting/stages/bend.cpp, run by check_fit_protocol).
#include <functional>
#include <string>

#include "core/config.hpp"
#include "core/dataset.hpp"
#include "core/input_error.hpp"

namespace twill {

/// Throws InputError (located by `locate` at the responsible key) when a simulated strip of
/// the fit would exceed the memory limit; the message says what it would need and the limit.
void check_fit_sizes(const Dataset& dataset, const Options& config, const ConfigKeyLocator& locate);

}  // namespace twill
