// meshcvt: where each cluster's vertex goes in the coarse mesh (Fan et al. Section 6.1, first step
// of uniform coarsening; declared in meshcvt/coarsen.h).
//
//   closest   : the cluster's mesh vertex nearest its mass centroid, the paper's choice (after
//               Valette & Chassery [23]): it "conforms with the spirit of CCVT on a mesh".
//   projected : the closest point of the cluster's own faces to the mass centroid (the CCVT
//               generator, eq. 6, restricted to the cluster), exact point-triangle distances.
//   qem       : the minimizer of the cluster's area-weighted plane quadric (Garland-Heckbert; the
//               paper's second option, after [24]), with a share of the planes just across its
//               border (as ACVD's vertex quadrics), solved by eigen-decomposition with small
//               eigenvalues truncated toward the mass centroid (Lindstrom's robust solve), then
//               clamped toward the centroid to stay near the cluster.
//
// Also here: the input resolution each placement asks for (subdivision_faces_per_cluster): qem wants
// ACVD's 10 vertices per cluster, since its points and lent planes come from the clusters' faces
// and borders, which at a dozen faces per cluster are too coarse for creases.
//
// Everything is one or two linear passes over faces and vertices with per-cluster accumulators in
// double; the order of accumulation is fixed (face order), so the result is deterministic.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>
#include <thread>
#include <unordered_set>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "parallel.h"
#include "symmetric_eigen3.h"
#include "triangle_bvh.h"

