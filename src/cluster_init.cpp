// meshcvt: initial clusterings.
//
// Hierarchical: Fan et al. Section 5.1, after Garland, Willmott, Heckbert "Hierarchical face
// clustering on polygonal surfaces" (I3D 2001). Faces are nodes of the dual graph; contracting a
// dual edge merges two clusters at the cost
//     F(e_ij) = (|z_ij - z_i|^2 |V_i| + |z_ij - z_j|^2 |V_j|) / (|V_i| + |V_j|)
//             = |V_i| |V_j| |z_i - z_j|^2 / (|V_i| + |V_j|)^2,
// z the cluster's mean point (centroid for cvt/ccvt, mean normal for l21, plus 0.01 times the same
// cost on mean centroids to break the ties of flat regions: kL21PositionWeight). With n·2^k < F <= n·2^(k+1)
// the first level contracts down to n·2^k nodes and k more levels halve the count, ending with
// exactly n connected clusters.
//
// Instead of a global priority queue each level runs rounds of "mutually cheapest" contractions: an
// edge is contracted when it is the cheapest edge of both its endpoints (among nodes not matched
// yet in the round, repeated until the matching is maximal). That is a matching found in O(E)
// without sorting (the paper, too, avoids sorting the big early levels), and the cheapest edge
// overall always qualifies, so every round makes progress. Only a round that would overshoot the
// level's exact node count sorts its candidates. Total O(F log F) at worst, in
// practice a few linear passes over shrinking edge lists. Above 65536 faces the early levels run in
// 2 or 4 spatial parts side by side, one per thread (hierarchical_clustering says how).
//
// Random: seeded region growing (one seed per mesh component first, the rest uniformly at random,
// grown breadth-first), for comparison.
//
// With per-component counts (ClusterOptions::component_clusters) both run component by component,
// so each component gets exactly its count.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <numeric>
#include <string>
#include <type_traits>
#include <utility>

#include "cluster_engine.h"
#include "meshcvt/error.h"
#include "parallel.h"

namespace meshcvt {

namespace {

struct DualEdge {
  uint32_t a, b;  // a < b, node ids of the current level
};

// A plain array that gives memory back when it shrinks. The graph's arrays only ever shrink from
// one round to the next; std::vector can only shrink by copying (shrink_to_fit: old and new both
// live, the peak of the whole initialization on big meshes) or not at all (resize: the pages of the
// unused tail stay resident). realloc to a smaller size trims in place: mremap for the large,
// mmap-backed blocks, a split chunk otherwise.
template <class T>
class ShrinkingArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  ShrinkingArray() = default;
  ShrinkingArray(const ShrinkingArray&) = delete;
  ShrinkingArray& operator=(const ShrinkingArray&) = delete;
  ShrinkingArray(ShrinkingArray&& other) noexcept { *this = std::move(other); }
  ShrinkingArray& operator=(ShrinkingArray&& other) noexcept {
    if (this != &other) {
      std::free(data_);
      data_ = std::exchange(other.data_, nullptr);
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }
  ~ShrinkingArray() { std::free(data_); }

  // n elements of `value` (the old contents are dropped).
  void assign(size_t n, T value) {
    reset(n);
    std::fill(data_, data_ + n, value);
  }
  // n elements left uninitialized (the old contents are dropped).
  void reset(size_t n) {
    std::free(data_);
    data_ = nullptr;
    size_ = 0;
    if (n == 0) return;
    data_ = static_cast<T*>(std::malloc(n * sizeof(T)));
    if (!data_) throw std::bad_alloc();
    size_ = n;
  }
  // Keeps the first n <= size() elements and releases the rest.
  void shrink(size_t n) {
    assert(n <= size_);
    if (n == size_) return;
    if (n == 0) {
      std::free(data_);
      data_ = nullptr;
    } else if (T* p = static_cast<T*>(std::realloc(data_, n * sizeof(T)))) {
      data_ = p;
    }  // (a failed shrink keeps the larger block, still valid)
    size_ = n;
  }

  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T* begin() { return data_; }
  T& operator[](size_t i) {
    assert(i < size_);
    return data_[i];
  }
  const T& operator[](size_t i) const {
    assert(i < size_);
    return data_[i];
  }

 private:
  T* data_ = nullptr;
  size_t size_ = 0;
};

// The faces as the nodes of the first level: their weight and sums computed when asked, so that
// the largest level keeps no copy of them (32 bytes per face for cvt, 56 for l21, at the peak of
// the initialization); later levels store their merged nodes.
struct FaceNodes {
  const ClusterProblem* problem = nullptr;  // null: the graph's nodes are stored
  const Mesh* mesh = nullptr;
  const uint32_t* subset = nullptr;  // node i = face subset[i]; null: node i = face i

  double weight(uint32_t node) const { return problem->weight[face(node)]; }
  // dims values: p, then (dims 6) the centroid in normalized coordinates, or (dims 4) area / w
  void mean(uint32_t node, int dims, double* out) const {
    const uint32_t f = face(node);
    for (int c = 0; c < 3; ++c) out[c] = double(problem->point[3 * size_t(f) + c]);
    if (dims == 4) {
      const double w = problem->weight[f];
      out[3] = w > 0 ? double(problem->area[f]) / w : 0.0;
    }
    if (dims == 6)
      for (int c = 0; c < 3; ++c) {
        double x = 0;
        for (int k = 0; k < 3; ++k) x += mesh->positions[3 * size_t(mesh->indices[3 * size_t(f) + k]) + c];
        out[3 + c] = (x / 3 - problem->origin[c]) / problem->extent;
      }
  }
  // dims values: w p, then (dims 6) w * centroid in normalized coordinates, or (dims 4) the area
  void sum(uint32_t node, int dims, double* out) const {
    mean(node, dims, out);
    const double w = problem->weight[face(node)];
    for (int c = 0; c < 3; ++c) out[c] *= w;
    if (dims == 6)
      for (int c = 3; c < 6; ++c) out[c] *= w;
    if (dims == 4) out[3] = double(problem->area[face(node)]);
  }
  uint32_t face(uint32_t node) const { return subset ? subset[node] : node; }
};

struct DualGraph {
  ShrinkingArray<double> weight;  // per node (empty while `faces` supplies the nodes)
  ShrinkingArray<double> sum;     // dims per node: sum of w p (then, for l21, sum of w * centroid)
  int dims = 3;
  FaceNodes faces;                 // the first level: nodes are faces
  ShrinkingArray<DualEdge> edges;  // may hold duplicates (several mesh edges between two clusters)
  uint32_t nodes = 0;

