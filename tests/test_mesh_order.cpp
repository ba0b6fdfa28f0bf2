// meshcvt tests: reordering a mesh for locality (mesh_order.cpp) keeps the surface, restores the
// input exactly, maps per-face values both ways, and does make neighbouring faces close in memory.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/mesh_order.h"
#include "meshcvt/topology.h"
#include "test_meshes.h"

using namespace meshcvt;

namespace {

// The grid with its faces in a random order (as scanners write them), with a source polygon per
// face and one unreferenced vertex.
Mesh shuffled_grid(uint32_t n, uint32_t seed) {
  Mesh g = test::grid(n, n, 1, 1, 0.2);
  std::vector<uint32_t> perm(g.face_count());
  std::iota(perm.begin(), perm.end(), 0u);
  std::shuffle(perm.begin(), perm.end(), std::mt19937(seed));
  Mesh m;
  test::add_vertex(m, 5, 5, 5);  // unreferenced, first
  m.positions.insert(m.positions.end(), g.positions.begin(), g.positions.end());
  for (uint32_t f : perm) {
    test::add_triangle(m, g.indices[3 * f] + 1, g.indices[3 * f + 1] + 1, g.indices[3 * f + 2] + 1);
    m.source_polygon.push_back(f / 2);
  }
  return m;
}

// Mean |f - g| over pairs of edge-adjacent faces.
double mean_neighbour_distance(const Mesh& m) {
  Topology t = build_topology(m);
  double sum = 0;
  size_t pairs = 0;
  for (uint32_t f = 0; f < m.face_count(); ++f)
    for (int e = 0; e < 3; ++e) {
      uint32_t g = t.face_adjacent[3 * f + e];
      if (g == kNone || g < f) continue;
      sum += g - f;
      ++pairs;
    }
  return sum / double(pairs);
}

// Each triangle as its three corner positions, in its own corner order rotated to start at the
// smallest position: the same set for two meshes means the same surface with the same orientation.
std::multiset<std::array<float, 9>> oriented_triangles(const Mesh& m) {
  std::multiset<std::array<float, 9>> out;
  for (size_t f = 0; f < m.face_count(); ++f) {
    std::array<std::array<float, 3>, 3> c;
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[j][k] = m.positions[3 * size_t(m.indices[3 * f + j]) + k];
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    std::array<float, 9> t;
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) t[3 * j + k] = c[j][k];
    out.insert(t);
  }
  return out;
}

}  // namespace

TEST_CASE("reorder_for_locality: same surface, exact restore, neighbours close in memory") {
  const Mesh input = shuffled_grid(40, 7);
  Mesh m = input;
  LocalityOrder order = reorder_for_locality(m, 0);
  REQUIRE_FALSE(order.identity());
  CHECK(m.face_count() == input.face_count());
  CHECK(m.vertex_count() == input.vertex_count());
  CHECK(oriented_triangles(m) == oriented_triangles(input));
  // face_of and vertex_of are permutations, and they say where each face and vertex came from
  std::vector<uint32_t> faces = order.face_of, vertices = order.vertex_of;
  std::sort(faces.begin(), faces.end());
  std::sort(vertices.begin(), vertices.end());
  for (uint32_t i = 0; i < faces.size(); ++i) CHECK(faces[i] == i);
  for (uint32_t i = 0; i < vertices.size(); ++i) CHECK(vertices[i] == i);
  for (size_t i = 0; i < m.face_count(); ++i) {
    CHECK(m.source_polygon[i] == input.source_polygon[order.face_of[i]]);
    for (int j = 0; j < 3; ++j) CHECK(order.vertex_of[m.indices[3 * i + j]] == input.indices[3 * size_t(order.face_of[i]) + j]);
  }
  CHECK(order.vertex_of.back() == 0);  // the unreferenced vertex goes last
  // the point of it: adjacent faces end up close in memory
  CHECK(mean_neighbour_distance(m) < 0.1 * mean_neighbour_distance(input));
  // deterministic
  Mesh again = input;
  CHECK(reorder_for_locality(again, 0).face_of == order.face_of);
  CHECK(again.indices == m.indices);

  restore_input_order(m, order);
  CHECK(m.indices == input.indices);
  CHECK(m.positions == input.positions);
  CHECK(m.source_polygon == input.source_polygon);
}

