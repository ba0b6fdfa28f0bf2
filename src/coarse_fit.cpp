// meshcvt: moves the vertices of a coarse mesh so that the input surface lies on both sides of it,
// the distance-fitting step of mesh optimization (Hoppe, DeRose, Duchamp, McDonald, Stuetzle,
// SIGGRAPH 1993, E_dist with the connectivity fixed), one Jacobi step per pass. Used after the
// `qem` placement (declared in coarsen.cpp's detail block).
//
// Why: a quadric point minimizes the squared distances to the planes of its cluster's faces, so it
// sits on the surface where the cluster is flat and just outside it where the cluster is curved.
// The coarse triangles between three such points are chords, below the surface in their middle:
// on a 131k-face sphere -> 200, every input point lies outside the coarse mesh. The distance the
// coarse mesh should minimize is to the input's points, not to the cluster's planes.
//
// One pass: each input face's centroid x (weight: its area) finds its closest point y on the
// triangles around its own cluster's vertex, with barycentric coordinates b. Its residual x - y is
// handed to the triangle's three vertices in proportion b, and each vertex moves by the weighted
// mean of what it received: a uniform offset of a triangle's samples moves its three vertices by
// exactly that offset. Only vertices whose every edge has two triangles move (boundaries keep
// their shape); connectivity and the vertex count are never touched. The sums are in 64-bit fixed
// point, so the result is the same for any thread count.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "meshcvt/coarsen.h"
#include "coarse_rings.h"
#include "parallel.h"
#include "triangle_bvh.h"

