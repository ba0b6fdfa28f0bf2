// meshcvt: midpoint subdivision (1 triangle -> 4), used to refine meshes that have too few faces for
// the requested clusters and to make big benchmark meshes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// Splits every triangle into four at its edge midpoints, `levels` times.
///
/// Input : mesh (any connectivity: boundaries, non-manifold edges and collapsed faces are kept as
///         they are); levels >= 0, 0 returns a copy.
/// Output: a mesh with F * 4^levels faces. Each undirected edge {a, b} gets one new vertex at
///         0.5 a + 0.5 b (float, in the input's units) shared by every face on that edge, so a
///         watertight mesh stays watertight and the Euler characteristic is unchanged; the edge
///         (a, a) of a collapsed face uses a itself. Original vertices keep their ids, new ones
///         follow in order of (lower, higher) endpoint. At each level face f becomes faces
///         4f .. 4f+3: (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca), all oriented as f, so
///         the children of input face f are [f * 4^levels, (f + 1) * 4^levels).
///         source_polygon[i] is the input's source polygon of the face that i came from (the
///         input face id when the input's source_polygon is empty). The area is unchanged
///         (up to float rounding of the midpoints).
/// Throws OptionError when the result would have more than 1431655765 faces or 4294967294
/// vertices (32-bit indices).
/// threads: how many threads work on each level, at most 16; 0 (the default): one per core, and
/// one per 32768 faces of the level at most. The result does not depend on it.
Mesh subdivide_midpoint(const Mesh& mesh, unsigned levels, unsigned threads = 0);

/// What subdivide_faces made.
struct SubdividedFaces {
  Mesh mesh;                     ///< input vertices keep their ids, midpoints follow
  std::vector<uint32_t> parent;  ///< per output face: the input face it lies in
};

/// Midpoint subdivision (as subdivide_midpoint, `levels` times) of the selected faces only: the
/// others are copied as they are. Meant for parts of a mesh too coarse for their clusters (a
/// component with fewer faces than it needs clusters).
///
/// Input : mesh; selected: one entry per face (non-zero: subdivide it); levels >= 0;
///         split_neighbours: what to do with a face that is not selected but has an edge of a
///         selected one (across a non-manifold edge, or at the selection's rim): false refuses it
///         (select whole parts that share no edge with the rest), true splits it at those edges'
///         midpoints so that no T-junction is left (one level at a time): into 2 faces across one
///         split edge, 3 at the corner between two (that corner's triangle, the rest cut along its
///         shorter diagonal), 4 as a selected face for three.
/// Output: faces in input order, each selected face replaced by its 4^levels children (in
///         subdivide_midpoint's order, oriented as it), each split neighbour by its 2 to 4 pieces,
///         parent naming the input face of each; every input vertex kept with its id, the new
///         midpoints after them. source_polygon follows the faces (the input face id where the
///         input has none). The area, orientation and Euler characteristic are kept.
/// Throws OptionError when the sizes disagree, an index is out of range, a selected face shares
/// an edge with a face that is not selected and split_neighbours is false (the split would leave
/// a T-junction), split_neighbours is true with levels > 1, or the result is beyond 32-bit indices.
SubdividedFaces subdivide_faces(const Mesh& mesh, const std::vector<uint8_t>& selected, unsigned levels,
                                bool split_neighbours = false);

/// The smallest k >= 0 such that faces * 4^k >= clusters * min_faces_per_cluster, i.e. how many
/// subdivision levels give every cluster at least `min_faces_per_cluster` faces on average.
/// Throws OptionError when min_faces_per_cluster is negative, NaN or infinite, or when faces is 0
/// and the target is not (no number of levels helps).
unsigned subdivision_levels_for(size_t faces, uint32_t clusters, double min_faces_per_cluster = 10);

}  // namespace meshcvt

namespace meshcvt {

/// What split_long_edges made.
struct SplitEdgesResult {
  Mesh mesh;                    ///< the refined mesh (input vertices keep their ids, midpoints follow)
  std::vector<uint32_t> parent; ///< per output face: the input face it lies in
  uint64_t split_edges = 0;     ///< edges split, over all rounds
  unsigned rounds = 0;          ///< rounds of splitting (0: nothing was too long)
  /// The split stopped at `max_faces`: a round would have made over_budget_faces faces (a lower
  /// bound on what the whole split makes). mesh, parent and the counts above are then empty.
  bool over_budget = false;
  uint64_t over_budget_faces = 0;
};

/// Splits every edge longer than its limit at its midpoint, with longest-edge (Rivara) refinement,
/// until no edge is longer: what a clustering needs where faces are longer than its clusters are
/// wide (CAD exports' long thin triangles), without refining the rest as subdivide_midpoint would.
///
/// Input : mesh (boundaries and non-manifold edges are fine: every face on a split edge is split
///         there; faces with a repeated corner are kept as they are); the limit, in the input's
///         units, either max_length for every face or face_max_length[f] for input face f (then
///         max_length is ignored). An edge is too long when it is longer than the limit of any
///         face on it; children keep their input face's limit.
/// Output: the refined mesh: each face is split across its own longest edge first (so no new angle
///         is below half of one it had), then each half across its other split edge, so a face
///         becomes 1 to 4 faces per round. Orientation, watertightness and the Euler characteristic
///         are kept; the midpoints are at 0.5 a + 0.5 b (float). The faces of input face f come out
///         together, in input face order, parent[i] naming f; source_polygon follows (the input
///         face id when the input has none and anything was split; left empty when nothing was).
///         The same input gives the same output.
/// max_faces (0: none): the most faces the result may have. A split whose lower bound
///         (split_long_edges_min_faces) or any round exceeds it stops there (over_budget): a face
///         budget, since on slivers (long edges, almost no area) the refinement's propagation can
///         make many times that bound (a needle-shaped tetrahedron of 2048 faces: 15 million faces
///         where the bound said under 2 million).
/// Throws OptionError on a limit that is not finite and > 0, arrays of the wrong size, or a result
/// beyond 32-bit indices.
SplitEdgesResult split_long_edges(const Mesh& mesh, double max_length, const std::vector<double>& face_max_length = {},
                                  uint64_t max_faces = 0);

/// A lower bound on the faces split_long_edges(mesh, max_length, face_max_length) makes, before
/// any work: no face within a limit l holds more than (sqrt 3 / 4) l^2 of area, and an edge of
/// length L ends in at least L / l pieces, each in a face shared by at most two. The guard
/// split_long_edges itself applies (beyond 32-bit indices: refused). Cost O(F); the same checks of
/// its inputs as split_long_edges.
double split_long_edges_min_faces(const Mesh& mesh, double max_length, const std::vector<double>& face_max_length = {});

/// The edge length of a coarse mesh of `clusters` vertices made of equilateral triangles, closed,
/// where the density is `density`, when its clusters are those of an optimal CVT of the surface:
/// cells of area (S / clusters) density^-1/2 (Gersho's law: area ~ rho^-1/2), so the length is
/// sqrt(2 S / (sqrt 3 clusters)) density^-1/4. S = sqrt_density_area, the integral of sqrt(rho)
/// over the surface (its area when the density is 1 everywhere). In the units of the surface.
/// Throws OptionError unless S is finite and >= 0, clusters > 0 and density finite and > 0.
double coarse_edge_length(double sqrt_density_area, uint32_t clusters, double density = 1.0);

}  // namespace meshcvt
