// meshcvt: Lloyd steps by constrained flooding, between the hierarchical initialization (Fan et al.
// Section 5.1) and the boundary-testing iteration (Section 3.1).
//
// Why: boundary testing moves a cluster border by at most one face per iteration, so a generator
// that must travel k faces needs k iterations, and the iteration count grows with the number of
// faces per cluster. One Lloyd step (Lloyd 1982; on meshes with connectivity kept by a flood, as in
// the partitioning step of Cohen-Steiner, Alliez, Desbrun, "Variational Shape Approximation", 2004)
// moves every border to the bisector of the current generators at once. A few such steps bring the
// clustering close to a CVT in O(F log F) each; the boundary iteration then only polishes.
//
// One step (voronoi_step below): every face takes the nearest generator among its cluster's and the
// adjacent clusters'; each cluster keeps the connected piece around its face nearest to its
// generator, and the other pieces flood to neighbouring clusters, so clusters stay non-empty and
// connected. A step is kept only if it lowers the energy, so the energy never rises before the
// iteration starts.
//
// Momentum: plain Lloyd steps converge slowly (each one closes a fixed fraction of the way), so the
// faces are assigned to generators extrapolated along their last move, g + m (g - g_previous),
// the over-relaxation used to speed up Lloyd's method (e.g. Liu et al., "On centroidal Voronoi
// tessellation - energy smoothness and fast computation", 2009, compare with it). The energy test
// is unchanged (the new clusters' own centroids), and a step that fails it is retried without the
// extrapolation. On the 1.2M bunny -> 10k, with the steps stopping at a 0.5% gain as they then
// did: energy after the steps 9.89e-5 -> 9.48e-5, iterations after them 234 -> 162 (m = 0.8).
//
// Assignments alone: most of a step's time is the walk that keeps each cluster's connected piece
// (and lists the clusters' new neighbours), yet after the first steps it sends only a few faces
// in a million elsewhere. So once a full step gains less than 5%, three steps in four are the
// assignment alone: the faces take their closest generators, the sums follow, and the candidates
// stay those of the last full step. The full step after them restores connected clusters (their
// stray pieces are orphans like any other) and checks enclosed clusters; only a full step can end
// the steps. If it fails, the labels go back to those before the assignments alone, and every step
// after that is full. The energy never rises: each assignment is kept only if it lowers it, and
// the full step after it too. The 4.8M bunny -> 10k: 24 steps 1.50 s -> 26 steps 0.95-0.98 s,
// energy after iterating 9.0698e-5 -> 9.0695e-5; on 494 runs of libcgal-demo meshes (cvt and
// ccvt, 40 / 300 / 1000 clusters) the energies differ by -14% to +5%, geometric mean -0.04%.
#include <algorithm>
#include <bit>
#include <cassert>
#include <utility>

#include "boundary_rule.h"
#include "cluster_engine.h"
#include "parallel.h"

