// meshcvt tests: moving coarse vertices over their own clusters to improve triangles
// (src/coarse_relax.cpp).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "meshcvt/quality.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"
#include "triangle_bvh.h"

using namespace meshcvt;

namespace {

// Distance from point v of `coarse` to the nearest face of `mesh` labelled `cluster`.
double distance_to_cluster(const Mesh& coarse, uint32_t v, const Mesh& mesh, const std::vector<uint32_t>& labels,
                           uint32_t cluster) {
  const double q[3] = {coarse.positions[3 * v], coarse.positions[3 * v + 1], coarse.positions[3 * v + 2]};
  double best = INFINITY;
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    if (labels[f] != cluster) continue;
    double corner[3][3], point[3];
    for (int j = 0; j < 3; ++j)
      for (int d = 0; d < 3; ++d) corner[j][d] = mesh.positions[3 * mesh.indices[3 * f + j] + d];
    best = std::min(best, closest_point_on_triangle(q, corner[0], corner[1], corner[2], point));
  }
  return std::sqrt(best);
}

// z of the normal of every triangle of a mesh in the plane z = 0 (positive: counter-clockwise from +z).
std::vector<double> normal_z(const Mesh& m) {
  std::vector<double> z;
  for (size_t t = 0; t < m.face_count(); ++t) {
    const float* a = &m.positions[3 * m.indices[3 * t]];
    const float* b = &m.positions[3 * m.indices[3 * t + 1]];
    const float* c = &m.positions[3 * m.indices[3 * t + 2]];
    z.push_back(double(b[0] - a[0]) * (c[1] - a[1]) - double(b[1] - a[1]) * (c[0] - a[0]));
  }
  return z;
}

// A mesh clustered on one thread and its dual before any relaxing (flips optional).
struct UnrelaxedDual {
  Clustering clustering;
  CoarsenResult coarse;
};
UnrelaxedDual unrelaxed_dual(const Mesh& input, const Topology& topology, uint32_t clusters, bool flip_edges) {
  ClusterOptions co;
  co.clusters = clusters;
  co.threads = 1;
  UnrelaxedDual d;
  d.clustering = cluster(input, topology, co);
  CoarsenOptions options;
  options.relax_passes = 0;
  options.flip_edges = flip_edges;
  d.coarse = coarsen_clustering(input, topology, d.clustering.labels, clusters, options);
  REQUIRE(d.coarse.defects.empty());
  return d;
}

// Labels for the hexagon fixtures, by face centroid in the grid's x and y: within `disk` of
// site[0] (the centre) cluster 0, otherwise the nearest of the six corners site[1..6].
std::vector<uint32_t> hexagon_labels(const Mesh& grid, const double site[7][2], double disk) {
  std::vector<uint32_t> labels(grid.face_count());
  for (size_t f = 0; f < grid.face_count(); ++f) {
    double gx = 0, gy = 0;
    for (int j = 0; j < 3; ++j) {
      gx += grid.positions[3 * grid.indices[3 * f + j]] / 3;
      gy += grid.positions[3 * grid.indices[3 * f + j] + 1] / 3;
    }
    uint32_t best = 1;
    if (std::hypot(gx - site[0][0], gy - site[0][1]) < disk) best = 0;
    for (uint32_t s = 2; s < 7 && best != 0; ++s)
      if (std::hypot(gx - site[s][0], gy - site[s][1]) < std::hypot(gx - site[best][0], gy - site[best][1])) best = s;
    labels[f] = best;
  }
  return labels;
}

// Input: a fine flat grid. Clusters (by face centroid): a disk of radius 0.25 around a regular
// hexagon's centre, the rest to the nearest corner. Coarse mesh: the hexagon's fan, the centre
// vertex placed inside its own cluster but near one corner, which gives angles below 30 degrees.
struct OffCentreHexagon {
  Mesh input;
  std::vector<uint32_t> labels;
  Mesh coarse;
};
OffCentreHexagon off_centre_hexagon() {
  OffCentreHexagon h;
  h.input = test::grid(60, 60);
  const Mesh& input = h.input;
  const double cx = 0.5, cy = 0.5, radius = 0.3;
  double site[7][2] = {{cx, cy}};
  for (int k = 0; k < 6; ++k) {
    site[k + 1][0] = cx + radius * std::cos(k * std::numbers::pi / 3);
    site[k + 1][1] = cy + radius * std::sin(k * std::numbers::pi / 3);
  }
  h.labels = hexagon_labels(input, site, 0.25);
  Mesh& coarse = h.coarse;
  test::add_vertex(coarse, cx + 0.2, cy + 0.03, 0);  // inside the centre disk, near corner 1
  for (int k = 0; k < 6; ++k) test::add_vertex(coarse, site[k + 1][0], site[k + 1][1], 0);
  for (uint32_t k = 0; k < 6; ++k) test::add_triangle(coarse, 0, 1 + k, 1 + (k + 1) % 6);
  return h;
}

}  // namespace