namespace meshcvt {

namespace {

// Eigenvalues below this fraction of the largest count as "not constrained by the quadric": a
// cluster on a gently curved or noisy surface keeps its centroid along those directions instead of
// flying off along a nearly flat valley of the quadric.
constexpr double kQemRelativeEigenvalueCutoff = 1e-3;
// The qem point may leave the cluster's bounding box by this fraction of the box diagonal (a ridge
// or corner point lies just outside the box of a cluster whose faces stop short of it).
constexpr double kQemBoxMargin = 0.1;
// Eigenvalues below this fraction of the largest are weak: a direction of theirs is dropped when
// the point would leave the grown box (see solve_quadric). Measured (seventeenth session, all 69
// libcgal-demo meshes at faces / 40): angles below 30 degrees 2862 -> 2748, the median RMS
// distance unchanged (ratios 0.974-1.043); bunny00 -> 500: Hausdorff 1.53 -> 1.13 % of the
// diagonal, refined_elephant -> 1000: 10 -> 2 triangles facing against their clusters.
constexpr double kQemWeakEigenvalue = 0.1;
// The share of the planes of the faces across a cluster's border that its quadric takes (see
// place_qem). Measured on the Table 1 meshes with the fitting (bench/RESULTS.md, fourteenth
// session): fandisk's RMS distance 0.0237-0.0245 % of the diagonal at 0.1, 0.0225-0.0231 at 0.3,
// 0.0225-0.0235 at 1; the smooth meshes' within 1% of each other.
constexpr double kBorderPlaneShare = 0.3;
// Two clusters' qem points nearer than this fraction of the smaller cluster's box diagonal are
// too close (see place_qem).
constexpr double kDistinctPoints = 0.01;
// Faces from which `projected` splits its scan over threads (below, starting them costs more).
constexpr uint32_t kMinParallelProjection = 65536;
// How many faces ahead the passes over all faces ask for their corners' positions. Vertex order
// need not follow face order (bunny-1.2M's does not), and the out-of-order window alone overlaps
// few of those loads: mass centroids 20-25 -> 10-11 ms, the box pass 23-26 -> 16 ms of the
// placement there; no change on meshes that fit the caches (fandisk, bunny00).
constexpr uint32_t kPrefetchFaces = 16;

// The corners of face f in double.
void face_corners(const Mesh& mesh, uint32_t f, double corner[3][3]) {
  for (int j = 0; j < 3; ++j)
    for (int d = 0; d < 3; ++d) corner[j][d] = mesh.positions[3 * size_t(mesh.indices[3 * size_t(f) + j]) + d];
}

}  // namespace

namespace detail {

void check_placement_inputs(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                            const std::vector<float>* face_weights) {
  size_t faces = mesh.face_count();
  // build_topology rejects such meshes; checked again because every pass indexes with them.
  // Whether any is out of range first: a loop without an early exit, vectorized, each element a
  // compare and an or (the checks with a throw inside were 3% of the dual on a small mesh).
  const size_t vertices = mesh.vertex_count();
  uint32_t bad_index = 0;
  if (vertices <= UINT32_MAX) {  // else every index is in range
    const uint32_t limit = uint32_t(vertices);
    for (uint32_t v : mesh.indices) bad_index |= v >= limit;
  }
  if (bad_index) throw OptionError("coarsen: a face has a vertex index out of range");
  if (labels.size() != faces)
    throw OptionError("coarsen: " + std::to_string(labels.size()) + " labels for " + std::to_string(faces) +
                      " faces");
  uint32_t bad_label = 0;
  for (uint32_t label : labels) bad_label |= label >= clusters;
  if (bad_label)
    for (size_t f = 0; f < faces; ++f)
      if (labels[f] >= clusters)
        throw OptionError("coarsen: face " + std::to_string(f) + " has cluster " + std::to_string(labels[f]) +
                          ", not below the cluster count " + std::to_string(clusters));
  if (face_weights && !face_weights->empty()) {
    if (face_weights->size() != faces)
      throw OptionError("coarsen: " + std::to_string(face_weights->size()) + " face weights for " +
                        std::to_string(faces) + " faces");
    for (size_t f = 0; f < faces; ++f) {
      float w = (*face_weights)[f];
      if (!std::isfinite(w) || w < 0)
        throw OptionError("coarsen: face weight " + std::to_string(f) + " is negative or not finite");
    }
  }
}

}  // namespace detail

namespace {

const float* vertex(const Mesh& mesh, uint32_t v) { return &mesh.positions[3 * size_t(v)]; }

// Twice the area vector of the triangle (a, b, c), in double.
inline void face_cross(const float* a, const float* b, const float* c, double n[3]) {
  double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  double w[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

// Twice the area vector of face f, in double.
void face_cross(const Mesh& mesh, size_t f, double n[3]) {
  face_cross(vertex(mesh, mesh.indices[3 * f]), vertex(mesh, mesh.indices[3 * f + 1]),
             vertex(mesh, mesh.indices[3 * f + 2]), n);
}

}  // namespace

namespace detail {

// Mass centroids in double: sum w_k g_k / sum w_k, or the plain mean of face centroids where the
// weights sum to zero (degenerate faces only).
std::vector<double> mass_centroids(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                   const std::vector<float>* face_weights) {
  bool weighted = face_weights && !face_weights->empty();
  // Per cluster, in one cache line: weighted x, y, z, weight, then plain x, y, z, count.
  std::vector<double> sums(8 * size_t(clusters), 0.0);
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    if (f + kPrefetchFaces < mesh.face_count())
      for (int c = 0; c < 3; ++c) __builtin_prefetch(vertex(mesh, mesh.indices[3 * (f + kPrefetchFaces) + c]));
    const float* p[3];
    for (int c = 0; c < 3; ++c) p[c] = vertex(mesh, mesh.indices[3 * f + c]);
    double n[3];
    face_cross(p[0], p[1], p[2], n);
    double w = 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (weighted) w *= (*face_weights)[f];
    double g[3] = {0, 0, 0};
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) g[d] += p[c][d];
    double* ws = &sums[8 * size_t(labels[f])];
    double* ps = ws + 4;
    for (int d = 0; d < 3; ++d) {
      ws[d] += w * (g[d] / 3.0);
      ps[d] += g[d] / 3.0;
    }
    ws[3] += w;
    ps[3] += 1.0;
  }
  std::vector<double> centroids(3 * size_t(clusters), 0.0);
  for (size_t i = 0; i < clusters; ++i) {
    const double* ws = &sums[8 * i];
    const double* ps = ws + 4;
    for (int d = 0; d < 3; ++d) {
      if (ws[3] > 0)
        centroids[3 * i + d] = ws[d] / ws[3];
      else if (ps[3] > 0)
        centroids[3 * i + d] = ps[d] / ps[3];
    }
  }
  return centroids;
}

}  // namespace detail

namespace {

double distance2(const float* p, const double* q) {
  double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
  return dx * dx + dy * dy + dz * dz;
}

// closest: prefer the cluster's own vertices (every incident face in the cluster), which no other
// cluster can pick; clusters without one take the nearest corner of their faces still free.
std::vector<float> place_closest(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                 const std::vector<double>& centroids, const std::vector<uint32_t>& vertex_cluster) {
  std::vector<uint32_t> best_vertex(clusters, kNone);
  std::vector<double> best_d2(clusters, INFINITY);
  size_t vertices = mesh.vertex_count();
  for (size_t v = 0; v < vertices; ++v) {
    uint32_t label = vertex_cluster[v];
    if (label >= clusters) continue;  // on a cluster border, or unused
    double d2 = distance2(vertex(mesh, uint32_t(v)), &centroids[3 * size_t(label)]);
    if (d2 < best_d2[label]) {  // strict: ties keep the lower vertex id
      best_d2[label] = d2;
      best_vertex[label] = uint32_t(v);
    }
  }
  bool missing = false;
  for (uint32_t i = 0; i < clusters; ++i) missing |= best_vertex[i] == kNone;
  if (missing) {
    // Clusters of a few faces have no own vertex: every corner is shared with a neighbour, and two
    // such neighbours would often pick the same one, giving the coarse mesh coincident vertices.
    // Each takes its nearest corner that no cluster before it took (the nearest one if all are).
    struct Candidate {
      uint32_t cluster, vertex;
      double d2;
    };
    std::vector<Candidate> candidates;
    for (size_t f = 0; f < mesh.face_count(); ++f) {
      uint32_t label = labels[f];
      if (best_vertex[label] != kNone) continue;  // has an own vertex
      for (int c = 0; c < 3; ++c) {
        uint32_t v = mesh.indices[3 * f + c];
        candidates.push_back({label, v, distance2(vertex(mesh, v), &centroids[3 * size_t(label)])});
      }
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      if (a.cluster != b.cluster) return a.cluster < b.cluster;
      if (a.d2 != b.d2) return a.d2 < b.d2;
      return a.vertex < b.vertex;
    });
    std::unordered_set<uint32_t> taken;
    for (size_t k = 0; k < candidates.size();) {
      size_t end = k;
      while (end < candidates.size() && candidates[end].cluster == candidates[k].cluster) ++end;
      uint32_t chosen = candidates[k].vertex;
      for (size_t m = k; m < end; ++m)
        if (!taken.count(candidates[m].vertex)) {
          chosen = candidates[m].vertex;
          break;
        }
      best_vertex[candidates[k].cluster] = chosen;
      taken.insert(chosen);
      k = end;
    }
  }
  std::vector<float> positions(3 * size_t(clusters), 0.0f);
  for (uint32_t i = 0; i < clusters; ++i)
    if (best_vertex[i] != kNone)
      for (int d = 0; d < 3; ++d) positions[3 * size_t(i) + d] = vertex(mesh, best_vertex[i])[d];
  return positions;
}

// Squared distance from p to the bounding box of face f: at most its distance to any point of the
// face. From exact differences, so within a few ulps of the true value. Written as p minus p
// clamped to the box, with two-argument min and max: minsd and maxsd, where the initializer-list
// forms or a comparison with zero compile to branches that a face's side of the box makes random.
double box_distance2(const Mesh& mesh, size_t f, const double* p) {
  const float* a = vertex(mesh, mesh.indices[3 * f]);
  const float* b = vertex(mesh, mesh.indices[3 * f + 1]);
  const float* c = vertex(mesh, mesh.indices[3 * f + 2]);
  double sum = 0;
  for (int d = 0; d < 3; ++d) {
    const double lo = std::min(std::min(a[d], b[d]), c[d]), hi = std::max(std::max(a[d], b[d]), c[d]);
    const double gap = p[d] - std::min(std::max(p[d], lo), hi);
    sum += gap * gap;
  }
  return sum;
}

// Per cluster, the least (value, face) seen so far: a smaller value wins, a tie goes to the lower
// face id. With the point-triangle distance as the value, also the closest point.
struct Nearest {
  double value = INFINITY;
  uint32_t face = kNone;
  double point[3] = {0, 0, 0};
};

bool nearer(double value, uint32_t face, const Nearest& than) {
  return value < than.value || (value == than.value && face < than.face);
}

// The closest point of the cluster's own faces to its mass centroid: the face of least exact
// point-triangle distance (ties: the lower face id), O(F) for all clusters and no search structure
// (a BVH over the whole mesh cost more than the clustering of a small mesh). On a surface the
// centroid of a disk-shaped cluster lies over the cluster, so this is the closest point of the
// surface unless another part of the mesh passes nearer than the cluster's own faces; keeping the
// vertex on its own cluster is what the dual wants anyway (vertices stay in cluster order, no two
// clusters trade places).
//
// Few faces get the exact test (on fandisk -> 1000, 2.9 per cluster of 13; in face order with a
// bounding-sphere bound, 60% of all faces): a first pass takes each face's box distance, a lower
// bound of its distance, and per cluster the face of least bound, the seed (usually the face under
// the centroid or next to it). The second starts from the seed's exact distance and tests only the
// faces whose bound is not above the best distance so far. The bound is shrunk far beyond rounding,
// so a face at the same distance is still tested, and the least (distance, face) of the tested
// faces is the least of all faces: skipping changes nothing.
std::vector<float> place_projected(const Mesh& mesh, uint32_t clusters, const std::vector<double>& centroids,
                                   const std::vector<uint32_t>& labels, unsigned threads, std::vector<uint32_t>* faces) {
  // Contiguous ranges of faces side by side (large meshes only: a pool costs its threads' start),
  // each with its own per-cluster answers, merged by the same rule, so the result does not depend
  // on the split.
  const uint32_t nf = uint32_t(labels.size());
  const unsigned parts = nf >= kMinParallelProjection ? std::max(1u, threads == 0 ? std::thread::hardware_concurrency() : threads) : 1;
  std::vector<uint32_t> bounds(parts + 1);
  for (unsigned p = 0; p <= parts; ++p) bounds[p] = uint32_t(uint64_t(nf) * p / parts);
  std::vector<Nearest> part_nearest(size_t(parts) * clusters);
  auto merge_parts = [&] {
    for (unsigned p = 1; p < parts; ++p)
      for (uint32_t c = 0; c < clusters; ++c) {
        const Nearest& other = part_nearest[size_t(p) * clusters + c];
        if (nearer(other.value, other.face, part_nearest[c])) part_nearest[c] = other;
      }
  };
  std::vector<double> face_bound(nf);
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, unsigned part) {
    Nearest* seed = &part_nearest[size_t(part) * clusters];
    for (uint32_t f = begin; f < end; ++f) {
      if (f + kPrefetchFaces < end)
        for (int k = 0; k < 3; ++k) __builtin_prefetch(vertex(mesh, mesh.indices[3 * (size_t(f) + kPrefetchFaces) + k]));
      const uint32_t c = labels[f];
      const double bound = box_distance2(mesh, f, &centroids[3 * size_t(c)]);
      face_bound[f] = bound;
      if (bound < seed[c].value) {  // faces ascend: ties keep the lower id
        seed[c].value = bound;
        seed[c].face = f;
      }
    }
  });
  merge_parts();
  for (uint32_t c = 0; c < clusters; ++c) {
    Nearest& seed = part_nearest[c];
    if (seed.face == kNone) continue;  // empty cluster
    double corner[3][3];
    face_corners(mesh, seed.face, corner);
    seed.value = closest_point_on_triangle(&centroids[3 * size_t(c)], corner[0], corner[1], corner[2], seed.point);
  }
  for (unsigned p = 1; p < parts; ++p)
    std::copy(part_nearest.begin(), part_nearest.begin() + clusters, part_nearest.begin() + size_t(p) * clusters);
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, unsigned part) {
    Nearest* best = &part_nearest[size_t(part) * clusters];
    for (uint32_t f = begin; f < end; ++f) {
      const uint32_t c = labels[f];
      if (face_bound[f] * (1 - 1e-9) > best[c].value || f == best[c].face) continue;
      double corner[3][3], point[3];
      face_corners(mesh, f, corner);
      const double d2 = closest_point_on_triangle(&centroids[3 * size_t(c)], corner[0], corner[1], corner[2], point);
      if (nearer(d2, f, best[c])) {
        best[c].value = d2;
        best[c].face = f;
        for (int d = 0; d < 3; ++d) best[c].point[d] = point[d];
      }
    }
  });
  merge_parts();
  if (faces) {
    faces->resize(clusters);
    for (uint32_t c = 0; c < clusters; ++c) (*faces)[c] = part_nearest[c].face;
  }
  std::vector<float> positions(3 * size_t(clusters), 0.0f);
  for (uint32_t c = 0; c < clusters; ++c)
    for (int d = 0; d < 3; ++d) positions[3 * size_t(c) + d] = float(part_nearest[c].point[d]);
  return positions;
}

