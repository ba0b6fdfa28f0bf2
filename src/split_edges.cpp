// meshcvt: splits the edges of a mesh that are too long for its clusters, at their midpoints, with
// the longest-edge refinement of Rivara ("Mesh refinement processes based on the generalized
// bisection of simplices", SIAM J. Numer. Anal. 21, 1984): a triangle is always split across its own
// longest edge first, so no angle gets smaller than half of one it had, and every triangle on a
// split edge is split there, so the mesh stays conforming (watertight stays watertight).
//
// Why: a cluster is a set of whole faces. Where a face is longer than a cluster is wide (the long
// thin triangles of CAD exports: a cylinder's fan, a flat side of two triangles) no cluster can be
// round, the dual gets thin triangles and relax cannot mend them (libcgal-demo's pinion_small -> 130:
// Q avg 0.51, 240 angles below 30 degrees). Uniform subdivision (subdivide_midpoint) refines the
// parts that are already fine as much as the coarse ones; splitting only the long edges does not.
//
// One round: mark every edge longer than the limit of a face on it; close the marks (a face with a
// marked edge gets its longest edge marked too, until nothing changes: the longest-edge
// propagation path); give each marked edge one midpoint vertex; replace each face by its children
// (1, 2, 3 or 4 triangles: bisect the longest edge, then each half across its other marked edge).
// Rounds repeat until no edge is too long; each halves the marked edges, so they end after about
// log2(longest edge / limit) rounds. Everything is decided by edge lengths and vertex ids (edges
// numbered in order of their two vertex ids, children written in face order): the same input gives
// the same output, whatever order the closure reaches the faces in.
#include "meshcvt/subdivide.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>
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

// The undirected edges of a triangle list, numbered in order of (lower vertex, higher vertex): a
// counting sort of the half-edges by lower vertex, then each vertex's few sorted by higher vertex
// (no hash table; a table of the marked edges took 4.9 s to split the 1.2M bunny for 400k clusters).
struct EdgeNumbering {
  std::vector<uint32_t> edge_of;  // per half-edge 3f + k: its edge, kNone where both ends are one vertex
  std::vector<uint32_t> lo, hi;   // per edge: its ends, lo < hi
  std::vector<uint64_t> keys;     // (hi << 32 | half-edge) in edge order: edge e's half-edges are
  std::vector<uint32_t> first;    // keys[first[e], first[e + 1])
  std::vector<uint32_t> offsets;  // scratch
};

void number_edges(const std::vector<uint32_t>& v, size_t vertices, EdgeNumbering& out) {
  const size_t half_edges = v.size();
  auto next = [](size_t h) { return h % 3 == 2 ? h - 2 : h + 1; };
  out.offsets.assign(vertices + 1, 0);
  for (size_t h = 0; h < half_edges; ++h)
    if (v[h] != v[next(h)]) ++out.offsets[std::min(v[h], v[next(h)]) + 1];
  for (size_t x = 0; x < vertices; ++x) out.offsets[x + 1] += out.offsets[x];
  out.keys.clear();  // (no copy of the last round's keys when it grows)
  out.keys.resize(out.offsets[vertices]);
  for (size_t h = 0; h < half_edges; ++h)
    if (v[h] != v[next(h)])
      out.keys[out.offsets[std::min(v[h], v[next(h)])]++] = uint64_t(std::max(v[h], v[next(h)])) << 32 | h;
  for (size_t x = vertices; x > 0; --x) out.offsets[x] = out.offsets[x - 1];  // back to the starts
  out.offsets[0] = 0;
  out.edge_of.assign(half_edges, kNone);
  out.lo.clear();
  out.hi.clear();
  out.first.clear();
  for (size_t x = 0; x < vertices; ++x) {
    uint64_t* first = out.keys.data() + out.offsets[x];
    uint64_t* last = out.keys.data() + out.offsets[x + 1];
    std::sort(first, last);
    for (uint64_t* k = first; k < last; ++k) {
      const uint32_t hi = uint32_t(*k >> 32);
      if (k == first || hi != uint32_t(k[-1] >> 32)) {
        out.lo.push_back(uint32_t(x));
        out.hi.push_back(hi);
        out.first.push_back(uint32_t(k - out.keys.data()));
      }
      out.edge_of[uint32_t(*k)] = uint32_t(out.lo.size() - 1);
    }
  }
  out.first.push_back(uint32_t(out.keys.size()));
}

bool collapsed(const uint32_t* v) { return v[0] == v[1] || v[1] == v[2] || v[0] == v[2]; }

}  // namespace

