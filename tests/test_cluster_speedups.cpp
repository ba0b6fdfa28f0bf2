// meshcvt tests: what makes the CPU engine fast must not change what it computes — the Lloyd steps
// after initialization (cluster_flood.cpp) and the margin accelerator of the boundary iteration
// (cluster_iterate.cpp).
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "cluster_engine.h"
#include "meshcvt/cluster.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "parallel.h"
#include "test_meshes.h"

using namespace meshcvt;

namespace {

Mesh scanned_elephant() { return read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off"); }

ClusterOptions options_for(Metric metric, uint32_t n) {
  ClusterOptions o;
  o.clusters = n;
  o.metric = metric;
  o.device = "cpu";
  return o;
}

}  // namespace

TEST_CASE("Lloyd steps lower the energy and keep exactly n connected clusters, each in one component") {
  const Mesh meshes[] = {scanned_elephant(), test::combine(test::torus(48, 20), test::icosphere(3), 3),
                         test::grid(30, 20)};
  for (const Mesh& m : meshes) {
    Topology t = build_topology(m);
    for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21})
      for (uint32_t n : {uint32_t(t.component_count), 7u + t.component_count, uint32_t(m.face_count() / 9)}) {
        CAPTURE(std::string(to_string(metric)));
        CAPTURE(n);
        ClusterOptions o = options_for(metric, n);
        ClusterProblem problem = make_cluster_problem(m, o);
        std::vector<uint32_t> labels = initial_clustering(problem, m, t, Init::hierarchical, n, 1);
        const double before = labeling_energy(problem, labels, n);
        std::vector<uint32_t> component_of(n, kNone);
        for (uint32_t f = 0; f < labels.size(); ++f) component_of[labels[f]] = t.face_component[f];
        WorkerPool pool(2);
        uint32_t kept = lloyd_flood_steps(problem, t, pool, labels, 8, 0.0);
        const double after = labeling_energy(problem, labels, n);
        if (kept > 0) CHECK(after < before);
        else CHECK(after == before);
        ClusterValidity v = check_clusters(t, labels, n);
        CHECK(v.empty == 0);
        CHECK(v.split == 0);
        for (uint32_t f = 0; f < labels.size(); ++f) REQUIRE(component_of[labels[f]] == t.face_component[f]);
      }
  }
}

TEST_CASE("Lloyd steps: same result on any thread count; cluster() starts lower with them") {
  Mesh m = scanned_elephant();
  Topology t = build_topology(m);
  ClusterOptions o = options_for(Metric::cvt, 300);
  ClusterProblem problem = make_cluster_problem(m, o);
  std::vector<uint32_t> init = initial_clustering(problem, m, t, Init::hierarchical, 300, 1);
  std::vector<uint32_t> one = init, two = init;
  WorkerPool pool1(1), pool3(3);
  uint32_t k1 = lloyd_flood_steps(problem, t, pool1, one, 6, 0.0);
  uint32_t k3 = lloyd_flood_steps(problem, t, pool3, two, 6, 0.0);
  CHECK(k1 == k3);
  CHECK(k1 > 0);  // the hierarchical clustering of a scan is far from a CVT: a step helps
  CHECK(one == two);

  o.lloyd_steps = 0;
  Clustering plain = cluster(m, t, o);
  o.lloyd_steps = 16;
  Clustering lloyd = cluster(m, t, o);
  CHECK(lloyd.history.front().energy < plain.history.front().energy);
  CHECK(lloyd.converged);
  CHECK(check_clusters(t, lloyd.labels, 300).ok());
}

// The margin accelerator skips a face only when no generator it reads can have moved far enough to
// change its decision; if that bound were wrong anywhere, labels would differ from testing every
// border face every iteration. Random initialization and the paper's mode make many moves and many
// near-ties, the cases most likely to expose a bound that is too loose.
TEST_CASE("margin accelerator: identical labels, moves and energies to testing every border face") {
  Mesh m = scanned_elephant();
  Topology t = build_topology(m);
  for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21})
    for (Init init : {Init::hierarchical, Init::random})
      for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper})
        for (uint32_t n : {9u, 120u, 900u}) {
          CAPTURE(std::string(to_string(metric)));
          CAPTURE(std::string(to_string(init)));
          CAPTURE(std::string(to_string(mode)));
          CAPTURE(n);
          ClusterOptions o = options_for(metric, n);
          o.init = init;
          o.topology = mode;
          o.seed = n;
          o.accelerate = false;
          Clustering plain = cluster(m, t, o);
          o.accelerate = true;
          Clustering fast = cluster(m, t, o);
          CHECK(fast.labels == plain.labels);
          REQUIRE(fast.history.size() == plain.history.size());
          uint64_t evaluated_fast = 0, evaluated_plain = 0;
          for (size_t i = 0; i < fast.history.size(); ++i) {
            CHECK(fast.history[i].moves == plain.history[i].moves);
            CHECK(fast.history[i].energy == plain.history[i].energy);
            evaluated_fast += fast.history[i].evaluated_faces;
            evaluated_plain += plain.history[i].evaluated_faces;
          }
          CHECK(evaluated_fast <= evaluated_plain);
        }
}

