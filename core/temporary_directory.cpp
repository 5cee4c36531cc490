#include "core/temporary_directory.hpp"

#include <signal.h>    // sigaction, raise
#include <stdlib.h>    // mkdtemp
#include <sys/wait.h>  // waitpid
#include <unistd.h>    // fork, execv, _exit

#include <array>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>

namespace twill {
namespace {

// The live directories, for a signal handler to remove. A handler may not allocate or lock, so
// the table is fixed and each entry is published by an atomic flag after its path is written.
// twill keeps at most two alive at once (a discover's scratch, a plot helper's); one beyond the
// table is still removed by its destructor, only not on a signal.
constexpr std::size_t kLiveSlots = 16;
constexpr std::size_t kPathCapacity = 4096;  // Linux's PATH_MAX, terminator included

struct LiveSlot {
  std::atomic<bool> used{false};
  char path[kPathCapacity] = {};
};

std::array<LiveSlot, kLiveSlots> live_slots;
std::mutex claim_mutex;  // directories are made from several threads (TBB tasks)

int claim_slot(const std::string& path) {
  if (path.size() >= kPathCapacity) return -1;
  std::lock_guard<std::mutex> lock(claim_mutex);
  for (std::size_t i = 0; i < live_slots.size(); ++i) {
    LiveSlot& slot = live_slots[i];
    if (slot.used.load(std::memory_order_acquire)) continue;
    std::memcpy(slot.path, path.c_str(), path.size() + 1);
    slot.used.store(true, std::memory_order_release);
    return static_cast<int>(i);
  }
  return -1;
}

// `rm -rf -- path` in a child: fork, execv and waitpid are async-signal-safe, walking a tree
// with <filesystem> is not.
void remove_tree_from_handler(char* path) {
  const pid_t child = fork();
  if (child == 0) {
    char rm[] = "rm", flags[] = "-rf", end_of_options[] = "--";
    char* argv[] = {rm, flags, end_of_options, path, nullptr};
    execv("/bin/rm", argv);
    _exit(127);
  }
  if (child < 0) return;
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
}

void on_termination(int signal_number) {
  const int saved_errno = errno;
  for (LiveSlot& slot : live_slots)
    if (slot.used.load(std::memory_order_acquire)) remove_tree_from_handler(slot.path);
  errno = saved_errno;
  struct sigaction default_action = {};
  default_action.sa_handler = SIG_DFL;
  sigemptyset(&default_action.sa_mask);
  sigaction(signal_number, &default_action, nullptr);
  raise(signal_number);  // delivered on return: the process ends as the signal says
}

}  // namespace

TemporaryDirectory::TemporaryDirectory(const std::string& prefix) {
  std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot create a temporary directory: " + std::string(std::strerror(errno)));
  path_ = pattern;
  slot_ = claim_slot(path_);
}

TemporaryDirectory::~TemporaryDirectory() {
  if (slot_ >= 0) live_slots[static_cast<std::size_t>(slot_)].used.store(false, std::memory_order_release);
  std::error_code ec;  // best effort: a leftover temp folder must not turn success into failure
  std::filesystem::remove_all(path_, ec);
}

void remove_temporary_directories_on_termination() {
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction current = {};
    if (sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
    struct sigaction action = {};
    action.sa_handler = on_termination;
    sigemptyset(&action.sa_mask);
    sigaction(signal_number, &action, nullptr);
  }
}

}  // namespace twill
