// meshcvt GPU kernel: bookkeeping of the changed-cluster list between iterations.
//  flags bit 2 clear (FLAG_CLEAR): clears the changed flags of the last iteration's list (count entries),
//    after the boundary kernel has read them.
//  else (gather): copies the sums of this iteration's changed clusters next to the list, so the host
//    downloads only those (counters[3] entries).
#version 460
#extension GL_GOOGLE_include_directive : require
#include "cluster_buffers.glsl"

const uint FLAG_CLEAR = 4u;

void main() {
  const uint i = invocation_index();
  Table t = pc.table;
  if ((pc.flags & FLAG_CLEAR) != 0u) {
    if (i < pc.count) t.changed_flags.v[t.changed_list.v[i]] = 0u;
    return;
  }
  if (i >= t.counters.v[COUNTER_CHANGED]) return;
  const uint c = t.changed_list.v[i];
  for (uint k = 0u; k < 5u; ++k) t.changed_sums.v[5u * i + k] = t.sums.v[5u * c + k];
}
