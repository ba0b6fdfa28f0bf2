// Tests of the GPU clustering engine (host/gpu_engine.cpp, shaders/cluster_*.comp): from the same
// initial clustering it must take exactly the CPU engine's decisions — same moves in every
// iteration, same energy history bit for bit, same labels face for face and same generators — on
// closed, open, multi-component, non-manifold and real scanned meshes, every metric, small to large
// cluster counts, both topology modes, with and without the accelerator; and the validation layer
// must stay silent (scripts/test.sh sets MESHCVT_VALIDATION=1).
//
// GPU tests need a Vulkan device (lavapipe from mesa-vulkan-drivers is enough); without one they
// fail with a message saying so, unless MESHCVT_SKIP_GPU_TESTS=1 skips them.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "cluster_engine.h"
#include "gpu_test_device.h"
#include "meshcvt/cluster.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/density.h"
#include "meshcvt/device.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "parallel.h"
#include "test_meshes.h"
#include "vk_context.h"

using namespace meshcvt;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Checks that two clusterings of cluster() are the same result: labels, generators, iteration
// counts, repair rounds and the energy history to the bit.
void check_same_clustering(const Clustering& a, const Clustering& b) {
  CHECK(a.labels == b.labels);
  CHECK(a.generators == b.generators);
  CHECK(a.iterations == b.iterations);
  CHECK(a.converged == b.converged);
  CHECK(a.repair.rounds == b.repair.rounds);
  REQUIRE(a.history.size() == b.history.size());
  for (size_t i = 0; i < a.history.size(); ++i) {
    CHECK(a.history[i].moves == b.history[i].moves);
    CHECK(same_bits(a.history[i].energy, b.history[i].energy));
  }
}

// A disc whose centre vertex has `spokes` faces around it, plus an outer ring of quads: vertex rings
// far beyond 64 faces, the disk filter's slow path on the CPU and the large member array on the GPU.
Mesh fan(uint32_t spokes) {
  Mesh m;
  const double pi = 3.14159265358979323846;
  uint32_t centre = test::add_vertex(m, 0, 0, 0.2);
  for (uint32_t ring = 1; ring <= 2; ++ring)
    for (uint32_t i = 0; i < spokes; ++i) {
      double a = 2 * pi * i / spokes + 0.3 * ring;
      test::add_vertex(m, ring * std::cos(a), ring * std::sin(a), 0.05 * std::sin(5 * a) * ring);
    }
  for (uint32_t i = 0; i < spokes; ++i) {
    uint32_t a = 1 + i, b = 1 + (i + 1) % spokes, c = 1 + spokes + i, d = 1 + spokes + (i + 1) % spokes;
    test::add_triangle(m, centre, a, b);
    test::add_triangle(m, a, c, d);
    test::add_triangle(m, a, d, b);
  }
  return m;
}

struct NamedMesh {
  const char* name;
  Mesh mesh;
};

