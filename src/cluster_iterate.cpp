// meshcvt: the boundary-testing iteration of Fan et al., Section 3.1 (Section 4 for L2,1), with
// configuration-wise updating and the accelerators of Section 5.2.
//
// One iteration, all decisions reading only the state at its start:
//  1. Gather (parallel, per face): each face on a cluster border tests its cluster edges with the
//     four-case rule (boundary_rule.h), the edge oriented so that T_l is the lower face id. The
//     moves proposed for the face itself are kept; several proposals: the closest destination wins,
//     ties to the lower cluster id. Every write goes to the face's own slot, so threads never race.
//  2. Disk filter (TopologyMode::preserving, beyond the paper): a proposal is kept only if
//     (a) the faces of its source cluster in the moved face's vertex ring stay edge-connected
//         without it, and non-empty (the source neither splits nor vanishes),
//     (b) the faces of its destination cluster in that ring are edge-connected (no ring closes
//         around a hole: a disk stays a disk),
//     (c) no other proposal that passed (a) and (b), shares a vertex with it and involves one of its
//         two clusters (as source or destination) has a lower face id. The tests of (a)/(b) read the
//         ring as it was; (c) makes that true for the two clusters they look at. Restricting (c) to
//         moves that leave the same cluster is not enough: a face can join D through a neighbour
//         that leaves D in the same iteration and end up cut off (seen on an icosphere).
//     Ranking only among proposals that pass (a) and (b) keeps the lowest passing one alive, so the
//     filter never blocks progress. Every kept move lowers the face's own distance, so any subset
//     of the rule's moves lowers the energy: the configuration-wise argument of Section 3.1 holds.
//  3. Apply: labels change at once; each cluster's sums change by its centroid variation
//     (eq. 8: + sum over V+ of w p, - sum over V- of w p), in 64-bit fixed point, so the result is
//     independent of the order and of the thread count. Generators are recomputed from the sums.
//
// Accelerator (5.2), exact: a face's decision depends only on its label, its edge-neighbours'
// labels and those clusters' generators. A face is re-tested when a label it reads changed in the
// last iteration (moved faces and their neighbours: the paper's "potential edges"), when its own
// proposal was refused by (c), or when a generator it reads has moved far enough to change its
// decision. A proposal refused by (a) or (b) sleeps the same way, with the budget of its move
// (rule_budget.h), and also wakes when a face of its vertex ring moves: until then it would be
// proposed and refused again. (l21 leaves ~900 such faces on bunny00 -> 100 for the last hundred
// iterations; they were re-tested in every one.)
// For the last, beyond the paper's "cluster changed" test: a face that decides to stay gets a
// budget b, the largest generator displacement that provably cannot flip any comparison of the
// four-case rule it made (each float distance bounded through the triangle inequality, with a
// relative allowance for float rounding far above the few roundings involved), and it is re-tested
// only once one of its clusters' generators has moved by b in total since its test. Clusters keep
// their total movement and their watching faces in buckets of budgets within a factor of 2 (a
// bucket is re-tested whole, a little early for some faces, never late), so an iteration touches
// only the faces that may be due, not every border face of every cluster that moved. Same
// decisions as testing every border face every iteration (`accelerate = false`); the tests check.
// Each worker registers the watches of the faces it tested in buckets of its own and flushes them
// itself, so the bookkeeping runs on every thread: serial, it was a third of the iteration on the
// 1.2M bunny with two threads. Which faces are re-tested early then depends on the split between
// threads; the decisions do not.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstring>
#include <string>

#include "boundary_rule.h"
#include "rule_budget.h"
#include "cluster_engine.h"
#include "parallel.h"

