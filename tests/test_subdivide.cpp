// Tests for midpoint subdivision: face counts, shared midpoints (watertight, same Euler
// characteristic), area, orientation, source_polygon, and subdivision_levels_for.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/mesh.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using meshcvt::Mesh;

namespace {

Mesh octahedron() {
  Mesh m;
  m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  m.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

// An open strip of 2 x 1 quads (a disk with one boundary loop).
Mesh strip() {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 2, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0};
  m.indices = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
  return m;
}

double area(const Mesh& m) { return meshcvt::mesh_info(m, meshcvt::build_topology(m)).total_area; }

// Normal (unnormalized) of face f, in double.
void normal(const Mesh& m, size_t f, double n[3]) {
  const float* a = &m.positions[3 * m.indices[3 * f]];
  const float* b = &m.positions[3 * m.indices[3 * f + 1]];
  const float* c = &m.positions[3 * m.indices[3 * f + 2]];
  double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  double w[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

}  // namespace

TEST_CASE("subdivide: closed mesh stays closed, keeps chi and area, faces x 4^k") {
  Mesh m = octahedron();
  meshcvt::MeshInfo before = meshcvt::mesh_info(m, meshcvt::build_topology(m));
  for (unsigned k = 1; k <= 3; ++k) {
    Mesh s = meshcvt::subdivide_midpoint(m, k);
    meshcvt::MeshInfo info = meshcvt::mesh_info(s, meshcvt::build_topology(s));
    CHECK(info.faces == m.face_count() << (2 * k));
    CHECK(info.boundary_edges == 0);
    CHECK(info.nonmanifold_edges == 0);
    CHECK(info.nonmanifold_vertices == 0);
    CHECK(info.orientation_flips == 0);
    CHECK(info.components == 1);
    CHECK(info.euler_characteristic == before.euler_characteristic);
    CHECK(info.genus == 0);
    // One new vertex per edge: V' = V + E.
    if (k == 1) CHECK(info.vertices == before.vertices + before.edges);
    CHECK(info.total_area == doctest::Approx(before.total_area).epsilon(1e-6));
  }
}

TEST_CASE("subdivide: open mesh keeps one boundary loop, boundary edges double") {
  Mesh m = strip();
  Mesh s = meshcvt::subdivide_midpoint(m, 2);
  meshcvt::Topology t = meshcvt::build_topology(s);
  CHECK(s.face_count() == 4 * 16);
  CHECK(t.boundary_edges == 6 * 4);
  CHECK(t.boundary_loops == 1);
  CHECK(meshcvt::mesh_info(s, t).genus == 0);
  CHECK(area(s) == doctest::Approx(2.0));
}

TEST_CASE("subdivide: children of face f are 4f..4f+3, oriented like f, at the midpoints") {
  Mesh m = octahedron();
  Mesh s = meshcvt::subdivide_midpoint(m, 1);
  REQUIRE(s.face_count() == 4 * m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    const uint32_t* p = &m.indices[3 * f];
    const uint32_t* c = &s.indices[12 * f];
    // Original vertices keep their ids and sit in the corner children.
    CHECK(c[0] == p[0]);
    CHECK(c[4] == p[1]);
    CHECK(c[8] == p[2]);
    // The middle child's corners are the midpoints of ab, bc, ca.
    for (int e = 0; e < 3; ++e) {
      uint32_t mid = c[9 + e], a = p[e], b = p[(e + 1) % 3];
      for (int x = 0; x < 3; ++x)
        CHECK(s.positions[3 * mid + x] == 0.5f * m.positions[3 * a + x] + 0.5f * m.positions[3 * b + x]);
    }
    double n0[3];
    normal(m, f, n0);
    for (size_t child = 4 * f; child < 4 * f + 4; ++child) {
      double n1[3];
      normal(s, child, n1);
      CHECK(n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] > 0);
      CHECK(s.source_polygon[child] == f);
    }
  }
}

TEST_CASE("subdivide: source_polygon follows the input's, over several levels") {
  Mesh m = strip();
  m.source_polygon = {7, 7, 9, 9};  // two quads, each cut in two triangles
  Mesh s = meshcvt::subdivide_midpoint(m, 3);
  REQUIRE(s.source_polygon.size() == s.face_count());
  for (size_t i = 0; i < s.face_count(); ++i) CHECK(s.source_polygon[i] == m.source_polygon[i / 64]);
}

TEST_CASE("subdivide: level 0 is a copy, bad input and oversize results throw") {
  Mesh m = octahedron();
  Mesh s = meshcvt::subdivide_midpoint(m, 0);
  CHECK(s.indices == m.indices);
  CHECK(s.positions == m.positions);
  CHECK_THROWS_AS(meshcvt::subdivide_midpoint(m, 15), meshcvt::OptionError);  // 8 * 4^15 > 1.4e9
  Mesh bad = m;
  bad.indices[0] = 99;
  CHECK_THROWS_AS(meshcvt::subdivide_midpoint(bad, 1), meshcvt::OptionError);
}

TEST_CASE("subdivide: non-manifold edge and collapsed face survive") {
  Mesh m;
  m.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1};
  m.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4, 2, 2, 4};  // a fin on edge {0,1}, and a collapsed face
  Mesh s = meshcvt::subdivide_midpoint(m, 1);
  meshcvt::Topology t = meshcvt::build_topology(s);
  CHECK(s.face_count() == 16);
  CHECK(t.nonmanifold_edges == 2);  // the fin edge, split in two halves
  // The collapsed face's (2, 2) edge has no midpoint of its own: no new vertex at vertex 2.
  uint64_t at_vertex2 = 0;
  for (size_t v = 5; v < s.vertex_count(); ++v)
    at_vertex2 += s.positions[3 * v] == 0 && s.positions[3 * v + 1] == 1 && s.positions[3 * v + 2] == 0;
  CHECK(at_vertex2 == 0);
}

