// meshcvt tests: the CPU clustering engine (Fan et al. Sections 3-5) — the four cases, energy
// descent, the disk filter, initialization, the final guarantees and determinism.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <memory>
#include <set>
#include <string>

#include "boundary_rule.h"
#include "cluster_engine.h"
#include "meshcvt/cluster.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "parallel.h"
#include "test_meshes.h"
#include "triangle_bvh.h"

using namespace meshcvt;

namespace {

// Energy of a labeling computed from scratch in double, with the exact optimal generator of every
// cluster (mass centroid; closest mesh point to it for ccvt; normalized mean normal for l21).
// Independent of the engine's float generators and fixed-point sums.
double exact_energy(const Mesh& m, Metric metric, const std::vector<uint32_t>& labels, uint32_t n,
                    const TriangleBvh* bvh = nullptr) {
  size_t nf = m.face_count();
  std::vector<double> w(nf), p(3 * nf);
  for (size_t f = 0; f < nf; ++f) {
    double v[3][3];
    for (int j = 0; j < 3; ++j)
      for (int c = 0; c < 3; ++c) v[j][c] = m.positions[3 * m.indices[3 * f + j] + c];
    double e1[3], e2[3];
    for (int c = 0; c < 3; ++c) e1[c] = v[1][c] - v[0][c], e2[c] = v[2][c] - v[0][c];
    double cr[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    double len = std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
    w[f] = 0.5 * len;
    for (int c = 0; c < 3; ++c)
      p[3 * f + c] = metric == Metric::l21 ? (len > 0 ? cr[c] / len : 0) : (v[0][c] + v[1][c] + v[2][c]) / 3;
  }
  std::vector<double> W(n, 0), S(3 * n, 0), z(3 * n, 0);
  std::unique_ptr<TriangleBvh> own_bvh;
  if (metric == Metric::ccvt && !bvh) bvh = (own_bvh = std::make_unique<TriangleBvh>(m)).get();
  for (size_t f = 0; f < nf; ++f) {
    W[labels[f]] += w[f];
    for (int c = 0; c < 3; ++c) S[3 * labels[f] + c] += w[f] * p[3 * f + c];
  }
  for (uint32_t i = 0; i < n; ++i) {
    if (W[i] <= 0) continue;
    if (metric == Metric::l21) {
      double l = std::sqrt(S[3 * i] * S[3 * i] + S[3 * i + 1] * S[3 * i + 1] + S[3 * i + 2] * S[3 * i + 2]);
      for (int c = 0; c < 3; ++c) z[3 * i + c] = l > 0 ? S[3 * i + c] / l : 0;
    } else {
      double g[3] = {S[3 * i] / W[i], S[3 * i + 1] / W[i], S[3 * i + 2] / W[i]};
      for (int c = 0; c < 3; ++c) z[3 * i + c] = g[c];
      if (metric == Metric::ccvt) {  // exact closest point of the mesh, in double
        TriangleBvh::Hit hit = bvh->closest_point(g);
        for (int c = 0; c < 3; ++c) z[3 * i + c] = hit.point_exact[c];
      }
    }
  }
  double e = 0;
  for (size_t f = 0; f < nf; ++f) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c) {
      double d = p[3 * f + c] - z[3 * labels[f] + c];
      d2 += d * d;
    }
    e += w[f] * d2;
  }
  return e;
}

// Connected pieces of every cluster (independent BFS over manifold edges) and non-empty clusters.
struct Pieces {
  uint32_t nonempty = 0, pieces = 0;
};
Pieces count_pieces(const Topology& t, const std::vector<uint32_t>& labels, uint32_t n) {
  std::vector<uint8_t> seen(labels.size(), 0), used(n, 0);
  Pieces r;
  std::vector<uint32_t> stack;
  for (uint32_t f = 0; f < labels.size(); ++f) {
    if (seen[f]) continue;
    ++r.pieces;
    if (!used[labels[f]]) used[labels[f]] = 1, ++r.nonempty;
    seen[f] = 1;
    stack.assign(1, f);
    while (!stack.empty()) {
      uint32_t g = stack.back();
      stack.pop_back();
      for (int e = 0; e < 3; ++e) {
        uint32_t o = t.face_adjacent[3 * g + e];
        if (o != kNone && !seen[o] && labels[o] == labels[g]) seen[o] = 1, stack.push_back(o);
      }
    }
  }
  return r;
}

