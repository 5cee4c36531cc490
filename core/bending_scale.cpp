#include "core/bending_scale.hpp"

#include <cmath>
#include <string>

#include "core/input_error.hpp"

namespace twill {
namespace {

void require_positive(double ratio, const char* name) {
  if (!(std::isfinite(ratio) && ratio > 0.0))
    throw InputError({"", 0, name}, "a bending ratio must be positive and finite, got " + std::to_string(ratio));
}

}  // namespace

BendingScale bending_scale(const MaterialParameters& p) {
  const double bw = p.bending_warp_ratio, bf = p.bending_weft_ratio;
  require_positive(bw, kBendingWarpRatioName);
  require_positive(bf, kBendingWeftRatioName);
  BendingScale out;
  out.diagonal << std::sqrt(bw), std::sqrt(bf), std::sqrt(std::sqrt(bw * bf));
  // d√b/db = √b/(2b); d(b_w b_f)^¼/db_w = (b_w b_f)^¼/(4 b_w), likewise for b_f.
  out.derivative << out.diagonal[0] / (2.0 * bw), 0.0,  //
      0.0, out.diagonal[1] / (2.0 * bf),                //
      out.diagonal[2] / (4.0 * bw), out.diagonal[2] / (4.0 * bf);
  return out;
}

}  // namespace twill
