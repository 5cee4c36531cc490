#include "app/python_script.hpp"

#include <dlfcn.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace twill {
namespace {

// The process's environment, without naming `environ`: a reference from the program would
// copy-relocate it into the executable, and the MPI plugin (loaded RTLD_DEEPBIND by
// study/mpi_transport.cpp) would then bind Open MPI to libc's stale original, whose setenv
// frees pointers it never allocated (an abort in MPI_Init under mpirun).
char** current_environment() { return *static_cast<char***>(dlsym(RTLD_DEFAULT, "environ")); }

// The exit status the scripts use for "matplotlib cannot be imported".
constexpr int kMissingMatplotlib = 3;

}  // namespace

void run_python_script(const Context& context, const std::string& script, const std::vector<std::string>& args) {
  const std::filesystem::path script_path = context.scripts_dir / script;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(script_path, ec))
    throw std::runtime_error("plot script not found: " + script_path.string() +
                             " (twill looks in the scripts/ folder of the source tree it was built from)");
  if (access(context.python.c_str(), X_OK) != 0)
    throw std::runtime_error("cannot run " + context.python + ": " + std::strerror(errno) +
                             " (plots need Debian's python3 with python3-matplotlib)");

  std::vector<std::string> argv_strings = {context.python, script_path.string()};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& s : argv_strings) argv.push_back(s.data());
  argv.push_back(nullptr);

  // posix_spawn, not std::system: no shell, so paths with spaces or quotes need no escaping.
  pid_t pid = 0;
  const int spawn_error = posix_spawn(&pid, context.python.c_str(), nullptr, nullptr, argv.data(), current_environment());
  if (spawn_error != 0)
    throw std::runtime_error("cannot start " + context.python + ": " + std::strerror(spawn_error));
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error(std::string("waiting for the plot script: ") + std::strerror(errno));
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
  if (WIFEXITED(status) && WEXITSTATUS(status) == kMissingMatplotlib)
    throw std::runtime_error("matplotlib is not importable by " + context.python +
                             " (install python3-matplotlib: apt-get install python3-matplotlib)");
  const std::string how = WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                            : "signal " + std::to_string(WTERMSIG(status));
  throw std::runtime_error(script + " failed (" + how + "); its messages are above");
}

}  // namespace twill