namespace meshcvt {

namespace {

// kRefusedByDisk: refused by (a) or (b) in the last iteration, destination_ still set.
// kProposedAgain: proposed again for that same destination (its disk tests may be reused).
enum ProposalState : uint8_t {
  kNoProposal = 0,
  kProposed = 1,
  kPassedDiskTests = 2,
  kRefusedByDisk = 3,
  kProposedAgain = 4
};

// Faces sharing a vertex with `face` (itself excluded), sorted, without repeats. The three vertex
// lists are sorted already (Topology's CSR), so a merge is enough.
void gather_vertex_ring(const Mesh& mesh, const Topology& topology, uint32_t face, std::vector<uint32_t>& ring) {
  ring.clear();
  const uint32_t* begin[3];
  const uint32_t* end[3];
  for (int j = 0; j < 3; ++j) {
    uint32_t v = mesh.indices[3 * size_t(face) + j];
    begin[j] = topology.vertex_faces.data() + topology.vertex_face_offsets[v];
    end[j] = topology.vertex_faces.data() + topology.vertex_face_offsets[v + 1];
  }
  for (;;) {
    uint32_t next = kNone;
    for (int j = 0; j < 3; ++j)
      if (begin[j] != end[j] && *begin[j] < next) next = *begin[j];
    if (next == kNone) break;
    for (int j = 0; j < 3; ++j)
      if (begin[j] != end[j] && *begin[j] == next) ++begin[j];
    if (next != face) ring.push_back(next);
  }
}

// The faces of `cluster` in `ring` (sorted) are non-empty and edge-connected. General version,
// for rings of any size (a vertex of high valence).
bool ring_is_connected(const Topology& topology, const std::vector<uint32_t>& labels,
                       const std::vector<uint32_t>& ring, uint32_t cluster) {
  thread_local std::vector<uint32_t> members, parent;
  members.clear();
  for (uint32_t g : ring)
    if (labels[g] == cluster) members.push_back(g);  // sorted, since ring is
  if (members.empty()) return false;
  parent.resize(members.size());
  for (size_t i = 0; i < members.size(); ++i) parent[i] = uint32_t(i);
  auto find = [&](uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  size_t pieces = members.size();
  for (size_t i = 0; i < members.size() && pieces > 1; ++i)
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(members[i]) + e];
      if (o == kNone || o < members[i]) continue;
      auto it = std::lower_bound(members.begin(), members.end(), o);
      if (it == members.end() || *it != o) continue;
      uint32_t a = find(uint32_t(i)), b = find(uint32_t(it - members.begin()));
      if (a != b) {
        parent[a] = b;
        --pieces;
      }
    }
  return pieces == 1;
}

// Connectivity of a set given as a bit mask over `members`, with adjacency as masks.
bool mask_is_connected(const uint64_t* adjacent, uint64_t set) {
  if (set == 0) return false;
  uint64_t reached = set & (~set + 1);  // lowest member
  uint64_t frontier = reached;
  while (frontier) {
    uint64_t next = 0;
    for (uint64_t f = frontier; f; f &= f - 1) next |= adjacent[__builtin_ctzll(f)];
    next &= set & ~reached;
    reached |= next;
    frontier = next;
  }
  return reached == set;
}

bool ring_keeps_disks(const Topology& topology, const std::vector<uint32_t>& labels, const std::vector<uint32_t>& ring,
                      uint32_t face, uint32_t destination) {
  const uint32_t source = labels[face];
  // Only faces of the two clusters matter; up to 64 of them (nearly always) are tested with bit
  // masks, larger rings (vertices of high valence) with union-find.
  uint32_t members[64];
  uint64_t in_source = 0, in_destination = 0;
  size_t count = 0;
  for (uint32_t g : ring) {
    uint32_t l = labels[g];
    if (l != source && l != destination) continue;
    if (count == 64)
      return ring_is_connected(topology, labels, ring, source) && ring_is_connected(topology, labels, ring, destination);
    (l == source ? in_source : in_destination) |= uint64_t(1) << count;
    members[count++] = g;
  }
  if (in_source == 0 || in_destination == 0) return false;
  // member id -> position, open addressing in 128 slots (at most half full)
  uint32_t slot_face[128];
  uint8_t slot_index[128];
  std::fill(slot_face, slot_face + 128, kNone);
  auto slot_of = [](uint32_t f) { return (f * 0x9E3779B1u) >> 25; };
  for (size_t i = 0; i < count; ++i) {
    uint32_t h = slot_of(members[i]);
    while (slot_face[h] != kNone) h = (h + 1) & 127;
    slot_face[h] = members[i];
    slot_index[h] = uint8_t(i);
  }
  uint64_t adjacent[64];
  for (size_t i = 0; i < count; ++i) {
    uint64_t bits = 0;
    uint32_t g = members[i], l = labels[g];
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(g) + e];
      if (o == kNone || labels[o] != l || o == face) continue;  // only same-cluster links count
      for (uint32_t h = slot_of(o); slot_face[h] != kNone; h = (h + 1) & 127)
        if (slot_face[h] == o) {
          bits |= uint64_t(1) << slot_index[h];
          break;
        }
    }
    adjacent[i] = bits;
  }
  return mask_is_connected(adjacent, in_source) && mask_is_connected(adjacent, in_destination);
}