struct Case {
  const char* name;
  Mesh mesh;
};

std::vector<Case> descent_meshes() {
  std::vector<Case> v;
  v.push_back({"icosphere", test::icosphere(3)});
  v.push_back({"torus", test::torus(40, 16)});
  v.push_back({"bumpy open grid", test::grid(24, 24, 1, 1, 0.08)});
  v.push_back({"two components", test::combine(test::icosphere(2), test::torus(24, 10), 3)});
  v.push_back({"grid with non-manifold wall", test::grid_with_wall(16)});
  v.push_back({"slivers", test::grid(60, 6, 20, 0.3, 0.2)});
  return v;
}

ClusterOptions options_for(Metric metric, uint32_t n) {
  ClusterOptions o;
  o.clusters = n;
  o.metric = metric;
  return o;
}

}  // namespace

TEST_CASE("four cases of the boundary test (Section 3.1)") {
  // case 1: both faces closer to their own cluster
  CHECK(decide_cluster_edge(1, 2, 3, 1, 1, 1) == EdgeMove::none);
  // equality keeps a face where it is (d_lp <= d_lq, d_rp >= d_rq)
  CHECK(decide_cluster_edge(2, 2, 2, 2, 1, 1) == EdgeMove::none);
  // case 2: T_r closer to V_p
  CHECK(decide_cluster_edge(1, 2, 1, 3, 1, 1) == EdgeMove::right_to_p);
  // case 3: T_l closer to V_q
  CHECK(decide_cluster_edge(3, 1, 3, 1, 1, 1) == EdgeMove::left_to_q);
  // case 4: both want to swap; the weighted comparison decides
  CHECK(decide_cluster_edge(2, 1, 1, 3, 1, 1) == EdgeMove::right_to_p);   // both in p: 3 < both in q: 4
  CHECK(decide_cluster_edge(3, 1, 2, 2.5f, 1, 1) == EdgeMove::left_to_q); // both in p: 5 > both in q: 3.5
  CHECK(decide_cluster_edge(2, 1, 1, 3, 10, 1) == EdgeMove::left_to_q);   // weights flip it: 21 > 13
  // case 4 tie: equal sums move T_l (the lower face id, by the caller's orientation)
  CHECK(decide_cluster_edge(2, 1, 1, 2, 1, 1) == EdgeMove::left_to_q);
  // several destinations for one face: closest wins, ties to the lower cluster id
  CHECK(better_destination(1.0f, 7, 2.0f, 3));
  CHECK_FALSE(better_destination(2.0f, 7, 2.0f, 3));
  CHECK(better_destination(2.0f, 2, 2.0f, 3));
}

TEST_CASE("a single move chosen by the rule lowers the energy (properties 3.1, 3.2, 4.1, 4.2)") {
  for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21}) {
    CAPTURE(std::string(to_string(metric)));
    Mesh m = test::grid(10, 10, 1, 1, 0.15);
    Topology t = build_topology(m);
    ClusterOptions o = options_for(metric, 5);
    ClusterProblem pr = make_cluster_problem(m, o);
    uint32_t case4 = 0, single = 0;
    for (uint64_t seed = 1; seed <= 6; ++seed) {
      std::vector<uint32_t> labels = initial_clustering(pr, m, t, Init::random, 5, seed);
      std::vector<int64_t> sums = compute_cluster_sums(pr, labels, 5);
      std::vector<float> g(15, 0.0f);
      for (uint32_t c = 0; c < 5; ++c) compute_generator(pr, &sums[c * kSumComponents], &g[3 * c]);
      double e0 = exact_energy(m, metric, labels, 5);
      for (uint32_t l = 0; l < pr.face_count; ++l)
        for (int e = 0; e < 3; ++e) {
          uint32_t r = t.face_adjacent[3 * l + e];
          if (r == kNone || r < l || labels[r] == labels[l]) continue;
          uint32_t p = labels[l], q = labels[r];
          const float* xl = &pr.point[3 * l];
          const float* xr = &pr.point[3 * r];
          float dlp = squared_distance(xl, &g[3 * p]), dlq = squared_distance(xl, &g[3 * q]);
          float drp = squared_distance(xr, &g[3 * p]), drq = squared_distance(xr, &g[3 * q]);
          EdgeMove mv = decide_cluster_edge(dlp, dlq, drp, drq, pr.weight[l], pr.weight[r]);
          if (mv == EdgeMove::none) continue;
          if (dlp > dlq && drp < drq) ++case4;
          else ++single;
          std::vector<uint32_t> moved = labels;
          if (mv == EdgeMove::right_to_p) moved[r] = p;
          else moved[l] = q;
          CHECK(exact_energy(m, metric, moved, 5) < e0 * (1 + 1e-12));
        }
    }
    CHECK(single > 0);  // the configurations did exercise the rule
    if (metric != Metric::l21) CHECK(case4 + single > 0);
  }
}

