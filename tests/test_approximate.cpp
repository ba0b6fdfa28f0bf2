// meshcvt tests: anisotropic shape approximation with the L2,1 metric (Fan et al. 6.2, VSA
// meshing) — exact results on polyhedra (cube, chamfered box), sharp edges of a cylinder, closed and
// manifold output, no flipped triangles, every fix on purpose-built partitions, the error-driven
// partition, the polygon writer and option checking.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <unistd.h>
#include <vector>

#include "meshcvt/approximate.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using namespace meshcvt;

namespace {

// ---- procedural meshes, vertices welded by position

struct Builder {
  Mesh mesh;
  std::map<std::array<long long, 3>, uint32_t> index;
  uint32_t vertex(double x, double y, double z) {
    std::array<long long, 3> key{std::llround(x * 1e6), std::llround(y * 1e6), std::llround(z * 1e6)};
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    uint32_t id = test::add_vertex(mesh, x, y, z);
    index.emplace(key, id);
    return id;
  }
  using P = std::array<double, 3>;
  uint32_t vertex(P p) { return vertex(p[0], p[1], p[2]); }
  // Grid of nu x nv quads on the parallelogram o + s u + t v, facing u x v.
  void grid(P o, P u, P v, uint32_t nu, uint32_t nv) {
    auto at = [&](uint32_t i, uint32_t j) {
      double s = double(i) / nu, t = double(j) / nv;
      return vertex(o[0] + s * u[0] + t * v[0], o[1] + s * u[1] + t * v[1], o[2] + s * u[2] + t * v[2]);
    };
    for (uint32_t j = 0; j < nv; ++j)
      for (uint32_t i = 0; i < nu; ++i) {
        uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
        test::add_triangle(mesh, a, b, c);
        test::add_triangle(mesh, a, c, d);
      }
  }
  // Triangle c, a, b subdivided k times along each edge, facing (a - c) x (b - c).
  void fan_triangle(P c, P a, P b, uint32_t k) {
    auto at = [&](uint32_t i, uint32_t j) {
      double s = double(i) / k, t = double(j) / k;
      return vertex(c[0] + s * (a[0] - c[0]) + t * (b[0] - c[0]), c[1] + s * (a[1] - c[1]) + t * (b[1] - c[1]),
                    c[2] + s * (a[2] - c[2]) + t * (b[2] - c[2]));
    };
    for (uint32_t i = 0; i < k; ++i)
      for (uint32_t j = 0; i + j < k; ++j) {
        test::add_triangle(mesh, at(i, j), at(i + 1, j), at(i, j + 1));
        if (i + j + 1 < k) test::add_triangle(mesh, at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
      }
  }
};

// Cube [-1,1]^3, each face a k x k grid of quads.
Mesh cube(uint32_t k) {
  Builder b;
  b.grid({1, -1, -1}, {0, 2, 0}, {0, 0, 2}, k, k);
  b.grid({-1, -1, -1}, {0, 0, 2}, {0, 2, 0}, k, k);
  b.grid({-1, 1, -1}, {0, 0, 2}, {2, 0, 0}, k, k);
  b.grid({-1, -1, -1}, {2, 0, 0}, {0, 0, 2}, k, k);
  b.grid({-1, -1, 1}, {2, 0, 0}, {0, 2, 0}, k, k);
  b.grid({-1, -1, -1}, {0, 2, 0}, {2, 0, 0}, k, k);
  return b.mesh;
}

// Closed prism over a convex polygon (counter-clockwise in xy), z in [0, h]: sides as grids of
// k x kh quads, caps as fans from the centroid with each sector subdivided k times.
Mesh prism(const std::vector<std::array<double, 2>>& polygon, double h, uint32_t k, uint32_t kh) {
  Builder b;
  size_t n = polygon.size();
  double cx = 0, cy = 0;
  for (auto& p : polygon) cx += p[0] / n, cy += p[1] / n;
  for (size_t i = 0; i < n; ++i) {
    auto p = polygon[i], q = polygon[(i + 1) % n];
    b.grid({p[0], p[1], 0}, {q[0] - p[0], q[1] - p[1], 0}, {0, 0, h}, k, kh);
    b.fan_triangle({cx, cy, h}, {p[0], p[1], h}, {q[0], q[1], h}, k);
    b.fan_triangle({cx, cy, 0}, {q[0], q[1], 0}, {p[0], p[1], 0}, k);
  }
  return b.mesh;
}

// A box 2 x 1 x 1 with one long edge chamfered: 7 planar faces, 10 corners.
const std::vector<std::array<double, 2>> kChamferedSection = {{0, 0}, {2, 0}, {2, 0.7}, {1.7, 1}, {0, 1}};

std::vector<std::array<double, 2>> regular_polygon(uint32_t n, double r) {
  std::vector<std::array<double, 2>> p;
  for (uint32_t i = 0; i < n; ++i) {
    double a = 2 * 3.14159265358979323846 * i / n;
    p.push_back({r * std::cos(a), r * std::sin(a)});
  }
  return p;
}

// ---- checks

std::array<double, 3> triangle_normal(const Mesh& m, size_t t) {
  const float* a = &m.positions[3 * m.indices[3 * t]];
  const float* b = &m.positions[3 * m.indices[3 * t + 1]];
  const float* c = &m.positions[3 * m.indices[3 * t + 2]];
  double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  return {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
}

std::array<double, 3> unit_normal(const Mesh& m, size_t t) {
  auto n = triangle_normal(m, t);
  double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  return {n[0] / l, n[1] / l, n[2] / l};
}

// Output triangles facing away from (or perpendicular to) their region's proxy normal.
size_t flipped_triangles(const ShapeApproximation& s) {
  size_t flipped = 0;
  for (size_t t = 0; t < s.mesh.face_count(); ++t) {
    auto n = triangle_normal(s.mesh, t);
    const float* p = &s.proxy_normals[3 * s.triangle_regions[t]];
    if (!(n[0] * p[0] + n[1] * p[1] + n[2] * p[2] > 0)) ++flipped;
  }
  return flipped;
}

// The output is a closed, oriented 2-manifold, as measured by the topology module.
void check_closed_manifold(const ShapeApproximation& s) {
  Topology t = build_topology(s.mesh);
  MeshInfo info = mesh_info(s.mesh, t);
  CHECK(info.faces > 0);
  CHECK(info.boundary_edges == 0);
  CHECK(info.nonmanifold_edges == 0);
  CHECK(info.nonmanifold_vertices == 0);
  CHECK(info.orientation_flips == 0);
  CHECK(info.degenerate_faces == 0);
  CHECK(s.stats.boundary_edges == 0);
  CHECK(s.stats.nonmanifold_edges == 0);
}

// Every polygon is a cycle of output vertices whose edges each appear in two polygons (closed input).
void check_polygons(const ShapeApproximation& s) {
  REQUIRE(s.polygon_offsets.size() == s.regions + 1);
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  size_t triangles = 0;
  for (uint32_t r = 0; r < s.regions; ++r) {
    uint32_t b = s.polygon_offsets[r], e = s.polygon_offsets[r + 1];
    if (b == e) continue;
    CHECK(e - b >= 3);
    triangles += e - b - 2;
    for (uint32_t i = b; i < e; ++i) directed[{s.polygon_vertices[i], s.polygon_vertices[i + 1 < e ? i + 1 : b]}]++;
  }
  CHECK(triangles == s.mesh.face_count());  // each n-gon gives n - 2 triangles
  for (auto& [edge, count] : directed) {
    CHECK(count == 1);
    CHECK(directed.count({edge.second, edge.first}) == 1);
  }
}

bool has_fix(const ShapeApproximation& s, MeshingFix::Kind kind) {
  return std::any_of(s.fixes.begin(), s.fixes.end(), [&](const MeshingFix& f) { return f.kind == kind; });
}

ApproximateOptions with_proxies(uint32_t n) {
  ApproximateOptions o;
  o.proxies = n;
  o.device = "cpu";
  return o;
}

std::string temp_path(const std::string& name) {
  return "/tmp/meshcvt_test_approximate_" + std::to_string(getpid()) + "_" + name;
}

}  // namespace

TEST_CASE("approximate: subdivided cube, 6 proxies -> 8 corners, 6 quads, 12 triangles, zero error") {
  Mesh m = cube(4);
  REQUIRE(m.face_count() == 6 * 16 * 2);
  ShapeApproximation s = approximate_shape(m, with_proxies(6));
  CHECK(s.regions == 6);
  CHECK(s.relative_error < 1e-12);
  CHECK(s.distortion < 1e-10);
  CHECK(s.mesh.vertex_count() == 8);
  CHECK(s.mesh.face_count() == 12);
  for (uint32_t r = 0; r < 6; ++r) CHECK(s.polygon_offsets[r + 1] - s.polygon_offsets[r] == 4);
  for (float c : s.mesh.positions) CHECK(std::abs(std::abs(c) - 1.0f) < 1e-6f);  // the cube's corners
  std::set<std::array<int, 3>> corners;
  for (size_t v = 0; v < 8; ++v)
    corners.insert({int(std::lround(s.mesh.positions[3 * v])), int(std::lround(s.mesh.positions[3 * v + 1])),
                    int(std::lround(s.mesh.positions[3 * v + 2]))});
  CHECK(corners.size() == 8);
  CHECK(flipped_triangles(s) == 0);
  check_closed_manifold(s);
  check_polygons(s);
  CHECK_FALSE(has_fix(s, MeshingFix::split_region));
  CHECK_FALSE(has_fix(s, MeshingFix::flipped_triangles));
  // The output encloses the cube's volume exactly (divergence theorem over the triangles).
  double volume = 0;
  for (size_t t = 0; t < s.mesh.face_count(); ++t) {
    const float* a = &s.mesh.positions[3 * s.mesh.indices[3 * t]];
    auto n = triangle_normal(s.mesh, t);
    volume += (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0;
  }
  CHECK(volume == doctest::Approx(8.0).epsilon(1e-6));
}

TEST_CASE("approximate, cluster (l21): a cube whose faces are oriented at random is oriented first") {
  // Every other triangle (by a fixed pseudo-random sequence) listed the other way round, as in
  // libcgal-demo's *-shuffled meshes: half the normals point inward, and without orienting the
  // mesh first the L2,1 partition splits the cube's sides.
  const Mesh original = cube(4);
  Mesh m = original;
  const size_t flipped = test::shuffle_orientation(m, 0, m.face_count(), 5);
  REQUIRE(flipped > 0);
  const ShapeApproximation ref = approximate_shape(original, with_proxies(6));
  const ShapeApproximation s = approximate_shape(m, with_proxies(6));
  CHECK(ref.reoriented_faces == 0);
  CHECK(s.reoriented_faces == flipped);
  CHECK(s.labels == ref.labels);
  CHECK(s.distortion == ref.distortion);
  CHECK(s.mesh.indices == ref.mesh.indices);
  CHECK(s.mesh.positions == ref.mesh.positions);
  check_closed_manifold(s);

  // cluster() with the L2,1 metric alone takes the normals as if the faces were oriented, and
  // leaves the mesh as it is: the same labels and energies as on the consistent cube.
  ClusterOptions co;
  co.clusters = 6;
  co.metric = Metric::l21;
  co.device = "cpu";
  const Mesh before = m;
  const Clustering c = cluster(m, co), c_ref = cluster(original, co);
  CHECK(m.indices == before.indices);
  CHECK(c.labels == c_ref.labels);
  REQUIRE(c.history.size() == c_ref.history.size());
  for (size_t i = 0; i < c.history.size(); ++i) CHECK(c.history[i].energy == c_ref.history[i].energy);
}

TEST_CASE("approximate: faces with a repeated corner are left out and take a neighbour's region") {
  // Welded slivers: (a, a, b) faces, no area, no edges. Each was a component of its own, and a
  // region of its own (or the partition refused: more components than proxies).
  const Mesh original = cube(4);  // 192 faces
  const Mesh m = test::with_collapsed_faces(original, 10, 19);
  const ShapeApproximation ref = approximate_shape(original, with_proxies(6));
  const ShapeApproximation s = approximate_shape(m, with_proxies(6));
  CHECK(s.collapsed_faces == 10);
  CHECK(s.regions == 6);
  CHECK(s.mesh.indices == ref.mesh.indices);
  CHECK(s.mesh.positions == ref.mesh.positions);
  CHECK(s.distortion == ref.distortion);
  // The cube's labels, and on each collapsed face those of the lowest face at its lowest corner.
  CHECK(s.labels == test::labels_at_lowest_corners(m, ref.labels));
  check_closed_manifold(s);
}

TEST_CASE("approximate: chamfered box keeps its 10 sharp corners with 7 proxies") {
  Mesh m = prism(kChamferedSection, 1.0, 4, 4);
  ShapeApproximation s = approximate_shape(m, with_proxies(7));
  CHECK(s.regions == 7);
  CHECK(s.relative_error < 1e-10);
  CHECK(s.mesh.vertex_count() == 10);
  CHECK(s.mesh.face_count() == 2 * 3 + 5 * 2);  // two pentagons and five quads
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {
    double x = s.mesh.positions[3 * v], y = s.mesh.positions[3 * v + 1], z = s.mesh.positions[3 * v + 2];
    double best = 1e9;
    for (auto& p : kChamferedSection)
      for (double h : {0.0, 1.0}) best = std::min(best, std::hypot(x - p[0], y - p[1], z - h));
    CHECK(best < 1e-5);
  }
  CHECK(flipped_triangles(s) == 0);
  check_closed_manifold(s);
  check_polygons(s);
}

TEST_CASE("approximate: closed cylinder keeps its rims; output vertices lie on the sharp edges") {
  const double height = 2.0;
  Mesh m = prism(regular_polygon(24, 1.0), height, 3, 6);
  ShapeApproximation s = approximate_shape(m, with_proxies(8));
  CHECK(s.regions == 8);
  CHECK(flipped_triangles(s) == 0);
  check_closed_manifold(s);
  check_polygons(s);
  // The caps are regions of their own: every output vertex is on a rim (z = 0 or z = h), near the
  // circle of radius 1 (anchors between two side regions move out towards the intersection of
  // their planes, anchors inside a side region's rim in towards its plane).
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {
    double x = s.mesh.positions[3 * v], y = s.mesh.positions[3 * v + 1], z = s.mesh.positions[3 * v + 2];
    CHECK((std::abs(z) < 1e-5 || std::abs(z - height) < 1e-5));
    double r = std::hypot(x, y);
    CHECK(r < 1.1);
    CHECK(r > 0.9);
  }
  // Both rims carry vertices: at least three each.
  size_t top = 0;
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) top += s.mesh.positions[3 * v + 2] > 1;
  CHECK(top >= 3);
  CHECK(s.mesh.vertex_count() - top >= 3);
}

TEST_CASE("approximate: L2,1 distortion never increases within round 0 and matches the report") {
  Mesh m = test::torus(40, 20);
  ShapeApproximation s = approximate_shape(m, with_proxies(24));
  const auto& h = s.clustering.history;
  REQUIRE(h.size() >= 2);
  size_t round0 = 0;
  for (size_t i = 1; i < h.size() && h[i].round == 0; ++i, ++round0)
    CHECK(h[i].energy <= h[i - 1].energy * (1 + 1e-9));
  CHECK(round0 >= 1);
  CHECK(h.back().energy < h.front().energy);
  // The engine's energy (bounding box scaled to unit size) and ours (input units) agree per area,
  // when meshing did not split regions.
  if (!has_fix(s, MeshingFix::split_region) && h.back().round == 0) {
    double extent = 2 * (1 + 0.35);  // the torus' largest bounding-box side
    double area_normalized = s.total_area / (extent * extent);
    CHECK(h.back().energy / area_normalized == doctest::Approx(s.relative_error).epsilon(1e-3));
  }
  CHECK(s.relative_error == doctest::Approx(s.distortion / s.total_area));
  CHECK(s.relative_error == doctest::Approx(l21_distortion(m, s.labels, s.regions) / s.total_area));
  CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
  check_closed_manifold(s);
}

TEST_CASE("approximate: --max-error terminates and meets the bound") {
  Mesh m = test::torus(32, 16);
  for (double bound : {0.2, 0.05}) {
    ApproximateOptions o;
    o.max_error = bound;
    o.device = "cpu";
    ShapeApproximation s = approximate_shape(m, o);
    CAPTURE(bound);
    CHECK(s.relative_error <= bound);
    REQUIRE(!s.rounds.empty());
    CHECK(s.rounds.back().relative_error <= bound);
    for (size_t i = 1; i < s.rounds.size(); ++i) {
      CHECK(s.rounds[i].proxies > s.rounds[i - 1].proxies);       // every round adds proxies
      CHECK(s.rounds[i].proxies <= 2 * s.rounds[i - 1].proxies);  // at most doubling
      CHECK(s.rounds[i - 1].relative_error > bound);              // and only while above the bound
    }
    CHECK(s.partition_proxies == s.rounds.back().proxies);
    check_closed_manifold(s);
  }
  // Bound 0 on a curved mesh: ends at one region per face, which is the input itself.
  Mesh ico = test::icosphere(1);
  ApproximateOptions o;
  o.max_error = 0;
  o.device = "cpu";
  ShapeApproximation s = approximate_shape(ico, o);
  CHECK(s.relative_error < 1e-20);
  CHECK(s.regions == ico.face_count());
  CHECK(s.mesh.face_count() == ico.face_count());
  CHECK(s.mesh.vertex_count() == ico.vertex_count());
  check_closed_manifold(s);
  // A loose bound needs no extra round.
  o.max_error = 4;
  s = approximate_shape(ico, o);
  CHECK(s.rounds.size() == 1);
}

TEST_CASE("approximate: several components are all kept") {
  Mesh m = test::combine(cube(3), test::icosphere(2), 4.0);
  ShapeApproximation s = approximate_shape(m, with_proxies(20));
  Topology t = build_topology(s.mesh);
  CHECK(t.component_count == 2);
  bool left = false, right = false;
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) (s.mesh.positions[3 * v] < 2 ? left : right) = true;
  CHECK(left);
  CHECK(right);
  check_closed_manifold(s);
  CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
}

TEST_CASE("approximate: the result does not depend on the thread count") {
  // The small torus is colored by one thread; the large one (~7200 interior vertices) splits the
  // coloring of its regions over the workers.
  for (Mesh m : {test::torus(30, 15), test::torus(120, 60)}) {
    ApproximateOptions a = with_proxies(12), b = with_proxies(12), c = with_proxies(12);
    a.threads = 1;
    b.threads = 2;
    c.threads = 3;
    ShapeApproximation x = approximate_shape(m, a), y = approximate_shape(m, b), z = approximate_shape(m, c);
    CHECK(x.labels == y.labels);
    CHECK(x.mesh.positions == y.mesh.positions);
    CHECK(x.mesh.indices == y.mesh.indices);
    CHECK(x.fixes == y.fixes);
    CHECK(x.labels == z.labels);
    CHECK(x.mesh.indices == z.mesh.indices);
    check_closed_manifold(y);
  }
  // The scanned elephant at 4 proxies: its curved regions are split several at a time, their
  // floods side by side on the pool's threads (approximate.cpp, split_by_normals).
  const Mesh e = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  ApproximateOptions a = with_proxies(4), b = with_proxies(4), c = with_proxies(4);
  a.threads = 1;
  b.threads = 2;
  c.threads = 3;
  const ShapeApproximation x = approximate_shape(e, a), y = approximate_shape(e, b), z = approximate_shape(e, c);
  CHECK(has_fix(x, MeshingFix::split_curved));
  CHECK(x.labels == y.labels);
  CHECK(x.labels == z.labels);
  CHECK(x.mesh.positions == y.mesh.positions);
  CHECK(x.mesh.indices == z.mesh.indices);
}

// Approximations of a scanned elephant (tests/data) with 12, 30 and 60 proxies: many of their
// regions take crossing-split anchors round after round, and several are triangulated directly.
template <class Check>
void for_elephant_approximations(Check check) {
  Mesh m = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  Topology t = build_topology(m);
  for (uint32_t n : {12u, 30u, 60u}) {
    CAPTURE(n);
    check(m, t, n, approximate_shape(m, t, with_proxies(n)));
  }
}

TEST_CASE("mesh_partition: recoloring a region from its changed border gives the coloring from scratch") {
  // Each meshing round that adds anchors colors the regions around them again; mesh_partition does
  // it from the border vertices whose (distance, color) decreased (approximate.cpp, colored_), keeps
  // a region's crossing test and the check of its coloring while its polygon is the same
  // (crossings_cache_, checked_), and after splitting curved regions copies the first coloring of
  // the regions whose faces and border seeds did not change from the pass before (FirstColorings).
  // On a scanned elephant many regions take crossing-split anchors round after round, and the
  // coarser partitions are meshed again after a split: the outputs must be those of coloring every
  // region, testing its crossings and checking its coloring from scratch in every round.
  size_t flip_anchors = 0, copied = 0;
  for_elephant_approximations([&](const Mesh& m, const Topology& t, uint32_t n, const ShapeApproximation& partition) {
    const std::vector<uint32_t>& labels = partition.clustering.labels;
    ShapeApproximation a = mesh_partition(m, t, labels, n);
    ShapeApproximation b = detail::mesh_partition_from_scratch(m, t, labels, n);
    CHECK(a.labels == b.labels);
    CHECK(a.mesh.positions == b.mesh.positions);
    CHECK(a.mesh.indices == b.mesh.indices);
    CHECK(a.fixes == b.fixes);
    for (const MeshingFix& f : a.fixes) flip_anchors += f.kind == MeshingFix::flip_anchor;
    copied += a.stats.copied_colorings;
    CHECK(b.stats.copied_colorings == 0);
  });
  CHECK(flip_anchors > 0);  // rounds that recolor did happen
  CHECK(copied > 0);        // and passes after a split
}

TEST_CASE("mesh_partition: border vertices at one position do not break the recoloring from the changed border") {
  // A damaged mesh (found by bench/pipeline_stress.py): corner.off with its vertices moved onto three
  // points, read without welding, so chords run along edges of no length. A chord split there can
  // give a border vertex the same distance (0) to a new end of a higher id: its (distance, color)
  // rises, where the recoloring from the changed border vertices assumes it only falls (an assert
  // fired in approximate.cpp's Mesher::recolor). The regions around it are colored from scratch
  // then: the outputs must be those of coloring every region from scratch in every round.
  const std::string path = temp_path("coincident.off");
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    REQUIRE(f != nullptr);
    std::fputs("OFF\n9 29 0\n1 0 0\n1 1 0\n1 1 0\n2 0 1\n2 0 1\n1 1 0\n1 0 0\n1 0 0\n1 0 0\n"
               "3 0 0 3\n3 0 3 2\n3 0 1 4\n3 0 4 3\n3 2 3 0\n3 2 0 0\n3 0 5 0\n3 0 0 0\n3 5 6 1\n3 5 1 0\n"
               "3 1 6 8\n3 1 8 4\n3 3 4 8\n3 3 8 7\n3 3 7 0\n3 3 0 0\n3 0 0 0\n3 0 0 0\n3 2 0 0\n3 2 0 0\n"
               "3 0 2 0\n3 0 0 0\n3 0 0 0\n3 0 0 7\n3 0 0 7\n3 0 7 5\n3 5 7 8\n3 5 8 6\n3 2 0 0\n",
               f);
    std::fclose(f);
  }
  ReadOptions apart;
  apart.weld = false;
  const Mesh m = read_mesh(path, apart);
  std::remove(path.c_str());
  const Topology t = build_topology(m);
  const ShapeApproximation s = approximate_shape(m, t, with_proxies(4));
  const uint32_t regions = *std::max_element(s.labels.begin(), s.labels.end()) + 1;
  const ShapeApproximation a = mesh_partition(m, t, s.labels, regions);
  const ShapeApproximation b = detail::mesh_partition_from_scratch(m, t, s.labels, regions);
  CHECK(a.mesh.positions == b.mesh.positions);
  CHECK(a.mesh.indices == b.mesh.indices);
  CHECK(a.fixes == b.fixes);
}

