// meshcvt: anisotropic shape approximation with the L2,1 metric (Fan et al., Sections 4 and 6.2,
// after Cohen-Steiner, Alliez, Desbrun, "Variational Shape Approximation", SIGGRAPH 2004).
//
// An L2,1 partition of the faces into regions R_i, each with a proxy plane (area-weighted centroid
// X_i, unit proxy normal N_i), becomes a compact mesh:
//
//  1. Partition: cluster() with Metric::l21, either with a fixed number of proxies or error-driven
//     (proxies are added by splitting the regions of highest distortion until E / area <= bound),
//     improved by VSA's proxy teleportation.
//  2. Anchors: mesh vertices shared by 3 or more regions, or on the mesh boundary where the region
//     changes; positioned at the mean of the vertex's projections onto its regions' proxy planes.
//  3. Edge extraction and chord subdivision: the borders between regions, cut at anchors, are the
//     chords; a chord gets a new anchor at its farthest vertex while d * sin(N_i, N_j) / |ab| is
//     above the chord error.
//  4. Triangulation: mesh vertices are colored by the closest anchor (along the border for border
//     vertices, by Dijkstra distance inside the regions); every input triangle with three colors
//     gives an output triangle. A region whose coloring is not a valid triangulation of its anchor
//     polygon is triangulated directly.
//
// Everything that would leave a hole, a flat component or a flipped triangle (regions that are not
// disks, closed components with fewer than 4 regions, borders without anchors, duplicate chords,
// chords crossing in a region's plane, regions too curved for one polygon) is fixed by splitting
// regions, adding anchors or putting anchors back on their mesh vertex, and each fix is reported
// (MeshingFix). For a closed manifold input the output is a closed oriented manifold with the same
// components; boundary loops of the input stay boundary loops.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

/// When a chord (a border between two anchors a and b) is split at its farthest vertex.
enum class ChordRule {
  /// Fan et al. 6.2: split while d * sin(N_i, N_j) / |ab| > chord_error, with d the largest
  /// distance of the chord's mesh vertices to the segment ab and N_i, N_j the proxy normals on its
  /// two sides (sin = 1 on the mesh boundary). Unitless: a flat border (N_i = N_j) is never split,
  /// a sharp one is split until it deviates from its segment by less than chord_error * |ab|.
  paper,
  /// CGAL's Variational_shape_approximation default (relative_to_chord = false,
  /// with_dihedral_angle = false): split while d / (mean edge length of the input) > chord_error.
  /// CGAL's default value is 5. For comparison with CGAL only.
  cgal,
};

/// Anchors added to one region by flip_anchor fixes in one meshing pass, at most (chords crossing in
/// the proxy plane are split up to this many times; a polygon that is simple there but still has no
/// unflipped triangulation gets only a few, then the region is split: split_curved).
inline constexpr uint32_t kMaxFlipAnchors = 32;

/// Meshing passes at most: a pass whose regions still give flipped triangles splits them
/// (MeshingFix::split_curved) and is followed by another. On the libcgal-demo meshes at 10
/// proxies nearly all end with none within 30 passes (bench/RESULTS.md, thirty-fifth session).
inline constexpr uint32_t kMaxSplitPasses = 32;

/// Default chord error for ChordRule::paper. Chosen on fandisk with 32 proxies so that the output
/// is at least as close to the input (Hausdorff and RMS distance) as with CGAL's default rule
/// (ChordRule::cgal, 5.0); see bench/RESULTS.md, "Shape approximation (L2,1)".
inline constexpr double kDefaultChordError = 0.3;

/// How a partition is turned into a mesh.
struct MeshingOptions {
  double chord_error = kDefaultChordError;  ///< threshold of chord_rule (unitless), >= 0
  ChordRule chord_rule = ChordRule::paper;
};