  double node_weight(uint32_t i) const { return faces.problem ? faces.weight(i) : weight[i]; }
  // Mean point(s) S / W of node i (weight w > 0) into out[dims].
  void node_mean(uint32_t i, double w, double* out) const {
    if (faces.problem) return faces.mean(i, dims, out);
    for (int c = 0; c < dims; ++c) out[c] = sum[dims * size_t(i) + c] / w;
  }
};

// For l21 the paper's cost compares mean normals only, and every merge inside a flat region costs
// exactly 0: which of those ties wins is then decided by face ids, and the levels end with one
// giant region holding small fragments (fandisk -> 32: 31 of 32 clusters enclosed in another,
// energy 2.3 before iterating). The same cost on the mean centroids (normalized coordinates), at
// this small weight, breaks those ties toward compact, even clusters while any real difference of
// normals still dominates. Measured (energy after iterating / iterations): fandisk -> 32
// 0.0887 / 410 -> 0.0278 / 95; refined_elephant -> 120 0.0954 / 247 -> 0.0917 / 167; bunny00 -> 100
// 0.1613 / 354 -> 0.1616 / 150. Weights 0.1 and 1 were worse on bunny00 (513 and 316 iterations).
constexpr double kL21PositionWeight = 0.01;

// F(e_ij) from the nodes' weights and mean points z = S / W (on the first level a face's own point,
// no division; later levels divide the stored sums here rather than keep an array of means, 24
// bytes per face at the peak of the initialization). dims 3; with dims 6 (l21) the second triple
// is the mean centroid and adds kL21PositionWeight times the same cost in positions.
// With a density rho (cvt, ccvt; ClusterProblem::area is then filled), F is multiplied by
// sqrt(rho) of the merged node (its weight over its area), and the graph carries each node's area
// as a fourth sum (dims 4). F alone does not change when every weight in a region is scaled by the
// same factor, so the initial clusters ignored a density that is even within a region, and the
// local iterations after them got only part of the way: 38 / 62 clusters on the rho = 1 / 16
// halves of a grid (n = 100), where an optimal CVT has 20 / 80 (Gersho: cell area ~ rho^-1/2).
// Merging while F sqrt(rho), about area x sqrt(rho) for compact nodes, is the smallest evens out
// exactly that: 18 / 82, and a lower final energy (bench/RESULTS.md, "Coarsening: gradation and
// subdivision"). A uniform density leaves every cost as it was (factor 1), and without a density
// nothing changes at all.
double density_factor(double weight, double area) { return area > 0 ? std::sqrt(weight / area) : 1.0; }

float contraction_cost(const DualGraph& g, uint32_t i, uint32_t j) {
  double wi = g.node_weight(i), wj = g.node_weight(j);
  if (!(wi > 0) || !(wj > 0)) return 0.0f;  // weightless faces merge for free
  if (!g.faces.problem) {
    // Stored nodes: with z = S / W, |z_i - z_j|^2 = |S_i w_j - S_j w_i|^2 / (w_i w_j)^2, so
    // F = |S_i w_j - S_j w_i|^2 / (w_i w_j (w_i + w_j)^2): one division instead of seven
    // (thirteen for l21), the largest cost of the later levels.
    const double* si = &g.sum[size_t(g.dims) * i];
    const double* sj = &g.sum[size_t(g.dims) * j];
    auto squared = [&](int k) {
      double d[3];
      for (int c = 0; c < 3; ++c) d[c] = si[k + c] * wj - sj[k + c] * wi;
      return d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    };
    double d2 = squared(0);
    if (g.dims == 6) d2 += kL21PositionWeight * squared(3);
    double w = wi + wj;
    if (g.dims == 4) return float(d2 / (wi * wj * (w * w)) * density_factor(w, si[3] + sj[3]));
    return float(d2 / (wi * wj * (w * w)));
  }
  double zi[6] = {}, zj[6] = {};  // (zeroed: GCC cannot see that dims entries get written)
  g.node_mean(i, wi, zi);
  g.node_mean(j, wj, zj);
  auto squared = [&](int k) {
    double d[3];
    for (int c = 0; c < 3; ++c) d[c] = zi[k + c] - zj[k + c];
    return d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  };
  double d2 = squared(0);
  if (g.dims == 6) d2 += kL21PositionWeight * squared(3);
  double w = wi + wj;
  if (g.dims == 4) return float(wi * wj * d2 / (w * w) * density_factor(w, zi[3] * wi + zj[3] * wj));
  return float(wi * wj * d2 / (w * w));
}

// Sorts one node's run of edges by upper end. Runs are short (a node has about three neighbours):
// an inline insertion sort, where a std::sort call per node cost more than the sorting. The upper
// ends of a run are distinct, so the order is the same as any sort's.
void sort_by_upper_end(DualEdge* first, DualEdge* last) {
  if (last - first > 16) {
    std::sort(first, last, [](const DualEdge& x, const DualEdge& y) { return x.b < y.b; });
    return;
  }
  for (DualEdge* i = first + (first != last); i < last; ++i) {
    const DualEdge e = *i;
    DualEdge* j = i;
    for (; j > first && (j - 1)->b > e.b; --j) *j = *(j - 1);
    *j = e;
  }
}

// An edge's place in a round's order is its cost's bits above its index. Costs are floats >= 0,
// whose bits order like their values, so one integer comparison orders edges by cost and breaks
// ties by index: every comparison has one answer, and a node's cheapest edge is a plain minimum.
uint32_t float_bits(float cost) {
  assert(cost >= 0.0f);
  uint32_t bits;
  std::memcpy(&bits, &cost, sizeof bits);
  return bits;
}

// The edges of `nodes` nodes from pairs (a, b), a != b, that for_each_pair(emit) gives, called twice
// (to count, then to fill): without repeats (several mesh edges may join two nodes), listed by
// lower end, each run in increasing upper end (as face_graph lists the first level's). A
// counting sort by the lower end and a "last seen" mark per upper end: O(pairs + nodes), no
// comparison sort. `edges` may be the array the pairs are read from (it is written only once both
// calls are done) if it has room for them; start, upper and last_seen are scratch.
template <class ForEachPair>
void unique_edges(uint32_t nodes, const ForEachPair& for_each_pair, ShrinkingArray<DualEdge>& edges,
                  std::vector<uint32_t>& start, std::vector<uint32_t>& upper, std::vector<uint32_t>& last_seen) {
  start.assign(size_t(nodes) + 1, 0);
  for_each_pair([&](uint32_t a, uint32_t b) { ++start[std::min(a, b) + 1]; });
  for (uint32_t i = 0; i < nodes; ++i) start[i + 1] += start[i];
  if (upper.size() < start[nodes]) upper.resize(start[nodes]);
  for_each_pair([&](uint32_t a, uint32_t b) { upper[start[std::min(a, b)]++] = std::max(a, b); });
  if (edges.size() < start[nodes]) edges.reset(start[nodes]);
  last_seen.assign(nodes, kNone);
  size_t kept = 0, from = 0;
  for (uint32_t a = 0; a < nodes; ++a) {
    const size_t to = start[a];  // after the fill, start[a] is the end of a's run
    const size_t run_start = kept;
    for (; from < to; ++from) {
      const uint32_t b = upper[from];
      if (last_seen[b] == a) continue;
      last_seen[b] = a;
      edges[kept++] = DualEdge{a, b};
    }
    sort_by_upper_end(edges.begin() + run_start, edges.begin() + kept);
  }
  edges.shrink(kept);
}

// Scratch arrays of the rounds of one contraction, kept from one round to the next: sizes only fall,
// so later rounds reuse the first round's pages instead of faulting fresh ones in (on the 4.8M
// bunny the initialization spent about a third of its time in page faults). The costs' array
// holds the rebuild's upper ends afterwards, and the matched flags the merge's started flags, so
// those pairs take no more memory than when each was freed before the next.
struct RoundScratch {
  std::vector<uint32_t> cost_bits;  // per edge: the cost's float bits; then the rebuild's upper ends
  std::vector<uint64_t> best;       // per node: key of its cheapest open edge
  std::vector<uint8_t> flags;       // per node: matched; then, per new node, started
  std::vector<uint32_t> chosen, open_edges, start, last_seen;
};

// One round: contract up to `wanted` mutually cheapest edges. Returns the new node id of every old
// node (ids given in increasing order of the lowest old id, so results never depend on hashing or
// threads) and updates the graph in place. The edges' costs are computed on `pool` when given (one
// per edge, so any split gives the same; null: this thread, as the parts do).
std::vector<uint32_t> contract_round(DualGraph& g, uint32_t wanted, WorkerPool* pool, RoundScratch& scratch) {
  const size_t ne = g.edges.size();
  const int dims = g.dims;
  // (keys are made from the costs when needed: half the memory of storing them)
  std::vector<uint32_t>& cost_bits = scratch.cost_bits;
  cost_bits.resize(ne);  // (no zeroing once the first round has grown it)
  auto cost_range = [&](size_t begin, size_t end, unsigned) {
    for (size_t e = begin; e < end; ++e) cost_bits[e] = float_bits(contraction_cost(g, g.edges[e].a, g.edges[e].b));
  };
  if (pool)
    pool->run(ne, cost_range);
  else
    cost_range(0, ne, 0);
  auto key = [&](uint32_t e) { return uint64_t(cost_bits[e]) << 32 | e; };

  // Passes of "mutually cheapest among the still unmatched" grow a matching until it is maximal
  // (or big enough): the costs stay those of the round's start, so one round does the work of
  // several without recomputing them.
  std::vector<uint64_t>& best = scratch.best;
  best.assign(g.nodes, UINT64_MAX);
  std::vector<uint8_t>& matched = scratch.flags;
  matched.assign(g.nodes, 0);
  // A matching has at most nodes / 2 edges: written through a pointer, as push_back in the pick
  // loop made the compiler reload the arrays the loop reads after every call.
  scratch.chosen.resize(g.nodes / 2 + 1);
  uint32_t* const chosen = scratch.chosen.data();
  size_t chosen_count = 0;
  // The edges still open (both ends unmatched) from the second pass on; the first pass takes every
  // edge without listing them, and the list made after it holds only the survivors.
  std::vector<uint32_t>& open_edges = scratch.open_edges;
  open_edges.clear();
  auto consider = [&](uint32_t e) {
    const DualEdge edge = g.edges[e];
    const uint64_t k = key(e);
    best[edge.a] = std::min(best[edge.a], k);
    best[edge.b] = std::min(best[edge.b], k);
  };
  auto pick = [&](uint32_t e) {
    const DualEdge edge = g.edges[e];
    const uint64_t k = key(e);
    if (best[edge.a] == k && best[edge.b] == k) chosen[chosen_count++] = e;
  };
  auto is_open = [&](uint32_t e) { return !matched[g.edges[e].a] && !matched[g.edges[e].b]; };
  for (int pass = 0; pass < 8 && chosen_count < wanted; ++pass) {
    if (pass == 0) {  // (best starts at UINT64_MAX)
      for (uint32_t e = 0; e < ne; ++e) consider(e);
    } else {
      if (pass == 1) {
        size_t count = 0;
        for (uint32_t e = 0; e < ne; ++e) count += is_open(e);
        open_edges.reserve(count);
        for (uint32_t e = 0; e < ne; ++e)
          if (is_open(e)) open_edges.push_back(e);
      } else {
        size_t kept = 0;
        for (uint32_t e : open_edges)
          if (is_open(e)) open_edges[kept++] = e;
        open_edges.resize(kept);
      }
      if (open_edges.empty()) break;
      // Only the ends of open edges are read by this pass: reset those, not every node.
      for (uint32_t e : open_edges) best[g.edges[e].a] = best[g.edges[e].b] = UINT64_MAX;
      for (uint32_t e : open_edges) consider(e);
    }
    const size_t before = chosen_count;
    if (pass == 0)
      for (uint32_t e = 0; e < ne; ++e) pick(e);
    else
      for (uint32_t e : open_edges) pick(e);
    if (chosen_count == before) break;
    for (size_t i = before; i < chosen_count; ++i) matched[g.edges[chosen[i]].a] = matched[g.edges[chosen[i]].b] = 1;
  }
  assert(chosen_count > 0 || ne == 0);
  if (chosen_count > wanted) {  // the cheapest `wanted` (keys are distinct; their order is not needed)
    std::nth_element(chosen, chosen + wanted, chosen + chosen_count,
                     [&](uint32_t x, uint32_t y) { return key(x) < key(y); });
    chosen_count = wanted;
  }


  // New ids in increasing order of a group's lowest node. relabel first holds, at the lower end a
  // of each chosen edge, its partner b > a (no separate partner array: 4 bytes per face at the
  // peak); visiting nodes in increasing order, a value above the node is a partner still to
  // number, one below it an id already given (ids never exceed the node that got them).
  std::vector<uint32_t> relabel(g.nodes, kNone);
  for (size_t i = 0; i < chosen_count; ++i) relabel[g.edges[chosen[i]].a] = g.edges[chosen[i]].b;
  uint32_t next = 0;
  for (uint32_t node = 0; node < g.nodes; ++node) {
    const uint32_t held = relabel[node];
    if (held != kNone && held < node) continue;  // the upper end of a pair, numbered already
    relabel[node] = next;
    if (held != kNone) relabel[held] = next;  // held > node: its partner
    ++next;
  }
  // Merged weights and sums, in place: new ids are given in increasing order of a group's lowest
  // old id, so r = relabel[node] <= node and slot r has already been read when node is reached.
  // (Separate arrays cost 32 bytes per face at the peak.) The group's lowest member starts the sum.
  // On the first level the nodes are faces (FaceNodes): the merged nodes go to new arrays of the
  // new size, in the same order of additions.
  {
    const bool from_faces = g.faces.problem != nullptr;
    if (from_faces) {
      g.weight.assign(next, 0.0);
      g.sum.assign(dims * size_t(next), 0.0);
    }
    std::vector<uint8_t>& started = scratch.flags;  // (the matched flags are dead)
    started.assign(next, 0);
    double scratch[6];
    for (uint32_t node = 0; node < g.nodes; ++node) {
      uint32_t r = relabel[node];
      assert(r <= node);
      const double w = from_faces ? g.faces.weight(node) : g.weight[node];
      const double* s = from_faces ? (g.faces.sum(node, dims, scratch), scratch) : &g.sum[dims * size_t(node)];
      if (!started[r]) {
        started[r] = 1;
        g.weight[r] = w;
        for (int c = 0; c < dims; ++c) g.sum[dims * size_t(r) + c] = s[c];
      } else {
        g.weight[r] += w;
        for (int c = 0; c < dims; ++c) g.sum[dims * size_t(r) + c] += s[c];
      }
    }
    g.faces = FaceNodes{};
    g.weight.shrink(next);
    g.sum.shrink(dims * size_t(next));
  }
  // The new edges, without self-loops, so edge lists shrink with the node count. In place (at most
  // ne of them); the costs' array, dead now, holds the upper ends.
  unique_edges(next, [&](auto&& emit) {
    for (size_t e = 0; e < ne; ++e) {
      const uint32_t a = relabel[g.edges[e].a], b = relabel[g.edges[e].b];
      if (a != b) emit(a, b);
    }
  }, g.edges, scratch.start, cost_bits, scratch.last_seen);
  g.nodes = next;
  return relabel;
}

// The first level's graph: faces as nodes. Node i is face subset[i] for i < count
// (local_of[subset[i]] == i), or face i without a subset. The subset is a union of whole
// components, or part `part` of `part_of` (then only the edges inside the part are kept).
DualGraph face_graph(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology, const uint32_t* subset,
                     uint32_t count, const uint32_t* local_of, const uint8_t* part_of = nullptr, uint8_t part = 0) {
  const uint32_t nf = subset ? count : problem.face_count;
  DualGraph g;
  g.nodes = nf;
  g.dims = problem.metric == Metric::l21 ? 6 : problem.area.empty() ? 3 : 4;
  g.faces = FaceNodes{&problem, &mesh, subset};
  // At most 3 per face (1.5 on a closed manifold mesh): the unused tail is given back below, and
  // its pages were never touched.
  g.edges.reset(3 * size_t(nf));
  size_t edge_count = 0;
  for (uint32_t f = 0; f < nf; ++f) {
    const size_t run_start = edge_count;
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(g.faces.face(f)) + e];
      if (o == kNone) continue;
      if (part_of && part_of[o] != part) continue;  // another part's face
      if (subset) o = local_of[o];  // (a component's neighbour is in the same component)
      if (o > f) g.edges[edge_count++] = DualEdge{f, o};
    }
    // in increasing upper end, as every level's edges: an edge's index then ranks it among equal
    // costs as its end ids would (float_bits)
    sort_by_upper_end(g.edges.begin() + run_start, g.edges.begin() + edge_count);
  }
  g.edges.shrink(edge_count);
  return g;
}

