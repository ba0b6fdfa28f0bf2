// meshcvt: uniform coarsening (Fan et al., Section 6.1): a face clustering of a triangle mesh
// becomes a coarse triangle mesh with one vertex per cluster, the dual of the clustering.
//
// Step 1 (vertex_placement.cpp): one point per cluster, see VertexPlacement.
// Step 2 (coarsen.cpp): every mesh vertex where three or more clusters meet gives the polygon of
// those clusters in the cyclic order of its face fan; a triangle for three, the max-min-angle
// triangulation for more. On the mesh boundary a vertex where two or more clusters meet gives its
// open fan's polygon closed by the boundary, so boundary loops of the input stay boundary loops.
//
// What would make the output non-manifold is reported as DualDefect records naming clusters, so a
// caller can fix the clustering (split a cluster and iterate again); a mesh is produced regardless.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

/// Where the coarse vertex of a cluster goes. Every choice uses the cluster's mass centroid
/// c_i = sum_k w_k g_k / sum_k w_k over its faces k, with g_k the face centroid and
/// w_k = rho_k * area_k (rho_k the optional face weight, 1 when absent).
enum class VertexPlacement {
  /// The mesh vertex of the cluster closest to c_i (the paper's choice, after Valette & Chassery).
  /// Only vertices whose faces all lie in the cluster compete, so no two clusters share a vertex.
  /// A cluster without such a vertex (a few faces) takes the closest corner of its faces that no
  /// lower-numbered cluster of that kind took (the closest corner if all are taken).
  closest,
  /// The closest point of the whole mesh surface to c_i (the CCVT generator, the paper's eq. 6).
  projected,
  /// The point minimizing the sum of w_k * squared distance to the planes of the cluster's faces
  /// (Garland-Heckbert quadrics). Directions the quadric does not constrain (eigenvalues below
  /// 1e-3 of the largest) are left at c_i, so a flat cluster gives c_i and a corner gives the
  /// corner. Clamped toward c_i so it stays inside the cluster's bounding box grown by 10% of its
  /// diagonal.
  qem,
};

struct CoarsenOptions {
  VertexPlacement placement = VertexPlacement::closest;
  /// 1: everything on the calling thread. Otherwise two independent passes run side by side on
  /// meshes of 50k faces or more, and `projected` builds and queries its BVH on this many threads
  /// (0: every core). The result does not depend on it.
  unsigned threads = 0;
};

/// Something in a clustering that makes its dual mesh non-manifold or degenerate. `cluster`,
/// `other` and `third` name the clusters involved (kNone where unused), smallest first except where
/// a kind says otherwise.
struct DualDefect {
  enum Kind : uint8_t {
    /// `cluster` is not one topological disk: not edge-connected, Euler characteristic V-E+F of its
    /// faces != 1 (an annulus, a handle, a whole closed component), or its faces touch each other
    /// at a vertex only (pinched). Its coarse vertex cannot be a manifold vertex.
    cluster_not_disk,
    /// `cluster` meets the mesh boundary in two or more arcs (on one loop or on several).
    boundary_arcs,
    /// `cluster` and `other` share two or more separate borders: their coarse edge would be the
    /// edge of four or more triangles.
    double_border,
    /// The triangle (cluster, other, third) comes out twice with opposite orientations (e.g. three
    /// clusters covering a sphere); both copies are kept. Same-orientation copies are merged
    /// silently (counted in CoarsenResult::merged_triangles).
    duplicate_triangle,
    /// The coarse edge (cluster, other) belongs to three or more triangles.
    nonmanifold_output,
    /// The coarse edge (cluster, other) is used twice in the same direction: the two triangles
    /// disagree on orientation.
    inconsistent_orientation,
    /// The input boundary passes from `cluster` to `other` (in that order along the loop) but no
    /// triangle has the edge between them: their border runs from boundary to boundary, so the
    /// output boundary cannot follow the input loop there.
    missing_boundary_edge,
    /// The triangle (cluster, other, third), in output order, has (almost) zero area: its vertices
    /// coincide or are collinear (sine of its smallest angle below 1e-9).
    degenerate_triangle,
    /// `cluster` has no face; its coarse vertex is (0, 0, 0) and unused.
    empty_cluster,
  };
  Kind kind = cluster_not_disk;
  uint32_t cluster = kNone;
  uint32_t other = kNone;
  uint32_t third = kNone;

  friend bool operator==(const DualDefect&, const DualDefect&) = default;
};

struct CoarsenResult {
  /// The coarse mesh: vertex i is cluster i (clusters vertices, some possibly unused), triangles
  /// oriented as the input. source_polygon is empty.
  Mesh mesh;
  /// Sorted by kind, then cluster ids; each distinct record once. Empty for a clean dual.
  std::vector<DualDefect> defects;
  uint64_t corner_vertices = 0;        ///< mesh vertices (fans) that gave a polygon of >= 3 clusters
  uint64_t polygons_triangulated = 0;  ///< polygons of >= 4 clusters split by max-min-angle
  uint64_t merged_triangles = 0;       ///< same-orientation duplicate triangles dropped
  uint64_t boundary_edges = 0;         ///< edges of the coarse mesh with one triangle
};

/// Builds the dual mesh of a face clustering.
///
/// mesh         : the input triangle mesh.
/// topology     : build_topology(mesh).
/// labels       : cluster id in [0, clusters) per face (mesh.face_count() entries).
/// clusters     : number of clusters n; the output has n vertices.
/// options      : vertex placement.
/// face_weights : optional density rho_k per face (face_count entries, finite, >= 0), weighting the
///                mass centroid and the quadrics; nullptr or empty means 1 everywhere.
/// Returns the coarse mesh, its defects and counts. Throws OptionError when the sizes disagree, a
/// label is >= clusters, or a weight is negative or not finite. O(F + V) time apart from the
/// `projected` placement, which builds a triangle BVH (O(F log F)).
CoarsenResult coarsen_clustering(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                 uint32_t clusters, const CoarsenOptions& options = {},
                                 const std::vector<float>* face_weights = nullptr);

/// The defects coarsen_clustering would report for the same inputs (the identical list). Meant for
/// a loop that fixes the clustering until this is empty. It costs about as much as
/// coarsen_clustering (the triangles are built to check them; the mesh is not kept), which is
/// linear and small next to clustering; with VertexPlacement::projected it includes the BVH build.
std::vector<DualDefect> find_dual_defects(const Mesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& labels, uint32_t clusters,
                                          const CoarsenOptions& options = {},
                                          const std::vector<float>* face_weights = nullptr);

/// Step 1 alone: the coarse vertex of every cluster, 3 floats (x, y, z, input units) per cluster;
/// (0, 0, 0) for a cluster with no face. The same points coarsen_clustering uses. Inputs and
/// errors as coarsen_clustering.
std::vector<float> place_cluster_vertices(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                          VertexPlacement placement,
                                          const std::vector<float>* face_weights = nullptr);

/// Mass centroids c_i (3 floats per cluster, input units; (0, 0, 0) for an empty cluster), as used
/// by every placement. A cluster whose faces all have zero weight gets the plain mean of its face
/// centroids.
std::vector<float> cluster_mass_centroids(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                          const std::vector<float>* face_weights = nullptr);

/// Parses "closest", "projected", "qem"; throws OptionError naming the accepted values.
VertexPlacement parse_vertex_placement(const std::string& s);
const char* to_string(VertexPlacement p);
/// "cluster_not_disk", "boundary_arcs", ... (the enumerator's name).
const char* to_string(DualDefect::Kind k);

}  // namespace meshcvt
