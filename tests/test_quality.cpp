// Tests for triangle quality (Table 1 of Fan et al.) and the surface distance (meshcvt/quality.h),
// on meshes built in code whose answers follow from elementary geometry.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/quality.h"

using meshcvt::Mesh;

namespace {

constexpr double kPi = std::numbers::pi;

Mesh triangle(double ax, double ay, double bx, double by, double cx, double cy) {
  Mesh m;
  m.positions = {float(ax), float(ay), 0, float(bx), float(by), 0, float(cx), float(cy), 0};
  m.indices = {0, 1, 2};
  return m;
}

// Frey-Borouchaki Q from the three edge lengths (Heron for the area), independent of the library.
double q_from_lengths(double a, double b, double c) {
  double s = 0.5 * (a + b + c);
  double area = std::sqrt(s * (s - a) * (s - b) * (s - c));
  return 6.0 / std::sqrt(3.0) * area / (s * std::max({a, b, c}));
}

Mesh tetrahedron() {
  Mesh m;
  m.positions = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  m.indices = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  return m;
}

Mesh octahedron() {
  Mesh m;
  m.positions = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
  m.indices = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
  return m;
}

// An n x n grid of squares (each split in two) over [x0, x1] x [y0, y1] in the plane z.
Mesh grid(int n, double x0, double x1, double y0, double y1, double z) {
  Mesh m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m.positions.push_back(float(x0 + (x1 - x0) * i / n));
      m.positions.push_back(float(y0 + (y1 - y0) * j / n));
      m.positions.push_back(float(z));
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t v = uint32_t(j * (n + 1) + i), w = v + uint32_t(n + 1);
      m.indices.insert(m.indices.end(), {v, v + 1, w + 1, v, w + 1, w});
    }
  return m;
}

}  // namespace

TEST_CASE("triangle_quality: equilateral triangle") {
  Mesh m = triangle(0, 0, 2, 0, 1, std::sqrt(3.0));
  meshcvt::TriangleQuality q = meshcvt::triangle_quality(m);
  CHECK(q.faces == 1);
  CHECK(q.min_angle_deg == doctest::Approx(60).epsilon(1e-6));
  CHECK(q.max_angle_deg == doctest::Approx(60).epsilon(1e-6));
  CHECK(q.avg_min_angle_deg == doctest::Approx(60).epsilon(1e-6));
  CHECK(q.angles_below_30 == 0);
  CHECK(q.q_min == doctest::Approx(1).epsilon(1e-6));
  CHECK(q.q_avg == doctest::Approx(1).epsilon(1e-6));
  CHECK(q.total_area == doctest::Approx(std::sqrt(3.0)).epsilon(1e-6));
  CHECK(q.degenerate_faces == 0);
}

TEST_CASE("triangle_quality: right isosceles, 30-60-90 and thin triangles") {
  SUBCASE("right isosceles: angles 45, 45, 90") {
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(triangle(0, 0, 1, 0, 0, 1));
    CHECK(q.min_angle_deg == doctest::Approx(45));
    CHECK(q.max_angle_deg == doctest::Approx(90));
    CHECK(q.angles_below_30 == 0);
    double expected = q_from_lengths(1, 1, std::sqrt(2.0));
    CHECK(expected < 0.9);  // the formula really distinguishes it from the equilateral
    CHECK(q.q_min == doctest::Approx(expected).epsilon(1e-7));
  }
  SUBCASE("angles 29, 61, 90: one corner below 30") {
    double t = std::tan(29.0 * kPi / 180);
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(triangle(0, 0, 1, 0, 0, t));
    CHECK(q.min_angle_deg == doctest::Approx(29).epsilon(1e-6));
    CHECK(q.angles_below_30 == 1);
    CHECK(q.q_min == doctest::Approx(q_from_lengths(1, t, std::hypot(1.0, t))).epsilon(1e-6));
  }
  SUBCASE("angles 31, 59, 90: none below 30") {
    double t = std::tan(31.0 * kPi / 180);
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(triangle(0, 0, 1, 0, 0, t));
    CHECK(q.min_angle_deg == doctest::Approx(31).epsilon(1e-6));
    CHECK(q.angles_below_30 == 0);
  }
  SUBCASE("obtuse sliver: two corners below 30, Q small") {
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(triangle(0, 0, 1, 0, 0.5, 0.05));
    CHECK(q.angles_below_30 == 2);
    double expected_min = std::atan2(0.05, 0.5) * 180 / kPi;
    CHECK(q.min_angle_deg == doctest::Approx(expected_min).epsilon(1e-6));
    CHECK(q.max_angle_deg == doctest::Approx(180 - 2 * expected_min).epsilon(1e-6));
    CHECK(q.q_min == doctest::Approx(q_from_lengths(1, std::hypot(0.5, 0.05), std::hypot(0.5, 0.05))).epsilon(1e-6));
  }
  SUBCASE("degenerate triangle: Q = 0, counted") {
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(triangle(0, 0, 1, 0, 2, 0));
    CHECK(q.q_min == 0);
    CHECK(q.degenerate_faces == 1);
    CHECK(q.min_angle_deg == 0);
    CHECK(q.angles_below_30 == 2);
  }
}

