// meshcvt: internal pieces of the clustering engine, shared by the CPU driver (cluster.cpp) and the
// GPU driver (host/). Nothing here is public API.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fixed_point.h"
#include "meshcvt/cluster.h"
#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

class TriangleBvh;
class WorkerPool;

/// Cluster sums in 64-bit fixed point, 5 per cluster: W, Sx, Sy, Sz, Q, where
/// W = sum w_k, S = sum w_k p_k, Q = sum w_k |p_k|^2. Integer sums do not depend on the order of
/// accumulation, so results are the same for any thread count and on the GPU.
inline constexpr int kSumComponents = 5;

/// Budget levels of the margin accelerator (cluster_iterate.cpp): level L >= 1 holds budgets in
/// [2^(L-32), 2^(L-31)), level 0 the smaller ones (normalized units).
inline constexpr int kBudgetLevels = 32;

/// Everything the iteration needs to know about the faces, in normalized coordinates: the mesh's
/// bounding box is mapped into [0, 1]^3 (uniform scale), so float distances keep their precision
/// and the fixed-point range is known in advance.
struct ClusterProblem {
  Metric metric = Metric::cvt;
  uint32_t face_count = 0;
  uint32_t clusters = 0;
  std::vector<float> point;   ///< 3 per face: centroid (cvt, ccvt) or unit normal (l21)
  std::vector<float> weight;  ///< per face: rho_k * area, normalized units
  /// per face: the area, normalized units; only with a density (else empty: weight is the area)
  std::vector<float> area;
  double fixed_scale = 1;     ///< fixed = round_half_away(value * fixed_scale); |every sum| < 2^62
  float origin[3] = {0, 0, 0};
  float extent = 1;           ///< input = origin + extent * normalized
  std::vector<float> normalized_positions;  ///< ccvt only: vertices in normalized coordinates
  std::shared_ptr<TriangleBvh> bvh;          ///< ccvt only: closest points on the mesh

  /// The 5 fixed-point contributions of face k (deterministic function of point and weight).
  /// Inline: the Lloyd steps, the iteration and every sum over the faces call it per moved face.
  void face_fixed(uint32_t k, int64_t out[kSumComponents]) const {
    double w = double(weight[k]) * fixed_scale;
    double px = point[3 * size_t(k)], py = point[3 * size_t(k) + 1], pz = point[3 * size_t(k) + 2];
    out[0] = round_half_away(w);
    out[1] = round_half_away(w * px);
    out[2] = round_half_away(w * py);
    out[3] = round_half_away(w * pz);
    out[4] = round_half_away(w * ((px * px + py * py) + pz * pz));
  }
};

/// Builds the per-face data. Throws OptionError for bad density arrays. pool (optional): the
/// per-face work in parallel ranges (the same result: each face's values are its own, and the
/// total weight is still added up in face order).
ClusterProblem make_cluster_problem(const Mesh& mesh, const ClusterOptions& options, WorkerPool* pool = nullptr);

/// Sums of every cluster from scratch. pool (optional): workers add up ranges of faces, and the
/// integer partial sums are added, so the result is the same for any thread count.
std::vector<int64_t> compute_cluster_sums(const ClusterProblem& problem, const std::vector<uint32_t>& labels,
                                          uint32_t clusters, WorkerPool* pool = nullptr);

/// Generator of one cluster from its sums (cvt: mass centroid; ccvt: closest mesh point to it;
/// l21: normalized S). Empty clusters (W = 0) keep `g` unchanged. Bit-identical wherever it runs.
void compute_generator(const ClusterProblem& problem, const int64_t sums[kSumComponents], float g[3]);
/// compute_generator for every cluster of `sums` (kSumComponents per cluster): 3 floats per cluster.
std::vector<float> generators_of(const ClusterProblem& problem, const std::vector<int64_t>& sums);

/// Energy of one cluster from its sums and generator: Q - 2 g.S + |g|^2 W, in double.
double cluster_energy(const ClusterProblem& problem, const int64_t sums[kSumComponents], const float g[3]);

/// Energy of a whole labeling computed independently, face by face in double (for tests).
double labeling_energy(const ClusterProblem& problem, const std::vector<uint32_t>& labels, uint32_t clusters);

/// Initial clustering: exactly `clusters` connected clusters (Section 5.1 or seeded growth).
/// component_clusters (optional, ClusterOptions::component_clusters, already validated): exactly
/// that many clusters in each component, numbered component by component for hierarchical.
/// Null or empty: the original scheme over the whole mesh. pool: threads for the hierarchical
/// scheme (null: the calling thread only); the result does not depend on it.
std::vector<uint32_t> initial_clustering(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology,
                                         Init init, uint32_t clusters, uint64_t seed,
                                         const std::vector<uint32_t>* component_clusters = nullptr,
                                         WorkerPool* pool = nullptr);

