// meshcvt: mesh connectivity, built once per mesh as flat arrays (CSR), and the `info` summary.
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Connectivity of a triangle mesh. Edge e of face f joins corners e and (e+1)%3 of f.
///
/// Faces are adjacent only across manifold edges (exactly two faces, any orientation); a
/// non-manifold edge (three or more faces) links nobody and is counted.
struct Topology {
  /// face_adjacent[3*f + e]: the face across edge e of face f, or kNone (boundary or non-manifold).
  std::vector<uint32_t> face_adjacent;

  /// Vertex -> incident faces, CSR: faces of vertex v are
  /// vertex_faces[vertex_face_offsets[v] .. vertex_face_offsets[v+1]), in increasing face id.
  std::vector<uint32_t> vertex_face_offsets;  // vertex_count + 1 entries
  std::vector<uint32_t> vertex_faces;

  /// Connected components of the face graph (across manifold edges): id per face, numbered in
  /// order of their lowest face.
  std::vector<uint32_t> face_component;
  uint32_t component_count = 0;

  uint64_t edge_count = 0;             ///< distinct undirected edges
  uint64_t boundary_edges = 0;         ///< edges with one face
  uint64_t boundary_loops = 0;         ///< closed chains of boundary edges
  uint64_t nonmanifold_edges = 0;      ///< edges with three or more faces
  uint64_t nonmanifold_vertices = 0;   ///< vertices whose face fan is not one disk or half-disk
  uint64_t degenerate_faces = 0;       ///< zero area (repeated corner or collinear)
  uint64_t duplicate_faces = 0;        ///< same three vertices as an earlier face (any order)
  uint64_t referenced_vertices = 0;    ///< vertices used by at least one face
};

/// Builds the connectivity of `mesh`. O(F log F) time, about 40 bytes per face.
Topology build_topology(const Mesh& mesh);

/// Summary printed by `meshcvt info`.
struct MeshInfo {
  uint64_t vertices = 0, faces = 0, edges = 0;
  uint32_t components = 0;
  uint64_t boundary_edges = 0, boundary_loops = 0;
  uint64_t nonmanifold_edges = 0, nonmanifold_vertices = 0;
  uint64_t degenerate_faces = 0, duplicate_faces = 0;
  int64_t euler_characteristic = 0;  ///< V - E + F over referenced vertices
  /// Genus, defined when the mesh is one closed, manifold, connected surface: (2 - chi) / 2.
  /// For an orientable manifold with boundary: (2 - chi - loops) / 2. -1 when not defined.
  int64_t genus = -1;
  float bbox_min[3] = {0, 0, 0}, bbox_max[3] = {0, 0, 0};
  double total_area = 0;  ///< in squared input units
};

/// Fills MeshInfo from a mesh and its topology.
MeshInfo mesh_info(const Mesh& mesh, const Topology& topology);

}  // namespace meshcvt
