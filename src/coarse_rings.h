// meshcvt: the triangles around each vertex of a coarse mesh, shared by the passes that move its
// vertices (coarse_relax.cpp, coarse_fit.cpp). Internal, not public API.
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

// Triangles per vertex, CSR: the triangles of vertex v are ring[offsets[v] .. offsets[v + 1]), in
// increasing order (a triangle repeating v is listed once per corner).
inline void coarse_triangle_rings(const Mesh& coarse, std::vector<uint32_t>& offsets, std::vector<uint32_t>& ring) {
  const size_t n = coarse.vertex_count(), triangles = coarse.face_count();
  offsets.assign(n + 1, 0);
  ring.resize(3 * triangles);
  for (uint32_t v : coarse.indices) ++offsets[v + 1];
  for (size_t i = 0; i < n; ++i) offsets[i + 1] += offsets[i];
  std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (size_t t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k) ring[fill[coarse.indices[3 * t + k]]++] = uint32_t(t);
}

}  // namespace meshcvt
