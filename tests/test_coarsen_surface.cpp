// Tests for coarsen_surface (the whole of `meshcvt coarsen` as a library call): long edges split
// first where a CAD-like triangulation has them, the fallback to the input as given, subdivision by
// placement, a caller's density carried to the faces made of each face, collapsed faces left out,
// the same result for any thread count, and the errors.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/mesh.h"
#include "meshcvt/quality.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"
#include "vec3.h"

using namespace meshcvt;

namespace {

// A closed cylinder as CAD exports triangulate it: k sides of two triangles each running the whole
// height h, caps fanned from their centres. Radius 1: each side triangle is h x 2 sin(pi / k).
Mesh cad_cylinder(uint32_t k = 48, double h = 6) {
  Mesh m;
  for (double z : {0.0, h})
    for (uint32_t i = 0; i < k; ++i)
      test::add_vertex(m, std::cos(2 * M_PI * i / k), std::sin(2 * M_PI * i / k), z);
  const uint32_t bottom = test::add_vertex(m, 0, 0, 0), top = test::add_vertex(m, 0, 0, h);
  for (uint32_t i = 0; i < k; ++i) {
    const uint32_t j = (i + 1) % k;
    test::add_triangle(m, i, j, k + j);
    test::add_triangle(m, i, k + j, k + i);
    test::add_triangle(m, bottom, j, i);
    test::add_triangle(m, top, k + i, k + j);
  }
  return m;
}

// A flat strip of q quads, each len x width (two triangles), along x from x = 3: every vertex is on
// its boundary.
Mesh strip(uint32_t q, double len, double width) {
  Mesh m;
  for (uint32_t i = 0; i <= q; ++i) {
    test::add_vertex(m, 3 + i * len, 0, 0);
    test::add_vertex(m, 3 + i * len, width, 0);
  }
  for (uint32_t i = 0; i < q; ++i) {
    test::add_triangle(m, 2 * i, 2 * i + 2, 2 * i + 3);
    test::add_triangle(m, 2 * i, 2 * i + 3, 2 * i + 1);
  }
  return m;
}

double longest_edge(const Mesh& m) {
  double longest = 0;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      const float* a = &m.positions[3 * size_t(m.indices[3 * f + k])];
      const float* b = &m.positions[3 * size_t(m.indices[3 * f + (k + 1) % 3])];
      longest = std::max(longest, std::sqrt(double(a[0] - b[0]) * (a[0] - b[0]) + double(a[1] - b[1]) * (a[1] - b[1]) +
                                            double(a[2] - b[2]) * (a[2] - b[2])));
    }
  return longest;
}

CoarsenSurfaceOptions with_n(uint32_t n) {
  CoarsenSurfaceOptions o;
  o.job.cluster.clusters = n;
  o.job.cluster.device = "cpu";
  return o;
}

// A valid coarse mesh: n vertices, a closed or open manifold with the surface's chi and loops.
void check_valid(const CoarsenSurfaceResult& r, uint32_t n) {
  CHECK_FALSE(r.job.defects_remain);
  CHECK(r.job.coarse.defects.empty());
  const Mesh& coarse = r.job.coarse.mesh;
  CHECK(coarse.vertex_count() == n);
  const Topology t = build_topology(coarse);
  const MeshInfo in = mesh_info(r.surface, r.topology), out = mesh_info(coarse, t);
  CHECK(out.nonmanifold_edges == 0);
  CHECK(out.nonmanifold_vertices == 0);
  CHECK(out.euler_characteristic == in.euler_characteristic);
  CHECK(out.boundary_loops == in.boundary_loops);
}


// Checks result.surface_origin against the mesh given from outside: every surface face names a
// face of `given`, and the pieces of each given face add up to its area (so they are its pieces).
void check_origin(const Mesh& given, const CoarsenSurfaceResult& r) {
  REQUIRE(r.given_faces == given.face_count());
  REQUIRE(r.surface_origin.size() == r.surface.face_count());
  std::vector<double> area(given.face_count(), 0.0);
  for (size_t i = 0; i < r.surface_origin.size(); ++i) {
    REQUIRE(r.surface_origin[i] < given.face_count());
    area[r.surface_origin[i]] += face_area(r.surface, i);
  }
  for (size_t f = 0; f < given.face_count(); ++f) CHECK(area[f] == doctest::Approx(face_area(given, f)).epsilon(1e-5));
}

CoarsenSurfaceOptions tracked(uint32_t n) {
  CoarsenSurfaceOptions o = with_n(n);
  o.keep_surface_origin = true;
  return o;
}

}  // namespace

