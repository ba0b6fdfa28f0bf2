// meshcvt: the indexed triangle mesh every part of the library works on.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshcvt {

/// Marks "no face / no vertex / no cluster" in index arrays.
inline constexpr uint32_t kNone = 0xffffffffu;

/// Indexed triangle mesh.
///
/// positions : 3 floats (x, y, z) per vertex, in the input's units.
/// indices   : 3 vertex ids per triangle, counter-clockwise seen from outside (as in the input).
/// source_polygon : for each triangle, the index of the input polygon it was cut from, so per-face
///                  output (labels) can be written in the input's face order. Empty means identity
///                  (the input had triangles only).
struct Mesh {
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  std::vector<uint32_t> source_polygon;

  size_t vertex_count() const { return positions.size() / 3; }
  size_t face_count() const { return indices.size() / 3; }
};

}  // namespace meshcvt
