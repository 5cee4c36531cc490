#include "fitting/fit_config.hpp"

#include "core/option_binding.hpp"
#include "core/registry.hpp"

namespace twill {
namespace {

OptionBindings<FitStopping> stopping_bindings() {
  using S = FitStopping;
  return {
      integer_option<S>("max_iterations", &S::max_iterations, "iterations per stage at the coarsest level",
                        at_least(1)),
      integer_option<S>("refine_max_iterations", &S::refine_max_iterations,
                        "iterations per stage at each refit of the resolution ladder (it starts at an optimum)",
                        at_least(1)),
      integer_option<S>("max_evaluations", &S::max_evaluations, "objective evaluations per stage and resolution",
                        at_least(1)),
      real_option<S>("gradient_tolerance", &S::gradient_tolerance, "projected-gradient inf-norm in scaled unknowns",
                     at_least(0.0)),
      real_option<S>("function_tolerance", &S::function_tolerance, "relative change of the objective per iteration",
                     at_least(0.0)),
      // A finer level starts at the coarser optimum and only corrects the discretisation change:
      // measured (canvas, Gauss–Newton, 32×48 warp) ε went 1.8103e-4 → 1.3491e-4 in one iteration,
      // then 3 more iterations and 12 rejected trials (14 of 16 curve evaluations, 30 s) moved
      // it by 1e-4 relative, i.e. the average error by ~5e-5 of itself. Tried and rejected
      // (2026-12-02): 1 %. With Gauss–Newton it is safe (canvas 132 → 117 s, τ·G12 moves by
      // 1.2e-4, fit errors unchanged), but a BFGS iteration can change ε by less than 1 % long
      // before it converges: canvas/bfgs stopped its refits early (weft 1.79 % instead of 1.37 %,
      // bias 0.65 % instead of 0.43 %, τ·G12 +5.04 %). The relative change of ε is not an
      // optimiser-independent convergence measure.
      real_option<S>("refine_function_tolerance", &S::refine_function_tolerance,
                     "relative change of the objective per iteration at each refit of the ladder", at_least(0.0)),
  };
}

OptionBindings<FitRepeats> repeats_bindings() {
  using S = FitRepeats;
  return {enum_option<S>("rule", &S::rule, repeat_rule_names(),
                         "paper: largest forces for warp/weft, one random run for others; largest-or-all: every run for "
                         "others"),
          integer_option<S>("seed", &S::seed, "seed of the random choice", at_least(0)),
          enum_option<S>("scale", &S::scale,
                         {{"none", SpecimenScale::None}, {"per-run", SpecimenScale::PerRun}},
                         "per-run: each fit run's forces times its own scale, a test's scales with geometric "
                         "mean 1 (the repeat scatter; matters where a rule fits several runs: all, largest-or-all)")};
}

OptionBindings<FitDataSelection> data_bindings() {
  using S = FitDataSelection;
  return {integer_option<S>("max_points", &S::max_points, "at most this many points per run, evenly spread",
                            at_least(2)),
          real_option<S>("min_force_fraction", &S::min_force_fraction,
                         "drop points below this fraction of the run's peak force (slack, noise)", in_range(0.0, 0.9))};
}

OptionBindings<FitResolution> resolution_bindings() {
  using S = FitResolution;
  return {integer_option<S>("coarse_cells_across", &S::coarse_cells_across,
                            "cells across the strip width at the coarsest level", at_least(1)),
          integer_option<S>("levels", &S::levels, "levels, each doubling the cells (8x12 -> 16x24 -> 32x48)",
                            in_range(1, 5))};
}

OptionBindings<FitSolver> solver_bindings() {
  using S = FitSolver;
  return {real_option<S>("gradient_tolerance", &S::gradient_tolerance, "Newton stops at |g_f| <= this * force scale",
                         greater_than(0.0))};
}

const char* const kPaperProtocolSource = "the default protocol (fitting/protocols/paper.yaml)";

}  // namespace

bool FitStopping::validate(std::string* error) const { return check_options(stopping_bindings(), *this, error); }
bool FitRepeats::validate(std::string* error) const { return check_options(repeats_bindings(), *this, error); }
bool FitDataSelection::validate(std::string* error) const { return check_options(data_bindings(), *this, error); }
bool FitResolution::validate(std::string* error) const { return check_options(resolution_bindings(), *this, error); }
bool FitSolver::validate(std::string* error) const { return check_options(solver_bindings(), *this, error); }

const char* paper_protocol_yaml() {
  static const char* const text =
#include "fitting/paper_protocol.inc"
      ;
  return text;
}

OptionSchema fit_config_schema() {
  OptionSchema s;
  s.add_component("discretization", registry_category::kDiscretization, "catmull-clark-kl",
                  "shell discretisation of every simulated test");
  // Default Gauss–Newton: Eq. 3 is a sum of squared relative residuals with an exact Jacobian
  // (core/fit_objective), and on the example datasets GN took 3–12 iterations per stage where
  // BFGS and Ipopt hit the limits (papers/optimizer_comparison, papers/fit_examples).
  s.add_component("optimizer", registry_category::kOptimizer, "gauss-newton",
                  "minimiser of the fit objective (paper Eq. 3) in every stage");
  s.add_component_list("effects", registry_category::kEffect,
                       "the model's effects, estimated by the fit and written to params.yaml (twill list effect)");
  OptionSchema& experiments = s.add_section("experiments", "the simulated tests the stages fit (twill list experiment)");
  experiments.add_component("tensile", registry_category::kExperiment, "tensile",
                            "experiment of every fitted tensile run (width, gauge length: each test's; cells: the "
                            "resolution levels)");
  experiments.add_component("bend", registry_category::kExperiment, "bend",
                            "experiment of the bend stage (width: each test's; its cells are its own)");
  s.add_section("stopping", "the optimiser's limits in every stage, applied to its common options") =
      option_schema(stopping_bindings());
  OptionSchema& uniform = s.add_section("uniform_strain", "the uniform-strain model of a strip (paper §5.3)");
  uniform.add_component("optimizer", registry_category::kOptimizer, "gauss-newton",
                        "optimiser of the uniform-strain fits (initial guess, degree-raise starts; the stages' limits)");
  s.add_section("repeats", "which repeated runs are fitted (paper §6.4)") = option_schema(repeats_bindings());
  s.add_section("data", "measured points used in the objective") = option_schema(data_bindings());
  s.add_section("resolution", "the levels of the multiresolution scheme (paper §5.5.4)") =
      option_schema(resolution_bindings());
  s.add_section("solver", "quasistatic equilibrium (paper §6.1)") = option_schema(solver_bindings());
  s.add_component_list("protocol", registry_category::kStage,
                       "the stages, run in order (twill list stage; default: the paper's)")
      .non_empty()
      .default_items(paper_protocol_yaml(), kPaperProtocolSource);
  return s;
}

std::string moved_key_hint(const std::string& key_path) {
  static const std::vector<std::pair<std::string, std::string>> moved = {
      {"degree", "the tensile-curve stages' max_degree, target_error, min_improvement, raise_attempts "
                 "(protocol[*].max_degree=...)"},
      {"stages", "stages are the protocol's entries: remove a strain-cutoff, bend or validation entry to skip it; "
                 "cutoff_fraction is the strain-cutoff stages' fraction"},
      {"bend", "experiments.bend.cells_across, experiments.bend.cells_along, and the bend stage's find_overhang "
               "(protocol[*].find_overhang=...)"},
      {"validation", "the validation stage's max_offset_deg, offset_iterations, offset_resolution_deg"},
      {"initial_guess", "uniform_strain.optimizer; remove the initial-guess entry of protocol to skip it "
                        "(and set protocol[*].uniform_starts=false for the old enabled: false)"},
      {"resolution.change_tolerance", "the resolution-ladder stage's change_tolerance"},
      {"resolution.extra_levels", "the resolution-ladder stage's extra_levels"},
  };
  for (const auto& [old_key, now] : moved)
    if (key_path == old_key || key_path.rfind(old_key + ".", 0) == 0)
      return "'" + old_key + "' moved (the protocol is a list of stages, twill fit --print-config): " + now;
  return {};
}

FitConfig read_fit_config(const Options& resolved) {
  FitConfig c;
  c.discretization = resolved.get_component("discretization");
  c.optimizer = resolved.get_component("optimizer");
  c.effects = resolved.get_component_list("effects");
  const Options& experiments = resolved.get_section("experiments");
  c.tensile_experiment = experiments.get_component("tensile");
  c.bend_experiment = experiments.get_component("bend");
  c.stopping = options_from(stopping_bindings(), resolved.get_section("stopping"), "stopping");
  c.uniform_strain_optimizer = resolved.get_section("uniform_strain").get_component("optimizer");
  c.repeats = options_from(repeats_bindings(), resolved.get_section("repeats"), "repeats");
  c.data = options_from(data_bindings(), resolved.get_section("data"), "data");
  c.resolution = options_from(resolution_bindings(), resolved.get_section("resolution"), "resolution");
  c.solver = options_from(solver_bindings(), resolved.get_section("solver"), "solver");
  c.protocol = resolved.get_component_list("protocol");
  return c;
}

}  // namespace twill