// The disk test of ring_keeps_disks read from the ring's cyclic order, without adjacency lookups
// between its faces: the common case, a face whose three corners each have one closed fan.
// Around such a face the faces sharing a corner form a cycle in which consecutive faces share an
// edge (around each corner from one edge-neighbour of the face to the next), so a cluster's faces
// in the ring are edge-connected exactly when they are one arc of the cycle, unless two of them are
// also adjacent across their outer edge (a chord, possible only around corners of low valence).
// `irregular` (anything else: a boundary or non-manifold edge or corner, a collapsed face, more
// than kMaxRingCycle faces, a chord between two faces of one of the two clusters) sends the caller
// to the general test; otherwise the answer is the same as ring_keeps_disks', and ring[0..size)
// holds the same faces as gather_vertex_ring's (in cyclic, not increasing, order).
enum class RingTest : uint8_t { keeps, breaks, irregular };
// Proposals (a ring walk and a few hundred nanoseconds each) from which the disk tests are split
// among the workers; the pool's default suits items of a few nanoseconds.
constexpr size_t kMinParallelDiskTests = 96;
constexpr uint32_t kMaxRingCycle = 64;
RingTest cyclic_ring_test(const Mesh& mesh, const Topology& topology, const uint32_t* labels, uint32_t face,
                          uint32_t destination, uint32_t* ring, uint32_t& size) {
  const uint32_t* indices = mesh.indices.data();
  const uint32_t* adjacent = topology.face_adjacent.data();
  const uint32_t* corner = indices + 3 * size_t(face);
  const uint32_t* across = adjacent + 3 * size_t(face);  // across[e]: edge (corner e, corner e+1)
  if (across[0] == kNone || across[1] == kNone || across[2] == kNone || across[0] == across[1] ||
      across[1] == across[2] || across[0] == across[2])
    return RingTest::irregular;
  // In a consistently oriented mesh each face crosses the shared edge against its neighbour's
  // direction, so around a corner the walk enters every face through the edge that starts at the
  // corner and leaves through the one before it: the adjacency alone gives the next face. Otherwise
  // the corner is looked up in each face's indices.
  const bool oriented = topology.orientation_flips == 0;
  // The fans of the three corners are walked side by side: each step waits for the face it
  // reads, and three independent walks keep three loads in flight.
  uint32_t fan[3][kMaxRingCycle], outer[3][kMaxRingCycle];  // outer: across the edge opposite the corner
  uint32_t count[3] = {0, 0, 0}, previous[3] = {face, face, face}, at[3], left[3];
  for (int j = 0; j < 3; ++j) {
    at[j] = across[(j + 2) % 3];  // the corner's first face; its last is across[j]
    const uint32_t v = corner[j];
    left[j] = topology.vertex_face_offsets[v + 1] - topology.vertex_face_offsets[v];
    if (left[j] < 3) return RingTest::irregular;
    left[j] -= 2;  // faces of the fan other than `face` and the last
  }
  for (int walking = 3; walking > 0;) {
    walking = 0;
    for (int j = 0; j < 3; ++j) {
      const uint32_t g = at[j];
      if (g == across[j]) continue;
      if (left[j]-- == 0) return RingTest::irregular;  // faces at the corner outside this fan, or a loop
      if (count[j] == kMaxRingCycle) return RingTest::irregular;  // (the whole ring is checked below)
      const uint32_t* ga = adjacent + 3 * size_t(g);
      int k;  // g's edge that starts at the corner
      uint32_t next;
      if (oriented) {
        // The edge back to the previous face, which must be g's only one: one bit of m.
        const uint32_t p = previous[j];
        const unsigned m = unsigned(ga[0] == p) | unsigned(ga[1] == p) << 1 | unsigned(ga[2] == p) << 2;
        if (m == 0 || (m & (m - 1)) != 0) return RingTest::irregular;
        k = int(m >> 1);
        next = ga[(k + 2) % 3];
      } else {
        const uint32_t* gc = indices + 3 * size_t(g);
        const uint32_t v = corner[j];
        k = gc[0] == v ? 0 : gc[1] == v ? 1 : gc[2] == v ? 2 : -1;
        if (k < 0) return RingTest::irregular;
        const uint32_t in = ga[k], out = ga[(k + 2) % 3];
        if (in == previous[j] && out != previous[j]) next = out;
        else if (out == previous[j] && in != previous[j]) next = in;
        else return RingTest::irregular;
      }
      if (next == kNone) return RingTest::irregular;
      // The first face is an edge-neighbour of `face`: its edge opposite the corner links it to the
      // previous corner's fan, not to a face outside the cycle.
      outer[j][count[j]] = previous[j] == face ? kNone : ga[(k + 1) % 3];
      fan[j][count[j]++] = g;
      previous[j] = g;
      at[j] = next;
      walking += next != across[j];
    }
  }
  if (left[0] != 0 || left[1] != 0 || left[2] != 0) return RingTest::irregular;  // faces at a corner outside its fan
  size = count[0] + count[1] + count[2];
  if (size > kMaxRingCycle) return RingTest::irregular;
  uint32_t ring_outer[kMaxRingCycle];
  for (int j = 0, i = 0; j < 3; ++j)
    for (uint32_t k = 0; k < count[j]; ++k, ++i) {
      ring[i] = fan[j][k];
      ring_outer[i] = outer[j][k];
    }
  const uint32_t source = labels[face];
  uint32_t label[kMaxRingCycle];
  uint64_t bloom = 0;  // a cheap first check of "is h in the ring" for the chords
  for (uint32_t i = 0; i < size; ++i) {
    label[i] = labels[ring[i]];
    bloom |= uint64_t(1) << ((ring[i] * 0x9E3779B1u) >> 26);
  }
  uint32_t source_arcs = 0, destination_arcs = 0;
  for (uint32_t i = 0, before = size - 1; i < size; before = i++) {
    const uint32_t l = label[i];
    if (l != source && l != destination) continue;
    if (l != label[before]) ++(l == source ? source_arcs : destination_arcs);
    const uint32_t h = ring_outer[i];
    if (h == kNone || !(bloom >> ((h * 0x9E3779B1u) >> 26) & 1) || labels[h] != l) continue;
    assert(h != face);  // h would be an edge-neighbour of face, which has two of its corners
    if (std::find(ring, ring + size, h) != ring + size) return RingTest::irregular;
  }
  return source_arcs == 1 && destination_arcs == 1 ? RingTest::keeps : RingTest::breaks;
}

// Tests (a) and (b) as the engine makes them: from the ring's cycle where cyclic_ring_test applies,
// else by adjacency between the ring's faces. `ring` gets the vertex ring's faces (in cyclic or in
// increasing order), kept by step() for test (c).
bool disk_tests_pass(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels, uint32_t face,
                     uint32_t destination, std::vector<uint32_t>& ring) {
  uint32_t cycle[kMaxRingCycle], size = 0;
  const RingTest test = cyclic_ring_test(mesh, topology, labels.data(), face, destination, cycle, size);
  if (test != RingTest::irregular) {
    ring.assign(cycle, cycle + size);
    return test == RingTest::keeps;
  }
  gather_vertex_ring(mesh, topology, face, ring);
  return ring_keeps_disks(topology, labels, ring, face, destination);
}

