// meshcvt: the triangles around each vertex of a coarse mesh, and sampled corners of each cluster,
// shared by the passes that move its vertices (coarse_relax.cpp, coarse_fit.cpp,
// coarse_toward_surface.cpp). Internal, not public API.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"
#include "vec3.h"

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

// Up to max_corners corners of the faces of each cluster c with wanted[c] != 0 (every cluster when
// `wanted` is null), CSR: those of every stride-th face of c in face order, stride = ceil(faces of
// c / (max_corners / 3)), so they spread over the cluster. What the moves of a coarse vertex
// measure the distance to the input from (coarse_relax.cpp, coarse_toward_surface.cpp).
inline void sample_cluster_corners(const Mesh& mesh, const std::vector<uint32_t>& labels, size_t clusters,
                                   size_t max_corners, const std::vector<uint8_t>* wanted,
                                   std::vector<uint32_t>& offsets, std::vector<Vec3>& corners) {
  const size_t wanted_faces = std::max<size_t>(1, max_corners / 3);
  std::vector<uint32_t> faces(clusters, 0), stride(clusters, 1), seen(clusters, 0);
  for (uint32_t c : labels)
    if (!wanted || (*wanted)[c]) ++faces[c];
  offsets.assign(clusters + 1, 0);
  for (size_t c = 0; c < clusters; ++c) {
    stride[c] = uint32_t(std::max<size_t>(1, (faces[c] + wanted_faces - 1) / wanted_faces));
    offsets[c + 1] = offsets[c] + 3 * ((faces[c] + stride[c] - 1) / stride[c]);
  }
  corners.resize(offsets[clusters]);
  for (size_t f = 0; f < labels.size(); ++f) {
    const uint32_t c = labels[f];
    if ((wanted && !(*wanted)[c]) || seen[c]++ % stride[c] != 0) continue;
    const size_t at = offsets[c] + 3 * ((seen[c] - 1) / stride[c]);
    for (int k = 0; k < 3; ++k) corners[at + k] = mesh_vertex(mesh, mesh.indices[3 * f + k]);
  }
}

}  // namespace meshcvt
