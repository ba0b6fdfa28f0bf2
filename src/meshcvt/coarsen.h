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
// coarsen_mesh (coarsen_mesh.cpp) does the whole job: clusters per component, clustering, a loop
// that fixes the clustering until it has no defect, the dual.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

/// Where the coarse vertex of a cluster goes. Every choice uses the cluster's mass centroid
/// c_i = sum_k w_k g_k / sum_k w_k over its faces k, with g_k the face centroid and
/// w_k = rho_k * area_k (rho_k the optional face weight, 1 when absent).
enum class VertexPlacement {
  /// The mesh vertex of the cluster closest to c_i (the paper's choice, after Valette & Chassery;
  /// vertices of the output are vertices of the input).
  /// Only vertices whose faces all lie in the cluster compete, so no two clusters share a vertex.
  /// A cluster without such a vertex (a few faces) takes the closest corner of its faces that no
  /// lower-numbered cluster of that kind took (the closest corner if all are taken).
  closest,
  /// The closest point of the cluster's own faces to c_i: the CCVT generator (the paper's eq. 6)
  /// restricted to the cluster, which on a surface is the closest point of the mesh unless another
  /// part of it passes nearer. Exact point-triangle distances, one per face, O(F).
  projected,
  /// The point minimizing the sum of w_k * squared distance to the planes of the cluster's faces
  /// (Garland-Heckbert quadrics), plus 0.3 / 3 of the planes of the other clusters' faces at each
  /// of its border vertices (a crease along the border then pulls the point onto it). Directions the
  /// quadric does not constrain (eigenvalues below 1e-3 of the largest) are left at c_i, so a flat
  /// cluster gives c_i and a corner gives the corner. A point that would leave the cluster's
  /// bounding box grown by 10% of its diagonal drops its weakest direction while that is below 0.1
  /// of the largest eigenvalue (a cluster around a tapered tube: the minimizer is the cone's apex),
  /// then is clamped toward c_i to stay inside that box. A point within 1% of that diagonal of
  /// another cluster's, or a corner of a flat dual triangle, keeps its own planes only. The corners
  /// of a triangle that faces against the same triangle on the `projected` points (the qem points
  /// turned it over) move toward their projected points: half, a quarter, then all the way, until
  /// no triangle is turned over. Then CoarsenOptions::fit_passes, the same unfolding again for the
  /// triangles its edge swaps made, CoarsenOptions::fit_min_angle_deg, and the slivers' flips
  /// (CoarsenOptions::flip_edges).
  qem,
};

