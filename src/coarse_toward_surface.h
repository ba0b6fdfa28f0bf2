// meshcvt: moving `qem` vertices of a coarse mesh part of the way back to the surface where their
// offsets fold triangles over or leave them thin (coarse_toward_surface.cpp). Internal, not public
// API: coarsen_clustering calls both after the `qem` placement.
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt::detail {

/// Whether triangle t of `coarse` faces against the same triangle with its corners at `surface`
/// (3 floats per vertex): its normal turned by more than 90 degrees. A triangle without area at
/// `surface` is not turned over.
bool turned_over(const Mesh& coarse, size_t t, const std::vector<float>& surface);

/// Moves the corners of every triangle that is turned over (against `surface`) toward their
/// surface points, half, a quarter, then all the way, in rounds until none is turned over.
/// coarse  : positions change in place, triangles do not.
/// surface : a point per vertex of `coarse` on the input surface (its cluster's `projected` point).
/// Returns the vertices moved.
uint64_t unfold_toward_surface(Mesh& coarse, const std::vector<float>& surface);

/// Moves each corner of a triangle whose smallest angle is below `min_angle_deg` (degrees, > 0)
/// toward its surface point, as little as lifts its triangles' smallest angle to the floor, or
/// else as far as lifts it most, never turning a triangle over nor taking its neighbourhood more
/// than 10% (in squared distance) farther from the input; on a crease it may instead step along
/// the crease, adding no angle below 30 degrees (see the .cpp). The mesh's smallest angle never
/// drops.
/// mesh, labels: the input and its clustering (labels[f] < coarse.vertex_count()), whose faces'
///               corners the distance is measured from.
/// Returns the moves made.
uint64_t widen_toward_surface(Mesh& coarse, const std::vector<float>& surface, double min_angle_deg,
                              const Mesh& mesh, const std::vector<uint32_t>& labels);

}  // namespace meshcvt::detail
