// Tests for the triangle BVH (src/triangle_bvh.h): the point-triangle distance against an
// independent computation, and BVH queries against a brute-force loop over every face, on random,
// sliver, degenerate, duplicated and badly distributed triangles. Also the prisms' lower bound of
// that distance (src/triangle_prisms.h) against the distance itself.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include "triangle_bvh.h"
#include "triangle_prisms.h"

using meshcvt::kNone;
using meshcvt::TriangleBvh;

namespace {

// Small deterministic generator for test data (xorshift64*).
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed * 0x9e3779b97f4a7c15ull + 1) {}
  double uniform(double lo = 0, double hi = 1) {
    s ^= s >> 12, s ^= s << 25, s ^= s >> 27;
    return lo + (hi - lo) * double((s * 0x2545f4914f6cdd1dull) >> 11) * 0x1.0p-53;
  }
};

using Vec = std::array<long double, 3>;

// Independent reference: the closest point of a triangle is either the minimizer of the distance
// over the triangle's plane (when its barycentric coordinates are all >= 0), or on an edge. Solves
// the 2x2 normal equations in long double instead of classifying Voronoi regions.
long double segment_distance2(const Vec& p, const Vec& a, const Vec& b) {
  long double ab2 = 0, apab = 0;
  for (int k = 0; k < 3; ++k) ab2 += (b[k] - a[k]) * (b[k] - a[k]), apab += (p[k] - a[k]) * (b[k] - a[k]);
  long double t = ab2 > 0 ? std::clamp(apab / ab2, 0.0L, 1.0L) : 0.0L;
  long double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    long double x = a[k] + t * (b[k] - a[k]) - p[k];
    d2 += x * x;
  }
  return d2;
}

long double reference_distance2(const double pd[3], const float* t) {
  Vec p{pd[0], pd[1], pd[2]}, a{t[0], t[1], t[2]}, b{t[3], t[4], t[5]}, c{t[6], t[7], t[8]};
  long double best = std::min({segment_distance2(p, a, b), segment_distance2(p, b, c), segment_distance2(p, c, a)});
  Vec u, w, ap;
  for (int k = 0; k < 3; ++k) u[k] = b[k] - a[k], w[k] = c[k] - a[k], ap[k] = p[k] - a[k];
  long double uu = 0, uw = 0, ww = 0, up = 0, wp = 0;
  for (int k = 0; k < 3; ++k)
    uu += u[k] * u[k], uw += u[k] * w[k], ww += w[k] * w[k], up += u[k] * ap[k], wp += w[k] * ap[k];
  long double det = uu * ww - uw * uw;
  if (det > 1e-12L * uu * ww) {
    long double s = (up * ww - wp * uw) / det, r = (wp * uu - up * uw) / det;
    if (s >= 0 && r >= 0 && s + r <= 1) {
      long double d2 = 0;
      for (int k = 0; k < 3; ++k) {
        long double x = a[k] + s * u[k] + r * w[k] - p[k];
        d2 += x * x;
      }
      best = std::min(best, d2);
    }
  }
  return best;
}

double triangle_distance2(const double q[3], const float* t, double point[3]) {
  double a[3] = {t[0], t[1], t[2]}, b[3] = {t[3], t[4], t[5]}, c[3] = {t[6], t[7], t[8]};
  return meshcvt::closest_point_on_triangle(q, a, b, c, point);
}

// Brute force over every face, ties to the lower face id: what the BVH must reproduce exactly.
TriangleBvh::Hit brute_force(const std::vector<float>& soup, const double q[3]) {
  TriangleBvh::Hit best;
  for (size_t f = 0; f < soup.size() / 9; ++f) {
    double p[3];
    double d2 = triangle_distance2(q, &soup[9 * f], p);
    if (d2 < best.distance2) {
      best.distance2 = d2;
      best.face = uint32_t(f);
      for (int k = 0; k < 3; ++k) best.point_exact[k] = p[k];
    }
  }
  return best;
}