TEST_CASE("mesh_partition: a direct triangulation is kept while other regions take anchors") {
  // A region triangulated directly keeps its triangulation from round to round while its polygon
  // and positions stay the same. Every round numbers the output vertices again (an anchor added
  // elsewhere shifts the ids after it), so what is kept must follow its input vertices.
  uint32_t reused = 0;
  for_elephant_approximations([&](const Mesh&, const Topology&, uint32_t, const ShapeApproximation& s) {
    reused += s.stats.reused_triangulations;
    check_closed_manifold(s);
    CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
    // Every polygon's triangles use only its own anchors.
    for (size_t k = 0; k < s.mesh.face_count(); ++k) {
      uint32_t r = s.triangle_regions[k];
      auto begin = s.polygon_vertices.begin() + s.polygon_offsets[r], end = s.polygon_vertices.begin() + s.polygon_offsets[r + 1];
      for (int j = 0; j < 3; ++j) CHECK(std::find(begin, end, s.mesh.indices[3 * k + j]) != end);
    }
  });
  CHECK(reused > 0);
}

TEST_CASE("mesh_partition: rounds to be redone leave out regions out of fixes; the round kept has them all") {
  // The elephant with about one face in 50 dropped (a scan with holes): the holes cut the proxies'
  // regions into many with long borders, and regions that have spent their fixes are left out of
  // the direct triangulations of rounds that are redone anyway, while regions that take a fix are
  // only tested for an acceptable triangulation (approximate.cpp, triangulate). The round kept
  // must still triangulate every polygon: n - 2 triangles each, made of its own anchors, every
  // edge shared by at most two triangles in opposite directions, and the flipped triangles counted
  // in the round kept.
  const Mesh full = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  Mesh m = full;
  m.indices.clear();
  for (size_t f = 0; f < full.face_count(); ++f)
    if (uint32_t(f * 2654435761u) % 50 != 0)
      m.indices.insert(m.indices.end(), &full.indices[3 * f], &full.indices[3 * f + 3]);
  REQUIRE(m.face_count() < full.face_count());
  const Topology t = build_topology(m);
  uint64_t deferred = 0, tested = 0;
  for (uint32_t n : {10u, 12u}) {
    CAPTURE(n);
    const ShapeApproximation s = approximate_shape(m, t, with_proxies(n));
    deferred += s.stats.deferred_triangulations;
    tested += s.stats.tested_polygons;
    size_t triangles = 0;
    for (uint32_t r = 0; r < s.regions; ++r) {
      const uint32_t b = s.polygon_offsets[r], e = s.polygon_offsets[r + 1];
      if (e > b) triangles += e - b - 2;
    }
    CHECK(triangles == s.mesh.face_count());
    for (size_t k = 0; k < s.mesh.face_count(); ++k) {
      const uint32_t r = s.triangle_regions[k];
      auto begin = s.polygon_vertices.begin() + s.polygon_offsets[r];
      auto end = s.polygon_vertices.begin() + s.polygon_offsets[r + 1];
      for (int j = 0; j < 3; ++j) CHECK(std::find(begin, end, s.mesh.indices[3 * k + j]) != end);
    }
    const MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
    CHECK(info.nonmanifold_edges == 0);
    CHECK(info.orientation_flips == 0);
    CHECK(s.stats.nonmanifold_edges == 0);
    CHECK(s.stats.inconsistent_edges == 0);
    CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
  }
  CHECK(deferred > 0);
  CHECK(tested > 0);  // and polygons found to need a fix without their triangulation
}

