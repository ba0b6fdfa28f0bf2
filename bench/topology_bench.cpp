// Benchmark harness for build_topology and subdivide_midpoint (see bench/topology_bench.sh): reads
// a mesh, optionally subdivides it K times, then builds its topology REPS times and prints the best
// wall time and the best process CPU time (all threads together). On a shared machine the CPU
// time says what the work costs; the wall time also includes waiting for a core.
// usage: topology_bench MESH [K] [REPS] [THREADS]   (THREADS: build_topology's; 0, the default: one per core)
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "meshcvt/io.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"

namespace {

double wall_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double cpu_s() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: topology_bench MESH [K] [REPS] [THREADS]\n");
    return 2;
  }
  unsigned levels = argc > 2 ? unsigned(std::atoi(argv[2])) : 0;
  int reps = argc > 3 ? std::max(1, std::atoi(argv[3])) : 5;
  unsigned threads = argc > 4 ? unsigned(std::atoi(argv[4])) : 0;
  try {
    meshcvt::Mesh mesh = meshcvt::read_mesh(argv[1]);
    double best_wall = 1e30, best_cpu = 1e30;
    if (levels > 0) {
      meshcvt::Mesh fine;
      for (int r = 0; r < reps; ++r) {
        double w = wall_s(), c = cpu_s();
        fine = meshcvt::subdivide_midpoint(mesh, levels);
        best_wall = std::min(best_wall, wall_s() - w);
        best_cpu = std::min(best_cpu, cpu_s() - c);
      }
      std::printf("subdivide_midpoint k=%u: %zu -> %zu faces: best wall %.1f ms, best cpu %.1f ms\n", levels,
                  mesh.face_count(), fine.face_count(), best_wall * 1e3, best_cpu * 1e3);
      mesh = std::move(fine);
    }
    best_wall = best_cpu = 1e30;
    meshcvt::Topology topology;
    for (int r = 0; r < reps; ++r) {
      topology = {};
      double w = wall_s(), c = cpu_s();
      topology = meshcvt::build_topology(mesh, threads);
      best_wall = std::min(best_wall, wall_s() - w);
      best_cpu = std::min(best_cpu, cpu_s() - c);
    }
    double w = wall_s();
    meshcvt::MeshInfo info = meshcvt::mesh_info(mesh, topology);
    double info_ms = (wall_s() - w) * 1e3;
    std::printf("build_topology %zu faces: best wall %.1f ms, best cpu %.1f ms (mesh_info %.1f ms; genus %lld, "
                "%u components)\n",
                mesh.face_count(), best_wall * 1e3, best_cpu * 1e3, info_ms, (long long)info.genus,
                info.components);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "topology_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