// The four-case test of the cluster edge between f (in p, at distance d_own from p's generator)
// and its neighbour g (in q), the edge oriented so that T_l is the lower face id: the three other
// distances and whether the rule moves f. Also its budget, the outcome's (stay or move).
struct EdgeTest {
  float d_fq, d_gp, d_gq;
  bool f_moves;
};
inline EdgeTest test_edge(const float* point, const float* weight, const float* gen, uint32_t f, uint32_t g, uint32_t p,
                          uint32_t q, float d_own) {
  const float* xf = point + 3 * size_t(f);
  const float* xg = point + 3 * size_t(g);
  EdgeTest t;
  t.d_fq = squared_distance(xf, gen + 3 * size_t(q));
  t.d_gp = squared_distance(xg, gen + 3 * size_t(p));
  t.d_gq = squared_distance(xg, gen + 3 * size_t(q));
  if (f < g)  // f is T_l in V_p, g is T_r in V_q
    t.f_moves = decide_cluster_edge(d_own, t.d_fq, t.d_gp, t.d_gq, weight[f], weight[g]) == EdgeMove::left_to_q;
  else        // g is T_l in V_q, f is T_r in V_p
    t.f_moves = decide_cluster_edge(t.d_gq, t.d_gp, t.d_fq, d_own, weight[g], weight[f]) == EdgeMove::right_to_p;
  return t;
}
// Calls visit(g, q, test) for each cluster edge of f: each edge-neighbour g in another cluster q,
// with that edge's four-case test. f is in p, at distance d_own from p's generator; adj its three
// neighbours (kNone: none).
template <class Visit>
inline void test_cluster_edges(const uint32_t* adj, const uint32_t* labels, const float* point, const float* weight,
                               const float* gen, uint32_t f, uint32_t p, float d_own, Visit&& visit) {
  for (int e = 0; e < 3; ++e) {
    const uint32_t g = adj[e];
    if (g == kNone) continue;
    const uint32_t q = labels[g];
    if (q == p) continue;
    visit(g, q, test_edge(point, weight, gen, f, g, p, q, d_own));
  }
}
inline double edge_budget(const float* weight, uint32_t f, uint32_t g, float d_own, const EdgeTest& t) {
  auto budget = t.f_moves ? move_budget : stay_budget;
  return f < g ? budget(d_own, t.d_fq, t.d_gp, t.d_gq, weight[f], weight[g], true)
               : budget(t.d_gq, t.d_gp, t.d_fq, d_own, weight[g], weight[f], false);
}

// Rounded down to float, so a watch never fires late.
float float_budget(double budget) {
  float b = float(budget);
  if (double(b) > budget) b = std::nextafter(b, 0.0f);
  return b;
}

}  // namespace

BoundaryIteration::BoundaryIteration(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology,
                                     TopologyMode mode, bool accelerate, WorkerPool& pool)
    : problem_(problem), mesh_(mesh), topology_(topology), mode_(mode), accelerate_(accelerate), pool_(pool) {}

void BoundaryIteration::reset(std::vector<uint32_t> labels) {
  const uint32_t nf = problem_.face_count, nc = problem_.clusters;
  labels_ = std::move(labels);
  assert(labels_.size() == nf);
  sums_ = compute_cluster_sums(problem_, labels_, nc, &pool_);
  generators_.assign(3 * size_t(nc), 0.0f);
  cluster_energy_.resize(nc);
  for (uint32_t c = 0; c < nc; ++c) {
    compute_generator(problem_, &sums_[size_t(c) * kSumComponents], &generators_[3 * c]);
    cluster_energy_[c] = cluster_energy(problem_, &sums_[size_t(c) * kSumComponents], &generators_[3 * c]);
  }
  destination_.assign(nf, kNone);
  proposal_state_.assign(nf, kNoProposal);
  vertex_moved_at_.assign(mode_ == TopologyMode::preserving ? mesh_.vertex_count() : 0, 0);
  // Every cluster counts as changed: the first iteration tests every border face.
  cluster_changed_.assign(nc, 1);
  changed_clusters_.resize(nc);
  for (uint32_t c = 0; c < nc; ++c) changed_clusters_[c] = c;
  dirty_faces_.clear();
  active_bits_.assign((size_t(nf) + 63) / 64, 0);
  worker_moves_.assign(pool_.size(), {});
  worker_rings_.assign(pool_.size(), {});
  worker_evaluated_.assign(pool_.size(), 0);
  movement_.assign(nc, 0.0);
  worker_watches_.assign(accelerate_ ? pool_.size() : 0, {});
  for (WatchBuckets& w : worker_watches_) {
    w.slot.assign(nc, kNone);
    w.clusters.reserve(nc);  // (pages untouched until used: no copies of the buckets as it grows)
    w.level_mask.assign(nc, 0);
  }
  eval_stamp_.assign(accelerate_ ? nf : 0, 0);
  budget_.assign(accelerate_ ? nf : 0, 0.0f);
  watch_count_.assign(accelerate_ ? nf : 0, 0);
  iteration_ = 0;
  live_watches_ = 0;
  any_asleep_ = false;
}

namespace {
// The budget level of a face: the largest L with 2^(L - kBudgetLevels) <= budget (0: below 2^-31).
int budget_level(float budget) {
  if (!(budget > 0)) return 0;
  int level = std::ilogb(budget) + kBudgetLevels;
  return std::clamp(level, 0, kBudgetLevels - 1);
}
double level_threshold(int level) { return level == 0 ? 0.0 : std::ldexp(1.0, level - kBudgetLevels); }
}  // namespace