namespace meshcvt {

namespace {

// Input faces sampled per coarse vertex (every stride-th face; all of them on smaller inputs).
constexpr size_t kSamplesPerVertex = 32;

// Barycentric coordinates of p, a point of triangle (a, b, c), from the areas opposite each corner
// (Ericson, Real-Time Collision Detection 3.4). A degenerate triangle gives its first corner.
void barycentric(const double p[3], const double a[3], const double b[3], const double c[3], double out[3]) {
  double v0[3], v1[3], v2[3];
  for (int d = 0; d < 3; ++d) v0[d] = b[d] - a[d], v1[d] = c[d] - a[d], v2[d] = p[d] - a[d];
  auto dot = [](const double* x, const double* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  const double d00 = dot(v0, v0), d01 = dot(v0, v1), d11 = dot(v1, v1), d20 = dot(v2, v0), d21 = dot(v2, v1);
  const double den = d00 * d11 - d01 * d01;
  if (!(den > 0)) {
    out[0] = 1, out[1] = 0, out[2] = 0;
    return;
  }
  const double v = std::clamp((d11 * d20 - d01 * d21) / den, 0.0, 1.0);
  const double w = std::clamp((d00 * d21 - d01 * d20) / den, 0.0, 1.0 - v);
  out[0] = 1 - v - w, out[1] = v, out[2] = w;
}

double face_area(const Mesh& mesh, size_t f) {
  const float* a = &mesh.positions[3 * size_t(mesh.indices[3 * f])];
  const float* b = &mesh.positions[3 * size_t(mesh.indices[3 * f + 1])];
  const float* c = &mesh.positions[3 * size_t(mesh.indices[3 * f + 2])];
  double e1[3], e2[3];
  for (int d = 0; d < 3; ++d) e1[d] = double(b[d]) - a[d], e2[d] = double(c[d]) - a[d];
  const double x = e1[1] * e2[2] - e1[2] * e2[1], y = e1[2] * e2[0] - e1[0] * e2[2], z = e1[0] * e2[1] - e1[1] * e2[0];
  return 0.5 * std::sqrt(x * x + y * y + z * z);
}

void corners(const Mesh& coarse, uint32_t triangle, double t[3][3]) {
  for (int j = 0; j < 3; ++j)
    for (int d = 0; d < 3; ++d) t[j][d] = coarse.positions[3 * size_t(coarse.indices[3 * size_t(triangle) + j]) + d];
}

}  // namespace

namespace detail {

uint64_t fit_coarse_vertices(Mesh& coarse, const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t passes,
                             unsigned threads) {
  const size_t n = coarse.vertex_count(), faces = mesh.face_count(), triangles = coarse.face_count();
  if (passes == 0 || n == 0 || triangles == 0 || labels.size() != faces) return 0;
  std::vector<uint32_t> ring_offsets, ring;  // triangles per coarse vertex (CSR)
  coarse_triangle_rings(coarse, ring_offsets, ring);
  // Movable: every edge at the vertex is used by exactly two triangles.
  std::vector<uint8_t> movable(n, 1);
  {
    std::vector<uint64_t> edges;
    edges.reserve(3 * triangles);
    for (size_t t = 0; t < triangles; ++t)
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = coarse.indices[3 * t + k], b = coarse.indices[3 * t + (k + 1) % 3];
        edges.push_back(a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a));
      }
    std::sort(edges.begin(), edges.end());
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j] == edges[i]) ++j;
      if (j - i != 2) movable[uint32_t(edges[i] >> 32)] = movable[uint32_t(edges[i])] = 0;
      i = j;
    }
  }
  // Scales of the fixed-point sums: a vertex's weight is at most the total area, its residual sum
  // at most the total area times the bounding-box diagonal; integer sums do not depend on the order
  // of addition, so the workers' partial sums give the same result for any thread count.
  double total_area = 0, lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t f = 0; f < faces; ++f) total_area += face_area(mesh, f);
  for (size_t v = 0; v < mesh.vertex_count(); ++v)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], double(mesh.positions[3 * v + d]));
      hi[d] = std::max(hi[d], double(mesh.positions[3 * v + d]));
    }
  const double diagonal = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                    (hi[2] - lo[2]) * (hi[2] - lo[2]));
  if (!(total_area > 0) || !(diagonal > 0)) return 0;
  const double weight_scale = std::ldexp(1.0, 60) / total_area;
  const double residual_scale = std::ldexp(1.0, 60) / (total_area * diagonal);
  // Every stride-th face is a sample: about kSamplesPerVertex per coarse vertex are plenty to
  // place it (measured: 32 per vertex give the RMS of all the faces to within 1%).
  const size_t stride = std::max<size_t>(1, faces / (kSamplesPerVertex * n));
  const size_t samples = (faces + stride - 1) / stride;

  WorkerPool pool(threads);
  std::vector<std::vector<int64_t>> partial(pool.size(), std::vector<int64_t>(4 * n));
  uint64_t moves = 0;
  for (uint32_t pass = 0; pass < passes; ++pass) {
    pool.run(samples, [&](size_t first, size_t last, unsigned worker) {
      int64_t* acc = partial[worker].data();
      std::fill(acc, acc + 4 * n, int64_t(0));
      for (size_t sample = first; sample < last; ++sample) {
        const size_t f = sample * stride;
        const uint32_t c = labels[f];
        if (c >= n) continue;
        const double area = face_area(mesh, f);
        if (!(area > 0)) continue;
        double x[3] = {0, 0, 0};
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 3; ++d) x[d] += double(mesh.positions[3 * size_t(mesh.indices[3 * f + j]) + d]) / 3;
        // The closest of the triangles around the cluster's vertex (ties: the first in the ring).
        double best = INFINITY, best_point[3] = {0, 0, 0};
        uint32_t best_triangle = 0;
        for (uint32_t i = ring_offsets[c]; i < ring_offsets[c + 1]; ++i) {
          double t[3][3], point[3];
          corners(coarse, ring[i], t);
          const double d2 = closest_point_on_triangle(x, t[0], t[1], t[2], point);
          if (d2 < best) {
            best = d2;
            best_triangle = ring[i];
            for (int d = 0; d < 3; ++d) best_point[d] = point[d];
          }
        }
        if (!(best < INFINITY)) continue;
        double t[3][3], b[3];
        corners(coarse, best_triangle, t);
        barycentric(best_point, t[0], t[1], t[2], b);
        const uint32_t* tri = &coarse.indices[3 * size_t(best_triangle)];
        for (int j = 0; j < 3; ++j) {
          int64_t* a = &acc[4 * size_t(tri[j])];
          a[0] += std::llround(area * b[j] * weight_scale);
          for (int d = 0; d < 3; ++d) a[1 + d] += std::llround(area * b[j] * (x[d] - best_point[d]) * residual_scale);
        }
      }
    }, 256);
    for (size_t v = 0; v < n; ++v) {
      int64_t sum[4] = {0, 0, 0, 0};
      for (const std::vector<int64_t>& acc : partial)
        for (int k = 0; k < 4; ++k) sum[k] += acc[4 * v + k];
      if (!movable[v] || sum[0] <= 0) continue;
      const double weight = double(sum[0]) / weight_scale;
      bool moved = false;
      for (int d = 0; d < 3; ++d) {
        const float p = float(coarse.positions[3 * v + d] + double(sum[1 + d]) / residual_scale / weight);
        moved |= p != coarse.positions[3 * v + d];
        coarse.positions[3 * v + d] = p;
      }
      moves += moved;
    }
  }
  return moves;
}

}  // namespace detail

}  // namespace meshcvt