// The weight (area times face weight; 0 for a degenerate face) and plane (unit normal n, offset d
// with n . x = d, coordinates relative to `origin`) of face f.
double face_plane(const Mesh& mesh, size_t f, const double origin[3], const std::vector<float>* face_weights,
                  double plane[4]) {
  double n[3];
  face_cross(mesh, f, n);
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (!(len > 0)) return 0;  // a degenerate face has no plane
  double w = 0.5 * len;      // area
  if (face_weights && !face_weights->empty()) w *= (*face_weights)[f];
  for (int d = 0; d < 3; ++d) plane[d] = n[d] / len;
  const float* a = vertex(mesh, mesh.indices[3 * f]);
  plane[3] = plane[0] * (a[0] - origin[0]) + plane[1] * (a[1] - origin[1]) + plane[2] * (a[2] - origin[2]);
  return w;
}

// Adds w times the quadric of `plane` to q: A += w n n^T (xx xy xz yy yz zz), b += w d n.
void add_plane(double q[9], double w, const double plane[4]) {
  const double* n = plane;
  q[0] += w * n[0] * n[0];
  q[1] += w * n[0] * n[1];
  q[2] += w * n[0] * n[2];
  q[3] += w * n[1] * n[1];
  q[4] += w * n[1] * n[2];
  q[5] += w * n[2] * n[2];
  q[6] += w * plane[3] * n[0];
  q[7] += w * plane[3] * n[1];
  q[8] += w * plane[3] * n[2];
}