// A face tested this iteration that stays gets one watch per cluster it read (its own and each
// neighbouring one), at that cluster's movement plus its budget, in the buckets of the worker
// that tested it (labels and movements do not change while the faces are tested).
void BoundaryIteration::register_watches(uint32_t f, WatchBuckets& watches) {
  watches.live_change -= watch_count_[f];  // the watches of its previous test are stale now
  uint32_t clusters[4];
  int count = 0;
  clusters[count++] = labels_[f];
  for (int e = 0; e < 3; ++e) {
    uint32_t o = topology_.face_adjacent[3 * size_t(f) + e];
    if (o == kNone) continue;
    uint32_t q = labels_[o];
    bool seen = false;
    for (int k = 0; k < count; ++k) seen |= clusters[k] == q;
    if (!seen) clusters[count++] = q;
  }
  const int level = budget_level(budget_[f]);
  for (int k = 0; k < count; ++k) {
    const uint32_t c = clusters[k];
    if (watches.slot[c] == kNone) {
      watches.slot[c] = uint32_t(watches.clusters.size());
      watches.clusters.emplace_back();
    }
    ClusterWatches& cw = watches.clusters[watches.slot[c]];
    std::vector<Watch>& bucket = cw.bucket[level];
    if (bucket.empty()) {
      // An empty bucket's clock starts now: every face in it was registered since.
      cw.flushed_at[level] = movement_[c];
      watches.level_mask[c] |= uint32_t(1) << level;
    }
    bucket.push_back(Watch{f, eval_stamp_[f]});
  }
  watch_count_[f] = uint8_t(count);
  watches.live_change += count;
  watches.entries += size_t(count);
}

void BoundaryIteration::sum_live_watches() {
  for (WatchBuckets& w : worker_watches_) {
    live_watches_ = size_t(int64_t(live_watches_) + w.live_change);
    w.live_change = 0;
  }
}

// Drops the watches of faces tested again since (they have newer ones or moved).
void BoundaryIteration::purge_watches(WatchBuckets& watches) {
  watches.entries = 0;
  for (uint32_t c = 0; c < problem_.clusters; ++c)
    for (uint32_t levels = watches.level_mask[c]; levels; levels &= levels - 1) {
      const int level = __builtin_ctz(levels);
      std::vector<Watch>& bucket = watches.clusters[watches.slot[c]].bucket[level];
      bucket.erase(
          std::remove_if(bucket.begin(), bucket.end(), [&](const Watch& w) { return eval_stamp_[w.face] != w.stamp; }),
          bucket.end());
      watches.entries += bucket.size();
      if (bucket.empty()) watches.level_mask[c] &= ~(uint32_t(1) << level);
    }
}

void BoundaryIteration::release_step_memory() {
  auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  release(destination_);
  release(proposal_state_);
  release(vertex_moved_at_);
  release(dirty_faces_);
  release(active_);
  release(active_bits_);
  release(worker_watches_);
  release(eval_stamp_);
  release(budget_);
  release(watch_count_);
  release(movement_);
  for (auto& v : worker_moves_) release(v);
  for (auto& v : worker_rings_) release(v);
}

std::string BoundaryIteration::description() const {
  return "cpu (" + std::to_string(pool_.size()) + (pool_.size() == 1 ? " thread)" : " threads)");
}

double BoundaryIteration::energy() const {
  double e = 0;  // in cluster order, as a sum of cluster_energy() over all clusters would be
  for (double ec : cluster_energy_) e += ec;
  return e;
}

bool BoundaryIteration::is_border(uint32_t f) const {
  const uint32_t* adj = &topology_.face_adjacent[3 * size_t(f)];
  uint32_t p = labels_[f];
  return (adj[0] != kNone && labels_[adj[0]] != p) || (adj[1] != kNone && labels_[adj[1]] != p) ||
         (adj[2] != kNone && labels_[adj[2]] != p);
}