struct CoarsenOptions {
  /// Default `projected`, chosen from bench/RESULTS.md ("Table 1"): on bunny00, fandisk,
  /// refined_elephant, a 131k sphere and the 1.2M/4.8M bunny its smallest angle is 2.6-11 degrees
  /// larger than `closest`'s, Q avg higher on every mesh, RMS error equal or lower, Hausdorff within 6%.
  VertexPlacement placement = VertexPlacement::projected;
  /// 1: everything on the calling thread. Otherwise two independent halves of the work run side by
  /// side on meshes of 4096 faces or more, the vertex placement spread over the remaining cores on
  /// large meshes (0: every core). The result does not depend on it.
  unsigned threads = 0;
  /// After building the dual: flip the shared edge of two adjacent, nearly coplanar triangles (normals
  /// within `flip_max_dihedral_deg`; for `closest` and `projected` also a sliver's pair where the
  /// flip barely moves the surface) whenever that raises the smaller of their minimum angles (see
  /// flip_coarse_edges). Vertices, topology and orientation are kept. Only when the dual has no defect.
  /// With `qem`, also the slivers' flips alone (no dihedral allowance) after the fitting: caps of
  /// three points in a row on a crease, which no move widens.
  bool flip_edges = true;
  double flip_max_dihedral_deg = 25;
  /// After the flips: passes of relax_coarse_vertices (0 = off), then the flips again. Moves
  /// vertices over their own cluster's faces where that improves their triangles. Default 3,
  /// chosen from bench/RESULTS.md ("Relaxing the coarse vertices", sixth session): it lifted
  /// fandisk -> 1000 from 26.9 to 33.4 degrees (Q avg 0.835 -> 0.887) and the elephant from 29.5 to
  /// 35.3 degrees with Hausdorff and RMS distance unchanged, at about 15% of the clustering time on
  /// the bunnies. Measured again in the twenty-third session: fandisk 27.1 -> 33.8 degrees, Q avg
  /// 0.839 -> 0.888 (the README's figures).
  /// Only when the dual has no defect.
  uint32_t relax_passes = 3;
  /// relax_coarse_vertices' limit (degrees) on how far a moved vertex may turn an incident
  /// triangle's normal.
  double relax_max_normal_turn_deg = 20;
  /// `qem` placement only, last: passes fitting the coarse mesh to the input (0 = off), the
  /// distance minimization of Hoppe et al. 1993 with the vertex count fixed (coarse_fit.cpp).
  /// About 64 sample points of the input per coarse vertex, each owned by its closest coarse
  /// triangle. A pass moves every vertex by the mean, weighted by area and barycentric share, of
  /// its samples' offsets from their closest points (a quadric point alone sits at the tangent
  /// planes of a curved cluster and leaves the triangles between such points below the surface),
  /// then, with `fit_swaps`, swaps the diagonal of two triangles where the other one lies closer to
  /// their samples by at least 30% (creases the clusters do not follow; the direction the surface
  /// bends least). Default 3, from bench/RESULTS.md (fourteenth session): with the swaps, RMS
  /// distance 27-46% below the quadric points alone on the Table 1 meshes (without them 19-46%).
  /// Only when the dual has no defect.
  uint32_t fit_passes = 3;
  /// The edge swaps of the fitting (above). They make triangles thinner where they follow a
  /// crease or the surface's flatter direction: off, the fitting only moves vertices.
  bool fit_swaps = true;
  /// Degrees, in [0, 60]: a swap may not take its pair's smallest angle below min(its old value,
  /// this), unless it removes at least 90% of the pair's squared distance (an edge laid along a
  /// sharp crease): then min(its old value, this, 10). 30 by default since the sixteenth session;
  /// 10, the floor before it, gives lower distances and many more thin triangles (bench/RESULTS.md,
  /// "meshcvt against ACVD": bunny00 -> 500 RMS 0.138 against 0.159 % of the diagonal with 178
  /// angles below 30 against 27; fandisk -> 1000 0.0202 against 0.0219 with 537 against 13).
  double fit_swap_min_angle_deg = 30;
  /// Degrees, in [0, 60]; 0 = off. Last, for `qem`: each corner of a triangle whose smallest angle
  /// is below this moves toward its cluster's projected point (7/8, 3/4, 1/2, 1/4 of the way from
  /// there, or onto it), as little as lifts its triangles' smallest angle to this, or else as far
  /// as lifts it most; only where it rises, no triangle turns over and the squared distance from
  /// the corners of its and its neighbours' clusters to their triangles stays within 1.1x of what
  /// it was when the pass first came to the vertex, so the mesh's smallest angle never drops and
  /// points held by a crease stay on it; where its triangles make a crease it may instead step
  /// along it (1/8 to 1/2 of its mean edge) if that adds no angle below 30 degrees.
  /// Default 20, from bench/RESULTS.md (seventeenth session): qem's smallest angle on the Table 1
  /// meshes rose from 2.4-12.3 degrees to 19.4-20.3 (the sphere's 45.1 unchanged), RMS distance
  /// at most 0.5% higher.
  double fit_min_angle_deg = 20;
  /// `qem` only: where three clusters' points lie on one line (or coincide) even with only their
  /// own faces' planes, as along the straight creases of a mesh midpoint-subdivided before the
  /// clustering, those clusters take their `projected` points (on the surface) instead, so that
  /// the triangle has an area. Off: the triangle is reported (DualDefect::degenerate_triangle),
  /// and the relax, flips and fitting skip the whole mesh. coarsen_mesh turns it off while it
  /// fixes the clustering (its rounds, and the start from single faces of a small component, may
  /// find one whose points are apart: the cube of tests/test_coarsen.cpp, whose corners they
  /// keep) and uses it for its last dual; with it, such triangles alone do not make coarsen_mesh
  /// cluster a component again at 2n, 4n, ... clusters.
  bool degenerate_to_surface = true;
  /// Open surfaces, after the relax: the vertex of each cluster that meets a boundary loop of the
  /// input in one arc goes onto that loop (coarse_boundary.cpp): onto the sharpest corner of the
  /// loop on its arc where there is one (a turn of 45 degrees or more over a quarter of a coarse
  /// edge on each side; a corner shared by two clusters' arcs goes to one of them), else onto the
  /// arc's point closest to the placement's point, then slides along its arc where that improves
  /// its triangles. Not for a loop whose arcs are on average shorter than 0.7 of their clusters'
  /// coarse edges (a hole smaller than the triangles around it), nor where a triangle would fold.
  /// Then two more relax passes (at most relax_passes), and a vertex left with a triangle below
  /// 30 degrees goes back toward its placed point (corners stay). All of it is undone when the
  /// coarse mesh's smallest angle ends below min(its value before, 30 degrees) or more of its
  /// angles are below 30 degrees (the report's columns; CoarsenResult::boundary_left_inside).
  /// Without it the coarse boundary runs inside the input's by about a third of a coarse edge and
  /// cuts its corners. Measured (bench/open_sweep.sh, bench/RESULTS.md) over 84 coarsenings of the
  /// 34 open libcgal-demo meshes: Hausdorff distance 10% or more lower in 50 (median ratio 0.74, at
  /// worst 1.03x), RMS distance in 47 (median 0.86, at worst 1.08x), angles below 30 degrees 660 ->
  /// 561 in all, mean Q avg 0.839 -> 0.830 (the boundary's triangles are taller: the clusters along
  /// it are cut by it, and their neighbours stay over their own faces). Only when the dual has no
  /// defect.
  bool boundary_onto_input = true;
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
    /// The input boundary passes from `cluster` to `other` (in that order along the loop) but the
    /// edge between them is not an edge of exactly one triangle: none has it (their border runs
    /// from boundary to boundary), or two do (the two clusters alone along a hole, which the
    /// output closes over). Either way the output boundary cannot follow the input loop there.
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
  uint64_t flipped_edges = 0;          ///< edges flipped to improve triangles (CoarsenOptions::flip_edges)
  uint64_t relaxed_moves = 0;          ///< vertex moves kept by relax_coarse_vertices (one vertex may move in several passes)
  uint64_t fitted_moves = 0;           ///< vertex moves of the fitting passes (CoarsenOptions::fit_passes, qem only)
  uint64_t swapped_edges = 0;          ///< edges swapped by the fitting (CoarsenOptions::fit_swaps, qem only)
  /// qem only: vertices moved toward their projected points because their qem points turned a
  /// triangle over (see VertexPlacement::qem), before relaxing and again after the fitting (a
  /// vertex moved both times counts twice).
  uint64_t unfolded_vertices = 0;
  /// qem only: vertex moves toward the projected points that lifted thin triangles
  /// (CoarsenOptions::fit_min_angle_deg).
  uint64_t angle_floor_moves = 0;
  /// qem only: clusters given their projected points because their triangle had no area even with
  /// their own planes (CoarsenOptions::degenerate_to_surface).
  uint64_t surface_points = 0;
  /// CoarsenOptions::boundary_onto_input: vertices put onto the input's boundary, of them onto a
  /// corner of a boundary loop, and of them moved back part of the way (or all of it) toward
  /// their placed points for their triangles' sake. boundary_left_inside: the vertices it had put
  /// onto the boundary when all of it was undone (the mesh's angles; see there), else 0.
  uint64_t boundary_vertices_moved = 0;
  uint64_t boundary_corners = 0;
  uint64_t boundary_backed_off = 0;
  uint64_t boundary_left_inside = 0;
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
/// label is >= clusters, or a weight is negative or not finite. O(F + V) time, plus the edge flips
/// (a few linear passes over the coarse mesh's edges).
CoarsenResult coarsen_clustering(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                 uint32_t clusters, const CoarsenOptions& options = {},
                                 const std::vector<float>* face_weights = nullptr);

/// The defects coarsen_clustering would report for the same inputs (the identical list). Meant for
/// a loop that fixes the clustering until this is empty. It costs about as much as
/// coarsen_clustering (the triangles are built to check them; the mesh is not kept), which is
/// linear and small next to clustering.
std::vector<DualDefect> find_dual_defects(const Mesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& labels, uint32_t clusters,
                                          const CoarsenOptions& options = {},
                                          const std::vector<float>* face_weights = nullptr);

/// Improves a triangle mesh by edge flips (src/coarse_flips.cpp): the edge shared by triangles
/// (u, v, c) and (v, u, d) becomes (c, d) when both are oriented consistently, (c, d) is not an
/// edge yet, u and v keep >= 3 edges (2 on a boundary), the triangles' normals are within
/// max_dihedral_deg degrees (creases are not cut) or, with `flat_slivers`, the pair holds a
/// triangle with an angle below 5 degrees and the tetrahedron (u, v, c, d) the flip sweeps is
/// thinner than 5% of |cd| (a sliver's normal says nothing; such a flip barely moves the
/// surface), the new triangles face the same side, and the smaller minimum angle of the pair
/// strictly grows. Passes over all edges (in sorted order: deterministic) until none flips, at
/// most max_passes. Vertices, Euler characteristic, boundaries and orientation are unchanged;
/// edges with one or more than two triangles are never flipped. Returns the number of flips.
/// O(E) per pass.
uint64_t flip_coarse_edges(Mesh& mesh, double max_dihedral_deg = 25, uint32_t max_passes = 8,
                           bool flat_slivers = true);

/// Moves the vertices of a coarse mesh over the faces of their own clusters to improve its
/// triangles (src/coarse_relax.cpp, where the rules are explained): tangential relaxation toward
/// the mean of each vertex's neighbours, restricted to the directions its ring's normals leave
/// free (the tangent plane where the ring is flat, the crease line on a crease, none at a corner),
/// the stepped point taken to a point of the vertex's own cluster's faces (full, half or quarter
/// step). A move is kept only when no incident triangle's normal turns by more than
/// max_normal_turn_deg degrees, the smallest incident angle stays >= min(its old value, 35 deg),
/// and either it or the sum of the incident qualities Q (quality.h) grows. A vertex of a triangle
/// below 33 deg may also step across a feature when that raises its smallest angle and keeps its
/// cluster's corners within 1.5x of their old largest squared distance to its triangles. So the
/// mesh's smallest angle never drops below min(its old value, 35 deg). A vertex off its cluster's
/// faces (a qem point placed off the surface) keeps its offset: it steps, by the same rules and not
/// onto the faces, only along the free directions of its own cluster's normal tensor (plane,
/// crease line, none at a corner), and only while its cluster's corners (24 of them at most) stay
/// within 1.2x (1.5x at a triangle below 33 deg) of their old largest squared distance to its
/// triangles. Vertices on a boundary or
/// at a non-manifold edge stay. Passes visit the vertices whose ring moved in the previous pass,
/// in classes of vertices that share no triangle (a greedy coloring in vertex order,
/// deterministic), until none moves, at most `passes`.
///
/// coarse   : the coarse mesh, vertex i standing for cluster i (as coarsen_clustering builds it);
///            positions (input units) are changed in place, triangles are not.
/// mesh     : the input mesh the clusters are made of.
/// topology : build_topology(mesh) (face adjacency for walking over a cluster).
/// labels   : cluster per face of `mesh`, each below coarse.vertex_count().
/// passes   : passes at most (0: nothing moves). max_normal_turn_deg: in [0, 180] degrees.
/// Returns the number of moves kept. A moved vertex that lay on its cluster's faces lies on them
/// (to float rounding). Vertex count, topology and orientation are unchanged. Throws OptionError
/// when the sizes disagree or an index is out of range. Time O(passes x vertices x a few walk
/// steps) plus O(F) for the rescue's rare cluster scans and the floating vertices' clusters.
/// threads: 0 = one per core; vertices that share no triangle move side by side, in classes (a
/// greedy coloring), so the result does not depend on it.
uint64_t relax_coarse_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                               const std::vector<uint32_t>& labels, uint32_t passes = 3,
                               double max_normal_turn_deg = 20, unsigned threads = 0);

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

