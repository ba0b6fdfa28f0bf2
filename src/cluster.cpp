// meshcvt: the clustering driver — Fan et al. end to end: initialization (5.1), boundary-testing
// iterations (3.1, 4, 5.2), then the safety net of connectivity repair (5.3) and restoring exactly n
// clusters, iterating again until the clustering is converged and valid.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <future>
#include <system_error>
#include <string>
#include <thread>

#include "cluster_engine.h"
#include "meshcvt/cluster.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"
#include "meshcvt/topology.h"
#include "parallel.h"

namespace meshcvt {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Rounds of repair + iterate before giving up on a perfectly valid result (repair alone still makes
// every cluster connected; see cluster()).
constexpr uint32_t kMaxRepairRounds = 8;

// Lloyd steps after initialization stop once one lowers the energy by less than a fraction of it:
// kLloydMinGain up to kLloydReferenceSize faces per cluster, less above, as (reference / size)^1.5.
// Boundary testing needs about one iteration per face layer a border still has to travel, so the
// more faces per cluster, the longer a global step stays the cheaper way down (measured with
// momentum 0.8, cluster_flood.cpp, on the 1.2M bunny -> 10k: 0.005 2.16 s, 0.002 1.78 s; the 4.8M
// bunny -> 10k: 0.002 12.8 s, 0.001 11.4 s, 0.0005 10.1 s; bunny00 -> 1000: 0.002 78 ms, 0.001
// 86 ms). Seventh session, after the faster iteration and initialization, hierarchy + Lloyd +
// iterations (min, alternating): 4.8M 4.08 s at the linear scaling's 0.00042 (26 steps), 3.90-3.96
// s at 0.0002 (33 steps); 1.2M and bunny00 the same within noise either way.
constexpr double kLloydMinGain = 0.002;
// Passes of repair + restore before the first iteration while a cluster is enclosed.
constexpr uint32_t kMaxEnclosedPasses = 4;
constexpr double kLloydReferenceSize = 100;
double lloyd_min_gain(uint32_t faces, uint32_t clusters) {
  double faces_per_cluster = double(faces) / std::max<uint32_t>(clusters, 1);
  return kLloydMinGain * std::min(1.0, std::pow(kLloydReferenceSize / faces_per_cluster, 1.5));
}

// Checks ClusterOptions::component_clusters against the mesh (OptionError naming the numbers).
void check_component_clusters(const Topology& topology, uint32_t face_count, const ClusterOptions& options) {
  const std::vector<uint32_t>& wanted = options.component_clusters;
  if (wanted.size() != topology.component_count)
    throw OptionError("component_clusters has " + std::to_string(wanted.size()) + " entries, the mesh has " +
                      std::to_string(topology.component_count) + " connected components");
  std::vector<uint32_t> faces(topology.component_count, 0);
  for (uint32_t f = 0; f < face_count; ++f) ++faces[topology.face_component[f]];
  uint64_t sum = 0;
  for (uint32_t c = 0; c < topology.component_count; ++c) {
    if (wanted[c] == 0 || wanted[c] > faces[c])
      throw OptionError("component " + std::to_string(c) + " has " + std::to_string(faces[c]) + " faces, cannot hold " +
                        std::to_string(wanted[c]) + " clusters");
    sum += wanted[c];
  }
  if (sum != options.clusters)
    throw OptionError("component_clusters add up to " + std::to_string(sum) + ", not the " +
                      std::to_string(options.clusters) + " clusters asked for");
}

// The component of every cluster of `labels` (kNone for an unused label), checking that no label
// spans two components; with per-component counts, unused labels are handed to the components short
// of their count (in component order) and a component holding too many labels is an error.
std::vector<uint32_t> label_components(const Topology& topology, const std::vector<uint32_t>& labels,
                                       const ClusterOptions& options) {
  const uint32_t n = options.clusters;
  std::vector<uint32_t> component(n, kNone);
  for (uint32_t f = 0; f < labels.size(); ++f) {
    uint32_t l = labels[f], c = topology.face_component[f];
    if (l >= n)
      throw OptionError("initial label " + std::to_string(l) + " of face " + std::to_string(f) + " is not below the " +
                        std::to_string(n) + " clusters");
    if (component[l] == kNone)
      component[l] = c;
    else if (component[l] != c)
      throw OptionError("initial label " + std::to_string(l) + " spans mesh components " +
                        std::to_string(component[l]) + " and " + std::to_string(c));
  }
  if (options.component_clusters.empty()) return component;
  std::vector<uint32_t> held(topology.component_count, 0);
  for (uint32_t l = 0; l < n; ++l)
    if (component[l] != kNone) ++held[component[l]];
  for (uint32_t k = 0; k < topology.component_count; ++k)
    if (held[k] > options.component_clusters[k])
      throw OptionError("initial labels put " + std::to_string(held[k]) + " clusters in component " + std::to_string(k) +
                        ", component_clusters allows " + std::to_string(options.component_clusters[k]));
  uint32_t c = 0;
  for (uint32_t l = 0; l < n; ++l) {
    if (component[l] != kNone) continue;
    while (held[c] >= options.component_clusters[c]) ++c;  // terminates: the counts add up to n
    component[l] = c;
    ++held[c];
  }
  return component;
}
}  // namespace

// Energy that has not decreased for this many iterations with faces still moving means float round-off
// is trading faces back and forth: stop rather than spin until max_iterations.
constexpr uint32_t kStallLimit = 16;

bool run_iterations(IterationEngine& it, uint32_t max_iterations,
                    const std::function<void(const ClusterProgress&)>& progress, uint32_t round, Clustering& out) {
  double best = it.energy();
  uint32_t stalled = 0;
  for (uint32_t i = 0; i < max_iterations; ++i) {
    IterationRecord r = it.step();
    r.round = round;
    out.history.push_back(r);
    ++out.iterations;
    if (progress) progress(ClusterProgress{"iterate", out.iterations, r.moves});
    if (r.moves == 0) return true;
    if (r.energy < best) {
      best = r.energy;
      stalled = 0;
    } else if (++stalled >= kStallLimit) {
      return false;
    }
  }
  return false;
}

Clustering cluster(const Mesh& mesh, const ClusterOptions& options) {
  return cluster(mesh, build_topology(mesh, options.threads), options);
}

namespace {

// cluster() of `mesh` without its collapsed faces, the labels given back to every face
// (labels_with_collapsed_faces: the cluster of a face at a corner). Only without per-component
// counts (those count the collapsed faces' own components).
Clustering cluster_without_collapsed_faces(const Mesh& mesh, const Topology& topology, const ClusterOptions& options) {
  const size_t faces = mesh.face_count();
  Mesh kept = mesh;
  std::vector<uint32_t> kept_index;
  remove_collapsed_faces(kept, &kept_index);
  ClusterOptions kept_options = options;
  auto keep = [&]<class T>(const std::vector<T>& per_face, std::vector<T>& out, const char* what) {
    if (per_face.empty()) return;
    if (per_face.size() != faces)
      throw OptionError(std::string(what) + " has " + std::to_string(per_face.size()) + " entries for " +
                        std::to_string(faces) + " faces");
    out.clear();
    for (size_t f = 0; f < faces; ++f)
      if (kept_index[f] != kNone) out.push_back(per_face[f]);
  };
  keep(options.density, kept_options.density, "the density");
  keep(options.initial_labels, kept_options.initial_labels, "initial_labels");
  Clustering out = cluster(kept, build_topology(kept, options.threads), kept_options);
  out.labels = labels_with_collapsed_faces(mesh, topology, kept_index, out.labels, 0);
  return out;
}

// The iterations and repair rounds from `labels` to the result, on `it`: out's labels,
// generators, history, iterations, converged, repair, device and iterate/repair timings.
void converge(IterationEngine& it, std::vector<uint32_t> labels, const ClusterProblem& problem,
              const Topology& topology, const std::vector<uint32_t>& cluster_component,
              const ClusterOptions& options, WorkerPool& pool, Clustering& out) {
  out.device = it.description();
  it.reset(std::move(labels));
  out.history.push_back(IterationRecord{it.energy(), 0, 0, 0});

  double iterate_s = 0, repair_s = 0;
  for (uint32_t round = 0;; ++round) {
    auto t = Clock::now();
    out.converged = run_iterations(it, options.max_iterations, options.progress, round, out);
    iterate_s += seconds_since(t);

    t = Clock::now();
    it.release_step_memory();  // reset() below re-creates it when another round follows
    std::vector<uint32_t> current = it.labels();
    std::vector<float> generators = it.generators();
    bool repaired = repair_connectivity(problem, topology, generators, current, problem.clusters, out.repair, &pool);
    uint32_t restored = restore_cluster_count(problem, topology, generators, current, problem.clusters,
                                              cluster_component.empty() ? nullptr : &cluster_component);
    out.repair.restored_clusters += restored;
    repair_s += seconds_since(t);
    if (options.progress && (repaired || restored)) options.progress(ClusterProgress{"repair", out.iterations, 0});
    if (!repaired && restored == 0) break;
    it.reset(std::move(current));
    if (round + 1 >= kMaxRepairRounds) {
      // Out of rounds: keep the repaired (connected, exactly n) clustering without iterating again.
      out.converged = false;
      break;
    }
    out.repair.rounds = round + 1;
  }
  out.timings.iterate = iterate_s;
  out.timings.repair = repair_s;

  out.labels = it.labels();
  const std::vector<float>& g = it.generators();
  out.generators.resize(g.size());
  for (size_t c = 0; c < g.size() / 3; ++c)
    for (int k = 0; k < 3; ++k)
      out.generators[3 * c + k] =
          options.metric == Metric::l21 ? g[3 * c + k] : problem.origin[k] + problem.extent * g[3 * c + k];
}

}  // namespace

Clustering cluster(const Mesh& mesh, const Topology& topology, const ClusterOptions& options) {
  // Faces with a repeated corner (left by welding: assimp-testmodels' spider has 56) have no area
  // and no edges: each is a component of its own and took a cluster (spider -> 136: 56 clusters of
  // one such face). They are left out, and take a neighbour's cluster afterwards.
  if (topology.collapsed_faces > 0 && topology.collapsed_faces < mesh.face_count() &&
      options.component_clusters.empty())
    return cluster_without_collapsed_faces(mesh, topology, options);
  auto t_start = Clock::now();
  DeviceChoice choice;
  bool no_gpu_to_be_had = false;
  try {
    choice = resolve_device_for_mesh(options.device, mesh.face_count(), options.threads);
  } catch (const DeviceError& e) {  // no loader, no such device, none usable
    if (!options.cpu_fallback) throw;
    no_gpu_to_be_had = true;
    choice.description = "cpu";
    choice.notice = "using the CPU engine, not " +
                    (options.device.empty() ? std::string("the device $MESHCVT_DEVICE names")
                                            : "\"" + options.device + "\"") +
                    ": " + e.what();
  }

  Clustering out;
  out.device_notice = choice.notice;
  out.fell_back = no_gpu_to_be_had;
  WorkerPool pool(options.threads);
  ClusterProblem problem = make_cluster_problem(mesh, options, &pool);
  // L2,1 compares the faces' normals: on a mesh whose triangles are ordered at random (libcgal-demo's
  // *-shuffled meshes) half of them point the wrong way. The normals are taken as if the faces were
  // oriented consistently (faces_to_orient); the mesh itself is left as it is.
  if (problem.metric == Metric::l21 && topology.orientation_flips > 0) {
    const std::vector<uint8_t> flip = faces_to_orient(mesh, topology);
    for (size_t f = 0; f < flip.size(); ++f)
      if (flip[f])
        for (int c = 0; c < 3; ++c) problem.point[3 * f + c] = -problem.point[3 * f + c];
  }
  std::unique_ptr<IterationEngine> engine;
  // The GPU engine's setup (device, pipelines, the arrays' upload: 0.6 s for 4.8M faces on an H200)
  // needs only the problem, so it runs on its own thread beside the initialization, which keeps
  // the pool busy on the CPU; the engine is taken before the first iteration. (An error there,
  // DeviceError say, comes out of get(); where no thread can be had it is built here.)
  std::future<std::unique_ptr<IterationEngine>> gpu_setup;
  auto make_gpu = [&] {
    return make_gpu_iteration(problem, mesh, topology, options.topology, options.accelerate, choice.device_index);
  };
  auto make_cpu = [&] {
    return std::make_unique<BoundaryIteration>(problem, mesh, topology, options.topology, options.accelerate, pool);
  };
  // Where the GPU engine may fail over (options.cpu_fallback, or a GPU that "auto" chose), a
  // DeviceError from it (setup, out of memory, a lost device, a failed rule check) hands the job to
  // the CPU engine, which takes the same decisions: the result is what `cpu` gives.
  const bool may_fall_back = choice.use_gpu && (options.cpu_fallback || choice.automatic);
  bool on_gpu = choice.use_gpu;
  auto fall_back = [&](const DeviceError& e) {  // (called in a handler: `throw` rethrows e)
    if (!may_fall_back || !on_gpu) throw;
    // (reason(): the error's advice, "try --device cpu", is what happens here already)
    out.device_notice = "using the CPU engine: the GPU engine on " + choice.description + " failed: " + e.reason();
    out.fell_back = true;
    engine.reset();  // (the GPU's buffers go before the CPU engine's arrays come)
    engine = make_cpu();
    on_gpu = false;
  };
  if (choice.use_gpu) {
    try {
      try {
        gpu_setup = std::async(std::launch::async, make_gpu);
      } catch (const std::system_error&) {
        engine = make_gpu();
      }
    } catch (const DeviceError& e) {
      fall_back(e);
    }
  } else {
    engine = make_cpu();
  }
  out.timings.setup = seconds_since(t_start);

  auto t = Clock::now();
  if (!options.component_clusters.empty()) check_component_clusters(topology, problem.face_count, options);
  std::vector<uint32_t> labels;
  // cluster -> mesh component, so restoring n re-creates a lost cluster where it was lost; only with
  // per-component counts (otherwise the original, global restore).
  std::vector<uint32_t> cluster_component;
  if (!options.initial_labels.empty()) {
    if (options.clusters == 0) throw OptionError("the number of clusters must be at least 1");
    if (options.initial_labels.size() != problem.face_count)
      throw OptionError("initial_labels has " + std::to_string(options.initial_labels.size()) + " entries for " +
                        std::to_string(problem.face_count) + " faces");
    if (options.clusters > problem.face_count)
      throw OptionError("cannot make " + std::to_string(options.clusters) + " clusters from " +
                        std::to_string(problem.face_count) + " faces");
    labels = options.initial_labels;
    cluster_component = label_components(topology, labels, options);
  } else {
    labels = initial_clustering(problem, mesh, topology, options.init, options.clusters, options.seed,
                                &options.component_clusters, &pool);
    if (!options.component_clusters.empty()) cluster_component = label_components(topology, labels, options);
    // Lloyd steps keep every cluster inside its component (they only trade faces between adjacent
    // clusters), so per-component counts hold.
    ClusterGraph graph;
    const auto t_lloyd = Clock::now();
    lloyd_flood_steps(problem, topology, pool, labels, options.lloyd_steps,
                      lloyd_min_gain(problem.face_count, problem.clusters), &graph);
    out.timings.init_lloyd = seconds_since(t_lloyd);
    // The hierarchy can leave a cluster enclosed by a single other one (for l21: an island of
    // other normals inside a region), and the Lloyd steps keep it. No topology-preserving move
    // removes it, so it used to stay until the repair after convergence, which dissolved it,
    // split a cluster to get back to n and iterated a second time (bunny00 -> 100 l21: 135 + 90
    // iterations). Dissolved now, before iterating. The repair runs only when there is an
    // enclosed cluster (its own checks cost 22 ms on the 1.2M bunny).
    // Dissolving a cluster can leave a neighbour enclosed in turn (the elephant -> 40: a cluster
    // that touched only the dissolved one and the one around both), so this repeats while there
    // is one, a few times at most; what is left the repair after convergence still catches.
    for (uint32_t pass = 0; pass < kMaxEnclosedPasses && !enclosed_clusters(graph).empty(); ++pass) {
      const std::vector<float> generators =
          generators_of(problem, compute_cluster_sums(problem, labels, problem.clusters, &pool));
      repair_connectivity(problem, topology, generators, labels, problem.clusters, out.repair, &pool);
      out.repair.restored_clusters += restore_cluster_count(problem, topology, generators, labels, problem.clusters,
                                                            cluster_component.empty() ? nullptr : &cluster_component);
      build_cluster_graph(topology, labels, problem.clusters, graph, &pool);
    }
  }
  if (options.component_clusters.empty()) cluster_component.clear();
  out.timings.init = seconds_since(t);
  if (gpu_setup.valid()) {
    t = Clock::now();
    try {
      engine = gpu_setup.get();
    } catch (const DeviceError& e) {
      fall_back(e);
    }
    out.timings.setup += seconds_since(t);  // what the initialization did not hide
  }
  if (options.progress) options.progress(ClusterProgress{"init", 0, 0});

  // A GPU that fails while iterating hands the job to the CPU engine from the same start, as if
  // it had run there from the beginning (what the iterations and repairs add to `out` is undone).
  std::vector<uint32_t> start_labels;
  Clustering out_at_start;
  if (may_fall_back && on_gpu) start_labels = labels, out_at_start = out;
  try {
    converge(*engine, std::move(labels), problem, topology, cluster_component, options, pool, out);
  } catch (const DeviceError& e) {
    if (!may_fall_back || !on_gpu) throw;
    const ClusterTimings timings = out.timings;
    out = std::move(out_at_start);
    out.timings = timings;
    fall_back(e);
    converge(*engine, std::move(start_labels), problem, topology, cluster_component, options, pool, out);
  }
  out.timings.total = seconds_since(t_start);
  return out;
}


Metric parse_metric(const std::string& s) {
  if (s == "cvt") return Metric::cvt;
  if (s == "ccvt") return Metric::ccvt;
  if (s == "l21") return Metric::l21;
  throw OptionError("unknown metric '" + s + "' (expected cvt, ccvt or l21)");
}

Init parse_init(const std::string& s) {
  if (s == "hierarchical") return Init::hierarchical;
  if (s == "random") return Init::random;
  throw OptionError("unknown initialization '" + s + "' (expected hierarchical or random)");
}

TopologyMode parse_topology_mode(const std::string& s) {
  if (s == "preserving") return TopologyMode::preserving;
  if (s == "paper") return TopologyMode::paper;
  throw OptionError("unknown topology mode '" + s + "' (expected preserving or paper)");
}

const char* to_string(Metric m) {
  switch (m) {
    case Metric::cvt: return "cvt";
    case Metric::ccvt: return "ccvt";
    case Metric::l21: return "l21";
  }
  return "?";
}

const char* to_string(Init i) { return i == Init::hierarchical ? "hierarchical" : "random"; }
const char* to_string(TopologyMode t) { return t == TopologyMode::preserving ? "preserving" : "paper"; }

}  // namespace meshcvt