TEST_CASE("mesh_partition: a closed component with fewer than 4 regions is made solid (two hemispheres)") {
  // Two hemispheres would give two copies of one triangle (their border has no anchor: three are
  // added); the component is split up to 4 regions instead, a tetrahedron-like solid.
  Mesh m = test::icosphere(3);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    double z = 0;
    for (int j = 0; j < 3; ++j) z += m.positions[3 * m.indices[3 * f + j] + 2];
    labels[f] = z > 0 ? 0 : 1;
  }
  ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 2);
  CHECK(has_fix(s, MeshingFix::solid_component));
  CHECK(s.regions >= 4);
  CHECK(flipped_triangles(s) == 0);
  check_closed_manifold(s);
  MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
  CHECK(info.duplicate_faces == 0);
  double volume = 0;
  for (size_t t = 0; t < s.mesh.face_count(); ++t) {
    const float* a = &s.mesh.positions[3 * s.mesh.indices[3 * t]];
    auto n = triangle_normal(s.mesh, t);
    volume += (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0;
  }
  CHECK(volume > 0.2);  // a solid inside the unit sphere (volume 4.19), not a flat double triangle
}

TEST_CASE("mesh_partition: an open surface as one region: anchors on its boundary, corners kept") {
  Mesh m = test::grid(8, 8);
  std::vector<uint32_t> labels(m.face_count(), 0);
  ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 1);
  // The boundary loop has no anchor: three evenly spaced ones, then chord subdivision (sin = 1 on
  // the boundary) adds the square's corners, the farthest points from the chords cutting them.
  CHECK(has_fix(s, MeshingFix::loop_anchors));
  CHECK(s.stats.chord_anchors > 0);
  CHECK(flipped_triangles(s) == 0);
  CHECK(s.mesh.face_count() == s.mesh.vertex_count() - 2);
  double area = 0;
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {  // on the square's boundary
    double x = s.mesh.positions[3 * v], y = s.mesh.positions[3 * v + 1];
    CHECK(std::min({x, 1 - x, y, 1 - y}) < 1e-6);
  }
  for (size_t t = 0; t < s.mesh.face_count(); ++t) area += triangle_normal(s.mesh, t)[2] / 2;
  CHECK(area == doctest::Approx(1.0).epsilon(1e-6));
  MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
  CHECK(info.boundary_loops == 1);
}

