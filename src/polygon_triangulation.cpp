// meshcvt: the triangulation of a polygon in space with the fewest bad triangles, then the largest
// smallest angle, by interval dynamic programming (Klincsek, "Minimal triangulations of polygonal
// domains", Annals of Discrete Mathematics 9, 1980). API in polygon_triangulation.h.
//
// Entry (i, j), i < j, is the best triangulation of the sub-polygon of corners i..j closed by the
// segment (i, j): its middle corner k and the two sub-polygons i..k and k..j. The order (cost, then
// -quality) is monotone under joining two sub-polygons with a triangle, so the optimum is exact.
//
// Why it is laid out as it is (the armadillo with 1% of its faces deleted -> 10 proxies: 1985
// polygons, 109 of them with 512 to 800 corners, 6e9 steps of the loop over k):
//  * each pair's entries are kept twice, at (i, j) and (j, i), so that the loop over k reads the
//    entries of (i, k) and (k, j) both along a row (by columns a polygon of 500 corners missed the
//    cache on every k: another armadillo with holes took 27.7 s, 17.7 s after, bench/RESULTS.md);
//  * 97% of the k are rejected by the first test, on the two sub-polygons' cost and quality alone,
//    before any geometry;
//  * the pairs go in tiles of kTile x kTile: pair (i, j) reads only pairs (i, k) and (k, j) with
//    i < k < j, which lie in its own tile (done before it: j ascending, i descending) or in tiles
//    of a nearer diagonal of tiles. The tiles of one diagonal are independent, so a pool fills them
//    side by side with one wait per diagonal (a wait per span of pairs, 500 of them per polygon,
//    cost more than the second core gave). Every pair reads the same entries and takes them in the
//    same order whatever the tiling and the thread count: the same triangulation (the armadillo
//    above: 9.8 s before the tiles, 5.3 s with them on two threads).
#include "polygon_triangulation.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <limits>

namespace meshcvt {

namespace {

// Side of the tiles of pairs, and the polygon size from which tiles are filled side by side. 16
// rather than 32: more tiles per diagonal for many cores (the armadillo above on 16 threads of the
// H200 machine: 4.3-4.5 s against 5.1-5.2 s), the same on two (5.25 s against 5.33 s); 64: 5.7 s.
constexpr uint32_t kTile = 16;
constexpr uint32_t kMinParallelCorners = 128;
constexpr uint32_t kNoCorner = std::numeric_limits<uint32_t>::max();

// The sine of the smallest angle of the triangle (i, k, j) when it is not bad (not a sliver, and
// facing along n unless n is zero), else -1. cr = (p[k] - p[i]) x (p[j] - p[i]); l.. are the
// lengths of its sides. The sine is twice the area over the product of the two shorter sides (the
// largest of the three products). One function for the dynamic programming and the test of a
// perfect triangulation, so that both call the same triangles bad.
double good_triangle_sine(Vec3 cr, Vec3 n, bool any_direction, const PolygonTriangleRules& rules, double lik,
                          double lkj, double lij) {
  const double area2 = length(cr);
  const double big = std::max({lkj * lij, lij * lik, lik * lkj});
  const double sine = big > 0 ? area2 / big : 0.0;
  if (sine > rules.min_sine && (any_direction || dot(cr, n) > rules.min_facing_cosine * area2)) return sine;
  return -1.0;
}

}  // namespace

uint32_t triangulate_polygon(std::span<const Vec3> p, Vec3 n, const std::vector<uint8_t>& allowed,
                             const PolygonTriangleRules& rules, WorkerPool* pool, std::vector<uint32_t>& triangles) {
  const uint32_t m = uint32_t(p.size());
  assert(m >= 3 && allowed.size() == size_t(m) * m);
  triangles.clear();
  const bool any_direction = dot(n, n) == 0;
  // Edge lengths, once per pair, mirrored like the tables.
  std::vector<double> len(size_t(m) * m);
  for (uint32_t i = 0; i < m; ++i)
    for (uint32_t j = i + 1; j < m; ++j) len[size_t(i) * m + j] = len[size_t(j) * m + i] = length(p[j] - p[i]);
  const uint32_t kWorst = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> cost(size_t(m) * m, kWorst), choice(size_t(m) * m, kNoCorner);
  std::vector<double> quality(size_t(m) * m, -1.0);
  for (uint32_t i = 0; i + 1 < m; ++i) {
    cost[size_t(i) * m + i + 1] = cost[size_t(i + 1) * m + i] = 0;
    quality[size_t(i) * m + i + 1] = quality[size_t(i + 1) * m + i] = std::numeric_limits<double>::infinity();
  }
  // The best middle corner of the sub-polygon i..j (i < j - 1), from the entries of shorter ones.
  auto solve = [&](uint32_t i, uint32_t j) {
    const size_t ij = size_t(i) * m + j;
    const size_t row_i = size_t(i) * m, row_j = size_t(j) * m;  // (i, k) at row_i + k, (k, j) at row_j + k
    uint32_t best_cost = cost[ij];
    double best_quality = quality[ij];
    uint32_t best_k = kNoCorner;
    for (uint32_t k = i + 1; k < j; ++k) {
      const size_t ik = row_i + k, kj = row_j + k;
      uint32_t c = cost[ik] + cost[kj];
      double q = std::min(quality[ik], quality[kj]);
      if (c > best_cost || (c == best_cost && !(q > best_quality))) continue;  // cannot do better
      if (!allowed[ik] || !allowed[kj]) c += m;
      const double sine =
          good_triangle_sine(cross(p[k] - p[i], p[j] - p[i]), n, any_direction, rules, len[ik], len[kj], len[ij]);
      if (sine >= 0)
        q = std::min(q, sine);
      else
        ++c;
      if (c < best_cost || (c == best_cost && q > best_quality)) best_cost = c, best_quality = q, best_k = k;
    }
    assert(best_k != kNoCorner);  // the first k always beats kWorst
    cost[ij] = cost[row_j + i] = best_cost;
    quality[ij] = quality[row_j + i] = best_quality;
    choice[ij] = best_k;
  };
  const uint32_t tiles = (m + kTile - 1) / kTile;
  auto solve_tile = [&](uint32_t ti, uint32_t tj) {
    const uint32_t i_end = std::min(m, (ti + 1) * kTile), j_end = std::min(m, (tj + 1) * kTile);
    for (uint32_t j = std::max(tj * kTile, 2u); j < j_end; ++j)
      for (uint32_t i = std::min(i_end, j - 1); i-- > ti * kTile;) solve(i, j);
  };
  const bool side_by_side = pool != nullptr && pool->size() > 1 && m >= kMinParallelCorners;
  for (uint32_t d = 0; d < tiles; ++d) {  // the diagonals of tiles, tile (t, t + d)
    if (side_by_side && tiles - d > 1)
      pool->run(
          tiles - d,
          [&](size_t first, size_t last, unsigned) {
            for (size_t t = first; t < last; ++t) solve_tile(uint32_t(t), uint32_t(t) + d);
          },
          2);
    else
      for (uint32_t t = 0; t + d < tiles; ++t) solve_tile(t, t + d);
  }
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0, m - 1}};
  while (!stack.empty()) {
    auto [i, j] = stack.back();
    stack.pop_back();
    if (j < i + 2) continue;
    uint32_t k = choice[size_t(i) * m + j];
    triangles.insert(triangles.end(), {i, k, j});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
  return cost[m - 1];
}

