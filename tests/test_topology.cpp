// Tests for build_topology and mesh_info on meshes made in code, whose counts are known by
// construction (closed solids, grids, tori, bow-ties, non-manifold fins, degenerate faces), plus
// brute-force cross-checks of the adjacency and vertex -> faces arrays.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/mesh.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using meshcvt::kNone;
using meshcvt::Mesh;
using meshcvt::Topology;

namespace {

Mesh tetrahedron() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};  // outward, consistently oriented
  return m;
}

Mesh moebius_strip() {
  // A strip of n quads whose ends are glued with a half twist.
  const int n = 8;
  Mesh m;
  for (int i = 0; i < n; ++i) {
    double u = 2 * M_PI * i / n, w = u / 2;
    for (int s = -1; s <= 1; s += 2)
      m.positions.insert(m.positions.end(), {float((2 + s * 0.5 * std::cos(w)) * std::cos(u)),
                                             float((2 + s * 0.5 * std::cos(w)) * std::sin(u)), float(s * 0.5 * std::sin(w))});
  }
  for (int i = 0; i < n; ++i) {
    uint32_t a = 2 * i, b = 2 * i + 1, c, d;
    if (i + 1 < n) c = 2 * (i + 1) + 1, d = 2 * (i + 1);
    else c = 0, d = 1;  // the twist: the two sides swap
    m.indices.insert(m.indices.end(), {a, d, c, a, c, b});
  }
  return m;
}

Mesh cube() {
  Mesh m;
  for (int i = 0; i < 8; ++i) m.positions.insert(m.positions.end(), {float(i & 1), float((i >> 1) & 1), float(i >> 2)});
  // Two outward triangles per side; vertex i = x + 2y + 4z.
  m.indices = {0, 2, 3, 0, 3, 1,   // z = 0
               4, 5, 7, 4, 7, 6,   // z = 1
               0, 1, 5, 0, 5, 4,   // y = 0
               2, 6, 7, 2, 7, 3,   // y = 1
               0, 4, 6, 0, 6, 2,   // x = 0
               1, 3, 7, 1, 7, 5};  // x = 1
  return m;
}

// nx * ny quads of a unit grid in the z = 0 plane, two triangles each. With wrap, the grid is
// closed on itself in both directions (a torus, positions on a real torus so areas are non-zero).
Mesh grid(int nx, int ny, bool wrap = false) {
  Mesh m;
  int vx = wrap ? nx : nx + 1, vy = wrap ? ny : ny + 1;
  for (int j = 0; j < vy; ++j)
    for (int i = 0; i < vx; ++i) {
      if (wrap) {
        double u = 2 * M_PI * i / nx, v = 2 * M_PI * j / ny;
        m.positions.insert(m.positions.end(), {float((2 + std::cos(v)) * std::cos(u)),
                                               float((2 + std::cos(v)) * std::sin(u)), float(std::sin(v))});
      } else {
        m.positions.insert(m.positions.end(), {float(i), float(j), 0.f});
      }
    }
  auto id = [&](int i, int j) { return uint32_t((j % vy) * vx + (i % vx)); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      uint32_t a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  return m;
}

// Brute force: faces sharing the two vertices of edge e of f (any orientation).
std::vector<uint32_t> faces_on_edge(const Mesh& m, uint32_t f, uint32_t e) {
  uint32_t a = m.indices[3 * f + e], b = m.indices[3 * f + (e + 1) % 3];
  std::vector<uint32_t> out;
  for (uint32_t g = 0; g < m.face_count(); ++g) {
    const uint32_t* t = &m.indices[3 * g];
    bool has_a = t[0] == a || t[1] == a || t[2] == a, has_b = t[0] == b || t[1] == b || t[2] == b;
    if (has_a && has_b && g != f) out.push_back(g);
  }
  return out;
}

// Checks face_adjacent and vertex_faces against brute force (for meshes without collapsed faces).
void check_against_brute_force(const Mesh& m, const Topology& t) {
  REQUIRE(t.face_adjacent.size() == m.indices.size());
  for (uint32_t f = 0; f < m.face_count(); ++f)
    for (uint32_t e = 0; e < 3; ++e) {
      std::vector<uint32_t> others = faces_on_edge(m, f, e);
      uint32_t expected = others.size() == 1 ? others[0] : kNone;
      CHECK(t.face_adjacent[3 * f + e] == expected);
    }
  REQUIRE(t.vertex_face_offsets.size() == m.vertex_count() + 1);
  for (uint32_t v = 0; v < m.vertex_count(); ++v) {
    std::vector<uint32_t> expected;
    for (uint32_t f = 0; f < m.face_count(); ++f)
      if (m.indices[3 * f] == v || m.indices[3 * f + 1] == v || m.indices[3 * f + 2] == v) expected.push_back(f);
    std::vector<uint32_t> got(t.vertex_faces.begin() + t.vertex_face_offsets[v],
                              t.vertex_faces.begin() + t.vertex_face_offsets[v + 1]);
    CHECK(got == expected);
  }
}

}  // namespace