/// Options of approximate_shape. Exactly one of `proxies` (> 0) and `max_error` (>= 0) is given.
struct ApproximateOptions {
  /// Fixed number of proxies n (1 <= n <= faces, n >= mesh components); 0 to use max_error.
  uint32_t proxies = 0;
  /// Error-driven: add proxies until the L2,1 distortion per area E / A <= max_error. Negative: not
  /// used. E / A is in [0, 4] (|n_k - N_i|^2 <= 4) and scale-free; 0 is met at the latest with one
  /// region per face.
  double max_error = -1;
  MeshingOptions meshing;
  /// VSA proxy teleportation after clustering (and after every error-driven round): merge the
  /// adjacent pair of regions that costs least, split the region of highest distortion, iterate
  /// again, and keep the result only if the distortion dropped (repeated while it pays). Fixes the
  /// local minima a greedy initialization leaves on CAD parts (two proxies on one plane while
  /// another proxy straddles a sharp edge). Runs on the CPU engine.
  bool teleport = true;
  /// Clustering engine for the partition ("auto", "cpu", "gpu", "gpu:N"; empty: $MESHCVT_DEVICE,
  /// else auto), as ClusterOptions::device. With max_error it runs the first partition; the rounds
  /// that add proxies run on the CPU engine.
  std::string device;
  unsigned threads = 0;             ///< CPU worker threads, 0 = every core (the result does not depend on it)
  uint32_t max_iterations = 1000;   ///< per round of boundary testing, as ClusterOptions::max_iterations
  /// Called between iterations of the partition (from the calling thread). May be empty.
  std::function<void(const ClusterProgress&)> progress;
};

/// One fix applied while meshing. Region ids are those of ShapeApproximation::labels; `vertex` is an
/// input vertex id. Unused fields are kNone (ids) or 0 (count).
struct MeshingFix {
  enum Kind : uint8_t {
    /// `region` was not a topological disk (an annulus, a handle, a whole closed component, pinched
    /// at a vertex): it was regrown as a disk and its other faces became `count` new regions.
    split_region,
    /// The closed border between `region` and `other` (kNone: the mesh boundary) had no anchor:
    /// `count` anchors were added, evenly spaced along it (3 for a border with no anchor, 1 at the
    /// farthest vertex for a border that met a single anchor).
    loop_anchors,
    /// `region` had fewer than 3 anchors: one was added at `vertex` on its most curved chord.
    polygon_anchor,
    /// Two chords joined the same two anchors (they would give one output edge shared by 4
    /// triangles): the chord between `region` and `other` got an anchor at `vertex`.
    duplicate_chord,
    /// The Dijkstra coloring of `region` did not give a valid, unflipped triangulation of its anchor
    /// polygon (or used an edge that exists elsewhere); the polygon was triangulated directly
    /// (fewest bad triangles, then max-min-angle, by dynamic programming).
    fallback_triangulation,
    /// `region`'s polygon, with its anchors at the mean of their projections, has no triangulation
    /// without flipped triangles (projections onto a neighbour's plane can fold a thin region):
    /// its `count` anchors were put back at their mesh vertices and the meshing done again.
    anchor_position,
    /// `region`'s polygon has no triangulation without flipped triangles or edges used elsewhere: an
    /// anchor was added at `vertex` (on a chord that cuts across the region in its proxy plane, else
    /// on the chord farthest from its segment) and the meshing done again (at most kMaxFlipAnchors
    /// per region).
    flip_anchor,
    /// Unresolved after every fix of a meshing pass: `count` triangles of `region` face away from its
    /// proxy normal (or are slivers), or reuse an edge of another region. Such a region is split
    /// (split_curved) and the meshing done again, until no region has any, or no such region can
    /// be split (a region of one face), or after kMaxSplitPasses passes; the last pass's records
    /// stay in the result (earlier passes' meshing records are replaced by the next pass's).
    flipped_triangles,
    /// `region` was too curved for one polygon (its triangulation kept flipped triangles): it was
    /// split in two by its normals (seeds: its two most different face normals), the new half being
    /// region `other`, and the whole meshing done again.
    split_curved,
    /// `region` has no area (only collapsed or zero-area faces) or no border that can be traced (a
    /// non-manifold configuration): it gives no output face.
    skipped_region,
    /// The closed mesh component of `region` was covered by fewer than 4 regions, whose output would
    /// be flat (two regions: two copies of one triangle): `region`, its largest, was split in two by
    /// its normals (the new half is region `other`), until the component has 4.
    solid_component,
  };
  Kind kind = split_region;
  uint32_t region = kNone;
  uint32_t other = kNone;
  uint32_t vertex = kNone;
  uint32_t count = 0;

  friend bool operator==(const MeshingFix&, const MeshingFix&) = default;
};

