#pragma once
// Option schemas and strictly validated configs (style.md practice 4; PolyFEM-style schema as
// data, Ceres-style errors that name the violated constraint).
//
// An OptionSchema says, per option: name, type, default (or "required"), allowed range or
// choices, and a one-line doc. Every registered implementation (registry.hpp) has one, and a
// command builds one for its whole config file. Resolving a YAML mapping against a schema
// gives an Options value in which every option of the schema is present (defaults filled in),
// or throws InputError naming file, line and key path for an unknown key, a wrong type, a
// value out of range, or a missing required option.
//
// Types: bool, int (64-bit), double (finite), string, list of doubles, and three structured
// kinds:
//   section         a nested mapping with its own schema              solver: {tolerance: 1e-9}
//   component       a registered implementation chosen by name, with that implementation's
//                   options (schema from the registry category):
//                       optimizer: bfgs                                (name only: defaults)
//                       optimizer: {name: bfgs, max_iterations: 50}
//                   a component option may have a default name; `{max_iterations: 50}` then
//                   means the default implementation with one option changed.
//   component list  a list of components (e.g. the effects of an extended model):
//                       effects: [{name: sag, strength: 0.1}, thermal]
//                   its default is empty or a YAML list (OptionSpec::default_items).
//
// Example (a command's config schema):
//
//   OptionSchema schema;
//   schema.add_string("dataset", "", "dataset folder (fabric.yaml + runs)").required();
//   schema.add_component("discretization", "discretization", "catmull-clark-kl", "the shell model");
//   schema.add_component("optimizer", "optimizer", "bfgs", "minimiser of the fit objective");
//   schema.add_int("seed", 1, "seed of the random repeat choice (paper §6.4)").at_least(0);
//   schema.add_string("repeats", "paper", "which repeats to fit").choices({"paper", "largest", "random", "all"});
//   OptionSchema& solver = schema.add_section("solver", "equilibrium solver");
//   solver.add_double("tolerance", 1e-9, "relative residual at which Newton stops").greater_than(0);
//
//   Options config = read_config_file(path, schema, &registry);   // validated, defaults filled
//   apply_override(config, schema, &registry, "solver.tolerance=1e-10");   // --set
//   write_config_file(config, out_dir + "/config.resolved.yaml");  // next to the result
//   double tol = config.get_section("solver").get_double("tolerance");
//
// Written configs (options_to_yaml) read back to an equal Options value (doubles bit-exact).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "core/yaml_reader.hpp"

namespace twill {

class Registry;

enum class OptionType { Bool, Int, Double, String, DoubleList, Section, Component, ComponentList };
/// "bool", "int", "double", "string", "list of doubles", "section", "component", "component list".
const char* to_string(OptionType type);

// ---------------------------------------------------------------------------------------
// Resolved values

struct OptionEntry;
struct ComponentChoice;
class Options;
using OptionValue = std::variant<bool, std::int64_t, double, std::string, std::vector<double>, Options,
                                 ComponentChoice, std::vector<ComponentChoice>>;

/// Resolved options: an ordered list of key → value (schema order). Getters throw
/// std::logic_error when the key is absent or holds another type: a resolved config always
/// matches its schema, so that is a programming error, not an input error.
class Options {
 public:
  bool has(const std::string& key) const;
  bool get_bool(const std::string& key) const;
  std::int64_t get_int(const std::string& key) const;
  double get_double(const std::string& key) const;
  const std::string& get_string(const std::string& key) const;
  const std::vector<double>& get_double_list(const std::string& key) const;
  const Options& get_section(const std::string& key) const;
  const ComponentChoice& get_component(const std::string& key) const;
  const std::vector<ComponentChoice>& get_component_list(const std::string& key) const;

  /// Sets (or appends) a value without schema checks; for code that builds options directly.
  /// Prefer apply_override(), which checks type and range.
  template <typename T>
  void set(const std::string& key, T value);