TEST_CASE("coarse relax: a hexagon whose centre vertex sits off-centre in its cluster gets fat triangles") {
  const auto [input, labels, coarse] = off_centre_hexagon();
  REQUIRE(distance_to_cluster(coarse, 0, input, labels, 0) < 1e-6);
  const TriangleQuality before = triangle_quality(coarse);
  REQUIRE(before.min_angle_deg < 30);

  Mesh relaxed = coarse;
  const Topology topology = build_topology(input);
  CHECK(relax_coarse_vertices(relaxed, input, topology, labels) > 0);
  const TriangleQuality after = triangle_quality(relaxed);
  CHECK(after.min_angle_deg >= 30);
  CHECK(after.q_avg > before.q_avg);
  // Triangles and vertex count unchanged, orientation kept, the moved vertex on its own cluster.
  CHECK(relaxed.indices == coarse.indices);
  CHECK(relaxed.vertex_count() == 7);
  for (double z : normal_z(relaxed)) CHECK(z > 0);
  CHECK(distance_to_cluster(relaxed, 0, input, labels, 0) < 1e-6);
  // The corners are on the boundary: they stay.
  for (size_t i = 3; i < relaxed.positions.size(); ++i) CHECK(relaxed.positions[i] == coarse.positions[i]);
  // Deterministic, and 0 passes moves nothing.
  Mesh again = coarse;
  relax_coarse_vertices(again, input, topology, labels);
  CHECK(again.positions == relaxed.positions);
  Mesh none = coarse;
  CHECK(relax_coarse_vertices(none, input, topology, labels, 0) == 0);
  CHECK(none.positions == coarse.positions);
}

TEST_CASE("coarse relax: a vertex at the apex of a cap on a curved surface moves off the chord") {
  // The hexagon of the first case on a cylinder of radius 2 (the grid bent around the x axis),
  // its centre cluster a disk of radius 0.28, and the centre vertex on the surface at 98% of the
  // way to the midpoint of side 1-2: triangle (0, 1, 2) is a cap of about 175 degrees whose plane
  // stands across the surface. Any move of its apex turns its normal by tens of degrees, which the
  // 20-degree limit refused, leaving the cap (cylinder_locally_refined -> 411: 0.38 degrees).
  // A cap's apex is judged by whether the cap then faces the ring's side.
  const double radius = 2, cx = 0.5, cy = 0.5, hexagon = 0.3;
  auto bend = [&](double u, double v, double out[3]) {
    out[0] = u, out[1] = radius * std::sin(v / radius), out[2] = radius * (1 - std::cos(v / radius));
  };
  Mesh input = test::grid(60, 60);
  for (size_t i = 0; i < input.vertex_count(); ++i) {
    double p[3];
    bend(input.positions[3 * i], input.positions[3 * i + 1], p);
    for (int d = 0; d < 3; ++d) input.positions[3 * i + d] = float(p[d]);
  }
  double site[7][2] = {{cx, cy}};
  for (int k = 0; k < 6; ++k) {
    site[k + 1][0] = cx + hexagon * std::cos(k * std::numbers::pi / 3);
    site[k + 1][1] = cy + hexagon * std::sin(k * std::numbers::pi / 3);
  }
  // Labels by the faces' centroids in the grid's own coordinates (before the bend).
  const std::vector<uint32_t> labels = hexagon_labels(test::grid(60, 60), site, 0.28);
  Mesh coarse;
  double p[3];
  bend(cx + 0.98 * (0.5 * (site[1][0] + site[2][0]) - cx), cy + 0.98 * (0.5 * (site[1][1] + site[2][1]) - cy), p);
  test::add_vertex(coarse, p[0], p[1], p[2]);
  for (int k = 0; k < 6; ++k) {
    bend(site[k + 1][0], site[k + 1][1], p);
    test::add_vertex(coarse, p[0], p[1], p[2]);
  }
  for (uint32_t k = 0; k < 6; ++k) test::add_triangle(coarse, 0, 1 + k, 1 + (k + 1) % 6);
  const Topology topology = build_topology(input);
  // On the cylinder, 2e-5 from the grid's flat faces: within what relax counts as on them.
  REQUIRE(distance_to_cluster(coarse, 0, input, labels, 0) < 3e-5);
  const TriangleQuality before = triangle_quality(coarse);
  REQUIRE(before.min_angle_deg < 5);

  Mesh relaxed = coarse;
  CHECK(relax_coarse_vertices(relaxed, input, topology, labels) > 0);
  const TriangleQuality after = triangle_quality(relaxed);
  CHECK(after.min_angle_deg > 30);
  CHECK(distance_to_cluster(relaxed, 0, input, labels, 0) < 1e-5);
  CHECK(relaxed.indices == coarse.indices);
  // Every triangle still faces the side the fan faced (+z at the top of the cylinder, near y = 0).
  for (size_t t = 0; t < relaxed.face_count(); ++t) {
    const float* a = &relaxed.positions[3 * relaxed.indices[3 * t]];
    const float* b = &relaxed.positions[3 * relaxed.indices[3 * t + 1]];
    const float* c = &relaxed.positions[3 * relaxed.indices[3 * t + 2]];
    CHECK(double(b[0] - a[0]) * (c[1] - a[1]) - double(b[1] - a[1]) * (c[0] - a[0]) > 0);
  }
}

