#include "effects/misalignment.hpp"

#include <cmath>
#include <stdexcept>

namespace twill {

OptionBindings<MisalignmentOptions> misalignment_bindings() {
  return {real_option<MisalignmentOptions>("spread_deg", &MisalignmentOptions::spread_deg,
                                           "RMS of the strips' cutting-angle offsets (offsets ~ N(0, spread²))",
                                           in_range(0.0, Misalignment::kMaxOffsetDeg))};
}

bool MisalignmentOptions::validate(std::string* error) const {
  return check_options(misalignment_bindings(), *this, error);
}

Misalignment::Misalignment(const MisalignmentOptions& options) : spread_deg_(options.spread_deg) {
  require_valid(options, kName);
}

std::string Misalignment::missing_data(const Dataset& dataset) const {
  for (const TensileTest& test : dataset.tensile)
    if (test.runs.size() >= 2) return "";
  return "needs repeats per angle: at least two runs of some tensile test";
}

std::vector<EffectParameter> Misalignment::per_run_parameters() const {
  EffectParameter offset;
  offset.name = std::string(kName) + ".offset_deg";
  offset.unit = unit_of("offset_deg");
  offset.doc = "the run's strip angle minus its nominal angle";
  offset.lower = -kMaxOffsetDeg;
  offset.upper = kMaxOffsetDeg;
  return {offset};
}

Options Misalignment::estimated_from_runs(const std::vector<Eigen::VectorXd>& run_values, const Options& model) const {
  Options out = model;
  if (run_values.empty()) return out;
  double sum_squares = 0;
  for (const Eigen::VectorXd& v : run_values) sum_squares += v[0] * v[0];
  out.set("spread_deg", std::sqrt(sum_squares / static_cast<double>(run_values.size())));  // ≤ kMaxOffsetDeg: offsets are bounded
  return out;
}

std::vector<SetupChange> Misalignment::adjust_setup(const Eigen::VectorXd& run_values, ExperimentInput* input) const {
  if (run_values.size() != 1) throw std::invalid_argument("misalignment: one per-run value (offset_deg) expected");
  input->angle_deg += run_values[0];
  return {SetupChange{setup_quantity::kAngle, Eigen::VectorXd::Ones(1)}};
}

}  // namespace twill