  /// Low-level access to a value; throws std::logic_error when absent.
  const OptionValue& value(const std::string& key) const;
  OptionValue& value(const std::string& key);

  const std::vector<OptionEntry>& entries() const { return entries_; }
  bool empty() const { return entries_.empty(); }
  bool operator==(const Options& other) const;

 private:
  const OptionEntry* find(const std::string& key) const;
  OptionEntry* find(const std::string& key);
  std::vector<OptionEntry> entries_;
};

/// A chosen implementation: registry category, registered name, and its resolved options.
struct ComponentChoice {
  std::string category;
  std::string name;
  Options options;
  bool operator==(const ComponentChoice& other) const = default;
};

struct OptionEntry {
  std::string key;
  OptionValue value;
  bool operator==(const OptionEntry& other) const = default;
};

template <typename T>
void Options::set(const std::string& key, T value) {
  OptionValue v;
  if constexpr (std::is_same_v<T, int>)
    v = static_cast<std::int64_t>(value);  // int literals are the common case in code
  else if constexpr (std::is_same_v<T, const char*>)
    v = std::string(value);
  else
    v = std::move(value);
  if (OptionEntry* e = find(key))
    e->value = std::move(v);
  else
    entries_.push_back(OptionEntry{key, std::move(v)});
}

// ---------------------------------------------------------------------------------------
// Schemas

struct OptionSpec;

/// The options of one implementation, one section, or one whole config file.
class OptionSchema {
 public:
  OptionSpec& add_bool(const std::string& name, bool default_value, const std::string& doc);
  OptionSpec& add_int(const std::string& name, std::int64_t default_value, const std::string& doc);
  OptionSpec& add_double(const std::string& name, double default_value, const std::string& doc);
  OptionSpec& add_string(const std::string& name, const std::string& default_value, const std::string& doc);
  OptionSpec& add_double_list(const std::string& name, std::vector<double> default_value, const std::string& doc);
  /// A nested section; returns its schema to add options to. Defaults come from its options.
  OptionSchema& add_section(const std::string& name, const std::string& doc);
  /// A component of `category`; `default_name` empty means the config must name one.
  OptionSpec& add_component(const std::string& name, const std::string& category,
                            const std::string& default_name, const std::string& doc);
  /// A list of components of `category` (default: empty list).
  OptionSpec& add_component_list(const std::string& name, const std::string& category, const std::string& doc);

  const std::vector<OptionSpec>& options() const { return options_; }
  const OptionSpec* find(const std::string& name) const;
  /// "a, b, c" (for error messages).
  std::string names() const;

 private:
  OptionSpec& add(OptionSpec spec);
  std::vector<OptionSpec> options_;
};

/// One option. The constraint setters return *this for chaining and throw std::logic_error
/// if the default violates the constraint or the constraint does not fit the type.
struct OptionSpec {
  using Default = std::variant<std::monostate, bool, std::int64_t, double, std::string, std::vector<double>>;

  std::string name;
  OptionType type = OptionType::Double;
  std::string doc;
  /// Default value; the default component name for Component; monostate for Section and
  /// ComponentList (defaults come from the nested schema / an empty list) and when required.
  Default default_value;
  bool is_required = false;
  std::optional<double> min, max;  ///< bounds for Int, Double and each DoubleList element
  bool min_exclusive = false, max_exclusive = false;
  std::vector<std::string> allowed;    ///< String choices (empty: any text)
  std::size_t min_items = 0;           ///< DoubleList / ComponentList
  std::string category;                ///< Component, ComponentList
  /// ComponentList: the default list as YAML, resolved like a config's (empty: []), and
  /// the name its errors give as the file (e.g. the embedded default protocol's).
  std::string default_items_yaml, default_items_source;
  std::shared_ptr<OptionSchema> section;  ///< Section