TEST_CASE("mesh_partition: a region that is not a disk is split (annulus, whole torus)") {
  SUBCASE("annulus around an inner region on an open grid") {
    Mesh m = test::grid(12, 12);
    std::vector<uint32_t> labels(m.face_count(), 0);
    for (uint32_t j = 4; j < 8; ++j)
      for (uint32_t i = 4; i < 8; ++i) labels[2 * (j * 12 + i)] = labels[2 * (j * 12 + i) + 1] = 1;
    ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 2);
    REQUIRE(has_fix(s, MeshingFix::split_region));
    CHECK(std::find_if(s.fixes.begin(), s.fixes.end(), [](auto& f) { return f.kind == MeshingFix::split_region; })
              ->region == 0);
    CHECK(s.regions > 2);
    CHECK(flipped_triangles(s) == 0);
    MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
    CHECK(info.boundary_loops == 1);  // only the grid's own boundary: no hole
    CHECK(info.nonmanifold_edges == 0);
    CHECK(info.orientation_flips == 0);
    CHECK(info.components == 1);
    // Every output triangle faces up, like the grid.
    for (size_t t = 0; t < s.mesh.face_count(); ++t) CHECK(triangle_normal(s.mesh, t)[2] > 0);
  }
  SUBCASE("a whole closed torus as one region") {
    Mesh m = test::torus(24, 12);
    std::vector<uint32_t> labels(m.face_count(), 0);
    ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 1);
    CHECK(has_fix(s, MeshingFix::split_region));
    CHECK(s.regions > 1);
    MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
    CHECK(info.boundary_edges == 0);
    CHECK(info.nonmanifold_edges == 0);
    CHECK(info.orientation_flips == 0);
    CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
  }
}