// A triangle soup as positions + indices (vertex i of face f = 3f + i).
struct Soup {
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  void add(const float t[9]) {
    for (int i = 0; i < 9; ++i) positions.push_back(t[i]);
    for (int i = 0; i < 3; ++i) indices.push_back(uint32_t(indices.size()));
  }
  size_t faces() const { return indices.size() / 3; }
};

// Random triangles in the unit cube: ordinary ones, slivers (one corner near an edge), needles (two
// corners almost equal), and exact degenerates (repeated corner, collinear corners, a point).
Soup random_soup(size_t count, uint64_t seed) {
  Rng rng(seed);
  Soup soup;
  for (size_t i = 0; i < count; ++i) {
    float t[9];
    double center[3] = {rng.uniform(), rng.uniform(), rng.uniform()};
    double size = rng.uniform(0.005, 0.08);
    for (int j = 0; j < 9; ++j) t[j] = float(center[j % 3] + size * rng.uniform(-1, 1));
    switch (i % 8) {
      case 5:  // sliver: corner 2 a tiny bit off the midpoint of edge 01
        for (int k = 0; k < 3; ++k) t[6 + k] = float(0.5 * (t[k] + t[3 + k]) + 1e-5 * rng.uniform(-1, 1));
        break;
      case 6:  // needle: corner 1 almost on corner 0
        for (int k = 0; k < 3; ++k) t[3 + k] = float(t[k] + 1e-6 * rng.uniform(-1, 1));
        break;
      case 7:  // exact degenerates, in turn: repeated corner, collinear, all three equal
        if (i % 24 == 7) {
          for (int k = 0; k < 3; ++k) t[3 + k] = t[k];
        } else if (i % 24 == 15) {  // exactly collinear: on a line parallel to x
          t[3] = t[0] + 0.25f, t[4] = t[1], t[5] = t[2];
          t[6] = t[0] - 0.125f, t[7] = t[1], t[8] = t[2];
        } else {
          for (int k = 0; k < 3; ++k) t[3 + k] = t[6 + k] = t[k];
        }
        break;
      default:
        break;
    }
    soup.add(t);
  }
  return soup;
}

void random_query(Rng& rng, double q[3]) {
  // Mostly inside the cube (near many triangles), some far outside.
  double spread = rng.uniform() < 0.8 ? 1.0 : 6.0;
  for (int k = 0; k < 3; ++k) q[k] = 0.5 + spread * rng.uniform(-0.6, 0.6);
}

void check_same(const TriangleBvh::Hit& got, const TriangleBvh::Hit& want) {
  CHECK(got.face == want.face);
  CHECK(got.distance2 == want.distance2);
  for (int k = 0; k < 3; ++k) CHECK(got.point_exact[k] == want.point_exact[k]);
}

}  // namespace

TEST_CASE("closest_point_on_triangle: known regions of a right triangle") {
  double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, p[3];
  struct Case {
    double q[3], point[3], d2;
  } cases[] = {
      {{0.2, 0.3, 5}, {0.2, 0.3, 0}, 25},     // face region, above
      {{0.2, 0.3, -2}, {0.2, 0.3, 0}, 4},     // face region, below
      {{-1, -2, 0}, {0, 0, 0}, 5},            // vertex a
      {{3, -1, 1}, {1, 0, 0}, 4 + 1 + 1},     // vertex b
      {{-1, 4, 0}, {0, 1, 0}, 1 + 9},         // vertex c
      {{0.5, -3, 4}, {0.5, 0, 0}, 9 + 16},    // edge ab
      {{-2, 0.25, 0}, {0, 0.25, 0}, 4},       // edge ac
      {{1, 1, 0}, {0.5, 0.5, 0}, 0.5},        // edge bc
      {{0.25, 0.25, 0}, {0.25, 0.25, 0}, 0},  // on the triangle
  };
  for (const Case& cs : cases) {
    double d2 = meshcvt::closest_point_on_triangle(cs.q, a, b, c, p);
    CHECK(d2 == doctest::Approx(cs.d2).epsilon(1e-12));
    for (int k = 0; k < 3; ++k) CHECK(p[k] == doctest::Approx(cs.point[k]).epsilon(1e-12));
  }
}