// Runs the CPU and the GPU engine side by side from the same initial clustering and compares every
// iteration; with `reset_again`, resets both to a perturbed state and compares again (as after the
// driver's repair). Returns the number of faces moved in all (so callers can check moves happened).
uint64_t compare_engines(const Mesh& mesh, const Topology& topology, Metric metric, uint32_t clusters,
                         TopologyMode mode, bool accelerate, int device, bool reset_again = true) {
  ClusterOptions options;
  options.clusters = clusters;
  options.metric = metric;
  ClusterProblem problem = make_cluster_problem(mesh, options);
  std::vector<uint32_t> initial = initial_clustering(problem, mesh, topology, Init::hierarchical, clusters, 1);

  WorkerPool pool(2);
  BoundaryIteration cpu(problem, mesh, topology, mode, accelerate, pool);
  std::unique_ptr<IterationEngine> gpu = make_gpu_iteration(problem, mesh, topology, mode, accelerate, device);
  cpu.reset(initial);
  gpu->reset(initial);
  REQUIRE(same_bits(cpu.energy(), gpu->energy()));
  REQUIRE(cpu.generators() == gpu->generators());

  uint64_t moves = 0;
  for (uint32_t iterations = 0; iterations < 300; ++iterations) {
    IterationRecord c = cpu.step();
    IterationRecord g = gpu->step();
    moves += c.moves;
    INFO("iteration " << iterations);
    REQUIRE(c.moves == g.moves);
    REQUIRE(same_bits(c.energy, g.energy));
    // The GPU tests a superset of the CPU's active set (exact either way).
    CHECK(g.evaluated_faces >= c.evaluated_faces);
    if (iterations % 7 == 3) REQUIRE(cpu.labels() == gpu->labels());  // labels come down mid-run too
    if (c.moves == 0) break;
  }
  REQUIRE(cpu.labels() == gpu->labels());
  REQUIRE(cpu.generators() == gpu->generators());
  REQUIRE(same_bits(cpu.energy(), gpu->energy()));
  if (!reset_again) return moves;

  // A second reset (as after the driver's repair) from a state both engines reach differently: the
  // converged labels with a few faces relabeled to a neighbour's cluster.
  std::vector<uint32_t> perturbed = cpu.labels();
  for (uint32_t f = 0; f < problem.face_count; f += 37) {
    uint32_t o = topology.face_adjacent[3 * size_t(f)];
    if (o != kNone) perturbed[f] = perturbed[o];
  }
  cpu.reset(perturbed);
  gpu->reset(perturbed);
  for (uint32_t i = 0; i < 300; ++i) {
    IterationRecord c = cpu.step();
    IterationRecord g = gpu->step();
    INFO("after reset, iteration " << i);
    REQUIRE(c.moves == g.moves);
    REQUIRE(same_bits(c.energy, g.energy));
    moves += c.moves;
    if (c.moves == 0) break;
  }
  REQUIRE(cpu.labels() == gpu->labels());
  REQUIRE(cpu.generators() == gpu->generators());
  return moves;
}

// Every metric x cluster counts {2, 17, 200, F/4} (those the mesh can take) in preserving mode; the
// paper's mode for 17 and F/4 (keeps the suite fast on lavapipe).
void compare_on_mesh(const NamedMesh& m) {
  if (test::skip_gpu_tests()) return;
  const int device = int(test::gpu_test_device());
  const uint64_t messages_before = vk::validation_message_count();
  Topology topology = build_topology(m.mesh);
  uint32_t components = 0;
  for (uint32_t c : topology.face_component) components = std::max(components, c + 1);
  const uint32_t nf = uint32_t(m.mesh.face_count());
  uint64_t moves = 0;
  for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21})
    for (uint32_t clusters : {2u, 17u, 200u, nf / 4}) {
      if (clusters < components || clusters > nf) continue;
      for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper}) {
        if (mode == TopologyMode::paper && clusters != 17 && clusters != nf / 4) continue;
        CAPTURE(std::string(m.name));
        CAPTURE(std::string(to_string(metric)));
        CAPTURE(clusters);
        CAPTURE(std::string(to_string(mode)));
        moves += compare_engines(m.mesh, topology, metric, clusters, mode, true, device, clusters == 17);
      }
    }
  CHECK(moves > 0);  // the engines had decisions to agree on
  CHECK(vk::validation_message_count() == messages_before);
}

}  // namespace