TEST_CASE("triangle_quality: minimum, average and counts over several triangles") {
  // Equilateral (min 60, Q 1), right isosceles (min 45), 20-70-90 (min 20, one corner < 30).
  Mesh m;
  double t20 = std::tan(20.0 * kPi / 180);
  m.positions = {0, 0, 0, 2, 0, 0, 1, float(std::sqrt(3.0)), 0,         // 0 1 2
                 10, 0, 0, 11, 0, 0, 10, 1, 0,                          // 3 4 5
                 20, 0, 0, 21, 0, 0, 20, float(t20), 0};                // 6 7 8
  m.indices = {0, 1, 2, 3, 4, 5, 6, 7, 8};
  meshcvt::TriangleQuality q = meshcvt::triangle_quality(m);
  CHECK(q.faces == 3);
  CHECK(q.min_angle_deg == doctest::Approx(20).epsilon(1e-5));
  CHECK(q.avg_min_angle_deg == doctest::Approx((60 + 45 + 20) / 3.0).epsilon(1e-5));
  CHECK(q.angles_below_30 == 1);
  double q20 = q_from_lengths(1, t20, std::hypot(1.0, t20));
  CHECK(q.q_min == doctest::Approx(q20).epsilon(1e-5));
  CHECK(q.q_avg == doctest::Approx((1 + q_from_lengths(1, 1, std::sqrt(2.0)) + q20) / 3).epsilon(1e-5));
}

TEST_CASE("triangle_quality: valence histograms") {
  SUBCASE("tetrahedron: four interior vertices of valence 3") {
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(tetrahedron());
    CHECK(q.referenced_vertices == 4);
    CHECK(q.valence_histogram == std::vector<uint64_t>{0, 0, 0, 4});
    CHECK(q.interior_valence_histogram == std::vector<uint64_t>{0, 0, 0, 4});
    CHECK(q.min_angle_deg == doctest::Approx(60));  // regular: all faces equilateral
    CHECK(q.q_min == doctest::Approx(1));
  }
  SUBCASE("octahedron: six vertices of valence 4") {
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(octahedron());
    CHECK(q.valence_histogram == std::vector<uint64_t>{0, 0, 0, 0, 6});
    CHECK(q.interior_valence_histogram == q.valence_histogram);
  }
  SUBCASE("grid: boundary vertices are not interior; an unreferenced vertex is not counted") {
    Mesh m = grid(3, 0, 1, 0, 1, 0);  // 16 vertices, 4 interior of valence 6
    m.positions.insert(m.positions.end(), {5, 5, 5});
    meshcvt::TriangleQuality q = meshcvt::triangle_quality(m);
    CHECK(q.referenced_vertices == 16);
    uint64_t total = 0;
    for (uint64_t c : q.valence_histogram) total += c;
    CHECK(total == 16);
    // Corners: (0,0) and (n,n) have valence 3 (diagonal), the other two 2; edge vertices 4.
    CHECK(q.valence_histogram == std::vector<uint64_t>{0, 0, 2, 2, 8, 0, 4});
    CHECK(q.interior_valence_histogram == std::vector<uint64_t>{0, 0, 0, 0, 0, 0, 4});
  }
}

