// Metrics of a fit report for the study database (study/run_metrics.hpp).
#include "study/run_metrics.hpp"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "core/material_law.hpp"
#include "fitting/discovery.hpp"

namespace twill {
namespace {

using json = nlohmann::json;
using Metrics = std::vector<std::pair<std::string, double>>;

// Mean avg_rel_error of `curves`, overall (`name`) and per label (`name.<label>`).
void curve_errors(const json& curves, const std::string& name, Metrics* out) {
  std::map<std::string, std::pair<double, int>> by_label;
  double sum = 0;
  for (const json& c : curves) {
    const double e = c.at("avg_rel_error").get<double>();
    auto& [label_sum, count] = by_label[c.at("label").get<std::string>()];
    label_sum += e;
    ++count;
    sum += e;
  }
  if (curves.empty()) return;
  out->emplace_back(name, sum / static_cast<double>(curves.size()));
  for (const auto& [label, s] : by_label) out->emplace_back(name + "." + label, s.first / s.second);
}

// The strains at which each fitted curve's slope η'(x) is recorded: within every example's
// data (warp and weft cutoffs 0.12–0.15, shear 0.33), from the small-strain end to the knee.
constexpr double kCurveStrains[] = {0.02, 0.05, 0.1};

void parameter_metrics(const json& p, Metrics* out) {
  for (const char* key : {"a11_Pa", "a12_Pa", "a22_Pa", "G12_Pa", "thickness_m", "density_kg_m2"})
    out->emplace_back(std::string("param.") + key, p.at(key).get<double>());
  for (const auto& [key, value] : p.at("membrane_N_per_m").items())
    out->emplace_back("param." + key + "_N_m", value.get<double>());
  for (const char* term : {"eta1", "eta3", "eta4"})
    for (const char* part : {"mu", "alpha"}) {
      const json& values = p.at(term).at(part);
      for (size_t i = 0; i < values.size(); ++i)
        out->emplace_back("param." + std::string(term) + "." + part + "[" + std::to_string(i) + "]",
                          values[i].get<double>());
    }
  for (const char* term : {"eta1", "eta3", "eta4"}) {
    const Curve curve{p.at(term).at("mu").get<std::vector<double>>(), p.at(term).at("alpha").get<std::vector<double>>()};
    for (const double x : kCurveStrains)
      out->emplace_back(fmt::format("curve.{}.slope@{:g}", term, x), evaluate_curve(curve, x).d1);
  }
}

// The degree each curve stage's curve ended at: report.json's `curve_degrees`; in reports
// written before it, the degree of the fit table's curves of the stage's label (the fit table
// names tests, which the paper's protocols label as their stages).
json kept_degrees(const json& report) {
  if (report.contains("curve_degrees")) return report.at("curve_degrees");
  json kept = json::object();
  for (const json& c : report.at("fit"))
    if (c.contains("degree") && c.at("degree").is_number()) kept[c.at("label").get<std::string>()] = c.at("degree");
  return kept;
}

// Per stage: its error and degree at the end — the last optimiser run at the degree its curve
// ended at (the degree search's last try may be a raise it did not keep), else its last run.
// Over all optimiser runs of the fit (one per stage, level and degree tried): counts, and how
// many ended other than converged (stalled, an iteration or evaluation limit, a failed line
// search).
void stage_metrics(const json& report, Metrics* out) {
  const json kept = kept_degrees(report);
  std::map<std::string, const json*> last, last_kept;
  double iterations = 0, evaluations = 0, solves = 0, not_converged = 0;
  for (const json& s : report.at("stages")) {
    const std::string stage = s.at("stage").get<std::string>();
    last[stage] = &s;
    if (kept.contains(stage) && s.value("degree", json()) == kept.at(stage)) last_kept[stage] = &s;
    if (s.value("status", "converged") != "converged") ++not_converged;
    iterations += s.at("iterations").get<double>();
    evaluations += s.at("evaluations").get<double>();
    solves += s.at("equilibrium_solves").get<double>();
  }
  for (auto [stage, s] : last) {
    if (last_kept.count(stage)) s = last_kept.at(stage);
    out->emplace_back("error.stage." + stage, s->at("avg_rel_error").get<double>());
    if (s->contains("degree") && s->at("degree").is_number())
      out->emplace_back("degree.stage." + stage, s->at("degree").get<double>());
  }
  out->emplace_back("count.optimizer_runs", static_cast<double>(report.at("stages").size()));
  out->emplace_back("count.optimizer_runs_not_converged", not_converged);
  out->emplace_back("count.iterations", iterations);
  out->emplace_back("count.evaluations", evaluations);
  out->emplace_back("count.equilibrium_solves", solves);
}

void effect_metrics(const json& effects, Metrics* out) {
  for (const json& e : effects) {
    const std::string name = "effect." + e.at("effect").get<std::string>();
    out->emplace_back(name + ".error_without", e.at("error_without").get<double>());
    out->emplace_back(name + ".error_with", e.at("error_with").get<double>());
    // The score test where it was evaluated (null otherwise); reports before the calibration
    // lack its p-value.
    if (!e.at("score").is_null()) {
      out->emplace_back(name + ".score", e.at("score").get<double>());
      out->emplace_back(name + ".score_p_value_iid", e.at("score_p_value_iid").get<double>());
      if (e.contains("score_p_value")) out->emplace_back(name + ".score_p_value", e.at("score_p_value").get<double>());
    }
    for (const json& p : e.at("parameters"))
      out->emplace_back("param." + p.at("name").get<std::string>(), p.at("value").get<double>());
  }
}

// Per validation test and strain component: the largest strain over the strip and the share
// of its area beyond the fitted cutoff (docs/fitting.md §7). Reports before it lack the key.
void strain_range_metrics(const json& report, Metrics* out) {
  if (!report.contains("validation_strain_range")) return;
  for (const json& r : report.at("validation_strain_range"))
    for (const auto& [component, largest] : r.at("largest").items()) {
      const std::string name = "strain.validation." + r.at("label").get<std::string>() + "." + component;
      out->emplace_back(name + ".largest", largest.get<double>());
      out->emplace_back(name + ".share_beyond_cutoff", r.at("share_of_area_beyond_cutoff").at(component).get<double>());
    }
}

}  // namespace

std::vector<std::pair<std::string, double>> fit_metrics(const nlohmann::json& report) {
  Metrics out;
  curve_errors(report.at("fit"), "error.fit", &out);
  curve_errors(report.at("validation"), "error.validation", &out);
  stage_metrics(report, &out);
  parameter_metrics(report.at("parameters"), &out);
  for (const json& b : report.at("bend"))
    if (b.at("chord_angle_deg").is_number())
      out.emplace_back("drape." + b.at("label").get<std::string>() + "_deg", b.at("chord_angle_deg").get<double>());
  effect_metrics(report.at("effects"), &out);
  strain_range_metrics(report, &out);
  for (const auto& [key, seconds] : report.at("timing_s").items()) out.emplace_back("time." + key, seconds.get<double>());
  return out;
}

std::vector<std::pair<std::string, double>> discover_metrics(const nlohmann::json& result) {
  Metrics out;
  const std::string verdict = result.at("verdict").get<std::string>();
  for (const std::string& v : discover_verdict_kinds()) out.emplace_back("verdict." + v, verdict.rfind(v, 0) == 0 ? 1.0 : 0.0);
  out.emplace_back("count.named", static_cast<double>(result.at("named").size()));
  for (const json& c : result.at("candidates")) {
    const std::string name = "candidate." + c.at("name").get<std::string>();
    for (const std::string& s : discover_statuses()) out.emplace_back(name + "." + s, c.at("status") == s ? 1.0 : 0.0);
    if (c.contains("p_value") && !c.at("p_value").is_null()) out.emplace_back(name + ".p_value", c.at("p_value").get<double>());
  }
  for (const auto& [test, g] : result.at("gap").items())
    for (const char* k : {"before", "after", "floor"})
      if (!g.at(k).is_null()) out.emplace_back("gap." + test + "." + k, g.at(k).get<double>());
  out.emplace_back("time.total", result.at("time_s").get<double>());
  return out;
}

std::vector<std::pair<std::string, double>> simulate_metrics(const nlohmann::json& result) {
  Metrics out;
  if (result.contains("reference")) {
    out.emplace_back("error.reference", result.at("reference").at("avg_rel_error").get<double>());
    const double worst = result.at("reference").at("worst_rel_error").get<double>();  // signed
    out.emplace_back("error.reference.worst", std::abs(worst));
    out.emplace_back("error.reference.worst_signed", worst);
  }
  const json& points = result.at("points");
  if (!points.empty())
    out.emplace_back("value.last", points.back().at(result.at("observable").get<std::string>()).get<double>());
  out.emplace_back("count.points", static_cast<double>(points.size()));
  out.emplace_back("count.newton_iterations", result.at("newton_iterations").get<double>());
  out.emplace_back("time.total", result.at("wall_time_s").get<double>());
  return out;
}

}  // namespace twill
