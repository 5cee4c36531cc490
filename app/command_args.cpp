// Argument checks shared by the commands (commands.hpp): resolutions and physical quantities
// given on the command line are held to the same limits as datasets and configs
// (core/input_limits.hpp).
#include <cctype>
#include <charconv>

#include "app/commands.hpp"
#include "core/input_error.hpp"

namespace twill {

std::pair<int, int> parse_resolution(const std::string& text, const std::string& option) {
  const InputLocation where{"command line", 0, option};
  const auto x = text.find_first_of("xX");
  auto read = [&](const std::string& part, long long* value) {
    const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), *value);
    return !part.empty() && ec == std::errc() && end == part.data() + part.size();
  };
  long long across = 0, along = 0;
  if (x == std::string::npos || !read(text.substr(0, x), &across) || !read(text.substr(x + 1), &along) ||
      across < 1 || along < 1)
    throw InputError(where, "expected NxM (cells across x along, positive integers), e.g. 16x24; got '" +
                                excerpt(text) + "'");
  const std::string violation = mesh_size_violation(static_cast<double>(across), static_cast<double>(along));
  if (!violation.empty()) throw InputError(where, violation);
  return {static_cast<int>(across), static_cast<int>(along)};  // fits: the limit is far below INT_MAX cells
}

double checked_argument(double value, const PhysicalRange& range, const std::string& option) {
  const std::string violation = range_violation(value, range);
  if (!violation.empty()) throw InputError({"command line", 0, option}, violation);
  return value;
}

}  // namespace twill
