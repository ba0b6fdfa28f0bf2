// meshcvt: moves `qem` vertices of a coarse mesh part of the way back to the surface where their
// offsets fold triangles over or leave them thin (declared in coarse_toward_surface.h).
//
// Why: a qem point is the minimizer of its cluster's plane quadric (Garland-Heckbert), off the
// surface on purpose: that offset is what lowers the distance between the coarse mesh and the
// input. But the points of neighbouring clusters are chosen independently. Where they cross (a
// thin part, two clusters pulled onto one crease) the triangle between them turns over, a fold
// that no later step undoes: relax keeps every move's normal turn within its limit, and the
// fitting follows an input that lies on both sides of the fold. Where they crowd (two points
// snapped onto a crease a few percent of a cluster apart) the triangle becomes a needle or a cap
// (fandisk -> 1000: 0.5 degrees) that relax cannot widen, since it moves such points only along
// their crease. The clusters' `projected` points lie on the surface and their triangles are
// relax's (no angle below 30 degrees on any Table 1 mesh): moving a few vertices part of the way
// back to them trades a little of the offset for a sound triangle. A fold is always undone; a thin
// triangle only where that costs its neighbourhood little distance to the input.
//
// Both passes visit vertices in index order, one after the other: the result does not depend on
// the thread count.
#include "coarse_toward_surface.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <iterator>
#include <numbers>

#include "coarse_rings.h"
#include "symmetric_eigen3.h"
#include "triangle_angle.h"
#include "triangle_bvh.h"

