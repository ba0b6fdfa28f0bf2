// meshcvt: mesh connectivity, built once per mesh as flat arrays (CSR), and the `info` summary.
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Connectivity of a triangle mesh. Edge e of face f joins corners e and (e+1)%3 of f; it is the
/// half-edge h = 3f + e, which starts at vertex indices[h].
///
/// Faces are adjacent only across manifold edges (exactly two faces, any orientation); a
/// non-manifold edge (three or more faces) links nobody and is counted.
///
/// A *collapsed* face (two or three equal corner indices, e.g. left by welding) has no edges: it
/// is adjacent to nobody, forms a component of its own, and its neighbours meet each other
/// across the edge it collapsed onto as if it were not there. It is still listed in vertex_faces
/// (once per distinct vertex) and counted in degenerate_faces.
struct Topology {
  /// face_adjacent[3*f + e]: the face across edge e of face f, or kNone (boundary, non-manifold
  /// or collapsed). Symmetric: if g = face_adjacent[3f+e] then g has an edge with the same two
  /// vertices whose entry is f.
  std::vector<uint32_t> face_adjacent;

  /// Vertex -> incident faces, CSR: faces of vertex v are
  /// vertex_faces[vertex_face_offsets[v] .. vertex_face_offsets[v+1]), in increasing face id, each
  /// face once. Unreferenced vertices have an empty range.
  std::vector<uint32_t> vertex_face_offsets;  // vertex_count + 1 entries
  std::vector<uint32_t> vertex_faces;

  /// Connected components of the face graph (across manifold edges): id per face, numbered in
  /// order of their lowest face (face 0 is in component 0).
  std::vector<uint32_t> face_component;
  uint32_t component_count = 0;

  uint64_t edge_count = 0;             ///< distinct undirected edges {a, b}, a != b
  uint64_t boundary_edges = 0;         ///< edges with one face
  /// Chains of boundary edges. At each end of a boundary edge the chain goes on to the boundary
  /// edge that closes the same fan of faces around that vertex (not just any boundary edge there),
  /// so two holes touching at one vertex are two loops. A chain cut short by a non-manifold edge
  /// still counts as one loop.
  uint64_t boundary_loops = 0;
  uint64_t nonmanifold_edges = 0;      ///< edges with three or more faces
  /// Referenced vertices whose faces, linked through the manifold edges at the vertex, fall into
  /// more than one fan (e.g. the bow-tie, or any vertex of a non-manifold edge). Collapsed faces
  /// are not part of any fan.
  uint64_t nonmanifold_vertices = 0;
  uint64_t degenerate_faces = 0;       ///< zero area: collapsed, or cross product exactly zero (in double)
  /// Faces with the same three vertices as an earlier face, in any order and orientation (for
  /// collapsed faces: the same sorted corner triple).
  uint64_t duplicate_faces = 0;
  uint64_t referenced_vertices = 0;    ///< vertices used by at least one face

  // ---- extensions (beyond the first contract)
  uint64_t collapsed_faces = 0;        ///< faces with a repeated corner index (part of degenerate_faces)
  /// Manifold edges whose two faces run along them in the same direction, i.e. neighbours with
  /// inconsistent orientation. 0 for a consistently oriented mesh.
  uint64_t orientation_flips = 0;
  /// Components whose faces cannot all be flipped to agree (a Moebius strip, a Klein bottle).
  /// Only searched for when orientation_flips > 0.
  uint32_t nonorientable_components = 0;
};

/// Builds the connectivity of `mesh`.
///
/// Input : mesh with F faces and V vertices; indices must be < V (asserted in debug builds;
///         checked: throws OptionError otherwise). At most 1431655765 faces (3F half-edges must
///         fit in 32 bits; OptionError otherwise).
/// Output: the Topology above. O(F + V) time apart from sorting the few edges at each vertex;
///         about 30 bytes per face for the result (face_adjacent, vertex_faces, face_component,
///         vertex_face_offsets) and per-vertex scratch besides (up to 12 bytes per vertex).
/// threads: how many threads work on it, at most 16; 0 (the default): one per core, and one per
///         32768 faces at most. The result does not depend on it.
Topology build_topology(const Mesh& mesh, unsigned threads = 0);

/// Orients every orientable component consistently: flips faces (swaps their corners 1 and 2) so
/// that across each manifold edge the two faces run along it in opposite directions, as a
/// scanner's or exporter's mesh with randomly ordered triangles needs before its dual, its normals
/// or its curvature mean anything. A closed component (no boundary or non-manifold edge) is made to
/// face outward (positive signed volume); an open one keeps the orientation of the larger part of
/// its area (on a tie, its lowest face's). Non-orientable components
/// (topology.nonorientable_components) are left as they are; so is every face of a component
/// already consistent. Positions, face order and connectivity do not change.
///
/// Input : mesh and topology = build_topology(mesh).
/// Output: the number of faces flipped; when it is > 0, topology is rebuilt for the flipped mesh
///         (orientation_flips is then 0 unless a component is non-orientable). O(F + V); nothing is
///         allocated when topology.orientation_flips == 0.
uint64_t orient_consistently(Mesh& mesh, Topology& topology);