TEST_CASE("energy never increases across iterations, every metric, several meshes and seeds") {
  for (const Case& cs : descent_meshes()) {
    Topology t = build_topology(cs.mesh);
    TriangleBvh bvh(cs.mesh);
    for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21})
      for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper}) {
        ClusterProblem pr = make_cluster_problem(cs.mesh, options_for(metric, 16));
        WorkerPool pool(2);
        uint32_t total_moves = 0;
        for (uint64_t seed = 1; seed <= 20; ++seed) {
          CAPTURE(std::string(cs.name));
          CAPTURE(std::string(to_string(metric)));
          CAPTURE(std::string(to_string(mode)));
          CAPTURE(seed);
          BoundaryIteration it(pr, cs.mesh, t, mode, true, pool);
          it.reset(initial_clustering(pr, cs.mesh, t, Init::random, 16, seed));
          double e = exact_energy(cs.mesh, metric, it.labels(), 16, &bvh);
          for (int i = 0; i < 300; ++i) {
            IterationRecord r = it.step();
            if (r.moves == 0) break;
            total_moves += uint32_t(r.moves);
            double e1 = exact_energy(cs.mesh, metric, it.labels(), 16, &bvh);
            REQUIRE(e1 <= e * (1 + 1e-9));
            e = e1;
            if (mode == TopologyMode::preserving) {
              // the disk filter keeps every cluster connected and non-empty at every step
              Pieces pc = count_pieces(t, it.labels(), 16);
              REQUIRE(pc.nonempty == 16);
              REQUIRE(pc.pieces == 16);
            }
          }
        }
        CHECK(total_moves > 0);
      }
  }
}

TEST_CASE("the disk filter refuses moves that split the source or break the destination's ring") {
  Mesh m = test::grid(8, 8);
  Topology t = build_topology(m);
  auto face = [](uint32_t i, uint32_t j, uint32_t k) { return 2 * (j * 8 + i) + k; };  // k: 0 = abd, 1 = adc
  SUBCASE("a one-face-wide band would split") {
    std::vector<uint32_t> labels(m.face_count(), 1);
    for (uint32_t i = 0; i <= 5; ++i) labels[face(i, 3, 0)] = labels[face(i, 3, 1)] = 0;  // band: row 3, i <= 5
    CHECK_FALSE(move_keeps_disks(m, t, labels, face(3, 3, 0), 1));
    // the band's free end can leave: the rest stays connected and cluster 1 wraps around the end
    CHECK(move_keeps_disks(m, t, labels, face(5, 3, 0), 1));
  }
  SUBCASE("destination faces in the ring in two arcs") {
    // column i = 4: cluster 2 below (j <= 3), cluster 0 above (4 <= j <= 6); cluster 1 everywhere
    // else, connected over the top row. f, the lowest face of cluster 0, sees cluster 1 on its left
    // and on its right, separated by clusters 0 and 2.
    std::vector<uint32_t> labels(m.face_count(), 1);
    for (uint32_t j = 0; j <= 6; ++j) labels[face(4, j, 0)] = labels[face(4, j, 1)] = j <= 3 ? 2 : 0;
    uint32_t f = face(4, 4, 0);
    CHECK_FALSE(move_keeps_disks(m, t, labels, f, 1));
    CHECK(move_keeps_disks(m, t, labels, f, 2));  // the same face may join the cluster below
  }
  SUBCASE("an ordinary move across a straight border") {
    std::vector<uint32_t> labels(m.face_count(), 0);
    for (uint32_t j = 0; j < 8; ++j)
      for (uint32_t i = 4; i < 8; ++i) labels[face(i, j, 0)] = labels[face(i, j, 1)] = 1;
    CHECK(move_keeps_disks(m, t, labels, face(3, 4, 0), 1));
  }
}

