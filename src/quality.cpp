// meshcvt: triangle quality, the measures of Table 1 in Fan et al. (SPM 2009, Section 7): smallest
// angle, average smallest angle, angles below 30 degrees, and Frey-Borouchaki's Q (minimum and
// mean), plus the vertex valence histogram. Everything in double from the float positions.
#include "meshcvt/quality.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>

#include "vec3.h"

namespace meshcvt {

namespace {

// Angle between u and w in degrees; atan2 of |u x w| and u . w is accurate near 0 and 180 degrees,
// where acos of a normalized dot product is not. 0 when either vector is zero.
inline double angle_deg(Vec3 u, Vec3 w) {
  return std::atan2(length(cross(u, w)), dot(u, w)) * (180.0 / std::numbers::pi);
}

// Valence of every referenced vertex (distinct neighbours through an edge), and whether it is
// interior (each of its edges has exactly two faces). Works vertex by vertex on a CSR list of
// incident faces: a neighbour listed twice is an edge with two faces.
void valences(const Mesh& mesh, TriangleQuality& q) {
  const size_t V = mesh.vertex_count(), F = mesh.face_count();
  std::vector<uint32_t> offsets(V + 1, 0);
  for (size_t i = 0; i < 3 * F; ++i) offsets[mesh.indices[i] + 1]++;
  for (size_t v = 0; v < V; ++v) offsets[v + 1] += offsets[v];
  std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
  std::vector<uint32_t> corner_faces(3 * F);
  for (size_t f = 0; f < F; ++f)
    for (int c = 0; c < 3; ++c) corner_faces[fill[mesh.indices[3 * f + c]]++] = uint32_t(f);

  std::vector<uint32_t> neighbours;
  for (size_t v = 0; v < V; ++v) {
    if (offsets[v] == offsets[v + 1]) continue;  // unreferenced
    q.referenced_vertices++;
    neighbours.clear();
    uint32_t previous_face = kNone;
    for (uint32_t i = offsets[v]; i < offsets[v + 1]; ++i) {
      uint32_t f = corner_faces[i];
      if (f == previous_face) continue;  // a face with this vertex at two corners: once is enough
      previous_face = f;
      for (int c = 0; c < 3; ++c) {
        uint32_t w = mesh.indices[3 * size_t(f) + c];
        if (w != v) neighbours.push_back(w);
      }
    }
    std::sort(neighbours.begin(), neighbours.end());
    size_t valence = 0;
    bool interior = true;
    for (size_t i = 0; i < neighbours.size();) {
      size_t j = i;
      while (j < neighbours.size() && neighbours[j] == neighbours[i]) ++j;
      interior = interior && (j - i == 2);
      ++valence;
      i = j;
    }
    if (valence == 0) interior = false;
    if (q.valence_histogram.size() <= valence) q.valence_histogram.resize(valence + 1, 0);
    q.valence_histogram[valence]++;
    if (interior) {
      if (q.interior_valence_histogram.size() <= valence) q.interior_valence_histogram.resize(valence + 1, 0);
      q.interior_valence_histogram[valence]++;
    }
  }
}

}  // namespace

TriangleQuality triangle_quality(const Mesh& mesh) {
  TriangleQuality q;
  const size_t F = mesh.face_count();
  q.faces = F;
  if (F == 0) return q;

  // Q = (6 / sqrt 3) * area / (s * h): 1 for the equilateral triangle (area = sqrt(3)/4 l^2,
  // s = 3l/2, h = l).
  const double q_scale = 6.0 / std::sqrt(3.0);
  double min_angle = 180, max_angle = 0, sum_min_angle = 0, q_min = INFINITY, q_sum = 0, area_sum = 0;
  for (size_t f = 0; f < F; ++f) {
    Vec3 p[3];
    for (int c = 0; c < 3; ++c) p[c] = mesh_vertex(mesh, mesh.indices[3 * f + c]);
    double tri_min = 180;
    for (int c = 0; c < 3; ++c) {
      double a = angle_deg(p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]);
      tri_min = std::min(tri_min, a);
      max_angle = std::max(max_angle, a);
      if (a < 30.0) q.angles_below_30++;
    }
    min_angle = std::min(min_angle, tri_min);
    sum_min_angle += tri_min;

    double area = 0.5 * length(cross(p[1] - p[0], p[2] - p[0]));
    double l0 = length(p[1] - p[0]), l1 = length(p[2] - p[1]), l2 = length(p[0] - p[2]);
    double semi_perimeter = 0.5 * ((l0 + l1) + l2);
    double longest = std::max(std::max(l0, l1), l2);
    double denominator = semi_perimeter * longest;
    double shape = denominator > 0 ? q_scale * area / denominator : 0.0;
    q_min = std::min(q_min, shape);
    q_sum += shape;
    area_sum += area;
    if (!(area > 0)) q.degenerate_faces++;
  }
  q.min_angle_deg = min_angle;
  q.max_angle_deg = max_angle;
  q.avg_min_angle_deg = sum_min_angle / double(F);
  q.q_min = q_min;
  q.q_avg = q_sum / double(F);
  q.total_area = area_sum;
  valences(mesh, q);
  return q;
}

}  // namespace meshcvt
