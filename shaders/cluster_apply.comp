// meshcvt GPU kernel: applies the accepted moves, one invocation per proposal (BoundaryIteration::
// step, part 3). The face's label changes; its 5 fixed-point contributions (ClusterProblem::
// face_fixed, uploaded once) are added to the destination's sums and subtracted from the origin's
// with 64-bit atomics: integer sums do not depend on the order, so they equal the CPU's exactly.
// Changed clusters are flagged and listed once each; moved faces, their neighbours and refused
// faces are marked dirty for the next iteration's active set.
//
// flags bit 1 (FLAG_ALL_ACCEPTED): TopologyMode::paper, every proposal is accepted.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "cluster_buffers.glsl"

const uint FLAG_ALL_ACCEPTED = 2u;

void mark_changed(Table t, uint c) {
  if (atomicExchange(t.changed_flags.v[c], 1u) == 0u)
    t.changed_list.v[counter_increment(t, COUNTER_CHANGED)] = c;
}

void main() {
  const uint i = invocation_index();
  if (i >= pc.count) return;
  Table t = pc.table;
  const uint f = t.proposals.v[i];
  t.state.v[f] = 0u;
  if ((pc.flags & FLAG_ALL_ACCEPTED) == 0u && t.accepted.v[i] == 0u) {
    t.dirty.v[f] = 1u;  // refused: the rule still wants it to move, so test it again
    return;
  }
  const uint from = t.labels.v[f], to = t.destination.v[f];
  t.labels.v[f] = to;
  for (uint k = 0u; k < 5u; ++k) {
    int64_t v = t.face_sums.v[5u * f + k];
    atomicAdd(t.sums.v[5u * from + k], -v);
    atomicAdd(t.sums.v[5u * to + k], v);
  }
  counter_increment(t, COUNTER_MOVES);
  mark_changed(t, from);
  mark_changed(t, to);
  t.dirty.v[f] = 1u;
  for (uint e = 0u; e < 3u; ++e) {
    uint o = t.adjacent.v[3u * f + e];
    if (o != NONE) t.dirty.v[o] = 1u;  // every writer writes 1: the race is harmless
  }
}