TEST_CASE("mesh_partition: two chords joining the same anchors are split") {
  // Cylinder as top cap, bottom cap and two half sides: each cap meets each side along an arc
  // between the same two anchors. A huge chord error keeps the chord rule out of it.
  const double height = 2.0;
  Mesh m = prism(regular_polygon(24, 1.0), height, 3, 6);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[k] += m.positions[3 * m.indices[3 * f + j] + k] / 3;
    auto n = unit_normal(m, f);
    labels[f] = n[2] > 0.5 ? 0 : n[2] < -0.5 ? 1 : c[1] > 0 ? 2 : 3;
  }
  MeshingOptions options;
  options.chord_error = 1e6;
  ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 4, options);
  CHECK(has_fix(s, MeshingFix::duplicate_chord));
  CHECK(s.stats.chord_anchors == 0);
  check_closed_manifold(s);
  CHECK(flipped_triangles(s) == 0);
}

TEST_CASE("mesh_partition: a region too curved for one polygon is split by its normals") {
  // A closed cylinder whose side is one region wrapping 270 degrees and one of 90: no triangulation
  // of the big region's anchor polygon faces along its proxy normal everywhere.
  const double pi = 3.14159265358979323846;
  Mesh m = prism(regular_polygon(32, 1.0), 1.0, 2, 3);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[k] += m.positions[3 * m.indices[3 * f + j] + k] / 3;
    auto n = unit_normal(m, f);
    double a = std::atan2(c[1], c[0]) + pi;  // (0, 2 pi]
    labels[f] = n[2] > 0.5 ? 0 : n[2] < -0.5 ? 1 : a < 1.5 * pi ? 2 : 3;
  }
  ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 4);
  CHECK(has_fix(s, MeshingFix::split_curved));
  CHECK(s.regions > 4);
  CHECK(flipped_triangles(s) == 0);
  CHECK(s.stats.flipped_triangles == 0);
  check_closed_manifold(s);
}