// ---- The whole job: clusters per component, clustering, fixing the clustering, the dual mesh
// (src/coarsen_mesh.cpp).

/// How the clusters of a coarsening are shared among the connected components of the face graph
/// (Topology::face_component numbering), so that every component can come out as a valid surface.
struct ComponentAllocation {
  std::vector<uint32_t> clusters;  ///< per component; adds up to n
  /// Per component: the fewest vertices any triangulation of that surface has (so no clustering
  /// with fewer clusters can give a valid dual). Closed manifold component with Euler
  /// characteristic chi: Heawood's bound, the least V >= 4 with V^2 - 7V + 6 chi >= 0 (4 for a
  /// sphere, 7 for a torus), 10 for the orientable genus-2 surface, 8 for the Klein bottle, 9 for
  /// the non-orientable chi = -1 surface (Jungerman-Ringel, Ringel). Manifold component with b >= 1
  /// boundary loops: max(3 b, closed(chi + b) - b): every boundary loop needs 3 vertices of its own,
  /// and coning each loop off with one new vertex must give a valid closed triangulation (3 for a
  /// disk, 6 for an annulus). A component that is not a manifold (non-manifold vertices): 4 if
  /// closed, 3 with boundary (nothing is guaranteed for it).
  std::vector<uint32_t> minimum;
  std::vector<uint32_t> faces;                 ///< per component
  std::vector<int64_t> euler_characteristic;   ///< per component, V - E + F
  std::vector<uint64_t> boundary_loops;        ///< per component
  std::vector<uint8_t> manifold;               ///< per component: orientable or not, no non-manifold vertex/edge
};

