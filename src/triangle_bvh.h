// meshcvt (internal): a bounding volume hierarchy over the triangles of a mesh, answering exact
// closest-point queries. Used for the surface error (approximation_error, quality.cpp) and for the
// CCVT generator (eq. 6 of the paper: the point of the mesh closest to a cluster's mass centroid).
//
// Layout: one flat array of 32-byte nodes (box + child/first-triangle + count), children of a node
// stored next to each other, triangles copied into leaf order so a leaf is one contiguous run.
// Built top-down with a binned surface-area heuristic in O(F log F), or along a Morton curve.
//
// Exactness: the point-to-triangle distance is computed in double from the float vertices
// (Ericson, Real-Time Collision Detection 5.1.5, with a fallback to the three edges for degenerate
// triangles). The traversal never prunes a box that could hold a triangle at the current best
// distance, so a query returns the same face and point as a brute-force loop over all faces with
// ties broken by the lower face id. A query is a pure function of the query point: the same
// result from any thread, in any order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Closest point on one triangle, in double. a, b, c: the corners; p: the query.
/// Writes the closest point to `closest` and returns its squared distance to p.
/// Degenerate triangles (repeated corners, collinear corners) are treated as their three edges.
double closest_point_on_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                                 double closest[3]);

class TriangleBvh {
 public:
  /// The closest point of the mesh to a query.
  struct Hit {
    float point[3] = {0, 0, 0};  ///< closest point, input units (rounded to float)
    uint32_t face = kNone;       ///< face id in the input's order; kNone when no face (empty BVH / beyond the bound)
    double distance2 = std::numeric_limits<double>::infinity();  ///< squared distance, input units squared
    double point_exact[3] = {0, 0, 0};                           ///< the same point in double, as computed
  };

  /// How the tree is built. Queries return the same hits from either (see Exactness above); only
  /// their speed and the build's differ.
  enum class Build {
    /// Binned surface-area heuristic, top-down: about 0.5 s of CPU per million faces, the fastest
    /// queries. For trees queried many times per face (the CCVT generator).
    sah,
    /// The faces sorted along a Morton curve of their centroids, split where the curve's leading
    /// bit changes (a linear BVH, Lauterbach et al. 2009): about 0.14 s per million faces on one
    /// thread (the 4.8M-face bunny: 0.64-0.68 s on 2026-11-28's VM, 0.48-0.50 s on two, where the
    /// SAH build took 2.15 s and 1.42 s on two threads some days before), queries somewhat slower.
    /// Every pass and the subtrees below the top levels run on `threads` threads (meshes above
    /// 65536 faces).
    /// For trees queried a few times per face (approximation_error).
    morton,
  };

  TriangleBvh() = default;

  /// Builds over `face_count` triangles: positions are 3 floats per vertex, indices 3 vertex ids
  /// per face (all < vertex count; not checked). The arrays are copied; they may be freed after.
  /// Faces with NaN/Inf coordinates are not supported (read_mesh rejects them).
  /// threads: how many threads may build (0: every core); the tree is the same for any number.
  /// Time O(F log F) (sah; morton: a radix sort and a linear pass); memory about 80 bytes per face.
  TriangleBvh(const float* positions, const uint32_t* indices, size_t face_count, unsigned threads = 0,
              Build build = Build::sah);
  explicit TriangleBvh(const Mesh& mesh, unsigned threads = 0, Build build = Build::sah)
      : TriangleBvh(mesh.positions.data(), mesh.indices.data(), mesh.face_count(), threads, build) {}

  /// Closest point of all faces to q. On an empty BVH returns a Hit with face == kNone.
  Hit closest_point(const double q[3]) const;
  Hit closest_point(const float q[3]) const;

  /// Closest point among the faces within squared distance `max_distance2` of q (inclusive);
  /// face == kNone when there is none. Faster than the unbounded query when a good bound is known
  /// (e.g. the distance from q to a point known to be on the mesh).
  Hit closest_point(const double q[3], double max_distance2) const;

  /// Closest points for `count` queries (3 doubles each), written to hits[0..count), spread over
  /// `threads` threads (0: every core). Same result as calling closest_point one by one.
  void closest_points(const double* queries, size_t count, Hit* hits, unsigned threads = 0) const;

  size_t face_count() const { return faces_.size(); }
  /// Whether two trees are the same to the byte: nodes, leaf order and triangles (the builds give
  /// the same tree for any thread count; tests check it).
  friend bool operator==(const TriangleBvh& a, const TriangleBvh& b);
  size_t node_count() const { return pairs_.empty() ? 0 : 2 * pairs_.size() - 1; }
  /// Bounding box of every face (zeros when empty).
  void bounds(float min[3], float max[3]) const;

  /// A node: box, then for an inner node (count == 0) the first of its two adjacent children, for a
  /// leaf the first triangle (in leaf order) and how many.
  struct Node {
    float min[3];
    uint32_t index;
    float max[3];
    uint32_t count;
  };

 private:
  // Two sibling nodes share one 64-byte cache line: a traversal step reads both children's boxes
  // with one memory access. Node i is pairs_[i / 2].node[i % 2]; the root is node 0 (node 1 unused),
  // so every pair of children starts at an even index.
  struct alignas(64) NodePair {
    Node node[2];
  };
  const Node& node(uint32_t i) const { return pairs_[i >> 1].node[i & 1]; }
  void prefetch_target(const Node& n) const;
  // The builders' node lists, as pairs (in `parts` ranges side by side).
  void set_nodes(const std::vector<Node>& nodes, unsigned parts = 1);
  std::vector<NodePair> pairs_;
  std::vector<float> triangles_;  // 9 floats per triangle, in leaf order
  std::vector<uint32_t> faces_;   // input face id per triangle, in leaf order
};

}  // namespace meshcvt
