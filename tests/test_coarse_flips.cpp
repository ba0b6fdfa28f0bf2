// meshcvt tests: edge flips improving the coarse mesh (src/coarse_flips.cpp).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/quality.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using namespace meshcvt;

namespace {

// A rhombus in the plane z = 0 split along its long diagonal: two slivers. The short diagonal gives
// two fat triangles.
Mesh rhombus(float height, float fold = 0) {
  Mesh m;
  // u = (-1, 0), v = (1, 0), c = (0, h), d = (0, -h, fold)
  m.positions = {-1, 0, 0, 1, 0, 0, 0, height, 0, 0, -height, fold};
  m.indices = {0, 1, 2, 1, 0, 3};
  return m;
}

// The angle rule as flip_coarse_edges defines it: smallest corner angle by atan2, radians.
double reference_min_angle(const Mesh& m, uint32_t a, uint32_t b, uint32_t c) {
  auto p = [&](uint32_t v) { return std::vector<double>{m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]}; };
  auto angle = [](std::vector<double> o, std::vector<double> q, std::vector<double> r) {
    double u[3], w[3];
    for (int i = 0; i < 3; ++i) u[i] = q[i] - o[i], w[i] = r[i] - o[i];
    const double cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const double nu = std::sqrt((u[0] * u[0] + u[1] * u[1]) + u[2] * u[2]), nw = std::sqrt((w[0] * w[0] + w[1] * w[1]) + w[2] * w[2]);
    if (nu == 0 || nw == 0) return 0.0;
    return std::atan2(std::sqrt((cr[0] * cr[0] + cr[1] * cr[1]) + cr[2] * cr[2]), (u[0] * w[0] + u[1] * w[1]) + u[2] * w[2]);
  };
  return std::min({angle(p(a), p(b), p(c)), angle(p(b), p(c), p(a)), angle(p(c), p(a), p(b))});
}

}  // namespace

TEST_CASE("coarse flips: two slivers across the long diagonal become two fat triangles") {
  Mesh m = rhombus(0.2f);
  double before = triangle_quality(m).min_angle_deg;
  CHECK(flip_coarse_edges(m) == 1);
  CHECK(triangle_quality(m).min_angle_deg > before);
  // the new diagonal joins the two tips (vertices 2 and 3), orientation kept (normals still +z)
  for (int t = 0; t < 2; ++t) {
    const uint32_t* f = &m.indices[3 * t];
    bool has2 = false, has3 = false;
    for (int k = 0; k < 3; ++k) has2 |= f[k] == 2, has3 |= f[k] == 3;
    CHECK((has2 && has3));
    const float* a = &m.positions[3 * f[0]];
    const float* b = &m.positions[3 * f[1]];
    const float* c = &m.positions[3 * f[2]];
    float nz = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    CHECK(nz > 0);
  }
  // fat triangles stay: flipping again would make it worse
  CHECK(flip_coarse_edges(m) == 0);
}

TEST_CASE("coarse flips: a crease, a boundary and a valence-3 vertex are left alone") {
  Mesh creased = rhombus(0.2f, 0.5f);  // d lifted: the two triangles meet at a sharp angle
  Mesh copy = creased;
  CHECK(flip_coarse_edges(creased, 25) == 0);
  CHECK(creased.indices == copy.indices);
  CHECK(flip_coarse_edges(creased, 89) == 1);  // allowed when the crease limit is raised

  // A single triangle: only boundary edges.
  Mesh single;
  single.positions = {0, 0, 0, 1, 0, 0, 0, 0.01f, 0};
  single.indices = {0, 1, 2};
  CHECK(flip_coarse_edges(single) == 0);

  // A tetrahedron: every vertex has 3 edges; a flip would leave a vertex with 2 (and duplicate an edge).
  Mesh tet;
  tet.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  tet.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  Mesh tet_copy = tet;
  CHECK(flip_coarse_edges(tet, 180) == 0);
  CHECK(tet.indices == tet_copy.indices);
}