// The minimizer of the quadric q (see add_plane) for a cluster with bounding box bb and mass
// centroid c (coordinates relative to the origin), into x.
void solve_quadric(const double q[9], const double bb[6], const double c[3], double out[3]) {
  double m[3][3] = {{q[0], q[1], q[2]}, {q[1], q[3], q[4]}, {q[2], q[4], q[5]}};
  // Minimize x^T A x - 2 b^T x: x = c + sum over kept eigenpairs of (u . (b - A c)) / lambda u.
  double r[3];
  for (int d = 0; d < 3; ++d) r[d] = q[6 + d] - (m[d][0] * c[0] + m[d][1] * c[1] + m[d][2] * c[2]);
  double values[3], vectors[3][3];
  symmetric_eigen3(m, values, vectors);
  const double largest = std::max({values[0], values[1], values[2]});
  bool kept[3];
  for (int k = 0; k < 3; ++k) kept[k] = largest > 0 && values[k] > kQemRelativeEigenvalueCutoff * largest;
  const double diagonal = std::sqrt((bb[3] - bb[0]) * (bb[3] - bb[0]) + (bb[4] - bb[1]) * (bb[4] - bb[1]) +
                                    (bb[5] - bb[2]) * (bb[5] - bb[2]));
  const double margin = kQemBoxMargin * diagonal;
  for (;;) {
    double x[3] = {c[0], c[1], c[2]};
    int weakest = -1;  // the kept direction of smallest eigenvalue
    for (int k = 0; k < 3; ++k) {
      if (!kept[k]) continue;
      if (weakest < 0 || values[k] < values[weakest]) weakest = k;
      const double along = (vectors[0][k] * r[0] + vectors[1][k] * r[1] + vectors[2][k] * r[2]) / values[k];
      for (int d = 0; d < 3; ++d) x[d] += along * vectors[d][k];
    }
    // Clamp: the largest t in [0, 1] keeping c + t (x - c) inside the grown box. c itself is inside
    // (a convex combination of points of the cluster; the box is widened to it against rounding).
    double t = 1.0;
    for (int d = 0; d < 3; ++d) {
      const double lo = std::min(bb[d], c[d]) - margin, hi = std::max(bb[3 + d], c[d]) + margin;
      const double step = x[d] - c[d];
      if (!std::isfinite(step)) {
        t = 0;
        continue;
      }
      if (c[d] + step > hi) t = std::min(t, (hi - c[d]) / step);
      if (c[d] + step < lo) t = std::min(t, (lo - c[d]) / step);
    }
    t = std::max(t, 0.0);
    // A point that would leave the box while its solution takes a weak direction has most likely
    // slid along a valley of the quadric (a curved cluster's faces nearly agree there): clamped, it
    // stood at the box's edge, beside the cluster rather than over it, and its triangles folded
    // over their neighbours (bunny00 -> 500: 4 coarse triangles facing against all three of their
    // clusters). The weakest direction is dropped, and the point solved again: along it the point
    // stays over the cluster; if it still leaves the box, the next weak one goes, then the clamp.
    if (t < 1 && weakest >= 0 && values[weakest] < kQemWeakEigenvalue * largest) {
      kept[weakest] = false;
      continue;
    }
    for (int d = 0; d < 3; ++d) out[d] = c[d] + t * (x[d] - c[d]);
    return;
  }
}

