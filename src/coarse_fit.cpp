// meshcvt: fits a coarse mesh to the input surface it stands for, the distance minimization of
// mesh optimization (Hoppe, DeRose, Duchamp, McDonald, Stuetzle, SIGGRAPH 1993: E_dist over the
// vertex positions and over edge swaps, the vertex count fixed). Used after the `qem` placement
// (declared in coarse_fit.h).
//
// Why move the vertices: a quadric point minimizes the squared distances to the planes of its
// cluster's faces, so it sits on the surface where the cluster is flat and just outside it where
// the cluster is curved. The coarse triangles between three such points are chords, below the
// surface in their middle: on a 131k-face sphere -> 200, every input point lies outside the coarse
// mesh. The distance the coarse mesh should minimize is to the input's points, not to the planes.
//
// Why swap edges: the dual of a clustering joins clusters that touch, whatever lies between their
// points. Where a crease runs between two rows of points, or the surface bends more one way than
// the other, the other diagonal of two triangles follows the surface more closely (data-dependent
// triangulation; on fandisk -> 1000, whose creases the clusters do not follow, most of the error
// sits along the creases).
//
// The samples: three points per sampled input face (the degree-2 quadrature rule), each weighing a
// third of its face's area, about kSamplesPerVertex per coarse vertex. Each is owned by one coarse
// triangle: first the closest of the triangles around its own cluster's vertex, later the closest
// of its owner and the owner's three neighbours (the owner moves little between passes).
// One pass:
//   * Jacobi step: each sample's residual x - y (y its closest point on its owner, with barycentric
//     coordinates b) is handed to the owner's three vertices in proportion b; each vertex moves by
//     the weighted mean of what it received (a uniform offset of a triangle's samples moves its
//     three vertices by exactly that offset). Only vertices whose every edge has two consistently
//     oriented triangles move, so boundaries keep their shape. The sums are 64-bit fixed point, so
//     the result is the same for any thread count.
//   * Owners again (parallel over samples, each writes its own).
//   * Edge swaps, in edge order until none applies: an edge between (u, v, c) and (v, u, d) becomes
//     (c, d) when the samples owned by the two triangles lie closer to the two new ones by at
//     least kSwapGain of their squared distance (small gains are not worth the thinner triangles:
//     they cost the bunnies far more angles below 30 degrees than they save distance, and raised
//     Hausdorff distances), the result stays a manifold with the same orientation (c, d not joined
//     already; u and v keep three edges; both new triangles face the side of the old ones), and
//     the smaller smallest angle of the pair does not drop below min(its old value,
//     swap_min_angle_deg), or, for a swap that removes at least 90% of the distance (an edge laid
//     along a sharp crease), below min(its old value, swap_min_angle_deg, 10 degrees).
//     Swaps are tested one after the other in a fixed order, so the result is deterministic; after
//     the first pass over the edges only edges with a vertex touched since are tested again.
// Connectivity changes only through swaps: the vertex count, the boundary and the orientation stay.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "coarse_fit.h"
#include "meshcvt/error.h"
#include "coarse_rings.h"
#include "fixed_point.h"
#include "parallel.h"
#include "triangle_angle.h"
#include "triangle_bvh.h"
#include "triangle_prisms.h"
#include "vec3.h"