/// The components of `mesh` as allocate_component_clusters sees them: per component its faces,
/// Euler characteristic, boundary loops, whether it is a manifold, and the fewest clusters it can
/// come out with as a valid surface (`minimum`); `clusters` is left empty. A component with fewer
/// faces than its minimum cannot be coarsened until it is refined (coarsen_surface subdivides
/// such components). mesh, topology: the mesh and build_topology(mesh). Throws OptionError when
/// the topology is not the mesh's. O(F + V).
ComponentAllocation describe_components(const Mesh& mesh, const Topology& topology);

/// Shares n clusters among the components of `mesh` in proportion to their areas (integral of
/// sqrt(rho) dA when a per-face density rho is given: the point density of a CVT with density rho in
/// 2D), never below a component's minimum (see ComponentAllocation) nor above its face count;
/// largest remainders round, ties to the lower component. Deterministic.
///
/// mesh, topology : the input and build_topology(mesh).
/// n              : clusters in all.
/// density        : optional rho per face (face_count entries, finite, > 0); nullptr or empty: 1.
/// Throws OptionError when n is below the sum of the minimums (the message gives both numbers and
/// the components' needs), when a component has fewer faces than its minimum (subdivide the mesh
/// first), when n exceeds the face count, or when the density is malformed. O(F + V).
ComponentAllocation allocate_component_clusters(const Mesh& mesh, const Topology& topology, uint32_t n,
                                                const std::vector<float>* density = nullptr);

/// One change the fix loop of coarsen_mesh made to the clustering (cluster ids as in that round's
/// labels).
struct CoarsenFix {
  enum Action : uint8_t {
    /// `cluster` is cut in pieces; for each piece beyond the first, the adjacent pair
    /// (`merged_into`, `freed`) of the same mesh component is merged (`freed` joining
    /// `merged_into`) and the piece takes the id `freed`, so the count stays n. One record per
    /// extra piece.
    cut,
    /// `faces` faces of `cluster` that separate the two borders of a double border move to the
    /// adjacent cluster `other`.
    move_faces,
  };
  Action action = cut;
  DualDefect defect;              ///< the defect this fix addresses, as found at the start of its round
  uint32_t cluster = kNone;       ///< cut: the cluster cut; move_faces: the cluster giving the faces
  uint32_t other = kNone;         ///< move_faces: the cluster receiving them
  uint32_t merged_into = kNone;   ///< cut
  uint32_t freed = kNone;         ///< cut
  uint32_t faces = 0;             ///< move_faces
  uint32_t round = 0;             ///< fix round, from 1
  uint32_t clusters = 0;          ///< clusters of the clustering it was made on (n, or refined_clusters)
};

/// "cut", "move_faces".
const char* to_string(CoarsenFix::Action a);

struct CoarsenMeshOptions {
  /// clusters = n (the coarse mesh's vertices), metric (cvt or ccvt), init, device, threads,
  /// density, progress... component_clusters and initial_labels must be left empty (set here).
  ClusterOptions cluster;
  CoarsenOptions coarsen;
  /// Fix rounds at most per attempt (each attempt: rounds until no defect, see coarsen_mesh);
  /// 0 = no fixing at all, the defects are reported as coarsen_clustering does.
  uint32_t max_fix_rounds = 12;
  /// Step 4 of coarsen_mesh: how many clusters, in all, the broken components rebuilt from single
  /// faces may be merged down from (smallest components first; a component that would pass the
  /// limit and those after it are not). From every face, that is the components' faces; from a
  /// finer clustering, its clusters there plus the faces made single around its defects, so a
  /// large component with few defects can still be rebuilt that way. The merging's cost grows
  /// faster than what it merges: polygon_mesh's 32k faces take about 1.5 s.
  uint64_t max_face_start_faces = 65536;
  /// Step 4's work budget: faces checked (each candidate merge's two clusters) per face of the
  /// components merged down, per merging. Where it is spent the merging stops, and the components
  /// it was merging stay as they were. At 512 no libcgal-demo output changes (one merging there
  /// checked at most 77 per face); without it, a subdivided tetrahedron of 16k faces rebuilt
  /// toward its 4 clusters took 78 s.
  uint64_t merge_budget_per_face = 512;
};