TEST_CASE("closest_point_on_triangle: degenerate triangles are their edges") {
  double p[3];
  SUBCASE("all corners equal") {
    double a[3] = {1, 2, 3}, q[3] = {1, 2, 5};
    CHECK(meshcvt::closest_point_on_triangle(q, a, a, a, p) == 4);
    CHECK(p[2] == 3);
  }
  SUBCASE("two corners equal") {
    double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, q[3] = {1, 3, 0};
    CHECK(meshcvt::closest_point_on_triangle(q, a, a, b, p) == doctest::Approx(9));
    CHECK(meshcvt::closest_point_on_triangle(q, a, b, b, p) == doctest::Approx(9));
    CHECK(meshcvt::closest_point_on_triangle(q, b, a, a, p) == doctest::Approx(9));
    CHECK(p[0] == doctest::Approx(1));
  }
  SUBCASE("collinear corners") {
    double a[3] = {0, 0, 0}, b[3] = {1, 1, 1}, c[3] = {3, 3, 3}, q[3] = {4, 4, 4};
    CHECK(meshcvt::closest_point_on_triangle(q, a, b, c, p) == doctest::Approx(3));
    double q2[3] = {1, 1, 1 + 1e-3};  // near the middle corner
    double d2 = meshcvt::closest_point_on_triangle(q2, a, b, c, p);
    CHECK(std::isfinite(d2));
    CHECK(d2 <= 1e-6 + 1e-15);
  }
}

TEST_CASE("closest_point_on_triangle agrees with an independent computation on random and thin triangles") {
  Soup soup = random_soup(3000, 7);
  Rng rng(11);
  double worst = 0;
  for (size_t f = 0; f < soup.faces(); ++f) {
    for (int j = 0; j < 4; ++j) {
      double q[3];
      const float* t = &soup.positions[9 * f];
      // Queries near the triangle (where the regions meet) and farther away.
      double scale = j < 2 ? 0.01 : 0.2;
      for (int k = 0; k < 3; ++k) q[k] = t[k] + scale * rng.uniform(-1, 1);
      double p[3];
      double d2 = triangle_distance2(q, t, p);
      long double want = reference_distance2(q, t);
      // The reported point lies at the reported distance.
      double dp = 0;
      for (int k = 0; k < 3; ++k) dp += (p[k] - q[k]) * (p[k] - q[k]);
      CHECK(dp == doctest::Approx(d2).epsilon(1e-9));
      // Distances agree to far below float resolution of the coordinates.
      double err = std::fabs(std::sqrt(d2) - double(std::sqrt(want)));
      worst = std::max(worst, err);
    }
  }
  CHECK(worst < 1e-9);
}

TEST_CASE("TriangleBvh: same face, distance and point as brute force on random soups") {
  for (TriangleBvh::Build build : {TriangleBvh::Build::sah, TriangleBvh::Build::morton})
  for (uint64_t seed : {1, 2, 3}) {
    CAPTURE(int(build));
    Soup soup = random_soup(seed == 1 ? 5 : 2500, seed);
    TriangleBvh bvh(soup.positions.data(), soup.indices.data(), soup.faces(), 0, build);
    CHECK(bvh.face_count() == soup.faces());
    Rng rng(seed + 100);
    for (int i = 0; i < 400; ++i) {
      double q[3];
      random_query(rng, q);
      check_same(bvh.closest_point(q), brute_force(soup.positions, q));
    }
  }
}

