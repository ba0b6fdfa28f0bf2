// meshcvt: midpoint subdivision, 1 triangle -> 4 per level, with one shared midpoint per edge.
//
// Each level groups the half-edges by their lower vertex with a counting sort (key: higher vertex,
// half-edge), so the half-edges of an edge end up next to each other without a hash table; a run of
// equal keys is one edge and gets one new vertex. Vertex ranges are split over two threads with the
// new vertex ids handed out per range after a count, so the result does not depend on the split.
#include "parallel.h"
#include "meshcvt/subdivide.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <exception>
#include <string>
#include <system_error>
#include <vector>

#include "meshcvt/error.h"

namespace meshcvt {

namespace {

constexpr uint64_t kMaxFaces = 0xffffffffu / 3;     // 3F half-edge ids fit in 32 bits
constexpr uint64_t kMaxVertices = 0xfffffffeu;      // below kNone

inline uint32_t next_half_edge(uint32_t h) { return h % 3 == 2 ? h - 2 : h + 1; }


// Splits [0, count) into `parts` ranges of about equal weight, weight given by the CSR `offsets`.
std::vector<uint32_t> split_by_offsets(const std::vector<uint32_t>& offsets, size_t count, unsigned parts) {
  std::vector<uint32_t> bounds{0};
  for (unsigned p = 1; p < parts; ++p) {
    uint32_t goal = uint32_t(uint64_t(offsets[count]) * p / parts);
    auto it = std::lower_bound(offsets.begin() + bounds.back(), offsets.begin() + count, goal);
    bounds.push_back(uint32_t(it - offsets.begin()));
  }
  bounds.push_back(uint32_t(count));
  return bounds;
}

void sort_small(uint64_t* first, uint64_t* last) {
  if (last - first > 24) {
    std::sort(first, last);
    return;
  }
  for (uint64_t* i = first + 1; i < last; ++i) {
    uint64_t k = *i;
    uint64_t* j = i;
    for (; j > first && j[-1] > k; --j) *j = j[-1];
    *j = k;
  }
}

// One level: `in` -> `out`, faces 4f..4f+3 from face f.
// parts: threads for the passes over vertices and faces (each range's edges are numbered after
// those of the ranges before it, so the result does not depend on it).
void subdivide_level(const Mesh& in, Mesh& out, unsigned parts) {
  size_t nv = in.vertex_count(), nf = in.face_count();
  const uint32_t* indices = in.indices.data();

  // Half-edges grouped by lower vertex: counting sort, keys (higher vertex << 32 | half-edge).
  std::vector<uint32_t> offsets(nv + 1, 0);
  for (uint32_t h = 0; h < 3 * nf; ++h) {
    uint32_t a = indices[h], b = indices[next_half_edge(h)];
    if (a != b) ++offsets[std::min(a, b) + 1];
  }
  for (size_t v = 0; v < nv; ++v) offsets[v + 1] += offsets[v];
  std::vector<uint64_t> keys(offsets[nv]);
  for (uint32_t h = 0; h < 3 * nf; ++h) {
    uint32_t a = indices[h], b = indices[next_half_edge(h)];
    if (a != b) keys[offsets[std::min(a, b)]++] = uint64_t(std::max(a, b)) << 32 | h;
  }
  for (size_t v = nv; v > 0; --v) offsets[v] = offsets[v - 1];
  offsets[0] = 0;

  // Pass 1: sort each vertex's keys and count its edges, per range.
  std::vector<uint32_t> bounds = split_by_offsets(offsets, nv, parts);
  std::vector<uint64_t> range_edges(bounds.size() - 1, 0);
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, size_t part) {
    uint64_t edges = 0;
    for (uint32_t v = begin; v < end; ++v) {
      uint64_t* first = keys.data() + offsets[v];
      uint64_t* last = keys.data() + offsets[v + 1];
      sort_small(first, last);
      for (uint64_t* k = first; k < last; ++k) edges += k == first || (*k >> 32) != (k[-1] >> 32);
    }
    range_edges[part] = edges;
  });
  uint64_t edge_total = 0;
  std::vector<uint64_t> range_first(range_edges.size());
  for (size_t p = 0; p < range_edges.size(); ++p) {
    range_first[p] = nv + edge_total;
    edge_total += range_edges[p];
  }
  if (nv + edge_total > kMaxVertices)
    throw OptionError("subdivision would make " + std::to_string(nv + edge_total) +
                      " vertices; at most 4294967294 are supported");

