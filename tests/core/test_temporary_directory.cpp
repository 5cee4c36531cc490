// core/temporary_directory.hpp: scratch removed at scope exit, and by the termination handlers
// when the process is ended by a signal (an interrupted `twill discover` left its scratch in
// /tmp before). The signal cases run in a forked child, which the parent signals and reaps.
#include "core/temporary_directory.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {

// A child that makes a scratch directory with a file in it, reports its path on a pipe and
// waits to be signalled; returns the child's pid and the path.
std::pair<pid_t, std::string> child_holding_scratch(bool install_handlers) {
  int channel[2];
  if (pipe(channel) != 0) return {-1, ""};
  const pid_t child = fork();
  if (child == 0) {
    close(channel[0]);
    for (const int s : {SIGINT, SIGTERM, SIGHUP}) signal(s, SIG_DFL);  // not nohup's inheritance
    if (install_handlers) twill::remove_temporary_directories_on_termination();
    twill::TemporaryDirectory scratch("twill-test-signal-");
    std::ofstream(fs::path(scratch.path()) / "params.yaml") << "tau: 1\n";
    const std::string path = scratch.path() + "\n";
    if (write(channel[1], path.data(), path.size()) != static_cast<ssize_t>(path.size())) _exit(3);
    for (;;) pause();
  }
  close(channel[1]);
  std::string path;
  char c = 0;
  while (read(channel[0], &c, 1) == 1 && c != '\n') path += c;
  close(channel[0]);
  return {child, path};
}

int terminating_signal(pid_t child) {
  int status = 0;
  if (waitpid(child, &status, 0) != child) return -1;
  return WIFSIGNALED(status) ? WTERMSIG(status) : 0;
}

}  // namespace

TEST(TemporaryDirectory, IsRemovedWithItsFilesAtScopeExit) {
  std::string path;
  {
    twill::TemporaryDirectory scratch("twill-test-scope-");
    path = scratch.path();
    std::ofstream(fs::path(path) / "a.yaml") << "x: 1\n";
    ASSERT_TRUE(fs::is_directory(path));
  }
  EXPECT_FALSE(fs::exists(path));
}

TEST(TemporaryDirectory, ASignalThatEndsTheProcessRemovesTheLiveScratchFirst) {
  for (const int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
    const auto [child, path] = child_holding_scratch(true);
    ASSERT_GT(child, 0);
    ASSERT_TRUE(fs::is_directory(path)) << path;
    kill(child, signal_number);
    EXPECT_EQ(terminating_signal(child), signal_number) << "the child ends by the signal it got";
    EXPECT_FALSE(fs::exists(path)) << strsignal(signal_number) << " left " << path;
  }
}

TEST(TemporaryDirectory, WithoutTheHandlersASignalLeavesTheScratch) {
  // The control: what the handlers are for (the child's destructor never runs).
  const auto [child, path] = child_holding_scratch(false);
  ASSERT_GT(child, 0);
  kill(child, SIGTERM);
  EXPECT_EQ(terminating_signal(child), SIGTERM);
  EXPECT_TRUE(fs::exists(path));
  fs::remove_all(path);
}
