// meshcvt: triangle quality (the columns of Table 1 in Fan et al.) and the distance between two
// surfaces (symmetric Hausdorff and RMS), to judge a coarsened mesh against its original.
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Shape of the triangles of a mesh, computed in double.
///
/// Angles are in degrees. Q is Frey and Borouchaki's shape measure,
///   Q = (6 / sqrt(3)) * area / (semi_perimeter * longest_edge),
/// 1 for an equilateral triangle, 0 for a degenerate one (defined as 0 when every edge has length 0).
/// Degenerate triangles count as measured: collinear corners give angles (0, 0, 180), a repeated
/// corner gives 0 at every corner.
struct TriangleQuality {
  uint64_t faces = 0;                ///< triangles measured
  uint64_t referenced_vertices = 0;  ///< vertices used by at least one face
  double min_angle_deg = 0;          ///< smallest corner angle over all triangles ("min ∠")
  double max_angle_deg = 0;          ///< largest corner angle over all triangles
  double avg_min_angle_deg = 0;      ///< mean over triangles of each triangle's smallest angle ("Ave. min ∠")
  uint64_t angles_below_30 = 0;      ///< corners with angle < 30 degrees ("∠ < 30°"), out of 3 * faces
  double q_min = 0;                  ///< smallest Q ("Qmin")
  double q_avg = 0;                  ///< mean Q over triangles ("Qave")
  uint64_t degenerate_faces = 0;     ///< triangles of zero area (Q = 0) as computed in double
  double total_area = 0;             ///< sum of triangle areas, input units squared
  /// valence_histogram[k]: referenced vertices with k distinct neighbours (joined by an edge).
  /// Size = largest valence + 1 (empty for a mesh with no face).
  std::vector<uint64_t> valence_histogram;
  /// Same, counting only interior vertices: every edge at the vertex is shared by exactly two faces.
  /// For a closed manifold surface the two histograms agree; on a regular triangulation interior
  /// vertices have valence 6.
  std::vector<uint64_t> interior_valence_histogram;
};

/// Measures the triangles of `mesh`. All zeros (empty histograms) for a mesh with no face.
/// Indices must be < vertex_count (as read_mesh guarantees). O(F) time plus small per-vertex sorts.
TriangleQuality triangle_quality(const Mesh& mesh);

/// Distance between two surfaces, in the input's units and relative to the reference's bounding
/// box diagonal. "a -> b" is the distance from points of a to the surface b.
struct ApproximationError {
  double hausdorff = 0;      ///< max(a_to_b_max, b_to_a_max): symmetric Hausdorff distance (sampled)
  double rms = 0;            ///< sqrt of the mean squared distance over the samples of both sides
  double hausdorff_rel = 0;  ///< hausdorff / diagonal (0 when the diagonal is 0)
  double rms_rel = 0;        ///< rms / diagonal
  double a_to_b_max = 0;     ///< largest distance from a point of a to ref (over samples and vertices)
  double b_to_a_max = 0;     ///< largest distance from a point of ref to a
  double a_to_b_rms = 0;     ///< RMS distance a -> ref (over the area-uniform samples)
  double b_to_a_rms = 0;     ///< RMS distance ref -> a
  double a_to_b_mean = 0;    ///< mean distance a -> ref (over the area-uniform samples)
  double b_to_a_mean = 0;    ///< mean distance ref -> a
  double diagonal = 0;       ///< bounding-box diagonal of the reference, input units
  uint64_t samples = 0;      ///< area-uniform samples per surface
  uint64_t points = 0;       ///< points measured in all: the samples of both sides plus every vertex of both
};

/// Default number of area-uniform samples per surface for approximation_error: the larger face
/// count of the two meshes, at least 100,000 and at most 1,000,000. The time grows linearly with
/// the samples while the sampled RMS settles in the third or fourth digit (bench/RESULTS.md).
uint64_t default_error_samples(const Mesh& a, const Mesh& ref);

/// Symmetric surface distance between `a` and the reference `ref`.
///
/// `samples_per_mesh` points (0: default_error_samples) are drawn area-uniformly on each surface
/// (jittered stratified sampling along the cumulative area, fixed seed: the same inputs give the
/// same numbers on every run and for any thread count); every vertex of each mesh is measured as
/// well, since the largest deviations often sit at corners. Each point's distance to the other
/// surface is exact (closest point on the nearest triangle, through a BVH), not to sample points.
/// Hausdorff: the largest of all those distances. RMS and mean: over the area-uniform samples only
/// (vertices would weigh an area integral towards fine regions).
/// threads: 0 = every core. seed: picks the sample positions.
/// Throws OptionError when either mesh has no face or zero total area.
ApproximationError approximation_error(const Mesh& a, const Mesh& ref, uint64_t samples_per_mesh = 0,
                                       unsigned threads = 0, uint64_t seed = 1);

}  // namespace meshcvt