TEST_CASE("subdivide: large enough for the threaded path, same as the sum of its parts") {
  // The last level, from 131072 faces, runs on up to four threads (one per 32768 faces, as the
  // cores allow); check the result against invariants.
  Mesh m = octahedron();
  Mesh s = meshcvt::subdivide_midpoint(m, 8);
  meshcvt::MeshInfo info = meshcvt::mesh_info(s, meshcvt::build_topology(s));
  CHECK(info.faces == 8u << 16);
  CHECK(info.vertices == 2 + info.faces / 2);  // closed genus 0: V = F / 2 + 2
  CHECK(info.boundary_edges == 0);
  CHECK(info.orientation_flips == 0);
  CHECK(info.duplicate_faces == 0);
  CHECK(info.genus == 0);
}

TEST_CASE("subdivide: every thread count gives the same mesh") {
  // A torus with a fin on one edge and a collapsed face, faces in scrambled order: each level's
  // edges are numbered per range of vertices, then put together.
  Mesh m = meshcvt::test::torus(20, 9);
  const uint32_t fin = uint32_t(m.vertex_count());
  meshcvt::test::add_vertex(m, 0.3, 0.2, 0.9);
  m.indices.insert(m.indices.end(), {m.indices[0], m.indices[1], fin, m.indices[5], m.indices[5], m.indices[7]});
  const size_t nf = m.face_count();
  for (size_t f = 0; f + 1 < nf; f += 3)
    for (int c = 0; c < 3; ++c) std::swap(m.indices[3 * f + c], m.indices[3 * (nf - 1 - f) + c]);
  const Mesh one = meshcvt::subdivide_midpoint(m, 2, 1);
  for (unsigned threads : {2u, 3u, 7u, 16u, 100u}) {
    CAPTURE(threads);
    const Mesh s = meshcvt::subdivide_midpoint(m, 2, threads);
    CHECK(s.indices == one.indices);
    CHECK(s.positions == one.positions);
    CHECK(s.source_polygon == one.source_polygon);
  }
}

