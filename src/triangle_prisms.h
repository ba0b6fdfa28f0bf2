// meshcvt: a lower bound of the distance from a point to a triangle, from the planes through the
// triangle's edges (the prism the triangle spans), to skip closest-point tests that cannot win.
// Internal, not public API.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "meshcvt/mesh.h"
#include "vec3.h"

namespace meshcvt {

/// Three planes per triangle of a mesh, one through each edge, perpendicular to the triangle and
/// facing away from it: the triangle lies on the inner side of all three, so a point's distance
/// to it is at least the point's largest distance beyond them, a lower bound for three dot
/// products instead of a closest-point test. A search for the nearest triangle skips those the
/// bound rules out (coarse_fit.cpp's owner searches: most samples lie well inside their owner's
/// prism, away from its neighbours; the 1.2M bunny -> 10k with qem keeps 0.25M of 6.5M neighbour
/// tests of its three owner updates, 0.8M of 4.3M of its first owner search).
class TrianglePrisms {
 public:
  /// tolerance: what the bound is lowered by before it rules a triangle out, in the mesh's length
  ///   unit; well above the rounding of the bound and of closest_point_on_triangle's distance (the
  ///   fit passes a billionth of the larger of the bounding box's diagonal and its coordinates),
  ///   so that a triangle ruled out is one the full test would not have found nearer.
  explicit TrianglePrisms(double tolerance) : tolerance_(tolerance) {}

  /// The planes of every triangle of `mesh` at its current positions (replacing earlier ones). A
  /// degenerate triangle gets zero planes: its bound is 0, never ruled out.
  void build(const Mesh& mesh) {
    const size_t triangles = mesh.face_count();
    planes_.assign(12 * triangles, 0.0);
    for (size_t t = 0; t < triangles; ++t) {
      const Vec3 p[3] = {mesh_vertex(mesh, mesh.indices[3 * t]), mesh_vertex(mesh, mesh.indices[3 * t + 1]),
                         mesh_vertex(mesh, mesh.indices[3 * t + 2])};
      const Vec3 normal = cross(p[1] - p[0], p[2] - p[0]);
      for (int k = 0; k < 3; ++k) {
        const Vec3 out = cross(p[(k + 1) % 3] - p[k], normal);  // in the plane, away from the third corner
        const double l = length(out);
        if (!(l > 0) || !std::isfinite(l)) {
          std::fill(&planes_[12 * t], &planes_[12 * t + 12], 0.0);
          break;
        }
        const Vec3 m = (1 / l) * out;
        double* plane = &planes_[12 * t + 4 * k];
        plane[0] = m.x, plane[1] = m.y, plane[2] = m.z, plane[3] = dot(m, p[k]);
      }
    }
  }

  /// Whether triangle t (of the mesh last built) is certainly farther from point x than the
  /// squared distance d2: its bound, less the tolerance, is positive and its square above d2.
  bool farther(uint32_t t, const double x[3], double d2) const {
    const double* plane = &planes_[12 * size_t(t)];
    double beyond = 0;
    for (int k = 0; k < 3; ++k, plane += 4)
      beyond = std::max(beyond, (plane[0] * x[0] + plane[1] * x[1]) + plane[2] * x[2] - plane[3]);
    const double bound = beyond - tolerance_;
    return bound > 0 && bound * bound > d2;
  }

 private:
  double tolerance_;
  std::vector<double> planes_;  // per triangle, per edge: unit normal and offset
};

}  // namespace meshcvt
