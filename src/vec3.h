// meshcvt: a 3-vector in double and the few operations the geometry code needs (quality measures,
// curvature density, coarse-mesh edge flips). Internal, not public API. dot sums x, y, z in that
// order, so every user rounds the same way.
#pragma once

#include <cmath>
#include <cstdint>

#include "meshcvt/mesh.h"

namespace meshcvt {

struct Vec3 {
  double x, y, z;
};
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator*(double s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3 a, Vec3 b) { return (a.x * b.x + a.y * b.y) + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double length(Vec3 a) { return std::sqrt(dot(a, a)); }

/// Position of vertex v of `mesh`, in double.
inline Vec3 mesh_vertex(const Mesh& mesh, uint32_t v) {
  const float* p = &mesh.positions[3 * size_t(v)];
  return {p[0], p[1], p[2]};
}

/// Area of face f of `mesh`, in double (half the length of (b - a) x (c - a)), in squared input units.
inline double face_area(const Mesh& mesh, size_t f) {
  const uint32_t* t = &mesh.indices[3 * f];
  const Vec3 a = mesh_vertex(mesh, t[0]);
  return 0.5 * length(cross(mesh_vertex(mesh, t[1]) - a, mesh_vertex(mesh, t[2]) - a));
}

}  // namespace meshcvt