TEST_CASE("gpu engine equals the CPU engine: sphere") { compare_on_mesh({"sphere", test::icosphere(3)}); }
TEST_CASE("gpu engine equals the CPU engine: torus") { compare_on_mesh({"torus", test::torus(36, 18)}); }
TEST_CASE("gpu engine equals the CPU engine: open grid") {
  compare_on_mesh({"open grid", test::grid(28, 24, 1.3, 1, 0.08)});
}
TEST_CASE("gpu engine equals the CPU engine: two components") {
  compare_on_mesh({"two components", test::combine(test::icosphere(2), test::torus(24, 12), 3)});
}
TEST_CASE("gpu engine equals the CPU engine: non-manifold edges") {
  compare_on_mesh({"non-manifold wall", test::grid_with_wall(24)});
}
TEST_CASE("gpu engine equals the CPU engine: scanned elephant") {
  compare_on_mesh({"elephant", read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off")});
}

TEST_CASE("gpu engine: without the accelerator, and on vertex rings beyond 64 faces") {
  if (test::skip_gpu_tests()) return;
  const int device = int(test::gpu_test_device());
  const uint64_t messages_before = vk::validation_message_count();
  {
    Mesh m = test::torus(30, 14);
    Topology t = build_topology(m);
    for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper}) {
      CAPTURE(std::string(to_string(mode)));
      CHECK(compare_engines(m, t, Metric::cvt, 23, mode, false, device) > 0);
    }
  }
  Mesh m = fan(150);  // the centre vertex has 150 faces
  Topology t = build_topology(m);
  for (Metric metric : {Metric::cvt, Metric::l21})
    for (uint32_t clusters : {2u, 9u, 40u}) {
      CAPTURE(std::string(to_string(metric)));
      CAPTURE(clusters);
      CHECK(compare_engines(m, t, metric, clusters, TopologyMode::preserving, true, device) > 0);
    }
  CHECK(vk::validation_message_count() == messages_before);
}

TEST_CASE("gpu engine: cluster() with device \"gpu\" equals device \"cpu\" end to end") {
  if (test::skip_gpu_tests()) return;
  int(test::gpu_test_device());
  const uint64_t messages_before = vk::validation_message_count();
  Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  // --gradation's density: face weights of 1 to 256 (and the initialization weighs its merges by it).
  const std::vector<float> graded = curvature_density(elephant, build_topology(elephant), 1.0);
  struct Case {
    const Mesh* mesh;
    Metric metric;
    uint32_t clusters;
    TopologyMode mode;
    const std::vector<float>* density = nullptr;
  };
  Mesh walls = test::grid_with_wall(20);
  for (const Case& k : {Case{&elephant, Metric::cvt, 300, TopologyMode::preserving},
                        Case{&elephant, Metric::l21, 40, TopologyMode::paper},  // repair rounds run
                        Case{&walls, Metric::ccvt, 30, TopologyMode::paper},
                        Case{&elephant, Metric::cvt, 250, TopologyMode::preserving, &graded},
                        Case{&elephant, Metric::ccvt, 120, TopologyMode::preserving, &graded}}) {
    ClusterOptions o;
    o.clusters = k.clusters;
    o.metric = k.metric;
    o.topology = k.mode;
    if (k.density) o.density = *k.density;
    o.device = "cpu";
    Clustering cpu = cluster(*k.mesh, o);
    o.device = "gpu";
    Clustering gpu = cluster(*k.mesh, o);
    CAPTURE(std::string(to_string(k.metric)));
    CAPTURE(k.clusters);
    CAPTURE(k.density != nullptr);
    CHECK(gpu.device != cpu.device);
    check_same_clustering(gpu, cpu);
    ClusterValidity v = check_clusters(build_topology(*k.mesh), gpu.labels, k.clusters);
    CHECK(v.ok());
  }
  CHECK(vk::validation_message_count() == messages_before);
}