TEST_CASE("reorder_for_locality: every thread count gives the same order, vertices by first use") {
  const Mesh input = shuffled_grid(30, 5);
  Mesh one = input;
  const LocalityOrder reference = reorder_for_locality(one, 0, 1);
  // Vertices by first use in the new face order, the unreferenced one last.
  std::vector<uint32_t> by_first_use;
  std::vector<uint8_t> seen(input.vertex_count(), 0);
  for (uint32_t f : reference.face_of)
    for (int j = 0; j < 3; ++j) {
      const uint32_t v = input.indices[3 * size_t(f) + j];
      if (!seen[v]) seen[v] = 1, by_first_use.push_back(v);
    }
  for (uint32_t v = 0; v < input.vertex_count(); ++v)
    if (!seen[v]) by_first_use.push_back(v);
  CHECK(reference.vertex_of == by_first_use);
  for (unsigned threads : {2u, 3u, 5u, 8u, 16u, 64u}) {
    CAPTURE(threads);
    Mesh m = input;
    const LocalityOrder order = reorder_for_locality(m, 0, threads);
    CHECK(order.face_of == reference.face_of);
    CHECK(order.vertex_of == reference.vertex_of);
    CHECK(m.indices == one.indices);
    CHECK(m.positions == one.positions);
    CHECK(m.source_polygon == one.source_polygon);
  }
}

TEST_CASE("reorder_for_locality: small meshes are left alone; per-face values map both ways") {
  Mesh m = shuffled_grid(8, 3);
  const Mesh input = m;
  LocalityOrder none = reorder_for_locality(m, m.face_count() + 1);
  CHECK(none.identity());
  CHECK(m.indices == input.indices);
  std::vector<uint32_t> ids(m.face_count());
  std::iota(ids.begin(), ids.end(), 0u);
  CHECK(to_input_order(ids, none) == ids);

  LocalityOrder order = reorder_for_locality(m, 0);
  // a per-face value of the input, carried into the new order and back
  std::vector<float> value(input.face_count());
  for (size_t f = 0; f < value.size(); ++f) value[f] = float(input.source_polygon[f]) + 0.5f;
  std::vector<float> moved = to_reordered(value, order);
  for (size_t i = 0; i < moved.size(); ++i) CHECK(moved[i] == float(m.source_polygon[i]) + 0.5f);
  std::vector<uint32_t> tags(m.face_count());
  for (size_t i = 0; i < tags.size(); ++i) tags[i] = m.source_polygon[i];
  CHECK(to_input_order(tags, order) == input.source_polygon);
  CHECK(to_reordered({}, order).empty());
  CHECK(to_input_order(std::vector<uint32_t>{}, order).empty());
}

TEST_CASE("reorder_for_locality: a clustering of the reordered mesh, mapped back, is valid on the input") {
  const Mesh input = shuffled_grid(48, 11);
  Mesh m = input;
  LocalityOrder order = reorder_for_locality(m, 0);
  ClusterOptions o;
  o.clusters = 40;
  o.device = "cpu";
  Clustering c = cluster(m, o);
  std::vector<uint32_t> labels = to_input_order(c.labels, order);
  // exactly n clusters, each edge-connected on the input mesh
  Topology t = build_topology(input);
  std::vector<uint32_t> parent(input.face_count());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (uint32_t f = 0; f < input.face_count(); ++f)
    for (int e = 0; e < 3; ++e) {
      uint32_t g = t.face_adjacent[3 * f + e];
      if (g != kNone && labels[g] == labels[f]) parent[find(f)] = find(g);
    }
  std::map<uint32_t, std::set<uint32_t>> pieces;
  for (uint32_t f = 0; f < input.face_count(); ++f) pieces[labels[f]].insert(find(f));
  CHECK(pieces.size() == 40);
  for (auto& [label, roots] : pieces) CHECK(roots.size() == 1);
}