TEST_CASE("coarse relax: a vertex at an edge that is not two consistently oriented triangles stays") {
  // The hexagon's centre moves as built (first case); each of these defects at its edges keeps it
  // where it is: a fan triangle turned over, one repeated, a fin on a spoke, a triangle repeating it.
  const auto [input, labels, coarse] = off_centre_hexagon();
  const Topology topology = build_topology(input);
  for (int defect = 0; defect < 4; ++defect) {
    CAPTURE(defect);
    Mesh broken = coarse;
    if (defect == 0) std::swap(broken.indices[1], broken.indices[2]);
    if (defect == 1) test::add_triangle(broken, 0, 1, 2);
    if (defect == 2) {
      test::add_vertex(broken, 0.5f, 0.5f, 0.3f);  // a cluster without faces
      test::add_triangle(broken, 1, 0, 7);
    }
    if (defect == 3) test::add_triangle(broken, 0, 0, 4);
    const Mesh before = broken;
    CHECK(relax_coarse_vertices(broken, input, topology, labels) == 0);
    CHECK(broken.positions == before.positions);
  }
}

TEST_CASE("coarse relax: a centre vertex above its flat cluster floats: it moves in the plane and keeps its height") {
  // The hexagon again with its centre vertex lifted off the plane (as a qem point can be). Its
  // cluster is flat: the free directions of its normal tensor are the plane's, so it moves toward
  // the middle of its ring as before, at the same height, and is not taken onto the faces.
  auto [input, labels, coarse] = off_centre_hexagon();
  const float height = 0.05f;
  coarse.positions[2] = height;
  const TriangleQuality before = triangle_quality(coarse);
  Mesh relaxed = coarse;
  const Topology topology = build_topology(input);
  CHECK(relax_coarse_vertices(relaxed, input, topology, labels) > 0);
  CHECK(relaxed.positions[2] == height);
  CHECK((relaxed.positions[0] != coarse.positions[0] || relaxed.positions[1] != coarse.positions[1]));
  const TriangleQuality after = triangle_quality(relaxed);
  CHECK(after.min_angle_deg > before.min_angle_deg);
  CHECK(after.q_avg > before.q_avg);
  CHECK(relaxed.indices == coarse.indices);
  for (double z : normal_z(relaxed)) CHECK(z > 0);
}

