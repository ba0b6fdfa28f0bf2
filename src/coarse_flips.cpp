// meshcvt: edge flips that improve the triangles of a coarse mesh, as the edge-flip step of
// surface remeshing does (Dyn, Hormann, Kim, Levin, "Optimizing 3D triangulations using discrete
// curvature analysis", 2001; Botsch and Kobbelt, "A remeshing approach to multiresolution
// modeling", SGP 2004).
//
// Why: the dual of a clustering (Fan et al. 6.1) connects clusters that meet at a mesh vertex. Near
// a place where four clusters meet almost at one point, the max-min-angle triangulation of the
// quad is only as good as the quad, and a vertex where three clusters meet nearly collinearly gives
// a sliver. Flipping the diagonal of two adjacent triangles to the other diagonal when that raises
// the smaller of their minimum angles removes most such triangles; vertices and topology stay the
// same (a flip keeps the Euler characteristic, boundaries and orientation).
//
// A flip of edge (u, v) between (u, v, c) and (v, u, d) into (c, u, d) and (d, v, c) is done only
// when: both triangles are oriented consistently across the edge, (c, d) is not an edge already
// (the result stays a manifold), u and v keep at least 3 edges (2 on a boundary), the two triangles are nearly
// coplanar (their normals within `max_dihedral_deg`, so creases of the surface are not cut) or,
// with `flat_slivers`, the pair holds a triangle below 5 degrees and the tetrahedron (u, v, c, d)
// the flip sweeps is thinner than kFlatFlip of the new edge (the normal of a sliver is noise: a
// cap of three nearly collinear points, a needle of two nearly coincident ones where a thin part
// turns; on the 69 libcgal-demo meshes at faces / 40 this took
// the default placement's smallest angle on cheese from 0.22 to 0.61 degrees, femur 0.27 -> 1.48,
// helmet 3.5 -> 10.9, pinion_small 4.8 -> 17.6), the new triangles face the same side as the old
// ones, and the smaller minimum angle strictly grows.
// The last makes every flip a strict local improvement; passes repeat until none applies (capped).
//
// Data structures (flat arrays, no hash map): the undirected edges in one array, built sorted by
// (smaller vertex, larger vertex) from a counting sort of the half-edges by their smaller vertex;
// an edge with exactly two triangles keeps them. The live edges whose smaller end is v form a list
// threaded through the array (`head[v]`, `Edge::next`), so "is (c, d) an edge" scans only the few
// edges of min(c, d). A flip retires its edge (unlinked; its key stays, for the pass order) and
// appends (c, d).
//
// The angle test is defined on atan2 angles: min(after) > min(before) + 1e-9 radians. A cheap
// stand-in almost always decides it the same way: the sine of a triangle's smallest angle, from
// the law of sines without trigonometry (smallest_sine_squared). All smallest angles are at most
// 60 degrees, where the sine grows, and |sin x - sin y| <= |x - y|: where the two sides' sines
// differ by more than kSineMargin (1e-7), the angles differ by more than that, far beyond the 1e-9
// plus the rounding of both computations (about 1e-15 each), so the atan2 comparison must come out
// the same way. atan2 runs only on the near-ties left (exact_min_grows); debug builds assert that
// every sine verdict agrees with it.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "meshcvt/coarsen.h"
#include "vec3.h"

