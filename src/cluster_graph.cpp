// meshcvt: which clusters touch which (the cluster graph of a labeling), shared by the Lloyd steps
// (cluster_flood.cpp: candidate clusters, enclosed clusters) and repair (cluster_repair.cpp:
// isolated clusters, dissolved). A counting sort by cluster and a short sort per cluster, O(F),
// in parallel when given a worker pool.
#include <algorithm>
#include <functional>

#include "cluster_engine.h"
#include "parallel.h"

namespace meshcvt {

void build_cluster_graph(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters,
                         ClusterGraph& g, WorkerPool* pool) {
  const uint32_t nf = uint32_t(labels.size()), nc = clusters;
  const uint32_t* adjacent = topology.face_adjacent.data();
  // The faces are cut into one range per worker (the same ranges in both passes, WorkerPool::run
  // splits a count the same way every time); each range counts and then writes its own part of
  // every cluster's list, so the lists come out the same for any thread count once sorted.
  const unsigned parts = pool ? pool->size() : 1;
  auto for_ranges = [&](size_t count, const std::function<void(size_t, size_t, unsigned)>& fn, size_t min_parallel = 2048) {
    if (pool) pool->run(count, fn, min_parallel);
    else fn(0, count, 0);
  };
  std::vector<uint32_t> part_count(size_t(parts) * nc, 0);  // [part][cluster] cross edges
  std::vector<uint8_t> part_open(size_t(parts) * nc, 0);
  for_ranges(nf, [&](size_t begin, size_t end, unsigned part) {
    uint32_t* counts = &part_count[size_t(part) * nc];
    uint8_t* open = &part_open[size_t(part) * nc];
    for (size_t f = begin; f < end; ++f)
      for (int e = 0; e < 3; ++e) {
        uint32_t o = adjacent[3 * f + e];
        if (o == kNone) open[labels[f]] = 1;
        else if (labels[o] != labels[f]) ++counts[labels[f]];
      }
  });
  // part_count becomes each part's first slot in its cluster's list
  g.offsets.assign(nc + 1, 0);
  g.open.assign(nc, 0);
  uint32_t total = 0;
  for (uint32_t c = 0; c < nc; ++c) {
    g.offsets[c] = total;
    for (unsigned p = 0; p < parts; ++p) {
      uint32_t n = part_count[size_t(p) * nc + c];
      part_count[size_t(p) * nc + c] = total;
      total += n;
      g.open[c] |= part_open[size_t(p) * nc + c];
    }
  }
  g.offsets[nc] = total;
  g.neighbours.resize(total);
  for_ranges(nf, [&](size_t begin, size_t end, unsigned part) {
    uint32_t* fill = &part_count[size_t(part) * nc];
    for (size_t f = begin; f < end; ++f)
      for (int e = 0; e < 3; ++e) {
        uint32_t o = adjacent[3 * f + e];
        if (o != kNone && labels[o] != labels[f]) g.neighbours[fill[labels[f]]++] = labels[o];
      }
  });
  g.count.assign(nc, 0);
  for_ranges(nc, [&](size_t begin, size_t end, unsigned) {
    for (size_t c = begin; c < end; ++c) {
      auto first = g.neighbours.begin() + g.offsets[c], last = g.neighbours.begin() + g.offsets[c + 1];
      std::sort(first, last);
      g.count[c] = uint32_t(std::unique(first, last) - first);
    }
  }, /*min_parallel=*/64);  // a sort per cluster
}

std::vector<uint32_t> enclosed_clusters(const ClusterGraph& g) {
  std::vector<uint32_t> enclosed;
  for (uint32_t c = 0; c < g.count.size(); ++c)
    if (!g.open[c] && g.count[c] == 1 && g.count[g.neighbours[g.offsets[c]]] >= 2) enclosed.push_back(c);
  return enclosed;
}

}  // namespace meshcvt
