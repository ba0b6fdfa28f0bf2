// meshcvt: keeping clusters valid — connectivity repair of Fan et al. Section 5.3, restoring the
// cluster count afterwards, and the validity check behind the final guarantees.
//
// Repair: a cluster split into several pieces keeps its largest piece (by weight); the faces of the
// other pieces go to the closest adjacent cluster (distance to its generator), in rounds that each
// read the state at their start, so the result does not depend on visiting order. A cluster
// enclosed by a single other cluster (isolated) is dissolved into it — unless that other cluster
// touches nobody else either: then the two are all there is in their mesh component, and the
// situation cannot be avoided.
//
// Restore: empty clusters are re-created by splitting the clusters of highest energy in two
// connected halves grown breadth-first from two far-apart faces (with per-component cluster counts,
// the cluster split is one of the emptied cluster's own mesh component).
#include <algorithm>
#include <cassert>
#include <functional>
#include <numeric>
#include <utility>

#include "boundary_rule.h"
#include "cluster_engine.h"
#include "parallel.h"

namespace meshcvt {

namespace {

struct UnionFind {
  std::vector<uint32_t> parent;
  explicit UnionFind(uint32_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void join(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);  // root = lowest face of the piece
  }
};

// Cluster c is enclosed by a single other cluster that itself has others around it (the test of
// enclosed_clusters), from a check's per-cluster findings.
bool enclosed(const std::vector<uint8_t>& open, const std::vector<uint32_t>& neighbour,
              const std::vector<uint8_t>& several, uint32_t c) {
  const uint32_t n = neighbour[c];
  return !open[c] && n != kNone && !several[c] && several[n];
}

// What nothing_to_repair's walks found when they found something to repair: the per-cluster
// findings (RepairCheck's, without labels) and each cluster's lowest face, where its walk started.
struct ClusterWalks {
  RepairCheck found;
  std::vector<uint32_t> first;
};

// Piece (connected part of a cluster) of every face, as the piece's lowest face id. With `walks`,
// a whole cluster is one piece, its lowest face: only the faces of split clusters are joined.
std::vector<uint32_t> cluster_pieces(const Topology& topology, const std::vector<uint32_t>& labels,
                                     const ClusterWalks* walks = nullptr) {
  uint32_t nf = uint32_t(labels.size());
  auto whole = [&](uint32_t f) { return walks != nullptr && walks->found.whole[labels[f]]; };
  UnionFind uf(nf);
  for (uint32_t f = 0; f < nf; ++f) {
    if (whole(f)) continue;
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
      if (o != kNone && o > f && labels[o] == labels[f]) uf.join(f, o);
    }
  }
  std::vector<uint32_t> piece(nf);
  for (uint32_t f = 0; f < nf; ++f) piece[f] = whole(f) ? walks->first[labels[f]] : uf.find(f);
  return piece;
}

// Isolated clusters (see enclosed_clusters).
std::vector<uint32_t> isolated_clusters(const Topology& topology, const std::vector<uint32_t>& labels,
                                        uint32_t clusters, WorkerPool* pool = nullptr) {
  ClusterGraph graph;
  build_cluster_graph(topology, labels, clusters, graph, pool);
  return enclosed_clusters(graph);
}

// Whether nothing needs repairing: every non-empty cluster is one edge-connected piece (a walk
// from its lowest face reaches all of its faces) and none is enclosed (enclosed_clusters: no mesh
// boundary, one neighbouring cluster, which has two or more). Clusters are walked in parallel, each
// worker marking the faces it reaches in a bit set of its own (a face is reached only by its own
// cluster's walk); the walk also notes the clusters next to each, so no cluster graph is built.
// Without a pool, the same on the calling thread.
// With `memo` holding the check of earlier labels, only the clusters that gained or lost a face
// since, or hold a face next to one that changed cluster, are walked: any other cluster has the
// same faces and the same clusters around them, so the same findings. (A teleport of bunny00 ->
// 100 l21 changes a tenth of the clusters; the full check was ~0.9 ms of each.)
// `walks` (optional) gets the walks' findings when the answer is false.
bool nothing_to_repair(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters,
                       WorkerPool* pool, RepairCheck* memo, ClusterWalks* walks = nullptr) {
  const uint32_t nf = uint32_t(labels.size());
  auto run = [&](size_t count, const std::function<void(size_t, size_t, unsigned)>& fn, size_t min_parallel) {
    if (pool) pool->run(count, fn, min_parallel);
    else fn(0, count, 0);
  };
  const uint32_t* adjacent = topology.face_adjacent.data();
  const uint32_t* label = labels.data();
  std::vector<uint8_t> walked(clusters, 1);  // the clusters to walk
  const bool incremental = memo && memo->labels.size() == nf && memo->whole.size() == clusters;
  if (incremental) {
    std::fill(walked.begin(), walked.end(), uint8_t(0));
    const uint32_t* before = memo->labels.data();
    for (uint32_t f = 0; f < nf; ++f) {
      if (label[f] == before[f]) continue;
      walked[before[f]] = walked[label[f]] = 1;
      for (int e = 0; e < 3; ++e) {
        const uint32_t g = adjacent[3 * size_t(f) + e];
        if (g != kNone) walked[label[g]] = 1;
      }
    }
  }
  // Each cluster's lowest face and size, per worker over its range of faces, then merged.
  const unsigned workers = pool ? pool->size() : 1;
  std::vector<uint32_t> worker_first(size_t(workers) * clusters, kNone), worker_size(size_t(workers) * clusters, 0);
  run(nf, [&](size_t begin, size_t end, unsigned w) {
    uint32_t* first = &worker_first[size_t(w) * clusters];
    uint32_t* size = &worker_size[size_t(w) * clusters];
    for (size_t f = begin; f < end; ++f) {
      if (first[label[f]] == kNone) first[label[f]] = uint32_t(f);
      ++size[label[f]];
    }
  }, /*min_parallel=*/2048);
  std::vector<uint32_t> first(clusters, kNone), size(clusters, 0);
  for (unsigned w = 0; w < workers; ++w)  // ranges in increasing face order: the first found is the lowest
    for (uint32_t c = 0; c < clusters; ++c) {
      if (first[c] == kNone) first[c] = worker_first[size_t(w) * clusters + c];
      size[c] += worker_size[size_t(w) * clusters + c];
    }
  std::vector<uint32_t>().swap(worker_first);
  std::vector<uint32_t>().swap(worker_size);

  // Per cluster: whole, open (touches a mesh boundary), its first neighbouring cluster and whether
  // it has a second one.
  std::vector<uint8_t> whole, open, several;
  std::vector<uint32_t> neighbour;
  if (incremental) {
    whole.swap(memo->whole);
    open.swap(memo->open);
    several.swap(memo->several);
    neighbour.swap(memo->neighbour);
    for (uint32_t c = 0; c < clusters; ++c)
      if (walked[c]) whole[c] = 1, open[c] = 0, several[c] = 0, neighbour[c] = kNone;
  } else {
    whole.assign(clusters, 1);
    open.assign(clusters, 0);
    several.assign(clusters, 0);
    neighbour.assign(clusters, kNone);
  }
  run(clusters, [&](size_t begin, size_t end, unsigned) {
    std::vector<uint64_t> marks((size_t(nf) + 63) / 64, 0);
    uint64_t* mark_bits = marks.data();
    // The walk holds at most the cluster's faces: sized once per cluster, written through a
    // pointer (push_back made the compiler reload every array the loop reads after each call).
    std::vector<uint32_t> walk;
    for (size_t c = begin; c < end; ++c) {
      if (first[c] == kNone || !walked[c]) continue;
      if (walk.size() < size[c]) walk.resize(size[c]);
      uint32_t* queue = walk.data();
      queue[0] = first[c];
      size_t tail = 1;
      mark_bits[first[c] >> 6] |= uint64_t(1) << (first[c] & 63);
      uint32_t next_to = kNone;
      bool is_open = false, more = false;
      for (size_t head = 0; head < tail; ++head) {
        const uint32_t f = queue[head];
        for (int e = 0; e < 3; ++e) {
          const uint32_t g = adjacent[3 * size_t(f) + e];
          if (g == kNone) {
            is_open = true;
          } else if (label[g] != c) {
            if (next_to == kNone) next_to = label[g];
            else more |= label[g] != next_to;
          } else if (!(mark_bits[g >> 6] >> (g & 63) & 1)) {
            mark_bits[g >> 6] |= uint64_t(1) << (g & 63);
            queue[tail++] = g;  // a face of c, each once: tail <= size[c]
          }
        }
      }
      whole[c] = tail == size[c];
      open[c] = is_open;
      neighbour[c] = next_to;
      several[c] = more;
    }
  }, /*min_parallel=*/2);
  bool nothing = true;
  for (uint32_t c = 0; c < clusters && nothing; ++c)
    nothing = whole[c] && !enclosed(open, neighbour, several, c);
  if (memo) {
    if (nothing) {
      memo->labels = labels;
      memo->whole.swap(whole);
      memo->open.swap(open);
      memo->several.swap(several);
      memo->neighbour.swap(neighbour);
    } else {
      *memo = RepairCheck{};  // the caller repairs: the labels change in ways not followed here
    }
  }
  if (walks && !nothing) {  // (the memo took the arrays only when nothing is to repair)
    walks->first = std::move(first);
    walks->found.whole = std::move(whole);
    walks->found.open = std::move(open);
    walks->found.several = std::move(several);
    walks->found.neighbour = std::move(neighbour);
  }
  return nothing;
}

}  // namespace

