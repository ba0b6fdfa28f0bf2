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
// coplanar (their normals within `max_dihedral_deg`, so creases of the surface are not cut), the
// new triangles face the same side as the old ones, and the smaller minimum angle strictly grows.
// The last makes every flip a strict local improvement; passes repeat until none applies (capped).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include "meshcvt/coarsen.h"
#include "vec3.h"

namespace meshcvt {

namespace {

// Smallest angle of triangle (a, b, c), radians; 0 when degenerate.
double min_angle(Vec3 a, Vec3 b, Vec3 c) {
  auto angle = [](Vec3 p, Vec3 q, Vec3 r) {  // at p
    Vec3 u = q - p, v = r - p;
    double nu = length(u), nv = length(v);
    if (nu == 0 || nv == 0) return 0.0;
    return std::atan2(length(cross(u, v)), dot(u, v));
  };
  return std::min({angle(a, b, c), angle(b, c, a), angle(c, a, b)});
}

uint64_t edge_key(uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a); }

constexpr uint32_t kNeverTested = UINT32_MAX;

}  // namespace

uint64_t flip_coarse_edges(Mesh& mesh, double max_dihedral_deg, uint32_t max_passes) {
  const size_t nt = mesh.face_count();
  std::vector<uint32_t>& tri = mesh.indices;
  auto vertex = [&](uint32_t v) { return mesh_vertex(mesh, v); };
  auto normal = [&](uint32_t a, uint32_t b, uint32_t c) { return cross(vertex(b) - vertex(a), vertex(c) - vertex(a)); };

  // Undirected edge -> its triangles (up to two are tracked; more marks the edge unflippable).
  struct EdgeFaces {
    uint32_t t[2] = {UINT32_MAX, UINT32_MAX};
    uint32_t count = 0;
    uint32_t tested = kNeverTested;  // flip count when last refused (see the pass loop)
  };
  std::unordered_map<uint64_t, EdgeFaces> edges;
  edges.reserve(nt * 2);
  std::vector<uint32_t> valence(mesh.vertex_count(), 0);
  for (uint32_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) {
      EdgeFaces& e = edges[edge_key(tri[3 * t + k], tri[3 * t + (k + 1) % 3])];
      if (e.count < 2) e.t[e.count] = t;
      ++e.count;
    }
  // A vertex on a boundary (or a non-manifold edge) may end with two edges, an interior one needs three.
  std::vector<uint8_t> on_boundary(mesh.vertex_count(), 0);
  for (const auto& [key, e] : edges) {
    ++valence[uint32_t(key >> 32)];
    ++valence[uint32_t(key)];
    if (e.count != 2) on_boundary[uint32_t(key >> 32)] = on_boundary[uint32_t(key)] = 1;
  }
  auto may_lose_edge = [&](uint32_t x) { return valence[x] > (on_boundary[x] ? 2u : 3u); };
  // Edges in a fixed order, so the result does not depend on the hash map's.
  std::vector<uint64_t> order;
  order.reserve(edges.size());
  for (const auto& [key, e] : edges)
    if (e.count == 2) order.push_back(key);
  std::sort(order.begin(), order.end());

  const double min_cos = std::cos(max_dihedral_deg * M_PI / 180.0);
  auto replace = [&](uint64_t key, uint32_t from, uint32_t to) {
    EdgeFaces& e = edges[key];
    for (uint32_t& t : e.t)
      if (t == from) {
        t = to;
        return;
      }
  };
  // Smallest angle of each triangle, cached: a triangle changes only when one of its edges flips.
  // min_angle of any rotation of a triangle's corners makes the same three calls, so the cached
  // value is exactly what the test below would compute. NaN: not known yet.
  std::vector<double> triangle_min(nt, std::numeric_limits<double>::quiet_NaN());
  auto cached_min = [&](uint32_t t) {
    if (std::isnan(triangle_min[t]))
      triangle_min[t] = min_angle(vertex(tri[3 * t]), vertex(tri[3 * t + 1]), vertex(tri[3 * t + 2]));
    return triangle_min[t];
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
    for (size_t i = 0; i < order.size(); ++i) {
      const uint64_t key = order[i];
      auto it = edges.find(key);
      if (it == edges.end() || it->second.count != 2) continue;
      uint32_t t1 = it->second.t[0], t2 = it->second.t[1];
      const uint32_t a = uint32_t(key >> 32), b = uint32_t(key);
      const uint32_t tested = it->second.tested;
      if (tested != kNeverTested && stamp[a] <= tested && stamp[b] <= tested) {
        // The triangles did not change (they contain a and b), so neither did c and d.
        uint32_t newest = 0;
        for (int k = 0; k < 3; ++k) newest = std::max({newest, stamp[tri[3 * t1 + k]], stamp[tri[3 * t2 + k]]});
        if (newest <= tested) continue;
      }
      it->second.tested = flip_count;  // refused unless flipped below (then the entry is erased)
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
      if (edges.count(edge_key(c, d))) continue;
      Vec3 n1 = normal(u, v, c), n2 = normal(v, u, d);
      double l1 = length(n1), l2 = length(n2);
      if (l1 == 0 || l2 == 0 || dot(n1, n2) < min_cos * l1 * l2) continue;
      Vec3 m1 = normal(c, u, d), m2 = normal(d, v, c), side = {n1.x / l1 + n2.x / l2, n1.y / l1 + n2.y / l2,
                                                             n1.z / l1 + n2.z / l2};
      if (!(dot(m1, side) > 0) || !(dot(m2, side) > 0)) continue;
      // The flip needs min(after) > min(before) + 1e-9, i.e. every new triangle's smallest angle
      // above the bound: the second is not measured when the first already fails.
      const double bound = std::min(cached_min(t1), cached_min(t2)) + 1e-9;
      const double after1 = min_angle(vertex(c), vertex(u), vertex(d));
      if (!(after1 > bound)) continue;
      const double after2 = min_angle(vertex(d), vertex(v), vertex(c));
      if (!(after2 > bound)) continue;
      triangle_min[t1] = after1, triangle_min[t2] = after2;
      // Flip: t1 = (c, u, d), t2 = (d, v, c).
      tri[3 * t1] = c, tri[3 * t1 + 1] = u, tri[3 * t1 + 2] = d;
      tri[3 * t2] = d, tri[3 * t2 + 1] = v, tri[3 * t2 + 2] = c;
      edges.erase(it);
      EdgeFaces fresh;
      fresh.t[0] = t1, fresh.t[1] = t2, fresh.count = 2;
      const uint64_t new_key = edge_key(c, d);
      edges[new_key] = fresh;
      replace(edge_key(u, d), t2, t1);  // was in t2 = (v, u, d), now in t1
      replace(edge_key(v, c), t1, t2);  // was in t1 = (u, v, c), now in t2
      --valence[u], --valence[v], ++valence[c], ++valence[d];
      ++flip_count;
      stamp[u] = stamp[v] = stamp[c] = stamp[d] = flip_count;
      order.push_back(new_key);  // tested again later in this pass
      ++flips_this_pass;
    }
    flips += flips_this_pass;
    if (flips_this_pass == 0) break;
    std::sort(order.begin(), order.end());
    order.erase(std::unique(order.begin(), order.end()), order.end());
  }
  return flips;
}

}  // namespace meshcvt
