// Outputs of `twill fit` (fit_protocol.hpp write_fit_outputs): params.yaml (the contract of
// dataset-format.md), report.json, report.md (paper Tables 3–5 for this dataset), config.yaml
// (the resolved config) and the plots of paper Figs. 2–4 (scripts/plot_fit.py).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "core/params_io.hpp"
#include "fitting/fit_protocol.hpp"

namespace twill {

namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

json options_to_json(const Options& options);

json value_to_json(const OptionValue& v) {
  return std::visit(
      [](const auto& x) -> json {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, Options>) {
          return options_to_json(x);
        } else if constexpr (std::is_same_v<T, ComponentChoice>) {
          json j = options_to_json(x.options);
          j["name"] = x.name;
          return j;
        } else if constexpr (std::is_same_v<T, std::vector<ComponentChoice>>) {
          json list = json::array();
          for (const ComponentChoice& c : x) {
            json j = options_to_json(c.options);
            j["name"] = c.name;
            list.push_back(j);
          }
          return list;
        } else {
          return json(x);
        }
      },
      v);
}

json options_to_json(const Options& options) {
  json j = json::object();
  for (const OptionEntry& e : options.entries()) j[e.key] = value_to_json(e.value);
  return j;
}

json curve_json(const FitCurve& c) {
  return {{"label", c.label},
          {"angle_deg", c.angle_deg},
          {"run", c.run},
          {"role", c.role},
          {"degree", c.degree},
          {"resolution", c.resolution},
          {"delta_theta_deg", c.delta_theta_deg},
          {"specimen_scale", c.specimen_scale},
          {"avg_rel_error", c.avg_rel_error},
          {"avg_rel_error_without_offset", c.avg_rel_error_without_offset},
          {"extension_mm", c.extension_mm},
          {"measured_N", c.measured_N},
          {"simulated_N", c.simulated_N}};
}

constexpr const char* kStrainNames[3] = {"E11", "E22", "E12"};

json strain_range_json(const FitStrainRange& r) {
  json largest, cutoff, share;
  for (int k = 0; k < 3; ++k) {
    largest[kStrainNames[k]] = r.largest[k];
    share[kStrainNames[k]] = r.share_beyond[k];
    cutoff[kStrainNames[k]] = r.cutoff[k] ? json(*r.cutoff[k]) : json(nullptr);  // null: off
  }
  return {{"label", r.label}, {"angle_deg", r.angle_deg}, {"extension_mm", r.extension_mm},
          {"largest", largest}, {"cutoff", cutoff}, {"share_of_area_beyond_cutoff", share}};
}

}  // namespace

json effect_curves_json(const std::vector<FitEffectCurve>& curves) {
  json out = json::array();
  for (const FitEffectCurve& c : curves)
    out.push_back({{"test", c.test}, {"run", c.run}, {"extension_mm", c.extension_mm}, {"measured_N", c.measured_N},
                   {"without_N", c.without_N}, {"with_N", c.with_N}});
  return out;
}