TEST_CASE("the disk tests read from the ring's cycle agree with the tests by adjacency") {
  // Closed, open and non-manifold meshes, one with every third face reversed (the walk around a
  // corner then reads each face's corners), and one with every fourth face split in three at its
  // centroid: a face next to a split one has a ring face that meets another across its outer edge
  // (a chord: the split face's corner of valence 3 is in both).
  Mesh flipped = test::torus(24, 10);
  for (size_t f = 0; f < flipped.face_count(); f += 3) std::swap(flipped.indices[3 * f + 1], flipped.indices[3 * f + 2]);
  Mesh split = test::icosphere(2);
  for (size_t f = 0, n = split.face_count(); f < n; f += 4) {
    const uint32_t a = split.indices[3 * f], b = split.indices[3 * f + 1], c = split.indices[3 * f + 2];
    double p[3];
    for (int d = 0; d < 3; ++d)
      p[d] = (double(split.positions[3 * a + d]) + split.positions[3 * b + d] + split.positions[3 * c + d]) / 3;
    const uint32_t centre = test::add_vertex(split, p[0], p[1], p[2]);
    split.indices[3 * f + 2] = centre;  // (a, b, centre)
    test::add_triangle(split, b, c, centre);
    test::add_triangle(split, c, a, centre);
  }
  // A bipyramid over a 100-gon: the two apexes have rings beyond the cyclic reading's 64 faces.
  Mesh bipyramid;
  const uint32_t top = test::add_vertex(bipyramid, 0, 0, 1), bottom = test::add_vertex(bipyramid, 0, 0, -1);
  for (int i = 0; i < 100; ++i) test::add_vertex(bipyramid, std::cos(i * 0.0628), std::sin(i * 0.0628), 0);
  for (uint32_t i = 0; i < 100; ++i) {
    test::add_triangle(bipyramid, top, 2 + i, 2 + (i + 1) % 100);
    test::add_triangle(bipyramid, bottom, 2 + (i + 1) % 100, 2 + i);
  }
  // Two spheres sharing one vertex: its faces form two fans.
  Mesh pinched = test::combine(test::icosphere(2), test::icosphere(2), 2.0);
  const uint32_t half = uint32_t(pinched.vertex_count() / 2);
  for (uint32_t& v : pinched.indices)
    if (v == half) v = 0;
  struct Case {
    const char* name;
    Mesh mesh;
  };
  const Case cases[] = {{"icosphere", test::icosphere(3)}, {"torus", test::torus(24, 10)},
                        {"grid", test::grid(12, 12)},      {"grid with wall", test::grid_with_wall(10)},
                        {"flipped faces", flipped},        {"split faces", split},
                        {"pinched spheres", pinched}, {"bipyramid", bipyramid}};
  for (const Case& c : cases) {
    CAPTURE(c.name);
    const Mesh& m = c.mesh;
    Topology t = build_topology(m);
    const uint32_t nf = uint32_t(m.face_count());
    ClusterProblem pr = make_cluster_problem(m, options_for(Metric::cvt, nf / 6));
    size_t cyclic = 0, irregular = 0;
    std::vector<uint32_t> ring, expected;
    for (uint64_t seed : {1, 2, 3}) {
      std::vector<uint32_t> labels = initial_clustering(pr, m, t, Init::random, nf / 6, seed);
      for (uint32_t f = 0; f < nf; ++f) {
        expected.clear();
        for (int j = 0; j < 3; ++j) {
          uint32_t v = m.indices[3 * size_t(f) + j];
          for (uint32_t k = t.vertex_face_offsets[v]; k < t.vertex_face_offsets[v + 1]; ++k)
            if (t.vertex_faces[k] != f) expected.push_back(t.vertex_faces[k]);
        }
        std::sort(expected.begin(), expected.end());
        expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
        std::set<uint32_t> destinations;
        for (uint32_t g : expected)
          if (labels[g] != labels[f]) destinations.insert(labels[g]);
        for (uint32_t d : destinations) {
          const bool by_adjacency = move_keeps_disks_by_adjacency(m, t, labels, f, d);
          const int by_cycle = move_keeps_disks_by_cycle(m, t, labels, f, d, &ring);
          REQUIRE(move_keeps_disks(m, t, labels, f, d) == by_adjacency);
          if (by_cycle < 0) {
            ++irregular;
            continue;
          }
          ++cyclic;
          REQUIRE(by_cycle == int(by_adjacency));
          std::sort(ring.begin(), ring.end());
          REQUIRE(ring == expected);
        }
      }
    }
    // The cyclic reading covers the ordinary faces; boundaries, the wall, chords, the pinched
    // vertex and rings beyond 64 faces (every face of the bipyramid) fall back.
    const std::string name = c.name;
    CHECK((cyclic > 0) == (name != "bipyramid"));
    CHECK((irregular > 0) == (name != "icosphere" && name != "torus" && name != "flipped faces"));
  }
}