TEST_CASE("TriangleBvh: ties go to the lower face id") {
  // A grid of squares split in two: a query on a grid vertex is at distance 0 from up to 6 faces.
  const int n = 12;
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) positions.insert(positions.end(), {float(x), float(y), 0.0f});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      uint32_t v = uint32_t(y * (n + 1) + x);
      indices.insert(indices.end(), {v, v + 1, v + n + 2, v, v + n + 2, v + n + 1});
    }
  // Faces listed in reverse too, so "lowest id" is not just "first built".
  for (TriangleBvh::Build build : {TriangleBvh::Build::sah, TriangleBvh::Build::morton})
  for (bool reverse : {false, true}) {
    CAPTURE(int(build));
    std::vector<uint32_t> idx = indices;
    if (reverse) {
      std::vector<uint32_t> r;
      for (size_t f = idx.size() / 3; f-- > 0;) r.insert(r.end(), idx.begin() + 3 * f, idx.begin() + 3 * f + 3);
      idx = r;
    }
    std::vector<float> soup;
    for (uint32_t v : idx) soup.insert(soup.end(), positions.begin() + 3 * v, positions.begin() + 3 * v + 3);
    TriangleBvh bvh(positions.data(), idx.data(), idx.size() / 3, 0, build);
    for (int y = 0; y <= n; y += 3)
      for (int x = 0; x <= n; x += 2) {
        for (double z : {0.0, 0.5, -2.0}) {
          double q[3] = {double(x), double(y), z};
          TriangleBvh::Hit got = bvh.closest_point(q), want = brute_force(soup, q);
          check_same(got, want);
          CHECK(got.distance2 == doctest::Approx(z * z));
        }
      }
  }
}