bool repair_connectivity(const ClusterProblem& problem, const Topology& topology, const std::vector<float>& generators,
                         std::vector<uint32_t>& labels, uint32_t clusters, RepairStats& stats, WorkerPool* pool,
                         RepairCheck* check) {
  const uint32_t nf = problem.face_count;
  // The usual case after a run (the topology-preserving step keeps clusters connected): nothing
  // split, nothing enclosed, nothing to do; checked (in parallel with a pool) before the serial
  // work below.
  ClusterWalks walks;
  if (nothing_to_repair(topology, labels, clusters, pool, check, &walks)) return false;
  std::vector<uint32_t> piece = cluster_pieces(topology, labels, &walks);

  // Largest piece of every cluster, by weight, ties to the lower piece id.
  std::vector<double> piece_weight(nf, 0.0);
  for (uint32_t f = 0; f < nf; ++f) piece_weight[piece[f]] += problem.weight[f];
  std::vector<uint32_t> kept(clusters, kNone);
  uint64_t pieces_dropped = 0;
  for (uint32_t f = 0; f < nf; ++f) {
    if (piece[f] != f) continue;  // visit each piece once, at its lowest face
    uint32_t c = labels[f];
    if (kept[c] == kNone) {
      kept[c] = f;
    } else {
      ++pieces_dropped;
      if (piece_weight[f] > piece_weight[kept[c]]) kept[c] = f;
    }
  }
  std::vector<uint8_t> orphan(nf, 0);
  uint64_t orphans = 0;
  for (uint32_t f = 0; f < nf; ++f)
    if (kept[labels[f]] != piece[f]) orphan[f] = 1, ++orphans;

  // Isolated clusters are dissolved into their enclosing cluster. When every cluster is whole the
  // check's walks saw all of each cluster's neighbours: the same test as the cluster graph's.
  std::vector<uint32_t> isolated;
  const RepairCheck& found = walks.found;
  if (std::all_of(found.whole.begin(), found.whole.end(), [](uint8_t w) { return w != 0; })) {
    for (uint32_t c = 0; c < clusters; ++c)
      if (enclosed(found.open, found.neighbour, found.several, c)) isolated.push_back(c);
  } else {
    isolated = isolated_clusters(topology, labels, clusters);
  }
  if (!isolated.empty()) {
    std::vector<uint8_t> dissolve(clusters, 0);
    for (uint32_t c : isolated) dissolve[c] = 1;
    for (uint32_t f = 0; f < nf; ++f)
      if (dissolve[labels[f]] && !orphan[f]) orphan[f] = 1, ++orphans;
    stats.dissolved_isolated += uint32_t(isolated.size());
  }
  if (orphans == 0) return false;
  stats.split_pieces += pieces_dropped;
  stats.reassigned_faces += orphans;

  // Rounds: an orphan next to a settled face joins the closest such neighbouring cluster. The
  // orphans left are kept in a list (in face order), so a round looks at them, not at every face.
  std::vector<uint32_t> frontier, next_labels, left_over;
  left_over.reserve(orphans);
  for (uint32_t f = 0; f < nf; ++f)
    if (orphan[f]) left_over.push_back(f);
  for (uint64_t left = orphans; left > 0;) {
    frontier.clear();
    next_labels.clear();
    for (uint32_t f : left_over) {
      uint32_t best = kNone;
      float best_d = 0;
      for (int e = 0; e < 3; ++e) {
        uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
        if (o == kNone || orphan[o]) continue;
        uint32_t c = labels[o];
        float d = squared_distance(&problem.point[3 * size_t(f)], &generators[3 * size_t(c)]);
        if (best == kNone || better_destination(d, c, best_d, best)) best = c, best_d = d;
      }
      if (best != kNone) frontier.push_back(f), next_labels.push_back(best);
    }
    // Every orphan piece borders a settled face: a mesh component always keeps a piece, since a
    // cluster never leaves the component it started in.
    assert(!frontier.empty());
    if (frontier.empty()) break;
    for (size_t i = 0; i < frontier.size(); ++i) {
      labels[frontier[i]] = next_labels[i];
      orphan[frontier[i]] = 0;
    }
    left -= frontier.size();
    left_over.erase(std::remove_if(left_over.begin(), left_over.end(), [&](uint32_t f) { return !orphan[f]; }),
                    left_over.end());
  }
  return true;
}

