// meshcvt: Morton (Z-order) codes and their stable sort, shared by the locality order of large
// meshes (mesh_order.cpp) and the Morton build of the triangle BVH (triangle_bvh.cpp). Morton
// curves: G. M. Morton, 1966. Internal, not public API.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "parallel.h"

namespace meshcvt {

/// The 10 low bits of x spread to every third bit (bit k -> bit 3k): a 30-bit Morton code is
/// spread_bits(x) | spread_bits(y) << 1 | spread_bits(z) << 2.
inline uint32_t spread_bits(uint32_t x) {
  x &= 0x3ff;
  x = (x | (x << 16)) & 0x030000ff;
  x = (x | (x << 8)) & 0x0300f00f;
  x = (x | (x << 4)) & 0x030c30c3;
  x = (x | (x << 2)) & 0x09249249;
  return x;
}

/// Indices 0..n-1 sorted by key (30-bit keys: the bits above are ignored), stable: equal keys keep
/// their order, so the result is a function of the keys alone, whatever `parts`. Two counting
/// passes of 15 bits over (key, index) pairs; each pass splits the pairs into `parts` ranges
/// counted and scattered side by side (run_ranges), range p's pairs of a bucket placed after those
/// of the ranges before it, as one thread places them. O(n).
inline std::vector<uint32_t> sort_by_key(const std::vector<uint32_t>& key, unsigned parts = 1) {
  constexpr uint32_t kBuckets = 1u << 15;
  const size_t n = key.size();
  parts = std::max(1u, parts);
  const std::vector<uint32_t> bounds = even_bounds(n, parts);
  std::vector<uint64_t> pairs(n), scratch(n);
  run_ranges(bounds, [&](size_t begin, size_t end, size_t) {
    for (size_t i = begin; i < end; ++i) pairs[i] = uint64_t(key[i]) << 32 | i;
  });
  std::vector<uint32_t> start(size_t(parts) * kBuckets);  // range p's counts, then its next slots
  for (int shift : {32, 47}) {
    run_ranges(bounds, [&](size_t begin, size_t end, size_t part) {
      uint32_t* count = &start[part * kBuckets];
      std::fill(count, count + kBuckets, 0u);
      for (size_t i = begin; i < end; ++i) ++count[(pairs[i] >> shift) & 0x7fff];
    });
    uint32_t total = 0;
    for (uint32_t bucket = 0; bucket < kBuckets; ++bucket)
      for (unsigned part = 0; part < parts; ++part) {
        uint32_t& s = start[part * kBuckets + bucket];
        const uint32_t c = s;
        s = total;
        total += c;
      }
    run_ranges(bounds, [&](size_t begin, size_t end, size_t part) {
      uint32_t* next = &start[part * kBuckets];
      for (size_t i = begin; i < end; ++i) {
        const uint64_t p = pairs[i];
        scratch[next[(p >> shift) & 0x7fff]++] = p;
      }
    });
    pairs.swap(scratch);
  }
  std::vector<uint32_t> order(n);
  run_ranges(bounds, [&](size_t begin, size_t end, size_t) {
    for (size_t i = begin; i < end; ++i) order[i] = uint32_t(pairs[i]);
  });
  return order;
}

}  // namespace meshcvt
