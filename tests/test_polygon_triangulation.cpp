// Tests of the polygon triangulation (src/polygon_triangulation.h): simple polygons whose best
// triangulation is known, and, on random polygons of up to 300 corners, the same triangles as a
// plain dynamic programming written here (pairs by span, one thread, one table entry per pair) for
// any thread count: the tiled, mirrored and parallel filling of the tables changes nothing.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include "parallel.h"
#include "polygon_triangulation.h"

using namespace meshcvt;

namespace {

// The same objective, written the plain way: best[i][j] over spans of increasing length.
uint32_t reference_triangulation(const std::vector<Vec3>& p, Vec3 n, const std::vector<uint8_t>& allowed,
                                 const PolygonTriangleRules& rules, std::vector<uint32_t>& triangles) {
  const size_t m = p.size();
  struct Entry {
    uint32_t cost = std::numeric_limits<uint32_t>::max();
    double quality = -1;
    uint32_t k = 0;
  };
  std::vector<std::vector<Entry>> best(m, std::vector<Entry>(m));
  for (size_t i = 0; i + 1 < m; ++i) best[i][i + 1] = {0, std::numeric_limits<double>::infinity(), 0};
  for (size_t span = 2; span < m; ++span)
    for (size_t i = 0; i + span < m; ++i) {
      const size_t j = i + span;
      Entry e = best[i][j];
      for (size_t k = i + 1; k < j; ++k) {
        uint32_t c = best[i][k].cost + best[k][j].cost;
        double q = std::min(best[i][k].quality, best[k][j].quality);
        if (!allowed[i * m + k] || !allowed[k * m + j]) c += uint32_t(m);
        const Vec3 cr = cross(p[k] - p[i], p[j] - p[i]);
        const double area2 = length(cr);
        const double lik = length(p[k] - p[i]), lkj = length(p[j] - p[k]), lij = length(p[j] - p[i]);
        const double big = std::max({lkj * lij, lij * lik, lik * lkj});
        const double sine = big > 0 ? area2 / big : 0.0;
        if (sine > rules.min_sine && (dot(n, n) == 0 || dot(cr, n) > rules.min_facing_cosine * area2))
          q = std::min(q, sine);
        else
          ++c;
        if (c < e.cost || (c == e.cost && q > e.quality)) e = {c, q, uint32_t(k)};
      }
      best[i][j] = e;
    }
  triangles.clear();
  std::vector<std::pair<size_t, size_t>> stack{{0, m - 1}};
  while (!stack.empty()) {
    auto [i, j] = stack.back();
    stack.pop_back();
    if (j < i + 2) continue;
    const size_t k = best[i][j].k;
    triangles.insert(triangles.end(), {uint32_t(i), uint32_t(k), uint32_t(j)});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
  return best[0][m - 1].cost;
}

std::vector<Vec3> regular_polygon(size_t m) {
  std::vector<Vec3> p(m);
  for (size_t i = 0; i < m; ++i) {
    const double a = 2 * std::numbers::pi * double(i) / double(m);
    p[i] = {std::cos(a), std::sin(a), 0};
  }
  return p;
}

std::vector<uint8_t> all_allowed(size_t m) { return std::vector<uint8_t>(m * m, 1); }

// Each polygon edge in one triangle, in the polygon's direction; each diagonal in two, opposite.
void check_is_triangulation(size_t m, const std::vector<uint32_t>& t) {
  REQUIRE(t.size() == 3 * (m - 2));
  std::vector<int> uses(m * m, 0);
  for (size_t f = 0; f < t.size(); f += 3)
    for (int e = 0; e < 3; ++e) ++uses[t[f + e] * m + t[f + (e + 1) % 3]];
  size_t wrong = 0;
  for (size_t i = 0; i < m; ++i)
    for (size_t j = 0; j < m; ++j) {
      if (j == (i + 1) % m) wrong += uses[i * m + j] != 1;
      else if (i == (j + 1) % m) wrong += uses[i * m + j] != 0;
      else wrong += uses[i * m + j] != uses[j * m + i];
    }
  CHECK(wrong == 0);
}

}  // namespace

TEST_CASE("triangulate_polygon: a convex polygon, a forbidden diagonal, a reflex corner") {
  const PolygonTriangleRules rules;
  std::vector<uint32_t> t;
  for (size_t m : {3u, 4u, 6u, 17u}) {
    CAPTURE(m);
    CHECK(triangulate_polygon(regular_polygon(m), {0, 0, 1}, all_allowed(m), rules, nullptr, t) == 0);
    check_is_triangulation(m, t);
  }
  // A square: both diagonals are as good; with (0, 2) forbidden, (1, 3) is taken, at no cost.
  std::vector<uint8_t> allowed = all_allowed(4);
  allowed[0 * 4 + 2] = allowed[2 * 4 + 0] = 0;
  CHECK(triangulate_polygon(regular_polygon(4), {0, 0, 1}, allowed, rules, nullptr, t) == 0);
  check_is_triangulation(4, t);
  for (size_t f = 0; f < t.size(); f += 3) CHECK(std::count(t.begin() + f, t.begin() + f + 3, 1u) == 1);
  // Both forbidden: one of them is used anyway, at a cost of m.
  allowed[1 * 4 + 3] = allowed[3 * 4 + 1] = 0;
  CHECK(triangulate_polygon(regular_polygon(4), {0, 0, 1}, allowed, rules, nullptr, t) == 4);
  // An arrow (corner 2 reflex): only the diagonal from the reflex corner keeps both triangles
  // facing +z. Against -z that diagonal's two triangles both face away; the other diagonal's
  // triangle over the reflex corner is folded back, facing -z: one bad triangle.
  const std::vector<Vec3> arrow{{0, 0, 0}, {2, 1, 0}, {0, 0.5, 0}, {-2, 1, 0}};
  CHECK(triangulate_polygon(arrow, {0, 0, 1}, all_allowed(4), rules, nullptr, t) == 0);
  for (size_t f = 0; f < t.size(); f += 3) CHECK(std::count(t.begin() + f, t.begin() + f + 3, 2u) == 1);
  CHECK(triangulate_polygon(arrow, {0, 0, -1}, all_allowed(4), rules, nullptr, t) == 1);
  for (size_t f = 0; f < t.size(); f += 3) CHECK(std::count(t.begin() + f, t.begin() + f + 3, 1u) == 1);
  // Without a normal only slivers count: three collinear corners cannot all be in a proper triangle.
  const std::vector<Vec3> flat{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  CHECK(triangulate_polygon(flat, {0, 0, 0}, all_allowed(3), rules, nullptr, t) == 1);
}

TEST_CASE("triangulate_polygon: the same triangles as the plain dynamic programming, on any thread count") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.35, 0.35), unit(0, 1);
  WorkerPool one(1), two(2), three(3);
  size_t polygons = 0, with_cost = 0;
  for (size_t m : {5u, 31u, 32u, 33u, 64u, 127u, 128u, 129u, 200u, 300u}) {
    for (int variant = 0; variant < 3; ++variant) {
      CAPTURE(m);
      CAPTURE(variant);
      // A star-like polygon in 3D with radial and vertical noise (reflex corners, near-ties), some
      // diagonals forbidden, and a normal for two variants out of three.
      std::vector<Vec3> p = regular_polygon(m);
      for (Vec3& c : p) {
        const double r = 1 + jitter(rng);
        c = {r * c.x, r * c.y, 0.2 * jitter(rng)};
      }
      std::vector<uint8_t> allowed = all_allowed(m);
      for (size_t i = 0; i < m; ++i)
        for (size_t j = i + 2; j < m; ++j)
          if (unit(rng) < 0.1 * variant) allowed[i * m + j] = allowed[j * m + i] = 0;
      const Vec3 n = variant == 1 ? Vec3{0, 0, 0} : Vec3{0, 0, 1};
      const PolygonTriangleRules rules;
      std::vector<uint32_t> expected, t;
      const uint32_t cost = reference_triangulation(p, n, allowed, rules, expected);
      for (WorkerPool* pool : {(WorkerPool*)nullptr, &one, &two, &three}) {
        CHECK(triangulate_polygon(p, n, allowed, rules, pool, t) == cost);
        CHECK(t == expected);
      }
      check_is_triangulation(m, t);
      ++polygons;
      with_cost += cost > 0;
    }
  }
  CHECK(polygons == 30);
  CHECK(with_cost > 0);  // the forbidden diagonals and reflex corners do cost somewhere
}

