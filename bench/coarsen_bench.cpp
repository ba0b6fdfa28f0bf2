// meshcvt benchmark: uniform coarsening (coarsen_clustering, the dual of a clustering) against the
// clustering it follows. Built and run by bench/coarsen_bench.sh; numbers go to bench/RESULTS.md
// ("Uniform coarsening").
//
// usage: coarsen_bench MESH LEVELS CLUSTERS LABELS [REPEATS] [first-use]
//   MESH     : a mesh file, subdivided LEVELS times (midpoint, 1 -> 4) before anything is timed.
//   CLUSTERS : n.
//   LABELS   : "engine" = meshcvt::cluster() on the CPU (timed, for the ratio), or
//              "grow"   = breadth-first region growing from n evenly spaced seed faces (fast,
//                         connected Voronoi-like regions; for sizes the engine takes too long on).
//   REPEATS  : timed runs of each coarsening call (default 5); the minimum and median are printed.
//   first-use: renumber vertices in order of first use by the faces. subdivide_midpoint numbers new
//              vertices by edge, so vertex order and face order disagree; most files (and this
//              renumbering) keep them close, which the vertex passes' memory accesses prefer.
// Environment: COARSEN_BENCH_OUT=PREFIX writes each coarse mesh to PREFIX-PLACEMENT.off (for
// quality measurements, e.g. the paper's Table 1 columns).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/io.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"

using namespace meshcvt;

namespace {

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// CPU seconds of the whole process (all threads): a second figure that a busy machine disturbs less.
double cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

std::vector<uint32_t> grow_regions(const Mesh& mesh, const Topology& topology, uint32_t clusters) {
  size_t faces = mesh.face_count();
  std::vector<uint32_t> labels(faces, kNone);
  std::vector<uint32_t> queue;
  queue.reserve(faces);
  for (uint32_t i = 0; i < clusters; ++i) {
    uint32_t seed = uint32_t((uint64_t(faces) * i) / clusters);
    if (labels[seed] != kNone) continue;
    labels[seed] = i;
    queue.push_back(seed);
  }
  for (size_t head = 0; head < queue.size(); ++head) {
    uint32_t f = queue[head];
    for (int e = 0; e < 3; ++e) {
      uint32_t g = topology.face_adjacent[3 * size_t(f) + e];
      if (g != kNone && labels[g] == kNone) {
        labels[g] = labels[f];
        queue.push_back(g);
      }
    }
  }
  for (uint32_t& l : labels)
    if (l == kNone) l = 0;  // faces of components without a seed
  return labels;
}

struct Timing {
  double min = 0, median = 0, cpu_min = 0;
};

template <typename F>
Timing repeat(int repeats, F&& f) {
  std::vector<double> t, cpu;
  for (int r = 0; r < repeats; ++r) {
    double t0 = now(), c0 = cpu_now();
    f();
    t.push_back(now() - t0);
    cpu.push_back(cpu_now() - c0);
  }
  std::sort(t.begin(), t.end());
  return {t.front(), t[t.size() / 2], *std::min_element(cpu.begin(), cpu.end())};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: coarsen_bench MESH LEVELS CLUSTERS engine|grow [REPEATS] [first-use]\n");
    return 2;
  }
  std::string path = argv[1], source = argv[4];
  unsigned levels = unsigned(std::atoi(argv[2]));
  uint32_t clusters = uint32_t(std::atol(argv[3]));
  int repeats = argc > 5 ? std::atoi(argv[5]) : 5;
  bool first_use = argc > 6 && std::string(argv[6]) == "first-use";

  Mesh mesh = subdivide_midpoint(read_mesh(path), levels);
  if (first_use) {
    std::vector<uint32_t> remap(mesh.vertex_count(), kNone);
    std::vector<float> positions;
    positions.reserve(mesh.positions.size());
    uint32_t next = 0;
    for (uint32_t& v : mesh.indices) {
      if (remap[v] == kNone) {
        remap[v] = next++;
        positions.insert(positions.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v) + 3]);
      }
      v = remap[v];
    }
    mesh.positions = std::move(positions);
  }
  double t0 = now();
  Topology topology = build_topology(mesh);
  double topology_s = now() - t0;
  std::printf("mesh %s, %u levels%s: %zu faces, %zu vertices; build_topology %.3f s\n", path.c_str(), levels,
              first_use ? ", vertices renumbered by first use" : "", mesh.face_count(), mesh.vertex_count(),
              topology_s);

  std::vector<uint32_t> labels;
  double cluster_s = 0;
  if (source == "engine") {
    ClusterOptions options;
    options.clusters = clusters;
    options.device = "cpu";
    t0 = now();
    Clustering c = cluster(mesh, topology, options);
    cluster_s = now() - t0;
    labels = std::move(c.labels);
    std::printf("cluster (cpu, %s): %.3f s, %u iterations\n", c.device.c_str(), cluster_s, c.iterations);
  } else {
    labels = grow_regions(mesh, topology, clusters);
    std::printf("labels: region growing from %u seeds\n", clusters);
  }

  for (VertexPlacement placement : {VertexPlacement::closest, VertexPlacement::qem, VertexPlacement::projected}) {
    CoarsenOptions options;
    options.placement = placement;
    CoarsenResult result;
    int runs = placement == VertexPlacement::projected ? std::max(1, repeats / 2) : repeats;
    Timing t = repeat(runs, [&] { result = coarsen_clustering(mesh, topology, labels, clusters, options); });
    std::printf("coarsen_clustering %-9s: wall min %.4f s, median %.4f s, cpu %.4f s", to_string(placement), t.min,
                t.median, t.cpu_min);
    if (cluster_s > 0) std::printf(" (%.1f%% of clustering)", 100 * t.min / cluster_s);
    std::printf("; %zu triangles, %llu corners, %llu n-gons, %zu defects\n", result.mesh.face_count(),
                (unsigned long long)result.corner_vertices, (unsigned long long)result.polygons_triangulated,
                result.defects.size());
    if (const char* prefix = std::getenv("COARSEN_BENCH_OUT"))
      write_mesh(std::string(prefix) + "-" + to_string(placement) + ".off", result.mesh);
  }
  Timing t = repeat(repeats, [&] { (void)find_dual_defects(mesh, topology, labels, clusters); });
  std::printf("find_dual_defects (closest): wall min %.4f s, median %.4f s, cpu %.4f s\n", t.min, t.median, t.cpu_min);
  return 0;
}