TEST_CASE("topology: tetrahedron is closed, genus 0") {
  Mesh m = tetrahedron();
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.edge_count == 6);
  CHECK(t.boundary_edges == 0);
  CHECK(t.boundary_loops == 0);
  CHECK(t.component_count == 1);
  CHECK(t.nonmanifold_edges == 0);
  CHECK(t.nonmanifold_vertices == 0);
  CHECK(t.orientation_flips == 0);
  CHECK(t.referenced_vertices == 4);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.euler_characteristic == 2);
  CHECK(info.genus == 0);
  CHECK(info.total_area == doctest::Approx(1.5 + std::sqrt(3.0) / 2));
  CHECK(info.bbox_min[0] == 0);
  CHECK(info.bbox_max[2] == 1);
}

TEST_CASE("topology: cube of 12 triangles") {
  Mesh m = cube();
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.vertices == 8);
  CHECK(info.faces == 12);
  CHECK(info.edges == 18);
  CHECK(info.euler_characteristic == 2);
  CHECK(info.genus == 0);
  CHECK(info.boundary_edges == 0);
  CHECK(info.orientation_flips == 0);
  CHECK(info.degenerate_faces == 0);
  CHECK(info.duplicate_faces == 0);
  CHECK(info.total_area == doctest::Approx(6.0));
}

TEST_CASE("topology: open grid has one boundary loop") {
  const int nx = 5, ny = 3;
  Mesh m = grid(nx, ny);
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.boundary_edges == 2 * (nx + ny));
  CHECK(t.boundary_loops == 1);
  CHECK(t.edge_count == uint64_t(nx * (ny + 1) + ny * (nx + 1) + nx * ny));
  CHECK(t.component_count == 1);
  CHECK(t.nonmanifold_vertices == 0);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.euler_characteristic == 1);
  CHECK(info.genus == 0);  // a disk
  CHECK(info.total_area == doctest::Approx(nx * ny));
}

TEST_CASE("topology: torus grid closed on itself has genus 1") {
  Mesh m = grid(6, 4, true);
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.vertices == 24);
  CHECK(info.faces == 48);
  CHECK(info.edges == 72);
  CHECK(info.boundary_edges == 0);
  CHECK(info.euler_characteristic == 0);
  CHECK(info.genus == 1);
}

TEST_CASE("topology: bow-tie has a non-manifold vertex and two components") {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, -1, 0, 0, -1, -1, 0};
  m.indices = {0, 1, 2, 0, 3, 4};
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.nonmanifold_vertices == 1);
  CHECK(t.nonmanifold_edges == 0);
  CHECK(t.component_count == 2);
  CHECK(t.boundary_edges == 6);
  CHECK(t.boundary_loops == 2);  // the two triangles' rims, not one figure eight
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.genus == -1);
}

TEST_CASE("topology: three faces on one edge make it non-manifold, with no adjacency across") {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.nonmanifold_edges == 1);
  CHECK(t.edge_count == 7);
  CHECK(t.boundary_edges == 6);
  for (uint32_t a : t.face_adjacent) CHECK(a == kNone);
  CHECK(t.component_count == 3);
  CHECK(t.nonmanifold_vertices == 2);  // both ends of the fin edge
  CHECK(meshcvt::mesh_info(m, t).genus == -1);
}

TEST_CASE("topology: two disjoint components numbered by their lowest face") {
  Mesh a = tetrahedron(), m;
  m.positions = a.positions;
  for (float p : a.positions) m.positions.push_back(p + 5);
  // Faces alternate between the two tetrahedra, the second one first.
  for (int f = 0; f < 4; ++f) {
    for (int c = 0; c < 3; ++c) m.indices.push_back(a.indices[3 * f + c] + 4);
    for (int c = 0; c < 3; ++c) m.indices.push_back(a.indices[3 * f + c]);
  }
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.component_count == 2);
  CHECK(t.face_component == std::vector<uint32_t>{0, 1, 0, 1, 0, 1, 0, 1});
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.euler_characteristic == 4);
  CHECK(info.genus == 0);  // summed over components
  CHECK(info.bbox_min[0] == 0);
  CHECK(info.bbox_max[0] == 6);
}