// A halving level contracts nearly every node with a partner, so with one matching per level
// every cluster ends up a union of about 2^k first-level nodes: equal face counts, not equal
// weights. Where the input's triangle sizes vary (scans) the clusters' density is then off over
// whole regions of the mesh, a long-wavelength error that the Lloyd steps remove only slowly
// (the 4.8M bunny -> 10k: the heaviest cluster 12.8x the mean weight, 35 Lloyd steps). So for
// cvt and ccvt the last levels (targets of at most kBalancedLevelsNodesPerCluster nodes per
// cluster) contract at most kBalancedRoundFraction of their nodes per round, with the costs
// recomputed in between: light nodes, cheap to merge, merge again within the level while heavy
// ones wait, as in a global priority queue (Garland et al.). Every level still ends at its exact
// count. 4.8M bunny: heaviest cluster 3.0x the mean, 24 Lloyd steps, energy at convergence
// -1.2%; the 1.2M bunny -2.5%. (With the cap on every level of at most 16n nodes, 0.25 and 0.35
// each left light clusters somewhere: 0.13x the mean on the 131k sphere with 0.25, 0.07x on the
// 4.8M bunny with 0.35, and the latter 42-48 Lloyd steps; bench/RESULTS.md.) Not for l21 (dual
// graphs of 6 dimensions: normals and centroids), whose regions should differ in size (flat parts
// large): there it raised the distortion by up to 20%.
constexpr double kBalancedRoundFraction = 0.3;
constexpr uint64_t kBalancedLevelsNodesPerCluster = 8;

