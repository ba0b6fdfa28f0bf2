// meshcvt GPU check of the boundary rule: evaluates shaders/boundary_rule.glsl's functions on
// cases made up by the host (host/vk_rule_check.cpp), which compares every result with
// src/boundary_rule.h bit for bit. The clustering's consistency tests only see the rule where a
// mesh happens to bring two candidates within a rounding of each other; these cases are made to,
// so a reordered sum, a lost `precise` (a fused multiply-add) or flushed subnormals show at once.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "boundary_rule.glsl"

layout(local_size_x_id = 0) in;

// One case: p.xyz, g.xyz, d_lp, d_lq, d_rp, d_rq, w_l, w_r, d, best_d, then c and best_c as bits
// (RuleCase in host/vk_rule_check.h, 16 words).
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer Cases { float v[]; };
// One result: squared_distance's bits, decide_cluster_edge, better_destination, 0 (RuleResult).
layout(buffer_reference, std430, buffer_reference_align = 4) writeonly buffer Results { uint v[]; };

// Must match RuleCheckPush in host/vk_rule_check.cpp (24 bytes).
layout(push_constant) uniform Push {
  Cases cases;
  Results results;
  uint count;
} pc;

void main() {
  // 2D dispatch for big counts (see Sequence::dispatch_1d).
  uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
  if (i >= pc.count) return;
  Cases c = pc.cases;
  const uint b = 16u * i;
  const vec3 p = vec3(c.v[b], c.v[b + 1u], c.v[b + 2u]);
  const vec3 g = vec3(c.v[b + 3u], c.v[b + 4u], c.v[b + 5u]);
  const float d = squared_distance(p, g);
  const uint edge = decide_cluster_edge(c.v[b + 6u], c.v[b + 7u], c.v[b + 8u], c.v[b + 9u], c.v[b + 10u], c.v[b + 11u]);
  const bool better = better_destination(c.v[b + 12u], floatBitsToUint(c.v[b + 14u]), c.v[b + 13u],
                                         floatBitsToUint(c.v[b + 15u]));
  Results r = pc.results;
  r.v[4u * i] = floatBitsToUint(d);
  r.v[4u * i + 1u] = edge;
  r.v[4u * i + 2u] = better ? 1u : 0u;
  r.v[4u * i + 3u] = 0u;
}
