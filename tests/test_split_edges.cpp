// Tests for split_long_edges (longest-edge refinement): no edge above its limit afterwards, the
// surface, its topology and orientation kept, each face inside its parent, angles no smaller than
// half the input's, per-face limits, non-manifold edges, and the errors.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/mesh.h"
#include "meshcvt/quality.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using meshcvt::Mesh;

namespace {

double edge_length(const Mesh& m, uint32_t a, uint32_t b) {
  double s = 0;
  for (int d = 0; d < 3; ++d) {
    const double x = double(m.positions[3 * size_t(a) + d]) - m.positions[3 * size_t(b) + d];
    s += x * x;
  }
  return std::sqrt(s);
}

double longest_edge(const Mesh& m) {
  double l = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) l = std::max(l, edge_length(m, m.indices[3 * f + k], m.indices[3 * f + (k + 1) % 3]));
  return l;
}

void normal(const Mesh& m, size_t f, double n[3]) {
  const float* a = &m.positions[3 * size_t(m.indices[3 * f])];
  const float* b = &m.positions[3 * size_t(m.indices[3 * f + 1])];
  const float* c = &m.positions[3 * size_t(m.indices[3 * f + 2])];
  const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  const double w[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

// Whether point q lies in triangle f of m (within a relative tolerance), q in its plane.
bool inside(const Mesh& m, size_t f, const double q[3]) {
  double n[3];
  normal(m, f, n);
  for (int k = 0; k < 3; ++k) {
    const float* a = &m.positions[3 * size_t(m.indices[3 * f + k])];
    const float* b = &m.positions[3 * size_t(m.indices[3 * f + (k + 1) % 3])];
    const double e[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double r[3] = {q[0] - a[0], q[1] - a[1], q[2] - a[2]};
    const double c[3] = {e[1] * r[2] - e[2] * r[1], e[2] * r[0] - e[0] * r[2], e[0] * r[1] - e[1] * r[0]};
    if (c[0] * n[0] + c[1] * n[1] + c[2] * n[2] < -1e-6 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2])) return false;
  }
  return true;
}

// Checks what every split must keep: each face is inside its parent and faces its way, the area,
// the topology (chi, boundary loops, manifoldness, orientation), and no edge above `limit`.
void check_split(const Mesh& in, const meshcvt::SplitEdgesResult& s, double limit) {
  for (uint32_t v : s.mesh.indices) REQUIRE(v < s.mesh.vertex_count());
  const meshcvt::MeshInfo a = meshcvt::mesh_info(in, meshcvt::build_topology(in));
  const meshcvt::MeshInfo b = meshcvt::mesh_info(s.mesh, meshcvt::build_topology(s.mesh));
  CHECK(b.euler_characteristic == a.euler_characteristic);
  CHECK(b.boundary_loops == a.boundary_loops);
  CHECK(b.components == a.components);
  CHECK(b.nonmanifold_edges == (a.nonmanifold_edges == 0 ? 0 : b.nonmanifold_edges));
  CHECK(b.orientation_flips == a.orientation_flips);
  CHECK(b.total_area == doctest::Approx(a.total_area).epsilon(1e-5));
  CHECK(longest_edge(s.mesh) <= limit);
  REQUIRE(s.parent.size() == s.mesh.face_count());
  CHECK(std::is_sorted(s.parent.begin(), s.parent.end()));  // children together, in input order
  for (size_t f = 0; f < s.mesh.face_count(); ++f) {
    const uint32_t p = s.parent[f];
    REQUIRE(p < in.face_count());
    double q[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) q[d] += s.mesh.positions[3 * size_t(s.mesh.indices[3 * f + k]) + d] / 3.0;
    CHECK(inside(in, p, q));
    double n0[3], n1[3];
    normal(in, p, n0);
    normal(s.mesh, f, n1);
    CHECK(n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] > 0);
  }
}

// A long flat sheet of two thin triangles (a CAD export's flat side): 20 x 1.
Mesh long_sheet() {
  Mesh m;
  meshcvt::test::add_vertex(m, 0, 0, 0);
  meshcvt::test::add_vertex(m, 20, 0, 0);
  meshcvt::test::add_vertex(m, 20, 1, 0);
  meshcvt::test::add_vertex(m, 0, 1, 0);
  meshcvt::test::add_triangle(m, 0, 1, 2);
  meshcvt::test::add_triangle(m, 0, 2, 3);
  return m;
}

}  // namespace

TEST_CASE("split_long_edges: a long sheet ends with no edge above the limit, its angles at least half") {
  const Mesh m = long_sheet();
  for (double limit : {10.0, 3.0, 1.0, 0.4}) {
    CAPTURE(limit);
    const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(m, limit);
    check_split(m, s, limit);
    CHECK(s.rounds > 0);
    CHECK(s.split_edges > 0);
    CHECK(s.mesh.face_count() > m.face_count());
    // The bound known before the work is one.
    const double at_least = meshcvt::split_long_edges_min_faces(m, limit);
    CHECK(at_least > 0.5 * m.face_count());
    CHECK(double(s.mesh.face_count()) >= at_least);
    // Longest-edge bisection: no angle smaller than half the input's smallest.
    CHECK(meshcvt::triangle_quality(s.mesh).min_angle_deg >= 0.5 * meshcvt::triangle_quality(m).min_angle_deg);
    // Input vertices keep their ids and positions.
    CHECK(std::equal(m.positions.begin(), m.positions.end(), s.mesh.positions.begin()));
  }
}