// Contracts g level by level down to each of `targets` in turn and returns the composed
// relabeling (node at entry -> node at the end). When the edges run out before a target, a part
// (`part`) stops there; the whole graph cannot: an error naming the count. pool: threads for the
// costs (null: this thread).
std::vector<uint32_t> contract_levels(DualGraph& g, const std::vector<uint32_t>& targets, WorkerPool* pool, bool part,
                                      uint32_t clusters) {
  std::vector<std::vector<uint32_t>> relabels;
  RoundScratch scratch;
  for (uint32_t target : targets) {
    while (g.nodes > target) {
      if (g.edges.empty()) {
        if (part) break;
        throw OptionError("cannot make " + std::to_string(clusters) + " connected clusters: the face graph has more components");
      }
      uint32_t wanted = g.nodes - target;
      // Balanced levels (see kBalancedRoundFraction; dims 3 or 4: cvt and ccvt): rounds of at most that
      // share of the nodes.
      if (g.dims != 6 && !part && target <= kBalancedLevelsNodesPerCluster * uint64_t(clusters))
        wanted = std::min(wanted, std::max<uint32_t>(1, uint32_t(kBalancedRoundFraction * g.nodes)));
      relabels.push_back(contract_round(g, wanted, pool, scratch));
      // The big early relabelings are folded into the first one at once (one pass over the faces
      // each) rather than kept to the end: 4 bytes per face less at the peak of the rounds.
      // Sizes only fall, so the folded ones are always a prefix of the rounds.
      if (relabels.size() == 2 && 2 * relabels[1].size() >= relabels[0].size()) {
        for (uint32_t& id : relabels[0]) id = relabels[1][id];
        relabels.pop_back();
      }
    }
  }
  if (relabels.empty()) {  // nothing to contract
    std::vector<uint32_t> identity(g.nodes);
    std::iota(identity.begin(), identity.end(), 0u);
    return identity;
  }
  // Compose the rounds' relabelings from the last to the first: O(total nodes), not O(F * rounds).
  for (size_t r = relabels.size(); r-- > 1;) {
    std::vector<uint32_t>& below = relabels[r - 1];
    const std::vector<uint32_t>& above = relabels[r];
    for (uint32_t& id : below) id = above[id];
  }
  return std::move(relabels[0]);
}

