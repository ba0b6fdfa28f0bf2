// meshcvt: which clusters touch which (the cluster graph of a labeling), shared by the Lloyd steps
// (cluster_flood.cpp: candidate clusters, enclosed clusters) and repair (cluster_repair.cpp:
// isolated clusters, dissolved). A counting sort by cluster and a short sort per cluster, O(F).
#include <algorithm>

#include "cluster_engine.h"

namespace meshcvt {

void build_cluster_graph(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters,
                         ClusterGraph& g) {
  const uint32_t nf = uint32_t(labels.size()), nc = clusters;
  const uint32_t* adjacent = topology.face_adjacent.data();
  g.offsets.assign(nc + 1, 0);
  g.open.assign(nc, 0);
  for (uint32_t f = 0; f < nf; ++f)
    for (int e = 0; e < 3; ++e) {
      uint32_t o = adjacent[3 * size_t(f) + e];
      if (o == kNone) g.open[labels[f]] = 1;
      else if (labels[o] != labels[f]) ++g.offsets[labels[f] + 1];
    }
  for (uint32_t c = 0; c < nc; ++c) g.offsets[c + 1] += g.offsets[c];
  g.neighbours.resize(g.offsets[nc]);
  std::vector<uint32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  for (uint32_t f = 0; f < nf; ++f)
    for (int e = 0; e < 3; ++e) {
      uint32_t o = adjacent[3 * size_t(f) + e];
      if (o != kNone && labels[o] != labels[f]) g.neighbours[fill[labels[f]]++] = labels[o];
    }
  g.count.assign(nc, 0);
  for (uint32_t c = 0; c < nc; ++c) {
    auto begin = g.neighbours.begin() + g.offsets[c], end = g.neighbours.begin() + g.offsets[c + 1];
    std::sort(begin, end);
    g.count[c] = uint32_t(std::unique(begin, end) - begin);
  }
}

std::vector<uint32_t> enclosed_clusters(const ClusterGraph& g) {
  std::vector<uint32_t> enclosed;
  for (uint32_t c = 0; c < g.count.size(); ++c)
    if (!g.open[c] && g.count[c] == 1 && g.count[g.neighbours[g.offsets[c]]] >= 2) enclosed.push_back(c);
  return enclosed;
}

}  // namespace meshcvt
