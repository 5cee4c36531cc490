// `twill fit` with effects (issue #15 item 2; fitting/stages/effect_fit.cpp): on data simulated
// with an effect on — the same model and mesh as the fit, so that only the fit is under test
// (the generator with other laws is in papers/hidden_effects) — the effect-fit stage brings
// the error to round-off from clearly above it and recovers the effect's parameters; and the
// report carries the effect's table and params.yaml its parameters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>

#include "core/dataset.hpp"
#include "core/params_io.hpp"
#include "effects/effect_experiment.hpp"
#include "effects/poisson/poisson.hpp"
#include "experiments/predictors.hpp"
#include "fitting/discovery.hpp"
#include "fitting/fit_config.hpp"
#include "fitting/fit_context.hpp"
#include "fitting/fit_effects.hpp"
#include "fitting/fit_protocol.hpp"
#include "tests/support/registered_parts.hpp"

namespace twill {
namespace {

using namespace twill::testing;
namespace fs = std::filesystem;

// The fit's strip: 2 cells across (resolution.coarse_cells_across=2, one level), the mesh the
// data is simulated on.
constexpr int kCellsAcross = 2, kCellsAlong = 3;

struct SyntheticTest {
  std::string label;
  double angle_deg;
  double rate_mm_min;
  std::vector<double> extensions_mm;
  std::vector<double> offsets_deg = {0.0};  ///< one run per entry, its strip cut at angle_deg + this
  std::vector<double> scales = {};         ///< per run: its forces times this (a specimen's scatter); empty: 1
  double noise = 0;                        ///< relative Gaussian noise on every force (sd)
  unsigned seed = 1;                       ///< of the noise, with the run's index
  std::string role = "fit";                ///< the dataset's role: fit or validation
  int refinement = 1;                      ///< the data's strip this many times finer than the fits' (the continuum's stand-in)
};

// Loading to 5 mm in 0.5 mm steps, then back to 1 mm.
std::vector<double> up_and_down() {
  std::vector<double> x;
  for (int i = 1; i <= 10; ++i) x.push_back(0.5 * i);
  for (int i = 9; i >= 2; --i) x.push_back(0.5 * i);
  return x;
}

// The truth: poplin's stiffnesses with linear curves (what the tiny protocol's degree-1
// stages can represent), a12 tied, no cutoffs, and `effect` on.
MaterialParameters truth_with(const ComponentChoice& effect) {
  MaterialParameters k = poplin();
  k.eta1 = k.eta3 = k.eta4 = Curve::linear();
  k.a12_Pa = MaterialParameters::tied_a12(k.a11_Pa, k.a22_Pa);
  k.cutoffs = Cutoffs{};
  k.effects = {effect};
  return k;
}

// The cantilever's cells in these fits (experiments.bend.cells_*), the mesh its data is
// simulated on.
constexpr int kBendCellsAcross = 2, kBendCellsAlong = 16;

// The overhang at which `truth`'s cantilever at `angle_deg` shows the D1388 chord angle.
double simulated_overhang(const MaterialParameters& truth, double angle_deg) {
  ExperimentInput input;
  input.label = "bend";
  input.angle_deg = angle_deg;
  input.start = truth;
  input.cells_across = kBendCellsAcross;
  input.cells_along = kBendCellsAlong;
  input.discretization = factory_for("catmull-clark-kl");
  const auto e = create_experiment(registry(), default_choice(registry_category::kExperiment, "bend"), input);
  auto* cantilever = dynamic_cast<CantileverPredictor*>(&innermost(*e));
  const OverhangSearchResult r = cantilever->experiment().find_overhang();
  EXPECT_TRUE(r.converged) << r.message;
  return r.overhang_mm;
}

// One run of `t` simulated from `truth` with its strip at `angle_deg`, as a CSV with lateral
// strains.
void write_run(const fs::path& csv_path, const MaterialParameters& truth, const SyntheticTest& t, double angle_deg,
               double scale, size_t run_index) {
  ExperimentInput input;
  input.label = t.label;
  input.angle_deg = angle_deg;
  input.start = truth;
  input.schedule = t.extensions_mm;
  input.rate_mm_min = t.rate_mm_min;
  input.cells_across = kCellsAcross * t.refinement;
  input.cells_along = kCellsAlong * t.refinement;
  input.discretization = factory_for("catmull-clark-kl");
  const ExperimentRun run =
      create_experiment(registry(), default_choice(registry_category::kExperiment, "tensile"), input)->simulate(truth);
  EXPECT_TRUE(run.completed) << run.message;
  const std::vector<double>& lateral = run.extras.at(0).second;  // lateral_strain
  std::mt19937_64 engine(t.seed * 1000 + run_index);
  std::normal_distribution<double> noise(0.0, t.noise);
  std::ofstream csv(csv_path);
  csv.precision(12);
  csv << "extension_mm,force_N,lateral_strain\n";
  for (size_t i = 0; i < run.schedule.size(); ++i)
    csv << run.schedule[i] << "," << scale * run.values[static_cast<Eigen::Index>(i)] * (1 + noise(engine)) << ","
        << lateral[i] << "\n";
}

// A dataset folder with one run per test and offset simulated from `truth` (and a warp and a weft
// cantilever when `with_bend`, an overhang per entry of `overhang_shares`: the simulated one times it).
std::string write_dataset(const std::string& name, const MaterialParameters& truth,
                          const std::vector<SyntheticTest>& tests, bool with_bend = false,
                          const std::vector<double>& overhang_shares = {1.0}) {
  const fs::path dir = fs::temp_directory_path() / ("twill_fit_effects_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "tensile");
  std::ofstream yaml(dir / "fabric.yaml");
  yaml << "name: " << name << "\nareal_density_g_m2: " << 1e3 * truth.density_kg_m2
       << "\nthickness_mm: " << 1e3 * truth.thickness_m << "\ntensile:\n";
  for (const SyntheticTest& t : tests) {
    std::string runs;
    for (size_t r = 0; r < t.offsets_deg.size(); ++r) {
      const std::string file = "tensile/" + t.label + (r == 0 ? "" : "-" + std::to_string(r + 1)) + ".csv";
      write_run(dir / file, truth, t, t.angle_deg + t.offsets_deg[r], t.scales.empty() ? 1.0 : t.scales.at(r), r);
      runs += (runs.empty() ? "" : ", ") + file;
    }
    yaml << "- angle_deg: " << t.angle_deg << "\n  label: " << t.label << "\n  width_mm: 50\n  gauge_length_mm: 75\n"
         << "  rate_mm_min: " << t.rate_mm_min << "\n  role: " << t.role << "\n  runs: [" << runs << "]\n";
  }
  if (with_bend) {
    yaml << "bend:\n";
    for (const double angle : {90.0, 0.0}) {
      const double overhang = simulated_overhang(truth, angle);
      std::string overhangs;
      for (const double share : overhang_shares)
        overhangs += (overhangs.empty() ? "" : ", ") + std::to_string(share * overhang);
      yaml << "- angle_deg: " << angle << "\n  width_mm: 25\n  length_mm: 200\n  chord_angle_deg: 41.5\n  overhang_mm: ["
           << overhangs << "]\n";
    }
  }
  return dir.string();
}

// The tiny protocol (three linear curve stages at 2x3), `bend_stage`, the effect-fit stage
// (with `stage_options`, e.g. ", observable: lateral_strain"; none when `effect` is empty) and
// `after` (", {name: ...}").
Options config_with(const std::string& effect, const std::string& stage_options = "",
                    const std::string& bend_stage = "", const std::string& after = "") {
  const OptionSchema schema = fit_config_schema();
  Options config = default_options(schema, &registry());
  apply_overrides(config, schema, &registry(),
                  {"resolution.coarse_cells_across=2", "resolution.levels=1", "data.max_points=10",
                   "experiments.bend.cells_across=" + std::to_string(kBendCellsAcross),
                   "experiments.bend.cells_along=" + std::to_string(kBendCellsAlong), "effects=[" + effect + "]",
                   "protocol=[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1},"
                   " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1},"
                   " {name: tensile-curve, label: bias, angle_deg: 45, term: eta4, max_degree: 1}" + bend_stage +
                       (effect.empty() ? "" : ", {name: effect-fit, effect: " + effect + stage_options + "}") + after +
                       "]"});
  return config;
}

// The score test at the neutral values (core/score_test.hpp) on data made with the effect on:
// the effect's signature is in the residuals, far beyond what the leftover explains.
void expect_significant_score(const FitEffect& e) {
  std::printf("[measured] %s: score T %.4g (d %d), p (iid) %.2g, p (calibrated) %.2g, noise phi %.2f\n",
              e.effect.c_str(), e.score, e.score_dof, e.score_p_value_iid, e.score_p_value, e.score_noise_correlation);
  EXPECT_GT(e.score_dof, 0);
  // The effect's own directions only: the curves' shapes are the baseline's (a curve's name is
  // a pattern of several unknowns; counted as one, the shapes fell to the candidate).
  EXPECT_LE(e.score_dof, static_cast<int>(e.parameters.size()));
  EXPECT_LT(e.score_p_value_iid, 1e-6);
  EXPECT_LT(e.score_p_value, 0.01);
  // The per-test breakdown: every run in one test, the runs' mean is the stage's, and each test
  // has a noise floor. (Not below its error: the floor is the mean |u| of a projection over all
  // runs, which can move misfit between tests, in relative residuals, not Σ|p̂ − p̆|/Σ|p̆|;
  // measured: poisson's forces 0.014 % without the effect, floor 0.22 %.)
  int runs = 0;
  double without = 0, with = 0;
  for (const FitEffectTest& t : e.tests) {
    runs += t.runs;
    without += t.runs * t.error_without;
    with += t.runs * t.error_with;
    EXPECT_GT(t.noise_floor, 0.0) << t.test;
  }
  EXPECT_EQ(runs, e.runs);
  EXPECT_NEAR(without / runs, e.error_without, 1e-12);
  EXPECT_NEAR(with / runs, e.error_with, 1e-12);
}

double fitted(const FitReport& report, const std::string& name) {
  for (const FitEffectParameter& p : report.effects.at(0).parameters)
    if (p.name == name) return p.value;
  ADD_FAILURE() << "no fitted " << name;
  return 0;
}

// Dahl friction with frictions of a few % of the strips' forces per width (warp ~ 1e4 N/m at 5 mm).
ComponentChoice typical_hysteresis() {
  ComponentChoice hysteresis = default_choice(registry_category::kEffect, "hysteresis");
  hysteresis.options.set("warp_friction_N_m", 150.0);
  hysteresis.options.set("weft_friction_N_m", 100.0);
  hysteresis.options.set("shear_friction_N_m", 20.0);
  hysteresis.options.set("saturation_strain", 0.01);
  return hysteresis;
}

TEST(FitWithEffects, HysteresisFromLoadingAndUnloadingRuns) {
  const MaterialParameters truth = truth_with(typical_hysteresis());
  const std::string folder = write_dataset("hysteresis", truth,
                                           {{"warp", 90, 300, up_and_down()},
                                            {"weft", 0, 300, up_and_down()},
                                            {"bias", 45, 300, up_and_down()}});
  const FitReport report = run_fit(read_dataset(folder), config_with("hysteresis"), registry(), {});
  ASSERT_EQ(report.effects.size(), 1u);
  const FitEffect& e = report.effects[0];
  std::printf("[measured] hysteresis fit: error %.3f %% without, %.4f %% with; warp %.2f weft %.2f shear %.2f N/m, "
              "e_c %.4f\n",
              100 * e.error_without, 100 * e.error_with, fitted(report, "hysteresis.warp_friction_N_m"),
              fitted(report, "hysteresis.weft_friction_N_m"), fitted(report, "hysteresis.shear_friction_N_m"),
              fitted(report, "hysteresis.saturation_strain"));
  // Without friction the unloading rows miss by the gap 2σ_s W: several %.
  EXPECT_GT(e.error_without, 0.01);
  expect_significant_score(e);
  // With it, the model that made the data: the optimiser's tolerance, not a modelling error.
  EXPECT_LT(e.error_with, 1e-3);
  EXPECT_NEAR(fitted(report, "hysteresis.warp_friction_N_m"), 150.0, 0.02 * 150.0);
  EXPECT_NEAR(fitted(report, "hysteresis.weft_friction_N_m"), 100.0, 0.02 * 100.0);
  EXPECT_NEAR(fitted(report, "hysteresis.saturation_strain"), 0.01, 0.05 * 0.01);
  // params.yaml carries the fitted effect.
  ASSERT_EQ(report.parameters.effects.size(), 1u);
  EXPECT_EQ(report.parameters.effects[0].name, "hysteresis");
  EXPECT_NE(params_to_yaml(report.parameters).find("warp_friction_N_m"), std::string::npos);
  fs::remove_all(folder);
}

TEST(FitWithEffects, PoissonFromLateralStrains) {
  ComponentChoice poisson = default_choice(registry_category::kEffect, "poisson");
  poisson.options.set("coupling_ratio", 0.3);
  poisson.options.set("coupling_curvature", 8.0);  // η2''(0): the strips' narrowing eases as they stretch
  const MaterialParameters truth = truth_with(poisson);
  std::vector<double> loading;
  for (int i = 1; i <= 10; ++i) loading.push_back(0.5 * i);
  const std::string folder = write_dataset("poisson", truth,
                                           {{"warp", 90, 300, loading}, {"weft", 0, 300, loading},
                                            {"bias", 45, 300, loading}});
  const FitReport report = run_fit(read_dataset(folder),
                                   config_with("poisson", ", observable: both"),
                                   registry(), {});
  ASSERT_EQ(report.effects.size(), 1u);
  const FitEffect& e = report.effects[0];
  std::printf("[measured] poisson fit: force and lateral-strain error %.3f %% without (r = 0.5, c = 0), %.4f %% with; "
              "r = %.4f, c = %.3f\n",
              100 * e.error_without, 100 * e.error_with, fitted(report, "poisson.coupling_ratio"),
              fitted(report, "poisson.coupling_curvature"));
  EXPECT_GT(e.error_without, 0.05);  // r = 0.5 narrows the strips visibly more than 0.3
  expect_significant_score(e);
  EXPECT_LT(e.error_with, 1e-3);
  EXPECT_NEAR(fitted(report, "poisson.coupling_ratio"), 0.3, 1e-3);
  EXPECT_NEAR(fitted(report, "poisson.coupling_curvature"), 8.0, 0.5);
  fs::remove_all(folder);
}

// What `twill discover` judges an unexplained lateral misfit on (effect_fit.cpp
// set_errors_beyond_known, FitEffectTest::error_beyond_known): the baseline's lateral error with
// the mesh's and a 1° cut's patterns fitted out, as the score test takes them. Strips every one
// cut 1° off (the shared narrowing of the generator's cuts, which read `unexplained at warp
// lateral strain` on poisson's null twins) lose their lateral misfit there; a coupling unlike the
// paper's (poisson's own signal) keeps it.
TEST(FitWithEffects, TheLateralErrorBeyondTheKnownPatternsLosesTheCutsNotTheCoupling) {
  std::vector<double> loading;
  for (int i = 1; i <= 10; ++i) loading.push_back(0.5 * i);
  const auto lateral_errors = [&](const std::string& name, const MaterialParameters& truth, double offset_deg) {
    const std::vector<double> offsets = {offset_deg};
    constexpr int kFiner = 2;  // the data on the strip the patterns are taken on, one level finer
    const std::string folder = write_dataset(name, truth,
                                             {{"warp", 90, 300, loading, offsets, {}, 0, 1, "fit", kFiner},
                                              {"weft", 0, 300, loading, offsets, {}, 0, 1, "fit", kFiner},
                                              {"bias", 45, 300, loading, offsets, {}, 0, 1, "fit", kFiner}});
    const FitReport report = run_fit(read_dataset(folder), config_with("poisson", ", observable: both"), registry(), {});
    fs::remove_all(folder);
    std::map<std::string, std::pair<double, double>> errors;  // without, beyond the known patterns
    for (const FitEffectTest& t : report.effects.at(0).tests) {
      errors[t.test] = {t.error_without, t.error_beyond_known};
      std::printf("[measured] %s, %s: %.3f %% without poisson, %.3f %% beyond the mesh's and a cut's patterns\n",
                  name.c_str(), t.test.c_str(), 100 * t.error_without, 100 * t.error_beyond_known);
    }
    return errors;
  };
  const auto cut = lateral_errors("lateral_cut", truth_with(default_choice(registry_category::kEffect, "poisson")), 1.0);
  ComponentChoice coupling = default_choice(registry_category::kEffect, "poisson");
  coupling.options.set("coupling_ratio", 0.3);
  const auto coupled = lateral_errors("lateral_coupling", truth_with(coupling), 0.0);
  EXPECT_TRUE(std::isnan(cut.at("warp").second));  // a force test has no lateral patterns
  // Measured: the cut data 17.87 / 13.19 % (warp / weft; most of it the 2×3 strip's own mesh
  // error) → 0.04 / 0.17 %; the coupling's 102.07 / 94.21 % → 36.48 / 48.35 %. On this coarse
  // strip the mesh's error is a sixth of the lateral strain, so the mesh pattern's reach of twice
  // it takes up to that much more of any misfit; at 8×12 it is 3.4 % at 2 mm.
  for (const std::string test : {"warp lateral strain", "weft lateral strain"}) {
    const auto [cut_without, cut_beyond] = cut.at(test);
    EXPECT_GT(cut_without, 0.05) << test;
    EXPECT_LT(cut_beyond, 0.05 * cut_without) << test;
    const auto [coupled_without, coupled_beyond] = coupled.at(test);
    EXPECT_GT(coupled_without, 0.5) << test;
    EXPECT_GT(coupled_beyond, 0.25 * coupled_without) << test;
    EXPECT_GT(coupled_beyond, 100 * cut_beyond) << test;
  }
}

// The curves' levels in the lateral strains' floor (effect_fit.cpp lateral_level_noise;
// docs/effects/poisson.md): each curve sits at its strips' mean scale, off its truth by
// sd(log s)/√n, and a strip's contraction follows the stiffnesses' ratios, which no specimen
// scale absorbs. Noiseless strips at the paper's coupling, three per test: scattered by ±10 %
// the lateral strains' floors hold that level's share; alike (every scale 1) they hold none.
TEST(FitWithEffects, TheLateralStrainsFloorHoldsTheCurvesLevels) {
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "poisson"));
  std::vector<double> loading;
  for (int i = 1; i <= 8; ++i) loading.push_back(0.5 * i);
  const std::vector<double> aligned = {0, 0, 0}, scattered = {0.9, 1.0, 1.1}, alike = {1, 1, 1};
  const auto floors_with = [&](const std::string& name, const std::vector<double>& scales) {
    const std::string folder = write_dataset(name, truth,
                                             {{"warp", 90, 300, loading, aligned, scales},
                                              {"weft", 0, 300, loading, aligned, scales},
                                              {"bias", 45, 300, loading, aligned, scales}});
    Options config = config_with("poisson", ", observable: both");
    // Curves of two terms: several unknowns per curve name (eta3.*), all of them the baseline's.
    apply_overrides(config, fit_config_schema(), &registry(),
                    {"repeats.rule=all", "repeats.scale=per-run", "protocol[0].max_degree=2", "protocol[0].target_error=1e-9",
                     "protocol[0].min_improvement=0"});
    const FitReport report = run_fit(read_dataset(folder), config, registry(), {});
    fs::remove_all(folder);
    EXPECT_LE(report.effects.at(0).score_dof, static_cast<int>(report.effects.at(0).parameters.size()));
    std::map<std::string, double> floors;
    for (const FitEffectTest& t : report.effects.at(0).tests) floors[t.test] = t.noise_floor;
    return floors;
  };
  const std::map<std::string, double> level = floors_with("poisson_levels", scattered),
                                      none = floors_with("poisson_no_levels", alike);
  // sd(log s) = 0.1004 over 3 strips: each curve's level is off by se = 0.0580. With the tie
  // a12 = ½ min(a11, a22) = ½ a22 (the truth's a22 < a11), the strip along a22 (warp) contracts
  // by a12/a22 = ½ whatever the levels, the strip along a11 (weft) by ½ a22/a11: by √2 se, on
  // average √(2/π) √2 se = 6.54 % (the rest of the law's terms move it by a few % of that).
  const double se = 0.1004 / std::sqrt(3.0), weft_floor = std::sqrt(2 / M_PI) * std::sqrt(2.0) * se;
  for (const std::string test : {"warp lateral strain", "weft lateral strain"})
    std::printf("[measured] %s floor: %.3f %% with the strips scattered by 10 %%, %.2e %% alike\n", test.c_str(),
                100 * level.at(test), 100 * none.at(test));
  EXPECT_NEAR(level.at("weft lateral strain"), weft_floor, 0.1 * weft_floor);
  EXPECT_LT(level.at("warp lateral strain"), 0.1 * weft_floor);
  EXPECT_LT(none.at("weft lateral strain"), 1e-5);
  EXPECT_LT(none.at("warp lateral strain"), 1e-5);
}

// Data whose coupling curvature lies beyond the effect's bound (η2''(0) = −15 < −10, simulated
// with the law's own η2): the fit stops on the bound, and the report says the data do not pin
// the parameter there (effect_fit.cpp note_unpinned) instead of handing out −10 as measured.
TEST(FitWithEffects, AParameterThatEndsOnABoundIsReportedAsNotPinned) {
  MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "poisson"));
  truth.effects.clear();
  truth.a12_Pa = 0.3 * std::min(truth.a11_Pa, truth.a22_Pa);
  truth.eta2 = Curve{{1.0}, {-14.0}};
  std::vector<double> loading;
  for (int i = 1; i <= 10; ++i) loading.push_back(0.5 * i);
  const std::string folder = write_dataset("poisson_bound", truth,
                                           {{"warp", 90, 300, loading}, {"weft", 0, 300, loading},
                                            {"bias", 45, 300, loading}});
  const FitReport report = run_fit(read_dataset(folder), config_with("poisson", ", observable: both"), registry(), {});
  const double c = fitted(report, "poisson.coupling_curvature");
  std::printf("[measured] poisson fit of eta2''(0) = -15: c = %.4f, r = %.4f\n", c,
              fitted(report, "poisson.coupling_ratio"));
  EXPECT_DOUBLE_EQ(c, Poisson::kMinCouplingCurvature);
  EXPECT_TRUE(std::any_of(report.notes.begin(), report.notes.end(), [](const std::string& n) {
    return n.find("poisson.coupling_curvature ended at its lower bound -10: the data do not pin it") != std::string::npos;
  }));
  fs::remove_all(folder);
}

