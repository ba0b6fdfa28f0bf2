// meshcvt tests: what makes the CPU engine fast must not change what it computes — the Lloyd steps
// after initialization (cluster_flood.cpp) and the margin accelerator of the boundary iteration
// (cluster_iterate.cpp).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "cluster_engine.h"
#include "boundary_rule.h"
#include "rule_budget.h"
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

TEST_CASE("Lloyd steps: assignments alone end in connected clusters, also when undone") {
  const Mesh meshes[] = {scanned_elephant(), test::combine(test::torus(48, 20), test::icosphere(3), 3),
                         test::grid(30, 20)};
  LloydCounts total;
  for (const Mesh& m : meshes) {
    Topology t = build_topology(m);
    for (Metric metric : {Metric::cvt, Metric::ccvt})
      for (uint32_t n : {7u + t.component_count, uint32_t(m.face_count() / 9)})
        for (uint32_t max_steps : {4u, 5u, 6u, 7u, 12u, 30u}) {
          CAPTURE(std::string(to_string(metric)));
          CAPTURE(n);
          CAPTURE(max_steps);
          ClusterOptions o = options_for(metric, n);
          ClusterProblem problem = make_cluster_problem(m, o);
          std::vector<uint32_t> labels = initial_clustering(problem, m, t, Init::hierarchical, n, 1);
          const double before = labeling_energy(problem, labels, n);
          WorkerPool pool(2);
          ClusterGraph graph, expected;
          LloydCounts counts;
          const uint32_t kept = lloyd_flood_steps(problem, t, pool, labels, max_steps, 0.0, &graph, &counts);
          CHECK(kept == counts.full + counts.assignment);
          CHECK(labeling_energy(problem, labels, n) <= before);
          ClusterValidity v = check_clusters(t, labels, n);
          CHECK(v.empty == 0);
          CHECK(v.split == 0);
          // the graph handed on is that of the final labels (after an undo: of the labels restored)
          build_cluster_graph(t, labels, n, expected);
          CHECK(graph.open == expected.open);
          REQUIRE(graph.count == expected.count);
          for (uint32_t c = 0; c < n; ++c)
            CHECK(std::equal(graph.neighbours.begin() + graph.offsets[c],
                             graph.neighbours.begin() + graph.offsets[c] + graph.count[c],
                             expected.neighbours.begin() + expected.offsets[c]));
          total.full += counts.full;
          total.assignment += counts.assignment;
          total.undone += counts.undone;
        }
  }
  // Both kinds of step ran, and some assignments alone were undone (a failed full step after
  // them, or max_steps reached in their midst): the cases above went through every path.
  CHECK(total.full > 0);
  CHECK(total.assignment > 0);
  CHECK(total.undone > 0);
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
namespace {
// The budget check below at one scale: the cluster edges' layout has size `size` (1 = the unit box
// of the normalized coordinates), the weights are scaled by `weight_scale`. Returns the edges
// checked, the moving ones among them and the tight ones (a budget below 1e-3 of the size).
struct BudgetCounts {
  uint64_t checked = 0, moving = 0, tight = 0;
};
BudgetCounts check_rule_budgets(double size, double weight_scale, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), weight(0.1, 1.0), scale(0.5, 0.999);
  auto offset = [&](const float base[3], double extent, float out[3]) {
    for (int k = 0; k < 3; ++k) out[k] = float(base[k] + size * extent * unit(rng));
  };
  BudgetCounts counts;
  for (int trial = 0; trial < 20000; ++trial) {
    const float origin[3] = {0, 0, 0};
    float xl[3], xr[3], gp[3], gq[3];
    offset(origin, 1.0, xl);
    offset(xl, 0.05, xr);
    offset(xl, 0.5, gp);
    offset(gp, trial % 2 ? 0.01 : 0.2, gq);  // half of them with nearly equal distances
    const float wl = float(weight_scale * weight(rng)), wr = float(weight_scale * weight(rng));
    auto decide = [&](const float p[3], const float q[3]) {
      return decide_cluster_edge(squared_distance(xl, p), squared_distance(xl, q), squared_distance(xr, p),
                                 squared_distance(xr, q), wl, wr);
    };
    const float d_lp = squared_distance(xl, gp), d_lq = squared_distance(xl, gq);
    const float d_rp = squared_distance(xr, gp), d_rq = squared_distance(xr, gq);
    const EdgeMove outcome = decide(gp, gq);
    for (bool left : {true, false}) {
      const bool moves = outcome == (left ? EdgeMove::left_to_q : EdgeMove::right_to_p);
      const double budget = moves ? move_budget(d_lp, d_lq, d_rp, d_rq, wl, wr, left)
                                  : stay_budget(d_lp, d_lq, d_rp, d_rq, wl, wr, left);
      if (!(budget > 0)) continue;
      ++counts.checked;
      counts.moving += moves;
      counts.tight += budget < 1e-3 * size;
      for (int k = 0; k < 8; ++k) {
        // Each generator displaced by less than the budget (at most the layout's size: a budget
        // far too large must still be caught).
        float np[3], nq[3];
        offset(gp, 1.0, np);
        offset(gq, 1.0, nq);
        for (auto [g, n] : {std::pair<const float*, float*>{gp, np}, {gq, nq}}) {
          double dir[3], len = 0;
          for (int c = 0; c < 3; ++c) dir[c] = double(n[c]) - g[c], len += dir[c] * dir[c];
          len = std::sqrt(len);
          const double step = std::min(budget, size) * scale(rng);
          for (int c = 0; c < 3; ++c) n[c] = float(g[c] + (len > 0 ? dir[c] / len * step : 0.0));
        }
        double moved_p = 0, moved_q = 0;
        for (int c = 0; c < 3; ++c) {
          moved_p += (double(np[c]) - gp[c]) * (double(np[c]) - gp[c]);
          moved_q += (double(nq[c]) - gq[c]) * (double(nq[c]) - gq[c]);
        }
        if (!(std::sqrt(std::max(moved_p, moved_q)) < budget)) continue;  // float rounding overshot
        const EdgeMove after = decide(np, nq);
        CAPTURE(size);
        CAPTURE(trial);
        CAPTURE(left);
        CHECK((after == (left ? EdgeMove::left_to_q : EdgeMove::right_to_p)) == moves);
      }
    }
  }
  return counts;
}
}  // namespace