namespace meshcvt {

namespace {

// Smallest angle of triangle (a, b, c), radians; 0 when degenerate. The flip decision is defined on
// these values: the faster tests below only reach the same answers.
double min_angle(Vec3 a, Vec3 b, Vec3 c) {
  auto angle = [](Vec3 p, Vec3 q, Vec3 r) {  // at p
    Vec3 u = q - p, v = r - p;
    double nu = length(u), nv = length(v);
    if (nu == 0 || nv == 0) return 0.0;
    return std::atan2(length(cross(u, v)), dot(u, v));
  };
  return std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
}

// sin^2 of the smallest angle of triangle (a, b, c) as the fraction area2 / edges2. Law of sines:
// the sine at a corner is |n| / (product of the lengths of the two edges there), n = twice the area
// vector; the smallest angle is the corner between the two longest edges (the largest product), and
// the smallest angle (<= 60 degrees) has the smallest sine of the three. Rounding is a few 1e-16 in
// the sine whatever the shape (the cross product's error is relative to the edges' product, which
// it is divided by). An edge of length 0 makes n exactly 0, the sine 0, as min_angle's 0; all three
// make edges2 0.
struct SineSquared {
  double area2, edges2;
};
// inline: it runs once per tested edge; as a call it cost about 7% of the whole.
inline SineSquared smallest_sine_squared(Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 ab = b - a, ac = c - a, bc = c - b;
  const Vec3 n = cross(ab, ac);
  const double l_ab = dot(ab, ab), l_ac = dot(ac, ac), l_bc = dot(bc, bc);
  return {dot(n, n), std::max({l_ab * l_ac, l_ab * l_bc, l_ac * l_bc})};
}

// Sine of the smallest angle; NaN where it cannot stand in for the angle (all three corners at one
// point, coordinates that are not finite), which leaves the decision to atan2.
double smallest_sine(SineSquared s) {
  if (!(s.edges2 > 0) || !std::isfinite(s.area2 + s.edges2)) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(s.area2 / s.edges2);
}

// Far above the rounding of both the sines and the atan2 angles (about 1e-15), and above the 1e-9
// of the decision: a sine difference of kSineMargin is an angle difference of at least kSineMargin.
constexpr double kSineMargin = 1e-7;

enum class Verdict { fails, passes, unsure };

// Whether a new triangle (its sin^2 `after`) keeps its smallest angle above the smaller old one (its
// sine `before`) plus 1e-9 radians, as the atan2 angles would decide it; unsure within the margin.
Verdict compare_sine(SineSquared after, double before) {
  if (!(after.edges2 > 0) || !std::isfinite(after.area2 + after.edges2)) return Verdict::unsure;
  const double low = before - kSineMargin, high = before + kSineMargin;
  // Squared on both sides (all >= 0) so that no square root or division is needed per test.
  if (low > 0 && after.area2 <= low * low * after.edges2) return Verdict::fails;
  if (after.area2 >= high * high * after.edges2) return Verdict::passes;
  return Verdict::unsure;
}

// A pair whose normals differ by more than the dihedral limit may still flip where the
// tetrahedron the flip sweeps is thinner than this fraction of the new edge (see the flip test):
// about what a 12-degree fold of two equilateral triangles sweeps.
constexpr double kFlatFlip = 0.05;
// ... and only where the pair holds a sliver, a triangle with an angle below 5 degrees, whose
// normal is noise.
const double kSliverSine = std::sin(5 * M_PI / 180);

constexpr uint32_t kNoEdge = UINT32_MAX;  // ends a list of edges; "no such edge"
constexpr uint32_t kNoFace = UINT32_MAX;
constexpr uint32_t kNeverTested = UINT32_MAX;

// An undirected edge (lo <= hi) with its two triangles in index order; kNoFace for an edge without
// exactly two (never flipped: kept only to answer "is an edge") and for a retired edge (flipped away).
struct Edge {
  uint32_t lo, hi;
  uint32_t face[2] = {kNoFace, kNoFace};
  uint32_t tested = kNeverTested;  // flip count when last refused (see the pass loop)
  uint32_t next = kNoEdge;         // next live edge whose smaller vertex is lo
};

// Edges of a mesh, built sorted by key, with head[v] = first live edge whose smaller end is v.
struct EdgeSet {
  std::vector<Edge> edges;
  std::vector<uint32_t> head;
  std::vector<uint8_t> on_boundary;  // an end of an edge without exactly two triangles

