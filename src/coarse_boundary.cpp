// meshcvt: puts the coarse vertices of the clusters along the input's boundary onto that boundary,
// and onto its corners (declared in coarse_boundary.h), a step of uniform coarsening (Fan et al.
// Section 6.1) for open surfaces, which the paper does not treat.
//
// Why: a coarse vertex is one point of its cluster (VertexPlacement). For a cluster on the boundary
// that point lies inside the surface, about a third of a coarse edge in from the boundary, so the
// coarse mesh's boundary ran inside the input's and cut off each of its corners. plane.off (a flat
// square, CGAL's demo data) -> 228 had a Hausdorff distance of 3.3% of its diagonal, all of it at
// the four corners (now 0); patch-01 -> 199 5.7% (now 3.7%), three_peaks -> 524 3.3% (now 2.2%).
//
// A cluster of a defect-free dual meets a boundary loop in at most one arc (two are a
// boundary_arcs defect): a chain of input boundary edges whose faces are the cluster's. Its vertex
// goes onto
//   * the sharpest corner of the loop on the arc, where the loop turns by at least kCornerTurnDeg
//     over a quarter of the cluster's coarse edge on each side (measured over a distance, so that
//     the jagged boundary of a scan has no corners, and the corner is the sharpest within that
//     distance). A corner at an end of an arc is shared with the next cluster along the loop; it
//     goes to one of the two: the one that has no corner of its own, the nearer if neither has
//     (sharpest corners first). Then a boundary edge of the coarse mesh ends at each corner;
//   * else the closest point of the arc to the vertex.
// A move is kept only when none of the vertex's coarse triangles loses its area or turns its
// normal by more than kMaxTurnDeg (where the arc lies across a fold from the point); a refused
// corner goes to the other cluster at it, or its cluster takes the closest point. Then the
// vertices off corners slide along their arcs toward the middle of their boundary neighbours
// where that improves their triangles, as relax does inside. A loop whose arcs are short against
// their clusters' coarse edges (kMinArcShare: a hole smaller than the triangles around it) is
// left alone. Vertices move one after the other in cluster order, each judged against the
// positions at that moment, so the result does not depend on the thread count.
//
// coarsen_clustering runs this after the relax, relaxes the other vertices around the new
// positions, and then calls back_off_boundary_vertices; it undoes all of it where the quality
// columns' limits would suffer (CoarsenOptions::boundary_onto_input).
//
// Cost: a pass over the faces for the boundary edges and the cluster areas, then walks along the
// loops: O(F + boundary vertices * window); the relax passes after it cost more.
#include "coarse_boundary.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "coarse_rings.h"
#include "triangle_angle.h"
#include "vec3.h"