TEST_CASE("topology: disk plus torus: genus sums over components") {
  Mesh a = grid(2, 2), b = grid(5, 3, true), m = a;
  uint32_t shift = uint32_t(a.vertex_count());
  m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
  for (uint32_t i : b.indices) m.indices.push_back(i + shift);
  Topology t = meshcvt::build_topology(m);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.components == 2);
  CHECK(info.boundary_loops == 1);
  CHECK(info.euler_characteristic == 1);
  CHECK(info.genus == 1);
}

TEST_CASE("topology: holes touching at a vertex: loops follow the fans") {
  // 4 x 4 grid without quads (1,1) and (2,2), which share the vertex P = (2,2). Around P the
  // surface is two wedges, each bounded by one edge of each hole, so following the boundary along
  // the surface (the edge that closes the same fan at P) goes from one hole into the other: the
  // two holes are one loop, plus the outer rim. This is the count of the surface with P split in
  // two (one vertex per fan): V 26, E 54, F 28, chi 0 = 2 - 2g - b gives b = 2 for g = 0 (b = 3
  // would give no integer genus). Walking by orientation alone could not decide at P.
  Mesh full = grid(4, 4), m;
  m.positions = full.positions;
  for (int q = 0; q < 16; ++q) {
    if (q == 1 * 4 + 1 || q == 2 * 4 + 2) continue;
    m.indices.insert(m.indices.end(), full.indices.begin() + 6 * q, full.indices.begin() + 6 * q + 6);
  }
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.boundary_edges == 16 + 8);
  CHECK(t.boundary_loops == 2);
  CHECK(t.nonmanifold_vertices == 1);
  CHECK(t.component_count == 1);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.euler_characteristic == 25 - 54 + 28);
  CHECK(info.genus == -1);  // not a manifold
}

TEST_CASE("topology: two grids touching at a corner: two loops, not one figure eight") {
  Mesh a = grid(2, 2), m = a;
  // The second grid is the first turned by 180 degrees about its corner (2,2) = vertex 8.
  uint32_t shift = uint32_t(a.vertex_count());
  for (size_t v = 0; v < a.vertex_count(); ++v)
    m.positions.insert(m.positions.end(), {4 - a.positions[3 * v], 4 - a.positions[3 * v + 1], 0.f});
  for (uint32_t i : a.indices) m.indices.push_back(i == 8 ? 8 : i + shift);  // (2,2) is shared
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.component_count == 2);
  CHECK(t.nonmanifold_vertices == 1);
  CHECK(t.boundary_edges == 16);
  CHECK(t.boundary_loops == 2);
}

TEST_CASE("topology: annulus has two loops, genus 0") {
  // 3 x 3 grid without the middle quad.
  Mesh full = grid(3, 3), m;
  m.positions = full.positions;
  for (int q = 0; q < 9; ++q)
    if (q != 4) m.indices.insert(m.indices.end(), full.indices.begin() + 6 * q, full.indices.begin() + 6 * q + 6);
  Topology t = meshcvt::build_topology(m);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.boundary_loops == 2);
  CHECK(info.nonmanifold_vertices == 0);
  CHECK(info.euler_characteristic == 0);
  CHECK(info.genus == 0);
}

// A fan of n triangles around vertex 0 (a disk), and the same fan doubled into a double cone
// whose two halves meet only at the apex.
Mesh fan(uint32_t n, bool double_cone) {
  Mesh m;
  m.positions = {0, 0, 0};
  for (uint32_t i = 0; i < n; ++i)
    m.positions.insert(m.positions.end(), {float(std::cos(2 * M_PI * i / n)), float(std::sin(2 * M_PI * i / n)), 1});
  for (uint32_t i = 0; i < n; ++i) m.indices.insert(m.indices.end(), {0, 1 + i, 1 + (i + 1) % n});
  if (double_cone) {
    for (uint32_t i = 0; i < n; ++i)
      m.positions.insert(m.positions.end(), {float(std::cos(2 * M_PI * i / n)), float(std::sin(2 * M_PI * i / n)), -1});
    for (uint32_t i = 0; i < n; ++i) m.indices.insert(m.indices.end(), {0, 1 + n + (i + 1) % n, 1 + n + i});
  }
  return m;
}