// Flags (keeps_own[max(i, j)] = 1) each pair of the clusters `order` whose points are within
// min(reach[i], reach[j]) of each other: a sweep along a direction oblique to every axis, each
// point looking ahead as far as its own reach (a close pair is within reach[i] of i, and no
// farther apart along a unit direction). Along x, as before, the sweep was quadratic on CAD
// models, whose points share x across a whole plane (a damaged fandisk at twice its faces with
// qem: 84.6 s, 7.1 s now); the pairs found are the same.
void mark_close_points(const std::vector<double>& points, const std::vector<double>& reach,
                       const std::vector<uint32_t>& order, std::vector<uint8_t>& keeps_own) {
  // (1, 2, 3) / sqrt(14) - no axis-aligned plane or 45-degree plane is perpendicular to it.
  const double norm = std::sqrt(14.0), w[3] = {1 / norm, 2 / norm, 3 / norm};
  std::vector<std::pair<double, uint32_t>> along;  // (position along w, cluster), sorted
  along.reserve(order.size());
  double scale = 0;
  for (uint32_t i : order) {
    const double* p = &points[3 * size_t(i)];
    along.push_back({w[0] * p[0] + w[1] * p[1] + w[2] * p[2], i});
    for (int d = 0; d < 3; ++d) scale = std::max(scale, std::fabs(p[d]));
  }
  std::sort(along.begin(), along.end());
  // Rounding of the positions along w stays far below a millionth of a millionth of the scale.
  const double slack = 1e-12 * scale;
  for (size_t k = 0; k < along.size(); ++k) {
    const uint32_t i = along[k].second;
    const double* p = &points[3 * size_t(i)];
    const double limit = along[k].first + reach[i] + slack;
    for (size_t m = k + 1; m < along.size() && along[m].first <= limit; ++m) {
      const uint32_t j = along[m].second;
      const double* q = &points[3 * size_t(j)];
      const double gap2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
      const double close = std::min(reach[i], reach[j]);
      if (gap2 <= close * close) keeps_own[std::max(i, j)] = 1;
    }
  }
}