// Parts of the mesh contracted side by side (see hierarchical_clustering): one per this many faces,
// rounded down to a power of two, at most kMaxParts. The count depends on the face count only,
// never on the threads, so the result does not either.
constexpr uint32_t kFacesPerPart = 32768;
constexpr uint32_t kMaxParts = 4;
// The parts contract down to the last level of at least this many nodes per cluster; the levels
// after it run on the whole graph, so that clusters form across the parts' borders.
constexpr uint64_t kPartNodesPerCluster = 8;

// Splits the faces into `parts` (a power of two) regions by recursive bisection of their positions
// across the longest side of each region's box. A region is cut at the edge of a histogram bin
// (kSplitBins along the side) nearest to its median: balanced to a fraction of a percent, in a few
// parallel passes over the faces and no array of its own, where computing every centroid and
// sorting for the exact median took 122 ms of the 4.8M bunny's initialization (mostly the
// centroid array: a histogram cut over it took as long). Counts are integers, so the cut does not depend on the threads. A face's
// position: its centroid (the problem's point) for cvt and ccvt, its first corner for l21 (whose
// point is a normal); either serves to group faces by region.
constexpr uint32_t kSplitBins = 4096;
std::vector<uint8_t> spatial_parts(const ClusterProblem& problem, const Mesh& mesh, uint32_t nf, uint32_t parts,
                                   WorkerPool& pool) {
  const bool corner = problem.metric == Metric::l21;
  auto position = [&](size_t f, int c) {
    return corner ? mesh.positions[3 * size_t(mesh.indices[3 * f]) + c] : problem.point[3 * f + c];
  };
  const unsigned workers = pool.size();
  std::vector<uint8_t> part_of(nf, 0);
  for (uint32_t regions = 1; regions < parts; regions *= 2) {
    // Each region's box (per worker, then merged: min and max do not depend on the order).
    std::vector<float> box(size_t(workers) * regions * 6);
    for (size_t i = 0; i < box.size(); i += 6)
      for (int c = 0; c < 3; ++c) box[i + c] = INFINITY, box[i + 3 + c] = -INFINITY;
    pool.run(nf, [&](size_t begin, size_t end, unsigned w) {
      float* mine = &box[size_t(w) * regions * 6];
      for (size_t f = begin; f < end; ++f) {
        float* b = mine + 6 * size_t(part_of[f]);
        for (int c = 0; c < 3; ++c) {
          const float x = position(f, c);
          b[c] = std::min(b[c], x);
          b[3 + c] = std::max(b[3 + c], x);
        }
      }
    });
    std::vector<int> axis(regions, 0);
    std::vector<float> low(regions), scale(regions);
    for (uint32_t r = 0; r < regions; ++r) {
      float lo[3], hi[3];
      for (int c = 0; c < 3; ++c) {
        lo[c] = INFINITY, hi[c] = -INFINITY;
        for (unsigned w = 0; w < workers; ++w) {
          lo[c] = std::min(lo[c], box[(size_t(w) * regions + r) * 6 + c]);
          hi[c] = std::max(hi[c], box[(size_t(w) * regions + r) * 6 + 3 + c]);
        }
      }
      for (int c = 1; c < 3; ++c)
        if (hi[c] - lo[c] > hi[axis[r]] - lo[axis[r]]) axis[r] = c;
      const float side = hi[axis[r]] - lo[axis[r]];
      low[r] = lo[axis[r]];
      scale[r] = side > 0 ? float(kSplitBins) / side : 0.0f;  // (an empty or flat region: one bin)
    }
    auto bin = [&](size_t f, uint32_t r) {
      const float t = (position(f, axis[r]) - low[r]) * scale[r];
      return std::min(kSplitBins - 1, uint32_t(std::max(0.0f, t)));
    };
    std::vector<uint32_t> count(size_t(workers) * regions * kSplitBins, 0);
    pool.run(nf, [&](size_t begin, size_t end, unsigned w) {
      uint32_t* mine = &count[size_t(w) * regions * kSplitBins];
      for (size_t f = begin; f < end; ++f) ++mine[size_t(part_of[f]) * kSplitBins + bin(f, part_of[f])];
    });
    // The cut: the first bin of the upper half, where the count below comes nearest to half.
    std::vector<uint32_t> cut(regions);
    for (uint32_t r = 0; r < regions; ++r) {
      std::vector<uint64_t> below(kSplitBins + 1, 0);
      for (uint32_t b = 0; b < kSplitBins; ++b) {
        uint64_t c = 0;
        for (unsigned w = 0; w < workers; ++w) c += count[(size_t(w) * regions + r) * kSplitBins + b];
        below[b + 1] = below[b] + c;
      }
      const uint64_t total = below[kSplitBins];
      uint32_t best = 1;
      for (uint32_t b = 1; b < kSplitBins; ++b)
        if (std::max(below[b], total - below[b]) < std::max(below[best], total - below[best])) best = b;
      cut[r] = best;
    }
    pool.run(nf, [&](size_t begin, size_t end, unsigned) {
      for (size_t f = begin; f < end; ++f) {
        const uint32_t r = part_of[f];
        part_of[f] = uint8_t(2 * r + (bin(f, r) >= cut[r]));
      }
    });
  }
  return part_of;
}

