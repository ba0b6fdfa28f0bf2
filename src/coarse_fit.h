// meshcvt: fitting a coarse mesh to the input it stands for (coarse_fit.cpp), after the `qem`
// placement. Internal, not public API: coarsen_clustering calls it (CoarsenOptions::fit_passes).
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/mesh.h"

namespace meshcvt::detail {

struct FitCounts {
  uint64_t moves = 0;  ///< vertex moves (one vertex may move in several passes)
  uint64_t swaps = 0;  ///< edges swapped
};

/// Passes of distance fitting (Hoppe et al. 1993, the vertex count fixed): a Jacobi step moving
/// the vertices toward their samples of the input, then, with `swaps`, edge swaps where the other
/// diagonal lies closer to them (see coarse_fit.cpp's top comment).
///
/// coarse : the coarse mesh, one vertex per cluster (vertex c stands for cluster c); positions and
///          triangles change in place, the vertex count, boundary and orientation do not.
/// mesh   : the input; labels[f] < coarse.vertex_count() is face f's cluster.
/// swap_min_angle_deg: CoarsenOptions::fit_swap_min_angle_deg (checked by the caller).
/// threads: 0 = one per core; the result does not depend on it (fixed-point sums, sequential
///          swaps).
FitCounts fit_coarse_mesh(Mesh& coarse, const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t passes,
                          bool swaps, double swap_min_angle_deg, unsigned threads);

/// Throws OptionError unless CoarsenOptions::fit_swap_min_angle_deg and fit_min_angle_deg are
/// within [0, 60] degrees (coarsen_clustering, and coarsen_mesh before it clusters).
void check_fit_angles(const CoarsenOptions& options);

}  // namespace meshcvt::detail
