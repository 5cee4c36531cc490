#pragma once
// Running the plot helpers in scripts/ (scripts take paths from arguments, style.md 11).
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "core/temporary_directory.hpp"  // TemporaryDirectory, which the plot helpers use

namespace twill {

/// Runs `context.python context.scripts_dir/<script> args...` and waits for it. Throws
/// std::runtime_error naming the problem when python or the script is missing, when
/// matplotlib is not importable (the scripts exit with status 3 then), or when the script
/// fails. The script's own stderr goes to the terminal.
void run_python_script(const Context& context, const std::string& script, const std::vector<std::string>& args);

}  // namespace twill