TEST_CASE("coarsen_surface: a CAD-like cylinder's long edges are split first, and its triangles come out better") {
  const Mesh cylinder = cad_cylinder();
  const uint32_t n = 60;
  CoarsenSurfaceOptions off = with_n(n);
  off.split_edges = 0;
  const CoarsenSurfaceResult plain = coarsen_surface(cylinder, off);
  const CoarsenSurfaceResult split = coarsen_surface(cylinder, with_n(n));

  // Both count the same long edges (the 96 side edges and more): at least one per cluster.
  CHECK(plain.long_edges == split.long_edges);
  CHECK(split.long_edges >= n);
  CHECK(plain.coarse_edge_length == doctest::Approx(split.coarse_edge_length));
  CHECK(plain.split_edges == 0);
  CHECK(plain.split_ratio == 0);
  CHECK(plain.surface.face_count() == cylinder.face_count());
  CHECK(split.split_ratio == kAutoSplitEdgesRatio);
  CHECK(split.split_edges > 0);
  CHECK(split.split_refused_faces == 0);  // far from a runaway (kAutoSplitMaxGrowth)
  CHECK_FALSE(split.split_discarded);
  CHECK(split.discarded_job_defects == -1);  // one job: the split one was valid
  CHECK(split.jobs.empty());
  // No edge of the clustered surface is longer than the limit.
  CHECK(longest_edge(split.surface) <= split.coarse_edge_length / kAutoSplitEdgesRatio * (1 + 1e-6));
  CHECK(longest_edge(plain.surface) > 5);

  check_valid(plain, n);
  check_valid(split, n);
  const TriangleQuality qp = triangle_quality(plain.job.coarse.mesh), qs = triangle_quality(split.job.coarse.mesh);
  CHECK(qs.q_avg > qp.q_avg + 0.05);
  CHECK(qs.angles_below_30 < qp.angles_below_30);

  // An explicit ratio splits at that ratio whatever the count.
  CoarsenSurfaceOptions three = with_n(n);
  three.split_edges = 3;
  const CoarsenSurfaceResult finer = coarsen_surface(cylinder, three);
  CHECK(finer.split_ratio == 3);
  CHECK(finer.surface.face_count() > split.surface.face_count());
  CHECK(longest_edge(finer.surface) <= finer.coarse_edge_length / 3 * (1 + 1e-6));
}

// Where auto refused to split `slivers` for n clusters (r): the surface as given, n vertices, and an
// explicit ratio refused at once instead of taking seconds and hundreds of MB.
static void check_split_left(const Mesh& slivers, uint32_t n, const CoarsenSurfaceResult& r) {
  CHECK(r.split_edges == 0);
  CHECK(r.split_ratio == 0);
  CHECK(r.surface.face_count() == slivers.face_count());
  CHECK(r.job.coarse.mesh.vertex_count() == n);
  CoarsenSurfaceOptions asked = with_n(n);
  asked.split_edges = kAutoSplitEdgesRatio;
  CHECK_THROWS_WITH_AS(coarsen_surface(slivers, asked), doctest::Contains("would make more than"), OptionError);
}

TEST_CASE("coarsen_surface: an input with fewer than 5 faces per cluster is split though few of its edges are long") {
  // A uniform sphere of 1280 faces at n = 400: none of its edges is longer than the coarse mesh's
  // edge, so the edge count alone does not split it; at 3.2 faces per cluster the clusters are one
  // to four faces each, too few to be round.
  const Mesh sphere = test::icosphere(3);
  const uint32_t n = 400;
  REQUIRE(double(sphere.face_count()) < kAutoSplitFacesPerCluster * n);
  CoarsenSurfaceOptions off = with_n(n);
  off.split_edges = 0;
  const CoarsenSurfaceResult plain = coarsen_surface(sphere, off);
  const CoarsenSurfaceResult split = coarsen_surface(sphere, with_n(n));
  CHECK(split.long_edges < n);
  CHECK(split.split_ratio == kAutoSplitEdgesRatio);
  CHECK(split.split_edges > 0);
  CHECK(split.surface.face_count() > sphere.face_count());
  CHECK(longest_edge(split.surface) <= split.coarse_edge_length / kAutoSplitEdgesRatio * (1 + 1e-6));
  CHECK(plain.split_edges == 0);
  check_valid(plain, n);
  check_valid(split, n);
  const TriangleQuality qp = triangle_quality(plain.job.coarse.mesh), qs = triangle_quality(split.job.coarse.mesh);
  CHECK(qs.q_avg > qp.q_avg + 0.02);
  CHECK(qs.min_angle_deg > qp.min_angle_deg);

  // At 5 faces per cluster and more, auto leaves it as given (as long as few edges are long).
  const CoarsenSurfaceResult five = coarsen_surface(sphere, with_n(sphere.face_count() / 5));
  CHECK(five.long_edges < sphere.face_count() / 5);
  CHECK(five.split_edges == 0);
  CHECK(five.surface.face_count() == sphere.face_count());

  // Far more vertices than faces: refused at once as before, not split toward an n it cannot reach
  // (99999999 from the elephant of tests/data ran out of memory).
  CHECK_THROWS_WITH_AS(coarsen_surface(sphere, with_n(99999999)), doctest::Contains("cannot make"), OptionError);
}

TEST_CASE("coarsen_surface: the split of slivers stops at its budget where the lower bound is far below") {
  // A double needle: apexes at x = 0 and 2, a triangle 1e-4 wide at x = 1 between them (six long
  // edges: enough for auto to split at n = 4). The bound (split_long_edges_min_faces) is within
  // the budget, but the longest-edge propagation along the needles makes many times the bound; the
  // stress sweep's case (a needle of 2048 faces, after qem's subdivision) split into 15 million
  // faces and clustered them for minutes.
  Mesh needle;
  needle.positions = {0, 0, 0, 1, 0, 0, 1, 1e-4f, 0, 1, 0, 1e-4f, 2, 0, 0};
  needle.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 4, 1, 2, 4, 2, 3, 4, 3, 1};
  const uint32_t n = 4;
  const CoarsenSurfaceResult r = coarsen_surface(needle, with_n(n));
  REQUIRE(r.coarse_edge_length > 0);
  const double budget = kAutoSplitMaxGrowth * double(needle.face_count());
  const double limit = r.coarse_edge_length / kAutoSplitEdgesRatio;
  CHECK(split_long_edges_min_faces(needle, limit) < budget);
  CHECK(split_long_edges(needle, limit).mesh.face_count() > budget);  // what the split makes, unchecked
  CHECK(r.split_refused_faces > budget);
  check_split_left(needle, n, r);
}