TEST(FitWithEffects, BendingAnisotropyFromWarpAndWeftCantilevers) {
  ComponentChoice bending = default_choice(registry_category::kEffect, "bending-anisotropy");
  bending.options.set("warp_bending_ratio", 2.0);
  bending.options.set("weft_bending_ratio", 0.7);
  const MaterialParameters truth = truth_with(bending);
  std::vector<double> loading;
  for (int i = 1; i <= 6; ++i) loading.push_back(0.5 * i);
  // Three overhangs per direction, ±1.2 % about the simulated one (the repeats D1388 asks for).
  const std::string folder =
      write_dataset("bending", truth, {{"warp", 90, 300, loading}, {"weft", 0, 300, loading}, {"bias", 45, 300, loading}},
                    true, {0.988, 1.0, 1.012});
  const Options config = config_with("bending-anisotropy", ", observable: chord_angle_deg", ", {name: bend}");
  const FitReport report = run_fit(read_dataset(folder), config, registry(), {});
  ASSERT_EQ(report.effects.size(), 1u);
  const FitEffect& e = report.effects[0];
  const double warp = fitted(report, "bending-anisotropy.warp_bending_ratio");
  const double weft = fitted(report, "bending-anisotropy.weft_bending_ratio");
  std::printf("[measured] bending-anisotropy fit: chord-angle error %.3f %% without, %.4f %% with; ratios %.4f, %.4f "
              "(warp/weft %.4f, truth %.4f), tau %.4g mm\n",
              100 * e.error_without, 100 * e.error_with, warp, weft, warp / weft, 2.0 / 0.7,
              1e3 * report.parameters.thickness_m);
  // One thickness cannot bend both strips to 41.5°: the bend stage leaves both off.
  EXPECT_GT(e.error_without, 0.02);
  // Two chord angles, two ratios: the fit is exact by construction, and the noise is judged by
  // the repeated overhangs (score_test_with_known_noise): one direction beyond the thickness.
  std::printf("[measured] bending-anisotropy score T %.4g (d %d), p %.2g; floors %.3f %%, %.3f %%\n", e.score,
              e.score_dof, e.score_p_value, 100 * e.tests.at(0).noise_floor, 100 * e.tests.at(1).noise_floor);
  EXPECT_EQ(e.score_dof, 1);
  EXPECT_LT(e.score_p_value, 1e-3);
  for (const FitEffectTest& t : e.tests) EXPECT_GT(t.noise_floor, 0.0) << t.test;
  EXPECT_LT(e.error_with, 1e-3);
  // What a cantilever identifies is its direction's small-curvature bending stiffness
  // b τ³ a / 12 (τ and equal ratios trade exactly, docs/effects/bending-anisotropy.md; the
  // tensile stages fix τ·a, the bend stage τ): those come back, not b itself.
  const MaterialParameters& k = report.parameters;
  auto stiffness = [](double b, double tau, double a) { return b * tau * tau * tau * a / 12; };
  const double warp_truth = stiffness(2.0, truth.thickness_m, truth.a11_Pa);
  const double weft_truth = stiffness(0.7, truth.thickness_m, truth.a22_Pa);
  std::printf("[measured] bending stiffness warp %.5g (truth %.5g), weft %.5g (truth %.5g) N m\n",
              stiffness(warp, k.thickness_m, k.a11_Pa), warp_truth, stiffness(weft, k.thickness_m, k.a22_Pa),
              weft_truth);
  EXPECT_NEAR(stiffness(warp, k.thickness_m, k.a11_Pa), warp_truth, 0.01 * warp_truth);
  EXPECT_NEAR(stiffness(weft, k.thickness_m, k.a22_Pa), weft_truth, 0.01 * weft_truth);
  fs::remove_all(folder);
  // One overhang per direction: nothing measures the chord angles' noise, and the stage says so.
  const std::string single = write_dataset(
      "bending_single", truth, {{"warp", 90, 300, loading}, {"weft", 0, 300, loading}, {"bias", 45, 300, loading}}, true);
  const FitReport once = run_fit(read_dataset(single), config, registry(), {});
  EXPECT_TRUE(std::isnan(once.effects.at(0).score)) << once.effects.at(0).score;
  std::string notes;
  for (const std::string& n : once.notes) notes += n + "\n";
  EXPECT_NE(notes.find("needs repeated overhangs"), std::string::npos) << notes;
  fs::remove_all(single);
}