struct CoarsenMeshResult {
  /// The clustering the coarse mesh is the dual of. Its iteration record (history, iterations,
  /// converged) is that of the cluster() call that produced it; when the labels come from fix
  /// rounds without a later iteration, a call with max_iterations = 0 (generators, repair as a
  /// safety net), so iterations is 0 and converged false.
  Clustering clustering;
  CoarsenResult coarse;    ///< the coarse mesh; coarse.defects are the defects that remain (empty when fixed)
  ComponentAllocation allocation;
  std::vector<CoarsenFix> fixes;     ///< every fix of the attempts kept, in order
  uint32_t fix_rounds = 0;           ///< rounds run, all attempts together (CoarsenFix::round <= this)
  size_t initial_defects = 0;        ///< defects of the first clustering
  uint32_t fix_iterations = 0;       ///< boundary-test iterations run after the first clustering, all together
  /// When the fixes at n could not clean the clustering: the larger count at which a valid
  /// clustering was made and then merged back to n (merged_back merges); 0 when not used.
  uint32_t refined_clusters = 0;
  uint32_t merged_back = 0;
  /// Components (at most max_face_start_faces in all, smallest first) still broken after that,
  /// rebuilt from single faces merged down to their count (their merges are counted in
  /// merged_back); face_start_from_finer of them from the finer clustering that left them the
  /// fewest defects, with only its clusters in a defect and their neighbours cut into single faces.
  uint32_t face_start_components = 0;
  uint32_t face_start_from_finer = 0;
  size_t abandoned_fixes = 0;        ///< fixes made on attempts that were not kept (not in `fixes`)
  /// Times the whole job was done again with more clusters for the components of several that
  /// stayed broken (each doubled, at most a cluster per 4 faces, taken from the others by their
  /// shares), each time leaving fewer defects; `allocation` is the last one. 0: the first kept.
  uint32_t reallocations = 0;
  /// Defects are left (coarse.defects): no attempt removed them all; `clustering` is then the one
  /// with the fewest defects.
  bool defects_remain = false;
  /// Before anything else (prepare_surface): copies of pinched vertices made
  /// (split_pinched_vertices), and faces flipped so that every orientable component is
  /// consistently oriented (orient_consistently); the coarse mesh follows the flipped faces.
  uint64_t split_vertices = 0;
  uint64_t reoriented_faces = 0;
  /// Faces with a repeated corner index (no area, no edges), left out of the clustering and the
  /// coarse mesh; in `clustering` they take the cluster of a face sharing a corner (cluster 0
  /// where none does). `allocation` is then that of the mesh without them (each collapsed face
  /// is a component of its own in build_topology's count, and is not one there).
  uint64_t collapsed_faces = 0;
  double cluster_seconds = 0;  ///< the first cluster() call
  double fix_seconds = 0;      ///< defect searches, fixes and the fix rounds' cluster() calls (0 when the
                               ///< first coarse mesh had no defect: building it was the search)
  double coarsen_seconds = 0;  ///< the final coarsen_clustering
};

/// Coarsens `mesh` to exactly n = options.cluster.clusters vertices (Fan et al. 6.1) and makes the
/// clustering valid first, so that its dual is a manifold like the input:
///  0. faces with a repeated corner (collapsed_faces) are left out, and a mesh with pinched
///     vertices or whose orientable components are not consistently oriented is prepared first,
///     on a copy (prepare_surface: split_vertices, reoriented_faces), so that a surface that is a
///     manifold but for those counts as one below;
///  1. allocate_component_clusters shares n among the components (OptionError when n is too small);
///  2. cluster() with those counts per component (on a single-component mesh: exactly the plain
///     cluster() result);
///  3. fix rounds while find_dual_defects finds any, on the labels (no iteration in between):
///     a double border that a third cluster's face splits in two loses that face to one of the
///     two; otherwise the cluster a defect names (the non-disk one, the one meeting the boundary in
///     two arcs, the heavier of a pair, the one of a duplicated triangle with fewest neighbours) is
///     cut into 2 pieces, or 3 for a ring around a handle, each a connected disk meeting the
///     boundary in one arc and every neighbour in one border; for each extra piece the adjacent
///     pair of the same component whose merge raises the CVT energy least
///     (W_a W_b / (W_a + W_b) |c_a - c_b|^2) and gives a fit cluster is merged, preferring clusters
///     in no defect. Once valid, cluster() iterates again from the fixed labels
///     (TopologyMode::preserving, same counts per component) to smooth them; defects it brings back
///     are fixed by more rounds, else the smoothing is redone in steps that keep the dual valid;
///  4. components of manifold surfaces still broken: a valid clustering at 2n, 4n, ... 32n (at
///     least 4 faces per cluster; not where the broken components hold under 1% of the faces,
///     each such clustering being of the whole mesh) is merged back to n by merges that keep the dual valid (the link
///     condition of an edge contraction, and every corner of four or more clusters keeping a
///     triangulation without an edge used twice) and replaces them; where greedy merging stops
///     above n (near the fewest vertices the surface allows), a dual edge flip (a strip of faces
///     along a border handed to the cluster at its end) opens a merge again; then components
///     still broken, smallest first while what they merge from stays within max_face_start_faces,
///     are rebuilt from single faces merged down the same way: first only around their defects in
///     the finer clustering that left them the fewest (its clusters in a defect and their
///     neighbours cut into single faces, the others kept), and where that does not remove
///     defects, every face. The merging has a work budget (merge_budget_per_face
///     faces checked per face merged): where it is spent, the components stay as they were. Fix
///     rounds that come back to labels they had before stop (a cycle);
///  5. coarsen_clustering of the clustering with the fewest defects;
///  6. on a mesh of several components, those of manifold surfaces still broken get twice their
///     clusters (at most one per 4 faces; the others give them up by their shares) and 1-5 run
///     again, up to 3 times while that leaves fewer defects (reallocations).
/// Degenerate triangles (geometry, not topology) are not fixed.
///
/// Inputs: mesh, topology = build_topology(mesh), options (see CoarsenMeshOptions). Outputs: see
/// CoarsenMeshResult; coordinates in the input's units, times in seconds.
/// Guarantees: exactly n clusters and n output vertices, each component holding its allocated
/// count; when defects_remain is false the dual has no DualDefect, which for a manifold input means
/// a manifold output with the input's Euler characteristic and boundary loops, every component kept
/// and every one of the n vertices used. Not guaranteed: that the loop succeeds (defects_remain
/// says so; measured failures: a small part at or near its minimum count, surfaces with holes or
/// tunnels much smaller than a cluster); the quality of clusters that were fixed and could not be
/// smoothed afterwards.
/// Deterministic for any thread count. Throws what allocate_component_clusters and cluster() throw,
/// and OptionError when options.cluster.component_clusters or initial_labels are set.
CoarsenMeshResult coarsen_mesh(const Mesh& mesh, const Topology& topology, const CoarsenMeshOptions& options);