TEST_CASE("coarsen_surface: auto leaves the long edges of slivers as they are instead of running away") {
  // Ten faces 0.2 long and 1e-7 wide: their area makes the coarse edge 1.7e-4 long, so splitting
  // would make tens of thousands of faces (the libcgal-demo case it stands for: gigabytes).
  const Mesh needle = strip(5, 0.2, 1e-7);
  const uint32_t n = 4;
  const CoarsenSurfaceResult r = coarsen_surface(needle, with_n(n));
  CHECK(r.long_edges == 10);
  const double at_least = split_long_edges_min_faces(needle, r.coarse_edge_length / kAutoSplitEdgesRatio);
  CHECK(at_least > kAutoSplitMaxGrowth * double(needle.face_count()));
  CHECK(r.split_refused_faces == std::ceil(at_least));  // (faces: the bound rounded up)
  check_split_left(needle, n, r);
  // Thinner still, the bound passes what 32-bit indices allow (about 1.43e9 faces): auto still
  // leaves the edges, with the same note, rather than stopping the job with an error.
  const Mesh thinner = strip(5, 0.2, 1e-17);
  const CoarsenSurfaceResult t = coarsen_surface(thinner, with_n(n));
  CHECK(t.split_refused_faces > 1.5e9);
  check_split_left(thinner, n, t);
  // A strip as wide as it is long is no runaway: split as before.
  const Mesh wide = strip(5, 0.2, 3);
  const CoarsenSurfaceResult w = coarsen_surface(wide, with_n(n));
  CHECK(w.split_refused_faces == 0);
  CHECK(w.split_edges > 0);
}

TEST_CASE("coarsen_surface: a mesh without long edges is coarsened as given, as coarsen_mesh would") {
  const Mesh sphere = test::icosphere(3);  // 1280 faces
  const uint32_t n = 40;
  const CoarsenSurfaceResult r = coarsen_surface(sphere, with_n(n));
  CHECK(r.long_edges < n);
  CHECK(r.split_edges == 0);
  CHECK(r.subdivision_levels == 0);
  CHECK(r.surface.face_count() == sphere.face_count());
  check_valid(r, n);
  // Below 2^18 faces there is no locality order, so the surface is the input and coarsen_mesh on it
  // gives the same mesh.
  CoarsenMeshOptions job = with_n(n).job;
  const CoarsenMeshResult direct = coarsen_mesh(sphere, build_topology(sphere), job);
  CHECK(direct.coarse.mesh.positions == r.job.coarse.mesh.positions);
  CHECK(direct.coarse.mesh.indices == r.job.coarse.mesh.indices);
}

TEST_CASE("coarsen_surface: where the split surface keeps defects, the input as given is kept when it has fewer") {
  // The elephant stretched 4x along x, without fix rounds (so defects stay): at n = 400 the split
  // surface's coarse mesh has more defects than the input's as given.
  Mesh stretched = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  for (size_t v = 0; v < stretched.vertex_count(); ++v) stretched.positions[3 * v] *= 4;
  const uint32_t n = 400;
  CoarsenSurfaceOptions o = with_n(n);
  o.job.max_fix_rounds = 0;
  o.retry_subdivided = false;  // (tested on its own below)
  CoarsenSurfaceOptions off = o, forced = o;
  off.split_edges = 0;
  forced.split_edges = kAutoSplitEdgesRatio;
  const CoarsenSurfaceResult chosen = coarsen_surface(stretched, o);
  const CoarsenSurfaceResult as_given = coarsen_surface(stretched, off);
  const CoarsenSurfaceResult split = coarsen_surface(stretched, forced);
  REQUIRE(chosen.long_edges >= n);
  REQUIRE(split.job.coarse.defects.size() > as_given.job.coarse.defects.size());
  CHECK(chosen.split_discarded);
  // One component, broken split: no partly split job, the one as given kept.
  REQUIRE(chosen.jobs.size() == 2);
  CHECK(chosen.jobs[0].surface == CoarsenSurfaceJob::split);
  CHECK(chosen.jobs[1].surface == CoarsenSurfaceJob::as_given);
  CHECK(chosen.jobs[1].kept);
  // Each job's surface and first defects: what the split made, and (no fix rounds) its defects.
  CHECK(chosen.jobs[0].faces == split.surface.face_count());
  CHECK(chosen.jobs[1].faces == stretched.face_count());
  CHECK(chosen.jobs[0].faces > chosen.jobs[1].faces);
  CHECK(chosen.jobs[0].initial_defects == split.job.initial_defects);
  CHECK(chosen.jobs[0].initial_defects == chosen.jobs[0].defects);
  CHECK(chosen.jobs[1].initial_defects == as_given.job.initial_defects);
  CHECK(chosen.unsplit_components == 0);
  CHECK(chosen.split_edges == 0);
  CHECK(chosen.split_ratio == 0);
  CHECK(chosen.discarded_job_defects == int64_t(split.job.coarse.defects.size()));
  CHECK(chosen.discarded_seconds > 0);
  CHECK(chosen.surface.face_count() == stretched.face_count());
  CHECK(chosen.job.coarse.mesh.positions == as_given.job.coarse.mesh.positions);
  CHECK(chosen.job.coarse.mesh.indices == as_given.job.coarse.mesh.indices);
}