TEST_CASE("triangle_quality: empty mesh") {
  meshcvt::TriangleQuality q = meshcvt::triangle_quality(Mesh{});
  CHECK(q.faces == 0);
  CHECK(q.valence_histogram.empty());
}

TEST_CASE("approximation_error: a mesh against itself is 0") {
  Mesh m = octahedron();
  meshcvt::ApproximationError e = meshcvt::approximation_error(m, m, 20000);
  CHECK(e.hausdorff < 1e-6);
  CHECK(e.rms < 1e-6);
  CHECK(e.diagonal == doctest::Approx(std::sqrt(12.0)));
  CHECK(e.samples == 20000);
  CHECK(e.points == 2 * 20000 + 12);
}

TEST_CASE("approximation_error: a plane against the plane shifted along its normal") {
  const double shift = 0.25;
  Mesh a = grid(6, 0, 1, 0, 2, 0), ref = grid(4, 0, 1, 0, 2, shift);
  meshcvt::ApproximationError e = meshcvt::approximation_error(a, ref, 30000);
  CHECK(e.hausdorff == doctest::Approx(shift).epsilon(1e-6));
  CHECK(e.rms == doctest::Approx(shift).epsilon(1e-6));
  CHECK(e.a_to_b_max == doctest::Approx(shift).epsilon(1e-6));
  CHECK(e.b_to_a_rms == doctest::Approx(shift).epsilon(1e-6));
  CHECK(e.a_to_b_mean == doctest::Approx(shift).epsilon(1e-6));
  double diagonal = std::sqrt(1.0 + 4.0);  // the reference's box is 1 x 2 x 0
  CHECK(e.diagonal == doctest::Approx(diagonal));
  CHECK(e.hausdorff_rel == doctest::Approx(shift / diagonal).epsilon(1e-6));
  CHECK(e.rms_rel == doctest::Approx(shift / diagonal).epsilon(1e-6));
}

TEST_CASE("approximation_error: one surface contained in the other, in the same plane") {
  // a = [0,1]^2 lies inside ref = [0,2] x [0,1]: a -> ref is 0; from ref to a the distance is
  // max(0, x - 1), so the max is 1 (at x = 2), the mean over ref is 1/4 and the mean square 1/6.
  Mesh a = grid(5, 0, 1, 0, 1, 0), ref = grid(8, 0, 2, 0, 1, 0);
  meshcvt::ApproximationError e = meshcvt::approximation_error(a, ref, 60000);
  CHECK(e.a_to_b_max < 1e-6);
  CHECK(e.b_to_a_max == doctest::Approx(1).epsilon(1e-9));  // reached at the vertices x = 2
  CHECK(e.hausdorff == doctest::Approx(1).epsilon(1e-9));
  CHECK(e.b_to_a_mean == doctest::Approx(0.25).epsilon(2e-3));
  CHECK(e.b_to_a_rms == doctest::Approx(std::sqrt(1.0 / 6)).epsilon(2e-3));
  CHECK(e.rms == doctest::Approx(std::sqrt(1.0 / 12)).epsilon(2e-3));  // both sides: (0 + 1/6) / 2

  // The roles swapped, the measured mesh now the one with more faces (whose tree is built while
  // the other side is measured): each side's numbers go with its own side.
  for (unsigned threads : {1u, 2u, 3u}) {
    meshcvt::ApproximationError swapped = meshcvt::approximation_error(ref, a, 60000, threads);
    CHECK(swapped.a_to_b_max == doctest::Approx(1).epsilon(1e-9));
    CHECK(swapped.b_to_a_max < 1e-6);
    CHECK(swapped.a_to_b_mean == doctest::Approx(0.25).epsilon(2e-3));
    CHECK(swapped.b_to_a_mean < 1e-6);
    CHECK(swapped.diagonal == doctest::Approx(std::sqrt(2.0)));  // the reference's box is now 1 x 1 x 0
  }
}