/// Which clusters touch which (cluster_graph.cpp). The neighbours of cluster c, sorted and unique,
/// are neighbours[offsets[c] .. offsets[c] + count[c]); open[c]: c has a boundary or non-manifold
/// edge (face_adjacent kNone).
struct ClusterGraph {
  std::vector<uint32_t> offsets, neighbours, count;
  std::vector<uint8_t> open;
};
void build_cluster_graph(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters,
                         ClusterGraph& graph, WorkerPool* pool = nullptr);

/// Clusters enclosed by exactly one other cluster that itself has other neighbours ("isolated"). A
/// cluster that reaches a boundary (or non-manifold) edge is not enclosed: the end of a strip
/// touches one neighbour and is still a disk. Increasing cluster order.
std::vector<uint32_t> enclosed_clusters(const ClusterGraph& graph);

/// What lloyd_flood_steps did: steps kept, by kind (cluster_flood.cpp), and the assignments alone
/// that were undone because the full step after them failed.
struct LloydCounts {
  uint32_t full = 0, assignment = 0, undone = 0;
};

/// Lloyd steps by constrained flooding (cluster_flood.cpp): at most `max_steps`, each kept only if it
/// lowers the energy, stopping once a full step gains less than `min_relative_gain` of the energy.
/// Clusters stay non-empty and connected. Returns the number of steps kept. final_graph
/// (optional): receives the cluster graph of the final labels. counts (optional): the steps by kind.
uint32_t lloyd_flood_steps(const ClusterProblem& problem, const Topology& topology, WorkerPool& pool,
                           std::vector<uint32_t>& labels, uint32_t max_steps, double min_relative_gain,
                           ClusterGraph* final_graph = nullptr, LloydCounts* counts = nullptr);

/// One engine running the boundary-testing iteration: the CPU's BoundaryIteration below, or the
/// GPU's (host/). Both must take exactly the same decisions; the driver in cluster.cpp does the rest
/// (rounds, repair, restoring n) with the same code for both.
/// GPU time of an engine's kernels, from timestamps written between them (bench/gpu_kernel_bench.cpp).
struct KernelTimes {
  double boundary_s = 0;              ///< the boundary-test kernel, summed over iterations, in seconds
  double update_s = 0;                ///< the kernels after it (disk, rank, apply, gather), in seconds
  uint64_t boundary_dispatches = 0;   ///< boundary-test dispatches timed
};

class IterationEngine {
 public:
  virtual ~IterationEngine() = default;
  /// Starts from `labels` (all faces labeled in [0, clusters)): sums, generators, active set.
  virtual void reset(std::vector<uint32_t> labels) = 0;
  /// One iteration; returns its record (moves, evaluated faces, energy after it).
  virtual IterationRecord step() = 0;
  /// Energy of the current state from the cluster sums and generators (cluster_energy summed).
  virtual double energy() const = 0;
  virtual const std::vector<uint32_t>& labels() const = 0;
  virtual const std::vector<float>& generators() const = 0;
  /// e.g. "cpu (2 threads)" or the GPU's name.
  virtual std::string description() const = 0;
  /// Frees what only step() needs (until the next reset), so that repair, which runs between
  /// rounds, does not add to the peak memory. labels(), generators() and energy() stay valid.
  virtual void release_step_memory() {}
  /// Asks the engine to time its kernels from now on; false when it cannot (the CPU engine).
  virtual bool start_kernel_timing() { return false; }
  /// The kernel times summed since start_kernel_timing(); zero when not timed.
  virtual KernelTimes kernel_times() const { return {}; }
};

/// The GPU engine on Vulkan device `device_index` (host/gpu_engine.cpp). Throws DeviceError.
std::unique_ptr<IterationEngine> make_gpu_iteration(const ClusterProblem& problem, const Mesh& mesh,
                                                    const Topology& topology, TopologyMode mode, bool accelerate,
                                                    int device_index);

/// How many times make_gpu_iteration was called in this process (set-ups tried, failed or not):
/// tests see from it whether a job went to the GPU again after it failed over to the CPU.
uint64_t gpu_engine_setups();