TEST_CASE("topology: fans of every size around one vertex (pairwise and sorted paths)") {
  // Up to 16 faces per vertex the edges at a vertex are grouped by pairwise comparison, beyond by
  // sorting: both must agree with brute force and with the counts known by construction.
  for (uint32_t n : {3u, 8u, 15u, 16u, 17u, 40u}) {
    CAPTURE(n);
    Mesh disk = fan(n, false);
    Topology t = meshcvt::build_topology(disk);
    check_against_brute_force(disk, t);
    CHECK(t.nonmanifold_vertices == 0);
    CHECK(t.boundary_edges == n);
    CHECK(t.boundary_loops == 1);
    CHECK(meshcvt::mesh_info(disk, t).genus == 0);
    Mesh cone = fan(n, true);
    t = meshcvt::build_topology(cone);
    check_against_brute_force(cone, t);
    CHECK(t.nonmanifold_vertices == 1);  // the apex: two fans
    CHECK(t.component_count == 2);
    CHECK(t.boundary_loops == 2);
    // A fin on one spoke makes that edge non-manifold in both paths.
    Mesh fin = disk;
    fin.positions.insert(fin.positions.end(), {0.5f, 0, 2});
    fin.indices.insert(fin.indices.end(), {0, 1, uint32_t(fin.vertex_count() - 1)});
    t = meshcvt::build_topology(fin);
    check_against_brute_force(fin, t);
    CHECK(t.nonmanifold_edges == 1);
    CHECK(t.nonmanifold_vertices == 2);
  }
}

TEST_CASE("topology: degenerate and duplicate faces") {
  Mesh m = grid(2, 1);  // vertices 0..5: (0,0) (1,0) (2,0) / (0,1) (1,1) (2,1); 4 faces
  m.positions.insert(m.positions.end(), {3, 0, 0});  // vertex 6, collinear with 0, 1, 2
  uint32_t base = uint32_t(m.face_count());
  m.indices.insert(m.indices.end(), {0, 2, 6,     // collinear: zero cross product
                                     4, 4, 5,     // collapsed
                                     5, 4, 4,     // collapsed, same corner triple
                                     1, 2, 5,     // copy of face 2 (1 2 5), same order
                                     5, 2, 1});   // and reversed
  Topology t = meshcvt::build_topology(m);
  CHECK(t.degenerate_faces == 3);
  CHECK(t.collapsed_faces == 2);
  CHECK(t.duplicate_faces == 3);
  // A collapsed face has no edges and no neighbours, and is in vertex_faces once per vertex.
  for (uint32_t e = 0; e < 3; ++e) CHECK(t.face_adjacent[3 * (base + 1) + e] == kNone);
  std::vector<uint32_t> faces4(t.vertex_faces.begin() + t.vertex_face_offsets[4],
                               t.vertex_faces.begin() + t.vertex_face_offsets[5]);
  CHECK(std::count(faces4.begin(), faces4.end(), base + 1) == 1);
  CHECK(std::is_sorted(faces4.begin(), faces4.end()));
  // The three copies of (1 2 5) make its edges non-manifold.
  CHECK(t.nonmanifold_edges == 3);
  CHECK(meshcvt::mesh_info(m, t).genus == -1);
}

TEST_CASE("topology: collapsed faces do not get between their neighbours") {
  // Two triangles (0 1 2) and (1 0 3) with a sliver (0 1 1) on their shared edge: still adjacent.
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0};
  m.indices = {0, 1, 2, 0, 1, 1, 1, 0, 3};
  Topology t = meshcvt::build_topology(m);
  CHECK(t.face_adjacent[0] == 2);
  CHECK(t.face_adjacent[6] == 0);
  CHECK(t.nonmanifold_edges == 0);
  CHECK(t.component_count == 2);  // {0, 2} and the sliver
  CHECK(t.face_component == std::vector<uint32_t>{0, 1, 0});
}

TEST_CASE("topology: inconsistent orientation is adjacent but counted") {
  Mesh m = grid(3, 3);
  std::swap(m.indices[3 * 8 + 1], m.indices[3 * 8 + 2]);  // face 8 is interior: all 3 edges flip
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.orientation_flips == 3);
  CHECK(t.nonorientable_components == 0);
  CHECK(meshcvt::mesh_info(m, t).genus == 0);
}

TEST_CASE("topology: Moebius strip is non-orientable") {
  Mesh m = moebius_strip();
  Topology t = meshcvt::build_topology(m);
  check_against_brute_force(m, t);
  CHECK(t.boundary_loops == 1);
  CHECK(t.orientation_flips >= 1);
  CHECK(t.nonorientable_components == 1);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.euler_characteristic == 0);
  CHECK(info.genus == -1);
}

