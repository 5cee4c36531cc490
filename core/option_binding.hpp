#pragma once
// One option-binding mechanism for every registered implementation (discretisations,
// optimisers, experiments, effects, stages): an implementation declares a typed options struct
// once, each field as a binding, and gets its schema, validation and typed struct from it, so
// a schema and its validation cannot disagree (issue #14, item 4).
//
// A binding is the field's spec (name, type, default taken from a default-constructed struct,
// range or choices, one-line doc) and how to read and write the field. From the bindings come
//   - the OptionSchema the registry validates configs against       (option_schema)
//   - the Ceres IsValid-style check of a typed struct, naming the
//     violated constraint, e.g. "c2 must be in (0, 1), got 1"      (check_options)
//   - the typed struct from resolved Options                        (options_from)
//   - the resolved Options of a struct, defaults included, to save
//     next to a result                                               (options_of)
// and FactoryCategory::add_bound (registry.hpp) registers an implementation from them.
//
// The struct provides `bool validate(std::string* error) const`: check_options(bindings) for
// the per-field ranges (stated only in the bindings) and then its cross-field constraints.
// Messages start with the offending field's name ("c1 = 0.5 must be smaller than c2 = 0.4"),
// which require_valid() reports as the InputError's key.
//
// Example (an implementation's header and source):
//
//   struct SagOptions {
//     double strength = 0.1;
//     int samples = 4;
//     bool validate(std::string* error) const { return check_options(sag_option_bindings(), *this, error); }
//   };
//   OptionBindings<SagOptions> sag_option_bindings() {
//     return {real_option<SagOptions>("strength", &SagOptions::strength, "sag per unit load", at_least(0.0)),
//             integer_option<SagOptions>("samples", &SagOptions::samples, "samples per cell", in_range(1, 16))};
//   }
//   // register_sag(): category.add_bound<Sag>("sag", "one-line description", sag_option_bindings());
//   // Sag(SagOptions options) { require_valid(options, "sag"); … }
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/config.hpp"
#include "core/input_error.hpp"

namespace twill {

/// A range or other constraint on a spec, e.g. [](OptionSpec& s) { s.greater_than(0); }.
using OptionConstraint = std::function<void(OptionSpec&)>;

/// The common constraints, for binding declarations.
inline OptionConstraint at_least(double lo) {
  return [lo](OptionSpec& s) { s.at_least(lo); };
}
inline OptionConstraint greater_than(double lo) {
  return [lo](OptionSpec& s) { s.greater_than(lo); };
}
inline OptionConstraint in_range(double lo, double hi) {  ///< closed interval [lo, hi]
  return [lo, hi](OptionSpec& s) { s.range(lo, hi); };
}

/// One option bound to a field of `Struct`.
template <class Struct>
struct OptionBinding {
  std::string name;
  std::string doc;  ///< one line
  /// Adds the spec to `schema` with the default taken from `defaults` and `doc` as its line.
  std::function<void(OptionSchema& schema, const Struct& defaults, const std::string& doc)>
      declare;
  std::function<OptionValue(const Struct&)> get;
  std::function<void(Struct&, const OptionValue&)> set;  ///< value already of the spec's type
};

template <class Struct>
using OptionBindings = std::vector<OptionBinding<Struct>>;

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

/// An integer field of any integral type (of Struct or a base of it); the spec is also capped
/// to the type's largest value (config integers are 64-bit) and, when unsigned, to >= 0.
template <class Struct, class Int, class Owner>
  requires(std::is_integral_v<Int> && !std::is_same_v<Int, bool> && std::is_base_of_v<Owner, Struct>)
OptionBinding<Struct> integer_option(std::string name, Int Owner::*field, std::string doc,
                                     OptionConstraint constraint = {}) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, constraint](OptionSchema& s, const Struct& d, const std::string& line) {
    OptionSpec& spec = s.add_int(name, static_cast<std::int64_t>(d.*field), line);
    if constexpr (std::is_unsigned_v<Int>) spec.at_least(0);
    if constexpr (sizeof(Int) < sizeof(std::int64_t))
      spec.at_most(static_cast<double>(std::numeric_limits<Int>::max()));
    if (constraint) constraint(spec);
  };
  b.get = [field](const Struct& o) { return OptionValue(static_cast<std::int64_t>(o.*field)); };
  b.set = [field](Struct& o, const OptionValue& v) {
    o.*field = static_cast<Int>(std::get<std::int64_t>(v));
  };
  return b;
}

