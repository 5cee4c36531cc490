#include "optimizers/option_schema.hpp"

#include <cmath>
#include <sstream>

namespace twill {
namespace {

std::string format_number(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s.precision(12);
  s << v;
  return s.str();
}

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out.append(out.empty() ? "" : ", ").append(item);
  return out;
}

}  // namespace

std::string to_string(OptionType type) {
  switch (type) {
    case OptionType::real:
      return "real";
    case OptionType::integer:
      return "integer";
    case OptionType::boolean:
      return "boolean";
    case OptionType::choice:
      return "choice";
  }
  return "unknown";
}

std::string to_string(const OptionValue& value) {
  if (const auto* b = std::get_if<bool>(&value)) return *b ? "true" : "false";
  if (const auto* i = std::get_if<int>(&value)) return std::to_string(*i);
  if (const auto* d = std::get_if<double>(&value)) return format_number(*d);
  return "'" + std::get<std::string>(value) + "'";
}

std::string OptionDescription::range() const {
  switch (type) {
    case OptionType::boolean:
      return "{false, true}";
    case OptionType::choice: {
      // Appended piecewise: `"{" + join(...)` trips GCC 12's false -Wrestrict positive.
      std::string text("{");
      text.append(join(choices)).append("}");
      return text;
    }
    case OptionType::real:
    case OptionType::integer:
      return std::string(minimum_inclusive && std::isfinite(minimum) ? "[" : "(") +
             format_number(minimum) + ", " + format_number(maximum) +
             (maximum_inclusive && std::isfinite(maximum) ? "]" : ")");
  }
  return "";
}

double option_as_real(const OptionValue& value) {
  if (const auto* i = std::get_if<int>(&value)) return *i;
  return std::get<double>(value);
}

int option_as_integer(const OptionValue& value) {
  if (const auto* d = std::get_if<double>(&value)) return static_cast<int>(*d);
  return std::get<int>(value);
}

std::string OptionDescription::check(const OptionValue& value) const {
  const std::string wrong_type =
      name + " = " + to_string(value) + " is not of type " + to_string(type);
  switch (type) {
    case OptionType::boolean:
      return std::holds_alternative<bool>(value) ? "" : wrong_type;
    case OptionType::choice: {
      const auto* text = std::get_if<std::string>(&value);
      if (!text) return wrong_type;
      for (const auto& c : choices)
        if (c == *text) return "";
      return name + " = '" + *text + "' is not one of " + range();
    }
    case OptionType::real:
    case OptionType::integer: {
      double v = 0.0;
      if (const auto* i = std::get_if<int>(&value)) {
        v = *i;
      } else if (const auto* d = std::get_if<double>(&value)) {
        v = *d;
        // An integer option accepts an integral real (YAML may give 20.0) in int's range.
        if (type == OptionType::integer &&
            (v != std::floor(v) || std::abs(v) > std::numeric_limits<int>::max()))
          return wrong_type;
      } else {
        return wrong_type;
      }
      const bool above = minimum_inclusive ? v >= minimum : v > minimum;
      const bool below = maximum_inclusive ? v <= maximum : v < maximum;
      if (std::isnan(v) || !above || !below)
        return name + " = " + to_string(value) + " is outside " + range();
      return "";
    }
  }
  return wrong_type;
}

void throw_unknown_option(const std::string& key, const std::vector<std::string>& known) {
  throw InputError({"", 0, key}, "unknown option '" + key + "'; known options: " + join(known));
}

}  // namespace twill