double split_long_edges_min_faces(const Mesh& mesh, double max_length, const std::vector<double>& face_max_length) {
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

  // A triangle with edges within l has at most (sqrt 3 / 4) l^2 of area, and an edge of length L
  // ends in at least L / l pieces (each in a face, shared by at most two).
  double area_bound = 0, edge_bound = 0;
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    const double l = face_max_length.empty() ? max_length : face_max_length[f];
    area_bound += face_area(mesh, f) / (std::sqrt(3.0) / 4 * l * l);
    for (int k = 0; k < 3; ++k) edge_bound += 0.5 * std::sqrt(length2(mesh.positions, t[k], t[(k + 1) % 3])) / l;
  }
  return std::max(area_bound, edge_bound);
}

SplitEdgesResult split_long_edges(const Mesh& mesh, double max_length, const std::vector<double>& face_max_length,
                                  uint64_t max_faces) {
  const size_t nf = mesh.face_count();
  // Beyond the budget already by the bound: no work at all (and no error, whatever the bound).
  // A request far beyond 32-bit indices is refused before any work (the inputs are checked there).
  const double at_least = split_long_edges_min_faces(mesh, max_length, face_max_length);
  SplitEdgesResult out;
  if (max_faces > 0 && at_least > double(max_faces)) {
    out.over_budget = true;
    out.over_budget_faces = uint64_t(std::min(std::ceil(at_least), 1.8e19));
    return out;
  }
  if (!(at_least <= double(kMaxFaces)))
    throw OptionError("split_long_edges: the limit would make more than " + std::to_string(kMaxFaces) +
                      " faces (at least " + std::to_string(uint64_t(std::min(at_least, 1e19))) + ")");

  out.mesh.positions = mesh.positions;
  out.mesh.indices = mesh.indices;
  out.parent.resize(nf);
  for (size_t f = 0; f < nf; ++f) out.parent[f] = uint32_t(f);
  std::vector<float>& p = out.mesh.positions;
  auto limit2 = [&](size_t f) {
    const double l = face_max_length.empty() ? max_length : face_max_length[out.parent[f]];
    return l * l;
  };

  EdgeNumbering numbering;
  std::vector<double> length2_of;  // per edge
  std::vector<uint32_t> midpoint;  // per edge: its midpoint vertex, kNone while not split
  std::vector<uint32_t> indices, parent, work;
  for (unsigned round = 0;; ++round) {
    const std::vector<uint32_t>& v = out.mesh.indices;
    const size_t faces = v.size() / 3;
    number_edges(v, p.size() / 3, numbering);
    const std::vector<uint32_t>& edge_of = numbering.edge_of;
    const size_t edges = numbering.lo.size();
    length2_of.resize(edges);
    for (size_t e = 0; e < edges; ++e) length2_of[e] = length2(p, numbering.lo[e], numbering.hi[e]);
    midpoint.assign(edges, kNone);
    constexpr uint32_t kMarked = kNone - 1;  // a marked edge before its midpoint is numbered (ids stay below)
    bool any = false;
    for (size_t f = 0; f < faces; ++f) {
      if (collapsed(&v[3 * f])) continue;  // no area: kept as it is
      const double l2 = limit2(f);
      for (int k = 0; k < 3; ++k)
        if (length2_of[edge_of[3 * f + k]] > l2) midpoint[edge_of[3 * f + k]] = kMarked, any = true;
    }
    if (!any) break;
    if (round == kMaxRounds)
      throw OptionError("split_long_edges: edges still too long after " + std::to_string(kMaxRounds) + " rounds");
    // The local index of face f's longest edge; ties go to the lower edge id (lower (lo, hi)), so
    // both faces of an edge agree on the order of their edges.
    auto longest = [&](size_t f) {
      int best = 0;
      for (int k = 1; k < 3; ++k) {
        const uint32_t e = edge_of[3 * f + k], b = edge_of[3 * f + best];
        if (length2_of[e] > length2_of[b] || (length2_of[e] == length2_of[b] && e < b)) best = k;
      }
      return best;
    };
    // Closure: a face with a marked edge has its longest edge marked. Each new mark is longer than
    // the edge that called for it, so this ends; the marks it ends with do not depend on the order
    // (the smallest set closed under the rule), so a work list of the faces on new marks does.
    auto has_mark = [&](size_t f) {
      const uint32_t* e = &edge_of[3 * f];
      return !collapsed(&v[3 * f]) && (midpoint[e[0]] == kMarked || midpoint[e[1]] == kMarked || midpoint[e[2]] == kMarked);
    };
    work.clear();
    for (size_t f = 0; f < faces; ++f)
      if (has_mark(f)) work.push_back(uint32_t(f));
    while (!work.empty()) {
      const uint32_t f = work.back();
      work.pop_back();
      const uint32_t e = edge_of[3 * size_t(f) + longest(f)];
      if (midpoint[e] == kMarked) continue;
      midpoint[e] = kMarked;
      for (uint32_t i = numbering.first[e]; i < numbering.first[e + 1]; ++i)
        work.push_back(uint32_t(numbering.keys[i]) / 3);  // every face on e now has a mark
    }
    // Midpoints numbered in edge order, the order of (lo, hi).
    const size_t vertices = p.size() / 3;
    size_t split = 0;
    for (size_t e = 0; e < edges; ++e) split += midpoint[e] == kMarked;
    if (vertices + split > kMaxVertices)
      throw OptionError("split_long_edges: the result would have more than " + std::to_string(kMaxVertices) + " vertices");
    p.resize(3 * (vertices + split));
    for (size_t e = 0, i = vertices; e < edges; ++e) {
      if (midpoint[e] != kMarked) continue;
      const uint32_t lo = numbering.lo[e], hi = numbering.hi[e];
      midpoint[e] = uint32_t(i);
      // 0.5a + 0.5b, as subdivide_midpoint: symmetric in a, b and no overflow near FLT_MAX.
      for (int d = 0; d < 3; ++d) p[3 * i + d] = 0.5f * p[3 * size_t(lo) + d] + 0.5f * p[3 * size_t(hi) + d];
      ++i;
    }
    out.split_edges += split;
    ++out.rounds;

    // The children per face: one more than its split edges (checked before they are made).
    auto mid = [&](size_t f, int k) { return collapsed(&v[3 * f]) ? kNone : midpoint[edge_of[3 * f + k]]; };
    uint64_t children = 0;
    for (size_t f = 0; f < faces; ++f) children += 1 + (mid(f, 0) != kNone) + (mid(f, 1) != kNone) + (mid(f, 2) != kNone);
    if (max_faces > 0 && children > max_faces) {  // (rounds only add faces: the result would have more)
      SplitEdgesResult over;
      over.over_budget = true;
      over.over_budget_faces = children;
      return over;
    }
    if (children > kMaxFaces)
      throw OptionError("split_long_edges: the result would have more than " + std::to_string(kMaxFaces) + " faces");
    indices.clear();  // (no copy of the last round's faces when it grows)
    parent.clear();
    indices.resize(3 * children);
    parent.resize(children);
    size_t made = 0;
    auto emit = [&](uint32_t a, uint32_t b, uint32_t c, uint32_t from) {
      indices[3 * made] = a, indices[3 * made + 1] = b, indices[3 * made + 2] = c;
      parent[made++] = from;
    };
    for (size_t f = 0; f < faces; ++f) {
      const uint32_t* t = &v[3 * f];
      const uint32_t from = out.parent[f];
      const uint32_t ms[3] = {mid(f, 0), mid(f, 1), mid(f, 2)};
      if (ms[0] == kNone && ms[1] == kNone && ms[2] == kNone) {
        emit(t[0], t[1], t[2], from);
        continue;
      }
      // Rotated so that the longest edge is (a, b), c opposite; m on (a, b), bc and ca maybe.
      const int k = longest(f);
      const uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
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
    assert(made == children);
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

double coarse_edge_length(double sqrt_density_area, uint32_t clusters, double density) {
  if (!(sqrt_density_area >= 0) || !std::isfinite(sqrt_density_area) || clusters == 0 || !(density > 0) ||
      !std::isfinite(density))
    throw OptionError("coarse_edge_length: needs a finite weighted area >= 0, clusters > 0 and a finite density > 0");
  // n vertices of a closed mesh of equilateral triangles make 2n triangles of area (sqrt 3 / 4) l^2
  // each, so a cluster covers (sqrt 3 / 2) l^2. An optimal CVT's cells cover A(rho) = C rho^-1/2
  // (Gersho), and they add up to n: C = S / n with S the integral of sqrt(rho). (With equal
  // weights per cluster instead, area ~ 1 / rho, the limit where rho is low came out several times
  // too long under --gradation, and blade -> 1622 was not split at all.)
  const double cluster_area = sqrt_density_area / (double(clusters) * std::sqrt(density));
  return std::sqrt(2.0 * cluster_area / std::sqrt(3.0));
}

}  // namespace meshcvt