TEST_CASE("topology: unreferenced vertices are not counted") {
  Mesh m = tetrahedron();
  m.positions.insert(m.positions.end(), {-7, 9, 9});
  Topology t = meshcvt::build_topology(m);
  CHECK(t.referenced_vertices == 4);
  CHECK(t.vertex_face_offsets[4] == t.vertex_face_offsets[5]);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.vertices == 4);
  CHECK(info.euler_characteristic == 2);
  CHECK(info.bbox_min[0] == 0);  // the stray vertex is not in the box
  CHECK(info.bbox_max[1] == 1);
}

TEST_CASE("topology: empty mesh and bad indices") {
  Mesh empty;
  Topology t = meshcvt::build_topology(empty);
  CHECK(t.component_count == 0);
  CHECK(t.vertex_face_offsets == std::vector<uint32_t>{0});
  CHECK(meshcvt::mesh_info(empty, t).genus == -1);
  Mesh bad = tetrahedron();
  bad.indices[5] = 4;
  CHECK_THROWS_AS(meshcvt::build_topology(bad), meshcvt::OptionError);
}

TEST_CASE("topology: large shuffled torus matches brute-force invariants on both threads' halves") {
  // Big enough (>= 65536 faces) that the vertex loops split over threads; faces shuffled so face
  // order and vertex order disagree.
  Mesh m = grid(256, 130, true);
  uint32_t nf = uint32_t(m.face_count());
  std::vector<uint32_t> shuffled(m.indices.size());
  uint64_t state = 12345;
  std::vector<uint32_t> order(nf);
  for (uint32_t f = 0; f < nf; ++f) order[f] = f;
  for (uint32_t f = nf - 1; f > 0; --f) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    std::swap(order[f], order[uint32_t((state >> 33) % (f + 1))]);
  }
  for (uint32_t f = 0; f < nf; ++f)
    for (int c = 0; c < 3; ++c) shuffled[3 * f + c] = m.indices[3 * order[f] + c];
  m.indices = shuffled;
  Topology t = meshcvt::build_topology(m);
  meshcvt::MeshInfo info = meshcvt::mesh_info(m, t);
  CHECK(info.faces == 2u * 256 * 130);
  CHECK(info.edges == 3u * 256 * 130);
  CHECK(info.genus == 1);
  CHECK(info.components == 1);
  CHECK(info.orientation_flips == 0);
  // Adjacency is symmetric and neighbours share exactly the edge's two vertices.
  uint64_t bad = 0;
  for (uint32_t h = 0; h < 3 * nf; ++h) {
    uint32_t g = t.face_adjacent[h];
    if (g == kNone || g >= nf) { ++bad; continue; }
    uint32_t a = m.indices[h], b = m.indices[h % 3 == 2 ? h - 2 : h + 1];
    int back = 0;
    for (uint32_t e = 0; e < 3; ++e) {
      uint32_t x = m.indices[3 * g + e], y = m.indices[3 * g + (e + 1) % 3];
      if (x == b && y == a) back += t.face_adjacent[3 * g + e] == h / 3;
    }
    bad += back != 1;
  }
  CHECK(bad == 0);
  // vertex_faces: every face listed at each of its corners, ids increasing.
  uint64_t listed = 0;
  for (uint32_t v = 0; v < m.vertex_count(); ++v) {
    uint32_t b = t.vertex_face_offsets[v], e = t.vertex_face_offsets[v + 1];
    CHECK(e - b == 6);
    for (uint32_t i = b; i < e; ++i) {
      uint32_t f = t.vertex_faces[i];
      listed += m.indices[3 * f] == v || m.indices[3 * f + 1] == v || m.indices[3 * f + 2] == v;
      if (i > b) CHECK(t.vertex_faces[i - 1] < f);
    }
  }
  CHECK(listed == 3ull * nf);
}