TEST_CASE("TriangleBvh: identical triangles and exponentially spaced ones") {
  for (TriangleBvh::Build build : {TriangleBvh::Build::sah, TriangleBvh::Build::morton}) {
    CAPTURE(int(build));
    {  // many copies of one triangle: the first copy wins
      Soup soup;
      float t[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
      for (int i = 0; i < 300; ++i) soup.add(t);
      TriangleBvh bvh(soup.positions.data(), soup.indices.data(), soup.faces(), 0, build);
      double q[3] = {0.2, 0.2, 1};
      TriangleBvh::Hit hit = bvh.closest_point(q);
      CHECK(hit.face == 0);
      CHECK(hit.distance2 == doctest::Approx(1));
    }
    {  // sizes and positions spread over many orders of magnitude
      Soup soup;
      for (int i = 0; i < 400; ++i) {
        float s = std::ldexp(1.0f, -(i % 100));
        float x = std::ldexp(1.0f, -(i / 4)) * (i % 2 ? 1.0f : -1.0f);
        float t[9] = {x, 0, 0, x + s, 0, 0, x, s, float(i % 3) * s};
        soup.add(t);
      }
      TriangleBvh bvh(soup.positions.data(), soup.indices.data(), soup.faces(), 0, build);
      Rng rng(5);
      for (int i = 0; i < 200; ++i) {
        double q[3] = {std::ldexp(rng.uniform(-1, 1), -int(rng.uniform(0, 40))), rng.uniform(-1e-3, 1e-3),
                       rng.uniform(-1e-6, 1e-6)};
        check_same(bvh.closest_point(q), brute_force(soup.positions, q));
      }
    }
  }
}

TEST_CASE("TriangleBvh: bounded queries, batches, threads, empty tree") {
  Soup soup = random_soup(1500, 9);
  TriangleBvh bvh(soup.positions.data(), soup.indices.data(), soup.faces());
  Rng rng(21);
  std::vector<double> queries;
  for (int i = 0; i < 3000; ++i) {
    double q[3];
    random_query(rng, q);
    queries.insert(queries.end(), q, q + 3);
  }
  size_t count = queries.size() / 3;
  std::vector<TriangleBvh::Hit> single(count);
  for (size_t i = 0; i < count; ++i) single[i] = bvh.closest_point(&queries[3 * i]);

  SUBCASE("a bound below the answer finds nothing, at or above it finds the same hit") {
    for (size_t i = 0; i < count; i += 7) {
      const double* q = &queries[3 * i];
      double d2 = single[i].distance2;
      CHECK(bvh.closest_point(q, d2 * 0.999).face == (d2 > 0 ? kNone : single[i].face));
      check_same(bvh.closest_point(q, d2), single[i]);
      check_same(bvh.closest_point(q, d2 * 4 + 1), single[i]);
    }
  }
  SUBCASE("float queries are the double query of the same point") {
    float qf[3] = {0.25f, 0.5f, 0.75f};
    double qd[3] = {0.25, 0.5, 0.75};
    check_same(bvh.closest_point(qf), bvh.closest_point(qd));
  }
  SUBCASE("batched queries match single ones for 1 and 3 threads") {
    for (unsigned threads : {1u, 3u}) {
      std::vector<TriangleBvh::Hit> batch(count);
      bvh.closest_points(queries.data(), count, batch.data(), threads);
      for (size_t i = 0; i < count; ++i) check_same(batch[i], single[i]);
    }
  }
  SUBCASE("queries from concurrent threads give the same answers") {
    std::vector<TriangleBvh::Hit> other(count);
    std::thread worker([&] {
      for (size_t i = count; i-- > 0;) other[i] = bvh.closest_point(&queries[3 * i]);
    });
    worker.join();
    for (size_t i = 0; i < count; ++i) check_same(other[i], single[i]);
  }
  SUBCASE("empty tree") {
    TriangleBvh empty;
    double q[3] = {0, 0, 0};
    CHECK(empty.closest_point(q).face == kNone);
    TriangleBvh empty2(nullptr, nullptr, 0);
    CHECK(empty2.closest_point(q).face == kNone);
    CHECK(empty2.face_count() == 0);
  }
  SUBCASE("bounds are the union of the triangles") {
    float lo[3], hi[3];
    bvh.bounds(lo, hi);
    for (int k = 0; k < 3; ++k) {
      float mn = INFINITY, mx = -INFINITY;
      for (size_t i = k; i < soup.positions.size(); i += 3)
        mn = std::min(mn, soup.positions[i]), mx = std::max(mx, soup.positions[i]);
      CHECK(lo[k] == mn);
      CHECK(hi[k] == mx);
    }
  }
}

TEST_CASE("TriangleBvh: a tree built by several threads answers like one built by one") {
  // A wavy 260 x 260 grid (135,200 faces): large enough for the build to hand subtrees to threads.
  const int n = 260;
  std::vector<float> positions;
  std::vector<uint32_t> indices;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x)
      positions.insert(positions.end(),
                       {float(x) / n, float(y) / n, 0.05f * std::sin(0.3f * float(x)) * std::cos(0.2f * float(y))});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      uint32_t v = uint32_t(y * (n + 1) + x);
      indices.insert(indices.end(), {v, v + 1, v + n + 2, v, v + n + 2, v + n + 1});
    }
  const size_t faces = indices.size() / 3;
  std::vector<float> soup;
  for (uint32_t v : indices) soup.insert(soup.end(), positions.begin() + 3 * v, positions.begin() + 3 * v + 3);
  for (TriangleBvh::Build build : {TriangleBvh::Build::sah, TriangleBvh::Build::morton}) {
    CAPTURE(int(build));
    TriangleBvh one(positions.data(), indices.data(), faces, 1, build);
    // The same tree to the byte on any number of threads (the Morton build's subtrees are laid out
    // where one thread puts them; 16: tasks of 65536 faces at most, more than 2 per thread).
    for (unsigned threads : {2u, 3u, 4u, 16u}) {
      CAPTURE(threads);
      TriangleBvh many(positions.data(), indices.data(), faces, threads, build);
      CHECK(one.node_count() == many.node_count());
      CHECK(one == many);
    }
    TriangleBvh four(positions.data(), indices.data(), faces, 4, build);
    Rng rng(77);
    for (int i = 0; i < 300; ++i) {
      double q[3] = {rng.uniform(-0.1, 1.1), rng.uniform(-0.1, 1.1), rng.uniform(-0.2, 0.2)};
      TriangleBvh::Hit a = one.closest_point(q);
      check_same(four.closest_point(q), a);
      if (i < 4) check_same(a, brute_force(soup, q));
    }
  }
  // A soup of 90,000 random triangles (slivers, needles, degenerates): children's boxes differ
  // along every axis, unlike the grid's halves.
  const Soup random = random_soup(90000, 11);
  const TriangleBvh soup_one(random.positions.data(), random.indices.data(), random.faces(), 1,
                             TriangleBvh::Build::morton);
  for (unsigned threads : {2u, 5u}) {
    CAPTURE(threads);
    CHECK(soup_one == TriangleBvh(random.positions.data(), random.indices.data(), random.faces(), threads,
                                  TriangleBvh::Build::morton));
  }
  // The comparison sees a difference: the same faces in another order make another tree.
  std::vector<uint32_t> reversed;
  for (size_t f = faces; f-- > 0;) reversed.insert(reversed.end(), indices.begin() + 3 * f, indices.begin() + 3 * f + 3);
  CHECK_FALSE(TriangleBvh(positions.data(), indices.data(), faces, 1, TriangleBvh::Build::morton) ==
              TriangleBvh(positions.data(), reversed.data(), faces, 1, TriangleBvh::Build::morton));
}

