// meshcvt: a memory order with locality for large meshes.
//
// Scanned and exported meshes often list their faces in no spatial order (libcgal-demo's bunny00:
// the median index distance between two adjacent faces is 12,900 of 75k), so every pass of the
// clustering that goes from a face to its neighbours (initialization, Lloyd steps, boundary
// testing, topology) misses the cache once the per-face arrays outgrow it. Reordering the mesh
// first, and restoring the input order for the outputs, makes those passes local.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Meshes with at least this many faces are worth reordering (the command-line tool does it
/// from here on): below it the per-face arrays of the clustering mostly stay in cache.
constexpr size_t kLocalityMinFaces = size_t(1) << 18;

/// How a mesh was reordered: face i of the reordered mesh is input face face_of[i], vertex j is
/// input vertex vertex_of[j]. Both empty: the mesh was left as it was.
struct LocalityOrder {
  std::vector<uint32_t> face_of;
  std::vector<uint32_t> vertex_of;
  bool identity() const { return face_of.empty(); }
};

/// Reorders `mesh` in place: faces by the Morton (Z-order) code of their centroid on a 1024^3 grid
/// over the bounding box of the vertices (ties keep the input order, so the order is
/// deterministic), vertices by first use in the new face order (unreferenced vertices last, in
/// input order); source_polygon follows the faces. The geometry and the orientation of every face are unchanged. O(F).
/// Meshes with fewer than `min_faces` faces are left as they are (an identity order is returned).
/// threads: how many threads work on it, at most 16; 0 (the default): one per core, and one per
/// 32768 faces at most. The result does not depend on it.
LocalityOrder reorder_for_locality(Mesh& mesh, size_t min_faces = kLocalityMinFaces, unsigned threads = 0);

/// Puts a mesh reordered by reorder_for_locality back in its input order (exactly: same arrays).
void restore_input_order(Mesh& mesh, const LocalityOrder& order);

/// Per-face values of the reordered mesh (e.g. Clustering::labels), in the input's face order
/// (an empty vector stays empty).
std::vector<uint32_t> to_input_order(const std::vector<uint32_t>& per_face, const LocalityOrder& order);

/// Per-face values in the input's face order (e.g. a density), in the reordered mesh's order (an
/// empty vector, e.g. a uniform density, stays empty).
std::vector<float> to_reordered(const std::vector<float>& per_input_face, const LocalityOrder& order);

}  // namespace meshcvt
