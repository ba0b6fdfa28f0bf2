// meshcvt: midpoint subdivision (1 triangle -> 4), used to refine meshes that have too few faces for
// the requested clusters and to make big benchmark meshes.
#pragma once

#include <cstddef>
#include <cstdint>

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
Mesh subdivide_midpoint(const Mesh& mesh, unsigned levels);

/// The smallest k >= 0 such that faces * 4^k >= clusters * min_faces_per_cluster, i.e. how many
/// subdivision levels give every cluster at least `min_faces_per_cluster` faces on average.
/// Throws OptionError when min_faces_per_cluster is negative, NaN or infinite, or when faces is 0
/// and the target is not (no number of levels helps).
unsigned subdivision_levels_for(size_t faces, uint32_t clusters, double min_faces_per_cluster = 10);

}  // namespace meshcvt
