// meshcvt: the four-case boundary test of Fan et al., Section 3.1 (and Section 4 for L2,1), in GLSL.
//
// Line-for-line twin of src/boundary_rule.h: same function names, same operation order. Every
// arithmetic result that decides a move is `precise` (no contraction into FMAs, no reassociation),
// so the GPU takes the CPU engine's decisions bit for bit.
#ifndef MESHCVT_BOUNDARY_RULE_GLSL
#define MESHCVT_BOUNDARY_RULE_GLSL

// Squares and products below this (2^-100) count as 0: the same values on devices that flush
// subnormals (see kRuleFloor in src/boundary_rule.h).
const float RULE_FLOOR = 7.88860905e-31;

// x * y, or 0 when that is below RULE_FLOOR (x, y >= 0).
float floored_product(float x, float y) {
  precise float r = x * y;
  return r < RULE_FLOOR ? 0.0 : r;
}

// Squared distance |p - g|^2, summed x, y, z in that order, each square floored (RULE_FLOOR).
float squared_distance(vec3 p, vec3 g) {
  precise float dx = p.x - g.x;
  precise float dy = p.y - g.y;
  precise float dz = p.z - g.z;
  precise float d = (floored_product(dx, dx) + floored_product(dy, dy)) + floored_product(dz, dz);
  return d;
}

// Outcome of testing one cluster edge (EdgeMove).
const uint EDGE_NONE = 0u;        // case 1: both faces are where they belong
const uint EDGE_RIGHT_TO_P = 1u;  // move T_r into V_p (case 2, or case 4 when that costs less)
const uint EDGE_LEFT_TO_Q = 2u;   // move T_l into V_q (case 3, or case 4 otherwise)

// Case 4's comparison: whether the pair costs less in V_p (weighted sums of floored products).
bool case4_keeps_pair_in_p(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  precise float both_in_p = floored_product(d_lp, w_l) + floored_product(d_rp, w_r);
  precise float both_in_q = floored_product(d_lq, w_l) + floored_product(d_rq, w_r);
  return both_in_p < both_in_q;
}

// The four cases for a cluster edge shared by T_l in V_p and T_r in V_q; T_l is the lower face id.
uint decide_cluster_edge(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  bool left_stays = d_lp <= d_lq;
  bool right_stays = d_rp >= d_rq;
  if (left_stays && right_stays) return EDGE_NONE;     // case 1
  if (left_stays) return EDGE_RIGHT_TO_P;              // case 2 (property 3.1)
  if (right_stays) return EDGE_LEFT_TO_Q;              // case 3 (property 3.1)
  // case 4 (property 3.2): both want to move; keep the pair in the cluster where it costs less.
  return case4_keeps_pair_in_p(d_lp, d_lq, d_rp, d_rq, w_l, w_r) ? EDGE_RIGHT_TO_P : EDGE_LEFT_TO_Q;
}

// Among several destinations proposed for one face: the smaller distance wins, ties to the lower
// cluster id. True when (d, c) beats (best_d, best_c).
bool better_destination(float d, uint c, float best_d, uint best_c) {
  return d < best_d || (d == best_d && c < best_c);
}

#endif
