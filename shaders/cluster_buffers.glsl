// meshcvt: what the clustering kernels (cluster_*.comp) share: the buffers, reached through a
// table of device addresses (no descriptor sets, so no array is limited by maxStorageBufferRange),
// the push constants, the invocation index of a 1D/2D dispatch and the vertex-ring walk.
// Must match GpuTable / GpuPush in host/gpu_engine.cpp.
#ifndef MESHCVT_CLUSTER_BUFFERS_GLSL
#define MESHCVT_CLUSTER_BUFFERS_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_KHR_shader_subgroup_ballot : require

layout(local_size_x_id = 0) in;

layout(buffer_reference, std430, buffer_reference_align = 4) buffer Uints { uint v[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) buffer Floats { float v[]; };
layout(buffer_reference, std430, buffer_reference_align = 8) buffer Int64s { int64_t v[]; };

// One address per array; sizes in host/gpu_engine.cpp.
layout(buffer_reference, std430, buffer_reference_align = 8) readonly buffer Table {
  Uints labels;          // per face: cluster
  Uints adjacent;        // 3 per face: Topology::face_adjacent
  Floats points;         // 3 per face: ClusterProblem::point
  Floats weights;        // per face
  Floats generators;     // 3 per cluster (written by the host)
  Int64s face_sums;         // 5 per face: ClusterProblem::face_fixed
  Int64s sums;           // 5 per cluster: W, Sx, Sy, Sz, Q in fixed point
  Uints destination;     // per face: proposed cluster (valid while state != 0)
  Uints state;           // per face: 0 no proposal, 1 proposed, 2 passed the disk tests
  Uints dirty;           // per face: 1 when it must be tested next iteration (moved, next to a move, refused)
  Uints proposals;       // faces with a proposal, in any order (counters[0] of them)
  Uints accepted;        // per proposal: 1 when it passed the rank test (c)
  Uints counters;        // 0 proposals, 1 moves, 2 evaluated faces, 3 changed clusters, 4 ring overflow
  Uints changed_flags;   // per cluster: 1 when its sums changed in the last iteration
  Uints changed_list;    // clusters whose sums changed (counters[3] of them)
  Int64s changed_sums;   // 5 per entry of changed_list: the new sums, for the host
  Uints indices;         // 3 per face: Mesh::indices
  Uints vertex_offsets;  // Topology::vertex_face_offsets
  Uints vertex_faces;    // Topology::vertex_faces
};

layout(push_constant) uniform Push {
  Table table;
  uint face_count;
  uint cluster_count;
  uint flags;  // FLAG_*
  uint count;  // invocations that do work (kernel-specific)
} pc;

const uint NONE = 0xffffffffu;
const uint FLAG_ACCELERATE = 1u;

const uint COUNTER_PROPOSALS = 0u;
const uint COUNTER_MOVES = 1u;
const uint COUNTER_EVALUATED = 2u;
const uint COUNTER_CHANGED = 3u;
const uint COUNTER_OVERFLOW = 4u;

// 2D dispatch for big counts (see Sequence::dispatch_1d).
uint invocation_index() {
  return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
}

vec3 face_point(Table t, uint f) { return vec3(t.points.v[3u * f], t.points.v[3u * f + 1u], t.points.v[3u * f + 2u]); }
vec3 generator(Table t, uint c) {
  return vec3(t.generators.v[3u * c], t.generators.v[3u * c + 1u], t.generators.v[3u * c + 2u]);
}

// atomicAdd(counters[which], 1) for each invocation that calls it, with one atomic per subgroup:
// returns the caller's slot (the counter's old value plus the caller's rank among the subgroup's
// callers). Thousands of invocations adding to one address serialize at the memory (the boundary
// test on 4.8M faces spent most of its time there on an H200); the slots are a permutation of the
// same values, and every list filled by them is read in any order.
uint counter_increment(Table t, uint which) {
  const uvec4 callers = subgroupBallot(true);
  uint base = 0u;
  if (subgroupElect()) base = atomicAdd(t.counters.v[which], subgroupBallotBitCount(callers));
  return subgroupBroadcastFirst(base) + subgroupBallotExclusiveBitCount(callers);
}

// Vertex ring of face f (faces sharing a vertex, f excluded) in increasing id, without repeats:
// a merge of the three sorted vertex lists, as gather_vertex_ring in src/cluster_iterate.cpp.
// ring_begin sets up the cursors; each ring_next returns the next face or NONE at the end.
void ring_begin(Table t, uint f, out uint b[3], out uint e[3]) {
  for (int j = 0; j < 3; ++j) {
    uint v = t.indices.v[3u * f + uint(j)];
    b[j] = t.vertex_offsets.v[v];
    e[j] = t.vertex_offsets.v[v + 1u];
  }
}
uint ring_next(Table t, uint f, inout uint b[3], uint e[3]) {
  for (;;) {
    uint next = NONE;
    for (int j = 0; j < 3; ++j)
      if (b[j] != e[j]) next = min(next, t.vertex_faces.v[b[j]]);
    if (next == NONE) return NONE;
    for (int j = 0; j < 3; ++j)
      if (b[j] != e[j] && t.vertex_faces.v[b[j]] == next) ++b[j];
    if (next != f) return next;
  }
}

#endif