TEST_CASE("coarsen_surface: a component that keeps defects split is left as given, the others split") {
  // The CAD cylinder and a strip 0.5 wide of 10 quads 2 long. At n = 60 the strip gets 11 clusters
  // each wider than it: split, its clusters all meet both long sides (boundary_arcs); as given, its
  // own triangles make a valid strip. The cylinder needs the split.
  const Mesh both = test::combine(cad_cylinder(), strip(10, 2, 0.5), 0);
  const uint32_t n = 60;
  const CoarsenSurfaceResult r = coarsen_surface(both, with_n(n));
  REQUIRE(r.jobs.size() == 2);
  CHECK(r.jobs[0].surface == CoarsenSurfaceJob::split);
  CHECK(r.jobs[0].defects > 0);
  CHECK_FALSE(r.jobs[0].kept);
  CHECK(r.jobs[1].surface == CoarsenSurfaceJob::partly_split);
  CHECK(r.jobs[1].defects == 0);
  CHECK(r.jobs[1].kept);
  CHECK(r.unsplit_components == 1);
  CHECK_FALSE(r.split_discarded);
  CHECK(r.discarded_job_defects == int64_t(r.jobs[0].defects));
  CHECK(r.split_edges > 0);
  check_valid(r, n);
  // The strip's 20 triangles are in the surface as they were (z = 0, x >= 3), the cylinder split.
  size_t strip_faces = 0;
  for (size_t f = 0; f < r.surface.face_count(); ++f) {
    bool on_strip = true;
    for (int k = 0; k < 3; ++k) {
      const float* p = &r.surface.positions[3 * size_t(r.surface.indices[3 * f + k])];
      on_strip = on_strip && p[0] >= 3 && p[2] == 0;
    }
    strip_faces += on_strip;
  }
  CHECK(strip_faces == 20);
  CHECK(r.surface.face_count() > both.face_count() + 1000);
  // Better than coarsening it all as given.
  CoarsenSurfaceOptions off = with_n(n);
  off.split_edges = 0;
  const CoarsenSurfaceResult as_given = coarsen_surface(both, off);
  CHECK(triangle_quality(r.job.coarse.mesh).q_avg > triangle_quality(as_given.job.coarse.mesh).q_avg + 0.05);
}

TEST_CASE("coarsen_surface: the partial fallback finds the broken component past a subdivided lone triangle") {
  // As above, with ten lone triangles first and the strip next: the triangles are subdivided in
  // every job (30 faces more before all the others), so the split surface's broken component (the
  // strip) is found only through the subdivision's parents, and the strip alone is left as given.
  Mesh lone;
  for (uint32_t i = 0; i < 10; ++i) {
    const uint32_t a = test::add_vertex(lone, -10, i, 0), b = test::add_vertex(lone, -9.7, i, 0),
                   c = test::add_vertex(lone, -10, i + 0.3, 0);
    test::add_triangle(lone, a, b, c);
  }
  const Mesh all = test::combine(test::combine(lone, strip(10, 2, 0.5), 0), cad_cylinder(), 0);
  const uint32_t n = 90;
  const CoarsenSurfaceResult r = coarsen_surface(all, tracked(n));
  REQUIRE(r.jobs.size() == 2);
  CHECK(r.jobs[0].defects > 0);
  CHECK(r.jobs[1].surface == CoarsenSurfaceJob::partly_split);
  CHECK(r.jobs[1].defects == 0);
  CHECK(r.jobs[1].kept);
  CHECK(r.unsplit_components == 1);
  CHECK(r.refined_components == 10);
  check_valid(r, n);
  check_origin(all, r);
  // The strip's 20 triangles as they were, each lone triangle in 4.
  size_t strip_faces = 0, lone_faces = 0;
  for (size_t f = 0; f < r.surface.face_count(); ++f) {
    bool on_strip = true, on_lone = true;
    for (int k = 0; k < 3; ++k) {
      const float* p = &r.surface.positions[3 * size_t(r.surface.indices[3 * f + k])];
      on_strip = on_strip && p[0] >= 3 && p[2] == 0;
      on_lone = on_lone && p[0] <= -9;
    }
    strip_faces += on_strip;
    lone_faces += on_lone;
  }
  CHECK(strip_faces == 20);
  CHECK(lone_faces == 40);
}