// The faces to test this iteration: faces marked dirty by the last one (moved, next to a move, or
// refused), and the faces whose watches fired (a generator they read has moved by their budget).
// The first iteration after reset, and every iteration without the accelerator: every border face,
// found by one pass over all faces (kept per-cluster border lists cost 12-16 bytes per face for a
// pass that the margin accelerator needs once per reset).
// The faces are marked in a bit set and listed in increasing id: the tests then walk the face
// arrays in memory order (with a locality order, mesh_order.h, neighbouring faces are close), where
// the order they were found in jumps across the mesh. The order changes no decision.
void BoundaryIteration::collect_active_faces() {
  uint64_t* bits = active_bits_.data();
  auto add = [&](uint32_t f) { bits[f >> 6] |= uint64_t(1) << (f & 63); };
  // In parallel over ranges of words: a count per range, then each range writes its part of the
  // list (the same list as one pass would make).
  const size_t words = active_bits_.size();
  auto list_marked = [&] {
    std::vector<size_t> range_start(pool_.size() + 1, 0);
    pool_.run(words, [&](size_t begin, size_t end, unsigned w) {
      size_t n = 0;
      for (size_t word = begin; word < end; ++word) n += size_t(std::popcount(bits[word]));
      range_start[w + 1] = n;
    }, /*min_parallel=*/8192);
    for (size_t w = 0; w < pool_.size(); ++w) range_start[w + 1] += range_start[w];
    active_.resize(range_start.back());
    pool_.run(words, [&](size_t begin, size_t end, unsigned w) {
      uint32_t* out = active_.data() + range_start[w];
      for (size_t word = begin; word < end; ++word) {
        for (uint64_t b = bits[word]; b; b &= b - 1) *out++ = uint32_t(word * 64 + __builtin_ctzll(b));
        bits[word] = 0;
      }
    }, /*min_parallel=*/8192);
  };
  auto every_border_face = [&] {  // whole words per range: no two workers write one word
    pool_.run(words, [&](size_t begin, size_t end, unsigned) {
      const size_t last = std::min<size_t>(end * 64, problem_.face_count);
      for (size_t f = begin * 64; f < last; ++f)
        if (is_border(uint32_t(f))) add(uint32_t(f));
    }, /*min_parallel=*/64);
  };
  if (!accelerate_ || iteration_ == 1) {  // iteration_ 1: the first after reset (no dirty face yet)
    every_border_face();
    list_marked();
    return;
  }
  for (uint32_t f : dirty_faces_) add(f);
  // Each worker flushes its own buckets; the faces go into the shared bit set (an atomic OR: the
  // set is the same in any order).
  // (On one thread when few clusters moved: waking the others costs more than the flushes.)
  const bool parallel = worker_watches_.size() > 1 && changed_clusters_.size() >= 256;
  pool_.run(worker_watches_.size(), [&](size_t begin, size_t end, unsigned) {
    for (size_t w = begin; w < end; ++w) flush_watches(worker_watches_[w], parallel);
  }, /*min_parallel=*/parallel ? 2 : worker_watches_.size() + 1);
  sum_live_watches();
  list_marked();
}

// Buckets whose cluster moved by their lower bound since their last flush: a face in the bucket
// was registered after that flush with a budget at least the bound, so none is re-tested late.
void BoundaryIteration::flush_watches(WatchBuckets& watches, bool concurrent) {
  uint64_t* bits = active_bits_.data();
  for (uint32_t c : changed_clusters_) {
    const double moved = movement_[c];
    if (watches.level_mask[c] == 0) continue;
    ClusterWatches& cw = watches.clusters[watches.slot[c]];
    for (uint32_t levels = watches.level_mask[c]; levels; levels &= levels - 1) {
      const int level = __builtin_ctz(levels);
      std::vector<Watch>& bucket = cw.bucket[level];
      if (!(moved - cw.flushed_at[level] >= level_threshold(level)) || moved == cw.flushed_at[level]) continue;
      watches.level_mask[c] &= ~(uint32_t(1) << level);
      watches.entries -= bucket.size();
      for (const Watch& w : bucket) {
        if (eval_stamp_[w.face] != w.stamp) continue;  // tested again since: stale
        // Its live watches are all in these buckets (this worker tested it last): no other
        // worker writes its count.
        --watches.live_change;
        --watch_count_[w.face];
        const uint64_t bit = uint64_t(1) << (w.face & 63);
        if (concurrent)
          std::atomic_ref<uint64_t>(bits[w.face >> 6]).fetch_or(bit, std::memory_order_relaxed);
        else
          bits[w.face >> 6] |= bit;
      }
      bucket.clear();
    }
  }
}

void BoundaryIteration::evaluate_range(size_t begin, size_t end, unsigned worker) {
  const float* point = problem_.point.data();
  const float* weight = problem_.weight.data();
  const float* gen = generators_.data();
  std::vector<uint32_t>& moves = worker_moves_[worker];
  uint64_t evaluated = 0;
  for (size_t i = begin; i < end; ++i) {
    uint32_t f = active_[i];
    uint32_t p = labels_[f];
    const uint32_t* adj = &topology_.face_adjacent[3 * size_t(f)];
    if (!is_border(f)) continue;
    ++evaluated;
    // Test every cluster edge of f; keep the moves the rule decides for f itself.
    const float* xf = point + 3 * size_t(f);
    float d_own = squared_distance(xf, gen + 3 * size_t(p));
    float best_d = 0;
    uint32_t best = kNone;
    double budget = 1e30;
    test_cluster_edges(adj, labels_.data(), point, weight, gen, f, p, d_own, [&](uint32_t g, uint32_t q, const EdgeTest& t) {
      if (t.f_moves && (best == kNone || better_destination(t.d_fq, q, best_d, best))) {
        best = q;
        best_d = t.d_fq;
      }
      if (accelerate_ && best == kNone) budget = std::min(budget, edge_budget(weight, f, g, d_own, t));
    });
    if (accelerate_) eval_stamp_[f] = iteration_;
    if (best != kNone) {
      proposal_state_[f] = proposal_state_[f] == kRefusedByDisk && destination_[f] == best ? kProposedAgain : kProposed;
      destination_[f] = best;
      moves.push_back(f);
    } else if (accelerate_) {
      budget_[f] = float_budget(budget);
      register_watches(f, worker_watches_[worker]);
    }
  }
  worker_evaluated_[worker] += evaluated;
}