template <class Struct>
OptionBinding<Struct> bool_option(std::string name, bool Struct::*field, std::string doc) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field](OptionSchema& s, const Struct& d, const std::string& line) {
    s.add_bool(name, d.*field, line);
  };
  b.get = [field](const Struct& o) { return OptionValue(o.*field); };
  b.set = [field](Struct& o, const OptionValue& v) { o.*field = std::get<bool>(v); };
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

/// Free text; `non_empty` rejects "" (then the default must not be "").
template <class Struct>
OptionBinding<Struct> string_binding(std::string name, std::string Struct::*field, std::string doc, bool non_empty) {
  OptionBinding<Struct> b;
  b.name = name;
  b.doc = std::move(doc);
  b.declare = [name, field, non_empty](OptionSchema& s, const Struct& d, const std::string& line) {
    auto& spec = s.add_string(name, d.*field, line);
    if (non_empty) spec.non_empty();
  };
  b.get = [field](const Struct& o) { return OptionValue(o.*field); };
  b.set = [field](Struct& o, const OptionValue& v) { o.*field = std::get<std::string>(v); };
  return b;
}

/// Free text, not empty (a label that other entries refer to, e.g. a fit stage's "warp").
template <class Struct>
OptionBinding<Struct> text_option(std::string name, std::string Struct::*field, std::string doc) {
  return string_binding(std::move(name), field, std::move(doc), true);
}

/// A file's path; "" (the default) means not given, and the owner's validate() says whether
/// that is allowed (e.g. the start-from stage's params, which it requires).
template <class Struct>
OptionBinding<Struct> path_option(std::string name, std::string Struct::*field, std::string doc) {
  return string_binding(std::move(name), field, std::move(doc), false);
}

/// A choice stored as an enum: `names` pairs each allowed text with its enumerator (the one
/// list of the enum's names; a value missing from it reads as "<unnamed>" and fails the check).
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

/// Replaces the doc line of option `name` (an implementation that ignores a shared option says so).
template <class Struct>
void set_option_doc(OptionBindings<Struct>& bindings, const std::string& name, std::string doc) {
  for (auto& b : bindings)
    if (b.name == name) b.doc = std::move(doc);
}

/// The schema, defaults from a default-constructed Struct.
template <class Struct>
OptionSchema option_schema(const OptionBindings<Struct>& bindings) {
  const Struct defaults{};
  OptionSchema schema;
  for (const auto& b : bindings) b.declare(schema, defaults, b.doc);
  return schema;
}

/// Ceres IsValid style: false with the first violated constraint in `error` (may be null),
/// e.g. "c2 must be in (0, 1), got 1". Cross-field constraints are the struct's validate().
template <class Struct>
bool check_options(const OptionBindings<Struct>& bindings, const Struct& options,
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

/// Throws InputError "<owner>: <what is wrong>" unless options.validate() passes; the error's
/// key is the field the message starts with (the convention of validate() messages).
template <class Struct>
void require_valid(const Struct& options, const std::string& owner) {
  std::string error;
  if (options.validate(&error)) return;
  throw InputError({"", 0, error.substr(0, error.find_first_of(" =:"))}, owner + ": " + error);
}

/// The typed struct from options resolved against option_schema(bindings) (so keys, types
/// and ranges are already checked; a mismatch is a programming error: std::logic_error).
/// Cross-field constraints (Struct::validate) failing throw InputError (require_valid).
template <class Struct>
Struct options_from(const OptionBindings<Struct>& bindings, const twill::Options& resolved,
                    const std::string& owner) {
  check_resolved_options(option_schema(bindings), resolved, owner);
  Struct options{};
  for (const auto& b : bindings) b.set(options, resolved.value(b.name));
  require_valid(options, owner);
  return options;
}

/// Every option's value (the resolved config of a struct).
template <class Struct>
twill::Options options_of(const OptionBindings<Struct>& bindings, const Struct& options) {
  twill::Options out;
  for (const auto& b : bindings) out.set(b.name, b.get(options));
  return out;
}

}  // namespace twill