// topology: when given, clusters also take a share of the planes across their border (see below),
// except those flagged in own_planes_only (when not null).
std::vector<float> place_qem(const Mesh& mesh, const Topology* topology, const std::vector<uint32_t>& labels,
                             uint32_t clusters, const std::vector<double>& centroids,
                             const std::vector<float>* face_weights, const std::vector<uint8_t>* own_planes_only) {
  // Coordinates relative to one mesh vertex keep the plane offsets d small where the mesh sits far
  // from the origin.
  double origin[3] = {0, 0, 0};
  if (mesh.vertex_count() > 0)
    for (int d = 0; d < 3; ++d) origin[d] = mesh.positions[d];
  // Per cluster: A = sum w n n^T (xx xy xz yy yz zz), b = sum w d n, and the bounding box.
  std::vector<double> quadric(9 * size_t(clusters), 0.0), lent(9 * size_t(clusters), 0.0);  // own, lent planes
  std::vector<double> box(6 * size_t(clusters));
  for (uint32_t i = 0; i < clusters; ++i)
    for (int d = 0; d < 3; ++d) {
      box[6 * size_t(i) + d] = INFINITY;
      box[6 * size_t(i) + 3 + d] = -INFINITY;
    }
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    uint32_t label = labels[f];
    double* bb = &box[6 * size_t(label)];
    for (int c = 0; c < 3; ++c) {
      const float* p = vertex(mesh, mesh.indices[3 * f + c]);
      for (int d = 0; d < 3; ++d) {
        bb[d] = std::min(bb[d], p[d] - origin[d]);
        bb[3 + d] = std::max(bb[3 + d], p[d] - origin[d]);
      }
    }
    double plane[4];
    const double w = face_plane(mesh, f, origin, face_weights, plane);
    if (w > 0) add_plane(&quadric[9 * size_t(label)], w, plane);
  }
  if (topology && kBorderPlaneShare > 0) {
    // Each vertex where clusters meet lends every cluster there a share of the planes of its faces
    // that belong to the others (a third of the face per corner, as ACVD's vertex quadrics sum the
    // faces around a vertex). A crease along a cluster border lies in none of the two clusters'
    // own planes, so without these their points stay on their flat sides and the coarse edge
    // between them cuts the crease (fandisk -> 1000: RMS 0.048 -> 0.032 % of the diagonal with the
    // vertex fitting alone); where the surface is smooth the lent planes agree with the own ones.
    // First the clusters meeting at each vertex (CSR; none where one cluster has all its faces),
    // then each face's plane once, lent to the other clusters at each of its corners.
    const std::vector<uint32_t>& offsets = topology->vertex_face_offsets;
    const std::vector<uint32_t>& around = topology->vertex_faces;
    const size_t vertices = offsets.size() - 1;
    std::vector<uint32_t> meeting_offsets(vertices + 1, 0), meeting;
    for (size_t v = 0; v < vertices; ++v) {
      const size_t first = meeting.size();
      for (uint32_t i = offsets[v]; i < offsets[v + 1]; ++i)
        if (std::find(meeting.begin() + first, meeting.end(), labels[around[i]]) == meeting.end())
          meeting.push_back(labels[around[i]]);
      if (meeting.size() - first < 2) meeting.resize(first);
      meeting_offsets[v + 1] = uint32_t(meeting.size());
    }
    for (size_t g = 0; g < mesh.face_count(); ++g) {
      const uint32_t* corner = &mesh.indices[3 * g];
      if (meeting_offsets[corner[0] + 1] == meeting_offsets[corner[0]] &&
          meeting_offsets[corner[1] + 1] == meeting_offsets[corner[1]] &&
          meeting_offsets[corner[2] + 1] == meeting_offsets[corner[2]])
        continue;  // inside its cluster
      double plane[4];
      const double w = face_plane(mesh, g, origin, face_weights, plane) * (kBorderPlaneShare / 3);
      if (!(w > 0)) continue;
      for (int k = 0; k < 3; ++k) {
        for (uint32_t i = meeting_offsets[corner[k]]; i < meeting_offsets[corner[k] + 1]; ++i)
          if (meeting[i] != labels[g]) add_plane(&lent[9 * size_t(meeting[i])], w, plane);
      }
    }
  }
  // Each cluster's point with the lent planes; where two clusters' points nearly meet (two
  // clusters at a corner of the surface both pulled onto it), the later cluster keeps the point of
  // its own planes: coincident vertices would give the dual degenerate triangles.
  std::vector<double> points(3 * size_t(clusters), 0.0), reach(clusters, -1.0);
  std::vector<uint32_t> order;  // the clusters with faces
  auto solve = [&](uint32_t i, bool with_lent) {
    double c[3], q[9];
    for (int d = 0; d < 3; ++d) c[d] = centroids[3 * size_t(i) + d] - origin[d];
    for (int k = 0; k < 9; ++k) q[k] = quadric[9 * size_t(i) + k] + (with_lent ? lent[9 * size_t(i) + k] : 0.0);
    solve_quadric(q, &box[6 * size_t(i)], c, &points[3 * size_t(i)]);
  };
  for (uint32_t i = 0; i < clusters; ++i) {
    const double* bb = &box[6 * size_t(i)];
    if (!(bb[0] <= bb[3])) continue;  // empty cluster
    solve(i, true);
    reach[i] = kDistinctPoints * std::sqrt((bb[3] - bb[0]) * (bb[3] - bb[0]) + (bb[4] - bb[1]) * (bb[4] - bb[1]) +
                                           (bb[5] - bb[2]) * (bb[5] - bb[2]));
    order.push_back(i);
  }
  if (topology && kBorderPlaneShare > 0) {
    std::vector<uint8_t> keeps_own(clusters, 0);
    if (own_planes_only) keeps_own = *own_planes_only;
    mark_close_points(points, reach, order, keeps_own);
    for (uint32_t i : order)
      if (keeps_own[i]) solve(i, false);
  }
  std::vector<float> positions(3 * size_t(clusters), 0.0f);
  for (uint32_t i : order)
    for (int d = 0; d < 3; ++d) positions[3 * size_t(i) + d] = float(points[3 * size_t(i) + d] + origin[d]);
  return positions;
}

}  // namespace

