#pragma once
// What a study records of each run (study/results_db.hpp `metrics`), read from the run's
// report.json (fitting/fit_report.cpp). Names, for `twill report` and SQL:
//
//   error.fit, error.fit.<label>                 mean average relative error of the final fit
//                                                curves (all, per test label), paper Eq. 3
//   error.validation, error.validation.<label>   the same for the validation strips
//   error.stage.<stage>                          a stage's error at its last (finest) entry
//   param.<name>                                 a11_Pa, a12_Pa, a22_Pa, G12_Pa, thickness_m,
//                                                tau_a11_N_m, tau_a22_N_m, tau_G12_N_m,
//                                                eta1.mu[0], eta1.alpha[0], …, effect parameters
//   curve.<term>.slope@<x>                       η'(x) of a fitted curve (eta1, eta3, eta4) at
//                                                x = 0.02, 0.05, 0.1: the curve as a function,
//                                                which is identifiable where its coefficients
//                                                are not (their order is arbitrary)
//   drape.<label>_deg                            the simulated cantilever chord angle
//   effect.<effect>.error_without, .error_with   the effect-fit stage's contrast
//   time.<timing key>                            per-stage wall times (s), time.total
//   count.iterations, count.evaluations,         optimiser iterations, objective evaluations and
//   count.equilibrium_solves                     equilibrium solves, summed over the stages
//   degree.stage.<stage>                         the degree a curve stage ended at
//   count.optimizer_runs[_not_converged]         optimiser runs (stage × level × degree tried),
//                                                and those that ended other than converged
//   strain.validation.<label>.<E11|E22|E12>.largest, .share_beyond_cutoff
//                                                a validation strip's largest strain and the
//                                                share of its area beyond the fitted cutoff
//                                                (docs/fitting.md §7)
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace twill {

/// The metrics of one `twill fit` report (report.json, parsed).
std::vector<std::pair<std::string, double>> fit_metrics(const nlohmann::json& report);

/// What a study records of a `twill simulate --json` run (study/study_command.hpp):
///   error.reference, error.reference.worst   avg and worst relative error against the
///   error.reference.worst_signed             config's reference (experiments/reference_errors.hpp;
///                                            signed: + where the simulation is stiffer)
///   value.last                               the observable at the last schedule entry
///                                            (force [N], chord angle [deg])
///   count.points, count.newton_iterations    schedule entries that converged; Newton steps
///   time.total                               the simulation's wall time (s)
std::vector<std::pair<std::string, double>> simulate_metrics(const nlohmann::json& result);

/// What a study records of a `twill discover` run (its discover.json; docs/discovery.md), so that
/// `twill report` averages over seeds are rates (papers/discovery):
///   verdict.named, verdict.none, verdict.tied,   1 for the run's verdict, 0 for the others
///   verdict.unexplained
///   count.named                                  effects named
///   candidate.<name>.<status>                    1 where the candidate has that status
///                                                (named, rejected, untestable, tied, failed), else 0
///   candidate.<name>.p_value                     its calibrated score test's (where evaluated)
///   gap.<test>.before|after|floor                the average relative errors of the gap table
///   time.total                                   the run's wall time (s)
std::vector<std::pair<std::string, double>> discover_metrics(const nlohmann::json& result);

}  // namespace twill