TEST_CASE("coarsen_surface: where defects remain, the input subdivided once is tried and kept if it has fewer") {
  // The retry coarsens the input subdivided once, as subdivide = 1 would, and keeps the result
  // with fewer defects; none runs when a subdivision is asked for, retry_subdivided is off or the
  // surface subdivided would have more than max_retry_faces faces.
  auto check_retry = [](const Mesh& mesh, CoarsenSurfaceOptions o) {
    CoarsenSurfaceOptions no_retry = o, once = o, explicit_zero = o;
    no_retry.retry_subdivided = false;
    once.subdivide = 1;
    explicit_zero.subdivide = 0;
    o.keep_surface_origin = true;  // (changes nothing else; checked below through the retry)
    const CoarsenSurfaceResult r = coarsen_surface(mesh, o);
    const CoarsenSurfaceResult plain = coarsen_surface(mesh, no_retry);
    const CoarsenSurfaceResult finer = coarsen_surface(mesh, once);
    const size_t a = plain.job.coarse.defects.size(), b = finer.job.coarse.defects.size();
    MESSAGE("defects as given " << a << ", subdivided once " << b);
    REQUIRE(a > 0);
    CHECK(plain.jobs.empty());
    CHECK(coarsen_surface(mesh, explicit_zero).jobs.empty());
    REQUIRE(r.jobs.size() == 2);
    CHECK(r.jobs[0].surface == CoarsenSurfaceJob::as_given);
    CHECK(r.jobs[0].defects == a);
    CHECK(r.jobs[1].surface == CoarsenSurfaceJob::subdivided);
    CHECK(r.jobs[1].defects == b);
    CHECK(r.job.coarse.defects.size() == std::min(a, b));
    CHECK(r.retried_subdivided == (b < a));
    CHECK(r.jobs[1].kept == (b < a));
    CHECK(r.jobs[0].kept == !(b < a));
    CHECK(r.surface.face_count() == (b < a ? 4 : 1) * mesh.face_count());
    CHECK(r.job.coarse.mesh.vertex_count() == o.job.cluster.clusters);
    if (b < a) CHECK(r.job.coarse.mesh.positions == finer.job.coarse.mesh.positions);
    CHECK(r.discarded_job_defects == int64_t(std::max(a, b)));
    check_origin(mesh, r);
    // The limit is on the surface subdivided: four times the faces.
    CoarsenSurfaceOptions at_limit = o, below = o;
    at_limit.max_retry_faces = 4 * mesh.face_count();
    below.max_retry_faces = 4 * mesh.face_count() - 1;
    CHECK(coarsen_surface(mesh, at_limit).jobs.size() == 2);
    CHECK(coarsen_surface(mesh, below).jobs.empty());
  };
  const Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  SUBCASE("the elephant without fix rounds") {
    CoarsenSurfaceOptions o = with_n(300);
    o.job.max_fix_rounds = 0;
    check_retry(elephant, o);
  }
  SUBCASE("the elephant with a fin of six triangles on one of its edges (a non-manifold edge)") {
    Mesh fin = elephant;
    const uint32_t a = fin.indices[0], b = fin.indices[1], nv = uint32_t(fin.vertex_count());
    const float* p = &elephant.positions[3 * size_t(a)];
    for (int i = 0; i < 6; ++i) test::add_vertex(fin, p[0] + 0.01 * (i + 1), p[1] + 0.05, p[2] + 0.01 * (6 - i));
    uint32_t previous = b;
    for (uint32_t i = 0; i < 6; ++i) {
      test::add_triangle(fin, a, previous, nv + i);
      previous = nv + i;
    }
    check_retry(fin, with_n(100));
  }
}

TEST_CASE("coarsen_surface: subdivision by placement, auto and levels") {
  const Mesh sphere = test::icosphere(1);  // 80 faces
  const uint32_t n = 20;
  CoarsenSurfaceOptions o = with_n(n);
  o.split_edges = 0;
  SUBCASE("projected takes the input as given by default") {
    const CoarsenSurfaceResult r = coarsen_surface(sphere, o);
    CHECK(r.subdivision_levels == 0);
    CHECK(r.subdivided_faces == 80);
    check_valid(r, n);
  }
  SUBCASE("qem subdivides to 20 faces per cluster by default: 80 x 4^2 >= 400") {
    o.job.coarsen.placement = VertexPlacement::qem;
    const CoarsenSurfaceResult r = coarsen_surface(sphere, o);
    CHECK(r.subdivision_levels == subdivision_levels_for(80, n, subdivision_faces_per_cluster(VertexPlacement::qem)));
    CHECK(r.subdivision_levels == 2);
    CHECK(r.surface.face_count() == 1280);
    check_valid(r, n);
  }
  SUBCASE("auto with projected: 10 faces per cluster, 80 x 4 >= 200") {
    o.subdivide = kSubdivideAuto;
    CHECK(coarsen_surface(sphere, o).subdivision_levels == 1);
  }
  SUBCASE("one level") {
    o.subdivide = 1;
    const CoarsenSurfaceResult r = coarsen_surface(sphere, o);
    CHECK(r.subdivision_levels == 1);
    CHECK(r.surface.face_count() == 320);
    check_valid(r, n);
  }
}