/// Faces per cluster the input should have before it is clustered for a placement: the
/// min_faces_per_cluster that `meshcvt coarsen --subdivide auto` passes to subdivision_levels_for
/// (meshcvt/subdivide.h); for `qem` also what the command does without --subdivide.
///   closest, projected: 10.
///   qem: 20, ACVD's rule (its -s 10: subdivide until the input has 10 vertices per cluster; a closed
///        triangle mesh has twice as many faces as vertices), so qem and ACVDQ see the same input.
///        Below it the clusters are a dozen faces each, their borders and lent planes too coarse
///        for the creases: fandisk -> 1000 (13 faces per cluster, one level), RMS distance 0.0225 ->
///        0.0201 % of the diagonal, angles below 30 degrees 698 -> 501; on smooth meshes at 10-20
///        faces per cluster (bunny00 -> 4000, the elephant -> 4500) the distance stays within 3%.
double subdivision_faces_per_cluster(VertexPlacement placement);
/// Whether `meshcvt coarsen` subdivides by subdivision_faces_per_cluster when no --subdivide is
/// given: `qem` only (the other placements keep the input as given).
bool subdivides_by_default(VertexPlacement placement);

/// Parses "closest", "projected", "qem"; throws OptionError naming the accepted values.
VertexPlacement parse_vertex_placement(const std::string& s);
const char* to_string(VertexPlacement p);
/// "cluster_not_disk", "boundary_arcs", ... (the enumerator's name).
const char* to_string(DualDefect::Kind k);

/// CoarsenSurfaceOptions::subdivide: the placement's default (subdivides_by_default: `auto` for
/// qem, no subdivision for the others), or `auto` (subdivision_levels_for with the placement's
/// subdivision_faces_per_cluster); 0..6 are levels.
inline constexpr int kSubdivideByPlacement = -2;
inline constexpr int kSubdivideAuto = -1;
/// CoarsenSurfaceOptions::split_edges: split at 1 / kAutoSplitEdgesRatio of the coarse edge length
/// where at least one edge per cluster is longer than that length or the input has fewer than
/// kAutoSplitFacesPerCluster faces per cluster (and at least one), else not at all; and, where
/// the split keeps defects, leave the components that have them as given, or all of it, when that
/// leaves fewer defects (see coarsen_surface). The ratio was chosen by sweeps over
/// libcgal-demo's meshes (bench/RESULTS.md, "Coarsening: long faces": 0.5 and 0.7 gave part of
/// the gain, 2 and 3 refine more for less).
inline constexpr double kSplitEdgesAuto = -1;
inline constexpr double kAutoSplitEdgesRatio = 1.5;
/// kSplitEdgesAuto splits an input with fewer faces than this per cluster whatever its edges:
/// clusters of one to four faces cannot be round, and the edge count alone misses inputs whose
/// edges are just below the coarse edge length (libcgal-demo's pinion -> faces / 1.5: 0.66 long
/// edges per cluster, Q avg 0.495 and 1252 angles below 30 degrees as given, 0.870 and none
/// split). Measured on the 128 libcgal-demo meshes up to 20k faces that auto did not split
/// (bench/RESULTS.md, "Coarsening: long faces", forty-first session): at faces / 1.5 Q avg 0.648
/// -> 0.884 on average, at faces / 2.5 0.789 -> 0.888, at faces / 4 0.847 -> 0.871 (angles
/// below 30 degrees 641 -> 115), at faces / 6 only 0.858 -> 0.871, with two meshes worse.
inline constexpr double kAutoSplitFacesPerCluster = 5;
/// kSplitEdgesAuto leaves the long edges as they are where splitting them would make more than this
/// many faces per cluster or per input face (split_long_edges_min_faces, and the split itself stops
/// at that budget: see split_long_edges' max_faces), and an explicit ratio is refused there
/// (OptionError): where the faces are slivers with long edges and almost no area,
/// the coarse edge length follows from that area and the split would go on for millions of faces
/// (7 faces of libcgal-demo's degtri_sliding, welded: more than 24 GB). The largest growth
/// measured on clean libcgal-demo meshes is 42 (pipe -> 213; pinion -> faces / 1.5, split for
/// having fewer than kAutoSplitFacesPerCluster faces per cluster: 31.5), far below it
/// (bench/RESULTS.md, "Coarsening: long faces").
inline constexpr double kAutoSplitMaxGrowth = 1000;