TEST_CASE("topology: every thread count gives the same topology") {
  // One mesh with everything build_topology tells apart: a torus (closed, genus 1), a grid with a
  // non-manifold wall (boundary loops, non-manifold edges), a Moebius strip (non-orientable),
  // collapsed and duplicated faces, a flipped face, an unreferenced vertex; faces shuffled so that
  // face order and vertex order disagree. Thread counts above the face count leave threads
  // without faces or vertices.
  using meshcvt::test::combine;
  Mesh m = combine(combine(meshcvt::test::torus(24, 12), meshcvt::test::grid_with_wall(12), 3.0), moebius_strip(), 6.0);
  m = meshcvt::test::with_collapsed_faces(m, 9, 7);
  for (int c = 0; c < 3; ++c) m.indices.push_back(m.indices[3 * 40 + c]);  // a duplicate of face 40
  std::swap(m.indices[3 * 100 + 1], m.indices[3 * 100 + 2]);               // a flipped face
  for (int c = 0; c < 3; ++c) m.positions.push_back(9.0f);                 // an unreferenced vertex
  const uint32_t nf = uint32_t(m.face_count());
  uint64_t state = 99;
  for (uint32_t f = nf - 1; f > 0; --f) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    const uint32_t g = uint32_t((state >> 33) % (f + 1));
    for (int c = 0; c < 3; ++c) std::swap(m.indices[3 * f + c], m.indices[3 * g + c]);
  }
  const Topology one = meshcvt::build_topology(m, 1);
  REQUIRE(one.nonmanifold_edges > 0);
  REQUIRE(one.boundary_loops > 0);
  REQUIRE(one.nonorientable_components == 1);
  REQUIRE(one.collapsed_faces == 9);
  REQUIRE(one.duplicate_faces > 0);
  REQUIRE(one.referenced_vertices + 1 == m.vertex_count());
  for (unsigned threads : {2u, 3u, 4u, 5u, 7u, 8u, 16u, 1000u}) {
    CAPTURE(threads);
    const Topology t = meshcvt::build_topology(m, threads);
    CHECK(t.face_adjacent == one.face_adjacent);
    CHECK(t.vertex_face_offsets == one.vertex_face_offsets);
    CHECK(t.vertex_faces == one.vertex_faces);
    CHECK(t.face_component == one.face_component);
    CHECK(t.component_count == one.component_count);
    CHECK(t.edge_count == one.edge_count);
    CHECK(t.boundary_edges == one.boundary_edges);
    CHECK(t.boundary_loops == one.boundary_loops);
    CHECK(t.nonmanifold_edges == one.nonmanifold_edges);
    CHECK(t.nonmanifold_vertices == one.nonmanifold_vertices);
    CHECK(t.degenerate_faces == one.degenerate_faces);
    CHECK(t.duplicate_faces == one.duplicate_faces);
    CHECK(t.referenced_vertices == one.referenced_vertices);
    CHECK(t.collapsed_faces == one.collapsed_faces);
    CHECK(t.orientation_flips == one.orientation_flips);
    CHECK(t.nonorientable_components == one.nonorientable_components);
  }
  // More threads than faces.
  const Topology small = meshcvt::build_topology(tetrahedron(), 16);
  CHECK(small.edge_count == 6);
  CHECK(small.vertex_faces.size() == 12);
  CHECK(small.boundary_edges == 0);
}

// ---- orient_consistently

namespace {

void flip_face(Mesh& m, size_t f) { std::swap(m.indices[3 * f + 1], m.indices[3 * f + 2]); }

using meshcvt::test::shuffle_orientation;
using meshcvt::test::signed_volume6;

}  // namespace

TEST_CASE("orient_consistently: a closed surface with faces flipped at random comes back outward") {
  struct Case {
    const char* name;
    Mesh mesh;
  };
  Mesh far = meshcvt::test::icosphere(2);
  for (size_t i = 0; i < far.positions.size(); i += 3) far.positions[i] += 1000.f;  // digits far from the origin
  std::vector<Case> cases;
  cases.push_back({"icosphere", meshcvt::test::icosphere(3)});
  cases.push_back({"torus", meshcvt::test::torus(30, 12)});
  cases.push_back({"icosphere at x = 1000", far});
  for (Case& c : cases) {
    CAPTURE(std::string(c.name));
    const Mesh original = c.mesh;
    REQUIRE(signed_volume6(original) > 0);
    REQUIRE(meshcvt::build_topology(original).orientation_flips == 0);
    for (uint32_t seed : {1u, 7u, 12345u}) {
      Mesh m = original;
      const size_t flipped = shuffle_orientation(m, 0, m.face_count(), seed);
      Topology t = meshcvt::build_topology(m);
      REQUIRE(t.orientation_flips > 0);
      CHECK(meshcvt::orient_consistently(m, t) == flipped);
      CHECK(m.indices == original.indices);  // every flipped face swapped back, no other touched
      CHECK(t.orientation_flips == 0);       // the topology was rebuilt for the flipped faces
      CHECK(t.face_adjacent == meshcvt::build_topology(m).face_adjacent);
    }
    // All faces flipped: consistent, inward. The function leaves a consistent mesh as it is.
    Mesh inward = original;
    for (size_t f = 0; f < inward.face_count(); ++f) flip_face(inward, f);
    Topology t = meshcvt::build_topology(inward);
    CHECK(meshcvt::orient_consistently(inward, t) == 0);
    CHECK(signed_volume6(inward) < 0);
  }
}