uint32_t restore_cluster_count(const ClusterProblem& problem, const Topology& topology,
                               const std::vector<float>& generators, std::vector<uint32_t>& labels,
                               uint32_t clusters, const std::vector<uint32_t>* cluster_component) {
  assert(!cluster_component || cluster_component->size() == clusters);
  const uint32_t nf = problem.face_count;
  uint32_t restored = 0;
  for (;;) {
    std::vector<uint32_t> size(clusters, 0);
    for (uint32_t f = 0; f < nf; ++f) ++size[labels[f]];
    std::vector<uint32_t> empty;
    for (uint32_t c = 0; c < clusters; ++c)
      if (size[c] == 0) empty.push_back(c);
    if (empty.empty()) return restored;
    // Energies of the current clusters about their (current) generators.
    std::vector<double> energy(clusters, 0.0);
    for (uint32_t f = 0; f < nf; ++f) {
      uint32_t c = labels[f];
      energy[c] += double(problem.weight[f]) * squared_distance(&problem.point[3 * size_t(f)], &generators[3 * size_t(c)]);
    }
    std::vector<uint32_t> order;
    for (uint32_t c = 0; c < clusters; ++c)
      if (size[c] >= 2) order.push_back(c);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
      return energy[a] != energy[b] ? energy[a] > energy[b] : a < b;
    });
    // Pairs (cluster to split, empty cluster to fill): the i-th highest energy with the i-th empty;
    // per component when asked, so an empty cluster comes back in the component it was lost from.
    std::vector<std::pair<uint32_t, uint32_t>> pairs;
    if (!cluster_component) {
      for (size_t s = 0; s < std::min(order.size(), empty.size()); ++s) pairs.push_back({order[s], empty[s]});
    } else {
      std::vector<uint8_t> taken(order.size(), 0);
      for (uint32_t e : empty) {
        for (size_t i = 0; i < order.size(); ++i) {
          if (taken[i] || (*cluster_component)[order[i]] != (*cluster_component)[e]) continue;
          taken[i] = 1;
          pairs.push_back({order[i], e});
          break;
        }
      }
    }
    // Empty: cannot happen while every component has at least as many faces as clusters.
    if (pairs.empty()) return restored;
    // faces of each cluster, CSR
    std::vector<uint32_t> offsets(size_t(clusters) + 1, 0), faces(nf);
    for (uint32_t c = 0; c < clusters; ++c) offsets[c + 1] = offsets[c] + size[c];
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (uint32_t f = 0; f < nf; ++f) faces[fill[labels[f]]++] = f;
    std::vector<uint32_t> queue;
    for (auto [c, fresh] : pairs) {
      const uint32_t* members = &faces[offsets[c]];
      uint32_t count = size[c];
      // seed a: farthest from the generator; seed b: farthest from a (ties: lower face id). Both
      // are taken among the faces on c's border with other clusters when it has any: halves grown
      // from two border faces both reach the border, so neither ends up enclosed by the other. (A
      // cluster covering a protrusion, a cap and a band around it, split from its tip and its
      // far rim would give back the cap enclosed by the band, an isolated cluster that repair
      // dissolves again, round after round.)
      // (c by value: clang 14 refuses a structured binding in a lambda's capture.)
      auto on_border = [&, cluster = c](uint32_t f) {
        for (int e = 0; e < 3; ++e) {
          uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
          if (o != kNone && labels[o] != cluster) return true;
        }
        return false;
      };
      bool any_border = false;
      for (uint32_t i = 0; i < count && !any_border; ++i) any_border = on_border(members[i]);
      uint32_t a = kNone, b = kNone;
      float da = -1, db = -1;
      for (uint32_t i = 0; i < count; ++i) {
        if (any_border && !on_border(members[i])) continue;
        float d = squared_distance(&problem.point[3 * size_t(members[i])], &generators[3 * size_t(c)]);
        if (d > da) da = d, a = members[i];
      }
      for (uint32_t i = 0; i < count; ++i) {
        if (members[i] == a || (any_border && !on_border(members[i]))) continue;
        float d = squared_distance(&problem.point[3 * size_t(members[i])], &problem.point[3 * size_t(a)]);
        if (d > db) db = d, b = members[i];
      }
      if (b == kNone)  // a single border face: any other face of c
        for (uint32_t i = 0; i < count && b == kNone; ++i)
          if (members[i] != a) b = members[i];
      assert(b != kNone);
      // Two-source breadth-first growth inside c (its faces marked kNone while unclaimed); b's half
      // becomes the fresh cluster. Faces not reached (c was not connected) stay in c.
      for (uint32_t i = 0; i < count; ++i) labels[members[i]] = kNone;
      labels[a] = c;
      labels[b] = fresh;
      queue.assign({a, b});
      for (size_t head = 0; head < queue.size(); ++head) {
        uint32_t f = queue[head];
        for (int e = 0; e < 3; ++e) {
          uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
          if (o == kNone || labels[o] != kNone) continue;
          labels[o] = labels[f];
          queue.push_back(o);
        }
      }
      for (uint32_t i = 0; i < count; ++i)
        if (labels[members[i]] == kNone) labels[members[i]] = c;
      ++restored;
    }
  }
}

ClusterValidity check_clusters(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters) {
  ClusterValidity v;
  std::vector<uint32_t> piece = cluster_pieces(topology, labels);
  std::vector<uint32_t> pieces(clusters, 0);
  for (uint32_t f = 0; f < labels.size(); ++f)
    if (piece[f] == f) ++pieces[labels[f]];
  for (uint32_t c = 0; c < clusters; ++c) {
    if (pieces[c] == 0) ++v.empty;
    if (pieces[c] > 1) v.split += pieces[c] - 1;
  }
  v.isolated = uint32_t(isolated_clusters(topology, labels, clusters).size());
  return v;
}

}  // namespace meshcvt
