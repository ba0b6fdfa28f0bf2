// meshcvt: budgets of the margin accelerator (Fan et al. Section 5.2, made exact): how far the
// generators may move before a decision of the four-case rule (boundary_rule.h) could change. The
// CPU engine (cluster_iterate.cpp) re-tests a face only once a generator it read has moved, in
// total, by its budget; tests/test_cluster_speedups.cpp checks the budgets against perturbed
// generators.
#pragma once

#include <algorithm>
#include <cmath>

#include "boundary_rule.h"

namespace meshcvt {

// Relative error allowed on every float distance and weighted sum the rule compares: each is a few
// roundings of 2^-24 away from its exact value, far below this.
constexpr double kRoundoff = 1e-6;

// One side of a comparison: sum of w_i * d_i over up to two terms (d_i float distances).
struct RuleSide {
  double w[2], d[2];
  int n;
};

// The largest b such that, if every generator moves by less than b, the comparison a < b... that
// holds now, side_a < side_b, still holds after the float evaluation; 0 when it is too close to call.
// A distance d from a generator that moves by at most b is bounded by (sqrt(d) +- b)^2 (triangle
// inequality), widened by kRoundoff for float rounding before and after.
inline double comparison_budget(const RuleSide& a, const RuleSide& b) {
  const double up = (1 + kRoundoff) * (1 + kRoundoff), down = (1 - kRoundoff) * (1 - kRoundoff);
  double upper_a = 0, weight_a = 0, root_sum_a = 0, lower_b = 0, root_sum_b = 0;
  for (int i = 0; i < a.n; ++i) {
    double r = std::sqrt(a.d[i] / (1 - kRoundoff));
    upper_a += a.w[i] * r * r;
    weight_a += a.w[i];
    root_sum_a += a.w[i] * r;
  }
  for (int i = 0; i < b.n; ++i) {
    double r = std::sqrt(b.d[i] / (1 + kRoundoff));
    lower_b += b.w[i] * r * r;
    root_sum_b += b.w[i] * r;
  }
  // The rule floors squares and products (kRuleFloor): a distance may come out lower than its exact
  // value by up to three floors, a weighted sum by w times that plus a floor per term, now (side a's
  // bound starts from it) and after the move (side b's).
  double floored = 0;
  for (int i = 0; i < a.n; ++i) floored += (3 * a.w[i] + 1) * double(kRuleFloor);
  for (int i = 0; i < b.n; ++i) floored += (3 * b.w[i] + 1) * double(kRuleFloor);
  double slack = down * lower_b - up * upper_a - 2 * floored;
  if (!(slack > 0)) return 0;
  // growth of the bounds for a displacement t: up (2 t root_sum_a + t^2 weight_a) + down 2 t root_sum_b
  double qa = up * weight_a, qc = 2 * (up * root_sum_a + down * root_sum_b);
  if (qa == 0 && qc == 0) return 1e30;  // weightless: nothing can change
  double t = 2 * slack / (qc + std::sqrt(qc * qc + 4 * qa * slack));
  return t * (1 - kRoundoff);
}

// A one-term side of a comparison: the distance d alone.
inline RuleSide single_side(float d) { return RuleSide{{1, 0}, {d, 0}, 1}; }

// The comparisons of decide_cluster_edge (boundary_rule.h) for one edge, in its argument order, and
// the two weighted sides of case 4.
struct EdgeSides {
  RuleSide in_p, in_q;
  bool left_stays, right_stays, pair_in_p;
};
inline EdgeSides edge_sides(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r) {
  return {{{w_l, w_r}, {d_lp, d_rp}, 2}, {{w_l, w_r}, {d_lq, d_rq}, 2}, d_lp <= d_lq, d_rp >= d_rq,
          case4_keeps_pair_in_p(d_lp, d_lq, d_rp, d_rq, w_l, w_r)};
}

// Budget of a face that stays for one cluster edge (f in V_p, g in V_q): the smallest displacement
// of the generators of p or q that could make this edge move it. Same argument order as
// decide_cluster_edge; `face_is_left` says which of the edge's faces is the one staying.
inline double stay_budget(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r, bool face_is_left) {
  const EdgeSides e = edge_sides(d_lp, d_lq, d_rp, d_rq, w_l, w_r);
  const RuleSide &in_p = e.in_p, &in_q = e.in_q;
  const bool left_stays = e.left_stays, right_stays = e.right_stays, pair_in_p = e.pair_in_p;
  double budget = 0;
  if (face_is_left) {  // the left face stays iff left_stays || (!right_stays && pair_in_p)
    if (left_stays) budget = comparison_budget(single_side(d_lp), single_side(d_lq));
    if (!right_stays && pair_in_p)
      budget = std::max(budget, std::min(comparison_budget(single_side(d_rp), single_side(d_rq)), comparison_budget(in_p, in_q)));
  } else {  // the right face stays iff right_stays || (!left_stays && !pair_in_p)
    if (right_stays) budget = comparison_budget(single_side(d_rq), single_side(d_rp));
    if (!left_stays && !pair_in_p)
      budget = std::max(budget, std::min(comparison_budget(single_side(d_lq), single_side(d_lp)), comparison_budget(in_q, in_p)));
  }
  return budget;
}

// Budget of a face that moves by one cluster edge: the smallest displacement of the generators of
// p or q that could make this edge stop moving it. Same arguments as stay_budget.
inline double move_budget(float d_lp, float d_lq, float d_rp, float d_rq, float w_l, float w_r, bool face_is_left) {
  const EdgeSides e = edge_sides(d_lp, d_lq, d_rp, d_rq, w_l, w_r);
  const RuleSide &in_p = e.in_p, &in_q = e.in_q;
  const bool left_stays = e.left_stays, right_stays = e.right_stays, pair_in_p = e.pair_in_p;
  double either = 0;
  if (face_is_left) {  // the left face moves iff !left_stays && (right_stays || !pair_in_p)
    if (right_stays) either = comparison_budget(single_side(d_rq), single_side(d_rp));
    if (!pair_in_p) either = std::max(either, comparison_budget(in_q, in_p));
    return std::min(comparison_budget(single_side(d_lq), single_side(d_lp)), either);
  }
  // the right face moves iff !right_stays && (left_stays || pair_in_p)
  if (left_stays) either = comparison_budget(single_side(d_lp), single_side(d_lq));
  if (pair_in_p) either = std::max(either, comparison_budget(in_p, in_q));
  return std::min(comparison_budget(single_side(d_rp), single_side(d_rq)), either);
}

}  // namespace meshcvt
