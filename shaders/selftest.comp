// meshcvt GPU self-test: exercises what the clustering shaders rely on — 64-bit integer atomics
// (GL_EXT_shader_atomic_int64) on buffers reached through device addresses (GL_EXT_buffer_reference),
// push constants, a specialization-constant workgroup size, barriers between dispatches, and
// addresses beyond maxStorageBufferRange. The host (host/vk_selftest.cpp) checks results exactly.
#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require

layout(local_size_x_id = 0) in;

layout(buffer_reference, std430, buffer_reference_align = 8) buffer Int64s { int64_t v[]; };

// Must match SelfTestPush in host/vk_selftest.h (56 bytes).
layout(push_constant) uniform Push {
  Int64s inputs;         // mode 0: values to add; mode 2: the array to write into
  Int64s counters;       // counter_count + 1 sums (the last counts invocations)
  Int64s results;        // mode 1: combined sums; mode 3: spin results
  uint64_t index;        // mode 2: element to write
  int64_t value;         // mode 2: value to write
  uint count;            // invocations that do work
  uint counter_count;
  uint mode;             // 0 accumulate, 1 combine, 2 write one element, 3 spin
  uint spin;             // mode 3: loop iterations per invocation
} pc;

void main() {
  // 2D dispatch for big counts (see Sequence::dispatch_1d).
  uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * gl_WorkGroupSize.x + gl_LocalInvocationID.x;
  if (pc.mode == 0u) {
    if (i >= pc.count) return;
    atomicAdd(pc.counters.v[i % pc.counter_count], pc.inputs.v[i]);
    atomicAdd(pc.counters.v[pc.counter_count], int64_t(1));
  } else if (pc.mode == 1u) {
    // Reads the sums of the previous dispatch: correct only after a barrier.
    if (i >= pc.counter_count) return;
    pc.results.v[i] = pc.counters.v[i] * int64_t(3) - int64_t(i);
  } else if (pc.mode == 2u) {
    if (i != 0u) return;
    pc.inputs.v[uint(pc.index)] = pc.value;  // a 32-bit index reaches 32 GiB of int64
  } else {
    if (i >= pc.count) return;
    // A 64-bit LCG the compiler cannot fold: keeps the device busy for the timeout test.
    uint64_t x = uint64_t(i) + uint64_t(pc.value);
    for (uint k = 0u; k < pc.spin; ++k) x = x * 6364136223846793005ul + 1442695040888963407ul;
    pc.results.v[i] = int64_t(x);
  }
}