TEST_CASE("approximation_error: the largest distance at a lone vertex among many nearer ones") {
  // A fine grid with three interior vertices raised to different heights, against the flat square:
  // the largest distance is the highest vertex's height, reached at that vertex alone (the samples
  // around it lie lower on its pyramid). The thousands of vertices nearer the plane must not hide
  // it, nor the lower raised vertex measured just before it among the vertices.
  const int n = 60;
  Mesh fine = grid(n, 0, 1, 0, 1, 0), flat = grid(1, 0, 1, 0, 1, 0);
  const float heights[3] = {0.125f, 0.2f, 0.3f};
  const int raised[3] = {5 * (n + 1) + 7, 33 * (n + 1) + 41, 52 * (n + 1) + 12};
  for (int k = 0; k < 3; ++k) fine.positions[3 * size_t(raised[k]) + 2] = heights[k];
  const double highest = double(0.3f);
  for (unsigned threads : {1u, 2u}) {
    CAPTURE(threads);
    // The fine mesh measured (its tree is the larger) and as the reference, 3000 samples each, so
    // that the vertices make most of the points.
    meshcvt::ApproximationError e = meshcvt::approximation_error(fine, flat, 3000, threads);
    CHECK(e.a_to_b_max == highest);
    CHECK(e.b_to_a_max < 0.05);  // the flat square's points under a pyramid, near its slopes
    meshcvt::ApproximationError swapped = meshcvt::approximation_error(flat, fine, 3000, threads);
    CHECK(swapped.b_to_a_max == highest);
    CHECK(swapped.hausdorff == highest);
    // The samples alone miss the apex: the RMS stays far below it.
    CHECK(swapped.b_to_a_rms < 0.05);
  }
}

TEST_CASE("approximation_error: the same numbers for any thread count, different for another seed") {
  Mesh a = octahedron(), ref = tetrahedron();
  meshcvt::ApproximationError one = meshcvt::approximation_error(a, ref, 50000, 1);
  for (unsigned threads : {2u, 3u, 8u}) {
    // (The larger mesh's tree is built on a thread of its own beside the other side's measurement.)
    meshcvt::ApproximationError many = meshcvt::approximation_error(a, ref, 50000, threads);
    CHECK(one.hausdorff == many.hausdorff);
    CHECK(one.rms == many.rms);
    CHECK(one.a_to_b_mean == many.a_to_b_mean);
    CHECK(one.b_to_a_rms == many.b_to_a_rms);
  }
  meshcvt::ApproximationError other = meshcvt::approximation_error(a, ref, 50000, 1, 2);
  CHECK(other.rms != one.rms);
  CHECK(other.rms == doctest::Approx(one.rms).epsilon(1e-2));
}

TEST_CASE("approximation_error: meshes without a face or without area are rejected") {
  Mesh empty;
  Mesh flat = triangle(0, 0, 1, 0, 2, 0);
  CHECK_THROWS_AS(meshcvt::approximation_error(empty, octahedron(), 1000), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::approximation_error(octahedron(), empty, 1000), meshcvt::OptionError);
  CHECK_THROWS_AS(meshcvt::approximation_error(octahedron(), flat, 1000), meshcvt::OptionError);
}

TEST_CASE("default_error_samples: the larger face count, at least 100k, at most 1M") {
  Mesh small = octahedron();
  CHECK(meshcvt::default_error_samples(small, small) == 100000);
  Mesh big = grid(300, 0, 1, 0, 1, 0);  // 180,000 faces
  CHECK(meshcvt::default_error_samples(small, big) == 180000);
  CHECK(meshcvt::default_error_samples(big, small) == 180000);
  Mesh huge;  // only the face count matters: 1.5M (unreferenced) faces
  huge.indices.assign(3 * 1'500'000, 0);
  CHECK(meshcvt::default_error_samples(small, huge) == 1000000);
}