  // Pass 2: one new vertex per run of equal keys, at the edge midpoint.
  out.positions.resize(3 * (nv + edge_total));
  std::copy(in.positions.begin(), in.positions.end(), out.positions.begin());
  std::vector<uint32_t> midpoint(3 * nf);
  // A collapsed edge (a, a) has no key; its "midpoint" is a.
  for (uint32_t h = 0; h < 3 * nf; ++h)
    if (indices[h] == indices[next_half_edge(h)]) midpoint[h] = indices[h];
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, size_t part) {
    uint32_t id = uint32_t(range_first[part]);
    const float* p = in.positions.data();
    float* q = out.positions.data();
    for (uint32_t v = begin; v < end; ++v) {
      const uint64_t* first = keys.data() + offsets[v];
      const uint64_t* last = keys.data() + offsets[v + 1];
      for (const uint64_t* k = first; k < last; ++k) {
        uint32_t hi = uint32_t(*k >> 32);
        if (k == first || hi != uint32_t(k[-1] >> 32)) {
          // 0.5a + 0.5b rather than (a + b) / 2: no overflow near FLT_MAX, and symmetric in a, b.
          for (int c = 0; c < 3; ++c) q[3 * size_t(id) + c] = 0.5f * p[3 * size_t(v) + c] + 0.5f * p[3 * size_t(hi) + c];
          ++id;
        }
        midpoint[uint32_t(*k)] = id - 1;
      }
    }
    assert(id == range_first[part] + range_edges[part]);
  });
  keys = {};

  out.indices.resize(12 * nf);
  run_ranges(even_bounds(nf, parts), [&](uint32_t begin, uint32_t end, size_t) {
    uint32_t* o = out.indices.data();
    for (size_t f = begin; f < end; ++f) {
      uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
      uint32_t ab = midpoint[3 * f], bc = midpoint[3 * f + 1], ca = midpoint[3 * f + 2];
      uint32_t* t = o + 12 * f;
      t[0] = a,  t[1] = ab, t[2] = ca;
      t[3] = ab, t[4] = b,  t[5] = bc;
      t[6] = ca, t[7] = bc, t[8] = c;
      t[9] = ab, t[10] = bc, t[11] = ca;
    }
  });
}

}  // namespace

Mesh subdivide_midpoint(const Mesh& mesh, unsigned levels, unsigned threads) {
  size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (mesh.indices.size() % 3 != 0 || mesh.positions.size() % 3 != 0)
    throw OptionError("mesh arrays are not whole triangles / vertices");
  for (uint32_t i : mesh.indices)
    if (i >= nv)
      throw OptionError("mesh uses vertex " + std::to_string(i) + " but has " + std::to_string(nv) + " vertices");
  if (!mesh.source_polygon.empty() && mesh.source_polygon.size() != nf)
    throw OptionError("mesh has " + std::to_string(mesh.source_polygon.size()) + " source_polygon entries for " +
                      std::to_string(nf) + " faces");
  if (levels == 0 || nf == 0) return mesh;
  // Check the final size before doing any work.
  uint64_t faces = nf;
  for (unsigned k = 0; k < levels && faces > 0; ++k) {
    faces *= 4;
    if (faces > kMaxFaces)
      throw OptionError(std::to_string(levels) + " subdivision levels of " + std::to_string(nf) +
                        " faces make more than " + std::to_string(kMaxFaces) + " faces");
  }

  Mesh current, next;
  const Mesh* in = &mesh;
  for (unsigned k = 0; k < levels; ++k) {
    subdivide_level(*in, next, range_threads(in->face_count(), threads));
    std::swap(current, next);
    in = &current;
  }
  // Children of input face f are [f * 4^levels, (f + 1) * 4^levels): shift by 2 bits per level.
  current.source_polygon.resize(current.face_count());
  unsigned shift = 2 * levels;
  for (size_t i = 0; i < current.face_count(); ++i) {
    size_t f = i >> shift;
    current.source_polygon[i] = mesh.source_polygon.empty() ? uint32_t(f) : mesh.source_polygon[f];
  }
  return current;
}

