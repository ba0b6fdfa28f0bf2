// meshcvt: splits the edges of a mesh that are too long for its clusters, at their midpoints, with
// the longest-edge refinement of Rivara ("Mesh refinement processes based on the generalized
// bisection of simplices", SIAM J. Numer. Anal. 21, 1984): a triangle is always split across its own
// longest edge first, so no angle gets smaller than half of one it had, and every triangle on a
// split edge is split there, so the mesh stays conforming (watertight stays watertight).
//
// Why: a cluster is a set of whole faces. Where a face is longer than a cluster is wide (the long
// thin triangles of CAD exports: a cylinder's fan, a flat side of two triangles) no cluster can be
// round, the dual gets thin triangles and relax cannot mend them (libcgal-demo's pinion -> 130:
// Q avg 0.51, 240 angles below 30 degrees). Uniform subdivision (subdivide_midpoint) refines the
// parts that are already fine as much as the coarse ones; splitting only the long edges does not.
//
// One round: mark every edge longer than the limit of a face on it; close the marks (a face with a
// marked edge gets its longest edge marked too, until nothing changes: the longest-edge
// propagation path); give each marked edge one midpoint vertex; replace each face by its children
// (1, 2, 3 or 4 triangles: bisect the longest edge, then each half across its other marked edge).
// Rounds repeat until no edge is too long; each halves the marked edges, so they end after about
// log2(longest edge / limit) rounds. Everything is decided by edge lengths and vertex ids, in face
// order: the output does not depend on a hash table's order or on threads.
#include "meshcvt/subdivide.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "meshcvt/error.h"
#include "vec3.h"

namespace meshcvt {

namespace {

constexpr uint64_t kMaxFaces = 0xffffffffu / 3;  // 3F half-edge ids fit in 32 bits
constexpr uint64_t kMaxVertices = 0xfffffffeu;   // below kNone
// Rounds after which the limit is judged unreachable (a limit of 1e-20 of a unit-sized mesh would
// take about 66; the face count check stops such a request long before).
constexpr unsigned kMaxRounds = 200;

uint64_t edge_key(uint32_t a, uint32_t b) { return uint64_t(std::min(a, b)) << 32 | std::max(a, b); }

// Squared length of edge {a, b}, the same number whichever way round it is asked for.
double length2(const std::vector<float>& p, uint32_t a, uint32_t b) {
  const uint32_t lo = std::min(a, b), hi = std::max(a, b);
  double s = 0;
  for (int d = 0; d < 3; ++d) {
    const double x = double(p[3 * size_t(hi) + d]) - double(p[3 * size_t(lo) + d]);
    s += x * x;
  }
  return s;
}

// The local index k of face (v0, v1, v2)'s longest edge (v_k, v_k+1); ties go to the lower edge key,
// so both faces of an edge agree on the order of their edges.
int longest_edge(const std::vector<float>& p, const uint32_t* v) {
  int best = 0;
  double best_length = length2(p, v[0], v[1]);
  uint64_t best_key = edge_key(v[0], v[1]);
  for (int k = 1; k < 3; ++k) {
    const double l = length2(p, v[k], v[(k + 1) % 3]);
    const uint64_t key = edge_key(v[k], v[(k + 1) % 3]);
    if (l > best_length || (l == best_length && key < best_key)) best = k, best_length = l, best_key = key;
  }
  return best;
}

bool collapsed(const uint32_t* v) { return v[0] == v[1] || v[1] == v[2] || v[0] == v[2]; }

}  // namespace

SplitEdgesResult split_long_edges(const Mesh& mesh, double max_length, const std::vector<double>& face_max_length) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (mesh.indices.size() % 3 != 0 || mesh.positions.size() % 3 != 0)
    throw OptionError("split_long_edges: mesh arrays are not whole triangles / vertices");
  for (uint32_t i : mesh.indices)
    if (i >= nv)
      throw OptionError("split_long_edges: mesh uses vertex " + std::to_string(i) + " but has " + std::to_string(nv) +
                        " vertices");
  if (!mesh.source_polygon.empty() && mesh.source_polygon.size() != nf)
    throw OptionError("split_long_edges: mesh has " + std::to_string(mesh.source_polygon.size()) +
                      " source_polygon entries for " + std::to_string(nf) + " faces");
  if (!face_max_length.empty() && face_max_length.size() != nf)
    throw OptionError("split_long_edges: " + std::to_string(face_max_length.size()) + " edge limits for " +
                      std::to_string(nf) + " faces");
  auto check_limit = [](double l) {
    if (!(l > 0) || !std::isfinite(l))
      throw OptionError("split_long_edges: the edge length limit must be a finite number > 0, not " + std::to_string(l));
  };
  if (face_max_length.empty())
    check_limit(max_length);
  else
    for (double l : face_max_length) check_limit(l);

