// meshcvt GPU kernel: test (c) of the topology-preserving filter, one invocation per proposal.
// Twin of the second pass of the disk filter in BoundaryIteration::step: a proposal that passed
// (a) and (b) is refused when a lower-id face of its vertex ring also passed and involves one of
// its two clusters (as source or destination). Reads labels as they were: nothing moves yet.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "cluster_buffers.glsl"

void main() {
  const uint i = invocation_index();
  if (i >= pc.count) return;
  Table t = pc.table;
  const uint f = t.proposals.v[i];
  uint keep = 0u;
  if (t.state.v[f] == 2u) {
    keep = 1u;
    const uint from = t.labels.v[f], to = t.destination.v[f];
    uint b[3], e[3];
    ring_begin(t, f, b, e);
    for (uint g = ring_next(t, f, b, e); g != NONE && g < f; g = ring_next(t, f, b, e)) {
      if (t.state.v[g] != 2u) continue;
      uint g_from = t.labels.v[g], g_to = t.destination.v[g];
      if (g_from == from || g_from == to || g_to == from || g_to == to) {
        keep = 0u;
        break;
      }
    }
  }
  t.accepted.v[i] = keep;
}