TEST_CASE("split_long_edges: closed and open meshes keep their topology; refined where long only") {
  // A torus stretched along x: its edges along x are long, those around the tube short.
  Mesh torus = meshcvt::test::torus(12, 24, 1, 0.3);
  for (size_t v = 0; v < torus.vertex_count(); ++v) torus.positions[3 * v] *= 6;
  const double before = longest_edge(torus);
  const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(torus, 0.5 * before);
  check_split(torus, s, 0.5 * before);
  CHECK(s.mesh.face_count() < 4 * torus.face_count());  // a subdivision would have made 4x
  const meshcvt::MeshInfo info = meshcvt::mesh_info(s.mesh, meshcvt::build_topology(s.mesh));
  CHECK(info.boundary_edges == 0);
  CHECK(info.nonmanifold_edges == 0);
  CHECK(info.genus == 1);

  const Mesh grid = meshcvt::test::grid(6, 3, 9, 1, 0.2);  // open, bumpy, cells 1.5 x 0.33
  const meshcvt::SplitEdgesResult g = meshcvt::split_long_edges(grid, 0.6);
  check_split(grid, g, 0.6);
  CHECK(meshcvt::mesh_info(g.mesh, meshcvt::build_topology(g.mesh)).genus == 0);
}

TEST_CASE("split_long_edges: nothing too long gives the mesh back as it is") {
  const Mesh m = meshcvt::test::icosphere(2);
  const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(m, 1.01 * longest_edge(m));
  CHECK(s.rounds == 0);
  CHECK(s.split_edges == 0);
  CHECK(s.mesh.indices == m.indices);
  CHECK(s.mesh.positions == m.positions);
  CHECK(s.mesh.source_polygon.empty());
  CHECK(s.parent.size() == m.face_count());
}

TEST_CASE("split_long_edges: per-face limits; an edge too long for one of its faces is split for both") {
  const Mesh m = long_sheet();
  // Face 0 allows 100 (nothing), face 1 allows 5: the shared diagonal (20.02) is too long for face
  // 1, so face 0 is split on it too (and on what keeps that conforming), but face 0's children
  // keep edges above 5.
  const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(m, 0, {100.0, 5.0});
  check_split(m, s, 20.0001);
  double longest_in_face0 = 0;
  for (size_t f = 0; f < s.mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = s.mesh.indices[3 * f + k], b = s.mesh.indices[3 * f + (k + 1) % 3];
      if (s.parent[f] == 1) CHECK(edge_length(s.mesh, a, b) <= 5.0);
      if (s.parent[f] == 0) longest_in_face0 = std::max(longest_in_face0, edge_length(s.mesh, a, b));
    }
  CHECK(longest_in_face0 > 5.0);
  CHECK(std::count(s.parent.begin(), s.parent.end(), 0u) > 1);  // split on the diagonal
}

TEST_CASE("split_long_edges: a split reaches along the longest-edge path (each face splits its own longest first)") {
  // A, B, C in a fan around vertex 1, each one's longest edge shared with the next: A's (1-2, 2.0) is
  // too long for A; B then needs its own longest (1-3, 3.0) split first, and C, on the other side of
  // that, its longest (1-4, 3.99), although neither is too long for B or C themselves.
  Mesh m;
  m.positions = {0, 0, 0, 1, -0.8f, 0, 2, 0, 0, 1.5f, 2.6f, 0, -1.5f, 3.7f, 0};
  const uint32_t p1 = 0, p0 = 1, p2 = 2, p3 = 3, p4 = 4;
  m.indices = {p1, p0, p2, p1, p2, p3, p1, p3, p4};  // A, B, C
  const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(m, 0, {1.5, 100.0, 100.0});
  check_split(m, s, 4.0);
  double longest_in[3] = {0, 0, 0};
  for (size_t f = 0; f < s.mesh.face_count(); ++f)
    for (int k = 0; k < 3; ++k)
      longest_in[s.parent[f]] = std::max(longest_in[s.parent[f]],
                                         edge_length(s.mesh, s.mesh.indices[3 * f + k], s.mesh.indices[3 * f + (k + 1) % 3]));
  CHECK(longest_in[0] <= 1.5);
  CHECK(longest_in[1] < 2.9);  // 1-3 split
  CHECK(longest_in[2] < 3.9);  // 1-4 split
  CHECK(meshcvt::triangle_quality(s.mesh).min_angle_deg >= 0.5 * meshcvt::triangle_quality(m).min_angle_deg);
}