namespace meshcvt {

namespace {

// Samples per coarse vertex (three points per sampled face; every face on smaller inputs).
// Measured with the swaps (fourteenth session): 32 instead of 64 raise qem's RMS distance by 4% on
// bunny00 -> 500 and 1% on the 1.2M bunny -> 10k; 16, by 8% and 5%.
constexpr size_t kSamplesPerVertex = 64;
// A swap must lower its samples' squared distance by this fraction (see the top comment).
constexpr double kSwapGain = 0.3;
// ... and may not make its pair's smallest angle smaller than min(old, swap_min_angle_deg), the
// floor CoarsenOptions::fit_swap_min_angle_deg gives: 30 by default since the sixteenth session,
// 10 before. At 10 qem's swaps left 248 of bunny00 -> 500's angles and 501 of fandisk -> 1000's
// below 30 degrees (ACVDQ: 7 and 25) for RMS distances 11% and 7% lower; at 30 qem's RMS stays
// below ACVD's and ACVDQ's on every Table 1 row (bench/RESULTS.md).
// A swap below that floor must lower its samples' squared distance by this fraction, and keep the
// pair's smallest angle at or above min(old, swap_min_angle_deg, kThinSwapAngleFloorDeg): on a
// sharp crease that the other diagonal cut across, laying the edge along it removes nearly all
// the distance (a cube at 60 vertices: 12-36x lower RMS with such swaps). Measured (sixteenth
// session): 0.75 instead of 0.9 left 54 instead of 32 of bunny00 -> 500's angles below 30
// degrees for 5% lower RMS.
constexpr double kThinSwapGain = 0.9;
constexpr double kThinSwapAngleFloorDeg = 10;
// Swap rounds stop after this many passes over the edges even if swaps remain (each swap lowers
// the sampled distance, so they would end anyway).
constexpr int kMaxSwapPasses = 8;
// Samples (a few closest-point tests each) below which one thread does a parallel step.
constexpr size_t kMinParallelSamples = 1024;

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


void corners(const Mesh& coarse, uint32_t triangle, double t[3][3]) {
  for (int j = 0; j < 3; ++j)
    for (int d = 0; d < 3; ++d) t[j][d] = coarse.positions[3 * size_t(coarse.indices[3 * size_t(triangle) + j]) + d];
}

double closest_point_to(const Mesh& coarse, uint32_t triangle, const double x[3], double point[3]) {
  double t[3][3];
  corners(coarse, triangle, t);
  return closest_point_on_triangle(x, t[0], t[1], t[2], point);
}

// Half-edges of the coarse mesh: h = 3t + k runs from indices[h] to indices[next(h)]; twin[h] is
// the half-edge running back along the same edge in the other triangle, kNone unless the edge has
// exactly two consistently oriented triangles (only such edges are swapped, and only vertices all
// of whose edges are such move).
struct HalfEdges {
  std::vector<uint32_t> twin, valence, leaving;  // leaving[v]: a half-edge starting at v
  std::vector<uint8_t> on_border;                // v has an edge without a twin

  static uint32_t next(uint32_t h) { return h - h % 3 + (h % 3 + 1) % 3; }
  static uint32_t prev(uint32_t h) { return h - h % 3 + (h % 3 + 2) % 3; }

  HalfEdges(const std::vector<uint32_t>& tri, size_t vertices)
      : twin(tri.size(), kNone), valence(vertices, 0), leaving(vertices, kNone), on_border(vertices, 0) {
    std::vector<std::pair<uint64_t, uint32_t>> keyed(tri.size());  // (undirected edge, half-edge)
    for (uint32_t h = 0; h < tri.size(); ++h) {
      const uint32_t a = tri[h], b = tri[next(h)];
      keyed[h] = {a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a), h};
      leaving[a] = h;
    }
    std::sort(keyed.begin(), keyed.end());
    for (size_t i = 0; i < keyed.size();) {
      size_t j = i;
      while (j < keyed.size() && keyed[j].first == keyed[i].first) ++j;
      const uint32_t a = uint32_t(keyed[i].first >> 32), b = uint32_t(keyed[i].first);
      ++valence[a], ++valence[b];
      const uint32_t h = keyed[i].second, g = j - i == 2 ? keyed[i + 1].second : kNone;
      if (a != b && g != kNone && tri[h] == tri[next(g)] && tri[g] == tri[next(h)]) {
        twin[h] = g, twin[g] = h;
      } else {
        on_border[a] = on_border[b] = 1;
      }
      i = j;
    }
  }