SubdividedFaces subdivide_faces(const Mesh& mesh, const std::vector<uint8_t>& selected, unsigned levels,
                                bool split_neighbours) {
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (selected.size() != nf)
    throw OptionError("subdivide_faces: " + std::to_string(selected.size()) + " selection entries for " +
                      std::to_string(nf) + " faces");
  if (!mesh.source_polygon.empty() && mesh.source_polygon.size() != nf)
    throw OptionError("mesh has " + std::to_string(mesh.source_polygon.size()) + " source_polygon entries for " +
                      std::to_string(nf) + " faces");
  for (uint32_t i : mesh.indices)
    if (i >= nv)
      throw OptionError("mesh uses vertex " + std::to_string(i) + " but has " + std::to_string(nv) + " vertices");
  if (split_neighbours && levels > 1)
    throw OptionError("subdivide_faces: split_neighbours takes one level at a time, not " + std::to_string(levels));
  // The selected faces alone, their vertices renumbered in order of first use.
  Mesh part;
  std::vector<uint32_t> local(nv, kNone), global;
  std::vector<uint64_t> edges;  // (lower << 32 | higher) of the selected faces' edges
  for (size_t f = 0; f < nf; ++f) {
    if (!selected[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * f + k], w = mesh.indices[3 * f + (k + 1) % 3];
      if (local[v] == kNone) {
        local[v] = uint32_t(global.size());
        global.push_back(v);
        part.positions.insert(part.positions.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v)] + 3);
      }
      part.indices.push_back(local[v]);
      if (v != w) edges.push_back(uint64_t(std::min(v, w)) << 32 | std::max(v, w));
    }
  }
  std::sort(edges.begin(), edges.end());
  // A face left as it is must not have an edge that gets a midpoint; with split_neighbours such a
  // face is split there instead (split_edges: a bit per edge, k for the edge from corner k).
  std::vector<uint8_t> split_edges(split_neighbours ? nf : 0, 0);
  uint64_t extra_faces = 0;  // what the split neighbours add
  for (size_t f = 0; f < nf && levels > 0; ++f) {
    if (selected[f]) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * f + k], w = mesh.indices[3 * f + (k + 1) % 3];
      if (v == w || local[v] == kNone || local[w] == kNone) continue;
      if (!std::binary_search(edges.begin(), edges.end(), uint64_t(std::min(v, w)) << 32 | std::max(v, w))) continue;
      if (!split_neighbours)
        throw OptionError("subdivide_faces: face " + std::to_string(f) +
                          " is not selected but shares an edge with a selected face (the split would leave a T-junction)");
      split_edges[f] |= uint8_t(1u << k);
      ++extra_faces;  // one more face per split edge: 2, 3 or 4 in all
    }
  }
  const Mesh fine = subdivide_midpoint(part, levels);
  const size_t part_nv = global.size(), children = size_t(1) << (2 * levels);
  if (nv + (fine.vertex_count() - part_nv) > kMaxVertices ||
      nf + (children - 1) * part.face_count() + extra_faces > kMaxFaces)
    throw OptionError("subdivide_faces: the result would be beyond 32-bit indices");
  SubdividedFaces out;
  out.mesh.positions = mesh.positions;
  out.mesh.positions.insert(out.mesh.positions.end(), fine.positions.begin() + 3 * part_nv, fine.positions.end());
  auto vertex_of = [&](uint32_t i) { return i < part_nv ? global[i] : uint32_t(nv + (i - part_nv)); };
  // With split neighbours (one level): each selected edge's midpoint, read off the children of a
  // selected face on it, (a, ab, ca) and (ab, b, bc) (subdivide_midpoint's order).
  std::vector<std::pair<uint64_t, uint32_t>> midpoints;  // (lower << 32 | higher, output vertex)
  if (extra_faces > 0) {
    size_t i = 0;
    for (size_t f = 0; f < nf; ++f) {
      if (!selected[f]) continue;
      const uint32_t* t = &mesh.indices[3 * f];
      const uint32_t* first = &fine.indices[3 * (4 * i)];
      const uint32_t mid[3] = {vertex_of(first[1]), vertex_of(fine.indices[3 * (4 * i + 1) + 2]), vertex_of(first[2])};
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = t[k], w = t[(k + 1) % 3];
        if (v != w) midpoints.push_back({uint64_t(std::min(v, w)) << 32 | std::max(v, w), mid[k]});
      }
      ++i;
    }
    std::sort(midpoints.begin(), midpoints.end());
  }
  auto midpoint_of = [&](uint32_t v, uint32_t w) {
    const uint64_t key = uint64_t(std::min(v, w)) << 32 | std::max(v, w);
    const auto it = std::lower_bound(midpoints.begin(), midpoints.end(), std::pair<uint64_t, uint32_t>{key, 0});
    assert(it != midpoints.end() && it->first == key);
    return it->second;
  };
  auto squared_distance = [&](uint32_t v, uint32_t w) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = double(out.mesh.positions[3 * size_t(v) + c]) - out.mesh.positions[3 * size_t(w) + c];
      d2 += d * d;
    }
    return d2;
  };
  const size_t faces_out = nf + (children - 1) * part.face_count() + extra_faces;
  out.mesh.indices.reserve(3 * faces_out);
  out.parent.reserve(faces_out);
  size_t next_part_face = 0;
  for (size_t f = 0; f < nf; ++f) {
    if (!selected[f] && (split_edges.empty() || split_edges[f] == 0)) {
      out.mesh.indices.insert(out.mesh.indices.end(), &mesh.indices[3 * f], &mesh.indices[3 * f] + 3);
      out.parent.push_back(uint32_t(f));
      continue;
    }
    if (!selected[f]) {
      // A neighbour split at its split edges' midpoints, oriented as it: across the one split edge
      // (two faces), at the corner between two (that corner's triangle and the rest cut along its
      // shorter diagonal: three), or as a selected face (four).
      const uint32_t* t = &mesh.indices[3 * f];
      const unsigned bits = split_edges[f];
      auto emit = [&](uint32_t a, uint32_t b, uint32_t c) {
        out.mesh.indices.insert(out.mesh.indices.end(), {a, b, c});
        out.parent.push_back(uint32_t(f));
      };
      if (bits == 7) {
        const uint32_t ab = midpoint_of(t[0], t[1]), bc = midpoint_of(t[1], t[2]), ca = midpoint_of(t[2], t[0]);
        emit(t[0], ab, ca), emit(ab, t[1], bc), emit(ca, bc, t[2]), emit(ab, bc, ca);
      } else if (bits == 1 || bits == 2 || bits == 4) {
        const int k = bits == 1 ? 0 : bits == 2 ? 1 : 2;  // the split edge runs from corner k
        const uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3], m = midpoint_of(a, b);
        emit(a, m, c), emit(m, b, c);
      } else {
        const int u = (~bits & 7) == 1 ? 0 : (~bits & 7) == 2 ? 1 : 2;  // the edge left whole runs from corner u
        const uint32_t c = t[u], a = t[(u + 1) % 3], b = t[(u + 2) % 3];
        const uint32_t ab = midpoint_of(a, b), bc = midpoint_of(b, c);
        emit(ab, b, bc);
        if (squared_distance(a, bc) <= squared_distance(ab, c))
          emit(a, ab, bc), emit(a, bc, c);
        else
          emit(a, ab, c), emit(ab, bc, c);
      }
      continue;
    }
    for (size_t c = next_part_face * children; c < (next_part_face + 1) * children; ++c) {
      for (int k = 0; k < 3; ++k) out.mesh.indices.push_back(vertex_of(fine.indices[3 * c + k]));
      out.parent.push_back(uint32_t(f));
    }
    ++next_part_face;
  }
  assert(out.parent.size() == faces_out);
  out.mesh.source_polygon.resize(faces_out);
  for (size_t i = 0; i < faces_out; ++i)
    out.mesh.source_polygon[i] = mesh.source_polygon.empty() ? out.parent[i] : mesh.source_polygon[out.parent[i]];
  return out;
}

unsigned subdivision_levels_for(size_t faces, uint32_t clusters, double min_faces_per_cluster) {
  if (!(min_faces_per_cluster >= 0) || !std::isfinite(min_faces_per_cluster))
    throw OptionError("minimum faces per cluster must be a finite number >= 0, not " +
                      std::to_string(min_faces_per_cluster));
  double target = double(clusters) * min_faces_per_cluster;
  double have = double(faces);
  if (have >= target) return 0;
  if (faces == 0) throw OptionError("a mesh with no faces cannot be subdivided to reach " + std::to_string(clusters) + " clusters");
  // have grows by 4x per step and target is finite, so this ends (after ~log4(target) steps).
  unsigned k = 0;
  for (; have < target; ++k) have *= 4;
  return k;
}

}  // namespace meshcvt