// Budget of a proposal (f moves to destination_[f]): the smallest displacement of a generator f's
// test read that could change its outcome, every cluster edge's (stay or move) and the order of
// the destinations proposed. The test's distances again, only for the few proposals refused by
// the disk tests (step()).
float BoundaryIteration::proposal_budget(uint32_t f) const {
  const float* point = problem_.point.data();
  const float* weight = problem_.weight.data();
  const float* gen = generators_.data();
  const uint32_t p = labels_[f], best = destination_[f];
  const uint32_t* adj = &topology_.face_adjacent[3 * size_t(f)];
  const float* xf = point + 3 * size_t(f);
  const float d_own = squared_distance(xf, gen + 3 * size_t(p));
  const float best_d = squared_distance(xf, gen + 3 * size_t(best));
  double budget = 1e30;
  test_cluster_edges(adj, labels_.data(), point, weight, gen, f, p, d_own, [&](uint32_t g, uint32_t q, const EdgeTest& t) {
    budget = std::min(budget, edge_budget(weight, f, g, d_own, t));
    if (t.f_moves && q != best) budget = std::min(budget, comparison_budget(single_side(best_d), single_side(t.d_fq)));
  });
  return float_budget(budget);
}

bool move_keeps_disks_by_adjacency(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                   uint32_t face, uint32_t destination) {
  std::vector<uint32_t> ring;
  gather_vertex_ring(mesh, topology, face, ring);
  return ring_keeps_disks(topology, labels, ring, face, destination);
}

int move_keeps_disks_by_cycle(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                              uint32_t face, uint32_t destination, std::vector<uint32_t>* ring) {
  uint32_t cycle[kMaxRingCycle], size = 0;
  const RingTest test = cyclic_ring_test(mesh, topology, labels.data(), face, destination, cycle, size);
  if (test == RingTest::irregular) return -1;
  if (ring) ring->assign(cycle, cycle + size);
  return test == RingTest::keeps ? 1 : 0;
}

bool move_keeps_disks(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels, uint32_t face,
                      uint32_t destination) {
  std::vector<uint32_t> ring;
  return disk_tests_pass(mesh, topology, labels, face, destination, ring);
}

// A face of the vertex ring of `face` moved in the last iteration (its disk tests may differ now).
void BoundaryIteration::apply_move(uint32_t f, uint32_t to) {
  const uint32_t from = labels_[f];
  destination_[f] = kNone;
  proposal_state_[f] = kNoProposal;
  int64_t v[kSumComponents];
  problem_.face_fixed(f, v);
  int64_t* s_from = &sums_[size_t(from) * kSumComponents];
  int64_t* s_to = &sums_[size_t(to) * kSumComponents];
  for (int c = 0; c < kSumComponents; ++c) {
    s_from[c] -= v[c];
    s_to[c] += v[c];
  }
  for (uint32_t c : {from, to})
    if (!cluster_changed_[c]) {
      cluster_changed_[c] = 1;
      changed_clusters_.push_back(c);
    }
  labels_[f] = to;
  if (mode_ == TopologyMode::preserving)
    for (int j = 0; j < 3; ++j) vertex_moved_at_[mesh_.indices[3 * size_t(f) + j]] = iteration_;
}

void BoundaryIteration::wake_refused_around(uint32_t f) {
  for (int j = 0; j < 3; ++j) {
    const uint32_t v = mesh_.indices[3 * size_t(f) + j];
    for (uint32_t k = topology_.vertex_face_offsets[v]; k < topology_.vertex_face_offsets[v + 1]; ++k) {
      const uint32_t h = topology_.vertex_faces[k];
      if (proposal_state_[h] == kRefusedByDisk) dirty_faces_.push_back(h);
    }
  }
}

void BoundaryIteration::mark_dirty_around(uint32_t f) {
  dirty_faces_.push_back(f);
  for (int e = 0; e < 3; ++e) {
    uint32_t o = topology_.face_adjacent[3 * size_t(f) + e];
    if (o != kNone) dirty_faces_.push_back(o);
  }
}

void BoundaryIteration::update_generators() {
  for (uint32_t c : changed_clusters_) {
    float* g = &generators_[3 * size_t(c)];
    const float old[3] = {g[0], g[1], g[2]};
    compute_generator(problem_, &sums_[size_t(c) * kSumComponents], g);
    cluster_energy_[c] = cluster_energy(problem_, &sums_[size_t(c) * kSumComponents], g);
    double dx = double(g[0]) - old[0], dy = double(g[1]) - old[1], dz = double(g[2]) - old[2];
    movement_[c] += std::sqrt(dx * dx + dy * dy + dz * dz);
  }
}

void BoundaryIteration::relabel(const std::vector<uint32_t>& labels) {
  const uint32_t nf = problem_.face_count;
  assert(labels.size() == nf && destination_.size() == nf);  // reset() ran, step memory is there
  // The apply phase of step() for these moves (the moves of the last iteration, as far as the
  // refusal cache and the watches can tell).
  for (uint32_t f = 0; f < nf; ++f) {
    if (labels[f] == labels_[f]) continue;
    assert(labels[f] < problem_.clusters);
    apply_move(f, labels[f]);
    mark_dirty_around(f);
    if (any_asleep_) wake_refused_around(f);
  }
  update_generators();
}

bool BoundaryIteration::ring_moved_last_iteration(uint32_t face) const {
  const uint32_t* v = &mesh_.indices[3 * size_t(face)];
  const uint32_t last = iteration_ - 1;
  return vertex_moved_at_[v[0]] == last || vertex_moved_at_[v[1]] == last || vertex_moved_at_[v[2]] == last;
}

