#pragma once
// Parameter files (params.yaml): the contract of docs/dataset-format.md, "Parameter file".
//
//   model: clyde2017
//   density_kg_m2: 0.294            # areal mass ρ_A [kg/m²]
//   thickness_m: 0.00053            # τ [m]
//   a11_Pa: 1.2e8                   # small-strain stiffnesses [Pa] (paper Eq. 2)
//   a12_Pa: 4.0e7
//   a22_Pa: 0.8e8
//   G12_Pa: 2.0e6
//   eta1: {mu: [1.3, -0.3], alpha: [2.0, 8.0]}   # curves η1, η3, η4 (paper §3.1)
//   eta3: {mu: [1.0], alpha: [3.0]}
//   eta4: {mu: [1.0], alpha: [1.5]}
//   eta2: {mu: [1.0], alpha: [4.0]}               # optional: the coupling curve, absent: η2(x) = x
//   cutoffs: {E11_min: 0.0, E11_max: 0.12, E22_min: 0.0, E22_max: 0.18, E12_max: 0.35}
//
//   effects: {misalignment: {spread_deg: 1.5}}   # optional: the model's effects
//
// Every key above is required except `eta2` (absent: the paper's η2(x) = x, §5.2; written only
// when it is not), `cutoffs.E11_min` and `cutoffs.E22_min` (default 0: compression is
// extrapolated from zero strain, model.md §4) and `effects`. A cutoff is a
// number or `null` (off). There is no `E12_min`: the shear box is symmetric. Any other key is
// an error. `effects` maps a registered effect's name (core/registry.hpp, category "effect")
// to its parameters, resolved strictly against the effect's schema (unknown effect or
// parameter, wrong type, out of bounds: an InputError naming file, line and key; a parameter
// left out takes the effect's default); absent or empty: the paper's model. Reading a file
// with effects needs the registry (the readers' `registry` argument).
//
// The law-side bending ratios of the flat vector (parameters.hpp: bending.warp_ratio,
// bending.weft_ratio) are not keys of the file: they read as 1 and are not written. The
// bending-anisotropy effect carries their values under `effects:` and its law hook sets them
// (docs/effects/bending-anisotropy.md), so a file never loses them; a material whose ratios
// were set in code (e.g. law_adjusted(), effects/effect_experiment.hpp) is written without them.
//
// Constraints checked on reading and by validate_parameters() (each an InputError naming file,
// line and key):
// - density_kg_m2, thickness_m, a11_Pa, a22_Pa, G12_Pa > 0 (and the bending ratios > 0);
// - a12_Pa ≥ 0 and a12² < a11·a22: the small-strain stiffness [[a11, a12], [a12, a22]] must be
//   positive definite (a12 = 0, no coupling, is allowed; the paper's a12 = ½ min(a11, a22)
//   always satisfies both);
// - each curve: mu and alpha non-empty and of equal length (the degree); every α ≠ 0 (the
//   law has the α → 0 limit μ log(1+x), but a file with α = 0 is far more likely a typo);
//   Σμ = 1 (η'(0) = 1, paper §3.1) within |Σμ − 1| ≤ 1e-9 · Σ|μ| — relative to Σ|μ| because
//   that is the size of the rounding error of the sum when weights of both signs cancel;
// - cutoffs: min ≤ 0 < max for warp and weft, E12_max > 0, when set: the box must contain the
//   rest state Ẽ = 0, otherwise the extrapolated law would not be stress-free at rest.
//
// Writing uses the shortest decimal text that reads back to the same double (std::to_chars),
// so write → read is bit-exact.
#include <string>

#include "core/parameters.hpp"
#include "core/yaml_reader.hpp"

namespace twill {

/// The model name that parameter files of this law carry in `model:`.
inline constexpr const char* kClyde2017ModelName = "clyde2017";

/// Reads and validates a params.yaml file. Throws InputError (file, line, key) on bad input.
MaterialParameters read_params_file(const std::string& path, const Registry* registry = nullptr);

/// Reads and validates a parameter block that is part of a larger YAML document (e.g. the
/// `params:` block of data/examples/truth/<name>.yaml). Errors name value.file() and key
/// paths below value.path().
MaterialParameters read_params(const YamlValue& value, const Registry* registry = nullptr);

/// Checks the constraints listed above on parameters built in code. Throws InputError with
/// `source` as the file name (line 0) and the offending key, e.g. `eta3.alpha[1]`.
void validate_parameters(const MaterialParameters& parameters, const std::string& source);

/// params.yaml text for `parameters` (flow-style curves, cutoffs and effects, as in the
/// contract; no `effects:` key for the paper's model).
/// Invalid parameters are written as they are (useful for diagnosing a failed fit) but will
/// then be rejected when read back.
std::string params_to_yaml(const MaterialParameters& parameters);

/// Writes params_to_yaml() to `path`; throws std::runtime_error if the file cannot be written.
void write_params_file(const MaterialParameters& parameters, const std::string& path);

}  // namespace twill
