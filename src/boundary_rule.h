// meshcvt: the four-case boundary test of Fan et al., Section 3.1 (and Section 4 for L2,1).
//
// This is THE rule; shaders/boundary_rule.glsl is its line-for-line GLSL twin and must stay so.
// Both evaluate in float with no contraction (-ffp-contract=off here, `precise` there) and in the
// same operation order, so the CPU and GPU engines take the same decisions bit for bit.
#pragma once

#include <cstdint>

namespace meshcvt {

/// Squares and products below this count as 0 in the rule. A device may flush subnormal results
/// (below 2^-126) to zero, and treat subnormal inputs as zero: NVIDIA's drivers do, and cannot
/// preserve them (shaderDenormPreserveFloat32 = 0). Flooring every square and product at 2^-100
/// on both engines keeps the rule's values the same there: a product whose exact value is below
/// 2^-100 is 0 on each (subnormal or not), one above it is the same normal float on each, a
/// subnormal input changes no product above it (coordinates are within [0, 1], weights small),
/// and sums of zeros and normal floats round alike. On meshes as they come the floor changes
/// nothing: in normalized coordinates it is a distance below 2^-50 (1e-15 of the bounding box),
/// or a face of area below 2^-100 / d.
constexpr float kRuleFloor = 0x1p-100f;

/// x * y, or 0 when that is below kRuleFloor (x, y >= 0).
inline float floored_product(float x, float y) {
  float r = x * y;
  return r < kRuleFloor ? 0.0f : r;
}

/// Squared distance |p - g|^2, summed x, y, z in that order, each square floored (kRuleFloor).
inline float squared_distance(const float p[3], const float g[3]) {
  float dx = p[0] - g[0];
  float dy = p[1] - g[1];
  float dz = p[2] - g[2];
  return (floored_product(dx, dx) + floored_product(dy, dy)) + floored_product(dz, dz);
}

/// Outcome of testing one cluster edge.
enum class EdgeMove : uint8_t {
  none,        ///< case 1: both faces are where they belong
  right_to_p,  ///< move T_r into V_p (case 2, or case 4 when that costs less)
  left_to_q,   ///< move T_l into V_q (case 3, or case 4 otherwise)
};

/// Case 4's comparison: whether the pair costs less in V_p (weighted sums of floored products).
inline bool case4_keeps_pair_in_p(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  float both_in_p = floored_product(d_lp, w_l) + floored_product(d_rp, w_r);
  float both_in_q = floored_product(d_lq, w_l) + floored_product(d_rq, w_r);
  return both_in_p < both_in_q;
}

/// The four cases for a cluster edge shared by T_l in V_p and T_r in V_q.
/// d_lp = |x_l - z_p|^2 etc.; w_l, w_r are the faces' weights (rho * area).
/// Orientation is fixed by the caller: T_l is always the face with the lower id, so that case 4's
/// tie (equal weighted sums) moves the lower face, whichever side looks at the edge.
inline EdgeMove decide_cluster_edge(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  bool left_stays = d_lp <= d_lq;
  bool right_stays = d_rp >= d_rq;
  if (left_stays && right_stays) return EdgeMove::none;      // case 1
  if (left_stays) return EdgeMove::right_to_p;                // case 2 (property 3.1)
  if (right_stays) return EdgeMove::left_to_q;                // case 3 (property 3.1)
  // case 4 (property 3.2): both want to move; keep the pair in the cluster where it costs less.
  return case4_keeps_pair_in_p(d_lp, d_lq, d_rp, d_rq, w_l, w_r) ? EdgeMove::right_to_p : EdgeMove::left_to_q;
}

/// Among several destinations proposed for one face by its cluster edges: the one at the smaller
/// distance wins, ties to the lower cluster id. Returns true when (d, c) beats (best_d, best_c).
inline bool better_destination(float d, uint32_t c, float best_d, uint32_t best_c) {
  return d < best_d || (d == best_d && c < best_c);
}

}  // namespace meshcvt