namespace meshcvt::detail {

namespace {

// A loop turning by at least this (degrees) over a quarter of a coarse edge on each side of a
// vertex has a corner there: a square's corner turns by 90, a hexagonal hole by 60 at each of its
// corners; a circular hole around k coarse vertices by about 180 / k over that distance (below 45
// for k >= 4).
constexpr double kCornerTurnDeg = 45;
// A loop's clusters go onto it only where its arcs are on average at least this fraction of their
// clusters' coarse edges long.
constexpr double kMinArcShare = 0.7;
// The window on each side of a vertex is a quarter of the coarse edge of its cluster (below), at
// most this many input edges.
constexpr uint32_t kMaxWindowEdges = 64;
// A move onto the boundary may turn a coarse triangle's normal by at most this (degrees).
constexpr double kMaxTurnDeg = 60;
// Slides along the arcs: at most this many passes; a slide may turn a triangle's normal by at most
// kSlideMaxTurnDeg (relax's limit), and may lower the smallest angle of the vertex's triangles
// only while that stays at or above kSlideSafeDeg (relax's margin over 30 degrees).
constexpr uint32_t kSlidePasses = 4;
constexpr double kSlideMaxTurnDeg = 20;
constexpr double kSlideSafeDeg = 35;
// After the relax around them: a vertex on the boundary with a triangle below this (degrees) goes
// back toward its placed point.
constexpr double kBackOffDeg = 30;

// The closest point of segment [a, b] to p.
Vec3 closest_on_segment(Vec3 p, Vec3 a, Vec3 b) {
  const Vec3 ab = b - a;
  const double l2 = dot(ab, ab);
  if (!(l2 > 0)) return a;
  const double t = std::clamp(dot(p - a, ab) / l2, 0.0, 1.0);
  return a + t * ab;
}

// v's triangles with v at q: whether each keeps an area and turns its normal by at most
// `max_turn_deg` from now; their smallest angle (radians) and sum of Q (as quality.cpp's).
struct RingShape {
  bool valid;
  double min_angle, q_sum;
};
RingShape shape_around(const Mesh& coarse, const std::vector<uint32_t>& ring_offsets, const std::vector<uint32_t>& ring,
                       uint32_t v, const float q[3], double max_turn_deg) {
  const double min_cos = std::cos(max_turn_deg * std::numbers::pi / 180);
  RingShape shape = {true, std::numbers::pi, 0.0};
  for (uint32_t i = ring_offsets[v]; i < ring_offsets[v + 1]; ++i) {
    const uint32_t* t = &coarse.indices[3 * size_t(ring[i])];
    const float* after[3];
    Vec3 b[3], a[3];
    for (int k = 0; k < 3; ++k) {
      after[k] = t[k] == v ? q : &coarse.positions[3 * size_t(t[k])];
      b[k] = mesh_vertex(coarse, t[k]);
      a[k] = {after[k][0], after[k][1], after[k][2]};
    }
    const Vec3 m0 = cross(b[1] - b[0], b[2] - b[0]), m1 = cross(a[1] - a[0], a[2] - a[0]);
    const double l0 = length(m0), l1 = length(m1);
    if (!(l1 > 0) || (l0 > 0 && !(dot(m0, m1) >= min_cos * l0 * l1))) return RingShape{false, 0, 0};
    shape.min_angle = std::min(shape.min_angle, smallest_angle(after[0], after[1], after[2]));
    const double e0 = length(a[1] - a[0]), e1 = length(a[2] - a[1]), e2 = length(a[0] - a[2]);
    shape.q_sum += (6 / std::sqrt(3.0)) * 0.5 * l1 / (0.5 * (e0 + e1 + e2) * std::max({e0, e1, e2}));
  }
  return shape;
}

}  // namespace

BoundarySnapCounts snap_boundary_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& labels, std::vector<uint8_t>& moved) {
  BoundarySnapCounts counts;
  moved.assign(coarse.vertex_count(), 0);
  const size_t faces = mesh.face_count(), n = coarse.vertex_count(), vertices = mesh.vertex_count();
  if (topology.boundary_edges == 0 || topology.nonmanifold_edges > 0 || topology.nonmanifold_vertices > 0 ||
      topology.collapsed_faces > 0 || topology.orientation_flips > 0 || labels.size() != faces)
    return counts;

  // The boundary half-edges (3 f + e, from corner e to corner e + 1 of face f): at a manifold
  // vertex of a consistently oriented mesh one leaves and one enters, so the loops are chains of
  // them. Per cluster its area, for its coarse edge.
  std::vector<uint32_t> leaving(vertices, kNone), entering(vertices, kNone);
  std::vector<double> cluster_area(n, 0.0);
  for (size_t f = 0; f < faces; ++f) {
    if (labels[f] >= n) return counts;
    cluster_area[labels[f]] += face_area(mesh, f);
    for (int e = 0; e < 3; ++e) {
      if (topology.face_adjacent[3 * f + e] != kNone) continue;
      const uint32_t h = uint32_t(3 * f + e);
      const uint32_t from = mesh.indices[h], to = mesh.indices[3 * f + (e + 1) % 3];
      if (leaving[from] != kNone || entering[to] != kNone) return counts;  // (not a manifold boundary)
      leaving[from] = h;
      entering[to] = h;
    }
  }
  // Every boundary vertex enters and leaves once: the walks below follow closed loops.
  for (size_t v = 0; v < vertices; ++v)
    if ((leaving[v] == kNone) != (entering[v] == kNone)) return counts;
  auto face_of = [](uint32_t h) { return h / 3; };
  auto head = [&](uint32_t h) { return mesh.indices[3 * size_t(h / 3) + (h % 3 + 1) % 3]; };  // the vertex h enters
  auto tail = [&](uint32_t h) { return mesh.indices[h]; };                                    // the vertex h leaves

  // The turn of the loop at each boundary vertex, over a window of a quarter of the coarse edge of
  // its entering edge's cluster (an equilateral triangulation has sqrt(3) / 2 e^2 of area per
  // vertex) on each side; `reach`: how many edges the window spans on each side.
  std::vector<double> turn(vertices, 0.0);
  std::vector<uint32_t> reach(vertices, 0);
  for (uint32_t v = 0; v < vertices; ++v) {
    if (leaving[v] == kNone) continue;
    const double window = 0.25 * std::sqrt(2.0 * cluster_area[labels[face_of(entering[v])]] / std::sqrt(3.0));
    const Vec3 p = mesh_vertex(mesh, v);
    uint32_t back = v, ahead = v, steps = 0;
    double back_length = 0, ahead_length = 0;
    bool wrapped = false;  // the two sides met: a loop within about two windows has no corner
    while (steps < kMaxWindowEdges && (back_length < window || ahead_length < window) && !wrapped) {
      ++steps;
      if (back_length < window) {
        const uint32_t w = tail(entering[back]);
        back_length += length(mesh_vertex(mesh, back) - mesh_vertex(mesh, w));
        back = w;
        wrapped = wrapped || back == ahead || back == v;
      }
      if (ahead_length < window) {
        const uint32_t w = head(leaving[ahead]);
        ahead_length += length(mesh_vertex(mesh, w) - mesh_vertex(mesh, ahead));
        ahead = w;
        wrapped = wrapped || ahead == back || ahead == v;
      }
    }
    reach[v] = steps;
    const Vec3 in = p - mesh_vertex(mesh, back), out = mesh_vertex(mesh, ahead) - p;
    const double li = length(in), lo = length(out);
    if (wrapped || !(li > 0) || !(lo > 0)) continue;
    turn[v] = std::acos(std::clamp(dot(in, out) / (li * lo), -1.0, 1.0)) * 180 / std::numbers::pi;
  }
  // Corners: a turn of at least kCornerTurnDeg, the largest within the vertex's window (ties: the
  // lower vertex id).
  std::vector<uint8_t> corner(vertices, 0);
  for (uint32_t v = 0; v < vertices; ++v) {
    if (!(turn[v] >= kCornerTurnDeg)) continue;
    bool sharpest = true;
    uint32_t back = v, ahead = v;
    for (uint32_t s = 0; s < reach[v] && sharpest; ++s) {
      back = tail(entering[back]);
      ahead = head(leaving[ahead]);
      for (uint32_t w : {back, ahead})
        if (w != v && (turn[w] > turn[v] || (turn[w] == turn[v] && w < v))) sharpest = false;
    }
    corner[v] = sharpest;
  }

  // Each cluster's arc: the run of boundary edges of its faces along a loop. A cluster with one
  // run starts it at its only edge whose predecessor is another cluster's (a cluster holding a
  // whole loop has no such edge and keeps its point).
  std::vector<uint32_t> runs(n, 0), run_start(n, kNone);
  for (uint32_t v = 0; v < vertices; ++v) {
    const uint32_t h = leaving[v];
    if (h == kNone) continue;
    const uint32_t c = labels[face_of(h)];
    if (labels[face_of(entering[v])] != c) ++runs[c], run_start[c] = h;
  }
  // The loops: each boundary vertex's loop, and per loop its length, its arcs (clusters) and the
  // sum of their coarse edges. A loop whose arcs are short against the coarse edges of their
  // clusters (a hole smaller than the triangles around it) is left alone: its clusters' vertices on
  // it would crowd its rim and make thin triangles, and then coarsen_clustering undoes the whole
  // step (head.off -> 48, 60, 126 with its small holes taken: undone each time; without them,
  // Hausdorff distance 8.07 -> 5.07, 7.63 -> 4.38, 5.36 -> 4.64% of the diagonal).
  std::vector<uint32_t> loop_of(vertices, kNone);
  std::vector<double> loop_length, loop_edges;
  for (uint32_t v = 0; v < vertices; ++v) {
    if (leaving[v] == kNone || loop_of[v] != kNone) continue;
    const uint32_t id = uint32_t(loop_length.size());
    double total = 0, edges = 0;
    for (uint32_t w = v; loop_of[w] == kNone;) {
      loop_of[w] = id;
      const uint32_t h = leaving[w], x = head(h);
      total += length(mesh_vertex(mesh, x) - mesh_vertex(mesh, w));
      const uint32_t c = labels[face_of(h)];
      if (labels[face_of(entering[w])] != c) edges += std::sqrt(2.0 * cluster_area[c] / std::sqrt(3.0));
      w = x;
    }
    loop_length.push_back(total);
    loop_edges.push_back(edges);
  }
  for (uint32_t c = 0; c < n; ++c) {
    if (runs[c] != 1) continue;
    const uint32_t l = loop_of[tail(run_start[c])];
    if (!(loop_length[l] >= kMinArcShare * loop_edges[l])) runs[c] = 0;  // (mean arc against mean edge)
  }
  // Per cluster with one arc: its first and last vertices (shared with the clusters before and
  // after it along the loop), and its sharpest corner strictly inside.
  std::vector<uint32_t> arc_first(n, kNone), arc_last(n, kNone), inner_corner(n, kNone);
  for (uint32_t c = 0; c < n; ++c) {
    if (runs[c] != 1) continue;
    uint32_t h = run_start[c];
    arc_first[c] = tail(h);
    uint32_t best = kNone;
    for (;;) {
      const uint32_t v = head(h), next = leaving[v];
      if (labels[face_of(next)] != c) {
        arc_last[c] = v;
        break;
      }
      if (corner[v] && (best == kNone || turn[v] > turn[best] || (turn[v] == turn[best] && v < best))) best = v;
      h = next;
    }
    inner_corner[c] = best;
  }
  // Each arc's points, in loop order (CSR), for the moves and the slides below.
  std::vector<uint32_t> arc_offsets(n + 1, 0);
  std::vector<Vec3> arc_points;
  for (uint32_t c = 0; c < n; ++c) {
    if (runs[c] == 1) {
      arc_points.push_back(mesh_vertex(mesh, arc_first[c]));
      for (uint32_t h = run_start[c];; h = leaving[head(h)]) {
        arc_points.push_back(mesh_vertex(mesh, head(h)));
        if (head(h) == arc_last[c]) break;
      }
    }
    arc_offsets[c + 1] = uint32_t(arc_points.size());
  }
  // The point of c's arc closest to p, and its distance along the arc from the arc's start.
  auto closest_on_arc = [&](uint32_t c, Vec3 p, double& along) {
    Vec3 best = arc_points[arc_offsets[c]];
    double best_d2 = dot(best - p, best - p), walked = 0;
    along = 0;
    for (uint32_t i = arc_offsets[c]; i + 1 < arc_offsets[c + 1]; ++i) {
      const Vec3 a = arc_points[i], b = arc_points[i + 1];
      const Vec3 q = closest_on_segment(p, a, b);
      const double d2 = dot(q - p, q - p);
      if (d2 < best_d2) best_d2 = d2, best = q, along = walked + length(q - a);
      walked += length(b - a);
    }
    return best;
  };
  // The point of c's arc `along` from its start (clamped to the arc).
  auto arc_point_at = [&](uint32_t c, double along) {
    for (uint32_t i = arc_offsets[c]; i + 1 < arc_offsets[c + 1]; ++i) {
      const Vec3 a = arc_points[i], b = arc_points[i + 1];
      const double l = length(b - a);
      if (along <= l) return l > 0 ? a + (std::max(along, 0.0) / l) * (b - a) : a;
      along -= l;
    }
    return arc_points[arc_offsets[c + 1] - 1];
  };

  std::vector<uint32_t> ring_offsets, ring;
  coarse_triangle_rings(coarse, ring_offsets, ring);
  auto ring_shape = [&](uint32_t v, const float q[3], double max_turn_deg) {
    return shape_around(coarse, ring_offsets, ring, v, q, max_turn_deg);
  };
  auto store = [&](uint32_t v, const float q[3]) {
    for (int d = 0; d < 3; ++d) coarse.positions[3 * size_t(v) + d] = q[d];
  };
  auto to_float = [](Vec3 p, float out[3]) { out[0] = float(p.x), out[1] = float(p.y), out[2] = float(p.z); };

  // The moves onto the boundary: first each cluster's own corner, then the corners at the ends of
  // arcs, sharpest first, each to the nearer of its two clusters that has not moved yet, or else
  // to the other; then the arcs' closest points for the rest. Each in cluster order.
  std::vector<uint8_t> on_arc(n, 0);  // 1: on its arc and free to slide along it; 2: on a corner
  auto try_corner = [&](uint32_t c, uint32_t v) {
    float q[3];
    to_float(mesh_vertex(mesh, v), q);
    if (!ring_shape(c, q, kMaxTurnDeg).valid) return false;
    store(c, q);
    on_arc[c] = 2;
    ++counts.moved;
    ++counts.corners;
    return true;
  };
  auto free_cluster = [&](uint32_t c) { return runs[c] == 1 && on_arc[c] == 0 && ring_offsets[c + 1] > ring_offsets[c]; };
  for (uint32_t c = 0; c < n; ++c)
    if (inner_corner[c] != kNone && free_cluster(c)) try_corner(c, inner_corner[c]);
  std::vector<uint32_t> junctions;
  for (uint32_t v = 0; v < vertices; ++v)
    if (corner[v] && labels[face_of(entering[v])] != labels[face_of(leaving[v])]) junctions.push_back(v);
  std::sort(junctions.begin(), junctions.end(),
            [&](uint32_t a, uint32_t b) { return turn[a] != turn[b] ? turn[a] > turn[b] : a < b; });
  for (uint32_t v : junctions) {
    uint32_t first = labels[face_of(entering[v])], second = labels[face_of(leaving[v])];
    const Vec3 p = mesh_vertex(mesh, v);
    const Vec3 d0 = mesh_vertex(coarse, first) - p, d1 = mesh_vertex(coarse, second) - p;
    if (dot(d1, d1) < dot(d0, d0)) std::swap(first, second);
    if (!(free_cluster(first) && try_corner(first, v)) && free_cluster(second)) try_corner(second, v);
  }
  for (uint32_t c = 0; c < n; ++c) {
    if (!free_cluster(c)) continue;
    double along;
    float q[3];
    to_float(closest_on_arc(c, mesh_vertex(coarse, c), along), q);
    if (ring_shape(c, q, kMaxTurnDeg).valid) {
      store(c, q);
      on_arc[c] = 1;
      ++counts.moved;
    }
  }

  // Slides along the arcs, as relax_coarse_vertices moves interior vertices: toward the arc's
  // point closest to the middle of the vertex's two boundary neighbours (all, half or a quarter of
  // the way along the arc), kept where the smallest angle of its triangles stays at or above
  // min(its old value, kSlideSafeDeg) and either rises or their sum of Q does, no triangle turning
  // by more than kSlideMaxTurnDeg. Corners stay.
  const double safe = kSlideSafeDeg * std::numbers::pi / 180;
  for (uint32_t pass = 0; pass < kSlidePasses; ++pass) {
    uint64_t slid = 0;
    for (uint32_t c = 0; c < n; ++c) {
      if (on_arc[c] != 1) continue;
      // The boundary neighbours: the corner after c in one of its triangles that comes before c
      // in none, and the other way round.
      uint32_t next = kNone, previous = kNone;
      for (uint32_t i = ring_offsets[c]; i < ring_offsets[c + 1]; ++i) {
        const uint32_t* t = &coarse.indices[3 * size_t(ring[i])];
        const int k = t[0] == c ? 0 : t[1] == c ? 1 : 2;
        const uint32_t a = t[(k + 1) % 3], b = t[(k + 2) % 3];
        bool a_before = false, b_after = false;
        for (uint32_t j = ring_offsets[c]; j < ring_offsets[c + 1]; ++j) {
          const uint32_t* u = &coarse.indices[3 * size_t(ring[j])];
          const int l = u[0] == c ? 0 : u[1] == c ? 1 : 2;
          a_before = a_before || u[(l + 2) % 3] == a;
          b_after = b_after || u[(l + 1) % 3] == b;
        }
        if (!a_before) next = a;
        if (!b_after) previous = b;
      }
      if (next == kNone || previous == kNone) continue;
      const float here[3] = {coarse.positions[3 * size_t(c)], coarse.positions[3 * size_t(c) + 1],
                             coarse.positions[3 * size_t(c) + 2]};
      const RingShape old_shape = ring_shape(c, here, 180);
      double at, goal;
      closest_on_arc(c, mesh_vertex(coarse, c), at);
      closest_on_arc(c, 0.5 * (mesh_vertex(coarse, next) + mesh_vertex(coarse, previous)), goal);
      for (double fraction : {1.0, 0.5, 0.25}) {
        float q[3];
        to_float(arc_point_at(c, at + fraction * (goal - at)), q);
        if (q[0] == here[0] && q[1] == here[1] && q[2] == here[2]) break;
        const RingShape shape = ring_shape(c, q, kSlideMaxTurnDeg);
        if (!shape.valid || shape.min_angle < std::min(old_shape.min_angle, safe)) continue;
        if (!(shape.min_angle > old_shape.min_angle) && !(shape.q_sum > old_shape.q_sum)) continue;
        store(c, q);
        ++slid;
        break;
      }
    }
    if (slid == 0) break;
  }
  for (uint32_t c = 0; c < n; ++c) moved[c] = on_arc[c];
  return counts;
}