  // Whether an edge joins a and b: the half-edges leaving a, turning both ways from one of them
  // (a fan may be open at a border).
  bool joined(const std::vector<uint32_t>& tri, uint32_t a, uint32_t b) const {
    const uint32_t start = leaving[a];
    for (uint32_t h = start;;) {
      if (tri[next(h)] == b) return true;
      h = twin[prev(h)];
      if (h == kNone) break;
      if (h == start) return false;
    }
    for (uint32_t h = start;;) {
      if (tri[prev(h)] == b) return true;
      const uint32_t g = twin[h];
      if (g == kNone) return false;
      h = next(g);
      if (h == start) return false;
    }
  }
};

struct Sample {
  double x[3];
  double weight;    // a third of its face's area
  double d2;        // squared distance to its owner
  double point[3];  // its closest point on its owner, at the positions it was measured at
  uint32_t owner;
};

}  // namespace

namespace detail {

FitCounts fit_coarse_mesh(Mesh& coarse, const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t passes,
                          bool swaps, double swap_min_angle_deg, unsigned threads) {
  FitCounts counts;
  const size_t n = coarse.vertex_count(), faces = mesh.face_count(), triangles = coarse.face_count();
  if (passes == 0 || n == 0 || triangles == 0 || labels.size() != faces) return counts;
  std::vector<uint32_t>& tri = coarse.indices;
  HalfEdges edges(tri, n);

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
  if (!(total_area > 0) || !(diagonal > 0)) return counts;
  const double weight_scale = std::ldexp(1.0, 60) / total_area;
  const double residual_scale = std::ldexp(1.0, 60) / (total_area * diagonal);

  // Samples of every stride-th face with a cluster that has triangles.
  std::vector<uint32_t> ring_offsets, ring;  // triangles per coarse vertex (CSR), for the first owners
  coarse_triangle_rings(coarse, ring_offsets, ring);
  const size_t stride = std::max<size_t>(1, 3 * faces / (kSamplesPerVertex * n));
  std::vector<Sample> samples;
  samples.reserve(3 * ((faces + stride - 1) / stride));
  for (size_t f = 0; f < faces; f += stride) {
    const uint32_t c = labels[f];
    if (c >= n || ring_offsets[c] == ring_offsets[c + 1]) continue;
    const double area = face_area(mesh, f);
    if (!(area > 0)) continue;
    double p[3][3];
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) p[j][d] = mesh.positions[3 * size_t(mesh.indices[3 * f + j]) + d];
    for (int k = 0; k < 3; ++k) {
      Sample s;
      for (int d = 0; d < 3; ++d) s.x[d] = (4 * p[k][d] + p[(k + 1) % 3][d] + p[(k + 2) % 3][d]) / 6;
      s.weight = area / 3;
      s.d2 = INFINITY;
      s.point[0] = s.point[1] = s.point[2] = 0;
      s.owner = c;  // the cluster, until the owners are found
      samples.push_back(s);
    }
  }
  WorkerPool pool(threads);
  double scale = diagonal;  // of the coordinates, for the prisms' tolerance
  for (int d = 0; d < 3; ++d) scale = std::max({scale, std::fabs(lo[d]), std::fabs(hi[d])});
  // A triangle the prisms rule out is one the full test would not have found nearer (the
  // tolerance is far above the rounding of either), so the owners are those of full searches.
  TrianglePrisms prisms(1e-9 * scale);
  prisms.build(coarse);
  // The closest of the triangles around the cluster's vertex (ties: the first in the ring). The
  // first whose prism holds the sample is measured first; then, in ring order, the others that
  // could be nearer.
  pool.run(samples.size(), [&](size_t first, size_t last, unsigned) {
    for (size_t i = first; i < last; ++i) {
      Sample& s = samples[i];
      const uint32_t c = s.owner;
      uint32_t guess = kNone;
      for (uint32_t r = ring_offsets[c]; r < ring_offsets[c + 1] && guess == kNone; ++r)
        if (!prisms.farther(ring[r], s.x, 0)) guess = r;
      if (guess == kNone) guess = ring_offsets[c];
      double guess_point[3];
      const double guess_d2 = closest_point_to(coarse, ring[guess], s.x, guess_point);
      for (uint32_t r = ring_offsets[c]; r < ring_offsets[c + 1]; ++r) {
        double d2, point[3];
        if (r == guess) {
          d2 = guess_d2;
          for (int d = 0; d < 3; ++d) point[d] = guess_point[d];
        } else {
          if (prisms.farther(ring[r], s.x, guess_d2)) continue;
          d2 = closest_point_to(coarse, ring[r], s.x, point);
        }
        if (d2 < s.d2) {
          s.d2 = d2, s.owner = ring[r];
          for (int d = 0; d < 3; ++d) s.point[d] = point[d];
        }
      }
    }
  }, kMinParallelSamples);