namespace {

json nullable(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }  // json has no NaN

// Parameters as numbers (the YAML file is the contract; this is for tools).
json parameters_json(const MaterialParameters& k) {
  json p;
  p["density_kg_m2"] = k.density_kg_m2;
  p["thickness_m"] = k.thickness_m;
  p["a11_Pa"] = k.a11_Pa;
  p["a12_Pa"] = k.a12_Pa;
  p["a22_Pa"] = k.a22_Pa;
  p["G12_Pa"] = k.G12_Pa;
  for (const auto& [name, c] : {std::pair{"eta1", &k.eta1}, std::pair{"eta3", &k.eta3}, std::pair{"eta4", &k.eta4}})
    p[name] = {{"mu", c->mu}, {"alpha", c->alpha}};
  if (k.eta2 != Curve::linear())  // as params.yaml: absent is the paper's η2(x) = x
    p["eta2"] = {{"mu", k.eta2.mu}, {"alpha", k.eta2.alpha}};
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  p["cutoffs"] = {{"E11_min", opt(k.cutoffs.E11_min)}, {"E11_max", opt(k.cutoffs.E11_max)},
                  {"E22_min", opt(k.cutoffs.E22_min)}, {"E22_max", opt(k.cutoffs.E22_max)},
                  {"E12_max", opt(k.cutoffs.E12_max)}};
  p["membrane_N_per_m"] = {{"tau_a11", k.thickness_m * k.a11_Pa},
                           {"tau_a22", k.thickness_m * k.a22_Pa},
                           {"tau_G12", k.thickness_m * k.G12_Pa}};
  return p;
}

json stage_json(const FitStageRecord& s) {
  return {{"stage", s.stage}, {"resolution", s.resolution}, {"degree", s.degree},
          {"avg_rel_error", s.avg_rel_error}, {"optimizer", s.optimizer},
          {"status", s.status}, {"message", s.message}, {"iterations", s.iterations},
          {"evaluations", s.evaluations}, {"equilibrium_solves", s.equilibrium_solves},
          {"wall_time_s", s.wall_time_s}};
}

json refinement_json(const FitRefinement& f) {
  json changes = json::array();
  for (const auto& c : f.changes)
    changes.push_back({{"name", c.name}, {"from", c.from}, {"to", c.to}, {"relative_change", c.relative}});
  return {{"stage", f.stage}, {"from_resolution", f.from_resolution},
          {"to_resolution", f.to_resolution}, {"response_change", f.response_change},
          {"response_strain", f.response_strain},
          {"decision", f.decision}, {"changes", changes}};
}

json effect_json(const FitEffect& e) {
  json parameters = json::array();
  for (const FitEffectParameter& q : e.parameters)
    parameters.push_back({{"name", q.name}, {"unit", q.unit}, {"value", q.value}, {"lower", q.lower},
                          {"upper", q.upper}});
  json tests = json::array();
  for (const FitEffectTest& t : e.tests)
    tests.push_back({{"test", t.test}, {"runs", t.runs}, {"error_without", t.error_without},
                     {"error_with", t.error_with}, {"noise_floor", nullable(t.noise_floor)},
                     {"error_beyond_known", nullable(t.error_beyond_known)}});
  return {{"effect", e.effect}, {"resolution", e.resolution}, {"runs", e.runs},
          {"points", e.points}, {"error_without", e.error_without},
          {"error_with", e.error_with},
          {"score", nullable(e.score)},  // null where not evaluated
          {"score_dof", e.score_dof}, {"score_p_value_iid", e.score_p_value_iid},
          {"score_p_value", e.score_p_value},
          {"score_noise_correlation", e.score_noise_correlation},
          {"parameters", parameters}, {"tests", tests}, {"curves", effect_curves_json(e.curves)}};
}

// A json array of `to_json(item)` for every item.
template <class Items, class ToJson>
json array_of(const Items& items, ToJson&& to_json) {
  json out = json::array();
  for (const auto& item : items) out.push_back(to_json(item));
  return out;
}

json report_json(const FitReport& r, const Options& config) {
  json j;
  j["dataset"] = r.dataset;
  j["dataset_folder"] = r.folder;
  j["config"] = options_to_json(config);
  j["parameters"] = parameters_json(r.parameters);
  j["initial_guess"] = array_of(r.initial_guess, [](const auto& g) -> json {
    return {{"label", g.label}, {"avg_rel_error_uniform", g.avg_rel_error_uniform},
            {"avg_rel_difference_full", g.avg_rel_difference_full}};
  });
  j["stages"] = array_of(r.stages, stage_json);
  j["curve_degrees"] = json::object();
  for (const auto& [stage, degree] : r.curve_degrees) j["curve_degrees"][stage] = degree;
  j["refinement"] = array_of(r.refinement, refinement_json);
  j["finest_resolution"] = r.finest_resolution;
  j["fit"] = array_of(r.fit, curve_json);
  j["bend"] = array_of(r.bend, [](const auto& b) -> json {
    return {{"label", b.label}, {"angle_deg", b.angle_deg}, {"measured_overhang_mm", b.measured_overhang_mm},
            {"chord_angle_deg", b.chord_angle_deg}, {"overhang_mm", b.overhang_mm}};
  });
  j["validation"] = array_of(r.validation, curve_json);
  j["validation_strain_range"] = array_of(r.validation_strain, strain_range_json);
  j["effects"] = array_of(r.effects, effect_json);
  json timing = json::object();
  for (const auto& [k, v] : r.timing_s) timing[k] = v;
  j["timing_s"] = timing;
  j["notes"] = r.notes;
  return j;
}

// "0.212 (cutoff 0.109: beyond over 31 % of the strip)": a cell per strain component.
std::string strain_range_cell(const FitStrainRange& r, int k) {
  if (!r.cutoff[k]) return fmt::format("{:.3g} (no cutoff)", r.largest[k]);
  return fmt::format("{:.3g} (cutoff {:.3g}{})", r.largest[k], *r.cutoff[k],
                     r.share_beyond[k] > 0 ? fmt::format(": **beyond over {:.1f} %**", 100 * r.share_beyond[k]) : "");
}

std::string strain_range_markdown(const std::vector<FitStrainRange>& ranges) {
  std::ostringstream md;
  md << "\nThe largest strain over each validation strip at its largest extension against the fitted "
        "cutoffs, and the share of the strip's area beyond them (paper §3.2): beyond a cutoff the law is "
        "its quadratic extension, so there the validation tests the extrapolation, not the fit.\n\n"
        "| test | extension | Ẽ11 | Ẽ22 | Ẽ12 |\n"
        "|---|---|---|---|---|\n";
  for (const FitStrainRange& r : ranges)
    md << fmt::format("| {} | {:g} mm | {} | {} | {} |\n", r.label, r.extension_mm,
                      strain_range_cell(r, 0), strain_range_cell(r, 1), strain_range_cell(r, 2));
  return md.str();
}

// The effect-fit stages' results: per effect the error on its runs without and with it, and
// its fitted parameters.
std::string effects_markdown(const std::vector<FitEffect>& effects) {
  std::ostringstream md;
  md << "\n## Effects (docs/effects.md)\n\nPer effect-fit stage: the mean average relative error of its "
        "runs with the effect at its neutral values (the paper's model) and fitted; the score test at the neutral "
        "values before the fit (T, its degrees of freedom d, the p-value if the residuals were iid, and the p-value "
        "calibrated against noise correlated along each run as the residuals are, with φ the runs' mean fitted lag-one "
        "correlation; core/score_test.hpp; — where it was not evaluated: an angle-offset effect, or no residual left "
        "to judge the noise by).\n\n"
        "| effect | resolution | runs | points | error without | error with | score T (d) | p (iid) | p (calibrated, φ) |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
  for (const FitEffect& e : effects)
    md << fmt::format("| {} | {} | {} | {} | {:.2f} % | {:.2f} % | {} | {} | {} |\n", e.effect, e.resolution, e.runs,
                      e.points, 100 * e.error_without, 100 * e.error_with,
                      std::isfinite(e.score) ? fmt::format("{:.4g} ({})", e.score, e.score_dof) : "—",
                      std::isfinite(e.score) ? fmt::format("{:.2g}", e.score_p_value_iid) : "—",
                      std::isfinite(e.score)
                          ? fmt::format("{:.2g} ({:.2f})", e.score_p_value, e.score_noise_correlation)
                          : "—");
  md << "\n| parameter | value | unit | bounds |\n|---|---|---|---|\n";
  for (const FitEffect& e : effects)
    for (const FitEffectParameter& p : e.parameters)
      md << fmt::format("| {} | {:.5g} | {} | [{:g}, {:g}] |\n", p.name, p.value, p.unit, p.lower, p.upper);
  return md.str();
}

// report.md's sections, in order.
std::string fit_table_markdown(const FitReport& r) {
  std::ostringstream md;
  md << "## Fit errors (paper Table 3)\n\nAverage relative error Σ|p̂ − p̆| / Σ|p̆| (model.md §8) at "
        "the resolution shown (where the run's stage ended: a stage the resolution ladder settled is not "
        "simulated finer; final-curves `level: finest` evaluates every run at the finest level)";
  const bool turned = std::any_of(r.fit.begin(), r.fit.end(), [](const FitCurve& c) { return c.delta_theta_deg != 0; });
  const bool scaled = std::any_of(r.fit.begin(), r.fit.end(), [](const FitCurve& c) { return c.specimen_scale != 1; });
  md << (turned ? ", each strip at its angle offset Δθ (misalignment effect-fit)" : "")
     << (scaled ? ", each run's forces times its specimen scale s (repeats.scale: per-run; a test's scales have "
                  "geometric mean 1)"
                : "")
     << ".\n\n| test | angle | run | " << (turned ? "Δθ | " : "") << (scaled ? "s | " : "")
     << "degree | resolution | error |\n|" << std::string(turned ? "---|" : "") << (scaled ? "---|" : "")
     << "---|---|---|---|---|---|\n";
  for (const auto& c : r.fit)
    md << fmt::format("| {} | {:g}° | {} | {}{}{} | {} | {:.2f} % |\n", c.label, c.angle_deg, c.run,
                      turned ? fmt::format("{:+.2f}° | ", c.delta_theta_deg) : "",
                      scaled ? fmt::format("{:.4f} | ", c.specimen_scale) : "", c.degree, c.resolution,
                      100 * c.avg_rel_error);
  return md.str();
}

std::string drape_and_validation_markdown(const FitReport& r) {
  std::ostringstream md;
  md << "\n## Drape (paper Table 4)\n\nChord angle simulated at the measured overhang (41.5° measured), "
        "and the simulated overhang at 41.5°.\n\n| test | angle | measured overhang | chord angle | "
        "overhang at 41.5° |\n|---|---|---|---|---|\n";
  for (const auto& b : r.bend)
    md << fmt::format("| {} | {:g}° | {:.2f} mm | {:.2f}° | {} |\n", b.label, b.angle_deg,
                      b.measured_overhang_mm, b.chord_angle_deg,
                      b.overhang_mm > 0 ? fmt::format("{:.2f} mm", b.overhang_mm) : "—");
  md << "\n## Validation (paper Table 5)\n\nPer validation run: the angle offset Δθ, the error with "
        "it, and without it.\n\n| test | angle | run | Δθ | error | error at Δθ = 0 |\n|---|---|---|---|---|---|\n";
  for (const auto& c : r.validation)
    md << fmt::format("| {} | {:g}° | {} | {:+.2f}° | {:.2f} % | {:.2f} % |\n", c.label, c.angle_deg, c.run,
                      c.delta_theta_deg, 100 * c.avg_rel_error, 100 * c.avg_rel_error_without_offset);
  return md.str();
}

std::string stages_and_ladder_markdown(const FitReport& r) {
  std::ostringstream md;
  md << "\n## Stages\n\n| stage | resolution | degree | error | optimiser | status | iterations | "
        "solves | time |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : r.stages)
    md << fmt::format("| {} | {} | {} | {:.2f} % | {} | {} | {} | {} | {:.1f} s |\n", s.stage, s.resolution,
                      s.degree, 100 * s.avg_rel_error, s.optimizer, s.status, s.iterations,
                      s.equilibrium_solves, s.wall_time_s);
  md << "\n## Discretisation error (resolution ladder)\n\nPer stage, the change of every fitted entry "
        "between two successive levels (|to − from| / |to|): the fit's own estimate of the error its "
        "finest level leaves (first-order convergence off-axis). Validation ran at "
     << r.finest_resolution << "; the fit table names each final curve's level.\n\n| stage | levels | entry | from | to | change |\n|---|---|---|---|---|---|\n";
  for (const auto& f : r.refinement)
    for (const auto& c : f.changes)
      md << fmt::format("| {} | {} → {} | {} | {:.6g} | {:.6g} | {:.3f} % |\n", f.stage, f.from_resolution,
                        f.to_resolution, c.name, c.from, c.to, 100 * c.relative);
  md << "\n| stage | levels | membrane response change (at strain) | decision |\n|---|---|---|---|\n";
  for (const auto& f : r.refinement)
    md << fmt::format("| {} | {} → {} | {:.3f} % ({:.3g}) | {} |\n", f.stage, f.from_resolution, f.to_resolution,
                      100 * f.response_change, f.response_strain, f.decision);
  return md.str();
}

std::string report_markdown(const FitReport& r) {
  std::ostringstream md;
  md << "# twill fit: " << r.dataset << "\n\n";
  md << "Dataset folder: `" << r.folder << "`. Parameters: `params.yaml`; everything below is also in "
        "`report.json`; the resolved config is `config.yaml`.\n\n";
  md << fit_table_markdown(r) << drape_and_validation_markdown(r);
  if (!r.validation_strain.empty()) md << strain_range_markdown(r.validation_strain);
  if (!r.effects.empty()) md << effects_markdown(r.effects);
  md << stages_and_ladder_markdown(r);
  md << "\n## Initial guess (paper §5.3)\n\n| run | uniform-strain fit error | uniform strain vs full "
        "solve |\n|---|---|---|\n";
  for (const auto& g : r.initial_guess)
    md << fmt::format("| {} | {:.2f} % | {:.2f} % |\n", g.label, 100 * g.avg_rel_error_uniform,
                      100 * g.avg_rel_difference_full);
  md << "\n## Parameters\n\n```yaml\n" << params_to_yaml(r.parameters) << "```\n";
  md << "\n## Timing\n\n| stage | time |\n|---|---|\n";
  for (const auto& [k, v] : r.timing_s) md << fmt::format("| {} | {:.1f} s |\n", k, v);
  md << "\n## Notes\n\n";
  for (const auto& n : r.notes) md << "- " << n << "\n";
  md << "\n## Figures\n\n![force-elongation](fig2_force_elongation.png)\n\n"
        "![error vs degree](fig3_error_vs_degree.png)\n\n![validation](fig4_validation_error.png)\n";
  return md.str();
}

// JSON text; invalid UTF-8 (a folder name from the command line) is replaced (U+FFFD) rather
// than thrown as json type_error 316 after a finished fit. Readers reject it in files.
std::string dump(const json& j) { return j.dump(2, ' ', false, json::error_handler_t::replace) + "\n"; }

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

std::string fit_report_json_text(const FitReport& report, const Options& config) {
  return dump(report_json(report, config));
}

void write_fit_outputs(const FitReport& report, const Options& config, const std::string& dir) {
  const fs::path d(dir);
  fs::create_directories(d);
  write_params_file(report.parameters, (d / "params.yaml").string());
  write_config_file(config, (d / "config.yaml").string());
  write_text(d / "report.json", dump(report_json(report, config)));
  write_text(d / "report.md", report_markdown(report));
}

void write_incomplete_fit_report(const FitReport& finished, const Options& config, const std::string& error,
                                 const std::string& dir) {
  const fs::path d(dir);
  fs::create_directories(d);
  write_config_file(config, (d / "config.yaml").string());
  json j = report_json(finished, config);
  j["complete"] = false;
  j["error"] = error;
  write_text(d / "report-incomplete.json", dump(j));
  std::string md = report_markdown(finished);
  const std::string banner =
      "# INCOMPLETE twill fit: " + finished.dataset + "\n\n**The fit failed; this report holds only the stages "
      "that finished before the failure. There is no params.yaml: the parameters below are intermediate.**\n\n"
      "Error: `" + error + "`\n\n";
  md.replace(0, md.find("\n\n") + 2, banner);  // the banner replaces the title line
  md.erase(md.find("\n## Figures"));            // no figures are drawn for a failed fit
  const std::string outputs = "Parameters: `params.yaml`; everything below is also in `report.json`";
  if (const auto at = md.find(outputs); at != std::string::npos)
    md.replace(at, outputs.size(), "Everything below is also in `report-incomplete.json`");
  write_text(d / "report-incomplete.md", md);
}

}  // namespace twill
