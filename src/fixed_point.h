// meshcvt: rounding to the 64-bit fixed point in which sums are kept so that they do not depend on
// the order of addition (the clustering's cluster sums, the coarse fitting's residual sums).
// Internal, not public API.
#pragma once

#include <cassert>
#include <cmath>
#include <cstdint>

namespace meshcvt {

/// std::llround (half away from zero) without the libm call and without branches (the fraction
/// is as likely above a half as below: branches on it mispredict half the time). Same result:
/// below 2^52 the fraction x - trunc(x) is exact in double, above it x is an integer.
/// x: |x| < 2^62 (the callers scale their sums to stay below it).
inline int64_t round_half_away(double x) {
  assert(std::fabs(x) < 0x1p62);
  int64_t r = int64_t(x);  // toward zero
  double fraction = x - double(r);
  return r + int64_t(fraction >= 0.5) - int64_t(fraction <= -0.5);
}

}  // namespace meshcvt