TEST_CASE("orient_consistently: an open surface keeps the orientation of its larger area") {
  const Mesh original = grid(6, 6);  // 72 faces, two per unit square, x = 0..6
  const uint32_t* orig = original.indices.data();
  auto square_x = [&](size_t f) {  // the x of a face's lowest corner: the column of its square
    float x = 1e9f;
    for (int k = 0; k < 3; ++k) x = std::min(x, original.positions[3 * size_t(orig[3 * f + k])]);
    return x;
  };
  // Columns 0 and 1 (a third of the area) flipped: they are flipped back.
  Mesh m = original;
  size_t minority = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    if (square_x(f) < 2) flip_face(m, f), ++minority;
  Topology t = meshcvt::build_topology(m);
  CHECK(meshcvt::orient_consistently(m, t) == minority);
  CHECK(m.indices == original.indices);
  // Columns 0 to 3 flipped (two thirds): the other third follows them.
  m = original;
  size_t majority = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    if (square_x(f) < 4) flip_face(m, f), ++majority;
  t = meshcvt::build_topology(m);
  CHECK(meshcvt::orient_consistently(m, t) == m.face_count() - majority);
  for (size_t f = 0; f < m.face_count(); ++f) {
    CAPTURE(f);
    CHECK(m.indices[3 * f] == orig[3 * f]);
    CHECK(m.indices[3 * f + 1] == orig[3 * f + 2]);
    CHECK(m.indices[3 * f + 2] == orig[3 * f + 1]);
  }
  CHECK(t.orientation_flips == 0);
}

TEST_CASE("orient_consistently: a Moebius strip is left as it is, the other parts are oriented") {
  const Mesh strip = moebius_strip();
  const Mesh sphere = meshcvt::test::icosphere(1);
  Mesh m = meshcvt::test::combine(strip, sphere, 10);
  const size_t flipped = shuffle_orientation(m, strip.face_count(), m.face_count(), 3);
  REQUIRE(flipped > 0);
  Topology t = meshcvt::build_topology(m);
  REQUIRE(t.nonorientable_components == 1);
  CHECK(meshcvt::orient_consistently(m, t) == flipped);
  CHECK(std::equal(strip.indices.begin(), strip.indices.end(), m.indices.begin()));
  CHECK(t.nonorientable_components == 1);
  CHECK(t.orientation_flips == meshcvt::build_topology(strip).orientation_flips);  // the strip's own
  Mesh sphere_part;
  sphere_part.positions = m.positions;
  sphere_part.indices.assign(m.indices.begin() + 3 * strip.face_count(), m.indices.end());
  CHECK(signed_volume6(sphere_part) > 0);
  // The strip alone: nothing can be done, nothing is touched.
  Mesh alone = strip;
  Topology ta = meshcvt::build_topology(alone);
  CHECK(meshcvt::orient_consistently(alone, ta) == 0);
  CHECK(alone.indices == strip.indices);
}

// ---- remove_collapsed_faces

TEST_CASE("remove_collapsed_faces: faces with a repeated corner go, the others keep their order and source") {
  Mesh m = meshcvt::test::icosphere(1);  // 80 faces
  const Mesh original = m;
  // Collapsed faces after faces 0, 10 and at the end: (a, a, b), (a, b, b), (c, c, c).
  const std::vector<std::array<uint32_t, 3>> extra = {{0, 0, 1}, {2, 3, 3}, {5, 5, 5}};
  Mesh with;
  with.positions = m.positions;
  std::vector<uint32_t> expected_index;  // per face of `with`
  for (uint32_t f = 0; f < 80; ++f) {
    with.indices.insert(with.indices.end(), &m.indices[3 * f], &m.indices[3 * f] + 3);
    expected_index.push_back(f);
    if (f == 0 || f == 10 || f == 79) {
      const auto& e = extra[f == 0 ? 0 : f == 10 ? 1 : 2];
      with.indices.insert(with.indices.end(), e.begin(), e.end());
      expected_index.push_back(meshcvt::kNone);
    }
  }
  std::vector<uint32_t> kept;
  Mesh cleaned = with;
  CHECK(meshcvt::remove_collapsed_faces(cleaned, &kept) == 3);
  CHECK(cleaned.indices == original.indices);
  CHECK(kept == expected_index);
  // source_polygon made explicit: the faces' indices in `with`
  REQUIRE(cleaned.source_polygon.size() == 80);
  for (uint32_t f = 0; f < 83; ++f)
    if (kept[f] != meshcvt::kNone) CHECK(cleaned.source_polygon[kept[f]] == f);
  CHECK(meshcvt::build_topology(cleaned).component_count == 1);
  CHECK(meshcvt::build_topology(with).component_count == 4);  // each collapsed face a component
  // A given source_polygon follows the faces; nothing to remove changes nothing.
  Mesh sourced = with;
  sourced.source_polygon.assign(83, 0);
  for (uint32_t f = 0; f < 83; ++f) sourced.source_polygon[f] = 1000 + f;
  meshcvt::remove_collapsed_faces(sourced);
  for (uint32_t f = 0; f < 83; ++f)
    if (kept[f] != meshcvt::kNone) CHECK(sourced.source_polygon[kept[f]] == 1000 + f);
  Mesh plain = original;
  CHECK(meshcvt::remove_collapsed_faces(plain, &kept) == 0);
  CHECK(plain.indices == original.indices);
  CHECK(plain.source_polygon.empty());
  CHECK(kept.size() == 80);
  CHECK(kept[79] == 79);
}

