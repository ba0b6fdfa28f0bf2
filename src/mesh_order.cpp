// meshcvt: reordering a mesh for memory locality (Morton order of face centroids), see
// meshcvt/mesh_order.h. Morton (Z-order) curves: G. M. Morton, 1966; their use for mesh layouts
// e.g. in Isenburg, Lindstrom, "Streaming meshes", 2005. A 30-bit code (10 bits per axis) sorted by
// two stable 15-bit counting passes: O(F), and deterministic, since ties keep the input order.
#include "meshcvt/mesh_order.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <thread>

#include "morton.h"
#include "parallel.h"

namespace meshcvt {

namespace {

constexpr uint32_t kNoVertex = 0xffffffffu;

}  // namespace

LocalityOrder reorder_for_locality(Mesh& mesh, size_t min_faces) {
  LocalityOrder order;
  const size_t nf = mesh.face_count(), nv = mesh.vertex_count();
  if (nf < min_faces || nf == 0) return order;
  // The box of all vertices, read in order (a referenced vertex lies in it; an unreferenced one
  // far away only makes the grid coarser).
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < nv; ++v)
    for (int k = 0; k < 3; ++k) {
      float x = mesh.positions[3 * v + k];
      lo[k] = std::min(lo[k], x);
      hi[k] = std::max(hi[k], x);
    }
  float extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  const float scale = extent > 0 && std::isfinite(extent) ? 1023.0f / extent : 0.0f;
  std::vector<uint32_t> key(nf);
  // Keys in parallel (each face's own), the face ranges split in two or more.
  const unsigned parts = std::max(1u, std::min(4u, std::thread::hardware_concurrency()));
  std::vector<uint32_t> bounds;
  for (unsigned p = 0; p <= parts; ++p) bounds.push_back(uint32_t(nf * p / parts));
  run_ranges(bounds, [&](size_t begin, size_t end, size_t) {
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
  order.face_of = sort_by_key(key);
  std::vector<uint32_t>().swap(key);

  // Vertices by first use; then the arrays are rebuilt in the new order.
  std::vector<uint32_t> new_id(nv, kNoVertex);
  order.vertex_of.reserve(nv);
  for (uint32_t f : order.face_of)
    for (int j = 0; j < 3; ++j) {
      uint32_t v = mesh.indices[3 * size_t(f) + j];
      if (new_id[v] == kNoVertex) {
        new_id[v] = uint32_t(order.vertex_of.size());
        order.vertex_of.push_back(v);
      }
    }
  for (uint32_t v = 0; v < nv; ++v)
    if (new_id[v] == kNoVertex) {
      new_id[v] = uint32_t(order.vertex_of.size());
      order.vertex_of.push_back(v);
    }
  assert(order.vertex_of.size() == nv);

  std::vector<uint32_t> indices(3 * nf);
  for (size_t i = 0; i < nf; ++i)
    for (int j = 0; j < 3; ++j) indices[3 * i + j] = new_id[mesh.indices[3 * size_t(order.face_of[i]) + j]];
  mesh.indices.swap(indices);
  std::vector<float> positions(3 * nv);
  for (size_t j = 0; j < nv; ++j)
    for (int k = 0; k < 3; ++k) positions[3 * j + k] = mesh.positions[3 * size_t(order.vertex_of[j]) + k];
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