/// The boundary-testing iteration on the CPU (Section 3.1 with configuration-wise updating and the
/// accelerators of 5.2). Holds labels, sums and generators; step() runs one iteration.
class BoundaryIteration final : public IterationEngine {
 public:
  BoundaryIteration(const ClusterProblem& problem, const Mesh& mesh, const Topology& topology, TopologyMode mode,
                    bool accelerate, WorkerPool& pool);
  void reset(std::vector<uint32_t> labels) override;
  /// Continues from the current state with `labels` (same cluster count) as if the faces that
  /// differ had moved in the last iteration: sums by their centroid variations, the generators of
  /// the clusters they left or joined recomputed, and only what those moves can affect tested
  /// next. Steps after it take exactly the decisions they would take after reset(labels), for a
  /// fraction of the first iteration's work when few faces differ.
  void relabel(const std::vector<uint32_t>& labels);
  IterationRecord step() override;
  double energy() const override;
  const std::vector<uint32_t>& labels() const override { return labels_; }
  const std::vector<float>& generators() const override { return generators_; }
  std::string description() const override;
  void release_step_memory() override;
  const std::vector<int64_t>& sums() const { return sums_; }

 private:
  void evaluate_range(size_t begin, size_t end, unsigned worker);
  void collect_active_faces();
  bool is_border(uint32_t face) const;
  bool ring_moved_last_iteration(uint32_t face) const;

  const ClusterProblem& problem_;
  const Mesh& mesh_;
  const Topology& topology_;
  TopologyMode mode_;
  bool accelerate_;
  WorkerPool& pool_;

  std::vector<uint32_t> labels_;
  std::vector<int64_t> sums_;          // kSumComponents per cluster
  std::vector<float> generators_;      // 3 per cluster
  std::vector<double> cluster_energy_;  // per cluster, kept with the generators (energy() sums them)
  std::vector<uint8_t> cluster_changed_;     // flag per cluster, set for those in changed_clusters_
  std::vector<uint32_t> changed_clusters_;   // clusters whose generator the last iteration changed
  std::vector<uint32_t> dirty_faces_;        // faces moved, next to a move, or refused last time
  std::vector<uint32_t> active_;             // faces to test in this iteration
  std::vector<uint64_t> active_bits_;        // one bit per face: marked for active_ (cleared once listed)
  std::vector<uint32_t> destination_;     // per face: proposed cluster or kNone (scratch)
  std::vector<uint8_t> proposal_state_;   // per face: a ProposalState (cluster_iterate.cpp)
  // Disk-test refusals are remembered (proposal_state_ kRefusedByDisk, destination_ kept): a face
  // proposing the same destination again, with no face around its vertices moved since, is
  // refused without gathering its ring; with the accelerator it is not even tested again until
  // that could change (step()).
  std::vector<uint32_t> vertex_moved_at_;  // per vertex: the last iteration that moved a face around it
  std::vector<std::vector<uint32_t>> worker_moves_;
  std::vector<std::vector<uint32_t>> worker_rings_;  // vertex rings of proposals: size, then faces
  std::vector<uint64_t> worker_evaluated_;


  // Margin accelerator (exact; see cluster_iterate.cpp): a face that decided to stay is re-tested
  // only once one of the generators it read has moved, in total, by its budget. Watches are kept
  // per cluster in buckets of budgets within a factor of 2; a bucket is flushed (all its faces
  // re-tested) once its cluster moved by the bucket's lower bound since its last flush. Each worker
  // keeps buckets of its own, filled by the faces it tested and flushed by it, so that registering
  // and flushing run in parallel with no lock: a face's live watches are all in the buckets of the
  // worker that last tested it. (Which worker holds a watch changes only when a face may be
  // re-tested early, never late; decisions are the same for any thread count.)
  struct Watch {
    uint32_t face, stamp;
  };
  struct ClusterWatches {
    std::vector<Watch> bucket[kBudgetLevels];  // per budget level
    double flushed_at[kBudgetLevels];          // per level: the cluster's movement_ at its last flush
  };
  struct WatchBuckets {
    // A worker's buckets for a cluster exist once it registers a watch there (a worker's faces
    // are mostly a region of the mesh: each cluster's buckets exist in about one worker).
    std::vector<uint32_t> slot;            // per cluster: its entry in `clusters`, or kNone
    std::vector<ClusterWatches> clusters;
    std::vector<uint32_t> level_mask;      // per cluster: bit L set when level L holds watches
    size_t entries = 0;                    // watches in the buckets, stale ones included
    int64_t live_change = 0;               // live watches added minus dropped, not yet summed
  };
  void register_watches(uint32_t f, WatchBuckets& watches);  // f was tested and stays
  void flush_watches(WatchBuckets& watches, bool concurrent);  // collect_active_faces, one worker's part
  void purge_watches(WatchBuckets& watches);
  // Moves face f to cluster `to` (apply phase of step(), shared with relabel): sums by its
  // centroid variation, labels, the two clusters marked changed, its vertices stamped, its
  // proposal cleared. The changed clusters' generators are then updated by update_generators().
  void apply_move(uint32_t f, uint32_t to);
  void mark_dirty_around(uint32_t f);  // f and its neighbours: labels they read changed
  // Refused faces asleep (see step()) around f's vertices marked dirty: their disk tests read
  // the labels of their vertex ring.
  void wake_refused_around(uint32_t f);
  float proposal_budget(uint32_t f) const;  // f proposes destination_[f] (cluster_iterate.cpp)
  bool any_asleep_ = false;  // a refused face has been put to sleep since reset()
  void update_generators();            // generators of changed_clusters_, and their movement
  void sum_live_watches();             // folds the workers' live_change into live_watches_
  std::vector<double> movement_;                  // per cluster: total distance its generator moved
  std::vector<WatchBuckets> worker_watches_;      // per worker
  std::vector<uint32_t> eval_stamp_;              // per face: iteration of its last test (0: none)
  std::vector<float> budget_;                     // per face: its budget from that test
  std::vector<uint8_t> watch_count_;              // per face: live watches of that test
  uint32_t iteration_ = 0;
  size_t live_watches_ = 0;
};

