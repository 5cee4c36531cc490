#pragma once
// The optimisers' option schemas, in the program's one schema vocabulary (core/config.hpp's
// OptionSchema / Options, used by the registry, core/registry.hpp).
//
// Each field of a typed options struct (BfgsOptions, …) is declared once, as a binding: its
// spec (name, type, default taken from a default-constructed struct, range or choices,
// one-line doc) and how to read and write the field. From the bindings come
//   - the OptionSchema the registry validates configs against       (option_schema)
//   - the Ceres IsValid-style check of a typed struct, naming the
//     violated constraint, e.g. "c2 must be in (0, 1), got 1"      (check_options)
//   - the typed struct from resolved Options                        (options_from)
//   - the resolved Options of a struct, defaults included, to save
//     next to a result                                               (options_of)
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/config.hpp"
#include "core/input_error.hpp"

namespace twill {

/// A range or other constraint on a spec, e.g. [](OptionSpec& s) { s.greater_than(0); }.
using OptionConstraint = std::function<void(OptionSpec&)>;

/// One option bound to a field of `Struct`.
template <class Struct>
struct OptionBinding {
  std::string name;
  std::string doc;  ///< one line
  /// Adds the spec to `schema` with the default taken from `defaults`.
  std::function<void(OptionSchema& schema, const Struct& defaults, const std::string& line)>
      declare;
  std::function<OptionValue(const Struct&)> get;
  std::function<void(Struct&, const OptionValue&)> set;  ///< value already of the spec's type
};

template <class Struct>
OptionBinding<Struct> real_option(std::string name, double Struct::*field, std::string doc,
                                  OptionConstraint constraint = {}) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, constraint](OptionSchema& s, const Struct& d, const std::string& line) {
    OptionSpec& spec = s.add_double(name, d.*field, line);
    if (constraint) constraint(spec);
  };
  b.get = [field](const Struct& o) { return OptionValue(o.*field); };
  b.set = [field](Struct& o, const OptionValue& v) { o.*field = std::get<double>(v); };
  return b;
}

/// An int field; the spec is also capped to int's range (config integers are 64-bit).
template <class Struct>
OptionBinding<Struct> integer_option(std::string name, int Struct::*field, std::string doc,
                                     OptionConstraint constraint = {}) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, constraint](OptionSchema& s, const Struct& d, const std::string& line) {
    OptionSpec& spec = s.add_int(name, d.*field, line);
    spec.at_most(std::numeric_limits<int>::max());
    if (constraint) constraint(spec);
  };
  b.get = [field](const Struct& o) { return OptionValue(static_cast<std::int64_t>(o.*field)); };
  b.set = [field](Struct& o, const OptionValue& v) {
    o.*field = static_cast<int>(std::get<std::int64_t>(v));
  };
  return b;
}

template <class Struct>
OptionBinding<Struct> choice_option(std::string name, std::string Struct::*field,
                                    std::vector<std::string> choices, std::string doc) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, choices](OptionSchema& s, const Struct& d, const std::string& line) {
    s.add_string(name, d.*field, line).choices(choices);
  };
  b.get = [field](const Struct& o) { return OptionValue(o.*field); };
  b.set = [field](Struct& o, const OptionValue& v) { o.*field = std::get<std::string>(v); };
  return b;
}

/// A choice stored as an enum: `names` pairs each allowed text with its enumerator.
template <class Struct, class Enum>
OptionBinding<Struct> enum_option(std::string name, Enum Struct::*field,
                                  std::vector<std::pair<std::string, Enum>> names,
                                  std::string doc) {
  auto text_of = [names](Enum value) {
    for (const auto& [text, e] : names)
      if (e == value) return text;
    return std::string("<unnamed>");
  };
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, names, text_of](OptionSchema& s, const Struct& d,
                                            const std::string& line) {
    std::vector<std::string> choices;
    for (const auto& [text, e] : names) choices.push_back(text);
    s.add_string(name, text_of(d.*field), line).choices(choices);
  };
  b.get = [field, text_of](const Struct& o) { return OptionValue(text_of(o.*field)); };
  b.set = [field, names](Struct& o, const OptionValue& v) {
    for (const auto& [text, e] : names)
      if (std::get<std::string>(v) == text) o.*field = e;
  };
  return b;
}

/// Replaces the doc line of option `name` (an optimiser that ignores a common option says so).
template <class Struct>
void set_option_doc(std::vector<OptionBinding<Struct>>& bindings, const std::string& name,
                    std::string doc) {
  for (auto& b : bindings)
    if (b.name == name) b.doc = std::move(doc);
}

/// The schema, defaults from a default-constructed Struct.
template <class Struct>
OptionSchema option_schema(const std::vector<OptionBinding<Struct>>& bindings) {
  const Struct defaults{};
  OptionSchema schema;
  for (const auto& b : bindings) b.declare(schema, defaults, b.doc);
  return schema;
}

/// Ceres IsValid style: false with the first violated constraint in `error` (may be null),
/// e.g. "c2 must be in (0, 1), got 1". Cross-field constraints are the struct's validate().
template <class Struct>
bool check_options(const std::vector<OptionBinding<Struct>>& bindings, const Struct& options,
                   std::string* error) {
  const OptionSchema schema = option_schema(bindings);
  for (const auto& b : bindings) {
    const OptionValue value = b.get(options);
    std::string problem;
    if (const auto* d = std::get_if<double>(&value); d && !std::isfinite(*d)) {
      problem = "must be finite, got " + std::to_string(*d);
    } else {
      problem = schema.find(b.name)->violation(value);
    }
    if (!problem.empty()) {
      if (error) *error = b.name + " " + problem;
      return false;
    }
  }
  return true;
}

/// The typed struct from options resolved against option_schema(bindings) (so keys, types
/// and ranges are already checked; a mismatch is a programming error: std::logic_error).
/// Cross-field constraints (Struct::validate) failing throw InputError naming the options.
template <class Struct>
Struct options_from(const std::vector<OptionBinding<Struct>>& bindings,
                    const twill::Options& resolved, const std::string& owner) {
  check_resolved_options(option_schema(bindings), resolved, owner);
  Struct options{};
  for (const auto& b : bindings) b.set(options, resolved.value(b.name));
  std::string error;
  if (!options.validate(&error)) throw InputError({"", 0, ""}, owner + ": " + error);
  return options;
}

/// Every option's value (the resolved config of a struct).
template <class Struct>
twill::Options options_of(const std::vector<OptionBinding<Struct>>& bindings,
                          const Struct& options) {
  twill::Options out;
  for (const auto& b : bindings) out.set(b.name, b.get(options));
  return out;
}

}  // namespace twill
