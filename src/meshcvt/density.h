// meshcvt: curvature-adaptive density for clustering and coarsening (ACVD's "gradation"): a
// per-face density rho that is larger where the surface bends, so a CVT puts smaller clusters (and
// a coarse mesh shorter edges) there and larger ones on flat parts.
#pragma once

#include <vector>

#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

/// Default bound on max(rho) / min(rho) (see curvature_density): at most an area ratio of 16 and an
/// edge-length ratio of 4 between the smallest and the largest clusters of an optimal CVT, so a
/// sharp crease (whose estimated curvature grows without bound as its faces shrink) cannot shrink
/// its clusters to slivers of a face or two. ACVD bounds its density at 100 x the mean.
inline constexpr double kDefaultMaxDensityRatio = 256;

/// Per-face density rho_k >= 1 from the surface's curvature, for ClusterOptions::density and the
/// face weights of coarsen_clustering.
///
/// mesh      : the triangle mesh (any connectivity; boundaries, non-manifold edges, collapsed and
///             zero-area faces are allowed).
/// topology  : build_topology(mesh) (only its vertex -> faces CSR is used).
/// gradation : g >= 0, finite. 0 gives exactly 1 for every face; larger g adapts more.
/// max_ratio : in [1, 1e30]: bound on max(rho) / min(rho).
///
/// Returns face_count() floats, the smallest exactly 1:
///     rho_k = min(((1 + c_k) / (1 + c_min))^g, max_ratio),
/// where c_k >= 0 is the face's curvedness sqrt((k1^2 + k2^2) / 2) (principal curvatures k1, k2,
/// in 1 / input units) times the bounding-box diagonal of the referenced vertices, so it has no
/// unit and does not change when the mesh is scaled: a sphere gives c = diagonal / radius (about
/// 3.46 for a whole sphere), a cylinder diagonal / (sqrt(2) radius), a plane 0. c is averaged over
/// the faces within four vertex rings (area-weighted, in four passes), so one noisy face cannot
/// make a tiny cluster and the density changes no faster than clusters can follow.
/// A face where the curvature cannot be estimated (zero area, a sliver) takes its neighbours'
/// value, or 0 when none has one. A flat mesh, or one whose faces are all degenerate, gives all
/// ones. Sharp creases count as curved: their c grows with the input's resolution near the crease
/// (about the dihedral angle over the face size), which is what max_ratio bounds.
///
/// What g means: an optimal CVT with density rho has, asymptotically, cells of one shape whose
/// energy (about rho * area^2 times a shape constant) is the same everywhere: with n cells, the
/// energy per unit area, rho * area, is smallest subject to integral(1 / area) = n exactly when
/// rho * area^2 is constant (Gersho's conjecture; Du, Faber, Gunzburger, SIAM Review 1999). So
///     cluster area            ~ rho^(-1/2) = ((1 + c) / (1 + c_min))^(-g/2),
///     coarse-mesh edge length ~ rho^(-1/4) = ((1 + c) / (1 + c_min))^(-g/4),
/// not area ~ 1 / rho. Where c >> 1, g = 2 makes edges ~ curvature^(-1/2), which equalizes the
/// error of a linear interpolant (curvature * edge^2 / 8) over the surface; g = 1 is milder.
/// Radii of curvature larger than the diagonal (c < 1) count as nearly flat. The clustering engine
/// reaches only part of this optimum (its moves are local); bench/RESULTS.md, "Coarsening:
/// gradation and subdivision", has the measurements.
///
/// Throws OptionError when g is negative or not finite, max_ratio is not in [1, 1e30], a face
/// uses a vertex that does not exist, or mesh and topology do not match. O(F + V) time, about 16
/// bytes per vertex and 8 per face besides the result, one thread per core (up to 16) on large
/// meshes (the result does not depend on it).
std::vector<float> curvature_density(const Mesh& mesh, const Topology& topology, double gradation,
                                     double max_ratio = kDefaultMaxDensityRatio);

/// Per-face scale-free curvedness c_k (see curvature_density), after the four-ring smoothing.
/// Same inputs and errors as curvature_density (without the mapping). Exposed for measurements
/// and tests: curvature_density(mesh, topology, g) maps it as above.
std::vector<float> face_curvedness(const Mesh& mesh, const Topology& topology);

}  // namespace meshcvt