// Misalignment where the data identify it: with two or more validation strips (22.5° and 67.5°,
// off the axes, where a cut moves the force to first order) the effect-fit stage is judged on
// them — error at a common offset per test and at each strip's own, each strip at its own
// scale, and a calibrated score test of the strips' offsets with their scales and a common
// offset per test as the baseline (docs/effects/misalignment.md; twill discover names
// misalignment on it). Strips cut 1–2° off, and the same specimens cut on their angles with
// 20 draws of the noise: the fitted law misses the validation angles by 0.2 % by itself (the
// tiny protocol's sequential stages), which per-strip offsets halve — without the common
// offset in the baseline 26 of 30 such null draws had p < 0.05 (measured), with it none.
TEST(FitWithEffects, MisalignmentIsJudgedOnTheValidationStripsWithAScoreTest) {
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "misalignment"));
  std::vector<double> loading;
  for (int i = 1; i <= 8; ++i) loading.push_back(0.5 * i);
  const double noise = 0.003;
  auto record = [&](const std::string& name, const std::vector<double>& low, const std::vector<double>& high,
                    unsigned seed) {
    const std::string folder = write_dataset(
        name, truth,
        {{"warp", 90, 300, loading}, {"weft", 0, 300, loading}, {"bias", 45, 300, loading},
         {"a22.5", 22.5, 300, loading, low, {1.1, 0.92}, noise, seed, "validation"},
         {"a67.5", 67.5, 300, loading, high, {0.95, 1.06}, noise, seed + 100, "validation"}});
    const FitReport report = run_fit(read_dataset(folder), config_with("misalignment"), registry(), {});
    fs::remove_all(folder);
    EXPECT_EQ(report.effects.size(), 1u);
    return report.effects.empty() ? FitEffect{} : report.effects[0];
  };
  const FitEffect cut = record("validation_cut", {1.5, -1.0}, {-2.0, 0.5}, 3);
  std::printf("[measured] misalignment on cut validation strips: error %.3f %% → %.3f %%, floor %.3f %%, T %.4g (d %d), "
              "p %.2g (iid %.2g), spread %.3f deg\n", 100 * cut.error_without, 100 * cut.error_with,
              100 * cut.tests.at(0).noise_floor, cut.score, cut.score_dof, cut.score_p_value, cut.score_p_value_iid,
              cut.parameters.at(0).value);
  ASSERT_EQ(cut.runs, 4);
  ASSERT_EQ(cut.tests.size(), 2u);
  EXPECT_EQ(cut.tests[0].test, "a22.5");
  EXPECT_GE(cut.score_dof, 2);  // strips − tests
  EXPECT_LT(cut.score_p_value, 0.01);
  EXPECT_LT(cut.error_with, cut.error_without / 3);
  // The held-out rows: offsets fitted on every other row of each strip predict the rows between.
  std::printf("[measured] held-out rows: %.3f %% at the common offsets, %.3f %% at each strip's own\n",
              100 * cut.held_out_rows_without, 100 * cut.held_out_rows_with);
  // Measured 5.40 % → 1.74 %; discover asks only that it holds (with < without).
  EXPECT_LT(cut.held_out_rows_with, cut.held_out_rows_without / 2);
  // On these linear curves a cut is nearly a scale (F' ∝ F for a linear strip), and with the
  // scales free the offsets come out short: 1.25° against 1.37° (measured).
  EXPECT_NEAR(cut.parameters.at(0).value, std::sqrt((1.5 * 1.5 + 1.0 + 4.0 + 0.25) / 4), 0.15);
  constexpr unsigned kNullDraws = 20;
  int rejected = 0, held = 0;
  double largest_spread = 0;
  for (unsigned seed = 10; seed < 10 + kNullDraws; ++seed) {
    const FitEffect aligned = record("validation_aligned", {0, 0}, {0, 0}, seed);
    rejected += aligned.score_p_value < 0.05;
    held += aligned.held_out_rows_with < aligned.held_out_rows_without;
    largest_spread = std::max(largest_spread, aligned.parameters.at(0).value);
  }
  std::printf("[measured] strips cut on their angles: %d of %u draws with p < 0.05, %d whose own offsets predicted "
              "the held-out rows better, largest spread %.3f deg\n", rejected, kNullDraws, held, largest_spread);
  EXPECT_LE(rejected, 3);  // 1 expected; P(≥ 4 of 20) = 1.6 % for a calibrated test
  EXPECT_LT(largest_spread, 0.3);
}

