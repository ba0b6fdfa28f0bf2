// meshcvt: reordering a mesh for memory locality (Morton order of face centroids), see
// meshcvt/mesh_order.h. Morton (Z-order) curves: G. M. Morton, 1966; their use for mesh layouts
// e.g. in Isenburg, Lindstrom, "Streaming meshes", 2005. A 30-bit code (10 bits per axis) sorted by
// two stable 15-bit counting passes: O(F), and deterministic, since ties keep the input order.
#include "meshcvt/mesh_order.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>

#include "morton.h"
#include "parallel.h"

namespace meshcvt {

namespace {

constexpr uint32_t kNoVertex = 0xffffffffu;

// fn(begin, end, part) over [0, count) in `parts` ranges of about equal size.
template <class Fn>
void for_ranges(size_t count, unsigned parts, const Fn& fn) {
  run_ranges(even_bounds(count, parts), fn);
}

// value = min(value, x), for values that several threads lower at once.
inline void lower_to(uint32_t& value, uint32_t x) {
  std::atomic_ref<uint32_t> v(value);
  uint32_t seen = v.load(std::memory_order_relaxed);
  while (x < seen && !v.compare_exchange_weak(seen, x, std::memory_order_relaxed)) {
  }
}

}  // namespace

LocalityOrder reorder_for_locality(Mesh& mesh, size_t min_faces, unsigned threads) {
  LocalityOrder order;
  const size_t nf = mesh.face_count(), nv = mesh.vertex_count();
  // (Corner positions 3 i + j are 32-bit below; a mesh with more faces is refused later anyway,
  // by build_topology.)
  if (nf < min_faces || nf == 0 || nf > (kNoVertex - 1) / 3) return order;
  const unsigned face_parts = range_threads(nf, threads), vertex_parts = range_threads(nv, threads);
  // The box of all vertices (a referenced vertex lies in it; an unreferenced one far away only
  // makes the grid coarser). Min and max do not depend on the split.
  struct Box {
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  };
  std::vector<Box> boxes(vertex_parts);
  for_ranges(nv, vertex_parts, [&](size_t begin, size_t end, size_t part) {
    Box& box = boxes[part];
    for (size_t v = begin; v < end; ++v)
      for (int k = 0; k < 3; ++k) {
        const float x = mesh.positions[3 * v + k];
        box.lo[k] = std::min(box.lo[k], x);
        box.hi[k] = std::max(box.hi[k], x);
      }
  });
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (const Box& box : boxes)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], box.lo[k]);
      hi[k] = std::max(hi[k], box.hi[k]);
    }
  float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const float scale = extent > 0 && std::isfinite(extent) ? 1023.0f / extent : 0.0f;
  std::vector<uint32_t> key(nf);
  for_ranges(nf, face_parts, [&](size_t begin, size_t end, size_t) {
    for (size_t f = begin; f < end; ++f) {
      uint32_t code = 0;
      for (int k = 0; k < 3; ++k) {
        float c = 0;
        for (int j = 0; j < 3; ++j) c += mesh.positions[3 * size_t(mesh.indices[3 * f + j]) + k];
        float cell = (c / 3 - lo[k]) * scale;  // NaN coordinates: cell 0
        uint32_t q = cell > 0 ? uint32_t(std::min(cell, 1023.0f)) : 0;
        code |= spread_bits(q) << k;
      }
      key[f] = code;
    }
  });
  order.face_of = sort_by_key(key, face_parts);
  std::vector<uint32_t>().swap(key);

  // The corners in the new face order, still with the input's vertex ids: the passes below read
  // them in order rather than through face_of.
  std::vector<uint32_t> indices(3 * nf);
  for_ranges(nf, face_parts, [&](size_t begin, size_t end, size_t) {
    for (size_t i = begin; i < end; ++i)
      for (int j = 0; j < 3; ++j) indices[3 * i + j] = mesh.indices[3 * size_t(order.face_of[i]) + j];
  });
  // Vertices by first use: a vertex's new id is the number of vertices whose first corner comes
  // before its own. Each thread lowers the first corners of its corners' vertices, then counts the
  // first corners in its range, and numbers them after those of the ranges before it.
  const size_t corners = 3 * nf;
  std::vector<uint32_t> first(nv, kNoVertex);
  for_ranges(corners, face_parts, [&](size_t begin, size_t end, size_t) {
    for (size_t k = begin; k < end; ++k) lower_to(first[indices[k]], uint32_t(k));
  });
  std::vector<uint32_t> firsts(face_parts + 1, 0);
  for_ranges(corners, face_parts, [&](size_t begin, size_t end, size_t part) {
    uint32_t n = 0;
    for (size_t k = begin; k < end; ++k) n += first[indices[k]] == k;
    firsts[part + 1] = n;
  });
  for (unsigned p = 0; p < face_parts; ++p) firsts[p + 1] += firsts[p];
  std::vector<uint32_t> new_id(nv, kNoVertex);
  order.vertex_of.resize(nv);
  for_ranges(corners, face_parts, [&](size_t begin, size_t end, size_t part) {
    uint32_t next = firsts[part];
    for (size_t k = begin; k < end; ++k) {
      const uint32_t v = indices[k];
      if (first[v] == k) {
        new_id[v] = next;
        order.vertex_of[next++] = v;
      }
    }
  });
  std::vector<uint32_t>().swap(first);
  uint32_t next = firsts[face_parts];
  for (uint32_t v = 0; v < nv; ++v)
    if (new_id[v] == kNoVertex) {
      new_id[v] = next;
      order.vertex_of[next++] = v;
    }
  assert(next == nv);
  for_ranges(corners, face_parts, [&](size_t begin, size_t end, size_t) {
    for (size_t k = begin; k < end; ++k) indices[k] = new_id[indices[k]];
  });
  mesh.indices.swap(indices);
  std::vector<float> positions(3 * nv);
  for_ranges(nv, vertex_parts, [&](size_t begin, size_t end, size_t) {
    for (size_t j = begin; j < end; ++j)
      for (int k = 0; k < 3; ++k) positions[3 * j + k] = mesh.positions[3 * size_t(order.vertex_of[j]) + k];
  });
  mesh.positions.swap(positions);
  if (mesh.source_polygon.size() == nf) {
    std::vector<uint32_t> source(nf);
    for (size_t i = 0; i < nf; ++i) source[i] = mesh.source_polygon[order.face_of[i]];
    mesh.source_polygon.swap(source);
  }
  return order;
}

