#include "core/input_error.hpp"

namespace twill {
namespace {
std::string format_message(const InputLocation& where, const std::string& what) {
  std::string message = where.file.empty() ? std::string("input") : where.file;
  if (where.line > 0) message.append(":").append(std::to_string(where.line));
  if (!where.key.empty()) message.append(": key '").append(where.key).append("'");
  message.append(": ").append(what);
  return message;
}
}  // namespace

InputError::InputError(InputLocation where, const std::string& what)
    : std::runtime_error(format_message(where, what)), where_(std::move(where)), reason_(what) {}

}  // namespace twill