  uint32_t find(uint32_t a, uint32_t b) const {
    const uint32_t lo = std::min(a, b), hi = std::max(a, b);
    for (uint32_t e = head[lo]; e != kNoEdge; e = edges[e].next)
      if (edges[e].hi == hi) return e;
    return kNoEdge;
  }
  // Asked only of edges in the pass order, which had two triangles when they were added.
  static bool retired(const Edge& e) { return e.face[0] == kNoFace; }
  void unlink(uint32_t e) {
    uint32_t* link = &head[edges[e].lo];
    while (*link != e) {
      assert(*link != kNoEdge);
      link = &edges[*link].next;
    }
    *link = edges[e].next;
  }
  uint32_t add(uint32_t a, uint32_t b, uint32_t face0, uint32_t face1) {
    Edge e;
    e.lo = std::min(a, b), e.hi = std::max(a, b);
    e.face[0] = face0, e.face[1] = face1;
    e.next = head[e.lo];
    head[e.lo] = uint32_t(edges.size());
    edges.push_back(e);
    return head[e.lo];
  }
};

// Counting sort of the half-edges by their smaller vertex (stable: triangle order within a
// vertex), then per vertex an insertion sort by the larger one (a handful each) and one edge per run.
EdgeSet build_edges(const std::vector<uint32_t>& tri, size_t vertex_count) {
  const size_t nh = tri.size();
  static constexpr uint32_t kNextCorner[3] = {1, 2, 0};
  // start[v + 1] counts, then (prefix sums) start[v] is where v's half-edges begin.
  std::vector<uint32_t> start(vertex_count + 1, 0);
  for (size_t t = 0; t < nh; t += 3)
    for (uint32_t k = 0; k < 3; ++k) {
      assert(tri[t + k] < vertex_count);
      ++start[std::min(tri[t + k], tri[t + kNextCorner[k]]) + 1];
    }
  for (size_t v = 0; v < vertex_count; ++v) start[v + 1] += start[v];
  struct HalfEdge {
    uint32_t hi, face;
  };
  std::vector<HalfEdge> by_lo(nh);
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (size_t t = 0; t < nh; t += 3)
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t a = tri[t + k], b = tri[t + kNextCorner[k]];
      by_lo[fill[std::min(a, b)]++] = {std::max(a, b), uint32_t(t / 3)};
    }
  EdgeSet set;
  set.head.assign(vertex_count, kNoEdge);
  set.on_boundary.assign(vertex_count, 0);
  set.edges.reserve(nh / 2 + nh / 32 + 16);  // a closed mesh has nh / 2, each flip adds one
  for (uint32_t v = 0; v < vertex_count; ++v) {
    HalfEdge* first = by_lo.data() + start[v];
    HalfEdge* last = by_lo.data() + start[v + 1];
    auto by_hi = [](const HalfEdge& x, const HalfEdge& y) { return x.hi < y.hi; };
    if (last - first > 32) {  // a vertex with very many edges (not in a dual): no quadratic sort
      std::stable_sort(first, last, by_hi);
    } else {
      for (HalfEdge* i = first + 1; i < last; ++i)  // stable: equal hi keep triangle order
        for (HalfEdge* j = i; j > first && by_hi(*j, j[-1]); --j) std::swap(j[-1], *j);
    }
    uint32_t previous = kNoEdge;
    for (HalfEdge* i = first; i < last;) {
      Edge e;
      e.lo = v, e.hi = i->hi;
      HalfEdge* run = i;
      while (i < last && i->hi == e.hi) ++i;
      if (i - run == 2)
        e.face[0] = run[0].face, e.face[1] = run[1].face;
      else  // a boundary or non-manifold edge: its ends may keep fewer edges
        set.on_boundary[v] = set.on_boundary[e.hi] = 1;
      const uint32_t id = uint32_t(set.edges.size());
      (previous == kNoEdge ? set.head[v] : set.edges[previous].next) = id;
      set.edges.push_back(e);
      previous = id;
    }
  }
  return set;
}

}  // namespace

