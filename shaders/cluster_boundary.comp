// meshcvt GPU kernel: the boundary test of Fan et al., Section 3.1, one invocation per face.
// Twin of BoundaryIteration::evaluate_range (src/cluster_iterate.cpp): a face on a cluster border
// tests each cluster edge with the four-case rule (T_l = the lower face id), keeps the moves the
// rule decides for itself, the closest destination winning (ties to the lower cluster id), and
// appends itself to the proposal list (order does not matter: every later decision is per face).
//
// Active set (the accelerator of Section 5.2, exact): with FLAG_ACCELERATE, a face is tested only
// when it is dirty (moved, next to a move, or refused last iteration) or its cluster or a
// neighbour's cluster changed: otherwise every input of its decision is as before and it would
// decide "stay" again. This is a superset of the CPU engine's active set (same decisions; the count
// of evaluated faces may be larger).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "cluster_buffers.glsl"
#include "boundary_rule.glsl"

void main() {
  const uint f = invocation_index();
  if (f >= pc.face_count) return;
  Table t = pc.table;
  const uint p = t.labels.v[f];
  bool test_it = (pc.flags & FLAG_ACCELERATE) == 0u;
  if (t.dirty.v[f] != 0u) {
    t.dirty.v[f] = 0u;
    test_it = true;
  }
  if (t.changed_flags.v[p] != 0u) test_it = true;
  uint adj[3], lab[3];
  bool border = false;
  for (int e = 0; e < 3; ++e) {
    adj[e] = t.adjacent.v[3u * f + uint(e)];
    lab[e] = adj[e] == NONE ? p : t.labels.v[adj[e]];
    if (lab[e] != p) {
      border = true;
      if (t.changed_flags.v[lab[e]] != 0u) test_it = true;
    }
  }
  if (!test_it || !border) return;
  counter_increment(t, COUNTER_EVALUATED);

  const vec3 xf = face_point(t, f);
  const float w_f = t.weights.v[f];
  const float d_own = squared_distance(xf, generator(t, p));
  float best_d = 0.0;
  uint best = NONE;
  for (int e = 0; e < 3; ++e) {
    const uint g = adj[e];
    if (g == NONE) continue;
    const uint q = lab[e];
    if (q == p) continue;
    const vec3 xg = face_point(t, g);
    const vec3 zq = generator(t, q);
    const float d_fq = squared_distance(xf, zq);
    const float d_gp = squared_distance(xg, generator(t, p));
    const float d_gq = squared_distance(xg, zq);
    bool f_moves;
    if (f < g)  // f is T_l in V_p, g is T_r in V_q
      f_moves = decide_cluster_edge(d_own, d_fq, d_gp, d_gq, w_f, t.weights.v[g]) == EDGE_LEFT_TO_Q;
    else        // g is T_l in V_q, f is T_r in V_p
      f_moves = decide_cluster_edge(d_gq, d_gp, d_fq, d_own, t.weights.v[g], w_f) == EDGE_RIGHT_TO_P;
    if (f_moves && (best == NONE || better_destination(d_fq, q, best_d, best))) {
      best = q;
      best_d = d_fq;
    }
  }
  if (best != NONE) {
    t.destination.v[f] = best;
    t.state.v[f] = 1u;
    t.proposals.v[counter_increment(t, COUNTER_PROPOSALS)] = f;
  }
}
