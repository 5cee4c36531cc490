#pragma once
// Option schemas as plain data (style.md §3–4, PolyFEM's JSON spec, Ceres' IsValid):
// every optimiser option has a name, a type, a default, a range and a one-line doc, and one
// binding ties it to a field of the typed options struct. From the bindings come
//   - the descriptions the registry shows and validates configs against (describe_options),
//   - the Ceres-style check of a typed struct (check_options: names the violated constraint),
//   - the strict conversion of a name → value map into the struct (options_from_values: an
//     unknown key, a wrong type or an out-of-range value throws InputError naming the key),
//   - the resolved map of every option, defaults included, to save with a result.
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/input_error.hpp"

namespace twill {

enum class OptionType { real, integer, boolean, choice };
std::string to_string(OptionType type);

/// A value as a config file gives it. A `choice` option takes a std::string.
using OptionValue = std::variant<bool, int, double, std::string>;
/// Options by name, e.g. {"c2": 0.9, "damping": "levenberg-marquardt"}.
using OptionValues = std::map<std::string, OptionValue>;
std::string to_string(const OptionValue& value);

struct OptionDescription {
  std::string name;
  OptionType type = OptionType::real;
  OptionValue default_value;
  /// Range of real and integer options; inclusive unless the flag says otherwise.
  double minimum = -std::numeric_limits<double>::infinity();
  double maximum = std::numeric_limits<double>::infinity();
  bool minimum_inclusive = true;
  bool maximum_inclusive = true;
  std::vector<std::string> choices;  ///< the allowed values of a choice option
  std::string doc;                   ///< one line

  /// The range as text: "(0, 1)", "[1, inf)", "{none, levenberg-marquardt}", "{false, true}".
  std::string range() const;
  /// Empty when `value` has this option's type (an int is accepted for a real, an integral
  /// real for an integer) and lies in range; otherwise the violated constraint, e.g.
  /// "c2 = 1.5 is outside (0, 1)".
  std::string check(const OptionValue& value) const;
};

/// `value` converted to the option's type (call after check() returned empty).
double option_as_real(const OptionValue& value);
int option_as_integer(const OptionValue& value);

/// One option bound to a field of `Options`.
template <class Options>
struct OptionBinding {
  OptionDescription description;  ///< default_value is filled from Options{} by describe
  std::function<OptionValue(const Options&)> get;
  std::function<void(Options&, const OptionValue&)> set;  ///< value already checked
};

template <class Options>
OptionBinding<Options> real_option(std::string name, double Options::*field, double minimum,
                                   bool minimum_inclusive, double maximum, bool maximum_inclusive,
                                   std::string doc) {
  OptionDescription d;
  d.name = std::move(name);
  d.type = OptionType::real;
  d.minimum = minimum;
  d.minimum_inclusive = minimum_inclusive;
  d.maximum = maximum;
  d.maximum_inclusive = maximum_inclusive;
  d.doc = std::move(doc);
  return {std::move(d), [field](const Options& o) { return OptionValue(o.*field); },
          [field](Options& o, const OptionValue& v) { o.*field = option_as_real(v); }};
}

template <class Options>
OptionBinding<Options> integer_option(std::string name, int Options::*field, int minimum,
                                      int maximum, std::string doc) {
  OptionDescription d;
  d.name = std::move(name);
  d.type = OptionType::integer;
  d.minimum = minimum;
  d.maximum = maximum;
  d.doc = std::move(doc);
  return {std::move(d), [field](const Options& o) { return OptionValue(o.*field); },
          [field](Options& o, const OptionValue& v) { o.*field = option_as_integer(v); }};
}

template <class Options>
OptionBinding<Options> choice_option(std::string name, std::string Options::*field,
                                     std::vector<std::string> choices, std::string doc) {
  OptionDescription d;
  d.name = std::move(name);
  d.type = OptionType::choice;
  d.choices = std::move(choices);
  d.doc = std::move(doc);
  return {std::move(d), [field](const Options& o) { return OptionValue(o.*field); },
          [field](Options& o, const OptionValue& v) { o.*field = std::get<std::string>(v); }};
}

/// A choice stored as an enum: `names` pairs each allowed text with its enumerator.
template <class Options, class Enum>
OptionBinding<Options> enum_option(std::string name, Enum Options::*field,
                                   std::vector<std::pair<std::string, Enum>> names,
                                   std::string doc) {
  OptionDescription d;
  d.name = std::move(name);
  d.type = OptionType::choice;
  for (const auto& [text, value] : names) d.choices.push_back(text);
  d.doc = std::move(doc);
  auto get = [field, names](const Options& o) {
    for (const auto& [text, value] : names)
      if (o.*field == value) return OptionValue(text);
    return OptionValue(std::string("<unnamed>"));
  };
  auto set = [field, names](Options& o, const OptionValue& v) {
    for (const auto& [text, value] : names)
      if (std::get<std::string>(v) == text) o.*field = value;
  };
  return {std::move(d), get, set};
}

/// The descriptions with defaults taken from a default-constructed Options.
template <class Options>
std::vector<OptionDescription> describe_options(
    const std::vector<OptionBinding<Options>>& bindings) {
  const Options defaults{};
  std::vector<OptionDescription> out;
  for (const auto& b : bindings) {
    out.push_back(b.description);
    out.back().default_value = b.get(defaults);
  }
  return out;
}

/// Every option's current value, by name (the resolved config).
template <class Options>
OptionValues option_values(const std::vector<OptionBinding<Options>>& bindings,
                           const Options& options) {
  OptionValues out;
  for (const auto& b : bindings) out[b.description.name] = b.get(options);
  return out;
}

/// Ceres IsValid style: false with the first violated range in `error` (which may be null).
template <class Options>
bool check_options(const std::vector<OptionBinding<Options>>& bindings, const Options& options,
                   std::string* error) {
  for (const auto& b : bindings) {
    const std::string problem = b.description.check(b.get(options));
    if (!problem.empty()) {
      if (error) *error = problem;
      return false;
    }
  }
  return true;
}

/// Throws InputError (key = the option name) for an unknown key, listing the known ones.
void throw_unknown_option(const std::string& key, const std::vector<std::string>& known);

/// Defaults overridden by `values`, checked key by key and then as a whole with
/// Options::validate(). Throws InputError naming the key (an unknown key lists the known ones).
template <class Options>
Options options_from_values(const std::vector<OptionBinding<Options>>& bindings,
                            const OptionValues& values) {
  Options options{};
  for (const auto& [key, value] : values) {
    const OptionBinding<Options>* binding = nullptr;
    for (const auto& b : bindings)
      if (b.description.name == key) binding = &b;
    if (!binding) {
      std::vector<std::string> known;
      for (const auto& b : bindings) known.push_back(b.description.name);
      throw_unknown_option(key, known);
    }
    const std::string problem = binding->description.check(value);
    if (!problem.empty()) throw InputError({"", 0, key}, problem);
    binding->set(options, value);
  }
  std::string error;
  if (!options.validate(&error)) throw InputError({"", 0, ""}, error);
  return options;
}

}  // namespace twill