TEST_CASE("approximate: few proxies on a curved scan: regions are split until no triangle faces away") {
  // The scanned elephant with 4 to 10 proxies: many regions are too curved for one polygon, and
  // their halves again, for up to 18 passes of splits and meshing. Passes followed by a split stop
  // once they know which regions to split (approximate.cpp, curved_without_deferred); the last
  // pass is meshed in full. The output must be closed, manifold, one polygon per region, with no
  // triangle facing away from its region (with at most 4 passes, as until the thirty-fifth
  // session, 12, 9 and 6 triangles faced away).
  const Mesh m = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  const Topology t = build_topology(m);
  uint32_t most_passes = 0, shortened = 0;
  for (uint32_t n : {4u, 8u, 10u}) {
    CAPTURE(n);
    const ShapeApproximation s = approximate_shape(m, t, with_proxies(n));
    CAPTURE(s.stats.meshing_passes);
    check_closed_manifold(s);
    check_polygons(s);
    CHECK(flipped_triangles(s) == 0);
    CHECK(s.stats.flipped_triangles == 0);
    CHECK(s.stats.inconsistent_edges == 0);
    CHECK(s.regions > n);
    const size_t splits = size_t(std::count_if(s.fixes.begin(), s.fixes.end(),
                                               [](const MeshingFix& f) { return f.kind == MeshingFix::split_curved; }));
    CHECK(splits >= s.stats.meshing_passes - 1);  // every pass but the last split something
    CHECK(s.stats.meshing_passes <= kMaxSplitPasses);
    CHECK(s.stats.shortened_passes < s.stats.meshing_passes);
    most_passes = std::max(most_passes, s.stats.meshing_passes);
    shortened += s.stats.shortened_passes;
  }
  CHECK(most_passes > 4);
  CHECK(shortened > 0);
}