  // Samples per triangle, kept by the swaps (a swap shares the pair's samples between its two new
  // triangles); rebuilt after each owner update.
  std::vector<std::vector<uint32_t>> owned(triangles);
  auto collect = [&] {
    for (auto& list : owned) list.clear();
    for (uint32_t i = 0; i < samples.size(); ++i) owned[samples[i].owner].push_back(i);
  };

  std::vector<std::vector<int64_t>> partial(pool.size(), std::vector<int64_t>(4 * n));
  auto jacobi_step = [&] {
    pool.run(samples.size(), [&](size_t first, size_t last, unsigned worker) {
      int64_t* acc = partial[worker].data();
      std::fill(acc, acc + 4 * n, int64_t(0));
      for (size_t i = first; i < last; ++i) {
        const Sample& s = samples[i];
        double t[3][3], b[3];
        const double* point = s.point;  // measured at these positions by the owner search or a swap
        corners(coarse, s.owner, t);
        barycentric(point, t[0], t[1], t[2], b);
        for (int j = 0; j < 3; ++j) {
          int64_t* a = &acc[4 * size_t(tri[3 * size_t(s.owner) + j])];
          a[0] += round_half_away(s.weight * b[j] * weight_scale);
          for (int d = 0; d < 3; ++d) a[1 + d] += round_half_away(s.weight * b[j] * (s.x[d] - point[d]) * residual_scale);
        }
      }
    }, kMinParallelSamples);
    for (size_t v = 0; v < n; ++v) {
      int64_t sum[4] = {0, 0, 0, 0};
      for (const std::vector<int64_t>& acc : partial)
        for (int k = 0; k < 4; ++k) sum[k] += acc[4 * v + k];
      if (edges.on_border[v] || edges.leaving[v] == kNone || sum[0] <= 0) continue;
      const double weight = double(sum[0]) / weight_scale;
      bool moved = false;
      for (int d = 0; d < 3; ++d) {
        const float p = float(coarse.positions[3 * v + d] + double(sum[1 + d]) / residual_scale / weight);
        moved |= p != coarse.positions[3 * v + d];
        coarse.positions[3 * v + d] = p;
      }
      counts.moves += moved;
    }
  };
  // The owner or a triangle across one of its edges, whichever is closest (ties: the owner, then
  // the lower edge).
  auto update_owners = [&] {
    prisms.build(coarse);
    pool.run(samples.size(), [&](size_t first, size_t last, unsigned) {
      for (size_t i = first; i < last; ++i) {
        Sample& s = samples[i];
        const uint32_t t = s.owner;
        s.d2 = closest_point_to(coarse, t, s.x, s.point);
        for (int k = 0; k < 3; ++k) {
          const uint32_t g = edges.twin[3 * size_t(t) + k];
          if (g == kNone || prisms.farther(g / 3, s.x, s.d2)) continue;
          double point[3];
          const double d2 = closest_point_to(coarse, g / 3, s.x, point);
          if (d2 < s.d2) {
            s.d2 = d2, s.owner = g / 3;
            for (int d = 0; d < 3; ++d) s.point[d] = point[d];
          }
        }
      }
    }, kMinParallelSamples);
  };