// A part's result: its faces (increasing ids), its faces' nodes and its graph at the last level it
// reached.
struct PartLevel {
  const uint32_t* faces = nullptr;  // (in the parts' shared list)
  uint32_t count = 0;
  std::vector<uint32_t> node_of;  // per face of the part, in the order of `faces`
  DualGraph graph;
  // Mesh edges to a later part's face: (this part's node, that face), each pair from its lower face.
  std::vector<std::pair<uint32_t, uint32_t>> border;
};

// Clusters the faces listed in `subset` (increasing face ids, a union of whole components) into
// `clusters` clusters; node i of the graph is face subset[i] and local_of[subset[i]] == i. Returns a
// label per listed face. A null subset means every face, node i = face i (local_of unused).
//
// The whole mesh is cut into parts (regions of the surface) that run the early levels, the costly
// ones, each on its own and in parallel, every level's target shared out in proportion to the
// parts' faces; no contraction crosses a part's border there. The parts' graphs are then joined
// (the mesh edges between parts become edges between their nodes), brought to that level's exact
// count and contracted on to n as one graph.
std::vector<uint32_t> hierarchical_clustering(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology,
                                              uint32_t clusters, WorkerPool& pool, const std::vector<uint32_t>* subset = nullptr,
                                              const std::vector<uint32_t>* local_of = nullptr) {
  const uint32_t nf = subset ? uint32_t(subset->size()) : problem.face_count;
  if (clusters >= nf) {
    std::vector<uint32_t> labels(nf);
    std::iota(labels.begin(), labels.end(), 0u);
    return labels;
  }
  // Level targets: n·2^k, n·2^(k-1), ..., n with n·2^k < F <= n·2^(k+1).
  std::vector<uint32_t> targets;
  for (uint64_t t = clusters; t < nf; t *= 2) targets.push_back(uint32_t(t));
  std::reverse(targets.begin(), targets.end());

  // The levels the parts run: those down to the last target of at least kPartNodesPerCluster nodes
  // per cluster (none: no parts).
  size_t part_levels = 0;
  while (part_levels < targets.size() && targets[part_levels] >= kPartNodesPerCluster * clusters) ++part_levels;
  uint32_t parts = 1;
  if (!subset && part_levels > 0)
    while (2 * parts <= kMaxParts && uint64_t(2 * parts) * kFacesPerPart <= nf) parts *= 2;
  if (parts == 1) {
    DualGraph g = face_graph(problem, mesh, topology, subset ? subset->data() : nullptr, nf,
                             local_of ? local_of->data() : nullptr);
    std::vector<uint32_t> labels = contract_levels(g, targets, &pool, false, clusters);
    assert(g.nodes == clusters);
    return labels;
  }

  const std::vector<uint8_t> part_of = spatial_parts(problem, mesh, nf, parts, pool);
  // Each part's faces in increasing id, and a face's place in its part: counted per worker's
  // range of faces, then each range writes its faces after those of the ranges before it.
  // (Both arrays uninitialized: their pages are first touched by the parallel fill, not by a
  // zeroing pass on one thread.)
  std::unique_ptr<uint32_t[]> local(new uint32_t[nf]), part_faces(new uint32_t[nf]);
  std::vector<PartLevel> levels(parts);
  {
    const unsigned workers = pool.size();
    std::vector<uint32_t> range_count(size_t(workers) * parts, 0);
    pool.run(nf, [&](size_t begin, size_t end, unsigned w) {
      for (size_t f = begin; f < end; ++f) ++range_count[size_t(w) * parts + part_of[f]];
    });
    std::vector<uint32_t> part_first(parts, 0);  // the part's first place in part_faces
    for (uint32_t p = 0; p < parts; ++p) {
      if (p > 0) part_first[p] = part_first[p - 1] + levels[p - 1].count;
      levels[p].faces = part_faces.get() + part_first[p];
      for (unsigned w = 0; w < workers; ++w) {
        const uint32_t c = range_count[size_t(w) * parts + p];
        range_count[size_t(w) * parts + p] = levels[p].count;  // now the range's first place in the part
        levels[p].count += c;
      }
    }
    pool.run(nf, [&](size_t begin, size_t end, unsigned w) {
      uint32_t* next = &range_count[size_t(w) * parts];
      for (size_t f = begin; f < end; ++f) {
        const uint8_t p = part_of[f];
        local[f] = next[p]++;
        part_faces[part_first[p] + local[f]] = uint32_t(f);
      }
    });
  }
  pool.run(parts, [&](size_t begin, size_t end, unsigned) {
    for (size_t p = begin; p < end; ++p) {
      const uint64_t count = levels[p].count;
      std::vector<uint32_t> part_targets;
      for (size_t l = 0; l < part_levels; ++l)
        part_targets.push_back(std::max<uint32_t>(1, uint32_t(uint64_t(targets[l]) * count / nf)));
      levels[p].graph = face_graph(problem, mesh, topology, levels[p].faces, levels[p].count, local.get(), part_of.data(),
                                   uint8_t(p));
      levels[p].node_of = contract_levels(levels[p].graph, part_targets, nullptr, true, clusters);
      for (uint32_t i = 0; i < count; ++i) {
        const uint32_t f = levels[p].faces[i];
        for (int k = 0; k < 3; ++k) {
          const uint32_t o = topology.face_adjacent[3 * size_t(f) + k];
          if (o != kNone && o > f && part_of[o] != p) levels[p].border.emplace_back(levels[p].node_of[i], o);
        }
      }
    }
  }, /*min_parallel=*/2);

  // The joined graph: part p's nodes numbered from node_base[p], their sums side by side; the
  // parts' edges and the mesh edges between parts.
  const int dims = levels[0].graph.dims;
  std::vector<uint32_t> node_base(parts + 1, 0);
  for (uint32_t p = 0; p < parts; ++p) node_base[p + 1] = node_base[p] + levels[p].graph.nodes;
  const uint32_t nodes = node_base[parts];
  DualGraph g;
  g.dims = dims;
  g.nodes = nodes;
  g.weight.reset(nodes);
  g.sum.reset(size_t(dims) * nodes);
  for (uint32_t p = 0; p < parts; ++p) {
    DualGraph& part = levels[p].graph;
    for (uint32_t i = 0; i < part.nodes; ++i) {
      const uint32_t node = node_base[p] + i;
      g.weight[node] = part.node_weight(i);
      if (part.faces.problem)  // a part that did not contract (its nodes are still faces)
        part.faces.sum(i, dims, &g.sum[size_t(dims) * node]);
      else
        for (int c = 0; c < dims; ++c) g.sum[size_t(dims) * node + c] = part.sum[size_t(dims) * i + c];
    }
  }
  auto node_of_face = [&](uint32_t f) { return node_base[part_of[f]] + levels[part_of[f]].node_of[local[f]]; };
  {
    std::vector<uint32_t> start, upper, last_seen;
    unique_edges(nodes, [&](auto&& emit) {
      for (uint32_t p = 0; p < parts; ++p) {
        const DualGraph& part = levels[p].graph;
        for (size_t e = 0; e < part.edges.size(); ++e) emit(node_base[p] + part.edges[e].a, node_base[p] + part.edges[e].b);
        for (const auto& [node, o] : levels[p].border) emit(node_base[p] + node, node_of_face(o));
      }
    }, g.edges, start, upper, last_seen);
  }
  for (PartLevel& level : levels) level.graph = DualGraph{};
  // The parts' level to its exact count, then the rest.
  std::vector<uint32_t> rest(targets.begin() + long(part_levels) - 1, targets.end());
  const std::vector<uint32_t> node_label = contract_levels(g, rest, &pool, false, clusters);
  assert(g.nodes == clusters);
  std::vector<uint32_t> labels(nf);
  pool.run(nf, [&](size_t begin, size_t end, unsigned) {
    for (size_t f = begin; f < end; ++f) labels[f] = node_label[node_of_face(uint32_t(f))];
  });
  return labels;
}

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