TEST_CASE("hierarchical initialization gives exactly n connected clusters") {
  Mesh m = test::torus(30, 12);
  Topology t = build_topology(m);
  uint32_t nf = uint32_t(m.face_count());
  for (Metric metric : {Metric::cvt, Metric::l21})
    for (uint32_t n : {1u, 2u, 7u, nf / 3, nf}) {
      CAPTURE(n);
      ClusterProblem pr = make_cluster_problem(m, options_for(metric, n));
      std::vector<uint32_t> labels = initial_clustering(pr, m, t, Init::hierarchical, n, 1);
      REQUIRE(labels.size() == nf);
      CHECK(*std::max_element(labels.begin(), labels.end()) == n - 1);
      Pieces pc = count_pieces(t, labels, n);
      CHECK(pc.nonempty == n);
      CHECK(pc.pieces == n);
    }
}

TEST_CASE("hierarchical initialization balances cluster weights where triangle sizes vary") {
  // A grid whose last tenth of columns is 21x wider: 70% of the area in 10% of the faces. One
  // matching per halving level gives clusters of about equal face counts, so the wide side's
  // clusters came out up to 4.6x the mean weight and the narrow side's down to 0.11x
  // (cluster_init.cpp, kBalancedRoundFraction). The weights should follow the area instead.
  const uint32_t nx = 96, ny = 96;
  Mesh m = test::grid(nx, ny);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const double x = m.positions[3 * v];
    m.positions[3 * v] = float(x + 20 * std::max(0.0, x - 0.9));
  }
  Topology t = build_topology(m);
  for (uint32_t n : {16u, 64u}) {
    CAPTURE(n);
    ClusterProblem pr = make_cluster_problem(m, options_for(Metric::cvt, n));
    std::vector<uint32_t> labels = initial_clustering(pr, m, t, Init::hierarchical, n, 1);
    std::vector<double> weight(n, 0.0);
    double total = 0;
    for (uint32_t f = 0; f < pr.face_count; ++f) weight[labels[f]] += pr.weight[f], total += pr.weight[f];
    const double mean = total / n;
    CAPTURE(*std::max_element(weight.begin(), weight.end()) / mean);
    CAPTURE(*std::min_element(weight.begin(), weight.end()) / mean);
    CHECK(*std::max_element(weight.begin(), weight.end()) <= 2.5 * mean);
    CHECK(*std::min_element(weight.begin(), weight.end()) >= 0.25 * mean);
  }
}

TEST_CASE("hierarchical initialization in parts: exactly n connected clusters, same labels for any thread count") {
  // Over 65536 faces the early levels run in spatial parts side by side (cluster_init.cpp): a
  // torus and a sphere, so that the parts cut across both and one holds pieces of two components.
  Mesh m = test::combine(test::torus(300, 120), test::icosphere(5), 3);
  REQUIRE(m.face_count() >= 65536);
  Topology t = build_topology(m);
  const uint32_t nf = uint32_t(m.face_count());
  for (Metric metric : {Metric::cvt, Metric::l21})
    for (uint32_t n : {2u, 64u, 1000u}) {
      CAPTURE(std::string(to_string(metric)));
      CAPTURE(n);
      ClusterProblem pr = make_cluster_problem(m, options_for(metric, n));
      WorkerPool one(1);
      std::vector<uint32_t> labels = initial_clustering(pr, m, t, Init::hierarchical, n, 1, nullptr, &one);
      REQUIRE(labels.size() == nf);
      Pieces pc = count_pieces(t, labels, n);
      CHECK(pc.nonempty == n);
      CHECK(pc.pieces == n);
      for (unsigned threads : {2u, 4u}) {
        WorkerPool pool(threads);
        CHECK(initial_clustering(pr, m, t, Init::hierarchical, n, 1, nullptr, &pool) == labels);
      }
    }
}