/// The disk tests (a) and (b) of the topology-preserving filter: moving `face` from its cluster to
/// `destination` keeps the faces of the source cluster in the face's vertex ring non-empty and
/// edge-connected without it, and the destination's faces in that ring edge-connected.
/// As the engine decides it: from the cyclic order of the ring where every corner of the face has
/// one closed fan, otherwise by the adjacency between the ring's faces (the two give the same answer).
bool move_keeps_disks(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels, uint32_t face,
                      uint32_t destination);
/// The same tests by adjacency between the ring's faces alone: any ring (boundaries, non-manifold
/// corners), the reference for the cyclic reading.
bool move_keeps_disks_by_adjacency(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                   uint32_t face, uint32_t destination);
/// The cyclic reading alone: 1 keeps, 0 breaks, -1 when it does not apply (a boundary or
/// non-manifold edge or corner, a collapsed face, more than 64 ring faces, or two faces of the
/// tested clusters adjacent across an edge the cycle does not follow). `ring`, when given, gets
/// the ring's faces in cyclic order.
int move_keeps_disks_by_cycle(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                              uint32_t face, uint32_t destination, std::vector<uint32_t>* ring = nullptr);

/// Runs iterations until no face moves (returns true), `max_iterations`, or a stall (energy not
/// decreasing for 16 iterations while faces still move: float round-off trading faces; false).
/// Appends each IterationRecord (tagged with `round`) to out.history and counts out.iterations.
bool run_iterations(IterationEngine& it, uint32_t max_iterations,
                    const std::function<void(const ClusterProgress&)>& progress, uint32_t round, Clustering& out);

/// Connectivity repair of Section 5.3 (split clusters keep their largest piece, the other pieces go
/// to the closest adjacent cluster; clusters enclosed by a single other cluster are dissolved).
/// Returns true when anything changed. Clusters may be left empty. pool (optional): threads for
/// the check that comes first and usually finds nothing to do; the result does not depend on it.
/// check (optional): what the last call's check found, kept by a caller that repairs the same
/// clustering again after a few moves (teleports): the check then walks only the clusters those
/// moves can affect. The result is the same with or without it.
struct RepairCheck;
bool repair_connectivity(const ClusterProblem& problem, const Topology& topology, const std::vector<float>& generators,
                         std::vector<uint32_t>& labels, uint32_t clusters, RepairStats& stats,
                         WorkerPool* pool = nullptr, RepairCheck* check = nullptr);

/// The check before repair_connectivity's work, per cluster, and the labels it was made for
/// (empty: none yet, or the labels were repaired since).
struct RepairCheck {
  std::vector<uint32_t> labels;
  std::vector<uint8_t> whole, open, several;  // one piece; touches a mesh boundary; two or more neighbours
  std::vector<uint32_t> neighbour;            // its first neighbouring cluster, kNone when none
};

/// Re-creates empty clusters by splitting the clusters of highest energy in two connected halves.
/// cluster_component (optional, `clusters` entries): the mesh component each cluster belongs to;
/// an empty cluster is then re-created by splitting the highest-energy cluster of its own
/// component, so per-component counts are kept. Null: any cluster may be split.
/// Returns the number of clusters re-created.
uint32_t restore_cluster_count(const ClusterProblem& problem, const Topology& topology,
                               const std::vector<float>& generators, std::vector<uint32_t>& labels,
                               uint32_t clusters, const std::vector<uint32_t>* cluster_component = nullptr);

/// Checks the final guarantees: every face labeled, every cluster non-empty and connected, and (when
/// avoidable) adjacent to at least two clusters. Returns counts of violations.
struct ClusterValidity {
  uint32_t empty = 0, split = 0, isolated = 0;
  bool ok() const { return empty == 0 && split == 0 && isolated == 0; }
};
ClusterValidity check_clusters(const Topology& topology, const std::vector<uint32_t>& labels, uint32_t clusters);

}  // namespace meshcvt