TEST_CASE("subdivision_levels_for: smallest k with faces * 4^k >= clusters * min") {
  CHECK(meshcvt::subdivision_levels_for(1000, 100, 10) == 0);
  CHECK(meshcvt::subdivision_levels_for(999, 100, 10) == 1);
  CHECK(meshcvt::subdivision_levels_for(250, 100, 10) == 1);   // 1000 >= 1000 exactly
  CHECK(meshcvt::subdivision_levels_for(249, 100, 10) == 2);
  CHECK(meshcvt::subdivision_levels_for(100, 100, 10) == 2);   // 400 < 1000 <= 1600
  CHECK(meshcvt::subdivision_levels_for(5558, 100000) == 4);   // 5558 * 4^3 = 356k < 1M <= 5558 * 4^4
  CHECK(meshcvt::subdivision_levels_for(10, 3, 0) == 0);
  CHECK(meshcvt::subdivision_levels_for(0, 0, 10) == 0);
  CHECK_THROWS_AS(meshcvt::subdivision_levels_for(0, 5, 10), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::subdivision_levels_for(10, 5, -1), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::subdivision_levels_for(10, 5, NAN), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::subdivision_levels_for(10, 5, INFINITY), meshcvt::OptionError);
}

TEST_CASE("subdivide_faces: only the selected faces, children in their place, parents, no T-junction") {
  // The octahedron and, apart from it, a lone triangle (vertices 6, 7, 8).
  Mesh m = octahedron();
  const float lone[] = {3, 0, 0, 4, 0, 0, 3, 1, 0};
  m.positions.insert(m.positions.end(), lone, lone + 9);
  m.indices.insert(m.indices.end(), {6, 7, 8});
  std::vector<uint8_t> selected(m.face_count(), 0);
  selected[8] = 1;
  for (unsigned levels : {1u, 2u}) {
    const meshcvt::SubdividedFaces s = meshcvt::subdivide_faces(m, selected, levels);
    const size_t children = size_t(1) << (2 * levels);
    REQUIRE(s.mesh.face_count() == 8 + children);
    REQUIRE(s.parent.size() == s.mesh.face_count());
    // The octahedron's faces and vertices are as they were; the lone triangle's children follow.
    for (size_t f = 0; f < 8; ++f) {
      CHECK(s.parent[f] == f);
      for (int k = 0; k < 3; ++k) CHECK(s.mesh.indices[3 * f + k] == m.indices[3 * f + k]);
    }
    for (size_t f = 8; f < s.mesh.face_count(); ++f) CHECK(s.parent[f] == 8);
    CHECK(std::equal(m.positions.begin(), m.positions.end(), s.mesh.positions.begin()));
    // 3 + 3 midpoints at one level, 15 vertices in all at two.
    CHECK(s.mesh.vertex_count() == 9 + (levels == 1 ? 3 : 12));
    CHECK(s.mesh.source_polygon == s.parent);
    // Area, orientation and the Euler characteristic are kept; the two parts stay apart.
    CHECK(area(s.mesh) == doctest::Approx(area(m)));
    const meshcvt::Topology t = meshcvt::build_topology(s.mesh);
    const meshcvt::MeshInfo before = meshcvt::mesh_info(m, meshcvt::build_topology(m)),
                            after = meshcvt::mesh_info(s.mesh, t);
    CHECK(after.euler_characteristic == before.euler_characteristic);
    CHECK(after.boundary_loops == 1);
    CHECK(after.components == 2);
    CHECK(t.orientation_flips == 0);
    for (size_t f = 8; f < s.mesh.face_count(); ++f) {
      double n[3];
      normal(s.mesh, f, n);
      CHECK(n[2] > 0);
    }
  }
  // Nothing selected: a copy.
  const meshcvt::SubdividedFaces none = meshcvt::subdivide_faces(m, std::vector<uint8_t>(m.face_count(), 0), 1);
  CHECK(none.mesh.indices == m.indices);
  CHECK(none.mesh.positions == m.positions);

  // A selected face sharing an edge with one that is not would leave a T-junction.
  std::vector<uint8_t> one(8 + 1, 0);
  one[0] = 1;
  CHECK_THROWS_AS(meshcvt::subdivide_faces(m, one, 1), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::subdivide_faces(m, std::vector<uint8_t>(3, 1), 1), meshcvt::OptionError);
  Mesh bad = m;
  bad.indices[0] = 99;
  CHECK_THROWS_AS(meshcvt::subdivide_faces(bad, selected, 1), meshcvt::OptionError);
}