namespace detail {

std::vector<float> place_cluster_vertices(const Mesh& mesh, const Topology* topology,
                                          const std::vector<uint32_t>& labels, uint32_t clusters,
                                          VertexPlacement placement, const std::vector<float>* face_weights,
                                          const std::vector<uint32_t>& vertex_cluster,
                                          const std::vector<double>& centroids, unsigned threads,
                                          std::vector<uint32_t>* faces, const std::vector<uint8_t>* own_planes_only) {
  if (faces) faces->clear();  // unknown unless the placement knows it
  switch (placement) {
    case VertexPlacement::closest:
      return place_closest(mesh, labels, clusters, centroids, vertex_cluster);
    case VertexPlacement::projected:
      return place_projected(mesh, clusters, centroids, labels, threads, faces);
    case VertexPlacement::qem:
      return place_qem(mesh, topology, labels, clusters, centroids, face_weights, own_planes_only);
  }
  throw OptionError("coarsen: unknown vertex placement");
}

}  // namespace detail

std::vector<float> cluster_mass_centroids(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                          const std::vector<float>* face_weights) {
  detail::check_placement_inputs(mesh, labels, clusters, face_weights);
  std::vector<double> centroids = detail::mass_centroids(mesh, labels, clusters, face_weights);
  return std::vector<float>(centroids.begin(), centroids.end());
}

