// meshcvt: Morton (Z-order) codes and their stable sort, shared by the locality order of large
// meshes (mesh_order.cpp) and the Morton build of the triangle BVH (triangle_bvh.cpp). Morton
// curves: G. M. Morton, 1966. Internal, not public API.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

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
/// their order, so the result is a function of the keys alone. Two counting passes of 15 bits over
/// (key, index) pairs, each reading its input in order. O(n).
inline std::vector<uint32_t> sort_by_key(const std::vector<uint32_t>& key) {
  const size_t n = key.size();
  std::vector<uint64_t> pairs(n), scratch(n);
  for (size_t i = 0; i < n; ++i) pairs[i] = uint64_t(key[i]) << 32 | i;
  std::vector<uint32_t> start(1u << 15);
  for (int shift : {32, 47}) {
    std::fill(start.begin(), start.end(), 0);
    for (uint64_t p : pairs) ++start[(p >> shift) & 0x7fff];
    uint32_t total = 0;
    for (uint32_t& s : start) {
      uint32_t c = s;
      s = total;
      total += c;
    }
    for (uint64_t p : pairs) scratch[start[(p >> shift) & 0x7fff]++] = p;
    pairs.swap(scratch);
  }
  std::vector<uint32_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = uint32_t(pairs[i]);
  return order;
}

}  // namespace meshcvt
