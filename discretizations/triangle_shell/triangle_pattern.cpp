#include "discretizations/triangle_shell/triangle_pattern.hpp"

#include "core/input_error.hpp"

namespace twill {

std::string to_string(TrianglePattern pattern) {
  switch (pattern) {
    case TrianglePattern::Right:
      return "right";
    case TrianglePattern::Left:
      return "left";
    case TrianglePattern::Alternating:
      return "alternating";
    case TrianglePattern::Cross:
      return "cross";
    case TrianglePattern::Irregular:
      return "irregular";
  }
  return "?";
}

std::vector<TrianglePattern> all_triangle_patterns() {
  return {TrianglePattern::Right, TrianglePattern::Left, TrianglePattern::Alternating,
          TrianglePattern::Cross, TrianglePattern::Irregular};
}

TrianglePattern triangle_pattern_from_string(const std::string& name) {
  std::string known;
  for (TrianglePattern p : all_triangle_patterns()) {
    if (to_string(p) == name) return p;
    known += (known.empty() ? "" : ", ") + to_string(p);
  }
  throw InputError({"", 0, "pattern"}, "unknown triangle pattern '" + name + "'; known: " + known);
}

}  // namespace twill
