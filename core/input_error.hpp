#pragma once
// Errors in user input (datasets, parameter files, configs, command lines).
//
// Bad input throws InputError; broken internal invariants assert instead (style.md §5).
// The message always names where the problem is: file, line (1-based, 0 when unknown) and the
// key path (e.g. `tensile[2].width_mm`), so a researcher can go straight to it.
#include <stdexcept>
#include <string>

namespace twill {

struct InputLocation {
  std::string file;   ///< path as the user gave it (empty when not from a file)
  int line = 0;       ///< 1-based line; 0 when unknown
  std::string key;    ///< key path inside the file, e.g. `eta1.mu[0]`; empty for a whole row
};

class InputError : public std::runtime_error {
 public:
  InputError(InputLocation where, const std::string& what);
  const InputLocation& where() const { return where_; }
  /// The message without the location prefix.
  const std::string& reason() const { return reason_; }

 private:
  InputLocation where_;
  std::string reason_;
};

}  // namespace twill
