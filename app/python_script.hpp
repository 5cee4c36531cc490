#pragma once
// Running the plot helpers in scripts/ (scripts take paths from arguments, style.md 11).
#include <string>
#include <vector>

#include "app/commands.hpp"

namespace twill {

/// Runs `context.python context.scripts_dir/<script> args...` and waits for it. Throws
/// std::runtime_error naming the problem when python or the script is missing, when
/// matplotlib is not importable (the scripts exit with status 3 then), or when the script
/// fails. The script's own stderr goes to the terminal.
void run_python_script(const Context& context, const std::string& script, const std::vector<std::string>& args);

/// A fresh private temporary directory (mkdtemp), removed when the object goes out of scope.
class TemporaryDirectory {
 public:
  explicit TemporaryDirectory(const std::string& prefix);
  ~TemporaryDirectory();
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory& operator=(const TemporaryDirectory&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace twill