/// The whole of `meshcvt coarsen` between reading and writing: what it does to the input before
/// coarsen_mesh, and coarsen_mesh.
struct CoarsenSurfaceOptions {
  /// The job. job.cluster.clusters = n; job.cluster.density may hold a per-face density of the
  /// input as given (face_count entries, > 0), carried to the faces made of each face; it must
  /// be empty when gradation > 0, which makes one.
  CoarsenMeshOptions job;
  /// Curvature-adaptive density (curvature_density of the input's own faces, after
  /// prepare_surface): 0 = uniform. Finite, >= 0.
  double gradation = 0;
  /// kSubdivideByPlacement, kSubdivideAuto, or 0..6 midpoint subdivision levels (subdivide_midpoint).
  int subdivide = kSubdivideByPlacement;
  /// kSplitEdgesAuto, 0 = never, or R in (0, 16]: split_long_edges at 1/R of the coarse edge length
  /// (coarse_edge_length of the surface and n, at each face's density where there is one, so the
  /// limit is smaller where clusters are) whatever the count of long edges.
  double split_edges = kSplitEdgesAuto;
  /// Count the edges longer than the coarse edge length when split_edges is 0 too (two passes
  /// over the faces; 0.03-0.1 s on 4.8M faces); they are always counted otherwise.
  bool count_long_edges = true;
  /// Where defects remain and subdivide is kSubdivideByPlacement: coarsen the surface as given
  /// (without a long-edge split) subdivided once too, and keep it if it has fewer defects.
  bool retry_subdivided = true;
  /// The retry runs only where the surface subdivided once has at most this many faces (four
  /// times the surface's): a job there costs several times the first one.
  uint64_t max_retry_faces = uint64_t(1) << 20;
  /// Subdivide (subdivide_faces) each component with fewer faces than the clusters it needs to
  /// come out as a valid surface (describe_components' minimum: 3 for a lone triangle), until it
  /// has enough, instead of refusing the mesh (as coarsen_mesh does when this is false). A face
  /// of another component on one of its edges (a non-manifold edge) is split at that edge's
  /// midpoint with it (subdivide_faces' split_neighbours), so the surface gets no T-junction and
  /// the rest of that component is left as it is.
  bool refine_small_components = true;
  /// Fill CoarsenSurfaceResult::surface_origin (what input_face_clusters needs): a face index per
  /// surface face, carried through every step (4.8M faces: about 40 MB more at the peak and 0.04 s).
  bool keep_surface_origin = false;
};

/// One of the jobs coarsen_surface ran when the first coarse mesh kept defects.
struct CoarsenSurfaceJob {
  enum Surface : uint8_t {
    split,         ///< every long edge split
    partly_split,  ///< split but for the components where the split surface had defects
    as_given,      ///< nothing split
    subdivided,    ///< the surface as given (the kept one where that job did not run), subdivided once
  };
  Surface surface = split;
  size_t faces = 0;            ///< of its surface (as clustered)
  size_t initial_defects = 0;  ///< of its first coarse mesh, before the fix loop
  size_t defects = 0;          ///< of its coarse mesh
  double seconds = 0;  ///< locality order, clustering, fixes, coarse mesh
  bool kept = false;
};