std::optional<bool> has_perfect_triangulation(std::span<const Vec3> p, Vec3 n, const std::vector<uint8_t>& allowed,
                                              const PolygonTriangleRules& rules, uint64_t max_tests) {
  const uint32_t m = uint32_t(p.size());
  assert(m >= 3 && allowed.size() == size_t(m) * m);
  const bool any_direction = dot(n, n) == 0;
  // usable(i, k): the sub-polygon i..k (i < k) has a perfect triangulation and its side (i, k) may
  // be used, as bits: by_first[i] holds bit k, by_last[k] holds bit i.
  const size_t words = (m + 63) / 64;
  std::vector<uint64_t> by_first(size_t(m) * words, 0), by_last(size_t(m) * words, 0);
  auto set_usable = [&](uint32_t i, uint32_t k) {
    by_first[size_t(i) * words + k / 64] |= uint64_t(1) << (k % 64);
    by_last[size_t(k) * words + i / 64] |= uint64_t(1) << (i % 64);
  };
  for (uint32_t i = 0; i + 1 < m; ++i)
    if (allowed[size_t(i) * m + i + 1]) set_usable(i, i + 1);
  uint64_t tests = 0;
  // Pair (i, j) reads pairs (i, k) and (k, j) with i < k < j: j ascending, i descending.
  for (uint32_t j = 2; j < m; ++j)
    for (uint32_t i = j - 1; i-- > 0;) {
      const uint64_t* first = &by_first[size_t(i) * words];
      const uint64_t* last = &by_last[size_t(j) * words];
      bool perfect = false;
      for (uint32_t w = (i + 1) / 64; w <= (j - 1) / 64 && !perfect; ++w) {
        uint64_t middle = first[w] & last[w];  // only bits i < k < j can be set in both
        while (middle != 0) {
          const uint32_t k = w * 64 + uint32_t(std::countr_zero(middle));
          middle &= middle - 1;
          if (++tests > max_tests) return std::nullopt;
          const double sine = good_triangle_sine(cross(p[k] - p[i], p[j] - p[i]), n, any_direction, rules,
                                                 length(p[k] - p[i]), length(p[j] - p[k]), length(p[j] - p[i]));
          if (sine >= 0) {
            perfect = true;
            break;
          }
        }
      }
      if (!perfect) continue;
      if (i == 0 && j == m - 1) return true;
      if (allowed[size_t(i) * m + j]) set_usable(i, j);
    }
  return false;
}

}  // namespace meshcvt