TEST_CASE("bad cluster counts are clear errors naming the numbers") {
  Mesh two = test::combine(test::icosphere(1), test::icosphere(1), 3);
  ClusterOptions o;
  o.clusters = 0;
  CHECK_THROWS_AS(cluster(two, o), OptionError);
  o.clusters = 100000;
  CHECK_THROWS_WITH_AS(cluster(two, o), doctest::Contains("160 faces"), OptionError);
  o.clusters = 1;
  CHECK_THROWS_WITH_AS(cluster(two, o), doctest::Contains("2 connected components"), OptionError);
  o.clusters = 4;
  o.metric = Metric::cvt;
  o.density.assign(3, 1.0f);
  CHECK_THROWS_AS(cluster(two, o), OptionError);
  // A bad density names its first bad face, whatever the thread count.
  o.density.assign(two.face_count(), 1.0f);
  o.density[97] = 0.0f;
  o.density[131] = -1.0f;
  for (unsigned threads : {1u, 4u}) {
    o.threads = threads;
    CHECK_THROWS_WITH_AS(cluster(two, o), doctest::Contains("density of face 97 "), OptionError);
  }
}

TEST_CASE("a mesh wider than the float range, or with a NaN corner, is a clear error") {
  // Two unit spheres scaled by s, at -3s and +3s along x: 8s wide. At s = 1e38 that is wider
  // than FLT_MAX (until the twenty-fourth session this overflowed the areas and the fixed-point
  // scale's int conversion, which UBSan reports); at 1e37 it fits.
  for (const float s : {1e38f, 1e37f}) {
    Mesh m = test::icosphere(1);
    for (float& x : m.positions) x *= s;
    Mesh far = m;
    for (size_t i = 0; i < m.positions.size(); i += 3) m.positions[i] -= 3 * s, far.positions[i] += 3 * s;
    const Mesh both = test::combine(m, far, 0);
    ClusterOptions o;
    o.clusters = 8;
    if (s == 1e38f) {
      CHECK_THROWS_WITH_AS(cluster(both, o), doctest::Contains("float range"), OptionError);
    } else {  // as wide as a float allows, and fine
      const Clustering c = cluster(both, o);
      CHECK(c.labels.size() == both.face_count());
    }
  }
  Mesh nan_corner = test::icosphere(1);
  nan_corner.positions[4] = NAN;
  ClusterOptions o;
  o.clusters = 8;
  CHECK_THROWS_WITH_AS(cluster(nan_corner, o), doctest::Contains("NaN"), OptionError);
}

TEST_CASE("final guarantees: exactly n connected, non-isolated clusters, every face labeled") {
  std::vector<Case> meshes = descent_meshes();
  for (const Case& cs : meshes) {
    Topology t = build_topology(cs.mesh);
    for (TopologyMode mode : {TopologyMode::preserving, TopologyMode::paper})
      for (Metric metric : {Metric::cvt, Metric::l21})
        for (uint32_t n : {6u, 40u}) {
          CAPTURE(std::string(cs.name));
          CAPTURE(std::string(to_string(mode)));
          CAPTURE(std::string(to_string(metric)));
          CAPTURE(n);
          ClusterOptions o = options_for(metric, n);
          o.topology = mode;
          Clustering c = cluster(cs.mesh, t, o);
          REQUIRE(c.labels.size() == cs.mesh.face_count());
          for (uint32_t l : c.labels) REQUIRE(l < n);
          Pieces pc = count_pieces(t, c.labels, n);
          CHECK(pc.nonempty == n);
          CHECK(pc.pieces == n);
          CHECK(check_clusters(t, c.labels, n).isolated == 0);
          CHECK(c.generators.size() == 3 * size_t(n));
          CHECK(c.history.size() == c.iterations + 1);
        }
  }
}

TEST_CASE("same labels whatever the thread count and with or without accelerators") {
  Mesh m = test::combine(test::torus(60, 24), test::icosphere(3), 3);
  Topology t = build_topology(m);
  for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21}) {
    CAPTURE(std::string(to_string(metric)));
    ClusterOptions o = options_for(metric, 60);
    o.threads = 1;
    o.accelerate = false;
    Clustering ref = cluster(m, t, o);
    uint64_t evaluated_plain = 0;
    for (auto& r : ref.history) evaluated_plain += r.evaluated_faces;
    for (unsigned threads : {1u, 2u, 4u})
      for (bool accelerate : {false, true}) {
        o.threads = threads;
        o.accelerate = accelerate;
        Clustering c = cluster(m, t, o);
        CHECK(c.labels == ref.labels);
        CHECK(c.iterations == ref.iterations);
        REQUIRE(c.history.size() == ref.history.size());
        uint64_t evaluated = 0;
        for (size_t i = 0; i < c.history.size(); ++i) {
          CHECK(c.history[i].energy == ref.history[i].energy);
          CHECK(c.history[i].moves == ref.history[i].moves);
          evaluated += c.history[i].evaluated_faces;
        }
        if (accelerate) CHECK(evaluated < evaluated_plain);  // the accelerator does skip work
      }
  }
}