TEST_CASE("has_perfect_triangulation: whether the dynamic programming's cost is 0, on random polygons") {
  // Star-like polygons from nearly convex to ragged (some crossing themselves), with and without a
  // normal and forbidden diagonals: the answer must be the triangulation's cost == 0 on each, and
  // both answers occur.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0, 1);
  const PolygonTriangleRules rules;
  size_t perfect = 0, imperfect = 0;
  for (size_t m : {3u, 4u, 5u, 8u, 31u, 64u, 65u, 130u}) {
    for (double spread : {0.02, 0.1, 0.35}) {
      for (int variant = 0; variant < 4; ++variant) {
        CAPTURE(m);
        CAPTURE(spread);
        CAPTURE(variant);
        std::vector<Vec3> p = regular_polygon(m);
        for (Vec3& c : p) {
          const double r = 1 + spread * (2 * unit(rng) - 1);
          c = {r * c.x, r * c.y, 0.2 * spread * (2 * unit(rng) - 1)};
        }
        // The most ragged ones also cross themselves: a corner swapped with one a few places on.
        if (spread > 0.3 && m > 8) std::swap(p[m / 3], p[m / 3 + 1 + size_t(unit(rng) * 4)]);
        std::vector<uint8_t> allowed = all_allowed(m);
        for (size_t i = 0; i < m; ++i)
          for (size_t j = i + 2; j < m; ++j)
            if (unit(rng) < 0.5 * (variant / 2)) allowed[i * m + j] = allowed[j * m + i] = 0;
        const Vec3 n = variant % 2 == 1 ? Vec3{0, 0, 0} : Vec3{0, 0, 1};
        std::vector<uint32_t> t;
        const bool expected = triangulate_polygon(p, n, allowed, rules, nullptr, t) == 0;
        const std::optional<bool> answer = has_perfect_triangulation(p, n, allowed, rules, uint64_t(1) << 40);
        REQUIRE(answer.has_value());
        CHECK(*answer == expected);
        (expected ? perfect : imperfect) += 1;
      }
    }
  }
  CHECK(perfect > 10);
  CHECK(imperfect > 10);
  // The arrow of the first test: perfect facing +z, not facing -z; three collinear corners never.
  const std::vector<Vec3> arrow{{0, 0, 0}, {2, 1, 0}, {0, 0.5, 0}, {-2, 1, 0}};
  CHECK(has_perfect_triangulation(arrow, {0, 0, 1}, all_allowed(4), rules, 100) == std::optional<bool>(true));
  CHECK(has_perfect_triangulation(arrow, {0, 0, -1}, all_allowed(4), rules, 100) == std::optional<bool>(false));
  const std::vector<Vec3> flat{{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  CHECK(has_perfect_triangulation(flat, {0, 0, 0}, all_allowed(3), rules, 100) == std::optional<bool>(false));
  // A square with both diagonals forbidden has none; with no test allowed, no answer.
  std::vector<uint8_t> allowed = all_allowed(4);
  allowed[0 * 4 + 2] = allowed[2 * 4 + 0] = allowed[1 * 4 + 3] = allowed[3 * 4 + 1] = 0;
  CHECK(has_perfect_triangulation(regular_polygon(4), {0, 0, 1}, allowed, rules, 100) == std::optional<bool>(false));
  CHECK(!has_perfect_triangulation(regular_polygon(17), {0, 0, 1}, all_allowed(17), rules, 0).has_value());
}