void restore_input_order(Mesh& mesh, const LocalityOrder& order) {
  if (order.identity()) return;
  const size_t nf = order.face_of.size(), nv = order.vertex_of.size();
  assert(mesh.face_count() == nf && mesh.vertex_count() == nv);
  std::vector<uint32_t> indices(3 * nf);
  for (size_t i = 0; i < nf; ++i)
    for (int j = 0; j < 3; ++j) indices[3 * size_t(order.face_of[i]) + j] = order.vertex_of[mesh.indices[3 * i + j]];
  mesh.indices.swap(indices);
  std::vector<float> positions(3 * nv);
  for (size_t j = 0; j < nv; ++j)
    for (int k = 0; k < 3; ++k) positions[3 * size_t(order.vertex_of[j]) + k] = mesh.positions[3 * j + k];
  mesh.positions.swap(positions);
  if (mesh.source_polygon.size() == nf) {
    std::vector<uint32_t> source(nf);
    for (size_t i = 0; i < nf; ++i) source[order.face_of[i]] = mesh.source_polygon[i];
    mesh.source_polygon.swap(source);
  }
}

std::vector<uint32_t> to_input_order(const std::vector<uint32_t>& per_face, const LocalityOrder& order) {
  if (order.identity() || per_face.empty()) return per_face;  // empty: nothing per face
  assert(per_face.size() == order.face_of.size());
  std::vector<uint32_t> out(per_face.size());
  for (size_t i = 0; i < per_face.size(); ++i) out[order.face_of[i]] = per_face[i];
  return out;
}

std::vector<float> to_reordered(const std::vector<float>& per_input_face, const LocalityOrder& order) {
  if (order.identity() || per_input_face.empty()) return per_input_face;  // empty: e.g. uniform density
  assert(per_input_face.size() == order.face_of.size());
  std::vector<float> out(per_input_face.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = per_input_face[order.face_of[i]];
  return out;
}

}  // namespace meshcvt