// Three strips per test cut off their nominal angles (one of them aligned), fitted with every
// repeat and an offset per strip, 5 rounds; `scales`: each strip's forces also times a specimen
// factor (geometric mean 1 per test), fitted with repeats.scale=per-run.
void check_misalignment_offsets(const std::string& name, bool scales) {
  // Three strips per test cut off their nominal angles, one of them aligned: every test of this
  // stiff-yarn weave (G12 = a22/230) has forces nearly even in the offset — warp and weft on
  // the axes, the bias, whose force is smallest at 45° — so the fit's gauge (gauge_offsets)
  // puts the best-aligned strip at 0 and the sign of an offset is not identified (compared in
  // |Δθ|).
  const std::vector<double> bias = {0.0, 1.0, -1.5}, warp = {0.0, 1.0, 2.0}, weft = {1.5, 0.0, 0.5};
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "misalignment"));
  std::vector<double> loading;
  for (int i = 1; i <= 8; ++i) loading.push_back(0.5 * i);
  const std::vector<double> none = {}, warp_scales = {1.12, 0.93, 1 / (1.12 * 0.93)},
                            weft_scales = {0.88, 1.05, 1 / (0.88 * 1.05)}, bias_scales = {1.0, 1.15, 1 / 1.15};
  const std::string folder = write_dataset(name, truth,
                                           {{"warp", 90, 300, loading, warp, scales ? warp_scales : none},
                                            {"weft", 0, 300, loading, weft, scales ? weft_scales : none},
                                            {"bias", 45, 300, loading, bias, scales ? bias_scales : none}});
  Options config = config_with("misalignment", ", rounds: 5", "", ", {name: final-curves}");
  apply_overrides(config, fit_config_schema(), &registry(),
                  {"repeats.rule=all", scales ? "repeats.scale=per-run" : "repeats.scale=none"});
  const FitReport report = run_fit(read_dataset(folder), config, registry(), [](int level, const std::string& line) {
    if (level == 0 && line.find("round") != std::string::npos) std::printf("[measured] %s\n", line.c_str());
  });
  ASSERT_EQ(report.effects.size(), 1u);
  const FitEffect& e = report.effects[0];
  std::map<std::string, double> truth_offsets;
  for (size_t r = 0; r < 3; ++r) {
    const std::string suffix = r == 0 ? "" : "-" + std::to_string(r + 1);
    truth_offsets["warp" + suffix] = warp[r];
    truth_offsets["weft" + suffix] = weft[r];
    truth_offsets["bias" + suffix] = bias[r];
  }
  double rms = 0, worst = 0;
  for (const auto& [run, offset] : truth_offsets) rms += offset * offset / static_cast<double>(truth_offsets.size());
  ASSERT_EQ(report.fit.size(), truth_offsets.size());
  double worst_bias = 0, worst_scale = 0;
  const std::map<std::string, const std::vector<double>*> drawn_scales = {
      {"warp", &warp_scales}, {"weft", &weft_scales}, {"bias", &bias_scales}};
  for (const FitCurve& c : report.fit) {
    const double error = std::abs(std::abs(c.delta_theta_deg) - std::abs(truth_offsets.at(c.run)));
    (c.label == "bias" ? worst_bias : worst) = std::max(c.label == "bias" ? worst_bias : worst, error);
    if (scales && c.label != "bias") {
      const size_t r = c.run == c.label ? 0 : static_cast<size_t>(c.run.back() - '1');
      worst_scale = std::max(worst_scale, std::abs(c.specimen_scale / drawn_scales.at(c.label)->at(r) - 1));
    }
    std::printf("[measured] %s: offset %+.2f deg (truth %+.2f), scale %.4f, error %.4f %%\n", c.run.c_str(),
                c.delta_theta_deg, truth_offsets.at(c.run), c.specimen_scale, 100 * c.avg_rel_error);
  }
  std::printf("[measured] misalignment fit (%s): error %.4f %% at the nominal angles, %.4f %% with the offsets; "
              "spread %.3f deg (truth RMS %.3f); worst offset error %.3f deg (warp, weft), %.3f deg (bias)\n",
              name.c_str(), 100 * e.error_without, 100 * e.error_with, fitted(report, "misalignment.spread_deg"),
              std::sqrt(rms), worst, worst_bias);
  // Cuts of 1–2° move these clamped strips' forces by under 1 % (the clamps hold the yarns
  // that run clamp to clamp); the curves fitted to the mean strip leave 0.87 % (0.74 % with a
  // scale per strip, a test's scales at geometric mean 1: a scale takes up little of a cut).
  EXPECT_GT(e.error_without, 0.005);
  // Five rounds: the bias offsets converge linearly, warp and weft in the first round.
  EXPECT_LT(e.error_with, 0.02 * e.error_without);
  if (!scales) {
    // Bias 1° strip: 0.65, 0.75, 0.90, 1.00° over rounds 2–5 (measured). Two steps of the
    // search's 0.05° grid.
    EXPECT_LT(std::max(worst, worst_bias), 0.1);
    EXPECT_NEAR(fitted(report, "misalignment.spread_deg"), std::sqrt(rms), 0.05);
  } else {
    // Only what a scale cannot do is left to find an offset by (the growth of the deficit with
    // extension). Found on warp and weft all the same, with the specimens' scales; on the
    // bias, where an offset is almost a scale, the alternation of search and refit crawls (1°
    // strip: 0.44, 0.64, 0.74, 0.79° over rounds 2–5, measured).
    EXPECT_LT(worst, 0.1);
    EXPECT_LT(worst_scale, 1e-3);
    EXPECT_LT(worst_bias, 0.35);
  }
  fs::remove_all(folder);
}

