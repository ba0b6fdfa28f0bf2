// meshcvt: the smallest angle of a triangle, shared by the passes that judge coarse triangles by it
// (the dual's polygon triangulation in coarsen.cpp, the widening in coarse_toward_surface.cpp, the
// fitting's edge swaps in coarse_fit.cpp).
// Internal, not public API.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

namespace meshcvt {

// The smallest angle of the triangle (a, b, c): the least atan2 over its corners, in radians.
//
// One atan2 where the order of the angles is plain: a corner whose angle is smaller than each other
// corner's by more than 1e-9 radians (from sin(k - m) = (s_k c_m - c_k s_m) / (r_k r_m), no
// atan2) has the smallest atan2 too, whose error is a few ulps, so min(pi, atan2 of that corner)
// is what the three calls give. Otherwise all three. (atan2 was a third of the triangulation.)
inline double smallest_angle(const float* a, const float* b, const float* c) {
  const float* p[3] = {a, b, c};
  double sine[3], cosine[3];  // times the lengths of the corner's two edges
  for (int k = 0; k < 3; ++k) {
    const float* o = p[k];
    const float* x = p[(k + 1) % 3];
    const float* y = p[(k + 2) % 3];
    double u[3] = {double(x[0]) - o[0], double(x[1]) - o[1], double(x[2]) - o[2]};
    double w[3] = {double(y[0]) - o[0], double(y[1]) - o[1], double(y[2]) - o[2]};
    double cross[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    sine[k] = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    cosine[k] = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
  }
  // Whether corner k's angle exceeds corner m's by more than 1e-9 radians.
  auto clearly_larger = [&](int k, int m) {
    const double difference = sine[k] * cosine[m] - cosine[k] * sine[m];
    return difference > 0 && difference * difference > 1e-18 * (sine[k] * sine[k] + cosine[k] * cosine[k]) *
                                                            (sine[m] * sine[m] + cosine[m] * cosine[m]);
  };
  for (int m = 0; m < 3; ++m) {
    const int k = m == 2 ? 0 : m + 1, l = k == 2 ? 0 : k + 1;
    if (clearly_larger(k, m) && clearly_larger(l, m)) return std::min(std::numbers::pi, std::atan2(sine[m], cosine[m]));
  }
  double smallest = std::numbers::pi;
  for (int k = 0; k < 3; ++k)
    smallest = std::min(smallest, std::atan2(sine[k], cosine[k]));  // atan2(0, 0) = 0: coincident points
  return smallest;
}

}  // namespace meshcvt