TEST_CASE("coarsen_surface: a caller's density sets the split's limits and follows the faces split from each face") {
  // Density 4 on the top cap, 1 elsewhere: the top cap's faces are split at 1 / sqrt 2 of the length
  // (coarse_edge_length goes as density^-1/4), and the clustering weighs each piece by its face's
  // density.
  const Mesh cylinder = cad_cylinder();
  const uint32_t n = 80;
  CoarsenSurfaceOptions o = with_n(n);
  std::vector<float>& density = o.job.cluster.density;
  for (size_t f = 0; f < cylinder.face_count(); ++f) {
    bool top = true;
    for (int k = 0; k < 3; ++k) top = top && cylinder.positions[3 * size_t(cylinder.indices[3 * f + k]) + 2] > 5.9f;
    density.push_back(top ? 4.0f : 1.0f);
  }
  const CoarsenSurfaceResult r = coarsen_surface(cylinder, o);
  REQUIRE(r.split_edges > 0);
  check_valid(r, n);
  // The longest edge on each cap.
  auto cap_edges = [](const Mesh& m, bool top) {
    Mesh cap;
    cap.positions = m.positions;
    for (size_t f = 0; f < m.face_count(); ++f) {
      bool on = true;
      for (int k = 0; k < 3; ++k) {
        const float z = m.positions[3 * size_t(m.indices[3 * f + k]) + 2];
        on = on && (top ? z > 5.999f : z < 0.001f);
      }
      if (on) cap.indices.insert(cap.indices.end(), &m.indices[3 * f], &m.indices[3 * f] + 3);
    }
    return longest_edge(cap);
  };
  // The area weighted by sqrt(density), 2 on the top cap.
  double area = 0;
  for (size_t f = 0; f < cylinder.face_count(); ++f) area += face_area(cylinder, f) * std::sqrt(density[f]);
  const double limit = coarse_edge_length(area, n) / kAutoSplitEdgesRatio;
  CHECK(r.coarse_edge_length == doctest::Approx(coarse_edge_length(area, n)));
  CHECK(cap_edges(r.surface, true) <= limit / std::sqrt(2.0) * (1 + 1e-6));
  CHECK(cap_edges(r.surface, false) > limit / std::sqrt(2.0) * 1.1);
  CHECK(cap_edges(r.surface, false) <= limit * (1 + 1e-6));

  // The job is coarsen_mesh on the split surface with each piece's parent's density (below 2^18
  // faces there is no locality order).
  std::vector<double> face_limit;
  for (float d : density) face_limit.push_back(coarse_edge_length(area, n, d) / kAutoSplitEdgesRatio);
  const SplitEdgesResult split = split_long_edges(cylinder, limit, face_limit);
  CHECK(split.mesh.indices == r.surface.indices);
  CoarsenMeshOptions job = o.job;
  job.cluster.density.clear();
  for (uint32_t parent : split.parent) job.cluster.density.push_back(density[parent]);
  const CoarsenMeshResult direct = coarsen_mesh(split.mesh, build_topology(split.mesh), job);
  CHECK(direct.clustering.labels == r.job.clustering.labels);
  CHECK(direct.coarse.mesh.positions == r.job.coarse.mesh.positions);
  // and not the result of a uniform density on it.
  job.cluster.density.clear();
  const CoarsenMeshResult uniform = coarsen_mesh(split.mesh, build_topology(split.mesh), job);
  CHECK(uniform.clustering.labels != r.job.clustering.labels);
}

TEST_CASE("coarsen_surface: collapsed faces are left out first, with their density entries") {
  // Seven collapsed faces put before the sphere's, with densities of their own: the result is
  // that of the sphere alone with its faces' densities.
  const Mesh sphere = test::icosphere(3);
  const Mesh appended = test::with_collapsed_faces(sphere, 7, 97);
  Mesh with = sphere;
  with.indices.assign(appended.indices.begin() + 3 * sphere.face_count(), appended.indices.end());
  with.indices.insert(with.indices.end(), sphere.indices.begin(), sphere.indices.end());
  REQUIRE(with.face_count() == sphere.face_count() + 7);
  CoarsenSurfaceOptions alone = with_n(40), o = with_n(40);
  for (size_t f = 0; f < sphere.face_count(); ++f) alone.job.cluster.density.push_back(1.0f + float(f % 5));
  o.job.cluster.density.assign(7, 100.0f);
  o.job.cluster.density.insert(o.job.cluster.density.end(), alone.job.cluster.density.begin(),
                               alone.job.cluster.density.end());
  const CoarsenSurfaceResult r = coarsen_surface(with, o), expected = coarsen_surface(sphere, alone);
  CHECK(r.collapsed_faces == 7);
  CHECK(r.input_faces == sphere.face_count());
  CHECK(r.surface.indices == sphere.indices);
  check_valid(r, 40);
  CHECK(r.job.coarse.mesh.positions == expected.job.coarse.mesh.positions);
  CHECK(r.job.coarse.mesh.indices == expected.job.coarse.mesh.indices);
}

TEST_CASE("coarsen_surface: same result for any thread count") {
  const Mesh cylinder = cad_cylinder();
  CoarsenSurfaceOptions one = with_n(60), three = with_n(60);
  one.job.cluster.threads = one.job.coarsen.threads = 1;
  three.job.cluster.threads = three.job.coarsen.threads = 3;
  const CoarsenSurfaceResult a = coarsen_surface(cylinder, one), b = coarsen_surface(cylinder, three);
  CHECK(a.split_edges == b.split_edges);
  CHECK(a.coarse_edge_length == b.coarse_edge_length);
  CHECK(a.job.coarse.mesh.positions == b.job.coarse.mesh.positions);
  CHECK(a.job.coarse.mesh.indices == b.job.coarse.mesh.indices);
}

TEST_CASE("coarsen_surface: errors") {
  const Mesh sphere = test::icosphere(1);  // 80 faces
  auto fails = [&](CoarsenSurfaceOptions o, const std::string& part) {
    try {
      coarsen_surface(sphere, o);
      FAIL("no error for " << part);
    } catch (const OptionError& e) {
      CHECK_MESSAGE(std::string(e.what()).find(part) != std::string::npos, e.what());
    }
  };
  CoarsenSurfaceOptions o = with_n(20);
  o.gradation = -1;
  fails(o, "gradation");
  o = with_n(20);
  o.gradation = NAN;
  fails(o, "gradation");
  o = with_n(20);
  o.subdivide = 7;
  fails(o, "subdivide");
  o = with_n(20);
  o.split_edges = 17;
  fails(o, "split_edges");
  o = with_n(20);
  o.split_edges = -0.5;
  fails(o, "split_edges");
  o = with_n(20);
  o.job.cluster.density.assign(79, 1.0f);
  fails(o, "79 entries for 80 faces");
  o = with_n(20);
  o.job.cluster.density.assign(80, 1.0f);
  o.gradation = 1;
  fails(o, "both");
  o = with_n(100);
  o.split_edges = 0;
  fails(o, "100 vertices from the 80 faces");

  Mesh collapsed;
  for (int i = 0; i < 3; ++i) test::add_vertex(collapsed, i, 0, 0);
  test::add_triangle(collapsed, 0, 0, 1);
  CHECK_THROWS_AS(coarsen_surface(collapsed, with_n(4)), Error);
}