/// Counts describing a meshing (its last pass when regions were split: MeshingFix::split_curved).
struct MeshingStats {
  uint32_t corner_anchors = 0;        ///< vertices of >= 3 regions, or of >= 2 regions on the mesh boundary
  uint32_t chord_anchors = 0;         ///< added by chord subdivision (the chord-error rule)
  uint32_t fix_anchors = 0;           ///< added by fixes (loop_anchors, polygon_anchor, duplicate_chord, flip_anchor)
  uint32_t chords = 0;                ///< borders between consecutive anchors, each counted once
  uint32_t coloring_regions = 0;      ///< regions triangulated by the Dijkstra coloring
  uint32_t fallback_regions = 0;      ///< regions triangulated directly (fallback_triangulation)
  uint32_t meshing_rounds = 0;        ///< 1 + rounds redone after anchor_position / flip_anchor fixes
  uint32_t reused_triangulations = 0; ///< direct triangulations kept from an earlier round (same polygon and positions)
  /// direct triangulations of regions out of fixes left out of a round's first try (made in the
  /// second try when the round is kept; a round that is redone never makes them)
  uint32_t deferred_triangulations = 0;
  /// polygons found to have no acceptable triangulation without making one (their region then took
  /// a fix)
  uint32_t tested_polygons = 0;
  /// regions whose first coloring in a pass after a split_curved one was copied from the pass
  /// before (same faces, interior and border seeds)
  uint32_t copied_colorings = 0;
  /// meshing passes: 1 + those after a split of curved regions (MeshingFix::split_curved)
  uint32_t meshing_passes = 0;
  /// passes that stopped once they found curved regions to split, before making every region's
  /// triangles (their meshes are dropped: the next pass meshes the split partition)
  uint32_t shortened_passes = 0;
  uint32_t vertex_anchors = 0;        ///< anchors placed at their mesh vertex (anchor_position)
  uint64_t flipped_triangles = 0;     ///< output triangles facing away from their proxy normal (0 unless reported)
  uint64_t boundary_edges = 0;        ///< output edges with one triangle
  uint64_t nonmanifold_edges = 0;     ///< output edges with three or more triangles
  uint64_t inconsistent_edges = 0;    ///< output edges whose two triangles run along them the same way
};

/// Error-driven partition: one entry per round.
struct RefinementRound {
  uint32_t proxies = 0;         ///< regions in the partition of this round
  double relative_error = 0;    ///< its E / A
};

struct ShapeApproximation {
  /// The triangle mesh. Vertex i is the anchor at input vertex anchor_vertices[i] (input units);
  /// triangles are oriented as the input. source_polygon is empty.
  Mesh mesh;
  std::vector<uint32_t> triangle_regions;  ///< region id of each output triangle
  std::vector<uint32_t> anchor_vertices;   ///< input vertex of each output vertex, increasing
  /// The polygon mesh, one polygon per region (its anchors in border order, oriented as the input;
  /// indices into mesh.positions), as CSR: polygon r is
  /// polygon_vertices[polygon_offsets[r] .. polygon_offsets[r+1]). Skipped regions have none.
  std::vector<uint32_t> polygon_offsets;
  std::vector<uint32_t> polygon_vertices;

  /// Final partition: region id per input face, in [0, regions). Regions split by fixes get new
  /// ids after the partition's.
  std::vector<uint32_t> labels;
  uint32_t regions = 0;
  std::vector<float> proxy_normals;    ///< 3 per region: unit N_i ((0,0,0) for a region of no area)
  std::vector<float> proxy_centroids;  ///< 3 per region: X_i, area-weighted centroid, input units

  /// L2,1 distortion of the final partition, E = sum_k |n_k - N_i|^2 |T_k| over input faces (in
  /// squared input units), the total area A, and E / A (scale-free; what max_error bounds).
  double distortion = 0;
  double total_area = 0;
  double relative_error = 0;

  std::vector<MeshingFix> fixes;  ///< in the order they were applied
  MeshingStats stats;
  /// approximate_shape only: faces flipped so that every orientable component is consistently
  /// oriented (orient_consistently) before anything else; the output follows the flipped faces.
  uint64_t reoriented_faces = 0;
  /// approximate_shape only: faces with a repeated corner index (no area, no edges), left out of
  /// the partition and the meshing; in `labels` (and clustering.labels) they take the region of a
  /// face at one of their corners (labels_with_collapsed_faces, topology.h).
  uint64_t collapsed_faces = 0;