TEST(FitWithEffects, MisalignmentOffsetsOfTheFitRuns) { check_misalignment_offsets("misalignment", false); }

TEST(FitWithEffects, MisalignmentOffsetsOfTheFitRunsWithSpecimenScales) {
  check_misalignment_offsets("misalignment_scaled", true);
}

// The spread params.yaml carries (fitting/fit_effects.cpp, docs/effects/misalignment.md "Which
// offsets the spread is estimated from"): from two or more validation offsets alone — off the
// axes a cut moves the force to first order, while fit-run offsets are second order and
// relative to their test's gauge (papers/hidden_effects: 0.2–0.3° RMS of validation offsets
// where nothing was cut, fit-run offsets up to 3.4°) — and pooled with the turned fit runs'
// where one validation strip cannot make a spread.
TEST(FitWithEffects, TheSpreadComesFromTheValidationOffsetsWhenThereAreTwo) {
  const Dataset dataset = read_dataset(std::string(TWILL_SOURCE_DIR) + "/examples/canvas");
  const FitConfig config = read_fit_config(config_with("misalignment"));
  auto spread_of = [&](const std::vector<double>& validation_offsets, std::string* notes) {
    FitContext context(dataset, config, registry(), {});
    FitReport out;
    context.set_output(&out);
    context.params.effects = config.effects;
    const std::vector<std::optional<double>> fit_offsets = {3.0, -4.0, std::nullopt};  // the last not turned
    for (const std::optional<double>& offset : fit_offsets) {
      RunData d;
      d.test = &dataset.tensile.at(0);
      d.run = &d.test->runs.at(0);
      if (offset) d.strip_angle_deg = d.test->angle_deg + *offset;
      context.fit_runs.push_back(d);
    }
    std::vector<FitCurve> validation(validation_offsets.size());
    for (size_t i = 0; i < validation.size(); ++i) validation[i].delta_theta_deg = validation_offsets[i];
    const std::vector<ComponentChoice> effects = estimate_effects(context, validation);
    for (const std::string& n : out.notes) *notes += n + "\n";
    return effects.at(0).options.get_double("spread_deg");
  };
  std::string alone, pooled;
  EXPECT_DOUBLE_EQ(spread_of({1.0, -2.0}, &alone), std::sqrt((1.0 + 4.0) / 2));
  EXPECT_NE(alone.find("estimated from the 2 validation offsets alone"), std::string::npos) << alone;
  EXPECT_DOUBLE_EQ(spread_of({1.0}, &pooled), std::sqrt((1.0 + 9.0 + 16.0) / 3));
  EXPECT_NE(pooled.find("estimated from the 1 validation offsets and 2 fit-run offsets"), std::string::npos) << pooled;
}

TEST(FitWithSpecimenScales, PerRunScalesRemoveTheSpecimenScatterExactly) {
  // Three specimens per angle whose forces differ by a factor each (the repeat scatter of paper
  // §6.4), geometric mean 1 per angle (core/specimen_scale.hpp). The warp's are two tests at one
  // angle (as at two crosshead speeds), two specimens and one, whose own means are 1.02 and
  // 0.96: the gauge is the curve's, not each test's (docs/fitting.md §3a; with a gauge per test
  // this fit missed the scatter-free one by percents). With repeats.scale: per-run the
  // fit finds the factors and the parameters it finds on the same specimens without scatter
  // (the tiny protocol's sequential stages leave their own ~2 % on both); without, the curve
  // lands between the specimens.
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "misalignment"));
  std::vector<double> loading;
  for (int i = 1; i <= 8; ++i) loading.push_back(0.5 * i);
  const std::vector<double> warp_a = {1.12, 0.93}, warp_b = {1 / (1.12 * 0.93)}, weft = {0.88, 1.05, 1 / (0.88 * 1.05)},
                            bias = {1.0, 1.15, 1 / 1.15}, none = {1, 1, 1};
  const std::vector<double> aligned = {0, 0, 0}, two = {0, 0}, one = {0};
  const std::string scattered = write_dataset("scales", truth,
                                              {{"warp-a", 90, 300, loading, two, warp_a},
                                               {"warp-b", 90, 30, loading, one, warp_b},
                                               {"weft", 0, 300, loading, aligned, weft},
                                               {"bias", 45, 300, loading, aligned, bias}});
  const std::string alike = write_dataset("no_scales", truth,
                                          {{"warp-a", 90, 300, loading, two, none},
                                           {"warp-b", 90, 30, loading, one, none},
                                           {"weft", 0, 300, loading, aligned, none},
                                           {"bias", 45, 300, loading, aligned, none}});
  Options config = config_with("", "", "", ", {name: final-curves}");
  apply_overrides(config, fit_config_schema(), &registry(), {"repeats.rule=all", "repeats.scale=none"});
  const FitReport unscaled = run_fit(read_dataset(scattered), config, registry(), {});
  apply_overrides(config, fit_config_schema(), &registry(), {"repeats.scale=per-run"});
  // Profiled on equal specimens the scales stay 1 (by symmetry); on the scattered ones the
  // profiled objective is the same function of the parameters (s_r = c_r t_r, Π t_r = 1),
  // with the same Jacobian rows at the found scales, from the same start (the slopes'
  // geometric mean, fit_protocol.cpp): the same optimiser path.
  const FitReport reference = run_fit(read_dataset(alike), config, registry(), {});
  const FitReport scaled = run_fit(read_dataset(scattered), config, registry(), {});
  const std::map<std::string, std::vector<double>> scales = {
      {"warp-a", warp_a}, {"warp-b", warp_b}, {"weft", weft}, {"bias", bias}};
  double worst_scale = 0, worst_error_change = 0, error_unscaled = 0;
  ASSERT_EQ(scaled.fit.size(), 9u);
  for (size_t i = 0; i < scaled.fit.size(); ++i) {
    const FitCurve& c = scaled.fit[i];
    const size_t r = c.run == c.label ? 0 : static_cast<size_t>(c.run.back() - '1');
    worst_scale = std::max(worst_scale, std::abs(c.specimen_scale / scales.at(c.label).at(r) - 1));
    worst_error_change = std::max(worst_error_change, std::abs(c.avg_rel_error - reference.fit[i].avg_rel_error));
    error_unscaled = std::max(error_unscaled, unscaled.fit[i].avg_rel_error);
    EXPECT_EQ(unscaled.fit[i].specimen_scale, 1.0);
  }
  const MaterialParameters &k = scaled.parameters, &k0 = reference.parameters;
  const double worst_stiffness = std::max({std::abs(k.a11_Pa / k0.a11_Pa - 1), std::abs(k.a22_Pa / k0.a22_Pa - 1),
                                           std::abs(k.G12_Pa / k0.G12_Pa - 1)});
  std::printf("[measured] specimen scales: worst run error %.2f %% without them, the scatter-free fit's to %.1e "
              "with them; worst scale error %.1e, worst stiffness vs the scatter-free fit %.1e\n",
              100 * error_unscaled, worst_error_change, worst_scale, worst_stiffness);
  EXPECT_GT(error_unscaled, 0.03);  // the 5–15 % scatter, split around the fitted curve
  // The same problem on the same path: round-off apart.
  EXPECT_LT(worst_error_change, 1e-8);
  EXPECT_LT(worst_scale, 1e-8);
  EXPECT_LT(worst_stiffness, 1e-8);
  fs::remove_all(scattered);
  fs::remove_all(alike);
}

TEST(FitWithEffects, AnEffectFitStageIsInactiveWithoutItsEffectAndRejectsUnknownNames) {
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "hysteresis"));
  const std::string folder = write_dataset("inactive", truth,
                                           {{"warp", 90, 300, up_and_down()}, {"bias", 45, 300, up_and_down()}});
  Options config = config_with("hysteresis");
  const OptionSchema schema = fit_config_schema();
  apply_overrides(config, schema, &registry(), {"effects=[]"});
  const FitReport report = run_fit(read_dataset(folder), config, registry(), {});
  EXPECT_TRUE(report.effects.empty());
  EXPECT_TRUE(report.parameters.effects.empty());
  apply_overrides(config, schema, &registry(), {"protocol[3].effect=hysterisis"});
  try {
    check_fit_protocol(read_dataset(folder), config, registry(), [](const std::string& key) { return InputLocation{"", 0, key}; });
    ADD_FAILURE() << "a misspelt effect passed the check";
  } catch (const InputError& e) {
    EXPECT_EQ(e.where().key, "protocol[3].effect");
    EXPECT_NE(std::string(e.what()).find("hysteresis"), std::string::npos) << e.what();  // lists the known
  }
  fs::remove_all(folder);
}