TEST_CASE("coarsen_surface: a component with fewer faces than it needs clusters is subdivided, not refused") {
  // A sphere of 320 faces and, apart from it, a lone triangle: a disk needs 3 clusters and has
  // one face, so coarsen_mesh alone refuses the mesh.
  Mesh m = test::icosphere(2);
  const size_t sphere_faces = m.face_count();
  const uint32_t a = test::add_vertex(m, 3, 0, 0), b = test::add_vertex(m, 3.3, 0, 0), c = test::add_vertex(m, 3, 0.3, 0);
  test::add_triangle(m, a, b, c);
  const uint32_t n = 30;

  CoarsenSurfaceOptions off = with_n(n);
  off.refine_small_components = false;
  try {
    coarsen_surface(m, off);
    FAIL("no error without the refinement");
  } catch (const OptionError& e) {
    CHECK_MESSAGE(std::string(e.what()).find("fewer than the 3 clusters") != std::string::npos, e.what());
  }

  const CoarsenSurfaceResult r = coarsen_surface(m, with_n(n));
  CHECK(r.refined_components == 1);
  CHECK(r.refined_with_them == 0);
  CHECK(r.refined_faces == 1);
  CHECK(r.surface.face_count() == sphere_faces + 4);  // one level: 4 faces for 3 clusters
  check_valid(r, n);
  const MeshInfo out = mesh_info(r.job.coarse.mesh, build_topology(r.job.coarse.mesh));
  CHECK(out.components == 2);
  CHECK(out.boundary_loops == 1);
  // The lone triangle's part holds 3 of the clusters.
  CHECK(std::count(r.job.allocation.clusters.begin(), r.job.allocation.clusters.end(), 3u) == 1);

  // A fin on one of the sphere's edges (a non-manifold edge): the sphere's two faces on that edge
  // are split at its midpoint with the fin, else it would be a T-junction in the sphere; the rest
  // of the sphere is left as it is.
  Mesh fin = test::icosphere(2);
  const uint32_t u = fin.indices[0], v = fin.indices[1];
  const uint32_t w = test::add_vertex(fin, 2 * fin.positions[3 * u], 2 * fin.positions[3 * u + 1],
                                      2 * fin.positions[3 * u + 2]);
  test::add_triangle(fin, u, v, w);
  CoarsenSurfaceOptions keep = with_n(n);
  keep.keep_surface_origin = true;
  const CoarsenSurfaceResult rf = coarsen_surface(fin, keep);
  CHECK(rf.refined_components == 1);
  CHECK(rf.refined_with_them == 1);  // the sphere, reported as such
  CHECK(rf.refined_faces == 3);      // the fin, and the sphere's two faces on its edge
  CHECK(rf.surface.face_count() == sphere_faces + 4 + 2);
  std::vector<uint32_t> pieces(fin.face_count(), 0);
  for (uint32_t g : rf.surface_origin) ++pieces[g];
  CHECK(pieces.back() == 4);
  CHECK(std::count(pieces.begin(), pieces.end(), 2u) == 2);
  CHECK(std::count(pieces.begin(), pieces.end(), 1u) == int(sphere_faces) - 2);
  // (Not check_valid: the dual cannot keep a non-manifold edge, so the loops may differ, as the
  // CLI's note says.)
  CHECK(rf.job.coarse.defects.empty());
  CHECK(rf.job.coarse.mesh.vertex_count() == n);
  const MeshInfo coarse = mesh_info(rf.job.coarse.mesh, build_topology(rf.job.coarse.mesh));
  CHECK(coarse.components == 2);
  CHECK(coarse.nonmanifold_edges == 0);
  CHECK(coarse.nonmanifold_vertices == 0);
  const Topology tf = build_topology(rf.surface);
  const MeshInfo fine = mesh_info(rf.surface, tf);
  CHECK(fine.nonmanifold_edges == 2);  // the fin's edge, in two halves
  CHECK(fine.boundary_edges == 4);     // the fin's other two edges, in halves: no T-junction
  CHECK(fine.euler_characteristic == mesh_info(fin, build_topology(fin)).euler_characteristic);

  // Two faces on the same three corners (a closed pillow of no volume, which needs 4 clusters)
  // come apart at their non-manifold edges when subdivided: no number of levels helps, and the
  // error says so.
  Mesh pillow = test::icosphere(2);
  const uint32_t p = test::add_vertex(pillow, 3, 0, 0), q = test::add_vertex(pillow, 3.3, 0, 0),
                 s = test::add_vertex(pillow, 3, 0.3, 0);
  test::add_triangle(pillow, p, q, s);
  test::add_triangle(pillow, p, s, q);
  try {
    coarsen_surface(pillow, with_n(n));
    FAIL("no error for the pillow");
  } catch (const OptionError& e) {
    CHECK_MESSAGE(std::string(e.what()).find("comes apart") != std::string::npos, e.what());
  }
}