std::vector<float> place_cluster_vertices(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                          VertexPlacement placement, const std::vector<float>* face_weights) {
  detail::check_placement_inputs(mesh, labels, clusters, face_weights);
  if (clusters > 0x7ffffffdu) throw OptionError("coarsen: too many clusters (" + std::to_string(clusters) + ")");
  // Each vertex's cluster when all its faces share one (kSeveral otherwise), for `closest`.
  constexpr uint32_t kSeveral = 0x7fffffffu, kUnset = 0x7ffffffeu;
  std::vector<uint32_t> vertex_cluster;
  if (placement == VertexPlacement::closest) {
    vertex_cluster.assign(mesh.vertex_count(), kUnset);
    for (size_t f = 0; f < mesh.face_count(); ++f) {
      const uint32_t* t = &mesh.indices[3 * f];
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) continue;  // collapsed: as coarsen_clustering
      for (int c = 0; c < 3; ++c) {
        uint32_t& state = vertex_cluster[t[c]];
        if (state != labels[f]) state = state == kUnset ? labels[f] : kSeveral;
      }
    }
  }
  Topology topology;  // qem lends clusters the planes across their borders
  if (placement == VertexPlacement::qem) topology = build_topology(mesh);
  return detail::place_cluster_vertices(mesh, placement == VertexPlacement::qem ? &topology : nullptr, labels,
                                        clusters, placement, face_weights, vertex_cluster,
                                        detail::mass_centroids(mesh, labels, clusters, face_weights), 0, nullptr,
                                        nullptr);
}

double subdivision_faces_per_cluster(VertexPlacement placement) {
  return placement == VertexPlacement::qem ? 20.0 : 10.0;
}

bool subdivides_by_default(VertexPlacement placement) { return placement == VertexPlacement::qem; }

VertexPlacement parse_vertex_placement(const std::string& s) {
  if (s == "closest") return VertexPlacement::closest;
  if (s == "projected") return VertexPlacement::projected;
  if (s == "qem") return VertexPlacement::qem;
  throw OptionError("unknown vertex placement '" + s + "' (expected closest, projected or qem)");
}

const char* to_string(VertexPlacement p) {
  switch (p) {
    case VertexPlacement::closest: return "closest";
    case VertexPlacement::projected: return "projected";
    case VertexPlacement::qem: return "qem";
  }
  return "?";
}

}  // namespace meshcvt