// `twill discover` end to end (fitting/discovery.hpp) on the tiny protocol with one effect-fit
// stage, hysteresis': three specimens per test with 15 %-like scatter and 0.5 % noise, the
// effect hidden or not. The ladder stage refits the curves once more after all three: without
// it the warp curve, fitted before the weft stage moved a22 (and the tied a12), misses the path
// by 2.2 %, and discover rightly calls that `unexplained at warp` (measured). The statistics over seeds and effects are papers/discovery's; here the
// workflow's decisions on one clear case each.
Options discover_config(const std::vector<std::string>& extra = {}) {
  const OptionSchema schema = discover_config_schema();
  Options config = default_options(schema, &registry());
  apply_overrides(config, schema, &registry(),
                  {"resolution.coarse_cells_across=2", "resolution.levels=1", "data.max_points=10",
                   "protocol=[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1},"
                   " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1},"
                   " {name: tensile-curve, label: bias, angle_deg: 45, term: eta4, max_degree: 1},"
                   " {name: resolution-ladder}, {name: effect-fit, effect: hysteresis}]"});
  apply_overrides(config, schema, &registry(), extra);
  return config;
}

DiscoverResult discover_on(const std::string& name, const ComponentChoice& effect,
                           const std::vector<std::string>& extra = {}) {
  const std::vector<double> offsets = {0.0, 0.0, 0.0}, scales = {1.12, 0.93, 0.96};
  constexpr double kNoise = 0.005;
  const std::string folder = write_dataset(name, truth_with(effect),
                                           {{"warp", 90, 300, up_and_down(), offsets, scales, kNoise, 1},
                                            {"weft", 0, 300, up_and_down(), offsets, scales, kNoise, 2},
                                            {"bias", 45, 300, up_and_down(), offsets, scales, kNoise, 3}});
  DiscoverResult result = run_discover(read_dataset(folder), discover_config(extra), registry(), {});
  fs::remove_all(folder);
  for (const DiscoverCandidate& c : result.candidates)
    std::printf("[measured] discover %s: %s %s (%s)\n", name.c_str(), c.name.c_str(), c.status.c_str(),
                c.reason.c_str());
  for (const DiscoverGap& g : result.gap)
    std::printf("[measured] discover %s: %s before %.2f %% after %.2f %% floor %.2f %%\n", name.c_str(),
                g.test.c_str(), 100 * g.before, 100 * g.after, 100 * g.floor);
  return result;
}

const DiscoverCandidate& candidate(const DiscoverResult& r, const std::string& name) {
  for (const DiscoverCandidate& c : r.candidates)
    if (c.name == name) return c;
  throw std::runtime_error("no candidate " + name);
}

TEST(Discover, NamesHiddenHysteresisAndShowsTheGapShrink) {
  const DiscoverResult r = discover_on("discover_hysteresis", typical_hysteresis());
  EXPECT_EQ(r.verdict, "named");
  ASSERT_EQ(r.named, std::vector<std::string>{"hysteresis"});
  ASSERT_TRUE(r.refit.has_value());
  ASSERT_EQ(r.refit->parameters.effects.size(), 1u);  // params.yaml carries it
  // Confirmed on held-out specimens: fitted on one fold, evaluated on the other.
  const DiscoverHeldOut& h = candidate(r, "hysteresis").held_out;
  EXPECT_TRUE(h.evaluated);
  EXPECT_LT(h.with, 0.5 * h.without);
  std::printf("[measured] discover: held-out specimens %.2f %% without, %.2f %% with\n", 100 * h.without, 100 * h.with);
  // Each fold's fit is a resample of the specimens: it recorded the effect's parameters.
  ASSERT_EQ(h.folds.size(), 2u);
  for (size_t i = 0; i < h.folds[0].size(); ++i)
    std::printf("[measured] discover: %s %.4g, folds %.4g, %.4g\n", h.folds[0][i].name.c_str(),
                candidate(r, "hysteresis").effect->parameters[i].value, h.folds[0][i].value, h.folds[1][i].value);
  ASSERT_EQ(r.gap.size(), 3u);
  for (const DiscoverGap& g : r.gap) {
    // The excess over the floor shrinks at least min_excess_shrink-fold (its acceptance rule).
    EXPECT_GT(g.before - g.floor, DiscoverOptions{}.min_excess_shrink * std::max(g.after - g.floor, 0.0)) << g.test;
  }
  // The residual plots' rows: every run's whole path, with the effect within the noise.
  ASSERT_EQ(r.curves.size(), 9u);
  for (const FitEffectCurve& c : r.curves) {
    ASSERT_EQ(c.with_N.size(), c.measured_N.size()) << c.run;
    ASSERT_EQ(c.without_N.size(), c.measured_N.size()) << c.run;
    double worst_with = 0;
    for (size_t i = 0; i < c.measured_N.size(); ++i)
      worst_with = std::max(worst_with, std::abs(c.with_N[i] - c.measured_N[i]) / std::abs(c.measured_N[i]));
    EXPECT_LT(worst_with, 0.03) << c.test << " " << c.run;  // 0.5 % noise: six standard deviations
  }
  // Where the time went, step by step, in order.
  std::vector<std::string> steps;
  for (const auto& [step, seconds] : r.step_times) {
    steps.push_back(step);
    EXPECT_GE(seconds, 0.0) << step;
  }
  const std::vector<std::string> expected = {"baseline", "candidate hysteresis", "candidate curve-degree",
                                             "fold 1 baseline", "held-out check hysteresis fold 1", "fold 2 baseline",
                                             "held-out check hysteresis fold 2"};
  EXPECT_EQ(steps, expected);
  // Without an effect-fit stage in the protocol, or without cantilevers: untestable, never named.
  EXPECT_EQ(candidate(r, "bending-anisotropy").status, "untestable");
  EXPECT_EQ(candidate(r, "misalignment").status, "untestable");
  EXPECT_NE(candidate(r, "misalignment").reason.find("effect-fit stage"), std::string::npos);
  // A richer elastic curve cannot open the loop: it is no rival to the friction.
  EXPECT_EQ(candidate(r, kCurveDegreeCandidate).status, "rejected") << candidate(r, kCurveDegreeCandidate).reason;
}

// A richer elastic curve is a candidate of its own (discover.curve_degree): on data whose warp
// curve is degree 2 and no effect is on, the tiny protocol's degree-1 curves leave a misfit;
// one degree more explains it, and no effect may be named for it.
DiscoverResult discover_richer_curve(const std::string& name, const std::vector<std::string>& extra = {}) {
  ComponentChoice none = default_choice(registry_category::kEffect, "hysteresis");  // neutral: no friction
  MaterialParameters truth = truth_with(none);
  // Stiffening late (η1 takes Ẽ11², about 0.005 at 5 mm: η1' is 1.1 at 2.5 mm, 2.6 at 5 mm):
  // the best single power law misses the stress by 6 % on average.
  truth.eta1 = Curve{{0.9, 0.1}, {1.0, 600.0}};
  const std::vector<double> offsets = {0.0, 0.0, 0.0}, scales = {1.12, 0.93, 0.96};
  constexpr double kNoise = 0.005;
  const std::string folder = write_dataset(name, truth,
                                           {{"warp", 90, 300, up_and_down(), offsets, scales, kNoise, 1},
                                            {"weft", 0, 300, up_and_down(), offsets, scales, kNoise, 2},
                                            {"bias", 45, 300, up_and_down(), offsets, scales, kNoise, 3}});
  const FitProgress say = [](int, const std::string& line) { std::printf("  %s\n", line.c_str()); };
  DiscoverResult r = run_discover(read_dataset(folder), discover_config(extra), registry(), say);
  fs::remove_all(folder);
  for (const DiscoverCandidate& c : r.candidates)
    std::printf("[measured] discover %s: %s %s (%s)\n", name.c_str(), c.name.c_str(), c.status.c_str(), c.reason.c_str());
  return r;
}

TEST(Discover, ARicherCurveIsNotPassedOffAsPhysics) {
  const DiscoverResult r = discover_richer_curve("discover_richer_curve");
  EXPECT_TRUE(std::find(r.named.begin(), r.named.end(), "hysteresis") == r.named.end()) << r.verdict;
  const DiscoverCandidate& curve = candidate(r, kCurveDegreeCandidate);
  EXPECT_EQ(curve.status, "named") << curve.reason;
  // It holds on held-out specimens: the curves raised on one fold, judged on the other's rows
  // (hysteresis', the effect neutral) against that fold's baseline.
  EXPECT_TRUE(curve.held_out.evaluated) << curve.held_out.failure << curve.held_out.note;
  EXPECT_EQ(curve.held_out.held, kHeldSpecimens);
  EXPECT_LT(curve.held_out.with, 0.5 * curve.held_out.without);
  std::printf("[measured] discover richer curve: held-out specimens %.2f %% without, %.2f %% with\n",
              100 * curve.held_out.without, 100 * curve.held_out.with);
}

// fit_runs_error_at (curve-degree's held-out rows where it is measured on the fit runs): each
// run at its own best scale, so noise-free specimens of different scales read nothing at the
// truth, and a curve of the wrong shape reads its misfit, whatever its stiffness.
TEST(DiscoverHeldOutRows, FitRunsAtTheirOwnScalesReadNothingAtTheTruthAndTheShapesMisfit) {
  MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "hysteresis"));  // no friction
  truth.eta1 = Curve{{0.9, 0.1}, {1.0, 600.0}};  // ARicherCurveIsNotPassedOffAsPhysics' warp
  const std::vector<double> offsets = {0.0, 0.0}, scales = {1.12, 0.93};
  const std::string folder = write_dataset("held_out_rows", truth,
                                           {{"warp", 90, 300, up_and_down(), offsets, scales, 0.0, 1},
                                            {"weft", 0, 300, up_and_down(), offsets, scales, 0.0, 2}});
  const Dataset data = read_dataset(folder);
  fs::remove_all(folder);
  const double at_truth = fit_runs_error_at(data, discover_config(), registry(), truth, 0);
  MaterialParameters linear = truth;
  linear.eta1 = Curve::linear();
  linear.a11_Pa *= 1.3;  // the scales take the stiffness, not the shape
  const double misfit = fit_runs_error_at(data, discover_config(), registry(), linear, 0);
  std::printf("[measured] fit runs' error at their own scales: %.2e at the truth, %.2f %% with a linear warp\n", at_truth,
              100 * misfit);
  EXPECT_LT(at_truth, 1e-4);
  EXPECT_GT(misfit, 0.01);
}