// Breadth-first growth from the seeds in `queue` (already labeled): a face joins the cluster that
// reaches it first. Every face must be reachable (one seed per component at least).
void grow_from_seeds(const Topology& topology, std::vector<uint32_t>& labels, std::vector<uint32_t>& queue) {
  for (size_t head = 0; head < queue.size(); ++head) {
    uint32_t f = queue[head];
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
      if (o != kNone && labels[o] == kNone) {
        labels[o] = labels[f];
        queue.push_back(o);
      }
    }
  }
  assert(queue.size() == labels.size());
}

std::vector<uint32_t> random_clustering(const ClusterProblem& problem, const Topology& topology, uint32_t clusters,
                                        uint64_t seed) {
  const uint32_t nf = problem.face_count;
  std::vector<uint32_t> labels(nf, kNone);
  uint64_t rng = seed;
  // One seed per component (a random face of it), so every face can be reached.
  std::vector<uint32_t> component_size(topology.component_count, 0), component_pick(topology.component_count, kNone);
  for (uint32_t f = 0; f < nf; ++f) {
    uint32_t c = topology.face_component[f];
    // reservoir sampling: a uniformly random face per component in one pass
    if (splitmix64(rng) % ++component_size[c] == 0) component_pick[c] = f;
  }
  std::vector<uint32_t> queue;
  queue.reserve(nf);
  uint32_t next = 0;
  for (uint32_t c = 0; c < topology.component_count; ++c) {
    labels[component_pick[c]] = next++;
    queue.push_back(component_pick[c]);
  }
  // The remaining seeds uniformly among unlabeled faces (partial Fisher-Yates on a candidate list).
  std::vector<uint32_t> free_faces;
  free_faces.reserve(nf - next);
  for (uint32_t f = 0; f < nf; ++f)
    if (labels[f] == kNone) free_faces.push_back(f);
  for (size_t i = 0; next < clusters; ++i) {
    size_t j = i + splitmix64(rng) % (free_faces.size() - i);
    std::swap(free_faces[i], free_faces[j]);
    labels[free_faces[i]] = next++;
    queue.push_back(free_faces[i]);
  }
  grow_from_seeds(topology, labels, queue);
  return labels;
}

