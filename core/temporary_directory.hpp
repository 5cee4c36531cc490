#pragma once
// A fresh private temporary directory (mkdtemp under the system's temporary folder), removed
// with everything in it when the object goes out of scope: scratch files twill creates itself
// (twill inspect's plot data, twill discover's held-out parameter files).
//
// A destructor does not run when the process is ended by a signal (Ctrl-C on a long discover,
// a batch system's SIGTERM). remove_temporary_directories_on_termination() covers that: main()
// calls it once, and an interrupted run removes its live scratch before it ends.
#include <string>

namespace twill {

class TemporaryDirectory {
 public:
  /// Throws std::runtime_error when the directory cannot be created.
  explicit TemporaryDirectory(const std::string& prefix);
  ~TemporaryDirectory();
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int slot_ = -1;  ///< its entry in the table the termination handler removes (−1: none)
};

/// Handlers for SIGINT, SIGTERM and SIGHUP that remove every live TemporaryDirectory and then
/// end the process by the same signal (its default action, so the parent sees how it ended).
/// A signal the process ignores (nohup's SIGHUP) stays ignored.
void remove_temporary_directories_on_termination();

}  // namespace twill