// ---- split_pinched_vertices

TEST_CASE("split_pinched_vertices: each fan of a pinched vertex but the first gets its own copy") {
  const uint32_t n = 8;
  const Mesh cone = fan(n, true);  // faces 0..n-1 around the apex above, n..2n-1 below
  Mesh m = cone;
  // A third fan at the apex: a flat ring of radius 2 (faces 2n..3n-1), and a collapsed face on it.
  const uint32_t base = uint32_t(m.vertex_count());
  for (uint32_t i = 0; i < n; ++i)
    m.positions.insert(m.positions.end(), {float(2 * std::cos(2 * M_PI * i / n)), float(2 * std::sin(2 * M_PI * i / n)), 0});
  for (uint32_t i = 0; i < n; ++i) m.indices.insert(m.indices.end(), {0, base + i, base + (i + 1) % n});
  m.indices.insert(m.indices.end(), {0, 0, base});
  Topology t = meshcvt::build_topology(m);
  REQUIRE(t.nonmanifold_vertices == 1);
  const meshcvt::MeshInfo before = meshcvt::mesh_info(m, t);
  const Mesh original = m;
  CHECK(meshcvt::split_pinched_vertices(m, t) == 2);
  REQUIRE(m.vertex_count() == original.vertex_count() + 2);
  for (uint32_t c : {uint32_t(original.vertex_count()), uint32_t(original.vertex_count() + 1)})
    for (int k = 0; k < 3; ++k) CHECK(m.positions[3 * c + k] == original.positions[k]);  // copies of the apex
  for (size_t f = 0; f < m.face_count(); ++f) {
    CAPTURE(f);
    // the fan with the lowest face keeps the apex; the others take the copies in their order
    const uint32_t apex = f < n ? 0 : f < 2 * n ? uint32_t(original.vertex_count()) : f < 3 * n ? uint32_t(original.vertex_count() + 1) : 0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t was = original.indices[3 * f + k];
      CHECK(m.indices[3 * f + k] == (was == 0 ? apex : was));
    }
  }
  CHECK(t.nonmanifold_vertices == 0);  // the topology was rebuilt
  check_against_brute_force(m, t);
  const meshcvt::MeshInfo after = meshcvt::mesh_info(m, t);
  CHECK(after.euler_characteristic == before.euler_characteristic + 2);
  CHECK(after.boundary_loops == before.boundary_loops);
  CHECK(after.components == before.components);
  // Nothing left to split.
  CHECK(meshcvt::split_pinched_vertices(m, t) == 0);
}

TEST_CASE("split_pinched_vertices: vertices of a non-manifold edge and manifold meshes are left alone") {
  // Three triangles on the edge (0, 1), a book of three pages: 0 and 1 have three fans each.
  Mesh book;
  book.positions = {0, 0, 0, 0, 0, 1, 1, 0, 0, -1, 0, 0, 0, 1, 0};
  book.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
  Topology t = meshcvt::build_topology(book);
  REQUIRE(t.nonmanifold_vertices == 2);
  REQUIRE(t.nonmanifold_edges == 1);
  const Mesh original = book;
  CHECK(meshcvt::split_pinched_vertices(book, t) == 0);
  CHECK(book.indices == original.indices);
  CHECK(book.positions == original.positions);
  Mesh sphere = meshcvt::test::icosphere(2);
  const Mesh sphere_before = sphere;
  Topology ts = meshcvt::build_topology(sphere);
  CHECK(meshcvt::split_pinched_vertices(sphere, ts) == 0);
  CHECK(sphere.indices == sphere_before.indices);
  CHECK(sphere.positions == sphere_before.positions);
}