struct CoarsenSurfaceResult {
  /// The surface that was clustered and coarsened: the input without its collapsed faces,
  /// subdivided, split, prepared (prepare_surface), in locality order (reorder_for_locality) and
  /// with its too small components subdivided (refined_components);
  /// job.clustering.labels are per face of it, and it is what the coarse mesh approximates.
  Mesh surface;
  Topology topology;        ///< build_topology(surface)
  /// With CoarsenSurfaceOptions::keep_surface_origin (else empty): per face of `surface`, the face
  /// of the mesh given to coarsen_surface that it is, or lies in (a subdivided or split face's
  /// pieces name it). Faces with a repeated corner have none.
  std::vector<uint32_t> surface_origin;
  size_t given_faces = 0;   ///< faces of the mesh given (collapsed ones included)
  CoarsenMeshResult job;    ///< coarsen_mesh's result; job.coarse.mesh is the coarse mesh
  uint64_t collapsed_faces = 0;      ///< faces with a repeated corner left out first
  size_t input_faces = 0;            ///< faces of the input without them
  unsigned subdivision_levels = 0;
  size_t subdivided_faces = 0;       ///< faces after the subdivision (input_faces x 4^levels)
  /// prepare_surface's changes, and the faces of the mesh it changed: the input before the
  /// subdivision when gradation > 0 (the density needs consistent normals), the surface otherwise.
  SurfacePreparation prepared;
  size_t prepared_faces = 0;
  /// The coarse edge length where the density is 1 (coarse_edge_length), and the edges longer than
  /// it where they are (at their face's density) in the subdivided mesh (0 when not counted).
  double coarse_edge_length = 0;
  uint64_t long_edges = 0;
  double split_ratio = 0;            ///< R the surface was split at (0: not split)
  uint64_t split_edges = 0;          ///< edges split in the surface (0: not split)
  /// kSplitEdgesAuto found long edges but left them (kAutoSplitMaxGrowth): at least this many faces
  /// would have come out (split_long_edges_min_faces, or the faces of the split's round that went
  /// past the budget). 0 when it did not.
  double split_refused_faces = 0;
  /// The jobs run when the first coarse mesh kept defects, in order: the first (split or as
  /// given); with kSplitEdgesAuto the partly split one (when only some components had defects) and
  /// the one as given (when defects remained); then the subdivided one (retry_subdivided). Each is
  /// kept only if it has fewer defects than the best before it. Empty when one job ran.
  std::vector<CoarsenSurfaceJob> jobs;
  /// The job kept is the subdivided retry: `surface` is the surface as given (without a split;
  /// the kept one where the job as given did not run) subdivided once (subdivision_levels and
  /// subdivided_faces still describe the subdivision asked for).
  bool retried_subdivided = false;
  /// Components of the kept job's surface subdivided because they had fewer faces than the
  /// clusters they need (CoarsenSurfaceOptions::refine_small_components); other components with
  /// faces split at an edge they share with one (a fin on a scan's edge: the scan's two faces on
  /// that edge); the faces subdivided or split, counted before.
  uint32_t refined_components = 0;
  uint32_t refined_with_them = 0;
  uint64_t refined_faces = 0;
  /// The job kept is the partly split one: components of the input left unsplit (split_edges
  /// counts the edges split in the others).
  uint32_t unsplit_components = 0;
  /// The job kept is the one as given (split_ratio and split_edges are then 0).
  bool split_discarded = false;
  /// The fewest defects among the jobs not kept (-1 when one job ran), and their time together.
  int64_t discarded_job_defects = -1;
  double discarded_seconds = 0;
  /// Subdivision, density, splitting and locality order, in seconds (the job's own times are in
  /// job).
  double prepare_seconds = 0;
  /// The kept job's topology (build_topology), prepare_surface and the refinement of too small
  /// components, in seconds.
  double topology_seconds = 0;
};

/// Coarsens a mesh as `meshcvt coarsen` does, to exactly n = options.job.cluster.clusters vertices:
///  1. faces with a repeated corner are left out (remove_collapsed_faces);
///  2. with a gradation, prepare_surface and curvature_density on the input's own faces;
///  3. subdivide_midpoint by options.subdivide (each face's density goes to its children);
///  4. split_long_edges by options.split_edges;
///  5. reorder_for_locality, build_topology, prepare_surface, the components too small for their
///     clusters subdivided (refine_small_components), then coarsen_mesh;
///  6. with kSplitEdgesAuto, where the split surface's coarse mesh keeps defects, step 5 again on
///     the mesh split but for the components that had them, then (defects remaining) on the unsplit
///     mesh; the result with the fewest defects is kept (ties: the more split one; see jobs);
///  7. where defects remain and no subdivision was asked for, step 5 on the surface as given
///     (without a split) subdivided once, kept if it has fewer (retry_subdivided).
/// What coarsen_mesh alone does not: subdivision, splitting long edges, the locality order (the
/// output depends on the input's face order only through it).
///
/// Inputs: mesh (any triangle mesh, e.g. read_mesh's; taken by value, moved in where the caller
///         has no further use), options (see CoarsenSurfaceOptions). Outputs: see
///         CoarsenSurfaceResult; lengths in the input's units, times in seconds.
/// Guarantees: those of coarsen_mesh, on the result's surface. Deterministic for any thread count.
/// Throws OptionError on options out of range (gradation, subdivide, split_edges, a density of the
/// wrong size or with a gradation), when n is larger than the faces and nothing subdivides, and
/// when a component too small for its clusters still has parts too small once subdivided (faces
/// on the same corners come apart at non-manifold edges); Error when every face is collapsed; and
/// what coarsen_mesh, subdivide_midpoint and split_long_edges throw.
CoarsenSurfaceResult coarsen_surface(Mesh mesh, const CoarsenSurfaceOptions& options);

/// The coarse vertex (= cluster) of every face of the mesh given to coarsen_surface: what a caller
/// needs to carry per-face data from the input to the coarse mesh, or to see which input faces
/// make each coarse vertex.
///
/// given  : the mesh given to coarsen_surface (as given: before anything it did).
/// result : coarsen_surface(given, options)'s result, with options.keep_surface_origin set.
/// Returns given.face_count() cluster ids, each below n. A face that was clustered as it is takes
/// its cluster; a face that was subdivided or split takes the cluster holding the largest area of
/// its pieces (ties: the lower id); a face with a repeated corner (left out) takes the cluster of
/// the lowest kept face at its lowest corner that has one (labels_with_collapsed_faces), or 0.
/// Throws OptionError when `given` does not have result.given_faces faces or the result has no
/// surface_origin. O(F log F) where faces were split, O(F) otherwise.
std::vector<uint32_t> input_face_clusters(const Mesh& given, const CoarsenSurfaceResult& result);

/// "split", "partly_split", "as_given", "subdivided".
const char* to_string(CoarsenSurfaceJob::Surface s);

}  // namespace meshcvt