TEST_CASE("split by normals: a noisy curved region by its curvature, a flat one in space, a CAD one at its sharp edge") {
  // The split the meshing makes of a region too curved for one polygon (approximate.cpp,
  // split_by_normals). On a scan the faces with the most extreme normals are noise: a split
  // seeded there kept a handful of faces in one half (the man at 10 proxies: 8 + 5245, ...).
  // Here half a cylinder's side, its vertices moved in and out by up to 4% of the radius: it must
  // come apart into two quarters, about half the faces each, each on its own side of the middle.
  {
    const double pi = 3.14159265358979323846;
    Mesh m = prism(regular_polygon(96, 1.0), 1.0, 2, 24);
    std::vector<uint32_t> labels(m.face_count());
    std::vector<double> angle(m.face_count(), -1);  // of a side face of region 0, in (0, pi)
    for (size_t f = 0; f < m.face_count(); ++f) {
      double c[3] = {0, 0, 0};
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) c[k] += m.positions[3 * m.indices[3 * f + j] + k] / 3;
      const auto n = unit_normal(m, f);
      const double a = std::atan2(c[1], c[0]);
      const bool side = std::abs(n[2]) < 0.5;
      labels[f] = side && a > 0 ? 0 : 1;
      if (labels[f] == 0) angle[f] = a;
    }
    // (The noise after the labels: the region is the half side, whatever its faces' normals.)
    uint32_t state = 12345;  // a fixed LCG: the same mesh every run
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      state = state * 1664525u + 1013904223u;
      const float scale = float(1 + 0.04 * (double(state >> 8) / double(1u << 24) * 2 - 1));
      m.positions[3 * v] *= scale, m.positions[3 * v + 1] *= scale;
    }
    const Topology t = build_topology(m);
    const uint32_t count = detail::split_regions_by_normals(m, t, labels, 2, {0});
    CHECK(count == 3);
    size_t in[2] = {0, 0}, wrong_side[2] = {0, 0};  // faces of each half; those past the middle
    for (size_t f = 0; f < m.face_count(); ++f) {
      if (angle[f] < 0) continue;
      REQUIRE((labels[f] == 0 || labels[f] == 2));
      const int half = labels[f] == 0 ? 0 : 1;
      ++in[half];
      wrong_side[half] += angle[f] < pi / 2;
    }
    CAPTURE(in[0]);
    CAPTURE(in[1]);
    CHECK(3 * std::min(in[0], in[1]) >= in[0] + in[1]);  // a third of the faces or more each
    // Each half lies on one side of the middle but for a few faces along the cut.
    const size_t stray = std::min(wrong_side[0] + (in[1] - wrong_side[1]), wrong_side[1] + (in[0] - wrong_side[0]));
    CAPTURE(stray);
    CHECK(10 * stray <= in[0] + in[1]);
  }
  // A flat region has one normal: every distance in the flood ties, and the ties are what split
  // it. They go to the face offered first, breadth first
  // from the seeds, so it comes apart in space: two parts of about equal size.
  {
    const Mesh m = cube(8);
    const Topology t = build_topology(m);
    std::vector<uint32_t> labels(m.face_count());
    size_t flat = 0;
    for (size_t f = 0; f < m.face_count(); ++f) {
      labels[f] = unit_normal(m, f)[2] > 0.999 ? 0 : 1;
      flat += labels[f] == 0;
    }
    REQUIRE(flat == 128);
    CHECK(detail::split_regions_by_normals(m, t, labels, 2, {0}) == 3);
    const size_t kept = size_t(std::count(labels.begin(), labels.end(), 0u));
    const size_t fresh = size_t(std::count(labels.begin(), labels.end(), 2u));
    CAPTURE(kept);
    CAPTURE(fresh);
    CHECK(kept + fresh == flat);
    CHECK(3 * std::min(kept, fresh) >= flat);
  }
  // On a CAD part the far side of a sharp edge is where the split belongs: two sides of the
  // chamfered box as one region (its face at y = 1 and the chamfer) come apart along their edge.
  {
    const Mesh m = prism(kChamferedSection, 1.0, 4, 4);
    const Topology t = build_topology(m);
    const double chamfer[3] = {0.7071067811865476, 0.7071067811865476, 0};
    std::vector<uint32_t> labels(m.face_count());
    std::vector<uint8_t> side(m.face_count(), 0);  // 1: top (+y), 2: chamfer
    for (size_t f = 0; f < m.face_count(); ++f) {
      const auto n = unit_normal(m, f);
      side[f] = n[1] > 0.999 ? 1 : n[0] * chamfer[0] + n[1] * chamfer[1] > 0.999 ? 2 : 0;
      labels[f] = side[f] != 0 ? 0 : 1;
    }
    const uint32_t count = detail::split_regions_by_normals(m, t, labels, 2, {0});
    CHECK(count == 3);
    std::set<std::pair<uint8_t, uint32_t>> pairs;  // (side, label) over the region's faces
    for (size_t f = 0; f < m.face_count(); ++f)
      if (side[f] != 0) pairs.insert({side[f], labels[f]});
    CHECK(pairs.size() == 2);  // each side one label, and the two labels differ
    if (pairs.size() == 2) CHECK(pairs.begin()->second != std::next(pairs.begin())->second);
  }
}

TEST_CASE("mesh_partition: regions meeting only at two poles get a third anchor") {
  // Four orange slices of a sphere: every border runs from pole to pole, all four chords join the
  // same two anchors and each slice has only those two.
  Mesh m = test::icosphere(3);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[k] += m.positions[3 * m.indices[3 * f + j] + k];
    double a = std::atan2(c[1], c[0]) + 3.14159265358979323846;  // (0, 2 pi]
    labels[f] = std::min(3u, uint32_t(a / (2 * 3.14159265358979323846 / 4)));
  }
  MeshingOptions options;
  options.chord_error = 1e6;  // no chord subdivision: only the fixes add anchors
  ShapeApproximation s = mesh_partition(m, build_topology(m), labels, 4, options);
  CHECK_FALSE(has_fix(s, MeshingFix::solid_component));
  CHECK((has_fix(s, MeshingFix::polygon_anchor) || has_fix(s, MeshingFix::duplicate_chord)));
  MeshInfo info = mesh_info(s.mesh, build_topology(s.mesh));
  CHECK(info.boundary_edges == 0);
  CHECK(info.nonmanifold_edges == 0);
  CHECK(info.orientation_flips == 0);
  for (uint32_t r = 0; r < s.regions; ++r) CHECK(s.polygon_offsets[r + 1] - s.polygon_offsets[r] >= 3);
}

