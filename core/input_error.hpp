#pragma once
// Errors in user input (datasets, parameter files, configs, command lines).
//
// Bad input throws InputError; broken internal invariants assert instead (style.md §5).
// The message always names where the problem is: file, line (1-based, 0 when unknown) and the
// key path (e.g. `tensile[2].width_mm`), so a researcher can go straight to it.
#include <cstddef>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace twill {

struct InputLocation {
  std::string file;   ///< path as the user gave it (empty when not from a file)
  int line = 0;       ///< 1-based line; 0 when unknown
  std::string key;    ///< key path inside the file, e.g. `eta1.mu[0]`; empty for a whole row
};

/// Where a config key was set (its file and line, or "--set"), for the error message.
using ConfigKeyLocator = std::function<InputLocation(const std::string& key_path)>;

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

/// Longest user text quoted whole in a message (bytes): a cell or a value longer than this is
/// cut, so a 10 MB cell is not echoed into the error; 80 is one terminal line.
constexpr std::size_t kMaxQuotedBytes = 80;

/// User text made safe to quote in a message: cut after kMaxQuotedBytes (with the full size
/// noted), and bytes that are not valid UTF-8 or are control characters written as `\xNN`.
std::string excerpt(std::string_view text);

/// Offset of the first byte of `text` that is not part of well-formed UTF-8 (RFC 3629: no
/// overlong forms, no surrogates, at most U+10FFFF), or std::string_view::npos when it all is.
std::size_t invalid_utf8_offset(std::string_view text);

}  // namespace twill