TEST_CASE("coarse relax: on a clustered torus vertices stay on their clusters and the smallest angle never drops") {
  Mesh input = test::torus(90, 36);
  Topology topology = build_topology(input);
  const uint32_t clusters = 150;
  const auto& [c, r] = unrelaxed_dual(input, topology, clusters, /*flip_edges=*/true);
  Mesh relaxed = r.mesh;
  // One vertex lifted off the surface (as a qem point can be): it floats. It keeps its offset
  // (not taken onto its cluster's faces) and steps only along its cluster's free directions.
  relaxed.positions[0] *= 1.05f;
  const double lift = distance_to_cluster(relaxed, 0, input, c.labels, 0);
  REQUIRE(lift > 1e-3);
  const TriangleQuality before = triangle_quality(relaxed);
  const uint64_t moves = relax_coarse_vertices(relaxed, input, topology, c.labels, 3);
  CHECK(moves > 0);
  const TriangleQuality after = triangle_quality(relaxed);
  CHECK(after.min_angle_deg >= std::min(before.min_angle_deg, 35.0) - 1e-9);
  CHECK(after.q_avg > before.q_avg);
  CHECK(relaxed.indices == r.mesh.indices);  // topology, orientation and vertex count kept
  // The torus bends little within a cluster: the floating vertex stays about as far off it.
  CHECK(distance_to_cluster(relaxed, 0, input, c.labels, 0) > 0.5 * lift);
  CHECK(distance_to_cluster(relaxed, 0, input, c.labels, 0) < 2.0 * lift);
  uint32_t moved = 0;
  for (uint32_t v = 1; v < clusters; ++v) {
    bool same = true;
    for (int d = 0; d < 3; ++d) same = same && relaxed.positions[3 * v + d] == r.mesh.positions[3 * v + d];
    if (same) continue;
    ++moved;
    CHECK(distance_to_cluster(relaxed, v, input, c.labels, v) < 1e-5);
  }
  CHECK(moved > 0);

  // The default job relaxes too: same vertex count, still a clean closed manifold.
  CoarsenResult job = coarsen_clustering(input, topology, c.labels, clusters);
  CHECK(job.relaxed_moves > 0);
  CHECK(job.defects.empty());
  CHECK(job.mesh.vertex_count() == clusters);
  MeshInfo info = mesh_info(job.mesh, build_topology(job.mesh));
  CHECK(info.euler_characteristic == 0);
  CHECK(info.boundary_loops == 0);
  CHECK(info.nonmanifold_edges == 0);
  CHECK(triangle_quality(job.mesh).min_angle_deg >= std::min(triangle_quality(r.mesh).min_angle_deg, 35.0) - 1e-9);
}

TEST_CASE("coarse relax: the same positions on 1, 2 and 4 threads, and the pass leaves no vertex off its cluster") {
  // Enough vertices that each class of the coloring is split over the workers (the pool keeps
  // small classes on one thread), on a bumpy surface so that moves meet and refuse each other.
  Mesh input = test::torus(160, 64);
  for (size_t v = 0; v < input.vertex_count(); ++v)
    input.positions[3 * v + 2] *= 1.0f + 0.2f * float(std::sin(0.37 * double(v)));
  Topology topology = build_topology(input);
  const uint32_t clusters = 1200;
  const auto& [c, r] = unrelaxed_dual(input, topology, clusters, /*flip_edges=*/false);
  std::vector<Mesh> relaxed;
  std::vector<uint64_t> moves;
  for (unsigned threads : {1u, 2u, 4u}) {
    relaxed.push_back(r.mesh);
    moves.push_back(relax_coarse_vertices(relaxed.back(), input, topology, c.labels, 3, 20, threads));
  }
  CHECK(moves[0] > clusters);  // most vertices move, some more than once
  CHECK(moves[1] == moves[0]);
  CHECK(moves[2] == moves[0]);
  CHECK(relaxed[1].positions == relaxed[0].positions);
  CHECK(relaxed[2].positions == relaxed[0].positions);
  CHECK(triangle_quality(relaxed[0]).min_angle_deg >= std::min(triangle_quality(r.mesh).min_angle_deg, 35.0) - 1e-9);
  for (uint32_t v = 0; v < clusters; v += 7) CHECK(distance_to_cluster(relaxed[0], v, input, c.labels, v) < 1e-5);
}

TEST_CASE("coarse relax: malformed inputs are rejected") {
  Mesh input = test::grid(4, 4);
  Topology topology = build_topology(input);
  Mesh coarse;
  test::add_vertex(coarse, 0, 0, 0);
  test::add_vertex(coarse, 1, 0, 0);
  test::add_vertex(coarse, 0, 1, 0);
  test::add_triangle(coarse, 0, 1, 2);
  std::vector<uint32_t> labels(input.face_count(), 0);
  CHECK_THROWS_AS(relax_coarse_vertices(coarse, input, topology, std::vector<uint32_t>(3, 0)), OptionError);
  labels[0] = 3;  // not below the coarse vertex count
  CHECK_THROWS_AS(relax_coarse_vertices(coarse, input, topology, labels), OptionError);
  labels[0] = 0;
  CHECK_THROWS_AS(relax_coarse_vertices(coarse, input, Topology{}, labels), OptionError);
  CHECK(relax_coarse_vertices(coarse, input, topology, labels) == 0);  // boundary vertices only
}