uint64_t back_off_boundary_vertices(Mesh& coarse, const std::vector<float>& placed, const std::vector<uint8_t>& moved) {
  const size_t n = coarse.vertex_count();
  if (placed.size() != coarse.positions.size() || moved.size() != n) return 0;
  std::vector<uint32_t> ring_offsets, ring;
  coarse_triangle_rings(coarse, ring_offsets, ring);
  const double kBackOff = kBackOffDeg * std::numbers::pi / 180;
  uint64_t count = 0;
  for (uint32_t v = 0; v < n; ++v) {
    if (moved[v] != 1) continue;  // (not at all, or onto a corner: corners stay)
    const float* here = &coarse.positions[3 * size_t(v)];
    const RingShape now = shape_around(coarse, ring_offsets, ring, v, here, 180);
    if (!(now.min_angle < kBackOff)) continue;
    const Vec3 from = mesh_vertex(coarse, v), to = {placed[3 * size_t(v)], placed[3 * size_t(v) + 1], placed[3 * size_t(v) + 2]};
    float best[3] = {here[0], here[1], here[2]};
    double best_angle = now.min_angle;
    for (double t : {0.25, 0.5, 0.75, 1.0}) {
      const Vec3 p = from + t * (to - from);
      const float q[3] = {float(p.x), float(p.y), float(p.z)};
      const RingShape shape = shape_around(coarse, ring_offsets, ring, v, q, kSlideMaxTurnDeg);
      if (!shape.valid || !(shape.min_angle > best_angle)) continue;
      best_angle = shape.min_angle;
      for (int d = 0; d < 3; ++d) best[d] = q[d];
      if (shape.min_angle >= kBackOff) break;
    }
    if (best_angle > now.min_angle) {
      for (int d = 0; d < 3; ++d) coarse.positions[3 * size_t(v) + d] = best[d];
      ++count;
    }
  }
  return count;
}

}  // namespace meshcvt::detail
