// meshcvt: per-face data of the clustering problem (Fan et al. eq. 1-6 and Section 4), cluster sums
// in 64-bit fixed point, generators and energies.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <functional>
#include <string>

#include "cluster_engine.h"
#include "meshcvt/error.h"
#include "parallel.h"
#include "triangle_bvh.h"

namespace meshcvt {

ClusterProblem make_cluster_problem(const Mesh& mesh, const ClusterOptions& options, WorkerPool* pool) {
  ClusterProblem pr;
  pr.metric = options.metric;
  pr.clusters = options.clusters;
  size_t nf = mesh.face_count(), nv = mesh.vertex_count();
  if (nf > 0xfffffff0u) throw OptionError("mesh has " + std::to_string(nf) + " faces; at most 4294967280 are supported");
  pr.face_count = uint32_t(nf);
  if (!options.density.empty() && options.density.size() != nf)
    throw OptionError("density has " + std::to_string(options.density.size()) + " values for " + std::to_string(nf) +
                      " faces");
  // Checked before the parallel part, so the message names the first bad face whatever the threads.
  for (size_t f = 0; f < options.density.size(); ++f) {
    const double rho = double(options.density[f]);
    if (!(rho > 0) || !std::isfinite(rho))
      throw OptionError("density of face " + std::to_string(f) + " is " + std::to_string(rho) + "; it must be > 0");
  }
  // The per-face (per-vertex) loops below: each index writes only its own values.
  auto for_ranges = [&](size_t count, const std::function<void(size_t, size_t, unsigned)>& fn) {
    if (pool)
      pool->run(count, fn);
    else
      fn(0, count, 0);
  };

  // Normalize: bounding box into [0,1]^3 with one uniform scale.
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], mesh.positions[3 * v + c]);
      hi[c] = std::max(hi[c], mesh.positions[3 * v + c]);
    }
  float extent = 0;
  for (int c = 0; c < 3; ++c) extent = std::max(extent, hi[c] - lo[c]);
  // Wider than the float range (coordinates near +-3.4e38 on both sides): the normalized faces'
  // areas would overflow, and the fixed-point scale below with them.
  if (std::isinf(extent))
    throw OptionError("the mesh spans more than the float range (its bounding box is wider than 3.4e38): scale it "
                      "down");
  if (!(extent > 0) || !std::isfinite(extent)) extent = 1;
  for (int c = 0; c < 3; ++c) pr.origin[c] = nv ? lo[c] : 0;
  pr.extent = extent;
  const double inv = 1.0 / double(extent);

  pr.point.resize(3 * nf);
  pr.weight.resize(nf);
  if (!options.density.empty() && pr.metric != Metric::l21) pr.area.resize(nf);
  if (pr.metric == Metric::ccvt) {
    pr.normalized_positions.resize(3 * nv);
    for_ranges(nv, [&](size_t first, size_t last, unsigned) {
      for (size_t v = first; v < last; ++v)
        for (int c = 0; c < 3; ++c)
          pr.normalized_positions[3 * v + c] = float((double(mesh.positions[3 * v + c]) - pr.origin[c]) * inv);
    });
  }

  for_ranges(nf, [&](size_t first, size_t last, unsigned) {
    for (size_t f = first; f < last; ++f) {
      double p[3][3];
      for (int j = 0; j < 3; ++j) {
        uint32_t v = mesh.indices[3 * f + j];
        for (int c = 0; c < 3; ++c) p[j][c] = (double(mesh.positions[3 * v + c]) - pr.origin[c]) * inv;
      }
      double e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
      double e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
      double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
      double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      double rho = options.density.empty() ? 1.0 : double(options.density[f]);
      pr.weight[f] = float(0.5 * len * rho);
      if (!pr.area.empty()) pr.area[f] = float(0.5 * len);
      for (int c = 0; c < 3; ++c) {
        if (pr.metric == Metric::l21)
          pr.point[3 * f + c] = len > 0 ? float(n[c] / len) : 0.0f;
        else
          pr.point[3 * f + c] = float((p[0][c] + p[1][c] + p[2][c]) / 3.0);
      }
    }
  });
  double total = 0;  // in face order, as it always was: fixed_scale below depends on it
  for (size_t f = 0; f < nf; ++f) total += pr.weight[f];
  if (!std::isfinite(total)) throw OptionError("the mesh's total area is not finite (a coordinate is NaN or infinite)");
  if (!(total > 0)) throw OptionError("the mesh has zero total area: nothing to cluster");
  // Every sum is bounded by 3 * total weight (|p|^2 <= 3 in the unit box; 1 for normals).
  pr.fixed_scale = std::ldexp(1.0, 61 - int(std::ceil(std::log2(3.0 * total))));

  if (pr.metric == Metric::ccvt)
    pr.bvh = std::make_shared<TriangleBvh>(pr.normalized_positions.data(), mesh.indices.data(), nf);
  return pr;
}