// Screened at the coarse level (2x3), the named richer curves are raised again from the baseline
// at the finest (4x6) and measured there: params.yaml's curves and the gap are the finest
// level's, as a named effect's refit is (refit_curve_degree). Its held-out check is
// ARicherCurveIsNotPassedOffAsPhysics'; off here (it doubled this test's time).
TEST(Discover, ARicherCurveScreenedCoarseIsRefittedAtTheFinestLevel) {
  const DiscoverResult r = discover_richer_curve("discover_richer_curve_levels",
                                                 {"resolution.levels=2", "discover.screening_level=0", "discover.held_out=false"});
  ASSERT_EQ(r.named, std::vector<std::string>{kCurveDegreeCandidate}) << r.verdict;
  EXPECT_EQ(r.baseline.finest_level, 1);
  ASSERT_TRUE(r.refit.has_value());
  ASSERT_EQ(r.refit->effects.size(), 1u);
  const FitEffect& refit = r.refit->effects.front();
  EXPECT_EQ(refit.effect, kCurveDegreeCandidate);
  EXPECT_EQ(refit.resolution, r.baseline.finest_resolution);
  EXPECT_LT(refit.error_with, refit.error_without);
  for (const FitCurve& c : r.refit->fit) EXPECT_EQ(c.resolution, r.baseline.finest_resolution) << c.run;
  for (const std::string& note : r.notes) EXPECT_EQ(note.find("refit at the finest level failed"), std::string::npos) << note;
  std::printf("[measured] discover richer curve at two levels: %.2f %% -> %.2f %% at %s (screened %.2f %% -> %.2f %%)\n",
              100 * refit.error_without, 100 * refit.error_with, refit.resolution.c_str(),
              100 * candidate(r, kCurveDegreeCandidate).effect->error_without,
              100 * candidate(r, kCurveDegreeCandidate).effect->error_with);
}

// discover.screening_level: candidates and folds at the ladder's coarsest level (4x6), the named
// effect refitted from the baseline at its finest (8x12). Not in the suite: 8 min on this
// machine (the baseline's bias stage at 8x12 alone 2 min), over the suite's budget; run it with
//   build/tests/twill_fitting_tests --gtest_also_run_disabled_tests --gtest_filter='Discover.DISABLED_Screens*'
// Measured 2026-12-03 (8528a6c + this test, 471 s beside another fit): hysteresis named,
// 20.47 % → 0.33 % at 4x6 (held-out 16.92 → 0.36 %), refit at 8x12: warp / weft / bias 15.31 /
// 14.55 / 30.32 % → 0.33 / 0.34 / 0.31 %; curve-degree rejected (17.33 → 14.04 %). On 2x3 and
// 4x6 the baseline's bias stage fails at 4x6 ("residuals not finite at x0": the 2x3 fit's
// curve does not solve on the finer strip), with or without friction in the data.
TEST(Discover, DISABLED_ScreensAtTheCoarseLevelAndRefitsTheNamedEffectAtTheFinest) {
  // A third of the typical friction (the typical one was not tried at these levels).
  ComponentChoice weak = typical_hysteresis();
  weak.options.set("warp_friction_N_m", 50.0);
  weak.options.set("weft_friction_N_m", 30.0);
  weak.options.set("shear_friction_N_m", 7.0);
  const DiscoverResult r = discover_on("discover_screening", weak,
                                       {"resolution.coarse_cells_across=4", "resolution.levels=2",
                                        "discover.screening_level=0"});
  EXPECT_EQ(r.named, std::vector<std::string>{"hysteresis"}) << r.verdict;
  EXPECT_EQ(r.baseline.finest_level, 1);
  EXPECT_EQ(candidate(r, "hysteresis").effect->resolution, "4x6");
  ASSERT_TRUE(r.refit.has_value());
  ASSERT_FALSE(r.refit->effects.empty());
  EXPECT_EQ(r.refit->effects.front().resolution, "8x12");
}

// `twill discover` on typical friction hidden in `tests`, both loop effects in the protocol;
// prints each candidate's status and reason.
DiscoverResult discover_loops_on(const std::string& what, const std::vector<SyntheticTest>& tests) {
  std::string name = "discover_" + what;
  std::replace(name.begin(), name.end(), ' ', '_');
  const std::string folder = write_dataset(name, truth_with(typical_hysteresis()), tests);
  const Options config = discover_config(
      {"protocol=[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1},"
       " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1},"
       " {name: tensile-curve, label: bias, angle_deg: 45, term: eta4, max_degree: 1},"
       " {name: resolution-ladder}, {name: effect-fit, effect: hysteresis}, {name: effect-fit, effect: rate-dependence}]"});
  DiscoverResult r = run_discover(read_dataset(folder), config, registry(), {});
  fs::remove_all(folder);
  for (const DiscoverCandidate& c : r.candidates)
    std::printf("[measured] discover %s: %s %s (%s)\n", what.c_str(), c.name.c_str(), c.status.c_str(), c.reason.c_str());
  return r;
}

// Friction at two crosshead speeds (every test at 300 and 30 mm/min, two specimens each): the
// data that separate a friction loop from a rate loop. Hysteresis named; rate-dependence, if it
// passes alone, is held out by speed and must not stand beside the friction (its held-out check
// then uses the speed folds, whose scratch files once carried a '/' of "mm/min"). The specimen
// scales are gauged per curve: each speed's pair averages 1.02 and 0.96 (docs/fitting.md §3a).
// Measured 2026-12-04: hysteresis 33.68 % → 0.36 % (floor 0.37 %, held-out 29.33 → 0.36 %);
// rate-dependence rejected (33.68 % → 42.55 %: its excess does not shrink), so its speed folds
// are not reached here; the generated datasets of papers/discovery reach them.
TEST(Discover, NamesFrictionNotRateWhereTwoSpeedsSeparateThem) {
  const std::vector<double> offsets = {0.0, 0.0}, fast = {1.12, 0.93}, slow = {0.96, 1.05};
  constexpr double kNoise = 0.005;
  std::vector<SyntheticTest> tests;
  unsigned seed = 1;
  for (const auto& [label, angle] : std::vector<std::pair<std::string, double>>{{"warp", 90}, {"weft", 0}, {"bias", 45}}) {
    tests.push_back({label + "-300", angle, 300, up_and_down(), offsets, fast, kNoise, seed++});
    tests.push_back({label + "-30", angle, 30, up_and_down(), offsets, slow, kNoise, seed++});
  }
  const DiscoverResult r = discover_loops_on("two speeds", tests);
  EXPECT_EQ(r.verdict, "named");
  EXPECT_EQ(r.named, std::vector<std::string>{"hysteresis"});
  const DiscoverCandidate& rate = candidate(r, "rate-dependence");
  EXPECT_NE(rate.status, "failed") << rate.reason;
  if (rate.held_out.evaluated) {
    EXPECT_EQ(rate.held_out.held, kHeldSpeeds);
  }
}

// At one speed both loop effects explain friction's loops alone; the pairwise rule (each scored
// after the other in a joint refit, both orders) rejects the one that adds nothing beside the
// other before the held-out checks, so that one gets no check (rate-dependence's two folds were
// 250 s of the 75 mm five-specimen discover's 1164 s, session 30), and the refit the report
// keeps — params.yaml — holds the named effect alone (it held the pair's loser before).
TEST(Discover, ThePairwiseRuleComesBeforeTheHeldOutChecksAndTheRefitHoldsWhatIsNamed) {
  const std::vector<double> offsets = {0.0, 0.0}, scales = {1.12, 0.93};  // two specimens: the fewest folds need
  constexpr double kNoise = 0.005;
  std::vector<SyntheticTest> tests;
  unsigned seed = 1;
  for (const auto& [label, angle] : std::vector<std::pair<std::string, double>>{{"warp", 90}, {"weft", 0}, {"bias", 45}})
    tests.push_back({label, angle, 300, up_and_down(), offsets, scales, kNoise, seed++});
  const DiscoverResult r = discover_loops_on("pairwise", tests);
  for (const auto& [step, seconds] : r.step_times) std::printf("[measured] discover pairwise step: %s %.1f s\n", step.c_str(), seconds);
  ASSERT_TRUE(r.refit.has_value());
  std::vector<std::string> refitted;
  for (const FitEffect& e : r.refit->effects) refitted.push_back(e.effect);
  EXPECT_EQ(refitted, r.named);
  EXPECT_EQ(r.named, std::vector<std::string>{"hysteresis"});
  const DiscoverCandidate& rate = candidate(r, "rate-dependence");
  EXPECT_EQ(rate.status, "rejected");
  EXPECT_NE(rate.reason.find("after hysteresis in the joint refit"), std::string::npos) << rate.reason;
  EXPECT_FALSE(rate.held_out.evaluated);
  EXPECT_NE(rate.reason.find("the pairwise rule rejected it first"), std::string::npos) << rate.reason;
  EXPECT_TRUE(candidate(r, "hysteresis").held_out.evaluated);
}

