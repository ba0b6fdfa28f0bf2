// meshcvt: the triangulation of a polygon in space that has the fewest bad triangles and then the
// largest smallest angle, by interval dynamic programming (Klincsek, "Minimal triangulations of
// polygonal domains", 1980). Used by the shape approximation's meshing (approximate.cpp) where a
// region's own coloring gives no valid triangulation. Internal, not public API.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "parallel.h"
#include "vec3.h"

namespace meshcvt {

/// What makes a triangle of the polygon bad (each costs 1; see triangulate_polygon).
struct PolygonTriangleRules {
  /// A triangle whose smallest angle has a sine at most this is a sliver: bad.
  double min_sine = 1e-6;
  /// With a non-zero `normal`, a triangle is bad unless dot(its normal, normal) is above this
  /// times the length of (b - a) x (c - a) (it faces along `normal`).
  double min_facing_cosine = 1e-6;
};

/// Triangulates the polygon with corners `corners` (m >= 3, in order around it; any units), among
/// all triangulations by diagonals, minimizing first the cost, then maximizing the smallest
/// sine of an angle over its triangles:
///   * cost = the number of bad triangles (slivers, or triangles not facing along `normal` when
///     `normal` is not zero; see PolygonTriangleRules) + m for each use of a diagonal (i, j) that
///     `allowed` forbids;
///   * allowed: m * m flags, allowed[i * m + j] == allowed[j * m + i] for every pair; 1 where the
///     diagonal between corners i and j may be used (read only for pairs that are not polygon edges).
/// Among triangulations equal in both, the one taken is fixed by the corners' order alone.
/// O(m^3) time, O(m^2) memory. pool (optional): from 128 corners, independent parts of the tables
/// are filled side by side; the result never depends on the thread count.
/// Output: `triangles` gets m - 2 triangles as 3 corner indices each, oriented as the polygon.
/// Returns the cost (0: no bad triangle, no forbidden diagonal).
uint32_t triangulate_polygon(std::span<const Vec3> corners, Vec3 normal, const std::vector<uint8_t>& allowed,
                             const PolygonTriangleRules& rules, WorkerPool* pool, std::vector<uint32_t>& triangles);

/// Whether triangulate_polygon(corners, normal, allowed, rules, ...) would return 0: whether the
/// polygon has a triangulation with no bad triangle and no forbidden diagonal (the same tests, to
/// the bit), decided without the qualities. A boolean interval dynamic programming over bit sets:
/// O(m^3 / 64) word operations plus the triangles tested, of which it stops at the first good one
/// per pair; O(m^2 / 32) words of memory. Cheaper than the triangulation when the answer is all
/// that is needed (a region that takes a fix when it has none). Returns nullopt when it would test
/// more than max_tests triangles (a polygon whose pairs have many candidates and few good ones).
std::optional<bool> has_perfect_triangulation(std::span<const Vec3> corners, Vec3 normal,
                                              const std::vector<uint8_t>& allowed, const PolygonTriangleRules& rules,
                                              uint64_t max_tests);

}  // namespace meshcvt