  OptionSpec& at_least(double lo);
  OptionSpec& greater_than(double lo);
  OptionSpec& at_most(double hi);
  OptionSpec& less_than(double hi);
  OptionSpec& range(double lo, double hi);  ///< closed interval [lo, hi]
  OptionSpec& choices(std::vector<std::string> values);
  OptionSpec& non_empty();  ///< lists: at least one item; strings: not empty
  /// A component list's default items, as YAML text (`source` names it in errors).
  OptionSpec& default_items(std::string yaml, std::string source);
  /// No default: the config must give the option (missing → InputError).
  OptionSpec& required();

  /// The constraint in words, e.g. "> 0", "in [0, 1]", "one of: a, b"; empty when none.
  std::string constraint_text() const;
  /// The default as YAML text, e.g. "1e-09", "[1, 2]", "bfgs"; "(required)" when required.
  std::string default_text() const;
  /// Empty when `value` satisfies the range/choices/size constraints, else what is wrong.
  std::string violation(const OptionValue& value) const;
};

// ---------------------------------------------------------------------------------------
// Resolving, overriding, writing

/// Validates a YAML mapping against `schema` and fills in defaults. A null/absent document is
/// read as an empty mapping. `registry` resolves component options; it may be nullptr when
/// the schema has no components.
Options resolve_options(const OptionSchema& schema, const YamlValue& value, const Registry* registry);

/// Every option at its default (components at their default names with default options).
/// Throws InputError when a required option has no default (nothing can fill it in).
Options default_options(const OptionSchema& schema, const Registry* registry);

/// Reads a YAML config file and resolves it.
Options read_config_file(const std::string& path, const OptionSchema& schema, const Registry* registry);

/// Applies one `--set key.path=value` override to a resolved config, with the same type,
/// range and choice checks as a file. Key paths use dots for sections and components and
/// [i] for component lists: `solver.tolerance=1e-10`, `optimizer.max_iterations=20`,
/// `effects[0].strength=0.2`; [*] sets the key in every entry that has it
/// (`protocol[*].max_degree=1`, an error when none has it); a whole component list is set as YAML: `effects=[misalignment]`. Values are YAML: `true`, `3`, `[0.1, 0.2]`; strings are taken
/// verbatim. Setting a component's name (`optimizer=gauss-newton` or `optimizer.name=...`)
/// switches the implementation and resets its options to that implementation's defaults
/// (so give the name before its options). Errors are InputErrors with file "--set".
void apply_override(Options& config, const OptionSchema& schema, const Registry* registry,
                    const std::string& assignment);
void apply_overrides(Options& config, const OptionSchema& schema, const Registry* registry,
                     const std::vector<std::string>& assignments);

/// `key` with every list index written [*] (`protocol[8].cells_along` ->
/// `protocol[*].cells_along`): the override that sets the key in every entry sets this one.
std::string with_every_index(const std::string& key);

/// Whether an override of `assigned` (`protocol`, `protocol[*].max_degree`, `solver.tolerance`)
/// sets the config key `key` (`protocol[2].stage`): the same key, the key in every list entry,
/// or a section or list that holds it. Errors about `key` are then located at the override.
bool override_sets_key(const std::string& assigned, const std::string& key);

/// Where a command's config key got its value: the last `--set` override that sets it, else
/// the config file (`config_file`, "" for the defaults). For errors found after resolving.
InputLocation command_line_key_location(const std::vector<std::string>& sets, const std::string& config_file,
                                        const std::string& key);

/// The resolved config as YAML (block style; components as {name, options...}).
std::string options_to_yaml(const Options& options);
/// Writes options_to_yaml(); throws std::runtime_error if the file cannot be written.
void write_config_file(const Options& options, const std::string& path);

/// Throws std::logic_error unless `options` has exactly the schema's keys with the schema's
/// types (a resolved config always does; hand-built options may not). Used by the registry
/// before calling a factory. `what` names the owner in the message.
void check_resolved_options(const OptionSchema& schema, const Options& options, const std::string& what);

}  // namespace twill