TEST_CASE("split_long_edges: a non-manifold edge is split for all its faces; source_polygon follows") {
  Mesh m;
  m.positions = {0, 0, 0, 4, 0, 0, 2, 1, 0, 2, -1, 0, 2, 0, 1};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};  // three faces on edge {0, 1}
  m.source_polygon = {5, 6, 6};
  const meshcvt::SplitEdgesResult s = meshcvt::split_long_edges(m, 3.0);
  check_split(m, s, 3.0);
  const meshcvt::Topology t = meshcvt::build_topology(s.mesh);
  CHECK(t.nonmanifold_edges == 2);  // both halves of the fin edge
  for (size_t f = 0; f < s.mesh.face_count(); ++f) CHECK(s.mesh.source_polygon[f] == m.source_polygon[s.parent[f]]);
}

TEST_CASE("split_long_edges: the same input gives the same output; bad limits and arrays throw") {
  Mesh torus = meshcvt::test::torus(10, 20);
  for (size_t v = 0; v < torus.vertex_count(); ++v) torus.positions[3 * v + 1] *= 5;
  const double limit = 0.3 * longest_edge(torus);
  const meshcvt::SplitEdgesResult a = meshcvt::split_long_edges(torus, limit);
  const meshcvt::SplitEdgesResult b = meshcvt::split_long_edges(torus, limit);
  CHECK(a.mesh.indices == b.mesh.indices);
  CHECK(a.mesh.positions == b.mesh.positions);
  CHECK(a.parent == b.parent);

  const Mesh m = long_sheet();
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, 0), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, NAN), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, INFINITY), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, 1, {1.0}), meshcvt::OptionError);  // one limit for two faces
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, 1, {1.0, -1.0}), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::split_long_edges(m, 1e-12), meshcvt::OptionError);  // beyond 32-bit indices
  Mesh bad = m;
  bad.indices[0] = 9;
  CHECK_THROWS_AS(meshcvt::split_long_edges(bad, 1), meshcvt::OptionError);
}

TEST_CASE("split_long_edges: a face budget stops the split; within it the result is the same") {
  // A needle tetrahedron (apex at the origin, a base 1e-4 wide at distance 1): its split makes about
  // 60 times split_long_edges_min_faces, the propagation along the needle's long edges.
  Mesh needle;
  needle.positions = {0, 0, 0, 1, 0, 0, 1, 1e-4f, 0, 1, 0, 1e-4f};
  needle.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  const double limit = 0.003;
  const double bound = meshcvt::split_long_edges_min_faces(needle, limit);
  const meshcvt::SplitEdgesResult all = meshcvt::split_long_edges(needle, limit);
  const uint64_t faces = all.mesh.face_count();
  REQUIRE(double(faces) > 20 * bound);
  CHECK_FALSE(all.over_budget);

  const meshcvt::SplitEdgesResult stopped = meshcvt::split_long_edges(needle, limit, {}, uint64_t(10 * bound));
  CHECK(stopped.over_budget);
  CHECK(stopped.over_budget_faces > uint64_t(10 * bound));
  CHECK(stopped.over_budget_faces <= faces);  // a round's faces: at most the end's
  CHECK(stopped.mesh.face_count() == 0);
  CHECK(meshcvt::split_long_edges(needle, limit, {}, faces - 1).over_budget);
  const meshcvt::SplitEdgesResult exact = meshcvt::split_long_edges(needle, limit, {}, faces);
  CHECK_FALSE(exact.over_budget);
  CHECK(exact.mesh.indices == all.mesh.indices);
  CHECK(exact.mesh.positions == all.mesh.positions);
  CHECK(exact.parent == all.parent);
  // Beyond the budget by the bound alone: no round runs.
  const meshcvt::SplitEdgesResult early = meshcvt::split_long_edges(needle, limit, {}, uint64_t(bound / 2));
  CHECK(early.over_budget);
  CHECK(early.over_budget_faces == uint64_t(std::ceil(bound)));
}

TEST_CASE("coarse_edge_length: equilateral triangles of n vertices, cells as an optimal CVT's") {
  // A closed mesh of n vertices has 2n triangles: each (sqrt 3 / 4) l^2.
  const double l = meshcvt::coarse_edge_length(100.0, 50);
  CHECK(2 * 50 * std::sqrt(3.0) / 4 * l * l == doctest::Approx(100.0));
  // 4x density: clusters of half the area (an optimal CVT's cells go as density^-1/2)
  CHECK(meshcvt::coarse_edge_length(100.0, 50, 4.0) == doctest::Approx(l / std::sqrt(2.0)));
  // Half of an area of 100 at density 1, half at 4: S = 50 + 50 sqrt(4) = 150, and the cells there
  // add up to the n clusters.
  auto cell = [](double edge) { return std::sqrt(3.0) / 2 * edge * edge; };
  const double at1 = meshcvt::coarse_edge_length(150.0, 50, 1.0), at4 = meshcvt::coarse_edge_length(150.0, 50, 4.0);
  CHECK(50 / cell(at1) + 50 / cell(at4) == doctest::Approx(50.0));
  CHECK_THROWS_AS(meshcvt::coarse_edge_length(100.0, 0), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::coarse_edge_length(-1.0, 5), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::coarse_edge_length(1.0, 5, 0.0), meshcvt::OptionError);
}
