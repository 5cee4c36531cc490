#pragma once
// What the parts of `twill discover` share (docs/discovery.md): discovery.cpp runs the workflow
// (baseline, candidates, held-out checks, refits), discovery_judge.cpp holds the decision rule
// and the noise floors, discovery_folds.cpp the held-out folds, discovery_report.cpp writes
// discover.json and discover.md. Not part of twill's interface (that is discovery.hpp).
#include <map>
#include <string>
#include <vector>

#include "core/registry.hpp"
#include "fitting/discovery.hpp"

namespace twill::discover_detail {

inline constexpr const char* kSection = "discover";
// A candidate's statuses (discover_statuses()); "named" and "tied" are verdict kinds too.
inline constexpr const char* kNamed = "named";
inline constexpr const char* kRejected = "rejected";
inline constexpr const char* kUntestable = "untestable";
inline constexpr const char* kTied = "tied";
inline constexpr const char* kFailed = "failed";
inline constexpr const char* kNone = "none";
inline constexpr const char* kUnexplained = "unexplained";
inline constexpr const char* kEffectFitStage = "effect-fit";
inline constexpr const char* kTensileCurveStage = "tensile-curve";
inline constexpr const char* kFinalCurvesStage = "final-curves";
inline constexpr const char* kStrainCutoffStage = "strain-cutoff";
inline constexpr const char* kBendStage = "bend";
inline constexpr const char* kInitialGuessStage = "initial-guess";
// curve-degree raises each curve while a raise lowers its error by at least this fraction: the
// error has stopped falling below it (the protocol's own search stops at 20 %, or at its target).
inline constexpr double kRicherCurveMinImprovement = 0.1;

/// The registered effect `name` at its neutral values (its schema defaults: the paper's model).
ComponentChoice neutral_effect(const std::string& name, const Registry& registry);
/// `names` as a YAML flow list ("[a, b]").
std::string yaml_list(const std::vector<std::string>& names);
/// The fit config with `effects` (each at its schema defaults: the neutral values).
Options with_effects(const Options& fit_config, const std::vector<std::string>& effects, const Registry& registry);
/// Each test's noise floor: the smallest of the candidates' that measured one.
std::map<std::string, double> floors_by_test(const std::vector<DiscoverCandidate>& candidates);
/// The record of effect `name` among `records`, nullptr when there is none.
const FitEffect* record_of(const std::vector<FitEffect>& records, const std::string& name);
/// The candidate called `name`, end() when there is none.
std::vector<DiscoverCandidate>::iterator find_candidate(DiscoverResult* result, const std::string& name);
/// The names of the candidates with `status`, in the candidates' order.
std::vector<std::string> with_status(const DiscoverResult& result, const std::string& status);
/// The fit runs' errors of a fit's final curves (report.fit), per test and overall, as an
/// effect-fit record's error_with (discovery_judge.cpp).
FitEffect fit_runs_error(const FitReport& report);
/// The gap per test (discovery_judge.cpp).
void measure_gap(const DiscoverResult& result, const std::map<std::string, double>& floors,
                 std::vector<DiscoverGap>* gap, std::string* rows, std::vector<FitEffectCurve>* curves);
/// Whether the protocol's effect-fit stage of `effect` fits the bend tests' chord angles.
bool fits_chord_angles(const Options& fit, const std::string& effect);

}  // namespace twill::discover_detail