TEST_CASE("gpu engine: kernel timing counts every boundary dispatch" * doctest::skip(test::skip_gpu_tests())) {
  const int device = int(test::gpu_test_device());
  Mesh mesh = test::icosphere(3);
  Topology topology = build_topology(mesh);
  ClusterOptions options;
  options.clusters = 17;
  ClusterProblem problem = make_cluster_problem(mesh, options);
  std::vector<uint32_t> initial = initial_clustering(problem, mesh, topology, Init::hierarchical, 17, 1);
  WorkerPool pool(1);
  BoundaryIteration cpu(problem, mesh, topology, TopologyMode::preserving, true, pool);
  CHECK_FALSE(cpu.start_kernel_timing());
  CHECK(cpu.kernel_times().boundary_dispatches == 0);

  std::unique_ptr<IterationEngine> gpu =
      make_gpu_iteration(problem, mesh, topology, TopologyMode::preserving, true, device);
  gpu->reset(initial);
  gpu->step();  // not timed
  CHECK(gpu->kernel_times().boundary_dispatches == 0);
  REQUIRE(gpu->start_kernel_timing());
  uint64_t steps = 0, moves = 0;
  for (; steps < 100; ) {
    IterationRecord r = gpu->step();
    ++steps;
    moves += r.moves;
    if (r.moves == 0) break;
  }
  REQUIRE(moves > 0);  // the update kernels ran too
  const KernelTimes k = gpu->kernel_times();
  CHECK(k.boundary_dispatches == steps);
  CHECK(k.boundary_s > 0.0);
  CHECK(k.update_s > 0.0);
}

TEST_CASE("gpu engine: a bad device index is a DeviceError") {
  if (test::skip_gpu_tests()) return;
  Mesh m = test::icosphere(1);
  Topology t = build_topology(m);
  ClusterOptions o;
  o.clusters = 4;
  ClusterProblem p = make_cluster_problem(m, o);
  CHECK_THROWS_AS(make_gpu_iteration(p, m, t, TopologyMode::preserving, true, 999), DeviceError);
  CHECK_THROWS_AS(make_gpu_iteration(p, m, t, TopologyMode::preserving, true, -1), DeviceError);
}

// $MESHCVT_GPU_FAULT makes a healthy device fail on demand (vk::arm_faults_from_environment): a
// lost device at the first wait or in the middle of the iterations, device memory exhausted at the
// first or a later buffer. cluster() must then throw a DeviceError that says what happened (not
// crash, hang or return half-made labels); with cpu_fallback it must instead give the CPU engine's
// result, saying why; and the next clustering in the process must run on the GPU again (a lost
// device's kit is dropped, not handed out again).
TEST_CASE("gpu engine: a lost device or exhausted memory is a DeviceError, or with cpu_fallback the CPU's result") {
  if (test::skip_gpu_tests()) return;
  int(test::gpu_test_device());
  const uint64_t messages_before = vk::validation_message_count();
  Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  ClusterOptions o;
  o.clusters = 300;
  o.device = "cpu";
  const Clustering cpu = cluster(elephant, o);
  o.device = "gpu";
  std::string gpu_name;
  {
    test::ScopedEnv none("MESHCVT_GPU_FAULT", nullptr);
    o.cpu_fallback = true;  // no failure: stays on the GPU, says nothing
    const Clustering gpu = cluster(elephant, o);
    gpu_name = gpu.device;
    CHECK(gpu.device != cpu.device);
    CHECK(gpu.device_notice.empty());
    CHECK(gpu.labels == cpu.labels);
  }
  struct Fault {
    const char* setting;
    const char* result;  // the VkResult the message must name
  };
  for (const Fault& fault : {Fault{"lost:1", "VK_ERROR_DEVICE_LOST"}, Fault{"lost:6", "VK_ERROR_DEVICE_LOST"},
                             Fault{"memory:1", "VK_ERROR_OUT_OF_DEVICE_MEMORY"},
                             Fault{"memory:12", "VK_ERROR_OUT_OF_DEVICE_MEMORY"}}) {
    CAPTURE(fault.setting);
    {
      test::ScopedEnv armed("MESHCVT_GPU_FAULT", fault.setting);
      o.cpu_fallback = false;
      std::string message;
      try {
        cluster(elephant, o);
      } catch (const DeviceError& e) {
        message = e.what();
      }
      CHECK(message.find(fault.result) != std::string::npos);
      CHECK(message.find("--device cpu") != std::string::npos);

      o.cpu_fallback = true;
      const Clustering fell_back = cluster(elephant, o);
      CHECK(fell_back.device == cpu.device);
      CHECK(fell_back.device_notice.find("using the CPU engine") == 0);
      CHECK(fell_back.device_notice.find(fault.result) != std::string::npos);
      CHECK(fell_back.fell_back);
      // It ran on the CPU: the error's advice to do so is left out.
      CHECK(fell_back.device_notice.find("--device cpu") == std::string::npos);
      check_same_clustering(fell_back, cpu);
    }
    test::ScopedEnv disarmed("MESHCVT_GPU_FAULT", nullptr);
    o.cpu_fallback = false;
    const Clustering again = cluster(elephant, o);
    CHECK(again.device == gpu_name);
    CHECK(again.labels == cpu.labels);
  }
  {
    test::ScopedEnv bad("MESHCVT_GPU_FAULT", "lost");
    CHECK_THROWS_AS(cluster(elephant, o), OptionError);  // a typo is not a device failure
  }
  CHECK(vk::validation_message_count() == messages_before);
}