  // At least this many faces come out: a triangle with edges within l has at most (sqrt 3 / 4) l^2 of
  // area, and an edge of length L ends in at least L / l pieces (each in a face, shared by at most
  // two). A request far beyond 32-bit indices is refused before any work.
  double area_bound = 0, edge_bound = 0;
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    const double l = face_max_length.empty() ? max_length : face_max_length[f];
    area_bound += face_area(mesh, f) / (std::sqrt(3.0) / 4 * l * l);
    for (int k = 0; k < 3; ++k) edge_bound += 0.5 * std::sqrt(length2(mesh.positions, t[k], t[(k + 1) % 3])) / l;
  }
  if (!(std::max(area_bound, edge_bound) <= double(kMaxFaces)))
    throw OptionError("split_long_edges: the limit would make more than " + std::to_string(kMaxFaces) +
                      " faces (at least " + std::to_string(uint64_t(std::min(std::max(area_bound, edge_bound), 1e19))) +
                      ")");

  SplitEdgesResult out;
  out.mesh.positions = mesh.positions;
  out.mesh.indices = mesh.indices;
  out.parent.resize(nf);
  for (size_t f = 0; f < nf; ++f) out.parent[f] = uint32_t(f);
  std::vector<float>& p = out.mesh.positions;
  auto limit2 = [&](size_t f) {
    const double l = face_max_length.empty() ? max_length : face_max_length[out.parent[f]];
    return l * l;
  };

  std::unordered_map<uint64_t, uint32_t> midpoint;  // marked edge -> its midpoint vertex
  std::vector<uint64_t> keys;
  std::vector<uint32_t> indices, parent;
  std::vector<uint8_t> touched;  // per vertex: an end of a marked edge
  for (unsigned round = 0;; ++round) {
    const std::vector<uint32_t>& v = out.mesh.indices;
    const size_t faces = v.size() / 3;
    midpoint.clear();
    for (size_t f = 0; f < faces; ++f) {
      if (collapsed(&v[3 * f])) continue;  // no area: kept as it is
      const double l2 = limit2(f);
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = v[3 * f + k], b = v[3 * f + (k + 1) % 3];
        if (length2(p, a, b) > l2) midpoint.emplace(edge_key(a, b), 0);
      }
    }
    if (midpoint.empty()) break;
    // Ends of marked edges: a face can have a marked edge only where two of its corners are such ends
    // (most faces are passed without a table lookup).
    touched.assign(p.size() / 3, 0);
    for (const auto& [key, id] : midpoint) touched[key >> 32] = touched[uint32_t(key)] = 1;
    if (round == kMaxRounds)
      throw OptionError("split_long_edges: edges still too long after " + std::to_string(kMaxRounds) + " rounds");
    // Closure: a face with a marked edge has its longest edge marked. Each new mark is longer than
    // the edge that called for it, so this ends.
    for (bool changed = true; changed;) {
      changed = false;
      for (size_t f = 0; f < faces; ++f) {
        const uint32_t* t = &v[3 * f];
        if (collapsed(t) || touched[t[0]] + touched[t[1]] + touched[t[2]] < 2) continue;
        const bool any = midpoint.count(edge_key(t[0], t[1])) || midpoint.count(edge_key(t[1], t[2])) ||
                         midpoint.count(edge_key(t[2], t[0]));
        if (!any) continue;
        const int k = longest_edge(p, t);
        if (midpoint.emplace(edge_key(t[k], t[(k + 1) % 3]), 0).second) {
          touched[t[k]] = touched[t[(k + 1) % 3]] = 1;
          changed = true;
        }
      }
    }
    // Midpoints numbered in key order (not the table's order).
    keys.clear();
    for (const auto& [key, id] : midpoint) keys.push_back(key);
    std::sort(keys.begin(), keys.end());
    const size_t vertices = p.size() / 3;
    if (vertices + keys.size() > kMaxVertices)
      throw OptionError("split_long_edges: the result would have more than " + std::to_string(kMaxVertices) + " vertices");
    p.resize(3 * (vertices + keys.size()));
    for (size_t i = 0; i < keys.size(); ++i) {
      const uint32_t lo = uint32_t(keys[i] >> 32), hi = uint32_t(keys[i]);
      midpoint[keys[i]] = uint32_t(vertices + i);
      // 0.5a + 0.5b, as subdivide_midpoint: symmetric in a, b and no overflow near FLT_MAX.
      for (int d = 0; d < 3; ++d) p[3 * (vertices + i) + d] = 0.5f * p[3 * size_t(lo) + d] + 0.5f * p[3 * size_t(hi) + d];
    }
    out.split_edges += keys.size();
    ++out.rounds;

    // The children per face: one more than its marked edges (checked before they are made).
    uint64_t children = 0;
    for (size_t f = 0; f < faces; ++f) {
      const uint32_t* t = &v[3 * f];
      children += 1;
      if (!collapsed(t))
        for (int k = 0; k < 3; ++k) children += midpoint.count(edge_key(t[k], t[(k + 1) % 3]));
    }
    if (children > kMaxFaces)
      throw OptionError("split_long_edges: the result would have more than " + std::to_string(kMaxFaces) + " faces");
    indices.clear();
    parent.clear();
    indices.reserve(3 * children);
    parent.reserve(children);
    auto emit = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t from) {
      indices.insert(indices.end(), {a, b, c});
      parent.push_back(from);
    };
    // The midpoint of edge {a, b}, or kNone when it is not split.
    auto mid = [&](uint32_t a, uint32_t b) {
      const auto it = midpoint.find(edge_key(a, b));
      return it == midpoint.end() ? kNone : it->second;
    };
    for (size_t f = 0; f < faces; ++f) {
      const uint32_t* t = &v[3 * f];
      const uint32_t from = out.parent[f];
      const uint32_t m0 = collapsed(t) ? kNone : mid(t[0], t[1]), m1 = collapsed(t) ? kNone : mid(t[1], t[2]),
                     m2 = collapsed(t) ? kNone : mid(t[2], t[0]);
      if (m0 == kNone && m1 == kNone && m2 == kNone) {
        emit(t[0], t[1], t[2], from);
        continue;
      }
      // Rotated so that the longest edge is (a, b), c opposite; m on (a, b), bc and ca maybe.
      const int k = longest_edge(p, t);
      const uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
      const uint32_t ms[3] = {m0, m1, m2};
      const uint32_t m = ms[k], bc = ms[(k + 1) % 3], ca = ms[(k + 2) % 3];
      assert(m != kNone);  // the closure marked the longest edge
      // (a, m, c) and (m, b, c), oriented as (a, b, c); each split again across its marked side.
      if (ca == kNone) {
        emit(a, m, c, from);
      } else {
        emit(a, m, ca, from);
        emit(m, c, ca, from);
      }
      if (bc == kNone) {
        emit(m, b, c, from);
      } else {
        emit(m, b, bc, from);
        emit(m, bc, c, from);
      }
    }
    assert(parent.size() == children);
    out.mesh.indices.swap(indices);
    out.parent.swap(parent);
  }
  if (!mesh.source_polygon.empty() || out.split_edges > 0) {
    out.mesh.source_polygon.resize(out.parent.size());
    for (size_t f = 0; f < out.parent.size(); ++f)
      out.mesh.source_polygon[f] = mesh.source_polygon.empty() ? out.parent[f] : mesh.source_polygon[out.parent[f]];
  }
  return out;
}

double coarse_edge_length(double weight, uint32_t clusters, double density) {
  if (!(weight >= 0) || !std::isfinite(weight) || clusters == 0 || !(density > 0) || !std::isfinite(density))
    throw OptionError("coarse_edge_length: needs a finite weight >= 0, clusters > 0 and a finite density > 0");
  // n vertices of a closed mesh of equilateral triangles make 2n triangles of area (sqrt 3 / 4) l^2
  // each; a cluster of weight W / n covers (W / n) / density of area.
  return std::sqrt(2.0 * weight / (std::sqrt(3.0) * double(clusters) * density));
}

}  // namespace meshcvt