TEST_CASE("input_face_clusters: the coarse vertex of every input face, as clustered, subdivided, split or collapsed") {
  // As given (no split, no reorder below 2^18 faces): the clustering's own labels.
  const Mesh sphere = test::icosphere(3);
  const CoarsenSurfaceResult plain = coarsen_surface(sphere, tracked(40));
  check_origin(sphere, plain);
  CHECK(input_face_clusters(sphere, plain) == plain.job.clustering.labels);

  // Subdivided once: children 4f..4f+3 of face f have equal areas (to float rounding), so f takes
  // a label that most of them have (two and two: either, as their rounded areas decide).
  CoarsenSurfaceOptions once = tracked(40);
  once.subdivide = 1;
  const CoarsenSurfaceResult sub = coarsen_surface(sphere, once);
  check_origin(sphere, sub);
  const std::vector<uint32_t> labels = input_face_clusters(sphere, sub);
  REQUIRE(labels.size() == sphere.face_count());
  size_t mixed = 0;
  for (size_t f = 0; f < sphere.face_count(); ++f) {
    const uint32_t* child = &sub.job.clustering.labels[4 * f];
    long best_count = 0;
    for (int k = 0; k < 4; ++k) best_count = std::max(best_count, long(std::count(child, child + 4, child[k])));
    CHECK(std::count(child, child + 4, labels[f]) == best_count);
    mixed += best_count < 4;
  }
  CHECK(mixed > 0);  // some faces straddle a border: the majority rule was exercised

  // Split (the CAD cylinder's long faces): every face's pieces are found, and its label is that of
  // at least one of them; every cluster id is below n.
  const Mesh cylinder = cad_cylinder();
  const CoarsenSurfaceResult split = coarsen_surface(cylinder, tracked(60));
  REQUIRE(split.split_edges > 0);
  check_origin(cylinder, split);
  const std::vector<uint32_t> cyl = input_face_clusters(cylinder, split);
  REQUIRE(cyl.size() == cylinder.face_count());
  for (size_t f = 0; f < cylinder.face_count(); ++f) {
    CHECK(cyl[f] < 60);
    bool found = false;
    for (size_t i = 0; i < split.surface_origin.size() && !found; ++i)
      found = split.surface_origin[i] == f && split.job.clustering.labels[i] == cyl[f];
    CHECK(found);
  }

  // Collapsed faces (after the sphere's): each takes the label of the lowest face at its lowest corner.
  const Mesh with = test::with_collapsed_faces(sphere, 5, 61);
  const CoarsenSurfaceResult rc = coarsen_surface(with, tracked(40));
  REQUIRE(rc.collapsed_faces == 5);
  check_origin(with, rc);
  const std::vector<uint32_t> lc = input_face_clusters(with, rc);
  CHECK(lc == test::labels_at_lowest_corners(with, rc.job.clustering.labels));

  // A lone triangle subdivided for its clusters: its 4 pieces name it.
  Mesh lone = sphere;
  const uint32_t a = test::add_vertex(lone, 3, 0, 0), b = test::add_vertex(lone, 3.3, 0, 0), c = test::add_vertex(lone, 3, 0.3, 0);
  test::add_triangle(lone, a, b, c);
  const CoarsenSurfaceResult rl = coarsen_surface(lone, tracked(40));
  REQUIRE(rl.refined_components == 1);
  check_origin(lone, rl);
  CHECK(input_face_clusters(lone, rl).size() == lone.face_count());

  CHECK_THROWS_AS(input_face_clusters(cylinder, plain), OptionError);
  // Without keep_surface_origin there is nothing to go by.
  const CoarsenSurfaceResult untracked = coarsen_surface(sphere, with_n(40));
  CHECK(untracked.surface_origin.empty());
  CHECK(untracked.job.coarse.mesh.positions == plain.job.coarse.mesh.positions);
  CHECK_THROWS_AS(input_face_clusters(sphere, untracked), OptionError);
}

TEST_CASE("input_face_clusters: the cluster with the largest area of a face's pieces, ties to the lower id") {
  // One face of the mesh given, in pieces made by hand (a result as coarsen_surface would fill it).
  Mesh given;
  test::add_vertex(given, 0, 0, 0);
  test::add_vertex(given, 4, 0, 0);
  test::add_vertex(given, 0, 4, 0);
  test::add_triangle(given, 0, 1, 2);
  auto result_of = [&](const Mesh& pieces, std::vector<uint32_t> labels) {
    CoarsenSurfaceResult r;
    r.given_faces = 1;
    r.surface = pieces;
    r.surface_origin.assign(pieces.face_count(), 0);
    r.job.clustering.labels = std::move(labels);
    return r;
  };
  // Subdivided: three of the four equal children in cluster 2, the last (the middle one) in 5.
  const Mesh four = subdivide_midpoint(given, 1);
  CHECK(input_face_clusters(given, result_of(four, {2, 2, 2, 5})) == std::vector<uint32_t>{2});
  CHECK(input_face_clusters(given, result_of(four, {5, 2, 2, 2})) == std::vector<uint32_t>{2});
  // Two and two of equal area (exactly: the corners are small integers): the lower id.
  CHECK(input_face_clusters(given, result_of(four, {9, 4, 9, 4})) == std::vector<uint32_t>{4});
  // Two pieces split at (1, 3) on the long edge: areas 2 and 6; the larger wins whatever the order.
  Mesh two = given;
  const uint32_t m = test::add_vertex(two, 1, 3, 0);
  two.indices = {0, 1, m, 0, m, 2};
  CHECK(input_face_clusters(given, result_of(two, {7, 3})) == std::vector<uint32_t>{7});
  CHECK(input_face_clusters(given, result_of(two, {3, 7})) == std::vector<uint32_t>{3});
  // Origins that are not faces of the mesh given are refused.
  CoarsenSurfaceResult bad = result_of(two, {3, 7});
  bad.surface_origin[1] = 1;
  CHECK_THROWS_AS(input_face_clusters(given, bad), OptionError);
}
