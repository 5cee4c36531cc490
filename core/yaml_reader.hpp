#pragma once
// Strict, location-aware reading of YAML input (parameter files, dataset descriptions,
// configs) on top of yaml-cpp.
//
// Every value read through these helpers knows the file it came from, its key path
// (`tensile[2].width_mm`, `eta1.mu[0]`) and its line, so that any problem becomes an
// InputError a researcher can act on (style.md practice 4). yaml-cpp's Node::Mark() is
// 0-based; InputLocation lines are 1-based, with 0 meaning "unknown" (nodes built in code,
// e.g. a `--set` override, have no mark).
//
// Strictness: YamlMap remembers every key the reader asked about (or declared with expect());
// finish() then rejects any other key (a typo never falls back to a default silently) and
// lists the keys it knows.
// Duplicate keys in one mapping are rejected too (yaml-cpp itself would keep one of them).
// Numbers must be finite; integers must be written without a fraction or exponent.
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/input_error.hpp"

namespace twill {

/// A YAML node together with where it came from.
class YamlValue {
 public:
  YamlValue(YAML::Node node, std::string file, std::string path);

  const YAML::Node& node() const { return node_; }
  const std::string& file() const { return file_; }
  /// Key path from the document root, e.g. `tensile[0].runs[1]` (empty for the root).
  const std::string& path() const { return path_; }
  /// 1-based line of the node, 0 when unknown. An empty value (`key:` and nothing) is
  /// located at its key's line (yaml-cpp marks it where the next token starts).
  int line() const;
  /// The line to report for an empty value (set by YamlMap for its values).
  void set_key_line(int line) { key_line_ = line; }
  InputLocation location() const { return {file_, line(), path_}; }
  /// An InputError located at this node.
  InputError error(const std::string& what) const;

  bool is_null() const;
  bool is_scalar() const { return node_.IsScalar(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool is_map() const { return node_.IsMap(); }

  /// A finite number (int or float syntax).
  double as_double() const;
  /// A number, or `null` (also `~` and an empty value) for "off".
  std::optional<double> as_optional_double() const;
  /// An integer (no fraction, no exponent) that fits in 64 bits.
  std::int64_t as_int() const;
  /// true/false (yaml-cpp also accepts yes/no/on/off).
  bool as_bool() const;
  /// Any scalar, as written.
  std::string as_string() const;
  /// A sequence of finite numbers (flow `[1, 2]` or block style).
  std::vector<double> as_double_list() const;
  /// A sequence of scalars.
  std::vector<std::string> as_string_list() const;
  /// Elements of a sequence, each with path `<path>[i]`; errors if this is not a sequence.
  std::vector<YamlValue> items() const;

  /// Short human description of the node's kind for error messages ("a list", "'abc'").
  std::string describe() const;

 private:
  YAML::Node node_;
  std::string file_;
  std::string path_;
  int key_line_ = 0;
};

/// A mapping read strictly: ask for keys, then call finish() to reject any other key.
class YamlMap {
 public:
  /// Throws InputError if `value` is not a mapping (or holds a key twice, or a non-scalar key).
  explicit YamlMap(const YamlValue& value);

  const YamlValue& value() const { return value_; }
  /// Whether the key is present (marks it as known).
  bool has(const std::string& key);
  /// The value of a required key; throws "missing key" at the mapping's line.
  YamlValue get(const std::string& key);
  /// The value of an optional key, or nullopt when absent.
  std::optional<YamlValue> find(const std::string& key);
  /// Declares every key this mapping may have and rejects any other key right away. Readers
  /// that know their keys call this first, so that a misspelt key is reported as unknown (with
  /// its line) rather than as the required key it was meant to be going missing.
  void expect(const std::vector<std::string>& keys);
  /// Throws InputError naming the first key (in file order) that was never asked about (nor
  /// expected), its line, and the known keys.
  void finish() const;
  /// Keys present in the file, in file order.
  const std::vector<std::string>& keys() const { return keys_in_order_; }
  /// Key path of a child key (`<path>.<key>`, or `<key>` at the root).
  std::string child_path(const std::string& key) const;

 private:
  YamlValue value_;
  std::vector<std::string> keys_in_order_;
  std::vector<int> key_lines_;
  std::set<std::string> known_;
};

/// Throws InputError unless `path` is a regular file (or a symlink to one): missing files,
/// directories, symlink loops and special files (FIFOs would block the reader) each get their
/// own message. With `listed_at` the error is located there (the fabric.yaml line that names
/// the file) and names the path in its text.
void check_readable_file(const std::string& path, const InputLocation& listed_at = {});

/// Parses a YAML file; a missing file or a syntax error is an InputError with the line.
YamlValue load_yaml_file(const std::string& path);
/// Parses YAML text; `source_name` stands in for the file name in messages.
YamlValue load_yaml_string(const std::string& text, const std::string& source_name);

/// The shortest decimal text that reads back as exactly `value` (std::to_chars), e.g.
/// "0.294", "1e-06", "30000000". Non-finite values are written as YAML's .inf/-.inf/.nan.
std::string format_double(double value);

/// Joins `path` and a child key: "a" + "b" -> "a.b"; "" + "b" -> "b".
std::string join_key_path(const std::string& path, const std::string& key);

}  // namespace twill