TEST_CASE("mesh_partition: the chord error trades vertices for accuracy") {
  Mesh m = prism(regular_polygon(48, 1.0), 1.0, 2, 2);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    auto n = unit_normal(m, f);
    double c = 0;
    for (int j = 0; j < 3; ++j) c += m.positions[3 * m.indices[3 * f + j]];
    labels[f] = n[2] > 0.5 ? 0 : n[2] < -0.5 ? 1 : c > 0 ? 2 : 3;
  }
  Topology t = build_topology(m);
  size_t previous = 0;
  for (double e : {1.0, 0.1, 0.03, 0.01}) {
    MeshingOptions o;
    o.chord_error = e;
    ShapeApproximation s = mesh_partition(m, t, labels, 4, o);
    CAPTURE(e);
    CHECK(s.mesh.vertex_count() >= previous);
    previous = s.mesh.vertex_count();
    check_closed_manifold(s);
  }
  CHECK(previous > 12);
  // The CGAL rule: splits by deviation over the mean edge length, whatever the dihedral angle.
  MeshingOptions cgal;
  cgal.chord_rule = ChordRule::cgal;
  cgal.chord_error = 0.5;
  ShapeApproximation s = mesh_partition(m, t, labels, 4, cgal);
  CHECK(s.stats.chord_anchors > 0);
  check_closed_manifold(s);
}

TEST_CASE("mesh_partition: collapsed faces and regions without faces give nothing and break nothing") {
  Mesh m = cube(2);
  uint32_t v0 = m.indices[0];
  test::add_triangle(m, v0, v0, m.indices[1]);  // collapsed face
  Topology t = build_topology(m);
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f + 1 < m.face_count(); ++f) {
    auto n = unit_normal(m, f);
    int axis = std::abs(n[0]) > 0.5 ? 0 : std::abs(n[1]) > 0.5 ? 1 : 2;
    labels[f] = uint32_t(2 * axis + (n[axis] > 0));
  }
  labels.back() = 6;  // a region of one collapsed face; region 7 has no face at all
  ShapeApproximation s = mesh_partition(m, t, labels, 8);
  CHECK(has_fix(s, MeshingFix::skipped_region));
  CHECK(s.mesh.vertex_count() == 8);
  CHECK(s.mesh.face_count() == 12);
  CHECK(s.polygon_offsets[7] == s.polygon_offsets[8]);
  check_closed_manifold(s);
}

TEST_CASE("approximate: non-manifold input (a wall standing on a grid) is meshed without failing") {
  Mesh m = test::grid_with_wall(12);
  MeshInfo in = mesh_info(m, build_topology(m));
  REQUIRE(in.nonmanifold_edges > 0);
  ShapeApproximation s = approximate_shape(m, with_proxies(8));
  CHECK(s.mesh.face_count() > 0);
  CHECK(flipped_triangles(s) == s.stats.flipped_triangles);
  MeshInfo out = mesh_info(s.mesh, build_topology(s.mesh));
  CHECK(out.nonmanifold_edges <= in.nonmanifold_edges);  // only where the input has them
  CHECK(out.orientation_flips == 0);
}

TEST_CASE("approximate: options are checked") {
  Mesh m = cube(2);
  ApproximateOptions o;
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);  // neither
  o.proxies = 6;
  o.max_error = 0.1;
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);  // both
  o.max_error = -1;
  o.meshing.chord_error = -0.5;
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);
  o.meshing.chord_error = std::nan("");
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);
  o.meshing.chord_error = 0.1;
  o.proxies = uint32_t(m.face_count() + 1);
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);
  o.proxies = 0;
  o.max_error = std::nan("");
  CHECK_THROWS_AS(approximate_shape(m, o), OptionError);
  Topology t = build_topology(m);
  CHECK_THROWS_AS(mesh_partition(m, t, std::vector<uint32_t>(m.face_count(), 3), 3), OptionError);
  CHECK_THROWS_AS(mesh_partition(m, t, std::vector<uint32_t>(5, 0), 1), OptionError);
  CHECK(parse_chord_rule("cgal") == ChordRule::cgal);
  CHECK_THROWS_AS(parse_chord_rule("vsa"), OptionError);
}

TEST_CASE("write_polygon_mesh: OBJ and OFF with n-gons read back; bad input leaves no file") {
  Mesh m = prism(kChamferedSection, 1.0, 2, 2);
  ShapeApproximation s = approximate_shape(m, with_proxies(7));
  for (const char* ext : {".obj", ".off"}) {
    std::string path = temp_path(std::string("poly") + ext);
    write_polygon_mesh(path, s.mesh.positions, s.polygon_offsets, s.polygon_vertices);
    ReadStats rs;
    Mesh back = read_mesh(path, {}, &rs);
    CAPTURE(ext);
    CHECK(rs.file_polygons == 7);
    CHECK(rs.triangulated_polygons == 7);  // 2 pentagons, 5 quads
    CHECK(back.face_count() == 16);
    CHECK(back.vertex_count() == s.mesh.vertex_count());
    CHECK(back.positions == s.mesh.positions);
    std::remove(path.c_str());
  }
  std::string bad = temp_path("poly.stl");
  CHECK_THROWS_AS(write_polygon_mesh(bad, s.mesh.positions, s.polygon_offsets, s.polygon_vertices), FileError);
  CHECK(access(bad.c_str(), F_OK) != 0);
  std::string off = temp_path("bad.off");
  std::vector<uint32_t> offsets = {0, 2}, vertices = {0, 1};
  CHECK_THROWS_AS(write_polygon_mesh(off, s.mesh.positions, offsets, vertices), OptionError);
  offsets = {0, 3};
  vertices = {0, 1, 99};
  CHECK_THROWS_AS(write_polygon_mesh(off, s.mesh.positions, offsets, vertices), OptionError);
  CHECK(access(off.c_str(), F_OK) != 0);
}