uint64_t flip_coarse_edges(Mesh& mesh, double max_dihedral_deg, uint32_t max_passes, bool flat_slivers) {
  const size_t nt = mesh.face_count();
  std::vector<uint32_t>& tri = mesh.indices;
  auto vertex = [&](uint32_t v) { return mesh_vertex(mesh, v); };
  auto normal = [&](uint32_t a, uint32_t b, uint32_t c) { return cross(vertex(b) - vertex(a), vertex(c) - vertex(a)); };

  EdgeSet set = build_edges(tri, mesh.vertex_count());
  std::vector<Edge>& edges = set.edges;
  // A vertex on a boundary (or a non-manifold edge) may end with two edges, an interior one needs three.
  std::vector<uint32_t> valence(mesh.vertex_count(), 0);
  // The pass order: the edges with two triangles by key (the array is sorted already), so the
  // result depends on nothing but the mesh. An entry is an edge id, whose key never changes: a flip
  // retires its edge (unlinked, kept for its key) and adds (c, d) as a new edge. If a later flip
  // makes a retired key an edge again, the entry finds it through the lists and tests it there too,
  // as a pass over keys would.
  std::vector<uint32_t> order;
  order.reserve(edges.size());
  for (uint32_t e = 0; e < edges.size(); ++e) {
    ++valence[edges[e].lo];
    ++valence[edges[e].hi];
    if (edges[e].face[0] != kNoFace) order.push_back(e);
  }
  auto may_lose_edge = [&](uint32_t x) { return valence[x] > (set.on_boundary[x] ? 2u : 3u); };
  auto by_key = [&](uint32_t x, uint32_t y) {
    return edges[x].lo != edges[y].lo ? edges[x].lo < edges[y].lo : edges[x].hi < edges[y].hi;
  };

  const double min_cos = std::cos(max_dihedral_deg * M_PI / 180.0);
  auto replace = [&](uint32_t e, uint32_t from, uint32_t to) {
    assert(e != kNoEdge);
    for (uint32_t& t : edges[e].face)
      if (t == from) {
        t = to;
        return;
      }
  };
  // Per triangle, cached (a triangle changes only when one of its edges flips): the sine of its
  // smallest angle, and its atan2 smallest angle, NaN until an unsure test needs it (allocated
  // then). min_angle of any rotation of a triangle's corners makes the same three calls, so the
  // cached value is exactly what the test would compute.
  std::vector<double> sine_min(nt);
  for (uint32_t t = 0; t < nt; ++t)
    sine_min[t] = smallest_sine(smallest_sine_squared(vertex(tri[3 * t]), vertex(tri[3 * t + 1]), vertex(tri[3 * t + 2])));
  std::vector<double> triangle_min;
  auto cached_min = [&](uint32_t t) {
    if (triangle_min.empty()) triangle_min.assign(nt, std::numeric_limits<double>::quiet_NaN());
    if (std::isnan(triangle_min[t]))
      triangle_min[t] = min_angle(vertex(tri[3 * t]), vertex(tri[3 * t + 1]), vertex(tri[3 * t + 2]));
    return triangle_min[t];
  };
  // The decision itself: min(after) > min(before) + 1e-9 on the atan2 angles, i.e. every new
  // triangle's smallest angle above the bound.
  auto exact_min_grows = [&](uint32_t t1, uint32_t t2, uint32_t c, uint32_t u, uint32_t d, uint32_t v) {
    const double bound = std::min(cached_min(t1), cached_min(t2)) + 1e-9;
    return min_angle(vertex(c), vertex(u), vertex(d)) > bound && min_angle(vertex(d), vertex(v), vertex(c)) > bound;
  };
  // Exact skip of repeated tests: an edge's test reads its two triangles, the valences of its ends
  // u, v and whether (c, d) is an edge. A flip changes those only for its own four vertices, which
  // it stamps with the flip count; so an edge refused at flip count T, none of whose u, v, c, d was
  // stamped since, would be refused again and is not tested (the result is the same as testing
  // every edge in every pass; later passes cost only the edges near the last pass's flips).
  std::vector<uint32_t> stamp(mesh.vertex_count(), 0);
  uint32_t flip_count = 0;
  uint64_t flips = 0;
  for (uint32_t pass = 0; pass < max_passes; ++pass) {
    uint64_t flips_this_pass = 0;
    const size_t sorted = order.size();
    for (size_t i = 0; i < order.size(); ++i) {
      const uint32_t a = edges[order[i]].lo, b = edges[order[i]].hi;
      uint32_t e = order[i];
      if (EdgeSet::retired(edges[e])) {
        e = set.find(a, b);
        if (e == kNoEdge) continue;
      }
      // Only edges with two triangles enter the order, a key returns only by a flip (with two),
      // and flips change no other edge's count.
      assert(edges[e].face[1] != kNoFace);
      const uint32_t t1 = edges[e].face[0], t2 = edges[e].face[1];
      const uint32_t tested = edges[e].tested;
      if (tested != kNeverTested && stamp[a] <= tested && stamp[b] <= tested) {
        // The triangles did not change (they contain a and b), so neither did c and d.
        auto unchanged = [&](uint32_t t) {
          return stamp[tri[3 * t]] <= tested && stamp[tri[3 * t + 1]] <= tested && stamp[tri[3 * t + 2]] <= tested;
        };
        if (unchanged(t1) && unchanged(t2)) continue;
      }
      edges[e].tested = flip_count;  // refused unless flipped below (then the edge is retired)
      // Orient: t1 holds u -> v, t2 holds v -> u.
      auto directed = [&](uint32_t t, uint32_t from, uint32_t to) {
        for (int k = 0; k < 3; ++k)
          if (tri[3 * t + k] == from && tri[3 * t + (k + 1) % 3] == to) return true;
        return false;
      };
      uint32_t u = a, v = b;
      if (!directed(t1, u, v)) std::swap(u, v);
      if (!directed(t1, u, v) || !directed(t2, v, u)) continue;  // inconsistent orientation: leave it
      auto third = [&](uint32_t t) {
        for (int k = 0; k < 3; ++k)
          if (tri[3 * t + k] != u && tri[3 * t + k] != v) return tri[3 * t + k];
        return UINT32_MAX;
      };
      const uint32_t c = third(t1), d = third(t2);
      if (c == UINT32_MAX || d == UINT32_MAX || c == d) continue;
      if (!may_lose_edge(u) || !may_lose_edge(v)) continue;
      if (set.find(c, d) != kNoEdge) continue;
      // The sine test first: it refuses most candidates, at the cost of one cross product each.
      const Vec3 pu = vertex(u), pv = vertex(v), pc = vertex(c), pd = vertex(d);
      // std::min would drop a NaN in its second argument: either old sine unknown, all unsure.
      const bool sines_known = !std::isnan(sine_min[t1]) && !std::isnan(sine_min[t2]);
      const double sine_before = std::min(sine_min[t1], sine_min[t2]);
      const SineSquared after1 = smallest_sine_squared(pc, pu, pd);
      const Verdict verdict1 = sines_known ? compare_sine(after1, sine_before) : Verdict::unsure;
      if (verdict1 == Verdict::fails) {
        assert(!exact_min_grows(t1, t2, c, u, d, v));
        continue;
      }
      const SineSquared after2 = smallest_sine_squared(pd, pv, pc);
      const Verdict verdict2 = sines_known ? compare_sine(after2, sine_before) : Verdict::unsure;
      if (verdict2 == Verdict::fails) {
        assert(!exact_min_grows(t1, t2, c, u, d, v));
        continue;
      }
      Vec3 n1 = normal(u, v, c), n2 = normal(v, u, d);
      double l1 = length(n1), l2 = length(n2);
      const bool coplanar = l1 > 0 && l2 > 0 && dot(n1, n2) >= min_cos * l1 * l2;
      // Or flat: the tetrahedron the flip sweeps is thin against the new edge (its volume over
      // the pair's area, |n1 . (d - u)| / (l1 + l2), below kFlatFlip |cd|), so the surface barely
      // moves whatever the normals say (a sliver's normal is noise).
      const bool flat = flat_slivers && !coplanar && !(sine_before >= kSliverSine) &&
                        std::fabs(dot(n1, pd - pu)) < kFlatFlip * (l1 + l2) * length(pd - pc);
      if (!coplanar && !flat) continue;
      // The side the pair faces: the mean of the unit normals, or where one of them is noise, the
      // area-weighted sum (the larger triangle's).
      Vec3 m1 = normal(c, u, d), m2 = normal(d, v, c),
           side = coplanar ? Vec3{n1.x / l1 + n2.x / l2, n1.y / l1 + n2.y / l2, n1.z / l1 + n2.z / l2} : n1 + n2;
      if (!(dot(m1, side) > 0) || !(dot(m2, side) > 0)) continue;
      if (verdict1 == Verdict::passes && verdict2 == Verdict::passes) {
        assert(exact_min_grows(t1, t2, c, u, d, v));
      } else if (!exact_min_grows(t1, t2, c, u, d, v)) {
        continue;
      }
      // Flip: t1 = (c, u, d), t2 = (d, v, c); their cached atan2 angles are unknown again.
      tri[3 * t1] = c, tri[3 * t1 + 1] = u, tri[3 * t1 + 2] = d;
      tri[3 * t2] = d, tri[3 * t2 + 1] = v, tri[3 * t2 + 2] = c;
      sine_min[t1] = smallest_sine(after1), sine_min[t2] = smallest_sine(after2);
      if (!triangle_min.empty()) triangle_min[t1] = triangle_min[t2] = std::numeric_limits<double>::quiet_NaN();
      set.unlink(e);
      edges[e].face[0] = edges[e].face[1] = kNoFace;  // retired
      replace(set.find(u, d), t2, t1);  // was in t2 = (v, u, d), now in t1
      replace(set.find(v, c), t1, t2);  // was in t1 = (u, v, c), now in t2
      order.push_back(set.add(c, d, t1, t2));  // tested again later in this pass
      --valence[u], --valence[v], ++valence[c], ++valence[d];
      ++flip_count;
      stamp[u] = stamp[v] = stamp[c] = stamp[d] = flip_count;
      ++flips_this_pass;
    }
    flips += flips_this_pass;
    if (flips_this_pass == 0) break;
    // The edges added this pass (one per flip) merged into the sorted entries, one per key.
    std::sort(order.begin() + ptrdiff_t(sorted), order.end(), by_key);
    std::inplace_merge(order.begin(), order.begin() + ptrdiff_t(sorted), order.end(), by_key);
    order.erase(std::unique(order.begin(), order.end(),
                            [&](uint32_t x, uint32_t y) { return edges[x].lo == edges[y].lo && edges[x].hi == edges[y].hi; }),
                order.end());
  }
  return flips;
}

}  // namespace meshcvt