namespace meshcvt {

namespace {

// Extrapolation of the generators in each Lloyd step (see the top of the file); 0: plain Lloyd.
constexpr double kLloydMomentum = 0.8;
// Assignments alone (see the top of the file): kAssignmentOnlySteps of them after each full step,
// once a full step gains less than kAssignmentOnlyBelowGain of the energy.
constexpr uint32_t kAssignmentOnlySteps = 3;
constexpr double kAssignmentOnlyBelowGain = 0.05;

double total_energy(const ClusterProblem& problem, const std::vector<int64_t>& sums, const std::vector<float>& generators) {
  double e = 0;
  for (uint32_t c = 0; c < problem.clusters; ++c)
    e += cluster_energy(problem, &sums[size_t(c) * kSumComponents], &generators[3 * size_t(c)]);
  return e;
}

// Per-worker lists of voronoi_step that keep their capacity from one step to the next.
struct StepScratch {
  std::vector<std::vector<uint64_t>> marks;   // kept faces, a bit set per worker
  std::vector<std::vector<uint32_t>> border;  // faces next to a worker's clusters, in cluster order
};

// One Lloyd step from `generators`, writing the new labels to `out`:
//  1. every face takes the closest generator among its cluster and the clusters adjacent to it
//     (a generator moves by less than a cluster's width per step, so the closest one is nearly
//     always among these; the energy check below catches the rest); ties to the lower cluster id;
//  2. every cluster keeps the edge-connected piece holding its face closest to its generator;
//  3. faces of the other pieces go, in breadth-first order from the kept pieces (faces in id
//     order), to the cluster of the neighbour that reaches them first.
// Also gives, without further passes over the faces, what the caller needs of the new labels:
// their cluster graph (`out_graph`, as build_cluster_graph would make it) and the change of the
// cluster sums (`delta`, clusters x kSumComponents, eq. 8's centroid variations).
// Returns false when a cluster would end up empty (the step is then not used).
// connect false: step 1 alone (an assignment alone): `out` may hold a cluster in pieces, and
// out_graph is `graph`, unchanged.
bool voronoi_step(const ClusterProblem& problem, const Topology& topology, const std::vector<uint32_t>& labels,
                  const ClusterGraph& graph, const std::vector<float>& generators, WorkerPool& pool,
                  std::vector<uint32_t>& out, ClusterGraph& out_graph, std::vector<int64_t>& delta,
                  StepScratch& scratch, bool connect) {
  const uint32_t nf = problem.face_count, nc = problem.clusters;
  const float* point = problem.point.data();
  const uint32_t* adjacent = topology.face_adjacent.data();
  auto distance = [&](uint32_t f, uint32_t c) { return squared_distance(point + 3 * size_t(f), &generators[3 * size_t(c)]); };
  const std::vector<uint32_t>& offsets = graph.offsets;
  const std::vector<uint32_t>& neighbours = graph.neighbours;
  const std::vector<uint32_t>& count = graph.count;
  const unsigned workers = pool.size();
  const size_t width = size_t(nc) * kSumComponents;

  // Each cluster's candidates (its neighbours) listed with their generators side by side: the
  // assignment reads them in order rather than through the neighbour ids (a dependent load per
  // candidate, the largest cost of the assignment on bunny00).
  struct Candidate {
    float g[3];
    uint32_t cluster;
  };
  // A face closer to its own generator than half the distance to the nearest adjacent generator
  // cannot be closer to another (triangle inequality): most faces need one distance. The bound is
  // shrunk a little so float rounding cannot turn a tie into a skip.
  std::vector<float> inner_radius2(nc, 0.0f);
  std::vector<uint32_t> candidate_begin(size_t(nc) + 1, 0);
  for (uint32_t c = 0; c < nc; ++c) candidate_begin[c + 1] = candidate_begin[c] + count[c];
  std::vector<Candidate> candidates(candidate_begin[nc]);
  for (uint32_t c = 0; c < nc; ++c) {
    float nearest = -1;
    Candidate* list = candidates.data() + candidate_begin[c];
    for (uint32_t k = offsets[c]; k < offsets[c] + count[c]; ++k) {
      const uint32_t q = neighbours[k];
      float d = squared_distance(&generators[3 * size_t(c)], &generators[3 * size_t(q)]);
      if (nearest < 0 || d < nearest) nearest = d;
      *list++ = Candidate{{generators[3 * size_t(q)], generators[3 * size_t(q) + 1], generators[3 * size_t(q) + 2]}, q};
    }
    inner_radius2[c] = nearest < 0 ? 0.0f : 0.25f * nearest * 0.999f;
  }

  // Each worker also keeps, per cluster, its face closest to the generator (the new seed), merged
  // below by (distance, face id): the same seeds for any thread count; and adds up the centroid
  // variations of its faces that change cluster (integers: any split gives the same sums).
  std::vector<float> worker_distance(size_t(workers) * nc, 0.0f);
  std::vector<uint32_t> worker_seed(size_t(workers) * nc, kNone);
  std::vector<int64_t> worker_delta(size_t(workers) * width, 0);
  out.resize(nf);
  pool.run(nf, [&](size_t begin, size_t end, unsigned w) {
    float* seed_distance = &worker_distance[size_t(w) * nc];
    uint32_t* seed_face = &worker_seed[size_t(w) * nc];
    int64_t* my_delta = worker_delta.data() + size_t(w) * width;
    // Raw pointers: through the vectors the compiler reloads their data after every store.
    const uint32_t* const label = labels.data();
    const float* const radius2 = inner_radius2.data();
    const float* const generator = generators.data();
    const uint32_t* const first_candidate = candidate_begin.data();
    const Candidate* const candidate = candidates.data();
    uint32_t* const assigned = out.data();
    int64_t v[kSumComponents];
    for (size_t f = begin; f < end; ++f) {
      const float* x = point + 3 * f;
      uint32_t own = label[f], best = own;
      float best_d = squared_distance(x, generator + 3 * size_t(own));
      if (!(best_d < radius2[own])) {
        for (uint32_t k = first_candidate[own]; k < first_candidate[own + 1]; ++k) {
          float d = squared_distance(x, candidate[k].g);
          if (better_destination(d, candidate[k].cluster, best_d, best)) {
            best = candidate[k].cluster;
            best_d = d;
          }
        }
      }
      assigned[f] = best;
      if (best != own) {
        problem.face_fixed(uint32_t(f), v);
        for (int k = 0; k < kSumComponents; ++k) {
          my_delta[size_t(own) * kSumComponents + k] -= v[k];
          my_delta[size_t(best) * kSumComponents + k] += v[k];
        }
      }
      if (seed_face[best] == kNone || best_d < seed_distance[best]) {  // faces in increasing id
        seed_face[best] = uint32_t(f);
        seed_distance[best] = best_d;
      }
    }
  });
  delta.assign(width, 0);
  for (unsigned w = 0; w < workers; ++w)
    for (size_t i = 0; i < width; ++i) delta[i] += worker_delta[size_t(w) * width + i];
  std::vector<int64_t>().swap(worker_delta);
  bool delta_exact = true;  // false once labels change other than through the orphans below
  std::vector<uint32_t> seed(nc, kNone);
  for (uint32_t c = 0; c < nc; ++c) {
    float seed_d = 0;
    for (unsigned w = 0; w < workers; ++w) {  // ranges in increasing face order: ties keep the first
      uint32_t f = worker_seed[size_t(w) * nc + c];
      if (f != kNone && (seed[c] == kNone || worker_distance[size_t(w) * nc + c] < seed_d)) {
        seed[c] = f;
        seed_d = worker_distance[size_t(w) * nc + c];
      }
    }
  }

  if (!connect) {  // the assignment alone (see lloyd_flood_steps); the candidates stay
    if (std::find(seed.begin(), seed.end(), kNone) != seed.end()) return false;
    out_graph = graph;
    return true;
  }

  // Each cluster's face closest to its generator under `assignment` (kNone for a cluster with no
  // face; ties to the lower face id).
  auto closest_faces = [&](const std::vector<uint32_t>& assignment) {
    std::vector<uint32_t> closest(nc, kNone);
    std::vector<float> closest_distance(nc, 0.0f);
    for (uint32_t f = 0; f < nf; ++f) {
      uint32_t c = assignment[f];
      float d = distance(f, c);
      if (closest[c] == kNone || d < closest_distance[c]) {
        closest[c] = f;
        closest_distance[c] = d;
      }
    }
    return closest;
  };
  // A generator nearest to no face (a badly placed cluster) keeps the face of its old cluster
  // closest to it, so every cluster stays non-empty.
  if (std::find(seed.begin(), seed.end(), kNone) != seed.end()) {
    std::vector<uint32_t> old_seed = closest_faces(labels);
    for (uint32_t c = 0; c < nc; ++c)
      if (seed[c] == kNone) out[old_seed[c]] = c;
    seed = closest_faces(out);
    for (uint32_t c = 0; c < nc; ++c)
      if (seed[c] == kNone) return false;  // a forced face was another cluster's only one
    delta_exact = false;
  }

  // Keep each cluster's piece around its seed; the rest become orphans. One cluster at a time, so
  // the walk stays inside one region of the mesh (a joint walk from all seeds hops between clusters
  // at every step and missed the cache on the 1.2M bunny); the pieces are the same either way, and
  // clusters are walked in parallel. Each worker marks the faces it keeps in a bit set of its own:
  // faces of different clusters share cache lines wherever the face order is not spatial, and a
  // shared array of marks written by every worker made two threads no faster than one (bunny00).
  // A face is walked only by its own cluster's walk, so the union of the sets is the kept faces.
  // The walk also lists, per cluster, the faces of other clusters next to its kept faces (their
  // final clusters, known once the orphans are placed, are its neighbours) and whether it
  // reaches a boundary.
  const size_t words = (size_t(nf) + 63) / 64;
  std::vector<std::vector<uint64_t>>& worker_marks = scratch.marks;
  std::vector<std::vector<uint32_t>>& worker_border = scratch.border;
  worker_marks.resize(workers);
  worker_border.resize(workers);
  std::vector<uint32_t> border_begin(nc), border_count(nc);   // cluster c's part of its worker's list
  std::vector<uint32_t> cluster_worker(nc, 0);                // the worker that walked c
  std::vector<size_t> worker_kept(workers, 0);
  out_graph.open.assign(nc, 0);
  pool.run(nc, [&](size_t begin, size_t end, unsigned w) {
    thread_local std::vector<uint32_t> walk;
    std::vector<uint64_t>& marks = worker_marks[w];
    std::vector<uint32_t>& border = worker_border[w];
    marks.assign(words, 0);
    border.clear();
    // Raw pointers and explicit growth in the hot loop: with push_back the compiler reloads every
    // vector's data pointer after each (possibly allocating) call.
    uint64_t* const mark_bits = marks.data();
    const uint32_t* const label = out.data();
    if (walk.size() < 1024) walk.resize(1024);
    if (border.capacity() < 1024) border.reserve(1024);
    border.resize(border.capacity());
    uint32_t* queue = walk.data();
    size_t queue_capacity = walk.size();
    uint32_t* border_list = border.data();
    size_t border_size = 0, border_capacity = border.size();
    for (size_t c = begin; c < end; ++c) {
      border_begin[c] = uint32_t(border_size);
      uint8_t open = 0;
      const uint32_t first = seed[c];
      mark_bits[first >> 6] |= uint64_t(1) << (first & 63);
      queue[0] = first;
      size_t tail = 1;
      for (size_t head = 0; head < tail; ++head) {
        const uint32_t f = queue[head];
        if (tail + 3 > queue_capacity) {  // room for the three neighbours
          walk.resize(2 * queue_capacity);
          queue = walk.data();
          queue_capacity = walk.size();
        }
        if (border_size + 3 > border_capacity) {
          border.resize(2 * border_capacity);
          border_list = border.data();
          border_capacity = border.size();
        }
        for (int e = 0; e < 3; ++e) {
          const uint32_t g = adjacent[3 * size_t(f) + e];
          if (g == kNone) {
            open = 1;
          } else if (label[g] != c) {
            border_list[border_size++] = g;
          } else if (!(mark_bits[g >> 6] >> (g & 63) & 1)) {  // only faces of c: no other walk writes them
            mark_bits[g >> 6] |= uint64_t(1) << (g & 63);
            queue[tail++] = g;
            // Its neighbours are read when it leaves the queue, tens of faces later: the walk's
            // order defeats the hardware prefetcher, and this load was its largest stall (4.8M
            // bunny -> 10k: Lloyd steps 1.70-1.72 -> 1.50-1.53 s).
            __builtin_prefetch(adjacent + 3 * size_t(g));
          }
        }
      }
      border_count[c] = uint32_t(border_size) - border_begin[c];
      cluster_worker[c] = w;
      out_graph.open[c] = open;
      worker_kept[w] += tail;
    }
    border.resize(border_size);
  }, /*min_parallel=*/2);  // a cluster is a walk over its faces: worth a thread from two on
  size_t kept_count = 0;
  for (size_t k : worker_kept) kept_count += k;

  // Orphans (faces outside every kept piece): breadth-first from the kept faces next to them, in
  // face order. Those are found from the orphans (face_adjacent is symmetric), a few percent of
  // the faces, rather than by looking around every kept face.
  std::vector<uint32_t> orphans, orphan_assigned;
  if (kept_count < nf) {
    std::vector<uint64_t> kept_bits;  // union of the workers' marks (a worker without clusters has none)
    for (unsigned w = 0; w < workers; ++w) {
      const std::vector<uint64_t>& marks = worker_marks[w];
      if (marks.size() != words) continue;  // a worker without clusters this step
      if (kept_bits.empty()) kept_bits.assign(words, 0);
      for (size_t i = 0; i < words; ++i) kept_bits[i] |= marks[i];
    }
    auto is_kept = [&](uint32_t f) { return (kept_bits[f >> 6] >> (f & 63) & 1) != 0; };
    auto keep = [&](uint32_t f) { kept_bits[f >> 6] |= uint64_t(1) << (f & 63); };
    for (size_t i = 0; i < words; ++i) {
      uint64_t missing = ~kept_bits[i];
      if (i == words - 1 && nf % 64) missing &= (uint64_t(1) << (nf % 64)) - 1;  // past the last face
      for (; missing; missing &= missing - 1) orphans.push_back(uint32_t(i * 64 + std::countr_zero(missing)));
    }
    orphan_assigned.resize(orphans.size());
    for (size_t i = 0; i < orphans.size(); ++i) orphan_assigned[i] = out[orphans[i]];
    std::vector<uint32_t> queue;
    for (uint32_t g : orphans)
      for (int e = 0; e < 3; ++e) {
        uint32_t f = adjacent[3 * size_t(g) + e];
        if (f != kNone && is_kept(f)) queue.push_back(f);
      }
    std::sort(queue.begin(), queue.end());
    queue.erase(std::unique(queue.begin(), queue.end()), queue.end());
    for (size_t head = 0; head < queue.size(); ++head) {
      uint32_t f = queue[head];
      for (int e = 0; e < 3; ++e) {
        uint32_t g = adjacent[3 * size_t(f) + e];
        if (g != kNone && !is_kept(g)) {
          keep(g);
          out[g] = out[f];
          queue.push_back(g);
        }
      }
    }
    // Faces not reachable through manifold edges from any kept face keep their old label.
    for (uint32_t f : orphans)
      if (!is_kept(f)) out[f] = labels[f];
  }
  for (std::vector<uint64_t>& marks : worker_marks) marks.clear();  // (capacity kept)

  // The sums: the assignment's variations, corrected for the orphans that moved on.
  if (delta_exact) {
    int64_t v[kSumComponents];
    for (size_t i = 0; i < orphans.size(); ++i) {
      const uint32_t f = orphans[i], from = orphan_assigned[i], to = out[f];
      if (from == to) continue;
      problem.face_fixed(f, v);
      for (int k = 0; k < kSumComponents; ++k) {
        delta[size_t(from) * kSumComponents + k] -= v[k];
        delta[size_t(to) * kSumComponents + k] += v[k];
      }
    }
  } else {  // recounted from the labels (rare: a cluster had to be given a face)
    delta.assign(width, 0);
    int64_t v[kSumComponents];
    for (uint32_t f = 0; f < nf; ++f) {
      if (out[f] == labels[f]) continue;
      problem.face_fixed(f, v);
      for (int k = 0; k < kSumComponents; ++k) {
        delta[size_t(labels[f]) * kSumComponents + k] -= v[k];
        delta[size_t(out[f]) * kSumComponents + k] += v[k];
      }
    }
  }

  // The graph of the new labels. A kept face's neighbours are in its walk's list; an orphan gives
  // its pairs both ways (its neighbours' lists missed it, or saw its assigned cluster).
  std::vector<std::pair<uint32_t, uint32_t>> extra;  // (cluster, neighbour)
  for (uint32_t f : orphans)
    for (int e = 0; e < 3; ++e) {
      uint32_t g = adjacent[3 * size_t(f) + e];
      if (g == kNone) {
        out_graph.open[out[f]] = 1;
      } else if (out[g] != out[f]) {
        extra.emplace_back(out[f], out[g]);
        extra.emplace_back(out[g], out[f]);
      }
    }
  std::sort(extra.begin(), extra.end());
  std::vector<uint32_t> extra_begin(size_t(nc) + 1, 0);
  for (const auto& pair : extra) ++extra_begin[pair.first + 1];
  for (uint32_t c = 0; c < nc; ++c) extra_begin[c + 1] += extra_begin[c];
  out_graph.offsets.assign(size_t(nc) + 1, 0);
  for (uint32_t c = 0; c < nc; ++c)
    out_graph.offsets[c + 1] = out_graph.offsets[c] + border_count[c] + (extra_begin[c + 1] - extra_begin[c]);
  out_graph.neighbours.resize(out_graph.offsets[nc]);
  out_graph.count.assign(nc, 0);
  pool.run(nc, [&](size_t begin, size_t end, unsigned) {
    for (size_t c = begin; c < end; ++c) {
      uint32_t* list = out_graph.neighbours.data() + out_graph.offsets[c];  // (data(): the lists may all be empty)
      uint32_t n = 0;
      const uint32_t* border = worker_border[cluster_worker[c]].data() + border_begin[c];
      for (uint32_t i = 0; i < border_count[c]; ++i)
        if (out[border[i]] != c) list[n++] = out[border[i]];
      for (uint32_t i = extra_begin[c]; i < extra_begin[c + 1]; ++i) list[n++] = extra[i].second;
      std::sort(list, list + n);
      out_graph.count[c] = uint32_t(std::unique(list, list + n) - list);
    }
  }, /*min_parallel=*/64);
#ifndef NDEBUG
  {  // the graph and the sums' change are those of the new labels, as if computed from scratch
    ClusterGraph check;
    build_cluster_graph(topology, out, nc, check);
    assert(check.open == out_graph.open && check.count == out_graph.count);
    for (uint32_t c = 0; c < nc; ++c)
      assert(std::equal(check.neighbours.data() + check.offsets[c], check.neighbours.data() + check.offsets[c] + check.count[c],
                        out_graph.neighbours.data() + out_graph.offsets[c]));
    std::vector<int64_t> before = compute_cluster_sums(problem, labels, nc), after = compute_cluster_sums(problem, out, nc);
    for (size_t i = 0; i < width; ++i) assert(after[i] - before[i] == delta[i]);
  }
#endif
  return true;
}

}  // namespace

uint32_t lloyd_flood_steps(const ClusterProblem& problem, const Topology& topology, WorkerPool& pool,
                           std::vector<uint32_t>& labels, uint32_t max_steps, double min_relative_gain,
                           ClusterGraph* final_graph, LloydCounts* counts) {
  if (counts) *counts = LloydCounts{};
  if (problem.clusters == 0 || max_steps == 0) {
    if (final_graph) build_cluster_graph(topology, labels, problem.clusters, *final_graph, &pool);
    return 0;
  }
  std::vector<int64_t> sums = compute_cluster_sums(problem, labels, problem.clusters, &pool);
  std::vector<float> generators = generators_of(problem, sums);
  double energy = total_energy(problem, sums, generators);
  ClusterGraph graph, next_graph;
  build_cluster_graph(topology, labels, problem.clusters, graph, &pool);
  const size_t enclosed = enclosed_clusters(graph).size();
  std::vector<uint32_t> next;
  std::vector<float> previous = generators, guide(generators.size());
  std::vector<int64_t> next_sums, delta;
  StepScratch scratch;
  std::vector<float> next_generators;
  double momentum = kLloydMomentum, next_energy = 0;
  uint32_t kept = 0;
  struct {
    std::vector<uint32_t> labels;
    std::vector<int64_t> sums;
    std::vector<float> generators, previous;
    double energy = 0;
  } checkpoint;                // the state before the last assignment alone
  uint32_t in_row = 0;         // assignments alone since the last full step (0: connected labels)
  bool alternate = false;      // full steps and assignments alone in turn
  bool may_alternate = true;   // false once an assignment alone, or the full step after it, failed
  for (uint32_t step = 0; step < max_steps; ++step) {
    const bool connect = !(alternate && in_row < kAssignmentOnlySteps);
    bool extrapolated = false;  // the guide differs from the generators (else a failure is final)
    for (size_t i = 0; i < generators.size(); ++i) {
      guide[i] = float(double(generators[i]) + momentum * (double(generators[i]) - double(previous[i])));
      extrapolated |= guide[i] != generators[i];
    }
    // A step is taken only if it keeps every cluster, encloses no new one and lowers the energy.
    // A cluster enclosed by one other (the other an annulus around it) would stay so under the
    // topology-preserving iteration until repair dissolves it. The graph of the new labels is
    // also the next step's list of candidate clusters.
    auto try_step = [&] {
      if (!voronoi_step(problem, topology, labels, graph, guide, pool, next, next_graph, delta, scratch, connect)) return false;
      if (connect && enclosed_clusters(next_graph).size() > enclosed) return false;
      next_sums = sums;
      for (size_t i = 0; i < sums.size(); ++i) next_sums[i] += delta[i];
      next_generators = generators_of(problem, next_sums);
      next_energy = total_energy(problem, next_sums, next_generators);
      return next_energy < energy;
    };
    if (!try_step()) {
      if (!connect) {  // an assignment alone failed: a full step from the same state
        alternate = may_alternate = false;
        continue;
      }
      if (in_row > 0) {
        // The full step after assignments alone failed: back to the labels before them, and
        // full steps only from there.
        if (counts) counts->undone += in_row, counts->assignment -= in_row;
        labels.swap(checkpoint.labels);
        sums.swap(checkpoint.sums);
        generators.swap(checkpoint.generators);
        previous.swap(checkpoint.previous);
        energy = checkpoint.energy;
        alternate = may_alternate = false;
        kept -= in_row;
        in_row = 0;
        continue;
      }
      // A plain step that fails would fail again: the first step (no previous generators yet)
      // is never retried. (On l21 the first step nearly always fails: 8 ms of 75k faces saved.)
      if (momentum == 0 || !extrapolated) break;
      momentum = 0;  // the extrapolation overshot: go on with a plain step from here
      previous = generators;
      continue;
    }
    double gain = (energy - next_energy) / energy;
    if (in_row == 0 && !connect) {  // the connected state, kept to go back to (swapped: no copy)
      checkpoint.labels.swap(labels);
      labels.swap(next);  // (`next` gets the checkpoint's old buffer: every step writes it whole)
      checkpoint.sums = sums;
      checkpoint.generators = generators;
      checkpoint.previous = previous;
      checkpoint.energy = energy;
    } else {
      labels.swap(next);
    }
    std::swap(graph, next_graph);
    sums.swap(next_sums);
    previous.swap(generators);
    generators.swap(next_generators);
    energy = next_energy;
    momentum = kLloydMomentum;
    ++kept;
    if (counts) ++(connect ? counts->full : counts->assignment);
    in_row = connect ? 0 : in_row + 1;
    // (The stop and the switch to assignments alone only after full steps: the gain of an
    // assignment alone is not that of a step that keeps the clusters connected.)
    if (connect && gain < min_relative_gain) break;
    if (connect && gain < kAssignmentOnlyBelowGain) alternate = may_alternate;
  }
  if (in_row > 0) {  // max_steps reached after assignments alone: the last connected labels
    if (counts) counts->undone += in_row, counts->assignment -= in_row;
    labels.swap(checkpoint.labels);
    kept -= in_row;
  }
  if (final_graph) *final_graph = std::move(graph);
  return kept;
}

}  // namespace meshcvt
