#include "core/yaml_reader.hpp"

#include <cassert>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace twill {
namespace {

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t");
  if (begin == std::string::npos) return {};
  const auto end = s.find_last_not_of(" \t");
  return s.substr(begin, end - begin + 1);
}

// Parses the whole of `text` as a decimal number with std::from_chars: locale independent,
// correctly rounded (so written-then-read doubles are bit-exact), and strict (no trailing
// junk). yaml-cpp's own conversion goes through a stringstream with base detection, which
// would read the integer "010" as octal 8.
template <typename T>
std::optional<T> parse_number(const std::string& raw) {
  std::string text = trim(raw);
  if (!text.empty() && text.front() == '+') text.erase(0, 1);
  if (text.empty()) return std::nullopt;
  T value{};
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto [end, ec] = std::from_chars(first, last, value);
  if (ec != std::errc() || end != last) return std::nullopt;
  return value;
}

}  // namespace

YamlValue::YamlValue(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {}

int YamlValue::line() const {
  if (!node_.IsDefined()) return 0;
  if (node_.IsNull() && key_line_ > 0) return key_line_;
  const int zero_based = node_.Mark().line;
  return zero_based < 0 ? 0 : zero_based + 1;
}

InputError YamlValue::error(const std::string& what) const { return InputError(location(), what); }

bool YamlValue::is_null() const { return !node_.IsDefined() || node_.IsNull(); }

std::string YamlValue::describe() const {
  if (is_null()) return "an empty value (null)";
  if (node_.IsSequence()) return "a list";
  if (node_.IsMap()) return "a mapping";
  return "'" + excerpt(node_.Scalar()) + "'";
}

double YamlValue::as_double() const {
  if (!node_.IsScalar()) throw error("expected a number, got " + describe());
  const auto value = parse_number<double>(node_.Scalar());
  if (!value) throw error("expected a number, got " + describe());
  if (!std::isfinite(*value)) throw error("expected a finite number, got " + describe());
  return *value;
}

std::optional<double> YamlValue::as_optional_double() const {
  if (is_null()) return std::nullopt;
  if (!node_.IsScalar()) throw error("expected a number or null, got " + describe());
  const auto value = parse_number<double>(node_.Scalar());
  if (!value || !std::isfinite(*value))
    throw error("expected a number or null, got " + describe());
  return *value;
}

std::int64_t YamlValue::as_int() const {
  if (!node_.IsScalar()) throw error("expected an integer, got " + describe());
  const auto value = parse_number<std::int64_t>(node_.Scalar());
  if (!value) throw error("expected an integer, got " + describe());
  return *value;
}

bool YamlValue::as_bool() const {
  bool value = false;
  if (!node_.IsScalar() || !YAML::convert<bool>::decode(node_, value))
    throw error("expected true or false, got " + describe());
  return value;
}

std::string YamlValue::as_string() const {
  if (!node_.IsScalar()) throw error("expected a text value, got " + describe());
  // Checked here, where it is read: text flows into file names, reports and JSON, whose
  // writers reject invalid UTF-8 (only after a whole fit, before this check).
  const std::size_t bad = invalid_utf8_offset(node_.Scalar());
  if (bad != std::string_view::npos)
    throw error("not valid UTF-8 text (byte " + std::to_string(bad + 1) + " of '" + excerpt(node_.Scalar()) +
                "'); save the file as UTF-8");
  return node_.Scalar();
}

std::vector<YamlValue> YamlValue::items() const {
  if (!node_.IsSequence()) throw error("expected a list, got " + describe());
  std::vector<YamlValue> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i)
    out.emplace_back(node_[i], file_, path_ + "[" + std::to_string(i) + "]");
  return out;
}

std::vector<double> YamlValue::as_double_list() const {
  std::vector<double> out;
  for (const auto& item : items()) out.push_back(item.as_double());
  return out;
}

std::vector<std::string> YamlValue::as_string_list() const {
  std::vector<std::string> out;
  for (const auto& item : items()) out.push_back(item.as_string());
  return out;
}

