// The input limits of core/input_limits.hpp and the text checks of core/input_error.hpp: every
// violation names the unit and the range; the mesh estimate says what it would need and the
// limit; invalid UTF-8 is found at its byte; long text is cut when quoted.
#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "core/input_error.hpp"
#include "core/input_limits.hpp"

namespace twill {
namespace {

TEST(InputLimits, RangeViolationNamesUnitRangeAndValue) {
  EXPECT_EQ(range_violation(0.53, limits::kThickness), "");
  const std::string v = range_violation(1e6, limits::kThickness);
  EXPECT_NE(v.find("(0, 20] mm"), std::string::npos) << v;
  EXPECT_NE(v.find("got 1e+06 mm"), std::string::npos) << v;
  EXPECT_NE(range_violation(0.0, limits::kStripWidth), "");  // the lower bound is exclusive
  EXPECT_EQ(range_violation(-180.0, limits::kAngle), "");    // the angle range is closed
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e308})
    EXPECT_NE(range_violation(bad, limits::kStripLength), "") << bad;
}

TEST(InputLimits, MeshEstimateSaysWhatItNeedsAndTheLimit) {
  EXPECT_EQ(mesh_size_violation(32, 48), "");
  EXPECT_EQ(mesh_size_violation(128, 192), "");  // the finest resolution the README measured
  const std::string v = mesh_size_violation(100000, 100000);
  EXPECT_NE(v.find("would need ~596 TiB"), std::string::npos) << v;
  EXPECT_NE(v.find("the limit is 4 GiB"), std::string::npos) << v;
  EXPECT_NE(mesh_size_violation(0, 4), "");
  EXPECT_NE(mesh_size_violation(1e30, 1e30), "");  // no overflow
}

TEST(InputText, InvalidUtf8IsFoundAtItsByte) {
  EXPECT_EQ(invalid_utf8_offset("canvas"), std::string_view::npos);
  EXPECT_EQ(invalid_utf8_offset("Köper — 斜纹 𝄞"), std::string_view::npos);
  EXPECT_EQ(invalid_utf8_offset("ab\xff"), 2u);
  EXPECT_EQ(invalid_utf8_offset("\xc0\xaf"), 0u);          // overlong '/'
  EXPECT_EQ(invalid_utf8_offset("a\xed\xa0\x80"), 1u);     // a UTF-16 surrogate
  EXPECT_EQ(invalid_utf8_offset("a\xf4\x90\x80\x80"), 1u);  // above U+10FFFF
  EXPECT_EQ(invalid_utf8_offset("ab\xe2\x82"), 2u);         // truncated
}

TEST(InputText, ExcerptCutsLongTextAndEscapesBadBytes) {
  const std::string big(10 * 1024 * 1024, '9');
  const std::string e = excerpt(big);
  EXPECT_LT(e.size(), 2 * kMaxQuotedBytes);
  EXPECT_NE(e.find("(10485760 bytes)"), std::string::npos) << e;
  EXPECT_EQ(excerpt("a\xff" "b\n"), "a\\xFFb\\x0A");
  EXPECT_EQ(excerpt("Köper"), "Köper");
}

}  // namespace
}  // namespace twill