  /// The clustering (empty for mesh_partition). After teleports or error-driven rounds, `labels` /
  /// `generators` are those of the end result and `history` goes on over every teleport and round:
  /// each starts a new IterationRecord::round number after the previous one's (teleports that did
  /// not lower the distortion are undone and left out). `timings` are cluster()'s alone.
  Clustering clustering;
  uint32_t requested_proxies = 0;        ///< -n, or 0 with max_error
  uint32_t partition_proxies = 0;        ///< regions of the partition before fixes
  std::vector<RefinementRound> rounds;   ///< error-driven rounds (empty with a fixed count)
  /// Wall-clock seconds: the whole partition (clustering, teleports, error-driven rounds), the part
  /// of it after cluster() (teleports and rounds, CPU engine), and the meshing.
  double partition_seconds = 0, refine_seconds = 0, meshing_seconds = 0;
};

/// Partitions `mesh` with the L2,1 metric and meshes the partition (the whole pipeline). A mesh
/// whose orientable components are not consistently oriented is oriented first, on a copy
/// (orient_consistently; reoriented_faces).
///
/// mesh     : triangle mesh; topology : build_topology(mesh).
/// options  : proxies or max_error (exactly one), meshing options, device, threads.
/// Returns the approximation. Throws OptionError when neither or both of proxies / max_error are
/// given, max_error or chord_error is negative or not finite, or the clustering rejects the count
/// (0, more than faces, fewer than components); DeviceError as cluster().
ShapeApproximation approximate_shape(const Mesh& mesh, const Topology& topology, const ApproximateOptions& options);

/// Same, building the topology.
ShapeApproximation approximate_shape(const Mesh& mesh, const ApproximateOptions& options);

/// Meshing alone (steps 2-4) for a given partition: any labels in [0, regions) (regions need not be
/// connected or disks: that is fixed and reported). O(F log F) for the coloring, plus O(m^3) for
/// each anchor polygon of m corners triangulated directly. Throws OptionError when labels.size() differs
/// from the face count, a label is >= regions, or the chord error is negative or not finite.
/// `clustering`, `requested_proxies` and `rounds` of the result are left empty. The coloring runs on
/// every core (the result does not depend on the thread count).
ShapeApproximation mesh_partition(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                  uint32_t regions, const MeshingOptions& options = {});

namespace detail {
/// mesh_partition with every region colored from scratch, and its crossing chords tested again,
/// in every meshing round. mesh_partition colors a region again only from the border vertices
/// whose (distance, color) decreased, and keeps a region's crossing test while its polygon stays
/// the same; both must give the same results, and the tests compare the two. Same inputs,
/// outputs and errors.
ShapeApproximation mesh_partition_from_scratch(const Mesh& mesh, const Topology& topology,
                                               const std::vector<uint32_t>& labels, uint32_t regions,
                                               const MeshingOptions& options = {});

/// The meshing's split of a region too curved for one polygon (split_by_normals in
/// approximate.cpp), for tests: each region listed in `split` that has two faces or more (faces
/// with a repeated corner aside) is split in two connected halves by its faces' normals. The first
/// half keeps the region's label, the second gets the next new label (`regions`, `regions` + 1, ...
/// in the order of the region ids). Returns the new region count. Throws OptionError as
/// mesh_partition does for bad labels, and for a listed region >= regions.
uint32_t split_regions_by_normals(const Mesh& mesh, const Topology& topology, std::vector<uint32_t>& labels,
                                  uint32_t regions, const std::vector<uint32_t>& split);
}  // namespace detail

/// L2,1 distortion E = sum_k |n_k - N_i|^2 |T_k| of a labeling (N_i: normalized area-weighted mean
/// normal of region i), in double, squared input units. `total_area` (optional) receives A.
double l21_distortion(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t regions,
                      double* total_area = nullptr);

/// Writes a polygon mesh (faces of any size >= 3) as OBJ or OFF, by the extension of `path`
/// (any case): positions 3 floats per vertex; polygon p is vertices[offsets[p] .. offsets[p+1]),
/// empty polygons are skipped; `origin` is added to every position as it is written (as
/// WriteOptions::origin in write_mesh). Written to a temporary file and renamed (no partial file on
/// failure). Throws FileError for another extension or an I/O failure, OptionError for indices out
/// of range or polygons of 1 or 2 vertices.
void write_polygon_mesh(const std::string& path, const std::vector<float>& positions,
                        const std::vector<uint32_t>& offsets, const std::vector<uint32_t>& vertices,
                        const std::array<double, 3>& origin = {0, 0, 0});

/// "paper" / "cgal"; parse_chord_rule throws OptionError naming the accepted values.
ChordRule parse_chord_rule(const std::string& s);
const char* to_string(ChordRule r);
/// "split_region", "loop_anchors", ... (the enumerator's name).
const char* to_string(MeshingFix::Kind k);

}  // namespace meshcvt
