// MPI messages through the run-time plugin (study/mpi_transport.hpp).
#include "study/mpi_transport.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace twill {
namespace {

// The plugin's file name, next to the program (study/mpi_shim/CMakeLists.txt).
constexpr const char* kPluginFile = "twill_mpi_shim.so";

// Each launcher's variable for the number of ranks: Open MPI, PMIx (Open MPI 5, Slurm's
// srun --mpi=pmix), PMI-1/2 (MPICH, Slurm's srun --mpi=pmi2).
constexpr const char* kWorldSizeVariables[] = {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"};

template <typename F>
F symbol(void* library, const char* name, const std::string& file) {
  void* address = dlsym(library, name);
  if (!address) throw std::runtime_error("the MPI plugin " + file + " lacks " + name + " (rebuild twill)");
  return reinterpret_cast<F>(address);
}

}  // namespace

bool launched_by_mpi() {
  for (const char* name : kWorldSizeVariables)
    if (const char* value = std::getenv(name)) return std::atoi(value) > 1;
  return false;
}

struct MpiTransport::Plugin {
  void* library = nullptr;
  int (*init)(int*, int*) = nullptr;
  int (*send)(const char*, int, int, int) = nullptr;
  int (*poll)(int*, int*, int*) = nullptr;
  int (*receive)(char*, int, int, int) = nullptr;
  void (*abort)(int) = nullptr;
  int (*finalize)() = nullptr;
};

MpiTransport::MpiTransport() {
  const std::string file = (std::filesystem::read_symlink("/proc/self/exe").parent_path() / kPluginFile).string();
  void* library = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND);
  if (!library)
    throw std::runtime_error("twill sweep was started by an MPI launcher but cannot load its MPI plugin: " +
                             std::string(dlerror()));
  plugin_ = std::make_unique<Plugin>(Plugin{
      library,
      symbol<int (*)(int*, int*)>(library, "twill_mpi_init", file),
      symbol<int (*)(const char*, int, int, int)>(library, "twill_mpi_send", file),
      symbol<int (*)(int*, int*, int*)>(library, "twill_mpi_poll", file),
      symbol<int (*)(char*, int, int, int)>(library, "twill_mpi_receive", file),
      symbol<void (*)(int)>(library, "twill_mpi_abort", file),
      symbol<int (*)()>(library, "twill_mpi_finalize", file)});
  if (plugin_->init(&rank_, &size_) != 0) throw std::runtime_error("MPI_Init failed (through " + file + ")");
}

// The library stays loaded: Open MPI cannot be initialised twice in one process anyway.
MpiTransport::~MpiTransport() { plugin_->finalize(); }

void MpiTransport::send(int destination, int tag, const std::string& bytes) const {
  if (plugin_->send(bytes.data(), static_cast<int>(bytes.size()), destination, tag) != 0)
    throw std::runtime_error("MPI: sending to rank " + std::to_string(destination) + " failed");
}

std::optional<MpiMessage> MpiTransport::poll() const {
  MpiMessage m;
  int count = 0;
  const int waiting = plugin_->poll(&m.source, &m.tag, &count);
  if (waiting < 0) throw std::runtime_error("MPI: probing for messages failed");
  if (waiting == 0) return std::nullopt;
  m.bytes.resize(static_cast<size_t>(count));
  if (plugin_->receive(m.bytes.data(), count, m.source, m.tag) != 0)
    throw std::runtime_error("MPI: receiving from rank " + std::to_string(m.source) + " failed");
  return m;
}

void MpiTransport::abort(int code) const {
  plugin_->abort(code);
  std::abort();
}

}  // namespace twill
