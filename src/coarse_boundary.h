// meshcvt: the coarse vertices of clusters along the input's boundary, put onto that boundary
// (coarse_boundary.cpp). Internal, not public API: coarsen_clustering calls it (see
// CoarsenOptions::boundary_onto_input).
#pragma once

#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt::detail {

struct BoundarySnapCounts {
  uint64_t moved = 0;    ///< coarse vertices moved onto the input's boundary (corners included)
  uint64_t corners = 0;  ///< of them, onto a corner of a boundary loop
};

/// Moves the vertex of each cluster that meets the input's boundary in one arc onto that arc: onto
/// the sharpest corner of the loop there, if the arc holds one, else onto the arc's closest point
/// to where the vertex is; then slides the vertices off corners along their arcs where that
/// improves their triangles. Loops whose arcs are short against their clusters' coarse edges are
/// left alone. See coarse_boundary.cpp for the corners and the checks on each move.
///
/// Inputs: coarse, the dual of (mesh, labels) without defects (vertex i is cluster i); topology of
///         mesh. Nothing moves when the input has non-manifold edges or vertices, faces with a
///         repeated corner, or inconsistently oriented neighbours (the loops' order is then not
///         the faces' orientation).
/// Output: coarse's positions (the other vertices, connectivity and orientation unchanged); the
///         counts; moved: per vertex 1 put onto the boundary, 2 onto a corner of it, else 0.
BoundarySnapCounts snap_boundary_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& labels, std::vector<uint8_t>& moved);

/// Later (after relax): each vertex put onto the boundary (not onto a corner: those stay) whose
/// triangles' smallest angle is below 30 degrees goes back toward its `placed` point (coarse's
/// positions before snap_boundary_vertices, 3 per vertex), as far as lifts that angle to 30
/// degrees (a quarter, half, three quarters or all of the way), or else by the step that lifts it
/// most; not at all where none does or a triangle would turn by more than 20 degrees. Returns how
/// many moved.
uint64_t back_off_boundary_vertices(Mesh& coarse, const std::vector<float>& placed, const std::vector<uint8_t>& moved);

}  // namespace meshcvt::detail