  const double angle_floor = swap_min_angle_deg * std::numbers::pi / 180;
  const double thin_floor = std::min(swap_min_angle_deg, kThinSwapAngleFloorDeg) * std::numbers::pi / 180;
  // The smallest angle of the coarse triangle (a, b, c) of vertex ids, radians (triangle_angle.h).
  auto vertex_angle = [&](uint32_t a, uint32_t b, uint32_t c) {
    return smallest_angle(&coarse.positions[3 * size_t(a)], &coarse.positions[3 * size_t(b)],
                          &coarse.positions[3 * size_t(c)]);
  };
  std::vector<double> triangle_angle(triangles);  // smallest angle of each triangle, during the swaps
  std::vector<uint32_t> touched(n, 0);  // the swap pass (from 1) that last changed a vertex's fan
  std::vector<uint32_t> pair;
  std::vector<double> to_first, to_second, points_first, points_second;
  uint32_t swap_pass = 0;
  // Tests edge h (the lower half-edge of its pair) and swaps it if that pays; true if swapped.
  auto try_swap = [&](uint32_t h) {
    const uint32_t g = edges.twin[h];
    const uint32_t t1 = h / 3, t2 = g / 3;
    const uint32_t u = tri[h], v = tri[HalfEdges::next(h)], c = tri[HalfEdges::prev(h)], d = tri[HalfEdges::prev(g)];
    if (c == d || owned[t1].size() + owned[t2].size() == 0) return false;
    if (edges.valence[u] <= (edges.on_border[u] ? 2u : 3u) || edges.valence[v] <= (edges.on_border[v] ? 2u : 3u))
      return false;
    const Vec3 pu = mesh_vertex(coarse, u), pv = mesh_vertex(coarse, v), pc = mesh_vertex(coarse, c),
               pd = mesh_vertex(coarse, d);
    const Vec3 n1 = cross(pv - pu, pc - pu), n2 = cross(pu - pv, pd - pv);
    const double l1 = length(n1), l2 = length(n2);
    if (!(l1 > 0) || !(l2 > 0)) return false;
    const Vec3 side = (1 / l1) * n1 + (1 / l2) * n2;
    if (!(dot(cross(pu - pc, pd - pc), side) > 0) || !(dot(cross(pv - pd, pc - pd), side) > 0)) return false;
    // (t1 and t2 in their own vertex order: smallest_angle does not depend on the starting corner)
    const double before = std::min(triangle_angle[t1], triangle_angle[t2]);
    const double after = std::min(vertex_angle(c, u, d), vertex_angle(d, v, c));
    // Below the floor only a swap that removes nearly all of the pair's distance (an edge laid
    // along a sharp crease the other diagonal cut across), and never below the thin floor.
    const bool thin = after < std::min(before, angle_floor);
    if ((thin && after < std::min(before, thin_floor)) || edges.joined(tri, c, d)) return false;
    // The pair's samples against the two triangles of the other diagonal; given up as soon as
    // the new sum cannot reach the required gain.
    pair.assign(owned[t1].begin(), owned[t1].end());
    pair.insert(pair.end(), owned[t2].begin(), owned[t2].end());
    double old_error = 0;
    for (uint32_t i : pair) old_error += samples[i].weight * samples[i].d2;
    const double limit = old_error * (1 - (thin ? kThinSwapGain : kSwapGain));
    const double a1[3][3] = {{pc.x, pc.y, pc.z}, {pu.x, pu.y, pu.z}, {pd.x, pd.y, pd.z}};
    const double a2[3][3] = {{pd.x, pd.y, pd.z}, {pv.x, pv.y, pv.z}, {pc.x, pc.y, pc.z}};
    double new_error = 0;
    to_first.resize(pair.size()), to_second.resize(pair.size());
    points_first.resize(3 * pair.size()), points_second.resize(3 * pair.size());
    for (size_t i = 0; i < pair.size() && new_error < limit; ++i) {
      const Sample& s = samples[pair[i]];
      to_first[i] = closest_point_on_triangle(s.x, a1[0], a1[1], a1[2], &points_first[3 * i]);
      to_second[i] = closest_point_on_triangle(s.x, a2[0], a2[1], a2[2], &points_second[3 * i]);
      new_error += s.weight * std::min(to_first[i], to_second[i]);
    }
    if (!(new_error < limit)) return false;
    // Swap: t1 = (c, u, d), t2 = (d, v, c); the four outer half-edges keep their twins.
    std::vector<uint32_t>& twin = edges.twin;
    const uint32_t outer_cu = twin[HalfEdges::prev(h)], outer_vc = twin[HalfEdges::next(h)],
                   outer_ud = twin[HalfEdges::next(g)], outer_dv = twin[HalfEdges::prev(g)];
    tri[3 * t1] = c, tri[3 * t1 + 1] = u, tri[3 * t1 + 2] = d;
    tri[3 * t2] = d, tri[3 * t2 + 1] = v, tri[3 * t2 + 2] = c;
    auto link = [&](uint32_t x, uint32_t y) {
      twin[x] = y;
      if (y != kNone) twin[y] = x;
    };
    link(3 * t1, outer_cu), link(3 * t1 + 1, outer_ud), link(3 * t1 + 2, 3 * t2 + 2);
    link(3 * t2, outer_dv), link(3 * t2 + 1, outer_vc);
    edges.leaving[c] = 3 * t1, edges.leaving[u] = 3 * t1 + 1, edges.leaving[d] = 3 * t2, edges.leaving[v] = 3 * t2 + 1;
    --edges.valence[u], --edges.valence[v], ++edges.valence[c], ++edges.valence[d];
    owned[t1].clear(), owned[t2].clear();
    for (size_t i = 0; i < pair.size(); ++i) {
      Sample& s = samples[pair[i]];
      const bool first = to_first[i] <= to_second[i];
      s.d2 = first ? to_first[i] : to_second[i];
      s.owner = first ? t1 : t2;
      const double* point = first ? &points_first[3 * i] : &points_second[3 * i];
      for (int d = 0; d < 3; ++d) s.point[d] = point[d];
      owned[s.owner].push_back(pair[i]);
    }
    triangle_angle[t1] = vertex_angle(c, u, d);
    triangle_angle[t2] = vertex_angle(d, v, c);
    touched[u] = touched[v] = touched[c] = touched[d] = swap_pass;
    return true;
  };
  // Passes over the edges; the first tests every edge, later ones only edges with a vertex whose
  // fan changed in the pass before or this one.
  auto swap_edges = [&] {
    collect();
    for (uint32_t t = 0; t < triangles; ++t)
      triangle_angle[t] = vertex_angle(tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]);
    for (int pass = 0; pass < kMaxSwapPasses; ++pass) {
      ++swap_pass;
      uint64_t swapped = 0;
      for (uint32_t h = 0; h < tri.size(); ++h) {
        const uint32_t g = edges.twin[h];
        if (g == kNone || g < h) continue;  // each edge once, from its lower half-edge
        if (pass > 0) {
          const uint32_t newest = std::max({touched[tri[h]], touched[tri[HalfEdges::next(h)]],
                                            touched[tri[HalfEdges::prev(h)]], touched[tri[HalfEdges::prev(g)]]});
          if (newest + 1 < swap_pass) continue;
        }
        swapped += try_swap(h);
      }
      counts.swaps += swapped;
      if (swapped == 0) break;
    }
  };

  for (uint32_t pass = 0; pass < passes; ++pass) {
    jacobi_step();
    update_owners();
    if (swaps) swap_edges();
  }
  return counts;
}

void check_fit_angles(const CoarsenOptions& options) {
  if (!(options.fit_swap_min_angle_deg >= 0 && options.fit_swap_min_angle_deg <= 60))
    throw OptionError("coarsen: fit_swap_min_angle_deg must be within [0, 60] degrees");
  if (!(options.fit_min_angle_deg >= 0 && options.fit_min_angle_deg <= 60))
    throw OptionError("coarsen: fit_min_angle_deg must be within [0, 60] degrees");
}

}  // namespace detail

}  // namespace meshcvt
