// meshcvt: face clustering by approximating a Centroidal Voronoi Tessellation.
//
// Implements Fan, Cheng, Huang, Li, Wang, Lai, "Mesh Clustering by Approximating Centroidal Voronoi
// Tessellation" (SPM 2009): boundary testing with configuration-wise updating (Section 3.1), the
// L2,1 metric (Section 4), hierarchical initialization (5.1), accelerators (5.2) and connectivity
// repair (5.3).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"

namespace meshcvt {

/// What a cluster's generator is and how far a face is from it. Every metric gives face k a weight
/// w_k = rho_k * |T_k| and a point p_k; cluster i keeps S_i = sum w_k p_k and W_i = sum w_k.
enum class Metric {
  cvt,   ///< p_k = centroid, generator = mass centroid S_i / W_i (eq. 5)
  ccvt,  ///< as cvt, generator = closest point of the mesh to the mass centroid (eq. 6)
  l21,   ///< p_k = unit normal, generator = normalize(S_i) (Section 4, proxy normal N_i)
};

/// How the first valid clustering is made.
enum class Init {
  hierarchical,  ///< dual-graph edge contraction with the paper's cost F(e_ij) (Section 5.1)
  random,        ///< seeded region growing from random faces
};

/// How the iteration keeps clusters connected.
enum class TopologyMode {
  /// Default: a move is applied only when both clusters stay locally disks around the moved face,
  /// so clusters stay connected without repair (beyond the paper; see cluster_iterate.cpp).
  preserving,
  /// The paper's literal rule; connectivity repaired after convergence (Section 5.3).
  paper,
};

/// Progress reported between iterations.
struct ClusterProgress {
  const char* phase = "";    ///< "init", "iterate", "repair"
  uint32_t iteration = 0;
  uint64_t moves = 0;        ///< faces moved in that iteration
};

struct ClusterOptions {
  uint32_t clusters = 0;  ///< n: exactly this many non-empty connected clusters come out
  Metric metric = Metric::cvt;
  Init init = Init::hierarchical;
  TopologyMode topology = TopologyMode::preserving;
  uint32_t max_iterations = 1000;  ///< per round of iteration; the loop also ends when no face moves
  bool accelerate = true;          ///< Section 5.2: skip settled cluster edges (exact: same result)
  /// After initialization (not with initial_labels): at most this many Lloyd steps, each moving every
  /// border to the bisector of the current generators at once (a constrained flood, see
  /// cluster_flood.cpp, with momentum), kept only while they lower the energy and stopped once one
  /// gains < 0.2% (less with over 100 faces per cluster). They do the long-range work that would
  /// take boundary testing one face layer per iteration; 0 leaves the initialization as the paper
  /// has it.
  uint32_t lloyd_steps = 64;
  unsigned threads = 0;            ///< 0: every core. The result does not depend on it.
  uint64_t seed = 1;               ///< for Init::random
  /// "auto", "cpu", "gpu" or "gpu:N". Empty: $MESHCVT_DEVICE, else "auto". "auto" takes a GPU only
  /// for auto_gpu_min_faces(threads) faces or more (meshcvt/device.h: 1M per two threads).
  std::string device;
  /// When the GPU asked for cannot be had (no Vulkan loader, no such device, none usable) or its
  /// engine fails (a DeviceError: its setup, out of device memory, a lost device, a failed rule
  /// check), run on the CPU engine (from the same start) instead of throwing: the labels are then
  /// the CPU engine's, as with "cpu", and Clustering::device_notice says why. A GPU chosen by
  /// "auto" always fails over so; set this to let "gpu" and "gpu:N" do it too.
  bool cpu_fallback = false;
  /// Optional per-face density rho_k (face_count entries, > 0); empty means 1 everywhere.
  std::vector<float> density;
  /// Optional: how many clusters each connected component of the face graph gets (indexed like
  /// Topology::face_component; component_count entries, each >= 1 and <= the component's faces,
  /// summing to `clusters`). Initialization puts exactly that many in each component and restoring n
  /// after repair re-creates a lost cluster inside the component that lost it, so every component
  /// ends with exactly its count. Empty: initialization decides (at least one per component).
  std::vector<uint32_t> component_clusters;
  /// Optional: start from these labels (face_count entries in [0, clusters)) instead of
  /// initializing; `init` and `seed` are then unused. A label's faces must lie in one component;
  /// labels need not be connected or all used (repair and restore make exactly n connected
  /// clusters). With component_clusters, each component must hold at most its count of labels
  /// (unused labels are given to the components short of their count, in component order).
  std::vector<uint32_t> initial_labels;
  /// Called after each iteration (from the calling thread). May be empty.
  std::function<void(const ClusterProgress&)> progress;
};

/// One iteration of the boundary test.
struct IterationRecord {
  double energy = 0;            ///< metric energy after the iteration, in normalized units (see Clustering)
  uint64_t moves = 0;           ///< faces that changed cluster
  uint64_t evaluated_faces = 0; ///< faces whose cluster edges were tested
  uint32_t round = 0;           ///< 0 before any repair; k after the k-th repair-and-iterate round
};

/// What connectivity repair did.
struct RepairStats {
  uint32_t rounds = 0;               ///< repair + iterate rounds after the first convergence
  uint64_t split_pieces = 0;         ///< extra pieces of split clusters merged into neighbours
  uint64_t reassigned_faces = 0;     ///< faces moved by repair
  uint32_t dissolved_isolated = 0;   ///< clusters enclosed by one other cluster, dissolved
  uint32_t restored_clusters = 0;    ///< clusters re-created by splitting to get back to n
};

/// Time spent in each phase, seconds. setup: the problem and the engine; the GPU engine's own
/// setup (device, pipelines, uploads) runs beside the initialization, and only what the
/// initialization did not hide counts here. init_lloyd: the part of init spent in the Lloyd steps
/// (the rest is the initial clustering, hierarchical or random, and dissolving enclosed clusters).
struct ClusterTimings {
  double setup = 0, init = 0, init_lloyd = 0, iterate = 0, repair = 0, total = 0;
};

struct Clustering {
  std::vector<uint32_t> labels;    ///< cluster id in [0, n) per face
  /// 3 floats per cluster: cvt/ccvt: the generator in input coordinates; l21: the unit proxy normal.
  std::vector<float> generators;
  /// Energies are computed in double in normalized coordinates (bounding box scaled to unit size),
  /// so they compare across meshes; history[0] is the initial clustering.
  std::vector<IterationRecord> history;
  uint32_t iterations = 0;  ///< iterations run, over all rounds
  bool converged = false;   ///< the last round ended because no face moved
  RepairStats repair;
  ClusterTimings timings;
  std::string device;       ///< which engine ran, e.g. "cpu (2 threads)" or the GPU's name
  /// One line saying why the CPU engine ran where a GPU was looked for: "auto" found a GPU that
  /// lacks a feature, or none where the machine seemed to have one (no loader, no device), or the
  /// GPU engine failed and fell back (ClusterOptions::cpu_fallback); else empty.
  std::string device_notice;
  /// The CPU engine ran because the GPU asked for failed or could not be had, and the job went on
  /// (a GPU that "auto" chose, or ClusterOptions::cpu_fallback; device_notice says why). A caller
  /// that clusters the same mesh again (coarsen's fix loop) asks for "cpu" from then on rather
  /// than set the failing GPU up again.
  bool fell_back = false;
};

/// Clusters the faces of `mesh` into exactly options.clusters connected clusters.
/// Faces with a repeated corner index (collapsed: no area and no edges, e.g. welded slivers) are
/// left out, unless component_clusters is given or every face is collapsed: the clusters are those
/// of the other faces (they count as no component), and each collapsed face takes the cluster of
/// the lowest face at its lowest corner that has one (labels_with_collapsed_faces; cluster 0 where
/// none shares a corner). density and initial_labels still have an entry per face.
/// Throws OptionError when n = 0, n > faces, or n < number of connected components (the message
/// names the numbers), when component_clusters or initial_labels do not fit the mesh as documented
/// above, DeviceError when a GPU was asked for and cannot run.
Clustering cluster(const Mesh& mesh, const ClusterOptions& options);

/// Same, reusing a topology already built for `mesh`.
Clustering cluster(const Mesh& mesh, const Topology& topology, const ClusterOptions& options);

/// Parses "cvt", "ccvt", "l21" / "hierarchical", "random" / "preserving", "paper";
/// throws OptionError naming the accepted values.
Metric parse_metric(const std::string& s);
Init parse_init(const std::string& s);
TopologyMode parse_topology_mode(const std::string& s);
const char* to_string(Metric m);
const char* to_string(Init i);
const char* to_string(TopologyMode t);

}  // namespace meshcvt