TEST_CASE("a real scanned mesh: converges, hierarchical init beats random, guarantees hold") {
  Mesh m = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  Topology t = build_topology(m);
  ClusterOptions o = options_for(Metric::cvt, 200);
  Clustering h = cluster(m, t, o);
  CHECK(h.converged);
  CHECK(h.history.back().energy < h.history.front().energy);
  Pieces pc = count_pieces(t, h.labels, 200);
  CHECK(pc.nonempty == 200);
  CHECK(pc.pieces == 200);
  o.init = Init::random;
  Clustering r = cluster(m, t, o);
  CHECK(r.converged);
  // hierarchical init starts closer to a CVT than random growth does
  CHECK(h.history.front().energy < r.history.front().energy);
}

TEST_CASE("face_fixed: each contribution is llround of its double value (half away from zero)") {
  // face_fixed rounds inline; the fixed-point sums, and so every label, depend on it agreeing with
  // std::llround exactly. Random faces of a bumpy grid and a scanned mesh, all three metrics, plus
  // the weights rescaled so that many products land on or near .5.
  Mesh meshes[] = {test::grid(24, 24, 1, 1, 0.3), read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off")};
  for (Mesh& m : meshes)
    for (Metric metric : {Metric::cvt, Metric::ccvt, Metric::l21}) {
      ClusterOptions o;
      o.clusters = 4;
      o.metric = metric;
      ClusterProblem pr = make_cluster_problem(m, o);
      for (double scale : {1.0, 0.0}) {
        if (scale == 0.0) pr.fixed_scale = 2.0;  // small integers times w: many exact halves
        for (uint32_t k = 0; k < pr.face_count; ++k) {
          if (scale == 0.0) pr.weight[k] = float(k % 7) * 0.25f;
          int64_t v[kSumComponents];
          pr.face_fixed(k, v);
          double w = double(pr.weight[k]) * pr.fixed_scale;
          double px = pr.point[3 * k], py = pr.point[3 * k + 1], pz = pr.point[3 * k + 2];
          const double exact[kSumComponents] = {w, w * px, w * py, w * pz, w * ((px * px + py * py) + pz * pz)};
          for (int c = 0; c < kSumComponents; ++c) REQUIRE(v[c] == std::llround(exact[c]));
        }
      }
    }
  CHECK(std::llround(2.5) == 3);  // what "half away from zero" means, for the reader
  CHECK(std::llround(-2.5) == -3);
}

TEST_CASE("faces with a repeated corner are left out of the clustering and take a neighbour's cluster") {
  // Welding slivers leaves faces like (a, a, b): no area, no edges, each a component of its own.
  // Each took one of the n clusters (assimp-testmodels' spider -> 136: 56 clusters of one such face).
  const Mesh sphere = test::icosphere(3);  // 1280 faces
  const uint32_t collapsed = 20;
  const Mesh m = test::with_collapsed_faces(sphere, collapsed, 61);
  REQUIRE(build_topology(m).collapsed_faces == collapsed);
  ClusterOptions o;
  o.clusters = 100;
  o.device = "cpu";
  const Clustering plain = cluster(sphere, o);
  const Clustering c = cluster(m, o);
  // The sphere's faces are clustered as without the collapsed ones (all 100 clusters are theirs),
  // and each collapsed face takes the cluster of the lowest face at its lowest corner.
  CHECK(c.labels == test::labels_at_lowest_corners(m, plain.labels));
  // Per-face options are given for every face, the collapsed ones included.
  ClusterOptions per_face = o;
  per_face.density.assign(m.face_count(), 1.0f);
  per_face.initial_labels = c.labels;
  per_face.max_iterations = 0;
  const Clustering again = cluster(m, per_face);
  CHECK(again.labels == c.labels);
}
