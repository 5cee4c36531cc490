// What `twill discover` writes (docs/discovery.md §3): discover.json, discover.md, the configs,
// the reports of the baseline and the refit, and params.yaml.
#include "fitting/discovery_detail.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "core/params_io.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_effects.hpp"

namespace twill {

using namespace discover_detail;

namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

}  // namespace

namespace {

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// Parameter i's interval: its range over the fit on every specimen and the fits on each fold
// (the specimen resamples; docs/discovery.md §2); none without folds.
std::optional<std::pair<double, double>> fold_interval(const DiscoverCandidate& c, size_t i) {
  if (c.held_out.folds.empty()) return std::nullopt;
  double lo = c.effect->parameters[i].value, hi = lo;
  for (const auto& fold : c.held_out.folds)
    if (i < fold.size()) {
      lo = std::min(lo, fold[i].value);
      hi = std::max(hi, fold[i].value);
    }
  return std::make_pair(lo, hi);
}

// A held-out check: what was held out, the errors without and with (overall and per held-out
// test), or why it failed or was not run; nothing when it was not asked for.
std::optional<json> held_out_json(const DiscoverHeldOut& h) {
  if (h.evaluated) {
    json tests = json::array();
    for (const FitEffectTest& t : h.tests)
      tests.push_back({{"test", t.test}, {"runs", t.runs}, {"error_without", t.error_without}, {"error_with", t.error_with}});
    return json{{"held", h.held}, {"error_without", h.without}, {"error_with", h.with}, {"tests", tests}};
  }
  if (!h.failure.empty()) return json{{"failed", h.failure}};
  if (!h.note.empty()) return json{{"not_evaluated", h.note}};
  return std::nullopt;
}

json candidate_json(const DiscoverCandidate& c) {
  json j = {{"name", c.name}, {"status", c.status}, {"reason", c.reason}};
  if (!c.effect) return j;
  const FitEffect& e = *c.effect;
  j["score"] = number(e.score);
  j["dof"] = e.score_dof;
  j["p_value"] = std::isfinite(e.score) ? json(e.score_p_value) : json(nullptr);
  j["p_value_iid"] = std::isfinite(e.score) ? json(e.score_p_value_iid) : json(nullptr);
  j["noise_correlation"] = std::isfinite(e.score) ? json(e.score_noise_correlation) : json(nullptr);
  j["error_without"] = e.error_without;
  j["error_with"] = e.error_with;
  j["resolution"] = e.resolution;
  j["tests"] = json::array();  // what the judge weighed, test by test (excess_over_floors)
  for (const FitEffectTest& t : e.tests)
    j["tests"].push_back({{"test", t.test}, {"runs", t.runs}, {"error_without", t.error_without},
                          {"error_with", t.error_with}, {"noise_floor", number(t.noise_floor)},
                          {"error_beyond_known", number(t.error_beyond_known)}, {"score_share", number(t.score_share)}});
  if (const auto held = held_out_json(c.held_out)) j["held_out"] = *held;
  if (const auto held = held_out_json(c.separating)) j["separating_check"] = *held;
  j["parameters"] = json::array();
  for (size_t i = 0; i < e.parameters.size(); ++i) {
    const FitEffectParameter& p = e.parameters[i];
    json q = {{"name", p.name}, {"value", p.value}, {"unit", p.unit}, {"neutral", p.neutral}, {"lower", p.lower},
              {"upper", p.upper}};
    if (const auto interval = fold_interval(c, i)) {
      json folds = json::array();
      for (const auto& fold : c.held_out.folds)
        if (i < fold.size()) folds.push_back(fold[i].value);
      q["folds"] = folds;
      q["interval"] = {interval->first, interval->second};
    }
    j["parameters"].push_back(q);
  }
  return j;
}

// The steps' times in order, as [step, seconds] pairs (a step name can repeat across runs of
// the same check, never within one discover).
json step_times_json(const std::vector<std::pair<std::string, double>>& steps) {
  json j = json::array();
  for (const auto& [step, seconds] : steps) j.push_back({step, seconds});
  return j;
}

// The load cell's noise the repeats show (null when not fitted): sd(y) = level · ((1 − w)|y| + w M).
json noise_json(const std::optional<RepeatNoise>& noise) {
  if (!noise) return nullptr;
  return {{"level", noise->level}, {"absolute_weight", noise->profile.absolute_weight},
          {"median_N", noise->profile.median}, {"correlation", noise->correlation}, {"runs", noise->runs},
          {"rows", noise->rows}};
}

json discover_json(const DiscoverResult& r, const Options& config) {
  json gap = json::object();
  for (const DiscoverGap& g : r.gap)
    gap[g.test] = {{"before", g.before}, {"after", g.after}, {"floor", number(g.floor)},
                   {"repeat_floor", number(g.repeat_floor)}, {"resolution_error", number(g.resolution_error)},
                   {"noise_floor", number(g.noise_floor)}, {"misfit_p", number(g.misfit_p)},
                   {"before_beyond_known", number(g.before_beyond_known)}};
  json candidates = json::array();
  for (const DiscoverCandidate& c : r.candidates) candidates.push_back(candidate_json(c));
  return {{"dataset", r.baseline.dataset},
          {"verdict", r.verdict},
          {"named", r.named},
          {"gap", gap},
          {"gap_rows", r.gap_rows},
          {"curves", effect_curves_json(r.curves)},
          {"candidates", candidates},
          {"repeat_noise", noise_json(r.noise)},
          {"alpha", config.get_section(kSection).get_double("alpha")},
          {"baseline_resolution", r.baseline.finest_resolution},
          {"screening_resolution", r.screening_resolution},
          {"refit_resolution", r.refit ? json(r.refit->effects.empty() ? "" : r.refit->effects.front().resolution) : json(nullptr)},
          {"notes", r.notes},
          {"time_s", r.time_s},
          {"step_times_s", step_times_json(r.step_times)}};
}

std::string cell(double v) { return std::isfinite(v) ? fmt::format("{:.2f} %", 100 * v) : "—"; }

std::string discover_markdown(const DiscoverResult& r) {
  std::ostringstream md;
  md << "# twill discover: " << r.baseline.dataset << "\n\n**Verdict: " << r.verdict << "**"
     << (r.named.empty() ? "" : " — named: " + yaml_list(r.named)) << "\n\n";
  md << "Baseline: the protocol without effects, every repeat with its specimen scale, finest resolution "
     << r.baseline.finest_resolution << " (docs/discovery.md). Candidates and held-out folds screened at "
     << r.screening_resolution;
  if (r.refit && !r.refit->effects.empty()) md << "; named effects refitted at " << r.refit->effects.front().resolution;
  md << ". Took " << fmt::format("{:.0f} s", r.time_s);
  std::string steps;
  for (const auto& [step, seconds] : r.step_times) steps += fmt::format("{}{} {:.0f} s", steps.empty() ? "" : "; ", step, seconds);
  md << (steps.empty() ? "" : " (" + steps + ")") << ".\n\n";
  md << "## Gap per test\n\nAverage relative error (model.md §8) on " << r.gap_rows
     << ": the paper's model (before), with the named effects (after), and the noise floor (the mean |residual| "
        "neither the baseline nor an effect explains, at its neutral values or fitted; docs/discovery.md §2) beside the "
        "repeats' own scatter about their mean curve (no model) and, when nothing is named, the baseline's resolution "
        "error (its strip one level finer), the error the repeats' pooled noise makes a perfect model miss by (noise "
        "floor) and the p-value of `before` against it (§2, \"The noise floor from the repeats\"); a lateral strain's "
        "`before` also with the mesh's and a 1° cut's patterns fitted out, in brackets (what `unexplained` judges "
        "there, §1).\n\n"
        "| test | before | after | floor | repeats' scatter | resolution error | noise floor | p (misfit) |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const DiscoverGap& g : r.gap)
    md << "| " << g.test << " | " << cell(g.before)
       << (std::isfinite(g.before_beyond_known) ? " (" + cell(g.before_beyond_known) + ")" : "") << " | " << cell(g.after) << " | " << cell(g.floor) << " | "
       << cell(g.repeat_floor) << " | " << cell(g.resolution_error) << " | " << cell(g.noise_floor) << " | "
       << (std::isfinite(g.misfit_p) ? fmt::format("{:.2g}", g.misfit_p) : "—") << " |\n";
  if (r.noise)
    md << fmt::format("\nThe repeats' noise (load cell, {} runs, {} rows): sd = {:.3g} % × ((1 − {:.2f}) |F| + {:.2f} × "
                      "{:.3g} N), lag-one correlation {:.2f}.\n",
                      r.noise->runs, r.noise->rows, 100 * r.noise->level, r.noise->profile.absolute_weight,
                      r.noise->profile.absolute_weight, r.noise->profile.median, r.noise->correlation);
  md << "\n## Candidates\n\n| effect | status | score T (d) | p (calibrated) | p (iid) | error without → with | why "
        "|\n|---|---|---|---|---|---|---|\n";
  for (const DiscoverCandidate& c : r.candidates) {
    const bool scored = c.effect && std::isfinite(c.effect->score);
    md << fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", c.name, c.status,
                      scored ? fmt::format("{:.4g} ({})", c.effect->score, c.effect->score_dof) : "—",
                      scored ? fmt::format("{:.2g}", c.effect->score_p_value) : "—",
                      scored ? fmt::format("{:.2g}", c.effect->score_p_value_iid) : "—",
                      c.effect ? cell(c.effect->error_without) + " → " + cell(c.effect->error_with) : "—", c.reason);
  }
  md << "\n| effect | parameter | value | neutral | interval over the specimen folds | unit |\n|---|---|---|---|---|---|\n";
  for (const DiscoverCandidate& c : r.candidates)
    if (c.effect)
      for (size_t i = 0; i < c.effect->parameters.size(); ++i) {
        const FitEffectParameter& p = c.effect->parameters[i];
        const auto interval = fold_interval(c, i);
        md << fmt::format("| {} | {} | {:.5g} | {:g} | {} | {} |\n", c.name, p.name, p.value, p.neutral,
                          interval ? fmt::format("{:.5g} … {:.5g}", interval->first, interval->second) : "—", p.unit);
      }
  if (!r.notes.empty()) {
    md << "\n## Notes\n\n";
    for (const std::string& n : r.notes) md << "- " << n << "\n";
  }
  md << "\n![residuals before and after](residuals.png)\n";
  return md.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

const std::vector<std::string>& discover_output_file_names() {
  static const std::vector<std::string> names = {"discover.json",        "discover.md",        "params.yaml",
                                                 "config.yaml",          "baseline-report.json", "refit-report.json",
                                                 "residuals.png"};
  return names;
}

void write_discover_outputs(const DiscoverResult& result, const Options& config, const std::string& dir) {
  const fs::path d(dir);
  fs::create_directories(d);
  write_text(d / "discover.json",
             discover_json(result, config).dump(2, ' ', false, json::error_handler_t::replace) + "\n");
  write_text(d / "discover.md", discover_markdown(result));
  write_params_file(result.refit ? result.refit->parameters : result.baseline.parameters, (d / "params.yaml").string());
  write_config_file(config, (d / "config.yaml").string());
  const Options fit = discover_fit_config(config);
  write_text(d / "baseline-report.json", fit_report_json_text(result.baseline, fit));
  if (result.refit) write_text(d / "refit-report.json", fit_report_json_text(*result.refit, fit));
}

}  // namespace twill