YamlMap::YamlMap(const YamlValue& value) : value_(value) {
  if (!value.is_map()) throw value.error("expected a mapping (key: value lines), got " + value.describe());
  const YAML::Node& node = value.node();
  for (auto it = node.begin(); it != node.end(); ++it) {
    const YamlValue key_node(it->first, value.file(), value.path());
    if (!it->first.IsScalar()) throw key_node.error("a key must be plain text, got " + key_node.describe());
    const std::string key = it->first.Scalar();
    if (invalid_utf8_offset(key) != std::string_view::npos)
      throw key_node.error("a key must be valid UTF-8 text, got '" + excerpt(key) + "'");
    for (std::size_t i = 0; i < keys_in_order_.size(); ++i) {
      if (keys_in_order_[i] == key)
        throw InputError({value.file(), key_node.line(), child_path(key)},
                         "duplicate key (first given on line " + std::to_string(key_lines_[i]) + ")");
    }
    keys_in_order_.push_back(key);
    key_lines_.push_back(key_node.line());
  }
}

std::string YamlMap::child_path(const std::string& key) const { return join_key_path(value_.path(), key); }

bool YamlMap::has(const std::string& key) {
  known_.insert(key);
  for (const auto& k : keys_in_order_)
    if (k == key) return true;
  return false;
}

std::optional<YamlValue> YamlMap::find(const std::string& key) {
  if (!has(key)) return std::nullopt;
  const YAML::Node& node = value_.node();
  YamlValue found(node[key], value_.file(), child_path(key));
  for (std::size_t i = 0; i < keys_in_order_.size(); ++i)
    if (keys_in_order_[i] == key) found.set_key_line(key_lines_[i]);
  return found;
}

YamlValue YamlMap::get(const std::string& key) {
  auto found = find(key);
  if (!found) throw InputError({value_.file(), value_.line(), child_path(key)}, "missing required key");
  return *found;
}

void YamlMap::expect(const std::vector<std::string>& keys) {
  known_.insert(keys.begin(), keys.end());
  finish();
}

void YamlMap::finish() const {
  for (std::size_t i = 0; i < keys_in_order_.size(); ++i) {
    if (known_.count(keys_in_order_[i])) continue;
    std::string known;
    for (const auto& k : known_) known += (known.empty() ? "" : ", ") + k;
    throw InputError({value_.file(), key_lines_[i], child_path(keys_in_order_[i])},
                     "unknown key (known keys here: " + known + ")");
  }
}

YamlValue load_yaml_string(const std::string& text, const std::string& source_name) {
  try {
    return YamlValue(YAML::Load(text), source_name, "");
  } catch (const YAML::Exception& e) {
    const int line = e.mark.line < 0 ? 0 : e.mark.line + 1;
    throw InputError({source_name, line, ""}, "YAML syntax error: " + e.msg);
  }
}

YamlValue load_yaml_file(const std::string& path) {
  check_readable_file(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError({path, 0, ""}, "cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  return load_yaml_string(text.str(), path);
}

void check_readable_file(const std::string& path, const InputLocation& listed_at) {
  namespace fs = std::filesystem;
  // Where the message points: the file itself, or the line of the file that names it.
  auto fail = [&](const std::string& what) {
    if (listed_at.file.empty()) throw InputError({path, 0, ""}, what);
    throw InputError(listed_at, what + ": " + path);
  };
  std::error_code ec;
  const fs::file_status link = fs::symlink_status(path, ec);
  if (ec || !fs::exists(link)) fail("cannot open file (no such file)");
  const fs::file_status target = fs::status(path, ec);
  if (ec) {
    // ELOOP: a symlink cycle; ENOENT: a dangling symlink.
    if (ec == std::errc::too_many_symbolic_link_levels) fail("a symlink loop, not a file");
    fail("a symlink to nothing (" + ec.message() + ")");
  }
  if (fs::is_directory(target)) fail("a directory, not a file");
  // Reading a FIFO, socket or device would block or never end: only regular files are read.
  if (!fs::is_regular_file(target)) fail("a special file (FIFO, socket or device), not a regular file");
}

std::string format_double(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  assert(ec == std::errc() && "a shortest double needs at most 24 characters");
  return std::string(buffer, end);
}

std::string join_key_path(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

}  // namespace twill
