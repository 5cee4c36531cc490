#include "core/input_error.hpp"

#include <cstdio>

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

std::size_t invalid_utf8_offset(std::string_view text) {
  const auto* s = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  std::size_t i = 0;
  while (i < n) {
    const unsigned char c = s[i];
    std::size_t length = 0;
    unsigned char lo = 0x80, hi = 0xBF;  // range of the second byte (RFC 3629 table, §4)
    if (c < 0x80) {
      ++i;
      continue;
    } else if (c >= 0xC2 && c <= 0xDF) {
      length = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      length = 3;
      if (c == 0xE0) lo = 0xA0;  // no overlong forms
      if (c == 0xED) hi = 0x9F;  // no UTF-16 surrogates
    } else if (c >= 0xF0 && c <= 0xF4) {
      length = 4;
      if (c == 0xF0) lo = 0x90;  // no overlong forms
      if (c == 0xF4) hi = 0x8F;  // at most U+10FFFF
    } else {
      return i;
    }
    if (i + length > n) return i;
    if (s[i + 1] < lo || s[i + 1] > hi) return i;
    for (std::size_t k = 2; k < length; ++k)
      if (s[i + k] < 0x80 || s[i + k] > 0xBF) return i;
    i += length;
  }
  return std::string_view::npos;
}

std::string excerpt(std::string_view text) {
  const std::string_view shown = text.substr(0, kMaxQuotedBytes);
  std::string out;
  std::size_t i = 0;
  while (i < shown.size()) {
    const std::size_t bad = invalid_utf8_offset(shown.substr(i));
    const std::size_t good = bad == std::string_view::npos ? shown.size() - i : bad;
    for (std::size_t k = i; k < i + good; ++k) {
      const auto c = static_cast<unsigned char>(shown[k]);
      if (c < 0x20 || c == 0x7F) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "\\x%02X", c);
        out += hex;
      } else {
        out += shown[k];
      }
    }
    i += good;
    if (i < shown.size()) {
      // A character cut at kMaxQuotedBytes looks invalid too; it is escaped like any other.
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", static_cast<unsigned char>(shown[i]));
      out += hex;
      ++i;
    }
  }
  if (text.size() > shown.size()) out += "… (" + std::to_string(text.size()) + " bytes)";
  return out;
}

}  // namespace twill