TEST_CASE("rule budgets: generators moved by less than a face's budget leave its decision unchanged") {
  // stay_budget and move_budget (rule_budget.h) on random cluster edges placed near the rule's
  // thresholds: moving p's and q's generators by less than the budget (measured on the float
  // coordinates, as the engine measures it) must not change whether the face moves. The engine
  // re-tests a face only once that much movement has added up, so a budget too large would
  // change labels there (the accelerator-off comparison below rarely reaches such a case).
  const BudgetCounts unit_box = check_rule_budgets(1.0, 1.0, 11);
  CAPTURE(unit_box.checked);
  CAPTURE(unit_box.moving);
  CAPTURE(unit_box.tight);
  CHECK(unit_box.checked > 20000);  // most edges have a budget
  CHECK(unit_box.moving > 5000);    // both outcomes are covered
  CHECK(unit_box.tight > 1000);     // and many decisions close to their thresholds
  // Where squares and products straddle the rule's floor (kRuleFloor, 2^-100): distances near
  // 2^-45 (squares of nearby points' coordinates near 2^-100) and weights near 2^-5.
  const BudgetCounts at_floor = check_rule_budgets(0x1p-45, 0x1p-5, 12);
  CAPTURE(at_floor.checked);
  CAPTURE(at_floor.moving);
  MESSAGE("budgets at the floor: " << at_floor.checked << " checked, " << at_floor.moving << " moving");
  CHECK(at_floor.checked > 5000);
  CHECK(at_floor.moving > 1000);
}

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