// coarsen_mesh clusters again in its fix rounds: after the GPU failed over once, those go to the CPU
// engine directly (one GPU set-up in all, not one per round), and the result, notice included, is
// the one a job that stayed on the CPU gives.
TEST_CASE("gpu engine: coarsen_mesh sets a GPU that failed over up once, not once per fix round") {
  if (test::skip_gpu_tests()) return;
  int(test::gpu_test_device());
  Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  const Topology topology = build_topology(elephant);
  CoarsenMeshOptions o;
  o.cluster.clusters = 300;
  o.cluster.device = "cpu";
  const CoarsenMeshResult cpu = coarsen_mesh(elephant, topology, o);
  REQUIRE(cpu.fix_rounds > 1);  // clusterings after the first, which the fallback must not retry
  o.cluster.device = "gpu";
  o.cluster.cpu_fallback = true;
  test::ScopedEnv armed("MESHCVT_GPU_FAULT", "memory:1");
  const uint64_t setups_before = gpu_engine_setups();
  const CoarsenMeshResult fell_back = coarsen_mesh(elephant, topology, o);
  CHECK(gpu_engine_setups() - setups_before == 1);
  CHECK(fell_back.clustering.fell_back);
  CHECK(!cpu.clustering.fell_back);
  CHECK(fell_back.clustering.device_notice.find("VK_ERROR_OUT_OF_DEVICE_MEMORY") != std::string::npos);
  CHECK(fell_back.fix_rounds == cpu.fix_rounds);
  CHECK(fell_back.clustering.labels == cpu.clustering.labels);
  CHECK(fell_back.coarse.mesh.positions == cpu.coarse.mesh.positions);
  CHECK(fell_back.coarse.mesh.indices == cpu.coarse.mesh.indices);
}

// cpu_fallback also covers a GPU that cannot be had at all (no loader, no device, no such index):
// "gpu:99" runs on the CPU engine with a notice naming it, instead of throwing. No device needed.
TEST_CASE("cluster(): cpu_fallback runs on the CPU when the GPU asked for does not exist") {
  Mesh sphere = test::icosphere(3);
  ClusterOptions o;
  o.clusters = 40;
  o.device = "gpu:99";
  CHECK_THROWS_AS(cluster(sphere, o), DeviceError);
  o.cpu_fallback = true;
  const Clustering fell_back = cluster(sphere, o);
  o.device = "cpu";
  o.cpu_fallback = false;
  const Clustering cpu = cluster(sphere, o);
  CHECK(fell_back.device == cpu.device);
  CHECK(fell_back.device_notice.find("using the CPU engine") == 0);
  CHECK(fell_back.device_notice.find("gpu:99") != std::string::npos);
  CHECK(fell_back.fell_back);
  CHECK(cpu.device_notice.empty());
  CHECK(!cpu.fell_back);
  check_same_clustering(fell_back, cpu);
  o.device = "bogus";  // a misspelt request is the caller's mistake, not a missing GPU
  o.cpu_fallback = true;
  CHECK_THROWS_AS(cluster(sphere, o), OptionError);
}