TEST_CASE("TrianglePrisms: known bounds around a right triangle") {
  meshcvt::Mesh mesh;
  mesh.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  mesh.indices = {0, 1, 2};
  meshcvt::TrianglePrisms prisms(1e-9);
  prisms.build(mesh);
  // In the plane, 0.3 beyond edge 01: the bound is the distance, 0.3.
  const double beside[3] = {0.5, -0.3, 0};
  CHECK(prisms.farther(0, beside, 0.0899));
  CHECK_FALSE(prisms.farther(0, beside, 0.09));
  // 0.4 beyond the hypotenuse and 2 above the plane: the bound sees only the 0.4 (distance ~2.04).
  const double above_beyond[3] = {0.5 + 0.4 / std::sqrt(2.0), 0.5 + 0.4 / std::sqrt(2.0), 2};
  CHECK(prisms.farther(0, above_beyond, 0.159));
  CHECK_FALSE(prisms.farther(0, above_beyond, 0.161));
  // Over the triangle: no bound however high.
  const double over[3] = {0.2, 0.2, 5};
  CHECK_FALSE(prisms.farther(0, over, 0));
  // Within the tolerance of a plane: not ruled out.
  const double on_edge[3] = {0.5, -1e-10, 0};
  CHECK_FALSE(prisms.farther(0, on_edge, 0));
}

TEST_CASE("TrianglePrisms: never rules out a triangle nearer than the distance given") {
  // Random, sliver, needle and degenerate triangles; queries near each and farther away. Given
  // the triangle's own squared distance by closest_point_on_triangle (the test the searches skip)
  // or more, it must not be ruled out; given less, it mostly is.
  Soup soup = random_soup(3000, 13);
  meshcvt::Mesh mesh;
  mesh.positions = soup.positions;
  mesh.indices = soup.indices;
  meshcvt::TrianglePrisms prisms(1e-9);
  prisms.build(mesh);
  Rng rng(17);
  size_t ruled_out = 0, wrong = 0, queries = 0;
  for (size_t f = 0; f < soup.faces(); ++f) {
    const float* t = &soup.positions[9 * f];
    for (int j = 0; j < 6; ++j) {
      double q[3], point[3];
      const double scale = j < 3 ? 0.01 : 0.3;
      for (int k = 0; k < 3; ++k) q[k] = t[k] + scale * rng.uniform(-1, 1);
      const double d2 = triangle_distance2(q, t, point);
      for (double at_least : {1.0, 1 + 1e-12, 2.0}) wrong += prisms.farther(uint32_t(f), q, at_least * d2);
      for (double below : {0.5, 0.01}) {
        ++queries;
        ruled_out += prisms.farther(uint32_t(f), q, below * d2);
      }
    }
  }
  CHECK(wrong == 0);
  // The bound does rule out: a bound that never did would pass the check above.
  CHECK(ruled_out > queries / 4);
  MESSAGE("ruled out " << ruled_out << " of " << queries);
}