/// The faces orient_consistently would flip, without flipping them: flip[f] = 1 for each (empty
/// when topology.orientation_flips == 0). For what needs consistent normals but not a changed mesh
/// (the L2,1 metric of cluster()). Same inputs; O(F + V).
std::vector<uint8_t> faces_to_orient(const Mesh& mesh, const Topology& topology);

/// Gives each fan of faces around a pinched vertex its own copy of the vertex (same position), so
/// that parts of the surface that touch at a point (two spheres sharing a vertex, a hole's rim
/// touching another's, a scan's pinched fold) no longer do. A fan is a set of faces at the vertex
/// joined across its manifold edges; the fan with the lowest face keeps the vertex, the others get
/// copies appended to the positions in the order of (vertex, lowest face). Vertices of a
/// non-manifold edge (three or more faces) are left as they are: copies would open that edge into
/// a slit. Collapsed faces stay on the vertex.
///
/// Input : mesh and topology = build_topology(mesh).
/// Output: the number of copies added (new vertices); when it is > 0, topology is rebuilt for the
///         changed mesh, whose Euler characteristic grows by as much. Faces, their order and
///         orientation do not change. O(F + V); nothing is done when topology.nonmanifold_vertices
///         == 0.
uint64_t split_pinched_vertices(Mesh& mesh, Topology& topology);

/// Removes the faces with a repeated corner index (collapsed: no area and no edges, e.g. left by
/// welding a sliver), keeping the others in order, and source_polygon in step with them (made
/// explicit when it was empty). Vertices are left as they are (some may then be unreferenced).
///
/// Input : mesh. Output: the number of faces removed; kept_index (optional): for each face of the
///         mesh as given, its index after, or kNone when removed. The caller rebuilds the topology.
///         O(F).
uint64_t remove_collapsed_faces(Mesh& mesh, std::vector<uint32_t>* kept_index = nullptr);

/// Per-face labels of `mesh` from those of the mesh remove_collapsed_faces made of it: a kept face
/// takes its own (kept_labels[kept_index[f]]), a removed one the label of the lowest kept face at
/// its lowest corner that has one, or `fallback` where no kept face shares a corner with it.
///
/// Input : mesh and topology = build_topology(mesh); kept_index as remove_collapsed_faces gave it;
///         kept_labels, one per kept face. Output: mesh.face_count() labels. O(F + removed faces x
///         their corners' valence).
std::vector<uint32_t> labels_with_collapsed_faces(const Mesh& mesh, const Topology& topology,
                                                  const std::vector<uint32_t>& kept_index,
                                                  const std::vector<uint32_t>& kept_labels, uint32_t fallback);

/// What prepare_surface changed.
struct SurfacePreparation {
  uint64_t split_vertices = 0;  ///< split_pinched_vertices' copies
  uint64_t flipped_faces = 0;   ///< orient_consistently's flips
};

/// split_pinched_vertices, then orient_consistently: what coarsen_mesh (`meshcvt coarsen`) does to
/// its input before clustering it, so that the coarse mesh of a surface that is a manifold but for
/// pinched vertices and the orientation of its triangles comes out a valid manifold
/// (approximate_shape only orients: its output's vertices are the input's). Same inputs and
/// outputs as those two.
SurfacePreparation prepare_surface(Mesh& mesh, Topology& topology);

/// Summary printed by `meshcvt info`. Counts are those of Topology; lengths and areas are in the
/// input's units.
struct MeshInfo {
  uint64_t vertices = 0;  ///< referenced vertices
  uint64_t faces = 0, edges = 0;
  uint32_t components = 0;
  uint64_t boundary_edges = 0, boundary_loops = 0;
  uint64_t nonmanifold_edges = 0, nonmanifold_vertices = 0;
  uint64_t degenerate_faces = 0, duplicate_faces = 0;
  int64_t euler_characteristic = 0;  ///< chi = V - E + F over referenced vertices
  /// Genus, total over components. Defined when the mesh is an orientable 2-manifold, possibly with
  /// boundary: no non-manifold edge or vertex, no collapsed face, no non-orientable component.
  /// Then each component i has chi_i = 2 - 2 g_i - b_i, so the sum is
  ///   genus = (2 C - chi - B) / 2      (C components, B boundary loops),
  /// which for one closed surface is the usual (2 - chi) / 2 and for one surface with boundary
  /// (2 - chi - B) / 2. -1 when not defined.
  int64_t genus = -1;
  float bbox_min[3] = {0, 0, 0}, bbox_max[3] = {0, 0, 0};  ///< over referenced vertices; zeros if none
  double total_area = 0;  ///< sum of triangle areas in double, in squared input units

  // ---- extensions
  uint64_t orientation_flips = 0;         ///< Topology::orientation_flips
  uint32_t nonorientable_components = 0;  ///< Topology::nonorientable_components
  uint64_t collapsed_faces = 0;           ///< Topology::collapsed_faces
};

/// Fills MeshInfo from a mesh and the topology build_topology(mesh) returned. O(F + V).
MeshInfo mesh_info(const Mesh& mesh, const Topology& topology);

}  // namespace meshcvt