// repair_connectivity's check with the last check kept (RepairCheck) walks only the clusters that
// the faces changed since can affect. A cluster can become enclosed without losing or gaining a
// face (its other neighbour gives way around it): that must be seen as by a check from scratch.
TEST_CASE("the repair check kept from the last call finds what a check from scratch finds") {
  Mesh m = test::grid(12, 12);
  Topology t = build_topology(m);
  ClusterOptions o = options_for(Metric::cvt, 3);
  ClusterProblem pr = make_cluster_problem(m, o);
  auto face = [](uint32_t i, uint32_t j, uint32_t k) { return 2 * (j * 12 + i) + k; };
  // A: the 2x2 cells at (5..6, 5..6); B: the rest of the left half; C: the rest of the right half.
  std::vector<uint32_t> labels(m.face_count());
  for (uint32_t j = 0; j < 12; ++j)
    for (uint32_t i = 0; i < 12; ++i)
      for (uint32_t k = 0; k < 2; ++k)
        labels[face(i, j, k)] = (i >= 5 && i <= 6 && j >= 5 && j <= 6) ? 0 : i < 6 ? 1 : 2;
  const std::vector<float> generators = generators_of(pr, compute_cluster_sums(pr, labels, 3));
  auto both = [&](const std::vector<uint32_t>& from, RepairCheck check) {
    std::vector<uint32_t> kept = from, scratch = from;
    RepairStats s1, s2;
    const bool a = repair_connectivity(pr, t, generators, kept, 3, s1, nullptr, &check);
    const bool b = repair_connectivity(pr, t, generators, scratch, 3, s2, nullptr);
    CHECK(a == b);
    CHECK(kept == scratch);
    CHECK(s1.dissolved_isolated == s2.dissolved_isolated);
    CHECK(s1.split_pieces == s2.split_pieces);
    return a;
  };
  RepairCheck check;
  std::vector<uint32_t> valid = labels;
  RepairStats stats;
  REQUIRE_FALSE(repair_connectivity(pr, t, generators, valid, 3, stats, nullptr, &check));
  REQUIRE(check.labels == labels);

  SUBCASE("a move that keeps every cluster valid") {
    std::vector<uint32_t> moved = labels;
    moved[face(6, 0, 1)] = 1;  // the face of C next to B in the bottom row: still three disks
    CHECK_FALSE(both(moved, check));
  }
  SUBCASE("A enclosed by B: C's faces around A's right side go to B, A's own faces do not change") {
    std::vector<uint32_t> moved = labels;
    for (uint32_t j = 4; j <= 7; ++j)
      for (uint32_t i = 5; i <= 7; ++i)
        for (uint32_t k = 0; k < 2; ++k)
          if (moved[face(i, j, k)] == 2) moved[face(i, j, k)] = 1;
    CHECK(both(moved, check));
    // The repair itself: A is dissolved into B, which encloses it; nothing else changes.
    std::vector<uint32_t> repaired = moved;
    RepairStats s;
    REQUIRE(repair_connectivity(pr, t, generators, repaired, 3, s, nullptr));
    CHECK(s.dissolved_isolated == 1);
    for (size_t f = 0; f < repaired.size(); ++f) CHECK(repaired[f] == (moved[f] == 0 ? 1u : moved[f]));
  }
  SUBCASE("C cut in two by a band of B") {
    std::vector<uint32_t> moved = labels;
    for (uint32_t i = 6; i < 12; ++i)
      for (uint32_t k = 0; k < 2; ++k) moved[face(i, 9, k)] = 1;
    CHECK(both(moved, check));
    // The repair itself: C keeps its larger piece (rows 0-8), the two rows above the band go to
    // B, the only cluster next to them.
    RepairStats s;
    REQUIRE(repair_connectivity(pr, t, generators, moved, 3, s, nullptr));
    CHECK(s.split_pieces == 1);
    for (uint32_t j = 0; j < 12; ++j)
      for (uint32_t i = 6; i < 12; ++i)
        for (uint32_t k = 0; k < 2; ++k) {
          CAPTURE(i);
          CAPTURE(j);
          const uint32_t expected = i == 6 && j >= 5 && j <= 6 ? 0u : j < 9 ? 2u : 1u;  // A, C, B
          CHECK(moved[face(i, j, k)] == expected);
        }
  }
}