std::vector<int64_t> compute_cluster_sums(const ClusterProblem& problem, const std::vector<uint32_t>& labels,
                                          uint32_t clusters, WorkerPool* pool) {
  const size_t width = size_t(clusters) * kSumComponents;
  auto add_range = [&](size_t begin, size_t end, int64_t* sums) {
    int64_t v[kSumComponents];
    for (size_t f = begin; f < end; ++f) {
      assert(labels[f] < clusters);
      problem.face_fixed(uint32_t(f), v);
      int64_t* s = &sums[size_t(labels[f]) * kSumComponents];
      for (int c = 0; c < kSumComponents; ++c) s[c] += v[c];
    }
  };
  std::vector<int64_t> sums(width, 0);
  // Workers' partial sums cost width per worker: worth it only while that is small next to the faces.
  const unsigned workers = pool ? pool->size() : 1;
  if (workers == 1 || width > problem.face_count) {
    add_range(0, problem.face_count, sums.data());
    return sums;
  }
  std::vector<int64_t> partial(size_t(workers - 1) * width, 0);
  pool->run(problem.face_count, [&](size_t begin, size_t end, unsigned w) {
    add_range(begin, end, w == 0 ? sums.data() : partial.data() + size_t(w - 1) * width);
  });
  for (unsigned w = 1; w < workers; ++w)
    for (size_t i = 0; i < width; ++i) sums[i] += partial[size_t(w - 1) * width + i];
  return sums;
}

void compute_generator(const ClusterProblem& problem, const int64_t sums[kSumComponents], float g[3]) {
  if (sums[0] <= 0) return;  // empty (or weightless) cluster: nothing to move towards
  double W = double(sums[0]);
  double s[3] = {double(sums[1]), double(sums[2]), double(sums[3])};
  if (problem.metric == Metric::l21) {
    double len = std::sqrt((s[0] * s[0] + s[1] * s[1]) + s[2] * s[2]);
    if (!(len > 0)) return;
    for (int c = 0; c < 3; ++c) g[c] = float(s[c] / len);
    return;
  }
  float centroid[3];
  for (int c = 0; c < 3; ++c) centroid[c] = float(s[c] / W);
  if (problem.metric == Metric::ccvt) {
    TriangleBvh::Hit hit = problem.bvh->closest_point(centroid);
    for (int c = 0; c < 3; ++c) g[c] = hit.point[c];
  } else {
    for (int c = 0; c < 3; ++c) g[c] = centroid[c];
  }
}

std::vector<float> generators_of(const ClusterProblem& problem, const std::vector<int64_t>& sums) {
  const size_t clusters = sums.size() / kSumComponents;
  std::vector<float> g(3 * clusters, 0.0f);
  for (size_t c = 0; c < clusters; ++c) compute_generator(problem, &sums[c * kSumComponents], &g[3 * c]);
  return g;
}

double cluster_energy(const ClusterProblem& problem, const int64_t sums[kSumComponents], const float g[3]) {
  if (sums[0] <= 0) return 0;
  double gx = g[0], gy = g[1], gz = g[2];
  double e = double(sums[4]) - 2.0 * (gx * double(sums[1]) + gy * double(sums[2]) + gz * double(sums[3])) +
             (gx * gx + gy * gy + gz * gz) * double(sums[0]);
  return std::max(0.0, e / problem.fixed_scale);
}

double labeling_energy(const ClusterProblem& problem, const std::vector<uint32_t>& labels, uint32_t clusters) {
  std::vector<int64_t> sums = compute_cluster_sums(problem, labels, clusters);
  const std::vector<float> g = generators_of(problem, sums);
  double e = 0;
  for (uint32_t f = 0; f < problem.face_count; ++f) {
    const float* p = &problem.point[3 * f];
    const float* z = &g[3 * size_t(labels[f])];
    double dx = double(p[0]) - z[0], dy = double(p[1]) - z[1], dz = double(p[2]) - z[2];
    e += double(problem.weight[f]) * (dx * dx + dy * dy + dz * dz);
  }
  return e;
}

}  // namespace meshcvt