namespace meshcvt::detail {

namespace {

// Widening: where a vertex may go, as shares of the way from its surface point to where it is,
// the smallest move first.
constexpr double kWidenShares[] = {0.875, 0.75, 0.5, 0.25, 0.0};
// Widening rounds at most (each lifts the worst triangles; a round that moves nothing ends it).
constexpr int kMaxWidenRounds = 4;
// A widening move may leave the distance of its neighbourhood to the input (the sum of squared
// distances that widen_toward_surface's neighbourhood_error measures) at most this factor above
// what it was when the pass first visited the vertex. Measured (seventeenth session, all 69
// libcgal-demo meshes at faces / 40, floor 20 degrees): without a limit the RMS distance rose by
// up to 57% (rotor_small -> 120, a CAD part whose points sit on its creases; helmet -> 25 +34%);
// against each move's own start instead of the first visit the moves compounded (helmet +30% at
// 1.1); with 1.1 the largest rise is 11% (helmet), the median unchanged, and fandisk -> 1000 keeps
// its crease points (RMS +0.5% instead of +4%; its needle widens along the crease instead, see
// kCreaseSteps).
constexpr double kWidenErrorGrowth = 1.1;
// Corners of a cluster's faces (every stride-th face, in face order) that the distance check
// measures from.
constexpr size_t kErrorCorners = 48;
// Eigenvalues of a vertex's normal tensor below this fraction of the largest leave their direction
// free (as relax's kFreeEigenvalue: normals within about +-13 degrees across it).
constexpr double kFreeEigenvalue = 0.05;
// ... and a crease bends them by more than about 30 degrees: its second eigenvalue is above this
// fraction of the largest. Without it the steps also ran on smoothly curved rings, and the 4.8M
// bunny -> 10k's smallest angle went 18.3 -> 16.4 degrees instead of 19.4 (the greedy order).
constexpr double kCreaseEigenvalue = 0.25;
// Steps along a crease, in mean edge lengths of the vertex, both ways, the smallest first.
constexpr double kCreaseSteps[] = {0.125, -0.125, 0.25, -0.25, 0.5, -0.5};
// A step along a crease may not add to the vertex's triangles an angle below this: such steps slide
// the vertex sideways as relax does, and without the limit they lifted the smallest angles but
// left more angles below 30 degrees (69 libcgal-demo meshes: 2508 -> 2545; with it 2500).
constexpr double kCreaseStepKeptDeg = 30;

// The angle at corner o of the triangle (o, x, y), in radians; 0 when an edge has no length.
double corner_angle(const float* o, const float* x, const float* y) {
  const double u[3] = {double(x[0]) - o[0], double(x[1]) - o[1], double(x[2]) - o[2]};
  const double w[3] = {double(y[0]) - o[0], double(y[1]) - o[1], double(y[2]) - o[2]};
  const double cross[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
  const double sine = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
  return std::atan2(sine, u[0] * w[0] + u[1] * w[1] + u[2] * w[2]);
}

double triangle_smallest_angle(const Mesh& coarse, size_t t) {
  const uint32_t* v = &coarse.indices[3 * t];
  return smallest_angle(&coarse.positions[3 * size_t(v[0])], &coarse.positions[3 * size_t(v[1])],
                        &coarse.positions[3 * size_t(v[2])]);
}

}  // namespace

bool turned_over(const Mesh& coarse, size_t t, const std::vector<float>& surface) {
  double n[2][3];
  for (int s = 0; s < 2; ++s) {
    const float* p = s == 0 ? coarse.positions.data() : surface.data();
    const float* a = &p[3 * size_t(coarse.indices[3 * t])];
    const float* b = &p[3 * size_t(coarse.indices[3 * t + 1])];
    const float* c = &p[3 * size_t(coarse.indices[3 * t + 2])];
    const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    n[s][0] = u[1] * v[2] - u[2] * v[1];
    n[s][1] = u[2] * v[0] - u[0] * v[2];
    n[s][2] = u[0] * v[1] - u[1] * v[0];
  }
  return (n[0][0] * n[1][0] + n[0][1] * n[1][1]) + n[0][2] * n[1][2] < 0;
}

// Rounds: every corner of a turned-over triangle takes its next share (kShares) of the way from
// its surface point to its position before the first round. At share 0 a triangle's corners are
// its surface points, where it is not turned over, so the rounds end.
uint64_t unfold_toward_surface(Mesh& coarse, const std::vector<float>& surface) {
  constexpr double kShares[] = {0.5, 0.25, 0.0};
  assert(surface.size() == coarse.positions.size());
  const size_t n = coarse.vertex_count();
  std::vector<float> start;            // the positions before the first move, once one is needed
  std::vector<uint8_t> pulls(n, 0);    // how often each vertex moved (its index into kShares)
  std::vector<uint8_t> moves_now(n, 0);
  uint64_t moved = 0;
  for (;;) {
    bool any = false;
    for (size_t t = 0; t < coarse.face_count(); ++t)
      if (turned_over(coarse, t, surface))
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = coarse.indices[3 * t + k];
          if (pulls[v] < std::size(kShares)) moves_now[v] = 1, any = true;
        }
    if (!any) return moved;
    if (start.empty()) start = coarse.positions;
    for (size_t v = 0; v < n; ++v) {
      if (!moves_now[v]) continue;
      moves_now[v] = 0;
      moved += pulls[v] == 0;
      const double share = kShares[pulls[v]++];
      for (int d = 0; d < 3; ++d) {
        const double from = surface[3 * v + d];
        coarse.positions[3 * v + d] = float(from + share * (double(start[3 * v + d]) - from));
      }
    }
  }
}

// Rounds: the corners of the triangles below the floor, in index order, each tries the places
// kWidenShares of the way from its surface point to where it stands, nearest first, and takes the
// first where its triangles' smallest angle reaches the floor, or else the one where it is
// largest; it moves only if that angle rises, none of its triangles is turned over and its
// neighbourhood stays within kWidenErrorGrowth of its distance to the input (so a point that a
// crease holds stays on it). Where that leaves it below the floor and its triangles make a crease,
// it may instead step along the crease (kCreaseSteps) if that adds no angle below
// kCreaseStepKeptDeg, under the same checks. A move changes only the vertex's own triangles, and
// lifts their smallest angle: the mesh's smallest angle never drops.
uint64_t widen_toward_surface(Mesh& coarse, const std::vector<float>& surface, double min_angle_deg,
                              const Mesh& mesh, const std::vector<uint32_t>& labels) {
  assert(surface.size() == coarse.positions.size() && min_angle_deg > 0);
  const double floor = min_angle_deg * std::numbers::pi / 180;
  const size_t n = coarse.vertex_count();
  // Nothing to widen (the sphere, most of the time): no rings, no pass over the input's labels.
  bool any_thin = false;
  for (size_t t = 0; t < coarse.face_count() && !any_thin; ++t) any_thin = triangle_smallest_angle(coarse, t) < floor;
  if (!any_thin) return 0;
  std::vector<uint32_t> offsets, ring;
  coarse_triangle_rings(coarse, offsets, ring);
  // Each cluster's corners for the distance check (kErrorCorners).
  std::vector<uint32_t> corner_offsets;
  std::vector<Vec3> corners;
  sample_cluster_corners(mesh, labels, n, kErrorCorners, nullptr, corner_offsets, corners);
  // The sum of squared distances from the corners of cluster w to the nearest of w's triangles.
  auto cluster_error = [&](uint32_t w) {
    double sum = 0;
    for (uint32_t i = corner_offsets[w]; i < corner_offsets[w + 1]; ++i) {
      double nearest = INFINITY;
      for (uint32_t j = offsets[w]; j < offsets[w + 1]; ++j) {
        double tri[3][3], point[3];
        for (int k = 0; k < 3; ++k)
          for (int d = 0; d < 3; ++d) tri[k][d] = coarse.positions[3 * size_t(coarse.indices[3 * size_t(ring[j]) + k]) + d];
        const double x[3] = {corners[i].x, corners[i].y, corners[i].z};
        nearest = std::min(nearest, closest_point_on_triangle(x, tri[0], tri[1], tri[2], point));
      }
      sum += nearest;
    }
    return sum;
  };
  // The same over v's cluster and its neighbours' clusters: the part of the distance to the input
  // that v's move changes (only v's triangles move, and each lies in its corners' rings).
  std::vector<uint32_t> around;
  auto neighbourhood_error = [&](uint32_t v) {
    around.assign(1, v);
    for (uint32_t j = offsets[v]; j < offsets[v + 1]; ++j)
      for (int k = 0; k < 3; ++k) around.push_back(coarse.indices[3 * size_t(ring[j]) + k]);
    std::sort(around.begin(), around.end());
    around.erase(std::unique(around.begin(), around.end()), around.end());
    double sum = 0;
    for (uint32_t w : around) sum += cluster_error(w);
    return sum;
  };
  // How many angles of v's triangles are below kCreaseStepKeptDeg.
  const double kept_angle = kCreaseStepKeptDeg * std::numbers::pi / 180;
  auto ring_thin_angles = [&](uint32_t v) {
    int count = 0;
    for (uint32_t i = offsets[v]; i < offsets[v + 1]; ++i) {
      const uint32_t* tri = &coarse.indices[3 * size_t(ring[i])];
      const float* corner[3] = {&coarse.positions[3 * size_t(tri[0])], &coarse.positions[3 * size_t(tri[1])],
                                &coarse.positions[3 * size_t(tri[2])]};
      for (int k = 0; k < 3; ++k) count += corner_angle(corner[k], corner[(k + 1) % 3], corner[(k + 2) % 3]) < kept_angle;
    }
    return count;
  };
  // The smallest angle of v's triangles as they are, or -1 when one is turned over.
  auto ring_angle = [&](uint32_t v) {
    double smallest = std::numbers::pi;
    for (uint32_t i = offsets[v]; i < offsets[v + 1]; ++i) {
      if (turned_over(coarse, ring[i], surface)) return -1.0;
      smallest = std::min(smallest, triangle_smallest_angle(coarse, ring[i]));
    }
    return smallest;
  };
  // Where v's triangles' normals leave exactly one direction free (the eigenvector of the
  // smallest eigenvalue of the sum of area * n n^T, below kFreeEigenvalue of the largest: a crease),
  // that direction scaled to v's mean edge length, into `along`.
  auto crease_direction = [&](uint32_t v, const float at[3], double along[3]) {
    double tensor[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    double edges = 0;
    for (uint32_t j = offsets[v]; j < offsets[v + 1]; ++j) {
      const uint32_t* tri = &coarse.indices[3 * size_t(ring[j])];
      const float *a = &coarse.positions[3 * size_t(tri[0])], *b = &coarse.positions[3 * size_t(tri[1])],
                  *c = &coarse.positions[3 * size_t(tri[2])];
      const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
      const double w[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
      const double m[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      const double l = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
      if (l > 0)
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y) tensor[x][y] += 0.5 * m[x] * m[y] / l;
      for (int k = 0; k < 3; ++k) {
        if (tri[k] == v) continue;
        const float* q = &coarse.positions[3 * size_t(tri[k])];
        const double e[3] = {double(q[0]) - at[0], double(q[1]) - at[1], double(q[2]) - at[2]};
        edges += std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
      }
    }
    // (In a closed fan each neighbour is a corner of two of the triangles.)
    const double mean_edge = edges / (2.0 * (offsets[v + 1] - offsets[v]));
    double values[3], vectors[3][3];
    symmetric_eigen3(tensor, values, vectors);
    const double largest = std::max({values[0], values[1], values[2]});
    int free = -1, free_count = 0, bent = 0;
    for (int k = 0; k < 3; ++k) {
      if (values[k] < kFreeEigenvalue * largest) free = k, ++free_count;
      bent += values[k] > kCreaseEigenvalue * largest;
    }
    if (free_count != 1 || bent != 2 || !(mean_edge > 0)) return false;
    for (int d = 0; d < 3; ++d) along[d] = mean_edge * vectors[d][free];
    return true;
  };
  std::vector<uint8_t> thin(n, 0);  // a corner of a triangle below the floor
  std::vector<double> initial_error(n, -1.0);  // neighbourhood_error(v) when v was first visited
  // A vertex that found no move, until one within two rings of it moves (what its angles and its
  // neighbourhood's distance read): a later round would find none again (fandisk -> 1000: a
  // third of the pass's time went to such vertices).
  std::vector<uint8_t> settled(n, 0);
  auto unsettle_around = [&](uint32_t v) {
    for (uint32_t j = offsets[v]; j < offsets[v + 1]; ++j)
      for (int k = 0; k < 3; ++k) {
        const uint32_t w = coarse.indices[3 * size_t(ring[j]) + k];
        for (uint32_t i = offsets[w]; i < offsets[w + 1]; ++i)
          for (int m = 0; m < 3; ++m) settled[coarse.indices[3 * size_t(ring[i]) + m]] = 0;
      }
  };
  uint64_t moves = 0;
  for (int round = 0; round < kMaxWidenRounds; ++round) {
    std::fill(thin.begin(), thin.end(), uint8_t(0));
    bool any = false;
    for (size_t t = 0; t < coarse.face_count(); ++t)
      if (triangle_smallest_angle(coarse, t) < floor)
        for (int k = 0; k < 3; ++k) thin[coarse.indices[3 * t + k]] = 1, any = true;
    if (!any) break;
    bool moved = false;
    for (uint32_t v = 0; v < n; ++v) {
      if (!thin[v] || settled[v]) continue;
      float* p = &coarse.positions[3 * size_t(v)];
      const float at[3] = {p[0], p[1], p[2]};
      const double before = ring_angle(v);
      if (initial_error[v] < 0) initial_error[v] = neighbourhood_error(v);
      const double error_limit = kWidenErrorGrowth * initial_error[v];
      double best = before;
      float best_at[3] = {at[0], at[1], at[2]};
      int thin_limit = -1;  // along a crease: the most angles below kCreaseStepKeptDeg allowed
      auto try_at = [&](const double q[3]) {
        for (int d = 0; d < 3; ++d) p[d] = float(q[d]);
        const double angle = ring_angle(v);
        if (angle > best && (thin_limit < 0 || ring_thin_angles(v) <= thin_limit) &&
            neighbourhood_error(v) <= error_limit) {
          best = angle;
          std::copy(p, p + 3, best_at);
        }
      };
      for (double share : kWidenShares) {
        if (best >= floor) break;
        double q[3];
        for (int d = 0; d < 3; ++d) {
          const double from = surface[3 * size_t(v) + d];
          q[d] = from + share * (double(at[d]) - from);
        }
        try_at(q);
      }
      // A point held on a crease cannot go toward its surface point without leaving the crease
      // (the distance check refuses it); along the crease it can (fandisk -> 1000: its needle of
      // two points on one crease went 9.6 -> 20.3 degrees, RMS unchanged).
      double along[3];
      std::copy(at, at + 3, p);  // the direction and the count where the vertex stands
      if (best < floor && crease_direction(v, at, along)) {
        thin_limit = ring_thin_angles(v);
        for (double step : kCreaseSteps) {
          if (best >= floor) break;
          const double q[3] = {at[0] + step * along[0], at[1] + step * along[1], at[2] + step * along[2]};
          try_at(q);
        }
      }
      std::copy(best_at, best_at + 3, p);
      if (best > before) {
        ++moves, moved = true;
        unsettle_around(v);
      } else {
        settled[v] = 1;
      }
    }
    if (!moved) break;
  }
  return moves;
}

}  // namespace meshcvt::detail