TEST_CASE("coarse flips: a sliver whose normal is noise flips where the flip sweeps almost nothing") {
  // c lies 0.01 above and 0.002 beside the edge u-v: a 0.6-degree cap whose normal points along
  // -y, 79 degrees from its neighbour's +z. The flip to c-d sweeps a tetrahedron 1% as thick as
  // the new edge is long: the surface stays where it is, and the cap becomes two fat triangles.
  Mesh m;
  m.positions = {-1, 0, 0, 1, 0, 0, 0, 0.002f, 0.01f, 0, -1, 0};
  m.indices = {0, 1, 2, 1, 0, 3};
  CHECK(triangle_quality(m).min_angle_deg < 1);
  Mesh kept = m;
  CHECK(flip_coarse_edges(kept, 25, 8, /*flat_slivers=*/false) == 0);  // as qem's coarsening asks
  CHECK(flip_coarse_edges(m, 25) == 1);
  CHECK(triangle_quality(m).min_angle_deg > 40);
  for (int t = 0; t < 2; ++t) {  // both new triangles still face +z, as the larger old one did
    const float* a = &m.positions[3 * m.indices[3 * t]];
    const float* b = &m.positions[3 * m.indices[3 * t + 1]];
    const float* c = &m.positions[3 * m.indices[3 * t + 2]];
    CHECK((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0);
  }
  // The same cap 0.3 above the edge: a real fold, 22% as thick as the new edge is long; left alone.
  Mesh folded;
  folded.positions = {-1, 0, 0, 1, 0, 0, 0, 0.002f, 0.3f, 0, -1, 0};
  folded.indices = {0, 1, 2, 1, 0, 3};
  CHECK(flip_coarse_edges(folded, 25) == 0);
}

TEST_CASE("coarse flips: topology, vertices and orientation are kept on closed and open meshes") {
  // A torus and an open grid with jittered vertices give many candidate flips.
  for (Mesh m : {test::torus(30, 12), test::grid(12, 9)}) {
    for (size_t i = 0; i < m.positions.size(); i += 3) {  // deterministic jitter in the tangent directions
      float j = float((i * 7919) % 13) / 13.0f - 0.5f;
      m.positions[i] += 0.08f * j;
      m.positions[i + 1] -= 0.06f * j;
    }
    MeshInfo before = mesh_info(m, build_topology(m));
    TriangleQuality q_before = triangle_quality(m);
    uint64_t flips = flip_coarse_edges(m, 40);
    CHECK(flips > 0);
    Topology t = build_topology(m);
    MeshInfo after = mesh_info(m, t);
    CHECK(after.euler_characteristic == before.euler_characteristic);
    CHECK(after.boundary_loops == before.boundary_loops);
    CHECK(after.nonmanifold_edges == 0);
    CHECK(after.nonmanifold_vertices == 0);
    CHECK(after.components == before.components);
    CHECK(triangle_quality(m).min_angle_deg >= q_before.min_angle_deg);
    // consistent orientation: every interior edge is used once in each direction
    std::vector<std::pair<uint32_t, uint32_t>> directed;
    for (size_t f = 0; f < m.face_count(); ++f)
      for (int k = 0; k < 3; ++k) directed.push_back({m.indices[3 * f + k], m.indices[3 * f + (k + 1) % 3]});
    std::sort(directed.begin(), directed.end());
    CHECK(std::adjacent_find(directed.begin(), directed.end()) == directed.end());
  }
}

TEST_CASE("coarse flips: near ties follow the atan2 rule, also where the fast sine test must defer") {
  // A unit square split along 0-2, vertex 3 nudged sideways: the other diagonal is better or worse
  // by about the nudge in radians. Nudges around 1e-9 (the rule's tolerance) and 1e-7 (the sine
  // test's margin, inside which atan2 decides) must give exactly what the rule says.
  int flipped = 0, kept = 0;
  for (double nudge : {0.0, 3e-10, -3e-10, 2e-9, -2e-9, 1e-8, -1e-8, 6e-8, -6e-8, 1.5e-7, -1.5e-7, 1e-6, -1e-6}) {
    Mesh m;
    m.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, float(nudge), 1, 0};
    m.indices = {0, 1, 2, 0, 2, 3};
    const double before = std::min(reference_min_angle(m, 0, 1, 2), reference_min_angle(m, 0, 2, 3));
    const double after = std::min(reference_min_angle(m, 0, 1, 3), reference_min_angle(m, 1, 2, 3));
    const uint64_t expected = after > before + 1e-9 ? 1 : 0;
    CAPTURE(nudge);
    CHECK(flip_coarse_edges(m) == expected);
    (expected ? flipped : kept) += 1;
  }
  CHECK(flipped >= 4);  // both outcomes occur on both sides of 1e-9
  CHECK(kept >= 4);
}
