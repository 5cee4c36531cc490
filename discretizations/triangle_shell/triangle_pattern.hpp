#pragma once
// How each cell of the strip is split into triangles (strip_triangulation.hpp describes the
// patterns; docs/triangle_shell.md §1 and §5 compare them).
#include <string>
#include <vector>

namespace twill {

enum class TrianglePattern { Right, Left, Alternating, Cross, Irregular };

/// "right", "left", "alternating", "cross", "irregular".
std::string to_string(TrianglePattern pattern);
/// Inverse of to_string(); throws InputError (key "pattern") listing the known names.
TrianglePattern triangle_pattern_from_string(const std::string& name);
/// Every pattern, in the order above (for tests and option schemas).
std::vector<TrianglePattern> all_triangle_patterns();

}  // namespace twill