TEST_CASE("subdivide_faces: split_neighbours splits the faces at the selection's edges, no T-junction") {
  // The octahedron (convex, around the origin: every face faces away from it), and stretched (so
  // that a face between two split edges is cut along either diagonal: the regular one ties). Its
  // face 0 is (0, 2, 4), with neighbours 4 across (0, 2), 1 across (2, 4), 3 across (4, 0).
  for (const float stretch : {1.0f, 3.0f}) {
  Mesh m = octahedron();
  m.positions[0] *= stretch, m.positions[3] *= stretch, m.positions[7] /= stretch, m.positions[10] /= stretch;
  struct Case {
    std::vector<uint8_t> selected;
    size_t faces;                 // faces out
    std::vector<size_t> pieces;   // per input face: its faces out
  };
  const Case cases[] = {
      // face 0 alone: its three neighbours each get one split edge (two pieces each).
      {{1, 0, 0, 0, 0, 0, 0, 0}, 14, {4, 2, 1, 2, 2, 1, 1, 1}},
      // faces 0 and 2: faces 1 and 3 lie between them (two split edges: three pieces), 4 and 6
      // get one split edge, 5 and 7 none.
      {{1, 0, 1, 0, 0, 0, 0, 0}, 20, {4, 3, 4, 3, 2, 1, 2, 1}},
      // face 0's three neighbours: face 0 has three split edges (four pieces, as if selected);
      // 2, 5 and 7 lie between two of them, 6 touches none.
      {{0, 1, 0, 1, 1, 0, 0, 0}, 26, {4, 4, 3, 4, 4, 3, 1, 3}},
  };
  for (const Case& c : cases) {
    CAPTURE(stretch);
    CAPTURE(c.faces);
    const meshcvt::SubdividedFaces s = meshcvt::subdivide_faces(m, c.selected, 1, /*split_neighbours=*/true);
    REQUIRE(s.mesh.face_count() == c.faces);
    REQUIRE(s.parent.size() == c.faces);
    std::vector<size_t> pieces(m.face_count(), 0);
    for (size_t f = 0; f < s.parent.size(); ++f) {
      ++pieces[s.parent[f]];
      if (f > 0) CHECK(s.parent[f] >= s.parent[f - 1]);  // in input order
    }
    CHECK(pieces == c.pieces);
    // A face between two split edges is cut along the shorter diagonal of what is left when the
    // corner between them is cut off: the edge its pieces share from an input vertex to a
    // midpoint, against the one from the other input vertex to the other midpoint.
    const uint32_t nv = uint32_t(m.vertex_count());
    auto d2 = [&](uint32_t p, uint32_t q) {
      double sum = 0;
      for (int k = 0; k < 3; ++k) {
        const double d = double(s.mesh.positions[3 * p + k]) - s.mesh.positions[3 * q + k];
        sum += d * d;
      }
      return sum;
    };
    for (uint32_t g = 0; g < m.face_count(); ++g) {
      if (pieces[g] != 3) continue;
      std::vector<uint32_t> corners, mids;
      std::vector<std::pair<uint32_t, uint32_t>> edges;
      for (size_t f = 0; f < s.mesh.face_count(); ++f) {
        if (s.parent[f] != g) continue;
        for (int k = 0; k < 3; ++k) {
          const uint32_t v = s.mesh.indices[3 * f + k], w = s.mesh.indices[3 * f + (k + 1) % 3];
          edges.push_back({std::min(v, w), std::max(v, w)});
          (v < nv ? corners : mids).push_back(v);
        }
      }
      std::sort(edges.begin(), edges.end());
      std::sort(mids.begin(), mids.end());
      mids.erase(std::unique(mids.begin(), mids.end()), mids.end());
      REQUIRE(mids.size() == 2);
      // The shared edges: the two midpoints' and the diagonal (an input vertex and a midpoint).
      std::pair<uint32_t, uint32_t> diagonal{meshcvt::kNone, meshcvt::kNone};
      for (size_t i = 0; i + 1 < edges.size(); ++i)
        if (edges[i] == edges[i + 1] && edges[i].first < nv) diagonal = edges[i];
      REQUIRE(diagonal.first != meshcvt::kNone);
      // The corner cut off: the input vertex of a piece with both midpoints that is not on the
      // diagonal (the piece of the diagonal's input vertex may have both midpoints too).
      uint32_t cut = meshcvt::kNone;
      for (size_t f = 0; f < s.mesh.face_count(); ++f) {
        if (s.parent[f] != g) continue;
        const uint32_t* t = &s.mesh.indices[3 * f];
        const uint32_t input_vertex = *std::find_if(t, t + 3, [&](uint32_t v) { return v < nv; });
        if (std::count_if(t, t + 3, [&](uint32_t v) { return v >= nv; }) == 2 && input_vertex != diagonal.first)
          cut = input_vertex;
      }
      REQUIRE(cut != meshcvt::kNone);
      const uint32_t* t = &m.indices[3 * g];
      const uint32_t other_corner = t[0] != cut && t[0] != diagonal.first ? t[0] : t[1] != cut && t[1] != diagonal.first ? t[1] : t[2];
      const uint32_t other_mid = mids[0] == diagonal.second ? mids[1] : mids[0];
      CHECK(d2(diagonal.first, diagonal.second) <= d2(other_corner, other_mid));
    }
    CHECK(s.mesh.source_polygon == s.parent);
    CHECK(std::equal(m.positions.begin(), m.positions.end(), s.mesh.positions.begin()));
    // Still a closed, consistently oriented sphere of the same area: a T-junction would leave
    // boundary edges.
    const meshcvt::Topology t = meshcvt::build_topology(s.mesh);
    const meshcvt::MeshInfo info = meshcvt::mesh_info(s.mesh, t);
    CHECK(info.boundary_edges == 0);
    CHECK(info.nonmanifold_edges == 0);
    CHECK(info.euler_characteristic == 2);
    CHECK(info.components == 1);
    CHECK(t.orientation_flips == 0);
    CHECK(info.total_area == doctest::Approx(area(m)));
    for (size_t f = 0; f < s.mesh.face_count(); ++f) {
      double n[3], centroid[3] = {0, 0, 0};
      normal(s.mesh, f, n);
      for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) centroid[d] += s.mesh.positions[3 * s.mesh.indices[3 * f + k] + d] / 3.0;
      CHECK(n[0] * centroid[0] + n[1] * centroid[1] + n[2] * centroid[2] > 0);  // outward, not flat
      // Each piece lies in its input face: its corners are on that face's plane.
      double pn[3];
      normal(m, s.parent[f], pn);
      const float* a = &m.positions[3 * m.indices[3 * s.parent[f]]];
      for (int k = 0; k < 3; ++k) {
        const float* p = &s.mesh.positions[3 * s.mesh.indices[3 * f + k]];
        CHECK(pn[0] * (p[0] - a[0]) + pn[1] * (p[1] - a[1]) + pn[2] * (p[2] - a[2]) == doctest::Approx(0));
      }
    }
  }
  }
  // Nothing to split at level 0; one level at a time.
  const Mesh m = octahedron();
  const std::vector<uint8_t> first{1, 0, 0, 0, 0, 0, 0, 0};
  CHECK(meshcvt::subdivide_faces(m, first, 0, true).mesh.indices == m.indices);
  CHECK_THROWS_AS(meshcvt::subdivide_faces(m, first, 2, true), meshcvt::OptionError);
}