// Going on from a converged engine with other labels (teleports) must take the decisions a reset
// to those labels takes: the faces that differ are handled as the last iteration's moves, and only
// what they can affect is tested next.
TEST_CASE("relabel: the same iterations as a reset to the new labels, fewer faces tested") {
  Mesh m = scanned_elephant();
  Topology t = build_topology(m);
  for (Metric metric : {Metric::cvt, Metric::l21})
    for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper}) {
      CAPTURE(std::string(to_string(metric)));
      CAPTURE(std::string(to_string(mode)));
      const uint32_t n = 60;
      ClusterOptions o = options_for(metric, n);
      ClusterProblem problem = make_cluster_problem(m, o);
      WorkerPool pool(2);
      BoundaryIteration converged(problem, m, t, mode, true, pool);
      converged.reset(initial_clustering(problem, m, t, Init::hierarchical, n, 1));
      for (int i = 0; i < 1000 && converged.step().moves > 0; ++i) {
      }
      // A teleport-like change: cluster 1 merged into its neighbour, cluster 1 re-seeded as the
      // faces of cluster 2 nearest its first face (breadth-first, a third of them).
      std::vector<uint32_t> changed = converged.labels();
      uint32_t other = kNone;
      for (uint32_t f = 0; f < changed.size() && other == kNone; ++f)
        if (changed[f] == 1)
          for (int e = 0; e < 3; ++e) {
            uint32_t g = t.face_adjacent[3 * size_t(f) + e];
            if (g != kNone && changed[g] != 1) other = changed[g];
          }
      REQUIRE(other != kNone);
      uint32_t donor = other == 2 ? 3 : 2;
      for (uint32_t& l : changed)
        if (l == 1) l = other;
      std::vector<uint32_t> queue;
      uint32_t size = 0;
      for (uint32_t l : changed) size += l == donor;
      for (uint32_t f = 0; f < changed.size() && queue.empty(); ++f)
        if (changed[f] == donor) queue.push_back(f), changed[f] = 1;
      for (size_t head = 0; head < queue.size() && queue.size() < size / 3; ++head)
        for (int e = 0; e < 3; ++e) {
          uint32_t g = t.face_adjacent[3 * size_t(queue[head]) + e];
          if (g != kNone && changed[g] == donor && queue.size() < size / 3) changed[g] = 1, queue.push_back(g);
        }

      BoundaryIteration fresh(problem, m, t, mode, true, pool);
      fresh.reset(changed);
      converged.relabel(changed);
      CHECK(converged.sums() == fresh.sums());
      CHECK(converged.energy() == fresh.energy());
      uint64_t tested_fresh = 0, tested_relabeled = 0;
      for (int i = 0; i < 1000; ++i) {
        IterationRecord a = fresh.step(), b = converged.step();
        REQUIRE(a.moves == b.moves);
        CHECK(a.energy == b.energy);
        tested_fresh += a.evaluated_faces;
        tested_relabeled += b.evaluated_faces;
        if (a.moves == 0) break;
      }
      CHECK(converged.labels() == fresh.labels());
      CHECK(tested_relabeled < tested_fresh);
    }
}

// Restoring n after repair splits a cluster in two. On a protrusion (the elephant's tusks and
// trunk) the cluster to split can be a cap with a band around it; halves grown from its tip and
// its far rim gave back a cap enclosed by a band, dissolved again by the next repair, until the
// round limit (not converged). Halves grown from two faces of its border cannot enclose each other.
// Here the enclosed clusters are the initialization's: dissolved before the first iteration.
TEST_CASE("restoring n after dissolving an enclosed cluster does not enclose it again") {
  Mesh m = scanned_elephant();
  Topology t = build_topology(m);
  for (uint32_t n : {40u, 60u}) {
    CAPTURE(n);
    for (uint32_t lloyd : {0u, 16u}) {
      ClusterOptions o = options_for(Metric::cvt, n);
      o.lloyd_steps = lloyd;
      Clustering c = cluster(m, t, o);
      CHECK(c.repair.dissolved_isolated > 0);  // the case this test is about does occur
      CHECK(c.converged);
      // The enclosed clusters come from the initialization: they are dissolved (and n restored)
      // before the iteration, so it converges once and the final repair finds nothing.
      CHECK(c.repair.rounds == 0);
      CHECK(check_clusters(t, c.labels, n).ok());
    }
  }
}