// Per-component counts: component c gets component_clusters[c] clusters.
// Hierarchical: the scheme above on each component alone, component c's ids following those of
// components 0..c-1. Random: one seed per component as above, then each component's remaining
// seeds uniformly among its own free faces, grown breadth-first (growth never leaves a component).
std::vector<uint32_t> per_component_clustering(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology, Init init,
                                               const std::vector<uint32_t>& component_clusters, uint64_t seed,
                                               WorkerPool& pool) {
  const uint32_t nf = problem.face_count, nc = topology.component_count;
  // faces of each component, CSR, in increasing face id; local_of[f] = position within its component
  std::vector<uint32_t> offsets(size_t(nc) + 1, 0), faces(nf), local_of(nf);
  for (uint32_t f = 0; f < nf; ++f) ++offsets[topology.face_component[f] + 1];
  for (uint32_t c = 0; c < nc; ++c) offsets[c + 1] += offsets[c];
  {
    std::vector<uint32_t> fill(offsets.begin(), offsets.end() - 1);
    for (uint32_t f = 0; f < nf; ++f) {
      uint32_t c = topology.face_component[f];
      local_of[f] = fill[c] - offsets[c];
      faces[fill[c]++] = f;
    }
  }
  std::vector<uint32_t> labels(nf, kNone);
  if (init == Init::hierarchical) {
    uint32_t base = 0;
    std::vector<uint32_t> subset;
    for (uint32_t c = 0; c < nc; ++c) {
      subset.assign(faces.begin() + offsets[c], faces.begin() + offsets[c + 1]);
      std::vector<uint32_t> local = hierarchical_clustering(problem, mesh, topology, component_clusters[c], pool, &subset, &local_of);
      for (size_t i = 0; i < subset.size(); ++i) labels[subset[i]] = base + local[i];
      base += component_clusters[c];
    }
    return labels;
  }
  uint64_t rng = seed;
  std::vector<uint32_t> queue;
  queue.reserve(nf);
  uint32_t next = 0;
  // One random face per component first (reservoir sampling, as random_clustering does).
  std::vector<uint32_t> component_size(nc, 0), component_pick(nc, kNone);
  for (uint32_t f = 0; f < nf; ++f) {
    uint32_t c = topology.face_component[f];
    if (splitmix64(rng) % ++component_size[c] == 0) component_pick[c] = f;
  }
  for (uint32_t c = 0; c < nc; ++c) {
    labels[component_pick[c]] = next++;
    queue.push_back(component_pick[c]);
  }
  std::vector<uint32_t> free_faces;
  for (uint32_t c = 0; c < nc; ++c) {
    free_faces.clear();
    for (uint32_t i = offsets[c]; i < offsets[c + 1]; ++i)
      if (labels[faces[i]] == kNone) free_faces.push_back(faces[i]);
    for (uint32_t i = 0; i + 1 < component_clusters[c]; ++i) {
      size_t j = i + splitmix64(rng) % (free_faces.size() - i);
      std::swap(free_faces[i], free_faces[j]);
      labels[free_faces[i]] = next++;
      queue.push_back(free_faces[i]);
    }
  }
  grow_from_seeds(topology, labels, queue);
  return labels;
}

}  // namespace

std::vector<uint32_t> initial_clustering(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology,
                                         Init init, uint32_t clusters, uint64_t seed,
                                         const std::vector<uint32_t>* component_clusters, WorkerPool* pool) {
  if (clusters == 0) throw OptionError("the number of clusters must be at least 1");
  if (clusters > problem.face_count)
    throw OptionError("cannot make " + std::to_string(clusters) + " clusters from " +
                      std::to_string(problem.face_count) + " faces");
  if (clusters < topology.component_count)
    throw OptionError("cannot make " + std::to_string(clusters) + " connected clusters: the mesh has " +
                      std::to_string(topology.component_count) +
                      " connected components (across manifold edges), each needs at least one cluster");
  std::unique_ptr<WorkerPool> own_pool;
  if (!pool) pool = (own_pool = std::make_unique<WorkerPool>(1)).get();
  if (component_clusters && !component_clusters->empty())
    return per_component_clustering(problem, mesh, topology, init, *component_clusters, seed, *pool);
  return init == Init::hierarchical ? hierarchical_clustering(problem, mesh, topology, clusters, *pool)
                                    : random_clustering(problem, topology, clusters, seed);
}

}  // namespace meshcvt
