// `twill recover --test warp|bias --degree N --optimizer NAME [--set KEY=VALUE] [--json]`:
// one parameter-recovery run (fitting/recovery_study.hpp): data simulated from known
// parameters, fitted back from a perturbed start. papers/optimizer_comparison runs it for every
// optimiser, test and degree and writes the README's comparison table.
#include <fmt/format.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "app/commands.hpp"
#include "core/params_io.hpp"
#include "fitting/recovery_study.hpp"

namespace twill {

void add_recover_command(CLI::App& app, Context& context) {
  struct Args {
    RecoveryCase c;
    std::string params, resolution = "4x6";
    bool json = false;
  };
  auto args = std::make_shared<Args>();
  CLI::App* cmd = app.add_subcommand("recover", "fit simulated tensile data back to known parameters (optimiser study)");
  cmd->add_option("--params", args->params, "base material (params.yaml); default: the canvas reference")->required();
  cmd->add_option("--test", args->c.test, "warp (a11, eta1) or bias (G12, eta4)")->check(CLI::IsMember({"warp", "bias"}));
  cmd->add_option("--degree", args->c.degree, "degree of the true curve")->check(CLI::Range(1, 3));
  cmd->add_option("--optimizer", args->c.optimizer, "registered optimiser (twill list)");
  cmd->add_option("--set", args->c.optimizer_overrides, "optimiser option KEY=VALUE (repeatable)");
  cmd->add_option("--discretization", args->c.discretization, "registered discretization");
  cmd->add_option("--resolution", args->resolution, "cells across x along, e.g. 4x6");
  cmd->add_option("--points", args->c.points, "data points")->check(CLI::Range(2, 200));
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->callback([&context, args] {
    if (std::sscanf(args->resolution.c_str(), "%dx%d", &args->c.cells_across, &args->c.cells_along) != 2)
      throw InputError({"--resolution", 0, "resolution"}, "expected NxM, got '" + args->resolution + "'");
    const RecoveryResult r = run_recovery(args->c, read_params_file(args->params, &context.registry), context.registry);
    if (args->json) {
      nlohmann::json j = {{"test", args->c.test}, {"degree", args->c.degree}, {"optimizer", args->c.optimizer},
                          {"resolution", args->resolution}, {"status", r.status}, {"message", r.message},
                          {"iterations", r.iterations}, {"evaluations", r.evaluations},
                          {"equilibrium_solves", r.equilibrium_solves}, {"wall_time_s", r.wall_time_s},
                          {"stiffness_error", r.stiffness_error}, {"curve_error", r.curve_error},
                          {"final_value", r.final_value}};
      std::cout << j.dump() << "\n";
    } else {
      std::cout << fmt::format("{} degree {} {}: {} ({}), {} iterations, {} evaluations, {} solves, {:.2f} s, "
                               "stiffness error {:+.2e}, curve error {:.2e}\n",
                               args->c.test, args->c.degree, args->c.optimizer, r.status, r.message, r.iterations,
                               r.evaluations, r.equilibrium_solves, r.wall_time_s, r.stiffness_error, r.curve_error);
    }
  });
}

}  // namespace twill