TEST(Discover, NamesNothingWhereNothingIsHidden) {
  ComponentChoice none = default_choice(registry_category::kEffect, "hysteresis");  // neutral: no friction
  const DiscoverResult r = discover_on(
      "discover_null", none,
      {"protocol=[{name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 1},"
       " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 1},"
       " {name: tensile-curve, label: bias, angle_deg: 45, term: eta4, max_degree: 1},"
       " {name: resolution-ladder}, {name: effect-fit, effect: misalignment}, {name: effect-fit, effect: hysteresis},"
       " {name: final-curves}]"});
  EXPECT_TRUE(r.named.empty());
  EXPECT_EQ(r.verdict, "none");
  EXPECT_EQ(candidate(r, "hysteresis").status, "rejected");
  EXPECT_EQ(candidate(r, kCurveDegreeCandidate).status, "rejected");  // the linear truth needs no richer curve
  // Not even fitted: no test of hysteresis' rows is above 2× its floor (the smaller of the
  // effects' and the repeats'), so nothing could be named or unexplained (fit_candidates;
  // ARicherCurveIsNotPassedOffAsPhysics fits and names it where there is a misfit).
  EXPECT_FALSE(candidate(r, kCurveDegreeCandidate).effect.has_value());
  EXPECT_NE(candidate(r, kCurveDegreeCandidate).reason.find("not fitted"), std::string::npos);
  // Misalignment on the fit strips (no validation strips), judged on the fit runs' loading rows:
  // none above 2× its effects' floor, so it is not fitted either (largest_loading_misfit).
  EXPECT_EQ(candidate(r, "misalignment").status, "rejected");
  EXPECT_FALSE(candidate(r, "misalignment").effect.has_value());
  EXPECT_NE(candidate(r, "misalignment").reason.find("no test of its rows"), std::string::npos);
  EXPECT_FALSE(r.refit.has_value());
}

// The baseline's degree search aims at the repeats' scatter, test by test: warp's three
// specimens with 0.5 % noise (a floor measured at 0.22 %) lower its target_error to that
// floor, under the protocol's 1 %; the weft's single specimen has no floor, and the bias' 5 %
// noise (a floor of 2.50 %) is above the protocol's 2 %, so both keep theirs. Friction's null
// twin 1 named curve-degree over a warp left at 2× its repeats' scatter (papers/discovery,
// 2026-12-06). Its second pass (baseline_above_target) is taken when an angle's fit runs end
// above their target on average.
TEST(Discover, TheBaselineAimsItsDegreeSearchAtTheRepeatsScatter) {
  const std::vector<double> three = {0.0, 0.0, 0.0}, scales = {1.12, 0.93, 0.96};
  const MaterialParameters truth = truth_with(default_choice(registry_category::kEffect, "hysteresis"));
  const std::string folder = write_dataset("discover_aim", truth,
                                           {{"warp", 90, 300, up_and_down(), three, scales, 0.005, 1},
                                            {"weft", 0, 300, up_and_down(), {0.0}, {1.0}, 0.005, 2},
                                            {"bias", 45, 300, up_and_down(), three, scales, 0.05, 3}});
  const Dataset dataset = read_dataset(folder);
  fs::remove_all(folder);
  const std::map<std::string, double> floors = repeat_floors(dataset);
  ASSERT_EQ(floors.count("warp"), 1u);
  ASSERT_EQ(floors.count("bias"), 1u);
  std::printf("[measured] repeat floors: warp %.3f %%, bias %.3f %%\n", 100 * floors.at("warp"),
              100 * floors.at("bias"));
  std::vector<std::string> notes;
  const Options config = discover_config({"protocol[2].target_error=0.02"});
  const Options baseline = discover_baseline_config(dataset, config, registry(), &notes);
  const std::map<std::string, double> expected = {{"warp", floors.at("warp")}, {"weft", 0.01}, {"bias", 0.02}};
  ASSERT_GT(floors.at("bias"), 0.02);  // the premise: the bias' scatter is above its target
  for (const ComponentChoice& stage : baseline.get_component_list("protocol"))
    if (stage.name == "tensile-curve")
      EXPECT_DOUBLE_EQ(stage.options.get_double("target_error"), expected.at(stage.options.get_string("label")))
          << stage.options.get_string("label");
  const auto aim = std::find_if(notes.begin(), notes.end(),
                               [](const std::string& n) { return n.find("target_error") != std::string::npos; });
  ASSERT_NE(aim, notes.end());
  EXPECT_NE(aim->find("warp 1.00 → "), std::string::npos) << *aim;
  EXPECT_EQ(aim->find("weft"), std::string::npos) << *aim;
  // The second pass is taken when an angle's fit runs end above its target on average.
  FitReport report;
  const auto run = [](const std::string& label, double angle, double error) {
    FitCurve c;
    c.label = label;
    c.angle_deg = angle;
    c.role = "fit";
    c.avg_rel_error = error;
    return c;
  };
  const double warp = floors.at("warp");
  report.fit = {run("warp", 90, 0.5 * warp), run("warp", 90, 1.4 * warp), run("weft", 0, 0.009),
                run("bias", 45, 0.019)};
  EXPECT_EQ(baseline_above_target(report, baseline), "");  // warp's mean 0.95× its floor
  report.fit[1].avg_rel_error = 1.6 * warp;
  EXPECT_EQ(baseline_above_target(report, baseline).rfind("warp ", 0), 0u) << baseline_above_target(report, baseline);
  report.fit[1].avg_rel_error = warp;
  report.fit.push_back(run("bias", 45, 0.03));  // bias' mean 2.45 % against its 2 %
  EXPECT_EQ(baseline_above_target(report, baseline).rfind("bias ", 0), 0u) << baseline_above_target(report, baseline);
}

// The baseline sets each strain cutoff at 99 % of the largest strain its fit strips see, not at
// the paper's 95 % (§5.2 steps 4, 6): above the cutoff the law is its quadratic extrapolation
// (§3.2), which the top of a stiffening curve cannot follow. Measured on a null twin's weft
// (tests/data/datasets/null-twin-6, degree 2, no effect): 0.38 % at the curve stage; with the
// cutoff at 95 % the ladder's refit (converged) ends at 1.38 %, at 99 % at 0.37 %. On the twin
// of seed 8 the 95 % cutoffs read `unexplained at weft-300` (1.64 % against the repeats'
// 0.17 %); papers/discovery/README.md, session 36.
TEST(Discover, TheBaselineCutsOffNearTheLargestStrainItsStripsSee) {
  const Dataset dataset = read_dataset(std::string(TWILL_SOURCE_DIR) + "/tests/data/datasets/null-twin-6");
  const std::string curves =
      "{name: initial-guess}, {name: tensile-curve, label: warp, angle_deg: 90, term: eta1, max_degree: 2},"
      " {name: tensile-curve, label: weft, angle_deg: 0, term: eta3, max_degree: 2, target_error: 0.0026}";
  std::vector<std::string> notes;
  const Options baseline = discover_baseline_config(
      dataset,
      discover_config({"protocol=[" + curves +
                       ", {name: strain-cutoff, stage: warp, fraction: 1.0}, {name: strain-cutoff, stage: weft},"
                       " {name: resolution-ladder}]"}),
      registry(), &notes);
  int cutoffs = 0;
  for (const ComponentChoice& stage : baseline.get_component_list("protocol"))
    if (stage.name == "strain-cutoff") {
      EXPECT_EQ(stage.options.get_double("fraction"), stage.options.get_string("stage") == "warp" ? 1.0 : 0.99)
          << stage.options.get_string("stage");
      ++cutoffs;
    }
  EXPECT_EQ(cutoffs, 2);
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes.back().find("the config had weft 0.95)"), std::string::npos) << notes.back();

  // Why: the weft's error at the end of a fit with its cutoff at either fraction.
  const auto weft_error = [&](double fraction) {
    const Options config = discover_config(
        {"resolution.coarse_cells_across=4", "data.max_points=20", "repeats.rule=all", "repeats.scale=per-run",
         "protocol=[" + curves + ", {name: strain-cutoff, stage: weft, fraction: " + std::to_string(fraction) +
             "}, {name: resolution-ladder}]"});
    const FitReport report = run_fit(dataset, discover_fit_config(config), registry(), {});
    const auto last = std::find_if(report.stages.rbegin(), report.stages.rend(),
                                   [](const FitStageRecord& r) { return r.stage == "weft"; });
    return last == report.stages.rend() ? std::nan("") : last->avg_rel_error;  // the ladder's refit
  };
  const double paper = weft_error(0.95), data = weft_error(0.99);
  std::printf("[measured] weft after its cutoff: %.2f %% at 95 %% of the largest strain, %.2f %% at 99 %%\n",
              100 * paper, 100 * data);
  EXPECT_GT(paper, 2.5 * data);
  EXPECT_LT(data, 0.005);
}

}  // namespace
}  // namespace twill