IterationRecord BoundaryIteration::step() {
  IterationRecord record;
  std::fill(worker_evaluated_.begin(), worker_evaluated_.end(), 0);
  for (auto& m : worker_moves_) m.clear();

  // 1. gather proposals
  ++iteration_;
  collect_active_faces();
  pool_.run(active_.size(), [&](size_t b, size_t e, unsigned w) { evaluate_range(b, e, w); });
  if (accelerate_) {
    sum_live_watches();
    size_t entries = 0;
    for (const WatchBuckets& w : worker_watches_) entries += w.entries;
    if (entries > 2 * live_watches_ + problem_.face_count / 8 + 1024)
      pool_.run(worker_watches_.size(), [&](size_t begin, size_t end, unsigned) {
        for (size_t w = begin; w < end; ++w) purge_watches(worker_watches_[w]);
      }, /*min_parallel=*/2);
  }
  std::vector<uint32_t> proposals;
  for (auto& m : worker_moves_) proposals.insert(proposals.end(), m.begin(), m.end());
  if (accelerate_)
    for (uint32_t f : proposals) {  // tested again: the watches of its previous test are stale
      live_watches_ -= watch_count_[f];
      watch_count_[f] = 0;
    }
  for (uint64_t n : worker_evaluated_) record.evaluated_faces += n;
  // A refused face tested again (it was dirty, or asleep and woken) that did not propose the same
  // destination: forget the refusal. (Refused faces asleep and not tested keep it.)
  for (uint32_t f : active_)
    if (proposal_state_[f] == kRefusedByDisk) {
      proposal_state_[f] = kNoProposal;
      destination_[f] = kNone;
    }

  // 2. disk filter
  std::vector<uint8_t> accepted(proposals.size(), 1);
  if (mode_ == TopologyMode::preserving && !proposals.empty()) {
    // Each proposal's vertex ring is gathered once and kept (per worker, flat) for test (c).
    std::vector<uint32_t> ring_begin(proposals.size() + 1), ring_worker(proposals.size());
    for (auto& r : worker_rings_) r.clear();
    pool_.run(proposals.size(), [&](size_t b, size_t e, unsigned w) {
      thread_local std::vector<uint32_t> ring;
      std::vector<uint32_t>& store = worker_rings_[w];
      for (size_t i = b; i < e; ++i) {
        uint32_t f = proposals[i];
        if (proposal_state_[f] == kProposedAgain && !ring_moved_last_iteration(f)) {  // refused as before
          if (accelerate_) budget_[f] = proposal_budget(f);  // (for its sleep, step 3)
          continue;
        }
        const bool keeps = disk_tests_pass(mesh_, topology_, labels_, f, destination_[f], ring);
        // Kept for (c), which looks only at lower face ids.
        ring_worker[i] = w;
        ring_begin[i] = uint32_t(store.size());
        store.push_back(0);
        for (uint32_t g : ring)
          if (g < f) store.push_back(g);
        store[ring_begin[i]] = uint32_t(store.size() - ring_begin[i] - 1);
        if (keeps)
          proposal_state_[f] = kPassedDiskTests;
        else if (accelerate_)
          budget_[f] = proposal_budget(f);
      }
    }, kMinParallelDiskTests);
    pool_.run(proposals.size(), [&](size_t b, size_t e, unsigned) {
      for (size_t i = b; i < e; ++i) {
        uint32_t f = proposals[i];
        if (proposal_state_[f] != kPassedDiskTests) {
          accepted[i] = 0;
          continue;
        }
        const uint32_t* ring = &worker_rings_[ring_worker[i]][ring_begin[i]];
        uint32_t ring_size = *ring++;
        uint32_t from = labels_[f], to = destination_[f];
        for (uint32_t k = 0; k < ring_size; ++k) {
          uint32_t g = ring[k];  // (only lower ids are kept: they alone can outrank f)
          if (proposal_state_[g] != kPassedDiskTests) continue;
          uint32_t g_from = labels_[g], g_to = destination_[g];
          if (g_from == from || g_from == to || g_to == from || g_to == to) {
            accepted[i] = 0;
            break;
          }
        }
      }
    });
  }

  // 3. apply all accepted moves at once
  for (uint32_t c : changed_clusters_) cluster_changed_[c] = 0;
  changed_clusters_.clear();
  dirty_faces_.clear();
  std::vector<uint32_t> moved;
  moved.reserve(proposals.size());
  for (size_t i = 0; i < proposals.size(); ++i) {
    uint32_t f = proposals[i];
    if (!accepted[i]) {
      if (mode_ == TopologyMode::preserving && proposal_state_[f] != kPassedDiskTests) {
        proposal_state_[f] = kRefusedByDisk;  // keeps destination_ for the next test
        if (accelerate_ && budget_[f] > 0) {
          // Asleep: tested again only when a generator it read moved by its budget (watches) or
          // a face of its vertex ring moved (below). Until then it would propose the same move
          // and be refused the same way.
          register_watches(f, worker_watches_[0]);
          any_asleep_ = true;
          continue;
        }
      } else {
        proposal_state_[f] = kNoProposal;
        destination_[f] = kNone;
      }
      dirty_faces_.push_back(f);  // refused: the rule still wants it to move, so test it again
      continue;
    }
    moved.push_back(f);
    apply_move(f, destination_[f]);
  }
  record.moves = moved.size();
  for (uint32_t f : moved) mark_dirty_around(f);
  if (any_asleep_)
    for (uint32_t f : moved) wake_refused_around(f);
  update_generators();
  record.energy = energy();
  return record;
}

}  // namespace meshcvt
