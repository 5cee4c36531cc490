// twill: fabric tests -> simulation-ready cloth parameters (Clyde, Teran & Tamstorf, SCA 2017).
//
// main() builds the one Registry, registers every module (app/program_registry.cpp), adds one subcommand per
// command_<name>.cpp, and turns errors into `twill: error: <message>` with an exit status:
// 0 success, 1 failure, 2 bad input (InputError or a malformed command line).
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <exception>
#include <iostream>

#include "app/commands.hpp"
#include "core/input_error.hpp"
#include "core/sparse_cholesky.hpp"
#include "core/temporary_directory.hpp"
#include "app/program_registry.hpp"

namespace {

// The scripts/ folder of the source tree this binary was built from. TWILL_SOURCE_DIR wins
// when the build defines it; otherwise this file's own path (CMake compiles it by absolute
// path) locates the tree.
std::filesystem::path scripts_dir() {
#ifdef TWILL_SOURCE_DIR
  return std::filesystem::path(TWILL_SOURCE_DIR) / "scripts";
#else
  return std::filesystem::path(__FILE__).parent_path().parent_path() / "scripts";
#endif
}

// twill parallelises with TBB (assembly, curves, points); OpenBLAS's own threads inside each
// CHOLMOD factorisation then oversubscribe the cores and spin (core/sparse_cholesky.hpp:
// measured 2x slower fits). One BLAS thread unless the environment chose a count.
void use_one_blas_thread() {
  if (std::getenv("OPENBLAS_NUM_THREADS") || std::getenv("OMP_NUM_THREADS")) return;
  twill::SparseCholesky::set_blas_threads(1);
}

}  // namespace

int main(int argc, char** argv) {
  use_one_blas_thread();
  twill::remove_temporary_directories_on_termination();  // an interrupted run leaves no scratch
  twill::Context context;
  context.scripts_dir = scripts_dir();
  CLI::App app{"twill: fabric tests -> simulation-ready cloth parameters\n"
               "(Clyde, Teran & Tamstorf, \"Modeling and data-driven parameter estimation for woven fabrics\", SCA 2017)",
               "twill"};
  try {
    twill::register_program(context.registry);

    app.set_version_flag("--version", std::string(TWILL_VERSION));
    app.require_subcommand(1);
    // ---- Commands: one line per command_<name>.cpp -------------------------------------------
    twill::add_list_command(app, context);
    twill::add_inspect_command(app, context);
    twill::add_simulate_command(app, context);
    twill::add_bench_command(app, context);
    twill::add_fit_command(app, context);
    twill::add_discover_command(app, context);
    twill::add_recover_command(app, context);
    twill::add_sweep_command(app, context);
    twill::add_report_command(app, context);
    // -----------------------------------------------------------------------------------------

    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "twill: error: " << e.what() << "\n(run 'twill --help' or 'twill <command> --help')\n";
    return 2;
  } catch (const twill::InputError& e) {
    std::cerr << "twill: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "twill: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
