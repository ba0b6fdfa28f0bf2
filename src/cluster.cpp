// meshcvt: the clustering driver — Fan et al. end to end: initialization (5.1), boundary-testing
// iterations (3.1, 4, 5.2), then the safety net of connectivity repair (5.3) and restoring exactly n
// clusters, iterating again until the clustering is converged and valid.
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

#include "cluster_engine.h"
#include "meshcvt/cluster.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"
#include "parallel.h"

namespace meshcvt {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Rounds of repair + iterate before giving up on a perfectly valid result (repair alone still makes
// every cluster connected; see cluster()).
constexpr uint32_t kMaxRepairRounds = 8;
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
  return cluster(mesh, build_topology(mesh), options);
}

Clustering cluster(const Mesh& mesh, const Topology& topology, const ClusterOptions& options) {
  auto t_start = Clock::now();
  DeviceChoice choice = resolve_device(options.device);

  Clustering out;
  out.device_notice = choice.notice;
  ClusterProblem problem = make_cluster_problem(mesh, options);
  WorkerPool pool(options.threads);
  std::unique_ptr<IterationEngine> engine;
  if (choice.use_gpu)
    engine = make_gpu_iteration(problem, mesh, topology, options.topology, options.accelerate, choice.device_index);
  else
    engine = std::make_unique<BoundaryIteration>(problem, mesh, topology, options.topology, options.accelerate, pool);
  out.device = engine->description();
  out.timings.setup = seconds_since(t_start);

  auto t = Clock::now();
  std::vector<uint32_t> labels =
      initial_clustering(problem, mesh, topology, options.init, options.clusters, options.seed);
  out.timings.init = seconds_since(t);
  if (options.progress) options.progress(ClusterProgress{"init", 0, 0});

  IterationEngine& it = *engine;
  it.reset(std::move(labels));
  out.history.push_back(IterationRecord{it.energy(), 0, 0, 0});

  double iterate_s = 0, repair_s = 0;
  for (uint32_t round = 0;; ++round) {
    t = Clock::now();
    out.converged = run_iterations(it, options.max_iterations, options.progress, round, out);
    iterate_s += seconds_since(t);

    t = Clock::now();
    std::vector<uint32_t> current = it.labels();
    std::vector<float> generators = it.generators();
    bool repaired = repair_connectivity(problem, topology, generators, current, problem.clusters, out.repair);
    uint32_t restored = restore_cluster_count(problem, topology, generators, current, problem.clusters);
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
