// Times curvature_density (src/density.cpp) against build_topology on the same mesh, best of N
// runs, wall and process CPU time (both threads together; steadier on a loaded machine), for
// bench/gradation_bench.sh.
//
// usage: density_bench MESH [REPEATS]
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "meshcvt/density.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: density_bench MESH [REPEATS]\n");
    return 2;
  }
  int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 3;
  meshcvt::Mesh mesh = meshcvt::read_mesh(argv[1]);
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  auto cpu_seconds = [](std::clock_t t) { return double(std::clock() - t) / CLOCKS_PER_SEC; };
  double topology_s = 1e30, density_s = 1e30, topology_cpu = 1e30, density_cpu = 1e30;
  meshcvt::Topology topology;
  std::vector<float> rho;
  for (int r = 0; r < repeats; ++r) {
    auto t0 = Clock::now();
    std::clock_t c0 = std::clock();
    topology = meshcvt::build_topology(mesh);
    topology_s = std::min(topology_s, seconds(t0));
    topology_cpu = std::min(topology_cpu, cpu_seconds(c0));
    t0 = Clock::now();
    c0 = std::clock();
    rho = meshcvt::curvature_density(mesh, topology, 1.0);
    density_s = std::min(density_s, seconds(t0));
    density_cpu = std::min(density_cpu, cpu_seconds(c0));
  }
  auto [lo, hi] = std::minmax_element(rho.begin(), rho.end());
  std::printf("%s: %zu faces, build_topology %.3f s (cpu %.3f s), curvature_density (g = 1) %.3f s (cpu %.3f s), "
              "best of %d; rho %.3g .. %.3g\n",
              argv[1], mesh.face_count(), topology_s, topology_cpu, density_s, density_cpu, repeats, double(*lo),
              double(*hi));
  return 0;
}
