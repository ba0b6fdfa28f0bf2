// meshcvt benchmark of the GPU engine's kernels (issue "Vulkan GPU engine", Performance): the
// boundary-test kernel's GPU time from timestamps written around it, the bytes it must touch, and
// what that is of the device's peak bandwidth; next to the CPU engine on the same iterations.
//
// Two runs from the same hierarchical initialization (metric cvt, topology preserving):
//   accelerated: the engine as `cluster` runs it, until no face moves; labels are compared with
//                the CPU engine's, face for face, and the per-iteration times of both are printed.
//   full:        every face tested every iteration (no active set), the first 5 iterations: the
//                kernel at its heaviest, the case a bandwidth figure is meant for.
//
// Bytes, a lower bound (what the kernel cannot avoid reading or writing once):
//   every face:      label 4 + dirty flag 4 + 3 adjacent faces 12           = 20 B
//   evaluated face:  point 12 + weight 4 (the neighbours' are counted as theirs) = 16 B more
//   proposal:        destination 4 + state 4 + list entry 4                 = 12 B more
// The neighbours' labels and points, the generators and the changed flags are taken to hit in
// cache (they are small or shared); so the bandwidth printed is at most what the kernel moves.
//
// Usage: gpu_kernel_bench MESH CLUSTERS PEAK_GB_PER_S [DEVICE_INDEX]
//   (default device: the one "gpu" picks; see bench/gpu_bench.sh, which runs it)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cluster_engine.h"
#include "meshcvt/cluster.h"
#include "meshcvt/device.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "parallel.h"

using namespace meshcvt;
using Clock = std::chrono::steady_clock;

static double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

static int run(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: gpu_kernel_bench MESH CLUSTERS PEAK_GB_PER_S [DEVICE_INDEX]\n");
    return 2;
  }
  const std::string path = argv[1];
  const uint32_t clusters = uint32_t(std::strtoul(argv[2], nullptr, 10));
  const double peak_gbps = std::strtod(argv[3], nullptr);
  const int device = argc > 4 ? std::atoi(argv[4]) : resolve_device("gpu").device_index;

  Mesh mesh = read_mesh(path);
  Topology topology = build_topology(mesh);
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  WorkerPool pool(threads);
  ClusterOptions options;
  options.clusters = clusters;
  options.metric = Metric::cvt;
  auto start = Clock::now();
  ClusterProblem problem = make_cluster_problem(mesh, options, &pool);
  const double problem_s = since(start);
  start = Clock::now();
  std::vector<uint32_t> initial =
      initial_clustering(problem, mesh, topology, Init::hierarchical, clusters, 1, nullptr, &pool);
  const double init_s = since(start);
  const uint64_t nf = problem.face_count;
  std::printf("%s: %llu faces -> %u clusters; %u CPU threads; problem %.3f s, hierarchical init %.3f s (CPU)\n",
              path.c_str(), (unsigned long long)nf, clusters, threads, problem_s, init_s);

  // CPU engine, accelerated, until nothing moves.
  BoundaryIteration cpu(problem, mesh, topology, TopologyMode::preserving, true, pool);
  cpu.reset(initial);
  uint32_t cpu_iterations = 0;
  start = Clock::now();
  for (; cpu_iterations < 1000; ++cpu_iterations)
    if (cpu.step().moves == 0) break;
  const double cpu_s = since(start);

  // GPU engine, accelerated: as `cluster` runs it.
  start = Clock::now();
  std::unique_ptr<IterationEngine> gpu =
      make_gpu_iteration(problem, mesh, topology, TopologyMode::preserving, true, device);
  const double setup_s = since(start);
  if (!gpu->start_kernel_timing()) throw std::runtime_error("the GPU engine cannot time its kernels");
  start = Clock::now();
  gpu->reset(initial);
  const double reset_s = since(start);
  uint32_t gpu_iterations = 0;
  uint64_t evaluated = 0, moves = 0;
  start = Clock::now();
  for (; gpu_iterations < 1000; ++gpu_iterations) {
    IterationRecord r = gpu->step();
    evaluated += r.evaluated_faces;
    moves += r.moves;
    if (r.moves == 0) break;
  }
  const double gpu_s = since(start);
  const bool same = gpu->labels() == cpu.labels();
  KernelTimes k = gpu->kernel_times();
  std::printf("  %s; engine setup %.3f s, reset %.3f s\n", gpu->description().c_str(), setup_s, reset_s);
  std::printf("  accelerated: CPU %u iterations %.3f s (%.2f ms each); GPU %u iterations %.3f s (%.2f ms each); "
              "labels %s\n",
              cpu_iterations + 1, cpu_s, 1e3 * cpu_s / (cpu_iterations + 1), gpu_iterations + 1, gpu_s,
              1e3 * gpu_s / (gpu_iterations + 1), same ? "identical" : "DIFFER");
  const double dispatches = double(std::max<uint64_t>(k.boundary_dispatches, 1));
  // Bytes per the model above; moves stand in for proposals (every proposal that passes moves).
  const double accel_bytes = 20.0 * nf * dispatches + 16.0 * evaluated + 12.0 * moves;
  std::printf("  accelerated kernels: boundary %.3f ms in all (%.1f us per dispatch), update %.3f ms; "
              "boundary >= %.1f GB/s = %.1f%% of %.0f GB/s\n",
              1e3 * k.boundary_s, 1e6 * k.boundary_s / dispatches, 1e3 * k.update_s,
              accel_bytes / k.boundary_s * 1e-9, 100.0 * accel_bytes / k.boundary_s * 1e-9 / peak_gbps, peak_gbps);

  // Every face tested every iteration: the first 5 iterations from the same start.
  gpu.reset();
  std::unique_ptr<IterationEngine> full =
      make_gpu_iteration(problem, mesh, topology, TopologyMode::preserving, false, device);
  full->start_kernel_timing();
  full->reset(initial);
  uint64_t full_evaluated = 0, full_moves = 0;
  const int full_iterations = 5;
  for (int i = 0; i < full_iterations; ++i) {
    IterationRecord r = full->step();
    full_evaluated += r.evaluated_faces;
    full_moves += r.moves;
  }
  KernelTimes kf = full->kernel_times();
  const double full_bytes = 20.0 * nf * full_iterations + 16.0 * full_evaluated + 12.0 * full_moves;
  std::printf("  full test: boundary %.1f us per dispatch (%.1f%% of faces evaluated), >= %.1f GB/s = %.1f%% of "
              "%.0f GB/s\n",
              1e6 * kf.boundary_s / full_iterations, 100.0 * full_evaluated / (double(nf) * full_iterations),
              full_bytes / kf.boundary_s * 1e-9, 100.0 * full_bytes / kf.boundary_s * 1e-9 / peak_gbps, peak_gbps);
  return same ? 0 : 1;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gpu_kernel_bench: %s\n", e.what());
    return 1;
  }
}
