// Tests for uniform coarsening (src/coarsen.cpp, src/vertex_placement.cpp): the dual mesh of
// hand-built clusterings of procedural meshes (sphere, planar grids with and without a hole, torus,
// wheels), checked with an independent count of the output's topology (V - E + F, boundary loops,
// edge use, orientation, areas); the defects of broken clusterings; the three vertex placements and
// the fitting passes after qem.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <set>
#include <utility>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/quality.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"
#include "coarse_toward_surface.h"
#include "triangle_bvh.h"

using namespace meshcvt;

namespace {

// ---- procedural meshes (with a label per face)

struct Labeled {
  Mesh mesh;
  std::vector<uint32_t> labels;
};

uint32_t add_vertex(Mesh& m, double x, double y, double z) {
  m.positions.insert(m.positions.end(), {float(x), float(y), float(z)});
  return uint32_t(m.vertex_count() - 1);
}

// Midpoint subdivision, 1 -> 4, children keep the parent's label.
Labeled subdivide(const Labeled& in, int levels) {
  Labeled out = in;
  for (int level = 0; level < levels; ++level) {
    Labeled next;
    next.mesh.positions = out.mesh.positions;
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoint;
    auto mid = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      const float* p = &next.mesh.positions[3 * a];
      const float* q = &next.mesh.positions[3 * b];
      uint32_t v = add_vertex(next.mesh, 0.5 * (double(p[0]) + q[0]), 0.5 * (double(p[1]) + q[1]),
                              0.5 * (double(p[2]) + q[2]));
      midpoint[key] = v;
      return v;
    };
    for (size_t f = 0; f < out.mesh.face_count(); ++f) {
      uint32_t a = out.mesh.indices[3 * f], b = out.mesh.indices[3 * f + 1], c = out.mesh.indices[3 * f + 2];
      uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      next.mesh.indices.insert(next.mesh.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
      for (int k = 0; k < 4; ++k) next.labels.push_back(out.labels[f]);
    }
    out = std::move(next);
  }
  return out;
}

// Octahedron, outward oriented, faces labeled so that the dual is a tetrahedron: A = the two upper
// faces with x > 0, B = upper with x < 0, C = lower with y > 0, D = lower with y < 0. Clusters meet
// in threes at +-x and +-y, in twos at +-z. Subdivided and pushed onto the unit sphere.
Labeled sphere_four_clusters(int levels) {
  Labeled o;
  uint32_t axis[3][2];
  for (int d = 0; d < 3; ++d)
    for (int s = 0; s < 2; ++s) {
      double p[3] = {0, 0, 0};
      p[d] = s == 0 ? 1 : -1;
      axis[d][s] = add_vertex(o.mesh, p[0], p[1], p[2]);
    }
  for (int sx = 0; sx < 2; ++sx)
    for (int sy = 0; sy < 2; ++sy)
      for (int sz = 0; sz < 2; ++sz) {
        uint32_t x = axis[0][sx], y = axis[1][sy], z = axis[2][sz];
        bool positive = ((sx + sy + sz) % 2) == 0;  // (x, y, z) is counter-clockwise seen from outside
        if (positive)
          o.mesh.indices.insert(o.mesh.indices.end(), {x, y, z});
        else
          o.mesh.indices.insert(o.mesh.indices.end(), {x, z, y});
        uint32_t label = sz == 0 ? (sx == 0 ? 0u : 1u) : (sy == 0 ? 2u : 3u);
        o.labels.push_back(label);
      }
  Labeled s = subdivide(o, levels);
  for (size_t v = 0; v < s.mesh.vertex_count(); ++v) {
    float* p = &s.mesh.positions[3 * v];
    double len = std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]);
    for (int d = 0; d < 3; ++d) p[d] = float(p[d] / len);
  }
  return s;
}

// Planar grid of nx * ny unit quads in z = 0 (quads where keep(i, j) is false are left out), each
// split into two counter-clockwise triangles; labels from the quad: label(i, j).
Labeled grid(int nx, int ny, const std::function<uint32_t(int, int)>& label,
             const std::function<bool(int, int)>& keep = [](int, int) { return true; }) {
  Labeled g;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) add_vertex(g.mesh, i, j, 0);
  auto id = [&](int i, int j) { return uint32_t(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      if (!keep(i, j)) continue;
      g.mesh.indices.insert(g.mesh.indices.end(),
                            {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      g.labels.insert(g.labels.end(), 2, label(i, j));
    }
  return g;
}

// Torus: an nx * ny grid wrapped both ways, on a torus of radii 3 and 1.
Labeled torus(int nx, int ny, const std::function<uint32_t(int, int)>& label) {
  Labeled t;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      double u = 2 * std::numbers::pi * i / nx, v = 2 * std::numbers::pi * j / ny;
      add_vertex(t.mesh, (3 + std::cos(v)) * std::cos(u), (3 + std::cos(v)) * std::sin(u), std::sin(v));
    }
  auto id = [&](int i, int j) { return uint32_t((j % ny) * nx + (i % nx)); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      t.mesh.indices.insert(t.mesh.indices.end(),
                            {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      t.labels.insert(t.labels.end(), 2, label(i, j));
    }
  return t;
}

// A planar wheel: a center and rim points, one triangle (center, rim[i], rim[i+1]) per sector,
// subdivided; sector i is cluster i. All sectors meet at the center.
Labeled wheel(const std::vector<std::array<double, 2>>& rim, int levels) {
  Labeled w;
  uint32_t center = add_vertex(w.mesh, 0, 0, 0);
  for (auto& p : rim) add_vertex(w.mesh, p[0], p[1], 0);
  uint32_t n = uint32_t(rim.size());
  for (uint32_t i = 0; i < n; ++i) {
    w.mesh.indices.insert(w.mesh.indices.end(), {center, 1 + i, 1 + (i + 1) % n});
    w.labels.push_back(i);
  }
  return subdivide(w, levels);
}

// Unit cube [0,1]^3, 12 outward triangles, subdivided.
Mesh cube(int levels) {
  Labeled c;
  for (int k = 0; k < 8; ++k) add_vertex(c.mesh, k & 1, (k >> 1) & 1, (k >> 2) & 1);
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (auto& q : quads) {
    c.mesh.indices.insert(c.mesh.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
    c.labels.insert(c.labels.end(), 2, 0);
  }
  return subdivide(c, levels).mesh;
}

// A label per face of `m`, label_of(centroid) (3 doubles).
template <typename LabelOf>
std::vector<uint32_t> labels_by_centroid(const Mesh& m, LabelOf label_of) {
  std::vector<uint32_t> labels(m.face_count());
  for (size_t f = 0; f < m.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) c[d] += m.positions[3 * m.indices[3 * f + k] + d] / 3.0;
    labels[f] = label_of(c);
  }
  return labels;
}

// ---- an independent look at the output

struct Surface {
  int64_t vertices = 0;  // referenced
  int64_t edges = 0, faces = 0;
  int64_t boundary_edges = 0, boundary_loops = 0;
  int64_t overused_edges = 0;   // edges of three or more triangles
  int64_t repeated_directed = 0;  // a directed edge used twice: orientations disagree
  int64_t degenerate = 0;       // zero area or a repeated corner
  std::set<std::pair<uint32_t, uint32_t>> boundary;  // undirected boundary edges
  int64_t chi() const { return vertices - edges + faces; }
};

Surface inspect(const Mesh& m) {
  Surface s;
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  std::map<std::pair<uint32_t, uint32_t>, int> undirected;
  std::set<uint32_t> used;
  for (size_t f = 0; f < m.face_count(); ++f) {
    const uint32_t* t = &m.indices[3 * f];
    for (int k = 0; k < 3; ++k) {
      used.insert(t[k]);
      ++directed[{t[k], t[(k + 1) % 3]}];
      ++undirected[std::minmax(t[k], t[(k + 1) % 3])];
    }
    const float* p[3] = {&m.positions[3 * t[0]], &m.positions[3 * t[1]], &m.positions[3 * t[2]]};
    double u[3], w[3];
    for (int d = 0; d < 3; ++d) u[d] = p[1][d] - p[0][d], w[d] = p[2][d] - p[0][d];
    double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2], cz = u[0] * w[1] - u[1] * w[0];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || std::sqrt(cx * cx + cy * cy + cz * cz) < 1e-9) ++s.degenerate;
  }
  s.vertices = int64_t(used.size());
  s.faces = int64_t(m.face_count());
  s.edges = int64_t(undirected.size());
  for (auto& [e, n] : directed) s.repeated_directed += n > 1;
  // Boundary loops: components of the graph of boundary edges (enough for the simple loops here).
  std::map<uint32_t, uint32_t> parent;
  std::function<uint32_t(uint32_t)> find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (auto& [e, n] : undirected) {
    s.overused_edges += n > 2;
    if (n != 1) continue;
    ++s.boundary_edges;
    s.boundary.insert(e);
    for (uint32_t x : {e.first, e.second})
      if (!parent.count(x)) parent[x] = x;
    parent[find(e.first)] = find(e.second);
  }
  for (auto& [x, p] : parent) s.boundary_loops += find(x) == x;
  return s;
}

bool has_defect(const std::vector<DualDefect>& defects, DualDefect::Kind kind, uint32_t cluster,
                uint32_t other = kNone) {
  for (const DualDefect& d : defects)
    if (d.kind == kind && d.cluster == cluster && (other == kNone || d.other == other)) return true;
  return false;
}

CoarsenResult coarsen(const Labeled& l, uint32_t clusters, VertexPlacement placement = VertexPlacement::closest,
                      bool boundary_onto_input = true) {
  Topology topology = build_topology(l.mesh);
  CoarsenOptions options;
  options.placement = placement;
  options.boundary_onto_input = boundary_onto_input;
  return coarsen_clustering(l.mesh, topology, l.labels, clusters, options);
}

bool has_edge(const Mesh& m, uint32_t a, uint32_t b) {
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      uint32_t x = m.indices[3 * f + k], y = m.indices[3 * f + (k + 1) % 3];
      if ((x == a && y == b) || (x == b && y == a)) return true;
    }
  return false;
}

// Block clustering of an nx * ny quad grid into blocks of size x size quads, numbered row by row.
std::function<uint32_t(int, int)> blocks(int nx, int size) {
  int per_row = (nx + size - 1) / size;
  return [=](int i, int j) { return uint32_t((j / size) * per_row + i / size); };
}

}  // namespace

TEST_CASE("coarsen: four clusters on a sphere give an outward tetrahedron") {
  Labeled s = sphere_four_clusters(3);
  CoarsenResult r = coarsen(s, 4);
  CHECK(r.defects.empty());
  Surface out = inspect(r.mesh);
  CHECK(r.mesh.vertex_count() == 4);
  CHECK(out.vertices == 4);
  CHECK(out.faces == 4);
  CHECK(out.edges == 6);
  CHECK(out.boundary_edges == 0);
  CHECK(out.chi() == 2);
  CHECK(out.repeated_directed == 0);
  CHECK(out.degenerate == 0);
  CHECK(r.corner_vertices == 4);
  CHECK(r.polygons_triangulated == 0);
  // Orientation follows the input: every triangle faces away from the sphere's center.
  for (size_t f = 0; f < r.mesh.face_count(); ++f) {
    const float* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &r.mesh.positions[3 * r.mesh.indices[3 * f + k]];
    double u[3], w[3], n[3], c[3];
    for (int d = 0; d < 3; ++d) u[d] = p[1][d] - p[0][d], w[d] = p[2][d] - p[0][d], c[d] = p[0][d] + p[1][d] + p[2][d];
    n[0] = u[1] * w[2] - u[2] * w[1], n[1] = u[2] * w[0] - u[0] * w[2], n[2] = u[0] * w[1] - u[1] * w[0];
    CHECK(n[0] * c[0] + n[1] * c[1] + n[2] * c[2] > 0);
  }
  // Flipping every input face flips every output triangle.
  Labeled flipped = s;
  for (size_t f = 0; f < flipped.mesh.face_count(); ++f)
    std::swap(flipped.mesh.indices[3 * f + 1], flipped.mesh.indices[3 * f + 2]);
  CoarsenResult rf = coarsen(flipped, 4);
  CHECK(rf.defects.empty());
  REQUIRE(rf.mesh.face_count() == 4);
  std::set<std::array<uint32_t, 3>> forward, backward;
  auto canonical = [](uint32_t a, uint32_t b, uint32_t c) {
    std::array<uint32_t, 3> t{a, b, c};
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    return t;
  };
  for (size_t f = 0; f < 4; ++f) {
    const uint32_t* t = &r.mesh.indices[3 * f];
    const uint32_t* u = &rf.mesh.indices[3 * f];
    forward.insert(canonical(t[0], t[2], t[1]));  // reversed
    backward.insert(canonical(u[0], u[1], u[2]));
  }
  CHECK(forward == backward);
}

TEST_CASE("coarsen: 3x3 blocks of a planar grid give a 3x3 vertex grid with one boundary loop") {
  Labeled g = grid(9, 9, blocks(9, 3));
  CoarsenResult r = coarsen(g, 9);
  CHECK(r.defects.empty());
  Surface out = inspect(r.mesh);
  CHECK(out.vertices == 9);
  CHECK(out.faces == 8);  // four 4-cluster corners, two triangles each
  CHECK(r.polygons_triangulated == 4);
  CHECK(out.boundary_edges == 8);
  CHECK(out.boundary_loops == 1);
  CHECK(out.chi() == 1);
  CHECK(out.overused_edges == 0);
  CHECK(out.repeated_directed == 0);
  CHECK(out.degenerate == 0);
  CHECK(r.boundary_edges == 8);
  // The output boundary follows the input loop: block (0,0) -> (1,0) -> (2,0) -> (2,1) -> ...
  const uint32_t loop[8] = {0, 1, 2, 5, 8, 7, 6, 3};
  for (int k = 0; k < 8; ++k) CHECK(out.boundary.count(std::minmax(loop[k], loop[(k + 1) % 8])) == 1);
  // Orientation follows the input (counter-clockwise seen from +z).
  for (size_t f = 0; f < r.mesh.face_count(); ++f) {
    const float* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &r.mesh.positions[3 * r.mesh.indices[3 * f + k]];
    CHECK((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]) > 0);
  }
}

TEST_CASE("coarsen: a grid with a hole keeps two boundary loops, corners at the hole are not cut off") {
  // 15 x 15 quads in 5 x 5 blocks of 3; the center block is a hole.
  auto hole = [](int i, int j) { return !(i / 3 == 2 && j / 3 == 2); };
  auto label = [](int i, int j) {
    uint32_t b = uint32_t((j / 3) * 5 + i / 3);
    return b > 12 ? b - 1 : b;  // block 12 is the hole
  };
  Labeled g = grid(15, 15, label, hole);
  CoarsenResult r = coarsen(g, 24);
  CHECK(r.defects.empty());
  Surface out = inspect(r.mesh);
  CHECK(out.vertices == 24);
  // 12 interior 4-cluster corners (2 triangles each) + 4 hole corners where 3 clusters meet.
  CHECK(out.faces == 28);
  CHECK(out.boundary_loops == 2);
  CHECK(out.boundary_edges == 16 + 4);
  CHECK(out.chi() == 0);
  CHECK(out.overused_edges == 0);
  CHECK(out.repeated_directed == 0);
  CHECK(out.degenerate == 0);
  // The inner loop runs through the four blocks sharing an edge with the hole: 7, 11, 12, 16
  // (block numbers 7, 11, 13, 17 before removing the hole).
  for (auto [a, b] : {std::pair{7u, 12u}, {12u, 16u}, {16u, 11u}, {11u, 7u}})
    CHECK(out.boundary.count(std::minmax(a, b)) == 1);
  // Block 6 touches the hole at its corner only: the triangle (11, 6, 7) there keeps it inside.
  CHECK(has_edge(r.mesh, 6, 7));
  CHECK(has_edge(r.mesh, 6, 11));
  CHECK(out.boundary.count({6u, 7u}) == 0);
}

// The coarse mesh of an engine clustering of grid g (n clusters), with or without the boundary
// step; and what the tests below look at: its smallest angle (degrees), its angles below 30
// degrees, and its vertices on the boundary edges.
// The vertices of the edges of one triangle.
std::set<uint32_t> boundary_vertex_set(const Mesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (size_t f = 0; f < m.face_count(); ++f)
    for (int k = 0; k < 3; ++k) ++uses[std::minmax(m.indices[3 * f + k], m.indices[3 * f + (k + 1) % 3])];
  std::set<uint32_t> on_boundary;
  for (const auto& [edge, count] : uses)
    if (count == 1) on_boundary.insert({edge.first, edge.second});
  return on_boundary;
}

struct OpenCoarse {
  CoarsenResult r;
  double min_angle = 180;
  uint64_t below_30 = 0;
  std::vector<uint32_t> boundary_vertices;
};
OpenCoarse coarsen_open(const Labeled& g, uint32_t n, bool boundary_onto_input, unsigned threads = 0) {
  Topology topology = build_topology(g.mesh);
  ClusterOptions co;
  co.clusters = n;
  const Clustering c = cluster(g.mesh, topology, co);
  CoarsenOptions options;
  options.boundary_onto_input = boundary_onto_input;
  options.threads = threads;
  OpenCoarse out;
  out.r = coarsen_clustering(g.mesh, topology, c.labels, n, options);
  const Mesh& m = out.r.mesh;
  const TriangleQuality q = triangle_quality(m);
  out.min_angle = q.min_angle_deg;
  out.below_30 = q.angles_below_30;
  const std::set<uint32_t> on_boundary = boundary_vertex_set(m);
  out.boundary_vertices.assign(on_boundary.begin(), on_boundary.end());
  return out;
}

TEST_CASE("coarsen: an open square's coarse boundary lies on its boundary and keeps its four corners") {
  // 30 x 30 unit quads; the engine's clustering into 60.
  Labeled g = grid(30, 30, [](int, int) { return 0u; });
  const OpenCoarse on = coarsen_open(g, 60, true), off = coarsen_open(g, 60, false);
  REQUIRE(on.r.defects.empty());
  REQUIRE(off.r.defects.empty());
  auto on_square = [](const float* p) {
    return std::fabs(p[0]) < 1e-5 || std::fabs(p[0] - 30) < 1e-5 || std::fabs(p[1]) < 1e-5 || std::fabs(p[1] - 30) < 1e-5;
  };
  auto is_corner = [](const float* p) {
    return (std::fabs(p[0]) < 1e-5 || std::fabs(p[0] - 30) < 1e-5) && (std::fabs(p[1]) < 1e-5 || std::fabs(p[1] - 30) < 1e-5);
  };
  auto count = [&](const OpenCoarse& c, auto&& test) {
    int k = 0;
    for (uint32_t v : c.boundary_vertices) k += test(&c.r.mesh.positions[3 * size_t(v)]);
    return k;
  };
  // Each vertex of the coarse boundary on the square's, the corners among them.
  CHECK(on.boundary_vertices.size() >= 8);
  CHECK(count(on, on_square) == int(on.boundary_vertices.size()));
  CHECK(count(on, is_corner) == 4);
  CHECK(on.r.boundary_corners == 4);
  CHECK(on.r.boundary_vertices_moved == on.boundary_vertices.size());
  CHECK(on.r.boundary_left_inside == 0);
  // Without the step the boundary runs inside and cuts the corners.
  CHECK(count(off, on_square) < int(off.boundary_vertices.size()));
  CHECK(count(off, is_corner) == 0);
  CHECK(off.r.boundary_vertices_moved == 0);
  // Same connectivity class, and the quality columns' limits kept.
  CHECK(on.boundary_vertices.size() == off.boundary_vertices.size());
  CHECK(on.min_angle >= std::min(off.min_angle, 30.0) - 1e-9);
  CHECK(on.below_30 <= off.below_30);
  // The same to the bit on one thread and on three.
  const OpenCoarse one = coarsen_open(g, 60, true, 1), three = coarsen_open(g, 60, true, 3);
  CHECK(one.r.mesh.positions == three.r.mesh.positions);
  CHECK(one.r.mesh.indices == three.r.mesh.indices);
  CHECK(one.r.mesh.positions == on.r.mesh.positions);
}

TEST_CASE("coarsen: the boundary step takes a hole's corners, and leaves a hole smaller than the triangles alone") {
  // 30 x 30 quads with a 10 x 10 hole (a loop of 40 unit edges) and a 1 x 1 hole (4 unit edges);
  // 60 clusters: coarse edges of about 4.
  auto keep = [](int i, int j) { return !(i >= 10 && i < 20 && j >= 10 && j < 20) && !(i == 4 && j == 25); };
  Labeled g = grid(30, 30, [](int, int) { return 0u; }, keep);
  const Topology topology = build_topology(g.mesh);
  CoarsenMeshOptions options;  // the whole job: the fix loop makes the clustering's dual clean
  options.cluster.clusters = 60;
  const CoarsenMeshResult job = coarsen_mesh(g.mesh, topology, options);
  const CoarsenResult& r = job.coarse;
  REQUIRE(r.defects.empty());
  const std::set<uint32_t> boundary_vertices = boundary_vertex_set(r.mesh);
  int hole_corners = 0, on_big_hole = 0, on_small_hole = 0;
  for (uint32_t v : boundary_vertices) {
    const float* p = &r.mesh.positions[3 * size_t(v)];
    const bool x_in = p[0] >= 10 - 1e-5 && p[0] <= 20 + 1e-5, y_in = p[1] >= 10 - 1e-5 && p[1] <= 20 + 1e-5;
    const bool x_side = std::fabs(p[0] - 10) < 1e-5 || std::fabs(p[0] - 20) < 1e-5;
    const bool y_side = std::fabs(p[1] - 10) < 1e-5 || std::fabs(p[1] - 20) < 1e-5;
    on_big_hole += (x_side && y_in) || (y_side && x_in);
    hole_corners += x_side && y_side;
    on_small_hole += p[0] >= 4 - 1e-5 && p[0] <= 5 + 1e-5 && p[1] >= 25 - 1e-5 && p[1] <= 26 + 1e-5;
  }
  CHECK(hole_corners == 4);
  CHECK(on_big_hole >= 4);
  // The small hole's clusters keep their points: none on its rim.
  CHECK(on_small_hole == 0);
}

TEST_CASE("coarsen: the boundary step is undone where it would cost the mesh angles below 30 degrees") {
  // A strip of 30 x 6 quads with small bumps, 20 clusters: two rows of clusters, each along one
  // side. Onto the sides, the two rows' vertices end the strip's width apart instead of about
  // half of it, and the triangles between them get taller than the relax can make up for
  // (measured without the undo: smallest angle 41.4 -> 28.9 degrees, one angle below 30).
  Mesh m;
  const int nx = 30, ny = 6;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) add_vertex(m, i, j, 0.02 * ((i * 7 + j * 3) % 5));
  auto id = [&](int i, int j) { return uint32_t(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      m.indices.insert(m.indices.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j), id(i + 1, j + 1), id(i, j + 1)});
  const Topology topology = build_topology(m);
  CoarsenMeshOptions options;
  options.cluster.clusters = 20;
  const CoarsenMeshResult on = coarsen_mesh(m, topology, options);
  options.coarsen.boundary_onto_input = false;
  const CoarsenMeshResult off = coarsen_mesh(m, topology, options);
  REQUIRE(on.coarse.defects.empty());
  REQUIRE(on.clustering.labels == off.clustering.labels);
  CHECK(on.coarse.boundary_left_inside > 0);
  CHECK(on.coarse.boundary_vertices_moved == 0);
  CHECK(on.coarse.mesh.positions == off.coarse.mesh.positions);
  CHECK(on.coarse.mesh.indices == off.coarse.mesh.indices);
  const TriangleQuality q_on = triangle_quality(on.coarse.mesh), q_off = triangle_quality(off.coarse.mesh);
  CHECK(q_on.min_angle_deg >= std::min(q_off.min_angle_deg, 30.0));
  CHECK(q_on.angles_below_30 <= q_off.angles_below_30);
}

TEST_CASE("coarsen: a block clustering of a torus keeps chi = 0") {
  Labeled t = torus(16, 12, [](int i, int j) { return uint32_t((j / 3) * 4 + i / 4); });
  CoarsenResult r = coarsen(t, 16);
  CHECK(r.defects.empty());
  Surface out = inspect(r.mesh);
  CHECK(out.vertices == 16);
  CHECK(out.faces == 32);
  CHECK(out.edges == 48);
  CHECK(out.chi() == 0);
  CHECK(out.boundary_edges == 0);
  CHECK(out.overused_edges == 0);
  CHECK(out.repeated_directed == 0);
  CHECK(out.degenerate == 0);
}

TEST_CASE("coarsen: an n-gon corner gives n - 2 triangles") {
  for (uint32_t n : {4u, 5u, 7u}) {
    CAPTURE(n);
    std::vector<std::array<double, 2>> rim;
    for (uint32_t i = 0; i < n; ++i) {
      double a = 2 * std::numbers::pi * (i + 0.3 * (i % 2)) / n;
      rim.push_back({std::cos(a) * (1 + 0.2 * (i % 3)), std::sin(a) * (1 + 0.2 * (i % 3))});
    }
    Labeled w = wheel(rim, 2);
    CoarsenResult r = coarsen(w, n);
    CHECK(r.defects.empty());
    Surface out = inspect(r.mesh);
    CHECK(out.faces == n - 2);
    CHECK(r.polygons_triangulated == 1);
    CHECK(out.boundary_loops == 1);
    CHECK(out.boundary_edges == n);
    CHECK(out.chi() == 1);
    CHECK(out.repeated_directed == 0);
    CHECK(out.degenerate == 0);
  }
}

TEST_CASE("coarsen: a quad corner is split along the diagonal that maximizes the minimum angle") {
  // The sectors' centroids (the qem points of flat clusters) form a rhombus twice as long as wide:
  // the short diagonal gives angles >= 53 degrees, the long one 26.6 degrees.
  // Rim points r_i with (r_i + r_{i+1}) / 3 = the rhombus corners (2,0), (0,1), (-2,0), (0,-1).
  std::vector<std::array<double, 2>> wide = {{3, -1.5}, {3, 1.5}, {-3, 1.5}, {-3, -1.5}};
  Labeled w = wheel(wide, 2);
  // (The rim is the wheel's boundary: the sectors' points stay where qem puts them.)
  CoarsenResult r = coarsen(w, 4, VertexPlacement::qem, /*boundary_onto_input=*/false);
  REQUIRE(r.mesh.face_count() == 2);
  CHECK(std::fabs(r.mesh.positions[0] - 2.0f) < 1e-5f);  // sector 0's centroid
  CHECK(std::fabs(r.mesh.positions[4] - 1.0f) < 1e-5f);  // sector 1's
  CHECK(has_edge(r.mesh, 1, 3));
  CHECK(!has_edge(r.mesh, 0, 2));
  // Numbering the sectors from the next one makes the other diagonal win: not a fixed fan.
  std::vector<std::array<double, 2>> shifted = {wide[1], wide[2], wide[3], wide[0]};
  CoarsenResult rt = coarsen(wheel(shifted, 2), 4, VertexPlacement::qem, /*boundary_onto_input=*/false);
  REQUIRE(rt.mesh.face_count() == 2);
  CHECK(has_edge(rt.mesh, 0, 2));
  CHECK(!has_edge(rt.mesh, 1, 3));
  CHECK(rt.defects.empty());
  CHECK(r.defects.empty());
}

TEST_CASE("coarsen: an annulus cluster is reported as not a disk") {
  // 15 x 15 quads in 5 x 5 blocks; the 8 blocks around the center block form cluster 0 (an
  // annulus), the center block is cluster 1, the 16 outer blocks clusters 2..17.
  std::map<int, uint32_t> outer;
  for (int b = 0; b < 25; ++b)
    if (std::max(std::abs(b % 5 - 2), std::abs(b / 5 - 2)) == 2) outer[b] = uint32_t(2 + outer.size());
  auto label = [&](int i, int j) {
    int bi = i / 3, bj = j / 3, ring = std::max(std::abs(bi - 2), std::abs(bj - 2));
    return ring == 1 ? 0u : ring == 0 ? 1u : outer.at(bj * 5 + bi);
  };
  Labeled g = grid(15, 15, label);
  Topology topology = build_topology(g.mesh);
  std::vector<DualDefect> defects = find_dual_defects(g.mesh, topology, g.labels, 18);
  CHECK(has_defect(defects, DualDefect::cluster_not_disk, 0));
  for (const DualDefect& d : defects)
    if (d.kind == DualDefect::cluster_not_disk) CHECK(d.cluster == 0);
  // The same list as the full construction, which still produces a mesh.
  CoarsenResult r = coarsen_clustering(g.mesh, topology, g.labels, 18);
  CHECK(r.defects == defects);
  CHECK(r.mesh.vertex_count() == 18);
}

TEST_CASE("coarsen: a disconnected or pinched cluster is reported") {
  // Cluster 0 in two separate blocks of a 3 x 1 block strip.
  Labeled g = grid(9, 3, [](int i, int) { return uint32_t(i / 3 == 1 ? 1 : 0); });
  Topology topology = build_topology(g.mesh);
  std::vector<DualDefect> defects = find_dual_defects(g.mesh, topology, g.labels, 2);
  CHECK(has_defect(defects, DualDefect::cluster_not_disk, 0));
  CHECK(!has_defect(defects, DualDefect::cluster_not_disk, 1));
  // Checkerboard 2 x 2 blocks: each cluster's blocks touch at the middle vertex only.
  Labeled c = grid(6, 6, [](int i, int j) { return uint32_t((i / 3 + j / 3) % 2); });
  Topology ct = build_topology(c.mesh);
  std::vector<DualDefect> cd = find_dual_defects(c.mesh, ct, c.labels, 2);
  CHECK(has_defect(cd, DualDefect::cluster_not_disk, 0));
  CHECK(has_defect(cd, DualDefect::cluster_not_disk, 1));
}

TEST_CASE("coarsen: a cluster in two pieces whose Euler characteristics add up to 1 is reported") {
  // 21 x 21 quads in 7 x 7 blocks: cluster 0 is the ring of 8 blocks around the center (chi 0)
  // plus the far corner block (chi 1), which does not touch the ring. Only connectivity tells.
  auto label = [](int i, int j) {
    int bi = i / 3, bj = j / 3, ring = std::max(std::abs(bi - 3), std::abs(bj - 3));
    if (ring == 1 || (bi == 0 && bj == 0)) return 0u;
    return ring == 0 ? 1u : 2u;
  };
  Labeled g = grid(21, 21, label);
  Topology topology = build_topology(g.mesh);
  std::vector<DualDefect> defects = find_dual_defects(g.mesh, topology, g.labels, 3);
  CHECK(has_defect(defects, DualDefect::cluster_not_disk, 0));
  CHECK(!has_defect(defects, DualDefect::cluster_not_disk, 1));
}

TEST_CASE("coarsen: two polygons of the same four clusters take different diagonals") {
  // Octahedron faces grouped by the quadrant of (x, y): four clusters meeting at +z and at -z in
  // two 4-cluster corners. The same diagonal at both would give two copies of two triangles; the
  // second polygon avoids the diagonal the first took, and the dual is a tetrahedron.
  Labeled s = sphere_four_clusters(2);
  for (size_t f = 0; f < s.mesh.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) c[d] += s.mesh.positions[3 * s.mesh.indices[3 * f + k] + d];
    s.labels[f] = (c[0] > 0 ? 0u : 1u) + (c[1] > 0 ? 0u : 2u);
  }
  CoarsenResult r = coarsen(s, 4);
  CHECK(r.defects.empty());
  CHECK(r.polygons_triangulated == 2);
  Surface out = inspect(r.mesh);
  CHECK(out.faces == 4);
  CHECK(out.edges == 6);
  CHECK(out.chi() == 2);
  CHECK(out.boundary_edges == 0);
  CHECK(out.overused_edges == 0);
  CHECK(out.repeated_directed == 0);
}

TEST_CASE("coarsen: a triangle produced twice with the same orientation is kept once") {
  // A broken clustering of a 4 x 4 quad grid (rows from the top) found by search: clusters 0, 1, 2
  // meet at two vertices with the same cyclic order.
  const uint32_t rows[4][4] = {{1, 1, 0, 1}, {0, 1, 0, 1}, {0, 2, 2, 1}, {0, 2, 2, 1}};
  Labeled g = grid(4, 4, [&](int i, int j) { return rows[3 - j][i]; });
  CoarsenResult r = coarsen(g, 3);
  CHECK(r.merged_triangles == 1);
  std::set<std::array<uint32_t, 3>> seen;
  for (size_t f = 0; f < r.mesh.face_count(); ++f) {
    std::array<uint32_t, 3> t{r.mesh.indices[3 * f], r.mesh.indices[3 * f + 1], r.mesh.indices[3 * f + 2]};
    std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
    CHECK(seen.insert(t).second);
  }
  CHECK(has_defect(r.defects, DualDefect::double_border, 0, 1));
}

TEST_CASE("coarsen: two clusters sharing two borders are reported") {
  // Blocks (4 x 3, 3 quads each):   row 2: A A A A
  //                                 row 1: C B D A
  //                                 row 0: A A A A
  // A (0) is a disk that meets B (1) above and below it; C (2) too.
  auto label = [](int i, int j) {
    int bi = i / 3, bj = j / 3;
    if (bj != 1 || bi == 3) return 0u;
    return bi == 0 ? 2u : bi == 1 ? 1u : 3u;
  };
  Labeled g = grid(12, 9, label);
  CoarsenResult r = coarsen(g, 4);
  CHECK(has_defect(r.defects, DualDefect::double_border, 0, 1));
  CHECK(has_defect(r.defects, DualDefect::double_border, 0, 2));
  CHECK(!has_defect(r.defects, DualDefect::double_border, 0, 3));
  CHECK(has_defect(r.defects, DualDefect::nonmanifold_output, 0, 1));
  CHECK(!has_defect(r.defects, DualDefect::cluster_not_disk, 0));
  CHECK(inspect(r.mesh).overused_edges > 0);  // what the defect announces
}

TEST_CASE("coarsen: a cluster meeting the boundary in two arcs is reported") {
  // Blocks 3 x 3:  A B A / A A A / A C A. A is a disk (an H) meeting the boundary in two arcs.
  auto label = [](int i, int j) {
    int bi = i / 3, bj = j / 3;
    if (bi == 1 && bj == 2) return 1u;
    if (bi == 1 && bj == 0) return 2u;
    return 0u;
  };
  Labeled g = grid(9, 9, label);
  CoarsenResult r = coarsen(g, 3);
  CHECK(has_defect(r.defects, DualDefect::boundary_arcs, 0));
  CHECK(!has_defect(r.defects, DualDefect::boundary_arcs, 1));
  CHECK(!has_defect(r.defects, DualDefect::cluster_not_disk, 0));
  // B's border with A runs from boundary to boundary: no triangle can carry the boundary edge.
  CHECK(has_defect(r.defects, DualDefect::missing_boundary_edge, 0, 1));
}

TEST_CASE("coarsen: a hole along the border of only two clusters is reported, and fixed by the whole job") {
  // The four-cluster sphere with one face of cluster 0 taken out at a corner where clusters 0, 2
  // and 3 meet, along the border of 0 and 2: the hole's corners are that corner, a vertex of the
  // 0|2 border and one inside 0. Every cluster stays a disk meeting the boundary at most once and
  // the 0|2 border stays one chain, yet along the hole the open fans end in clusters 0 and 2 alone
  // (3 is inside the corner's fan): the output would close over the hole, 0-2 an edge of two
  // triangles instead of one. Found by the first version of the check, on ChineseDragon -> 300,
  // whose fix loop left such a hole and a chi of 1 instead of 0.
  Labeled o = sphere_four_clusters(3);
  const Topology before = build_topology(o.mesh);
  auto clusters_at = [&](uint32_t v) {
    std::set<uint32_t> c;
    for (uint32_t i = before.vertex_face_offsets[v]; i < before.vertex_face_offsets[v + 1]; ++i)
      c.insert(o.labels[before.vertex_faces[i]]);
    return c;
  };
  size_t hole = SIZE_MAX;
  for (size_t f = 0; f < o.mesh.face_count() && hole == SIZE_MAX; ++f) {
    if (o.labels[f] != 0) continue;
    int corner = 0, border = 0, inside = 0;
    for (int k = 0; k < 3; ++k) {
      const std::set<uint32_t> c = clusters_at(o.mesh.indices[3 * f + k]);
      corner += c == std::set<uint32_t>{0, 2, 3};
      border += c == std::set<uint32_t>{0, 2};
      inside += c == std::set<uint32_t>{0};
    }
    if (corner == 1 && border == 1 && inside == 1) hole = f;
  }
  REQUIRE(hole != SIZE_MAX);
  o.mesh.indices.erase(o.mesh.indices.begin() + 3 * hole, o.mesh.indices.begin() + 3 * hole + 3);
  o.labels.erase(o.labels.begin() + hole);
  CoarsenResult r = coarsen(o, 4);
  CHECK((has_defect(r.defects, DualDefect::missing_boundary_edge, 0, 2) ||
         has_defect(r.defects, DualDefect::missing_boundary_edge, 2, 0)));
  for (const DualDefect& d : r.defects) CHECK(d.kind == DualDefect::missing_boundary_edge);
  // The whole job on this mesh (its own clustering, fixed where needed) keeps the hole and chi 1.
  const Topology topology = build_topology(o.mesh);
  REQUIRE(topology.boundary_loops == 1);
  CoarsenMeshOptions job;
  job.cluster.clusters = 12;
  CoarsenMeshResult fixed = coarsen_mesh(o.mesh, topology, job);
  CHECK(!fixed.defects_remain);
  Surface s = inspect(fixed.coarse.mesh);
  CHECK(s.boundary_loops == 1);
  CHECK(s.chi() == 1);
}

TEST_CASE("coarsen: three clusters on a sphere give two opposite triangles, reported") {
  // Octahedron faces by octant: x > 0 is A; x < 0 split by y into B and C.
  Labeled s = sphere_four_clusters(2);
  for (size_t f = 0; f < s.mesh.face_count(); ++f) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int d = 0; d < 3; ++d) c[d] += s.mesh.positions[3 * s.mesh.indices[3 * f + k] + d];
    s.labels[f] = c[0] > 0 ? 0 : c[1] > 0 ? 1 : 2;
  }
  CoarsenResult r = coarsen(s, 3);
  CHECK(r.mesh.face_count() == 2);
  CHECK(has_defect(r.defects, DualDefect::duplicate_triangle, 0, 1));
  Surface out = inspect(r.mesh);
  CHECK(out.repeated_directed == 0);  // the two copies are oppositely oriented
}

TEST_CASE("coarsen: coincident coarse vertices and flipped input faces are reported") {
  // Octahedron, one cluster per face: 8 clusters of one face share 6 vertices, so `closest` must
  // put two clusters on one point. The dual is a cube (six 4-cluster corners, 12 triangles).
  Labeled o = sphere_four_clusters(0);
  for (uint32_t f = 0; f < 8; ++f) o.labels[f] = f;
  CoarsenResult r = coarsen(o, 8);
  CHECK(r.mesh.face_count() == 12);
  CHECK(std::any_of(r.defects.begin(), r.defects.end(),
                    [](const DualDefect& d) { return d.kind == DualDefect::degenerate_triangle; }));
  CHECK(inspect(r.mesh).degenerate > 0);
  // With face centroids (qem of a single flat face) the cube has 8 distinct corners: clean.
  CoarsenResult q = coarsen(o, 8, VertexPlacement::qem);
  CHECK(q.defects.empty());
  Surface cube_out = inspect(q.mesh);
  CHECK(cube_out.chi() == 2);
  CHECK(cube_out.degenerate == 0);

  // Cluster 0's faces flipped against their neighbours: the output cannot be consistent.
  Labeled s = sphere_four_clusters(2);
  for (size_t f = 0; f < s.mesh.face_count(); ++f)
    if (s.labels[f] == 0) std::swap(s.mesh.indices[3 * f + 1], s.mesh.indices[3 * f + 2]);
  CoarsenResult flipped = coarsen(s, 4);
  CHECK(flipped.mesh.face_count() == 4);
  CHECK(std::any_of(flipped.defects.begin(), flipped.defects.end(),
                    [](const DualDefect& d) { return d.kind == DualDefect::inconsistent_orientation; }));
}

TEST_CASE("coarsen: empty clusters and bad inputs") {
  Labeled g = grid(9, 9, blocks(9, 3));
  Topology topology = build_topology(g.mesh);
  // An unused cluster id: reported, its vertex unused.
  CoarsenResult r = coarsen_clustering(g.mesh, topology, g.labels, 10);
  CHECK(r.mesh.vertex_count() == 10);
  CHECK(has_defect(r.defects, DualDefect::empty_cluster, 9));
  CHECK(r.defects.size() == 1);
  CHECK(r.mesh.face_count() == 8);
  std::vector<uint32_t> bad = g.labels;
  bad[5] = 9;
  CHECK_THROWS_AS(coarsen_clustering(g.mesh, topology, bad, 9), OptionError);
  bad.pop_back();
  CHECK_THROWS_AS(coarsen_clustering(g.mesh, topology, bad, 9), OptionError);
  std::vector<float> weights(g.mesh.face_count(), 1.0f);
  weights[3] = -1;
  CHECK_THROWS_AS(coarsen_clustering(g.mesh, topology, g.labels, 9, {}, &weights), OptionError);
  weights.pop_back();
  CHECK_THROWS_AS(coarsen_clustering(g.mesh, topology, g.labels, 9, {}, &weights), OptionError);
  Topology other = build_topology(grid(3, 3, blocks(3, 3)).mesh);
  CHECK_THROWS_AS(coarsen_clustering(g.mesh, other, g.labels, 9), OptionError);
  CHECK(parse_vertex_placement("qem") == VertexPlacement::qem);
  CHECK(parse_vertex_placement("closest") == VertexPlacement::closest);
  CHECK(parse_vertex_placement("projected") == VertexPlacement::projected);
  CHECK_THROWS_AS(parse_vertex_placement("centroid"), OptionError);
  CHECK(std::string(to_string(VertexPlacement::projected)) == "projected");
  CHECK(std::string(to_string(DualDefect::double_border)) == "double_border");
}

TEST_CASE("coarsen: closest placement picks a vertex of the cluster near its centroid") {
  Labeled s = sphere_four_clusters(3);
  std::vector<float> p = place_cluster_vertices(s.mesh, s.labels, 4, VertexPlacement::closest);
  CHECK(p == coarsen(s, 4).mesh.positions);  // the points the dual uses
  std::vector<float> c = cluster_mass_centroids(s.mesh, s.labels, 4);
  for (uint32_t i = 0; i < 4; ++i) {
    CAPTURE(i);
    // p_i is a corner of a face of cluster i, and no corner of the cluster is closer to c_i.
    bool found = false;
    double best = INFINITY, chosen = 0;
    for (size_t f = 0; f < s.mesh.face_count(); ++f) {
      if (s.labels[f] != i) continue;
      for (int k = 0; k < 3; ++k) {
        const float* v = &s.mesh.positions[3 * s.mesh.indices[3 * f + k]];
        double d2 = 0;
        for (int d = 0; d < 3; ++d) d2 += (double(v[d]) - c[3 * i + d]) * (double(v[d]) - c[3 * i + d]);
        best = std::min(best, d2);
        if (v[0] == p[3 * i] && v[1] == p[3 * i + 1] && v[2] == p[3 * i + 2]) found = true, chosen = d2;
      }
    }
    CHECK(found);
    CHECK(chosen == best);
  }
}

TEST_CASE("coarsen: clusters of a single face each get their own corner") {
  // Four fat sectors of a square wheel, one face each: every centroid is nearest the shared center,
  // so the nearest corner alone would put all four coarse vertices on it.
  Labeled w = wheel({{1, 0}, {0, 1}, {-1, 0}, {0, -1}}, 0);
  std::vector<float> p = place_cluster_vertices(w.mesh, w.labels, 4, VertexPlacement::closest);
  std::set<std::array<float, 3>> distinct;
  for (uint32_t i = 0; i < 4; ++i) distinct.insert({p[3 * i], p[3 * i + 1], p[3 * i + 2]});
  CHECK(distinct.size() == 4);
  CHECK(p[0] == 0.0f);  // cluster 0 still gets the nearest corner, the center
  CHECK(p[1] == 0.0f);
}

TEST_CASE("coarsen: mass centroids follow the face weights") {
  Labeled g = grid(4, 2, [](int, int) { return 0u; });
  std::vector<float> c = cluster_mass_centroids(g.mesh, g.labels, 1);
  CHECK(c[0] == doctest::Approx(2.0));
  CHECK(c[1] == doctest::Approx(1.0));
  std::vector<float> weights(g.mesh.face_count(), 1.0f);
  for (size_t f = 0; f < weights.size(); ++f)
    if (g.mesh.positions[3 * g.mesh.indices[3 * f]] >= 2) weights[f] = 3.0f;  // right half weighs 3
  c = cluster_mass_centroids(g.mesh, g.labels, 1, &weights);
  CHECK(c[0] == doctest::Approx((1.0 * 1 + 3.0 * 3) / 4));
  CHECK(c[1] == doctest::Approx(1.0));
}

TEST_CASE("coarsen: qem on a flat cluster lies in its plane, at a cube corner recovers the corner") {
  // A grid turned into a tilted plane; two clusters.
  Labeled g = grid(6, 6, [](int i, int) { return uint32_t(i / 3); });
  const double n[3] = {0.36, 0.48, 0.8};  // unit normal of the plane after the map below
  for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    float* p = &g.mesh.positions[3 * v];
    double x = p[0], y = p[1];
    // Orthonormal basis of the plane n . q = 2: e1 = (0.8, 0, -0.36)/|.|, e2 = n x e1.
    double e1[3] = {0.8, 0, -0.36}, l1 = std::sqrt(0.8 * 0.8 + 0.36 * 0.36);
    for (double& e : e1) e /= l1;
    double e2[3] = {n[1] * e1[2] - n[2] * e1[1], n[2] * e1[0] - n[0] * e1[2], n[0] * e1[1] - n[1] * e1[0]};
    for (int d = 0; d < 3; ++d) p[d] = float(2 * n[d] + x * e1[d] + y * e2[d]);
  }
  std::vector<float> q = place_cluster_vertices(g.mesh, g.labels, 2, VertexPlacement::qem);
  std::vector<float> c = cluster_mass_centroids(g.mesh, g.labels, 2);
  for (int i = 0; i < 2; ++i) {
    double offset = n[0] * q[3 * i] + n[1] * q[3 * i + 1] + n[2] * q[3 * i + 2] - 2;
    CHECK(std::fabs(offset) < 1e-5);
    for (int d = 0; d < 3; ++d) CHECK(q[3 * i + d] == doctest::Approx(c[3 * i + d]).epsilon(1e-5));
  }

  // The three quarter-faces around the corner (1,1,1) of the unit cube.
  Mesh box = cube(3);
  std::vector<uint32_t> labels =
      labels_by_centroid(box, [](const double* m) { return m[0] > 0.5 && m[1] > 0.5 && m[2] > 0.5 ? 0u : 1u; });
  std::vector<float> corner = place_cluster_vertices(box, labels, 2, VertexPlacement::qem);
  for (int d = 0; d < 3; ++d) CHECK(corner[d] == doctest::Approx(1.0).epsilon(1e-6));
  std::vector<float> centroid = cluster_mass_centroids(box, labels, 2);
  CHECK(centroid[0] < 0.9f);  // the centroid itself is well inside
}

TEST_CASE("coarsen: of the qem points pulled onto one cube corner, the first cluster's stays there") {
  // Each face of the unit cube in four quadrants, one cluster each: at every corner three
  // clusters meet, and each one's lent planes (the two other faces across its two creases) pull
  // its point onto the corner. Coincident points would make degenerate triangles, so of each
  // close pair the later cluster keeps the point of its own plane, its mass centroid; the first
  // keeps the corner. Points on three planes per axis, many sharing a coordinate.
  Mesh box = cube(3);
  std::vector<uint32_t> labels = labels_by_centroid(box, [](const double* m) {
    int axis = 0;  // the axis the face is normal to: its coordinate is 0 or 1 at every corner
    for (int d = 0; d < 3; ++d)
      if (m[d] < 1e-9 || m[d] > 1 - 1e-9) axis = d;
    const uint32_t corner = (m[0] > 0.5) | (m[1] > 0.5) << 1 | (m[2] > 0.5) << 2;
    return 3 * corner + uint32_t(axis);
  });
  std::vector<float> q = place_cluster_vertices(box, labels, 24, VertexPlacement::qem);
  std::vector<float> c = cluster_mass_centroids(box, labels, 24);
  for (uint32_t corner = 0; corner < 8; ++corner) {
    CAPTURE(corner);
    const float at[3] = {float(corner & 1), float(corner >> 1 & 1), float(corner >> 2 & 1)};
    for (int d = 0; d < 3; ++d) CHECK(q[3 * (3 * corner) + d] == doctest::Approx(at[d]).epsilon(1e-6));
    for (uint32_t i = 3 * corner + 1; i < 3 * corner + 3; ++i)
      for (int d = 0; d < 3; ++d) CHECK(q[3 * i + d] == doctest::Approx(c[3 * i + d]).epsilon(1e-5));
  }
}

TEST_CASE("coarsen: qem points of two flat clusters meeting at a crease lie on the crease") {
  // An 8 x 4 grid folded up by 90 degrees along x = 4: a floor (cluster 0, 4 x 4) and a wall
  // (cluster 1, 4 x 2). Each cluster's own planes are one plane, which leaves its point at its
  // centroid, 2 units from the crease; the planes lent across the border pull both onto the crease
  // line (x = 4, z = 0), at different places along it (y = 2 and y = 1).
  Labeled g = grid(8, 4, [](int i, int) { return uint32_t(i >= 4); }, [](int i, int j) { return i < 4 || j < 2; });
  for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    float* p = &g.mesh.positions[3 * v];
    if (p[0] > 4) p[2] = p[0] - 4, p[0] = 4;
  }
  std::vector<float> q = place_cluster_vertices(g.mesh, g.labels, 2, VertexPlacement::qem);
  std::vector<float> c = cluster_mass_centroids(g.mesh, g.labels, 2);
  for (int i = 0; i < 2; ++i) {
    CAPTURE(i);
    CHECK(std::hypot(q[3 * i] - 4.0, q[3 * i + 2] - 0.0) < 1e-4);  // on the crease
    CHECK(q[3 * i + 1] == doctest::Approx(c[3 * i + 1]).epsilon(1e-5));  // along it, at the centroid
    CHECK(std::hypot(c[3 * i] - 4.0, c[3 * i + 2] - 0.0) > 1.5);
  }
}

TEST_CASE("coarsen: a qem point that a weak direction would take off its cluster stays over it") {
  // One cluster: half of a slightly tapered tube (radius 1 + taper * z, z in [0, 2]), as a
  // cluster around a bunny's ear or an elephant's leg. Every tangent plane of a cone passes
  // through its apex, so the quadric's minimizer is the apex, 1 / taper below the cluster, and
  // only the taper constrains the point along the axis (a weak eigenvalue). Clamped to the grown
  // box the point would stand below the cluster's lower edge, where its coarse triangles fold
  // over their neighbours. That direction is dropped: along the axis the point stays at the
  // centroid's height, and across it where the other planes put it.
  for (double taper : {0.02, 0.1, 0.2, 0.3}) {
    CAPTURE(taper);
    Labeled g = grid(8, 8, [](int, int) { return 0u; });
    for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
      float* p = &g.mesh.positions[3 * v];
      const double angle = std::numbers::pi * p[0] / 8, z = p[1] / 4, radius = 1 + taper * z;
      p[0] = float(radius * std::cos(angle));
      p[1] = float(radius * std::sin(angle));
      p[2] = float(z);
    }
    std::vector<float> q = place_cluster_vertices(g.mesh, g.labels, 1, VertexPlacement::qem);
    std::vector<float> c = cluster_mass_centroids(g.mesh, g.labels, 1);
    // (Clamped, the point stood at z = -0.33 to -0.41 from taper 0.1 on, 0.63 from the axis.)
    CHECK(std::fabs(q[2] - c[2]) < 0.35);  // along the axis: over the cluster (z in [0, 2])
    // Across it: the quadric's minimizer for half a circle's tangents, 4 / pi of the radius.
    const double off_axis = std::hypot(q[0], q[1]), radius = 1 + taper * q[2];
    CHECK(off_axis > 1.2 * radius);
    CHECK(off_axis < 1.35 * radius);
  }
}

TEST_CASE("coarsen: qem points pulled onto one line keep their own planes where they would make a flat triangle") {
  // An 8 x 6 grid folded up along x = 4. Floor: cluster 0 (y < 3), 1 (y > 3); wall: 2 (y < 2),
  // 3 (2 < y < 4), 4 (y > 4). The lent planes pull every point onto the crease line, so the
  // triangle of clusters 0, 1, 3 (they meet at (4, 3, 0)) would have no area.
  Labeled g = grid(8, 6, [](int i, int j) {
    if (i < 4) return j < 3 ? 0u : 1u;
    return j < 2 ? 2u : j < 4 ? 3u : 4u;
  });
  for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    float* p = &g.mesh.positions[3 * v];
    if (p[0] > 4) p[2] = p[0] - 4, p[0] = 4;
  }
  std::vector<float> lent = place_cluster_vertices(g.mesh, g.labels, 5, VertexPlacement::qem);
  for (uint32_t c : {0u, 1u, 3u}) CHECK(std::hypot(lent[3 * c] - 4.0, lent[3 * c + 2]) < 1e-4);
  CoarsenOptions options;
  options.placement = VertexPlacement::qem;
  CoarsenResult r = coarsen_clustering(g.mesh, build_topology(g.mesh), g.labels, 5, options);
  CHECK(r.defects.empty());
  CHECK(inspect(r.mesh).degenerate == 0);
  bool kept_own = false;  // some cluster of the flat triangle left the crease
  for (uint32_t c : {0u, 1u, 3u}) kept_own |= std::hypot(r.mesh.positions[3 * c] - 4.0, r.mesh.positions[3 * c + 2]) > 0.5;
  CHECK(kept_own);
}

TEST_CASE("coarsen: qem points left on one line by their own planes take their projected points") {
  // An 8 x 6 grid folded up along x = 4 (cells i < 4 floor, i >= 4 wall). Clusters A (0), B (1)
  // and C (2) each hold cells on both sides of the crease, so their own planes, not only the lent
  // ones, put their points on the crease line; they meet at (3, 4), so the triangle of A, B and C
  // has no area. (A mesh midpoint-subdivided before the clustering is full of such straight
  // creases: the armadillo -> 52000 and boeing -> 2564 with qem kept such triangles, and with
  // them no relax, flips or fitting at all.) D (3) and E (4) are floor and wall, F (5) the wall
  // cells right of B.
  Labeled g = grid(8, 6, [](int i, int j) {
    if (i < 2) return 3u;
    if (i >= 6) return 4u;
    if (j < 2) return 0u;
    if (j >= 4) return 2u;
    return i == 2 ? 0u : i == 5 ? 5u : 1u;
  });
  for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    float* p = &g.mesh.positions[3 * v];
    if (p[0] > 4) p[2] = p[0] - 4, p[0] = 4;
  }
  CoarsenOptions options;
  options.placement = VertexPlacement::qem;
  CoarsenResult r = coarsen_clustering(g.mesh, build_topology(g.mesh), g.labels, 6, options);
  CHECK(r.defects.empty());
  CHECK(inspect(r.mesh).degenerate == 0);
  CHECK(r.relaxed_moves + r.fitted_moves > 0);  // the finishing passes ran
  CHECK(r.surface_points == 1);  // of the three, one point leaves the crease
  // Off, the triangle is a defect, as coarsen_mesh's fix rounds want it.
  options.degenerate_to_surface = false;
  CoarsenResult kept = coarsen_clustering(g.mesh, build_topology(g.mesh), g.labels, 6, options);
  CHECK(kept.defects.size() == 1);
  CHECK(kept.surface_points == 0);
  // The points as placed (no flips, relax or fitting after): of A, B and C, two keep their
  // points on the crease line, one stands on the surface beside it.
  CoarsenOptions placed;
  placed.placement = VertexPlacement::qem;
  placed.relax_passes = placed.fit_passes = 0;
  placed.fit_min_angle_deg = 0;
  placed.flip_edges = false;
  CoarsenResult p = coarsen_clustering(g.mesh, build_topology(g.mesh), g.labels, 6, placed);
  CHECK(p.surface_points == 1);
  int on_crease = 0;
  for (uint32_t c : {0u, 1u, 2u}) on_crease += std::hypot(p.mesh.positions[3 * c] - 4.0, p.mesh.positions[3 * c + 2]) < 1e-3;
  CHECK(on_crease == 2);
}

TEST_CASE("coarsen: qem's edge swaps bring a cube's coarse mesh closer, keeping it a closed manifold") {
  // A CVT clustering does not follow a cube's edges: some dual edges cut across them. Swapping
  // those for the other diagonal lowers the distance to the cube.
  Mesh box = cube(4);  // 3072 faces
  Topology topology = build_topology(box);
  ClusterOptions co;
  co.clusters = 60;
  const std::vector<uint32_t> labels = cluster(box, topology, co).labels;
  CoarsenOptions moves_only, swaps, swaps_one_thread;
  moves_only.placement = swaps.placement = swaps_one_thread.placement = VertexPlacement::qem;
  moves_only.fit_swaps = false;
  swaps.threads = 3;  // several parts even on a one-core machine
  swaps_one_thread.threads = 1;
  CoarsenResult a = coarsen_clustering(box, topology, labels, 60, moves_only);
  CoarsenResult b = coarsen_clustering(box, topology, labels, 60, swaps);
  REQUIRE(a.defects.empty());
  REQUIRE(b.defects.empty());
  CHECK(a.swapped_edges == 0);
  CHECK(b.swapped_edges > 0);
  CHECK(b.mesh.indices != a.mesh.indices);
  CHECK(approximation_error(b.mesh, box).rms < 0.9 * approximation_error(a.mesh, box).rms);
  Surface s = inspect(b.mesh);
  CHECK(s.vertices == 60);
  CHECK(s.chi() == 2);
  CHECK(s.boundary_edges == 0);
  CHECK(s.overused_edges == 0);
  CHECK(s.repeated_directed == 0);
  CHECK(s.degenerate == 0);
  // Swaps one after the other in a fixed order, fixed-point sums: the same for any thread count.
  CoarsenResult c = coarsen_clustering(box, topology, labels, 60, swaps_one_thread);
  CHECK(c.mesh.indices == b.mesh.indices);
  CHECK(c.mesh.positions == b.mesh.positions);
}

TEST_CASE("coarsen: on a curved surface qem's edge swaps make no more thin triangles than they find") {
  // Swaps that only shave some distance may not take a pair's smallest angle below 30 degrees
  // (a floor of 10 tripled bunny00 -> 500's angles below 30); only a swap that removes nearly all
  // of its pair's distance, as along a sharp crease (the cube above), may go lower. The elephant
  // has no such crease.
  const Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  const Topology topology = build_topology(elephant);
  for (uint32_t clusters : {150u, 300u}) {
    CAPTURE(clusters);
    // The whole job (its genus needs the fix loop); the swaps do not change the clustering.
    CoarsenMeshOptions moves_only, swaps;
    moves_only.cluster.clusters = swaps.cluster.clusters = clusters;
    moves_only.coarsen.placement = swaps.coarsen.placement = VertexPlacement::qem;
    moves_only.coarsen.fit_swaps = false;
    // The swaps alone: no widening of thin triangles after them.
    moves_only.coarsen.fit_min_angle_deg = swaps.coarsen.fit_min_angle_deg = 0;
    CoarsenMeshResult a = coarsen_mesh(elephant, topology, moves_only);
    CoarsenMeshResult b = coarsen_mesh(elephant, topology, swaps);
    REQUIRE(!a.defects_remain);
    REQUIRE(!b.defects_remain);
    REQUIRE(a.clustering.labels == b.clustering.labels);
    CHECK(b.coarse.swapped_edges > 0);
    CHECK(approximation_error(b.coarse.mesh, elephant).rms < approximation_error(a.coarse.mesh, elephant).rms);
    CHECK(triangle_quality(b.coarse.mesh).angles_below_30 <= triangle_quality(a.coarse.mesh).angles_below_30);
    // The old floor, asked for: more swaps, more thin triangles.
    CoarsenOptions low_floor = swaps.coarsen;
    low_floor.fit_swap_min_angle_deg = 10;
    CoarsenResult c = coarsen_clustering(elephant, topology, b.clustering.labels, clusters, low_floor);
    REQUIRE(c.defects.empty());
    CHECK(c.swapped_edges > b.coarse.swapped_edges);
    CHECK(triangle_quality(c.mesh).angles_below_30 > triangle_quality(b.coarse.mesh).angles_below_30);
  }
  for (double bad : {-1.0, 61.0, std::nan("")})
    for (double CoarsenOptions::*angle : {&CoarsenOptions::fit_swap_min_angle_deg, &CoarsenOptions::fit_min_angle_deg}) {
      CAPTURE(bad);
      CoarsenOptions o;
      o.placement = VertexPlacement::qem;
      o.*angle = bad;
      std::vector<uint32_t> labels(elephant.face_count(), 0);
      CHECK_THROWS_AS(coarsen_clustering(elephant, topology, labels, 1, o), OptionError);
      CoarsenMeshOptions job;
      job.cluster.clusters = 100;
      job.coarsen = o;
      CHECK_THROWS_AS(coarsen_mesh(elephant, topology, job), OptionError);
    }
}

TEST_CASE("coarsen: qem leaves no sliver that a flip sweeping almost nothing would remove") {
  // At 2400 clusters on the elephant of tests/data (subdivided twice first, as for any qem job
  // with few faces per cluster), the fitting puts three points in a row on a ridge: a 3-degree
  // cap. Its long edge's flip sweeps almost no volume, so it is made after the fitting (the
  // distance to the input barely changes: RESULTS.md has the numbers).
  const Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  CoarsenSurfaceOptions options;
  options.job.cluster.clusters = 2400;
  options.job.coarsen.placement = VertexPlacement::qem;
  const CoarsenSurfaceResult r = coarsen_surface(elephant, options);
  const Mesh& coarse = r.job.coarse.mesh;
  REQUIRE(!r.job.defects_remain);
  REQUIRE(coarse.vertex_count() == 2400);
  Mesh again = coarse;
  CHECK(flip_coarse_edges(again, 0, 8, /*flat_slivers=*/true) == 0);
  CHECK(triangle_quality(coarse).min_angle_deg > 5);
  // The flips keep the mesh what it was: closed, the input's genus, consistently oriented.
  const MeshInfo info = mesh_info(coarse, build_topology(coarse));
  CHECK(info.euler_characteristic == mesh_info(elephant, build_topology(elephant)).euler_characteristic);
  CHECK(info.boundary_loops == 0);
  CHECK(info.nonmanifold_edges == 0);
  CHECK(info.orientation_flips == 0);
}

// Triangles of `coarse` facing against the same triangles with their corners at `surface`.
size_t turned_over_triangles(const Mesh& coarse, const std::vector<float>& surface) {
  size_t count = 0;
  for (size_t t = 0; t < coarse.face_count(); ++t) {
    double n[2][3];
    for (int s = 0; s < 2; ++s) {
      const float* p = s == 0 ? coarse.positions.data() : surface.data();
      const float *a = &p[3 * coarse.indices[3 * t]], *b = &p[3 * coarse.indices[3 * t + 1]],
                  *c = &p[3 * coarse.indices[3 * t + 2]];
      const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
      const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
      n[s][0] = u[1] * v[2] - u[2] * v[1], n[s][1] = u[2] * v[0] - u[0] * v[2], n[s][2] = u[0] * v[1] - u[1] * v[0];
    }
    count += n[0][0] * n[1][0] + n[0][1] * n[1][1] + n[0][2] * n[1][2] < 0;
  }
  return count;
}

// The whole job (coarsen_mesh) with `qem` placement, the other options at their defaults.
CoarsenMeshResult coarsen_qem(const Mesh& mesh, const Topology& topology, uint32_t clusters) {
  CoarsenMeshOptions job;
  job.cluster.clusters = clusters;
  job.coarsen.placement = VertexPlacement::qem;
  CoarsenMeshResult r = coarsen_mesh(mesh, topology, job);
  REQUIRE(!r.defects_remain);
  return r;
}

TEST_CASE("coarsen: qem points never turn a coarse triangle over") {
  // On the elephant's legs, trunk and ears, neighbouring clusters' qem points can cross: the
  // triangle between them then faces against the same triangle on the clusters' projected points
  // (on the surface), a fold no later step undoes. Those corners move toward their projected
  // points until no triangle is turned over; without that, 1, 2, 3 and 1 triangles stayed turned
  // over at these counts.
  const Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  const Topology topology = build_topology(elephant);
  uint64_t unfolded = 0;
  for (uint32_t clusters : {30u, 80u, 100u, 250u}) {
    CAPTURE(clusters);
    CoarsenMeshResult r = coarsen_qem(elephant, topology, clusters);
    const std::vector<float> surface =
        place_cluster_vertices(elephant, r.clustering.labels, clusters, VertexPlacement::projected);
    CHECK(turned_over_triangles(r.coarse.mesh, surface) == 0);
    unfolded += r.coarse.unfolded_vertices;
    // Only qem moves points so.
    CHECK(coarsen_clustering(elephant, topology, r.clustering.labels, clusters).unfolded_vertices == 0);
  }
  CHECK(unfolded > 0);
}

TEST_CASE("coarsen: qem's thin triangles widen toward the surface at little cost in distance") {
  // Last, the corners of triangles below fit_min_angle_deg (default 20) move part of the way back
  // toward their projected points where that lifts their smallest angle and keeps their
  // neighbourhood's squared distance to the input within 1.1x. Off (0), qem keeps triangles of
  // 6.0, 2.4 and 10.2 degrees at these counts (at 500 the last sliver flips lift a 3.8-degree cap;
  // the widening takes that count to 16.0 degrees).
  const Mesh elephant = read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  const Topology topology = build_topology(elephant);
  for (uint32_t clusters : {100u, 200u, 500u}) {
    CAPTURE(clusters);
    CoarsenMeshResult widened = coarsen_qem(elephant, topology, clusters);
    CoarsenOptions off;
    off.placement = VertexPlacement::qem;
    off.fit_min_angle_deg = 0;
    CoarsenResult thin = coarsen_clustering(elephant, topology, widened.clustering.labels, clusters, off);
    REQUIRE(thin.defects.empty());
    CHECK(thin.angle_floor_moves == 0);
    CHECK(widened.coarse.angle_floor_moves > 0);
    const TriangleQuality before = triangle_quality(thin.mesh), after = triangle_quality(widened.coarse.mesh);
    CHECK(before.min_angle_deg < 12);
    CHECK(after.min_angle_deg > before.min_angle_deg + 5);
    CHECK(after.angles_below_30 <= before.angles_below_30);
    CHECK(approximation_error(widened.coarse.mesh, elephant).rms < 1.03 * approximation_error(thin.mesh, elephant).rms);
  }
}

TEST_CASE("coarsen: a thin triangle between two points on one crease widens along the crease") {
  // An 8 x 6 grid folded up along x = 4 (floor z = 0, wall x = 4). Clusters A (y < 3) and B
  // (y > 3) hold the faces next to the crease on both sides, C the rest of the floor, D the rest of
  // the wall. A's and B's points sit on the crease 0.2 apart, so the floor triangle (A, B, C) and
  // the wall triangle (B, A, D) are needles of 4.6 degrees. Their surface points are where they
  // stand, so going toward them changes nothing; along the crease (the one direction their
  // triangles' normals leave free) they can move apart, staying on it.
  Labeled g = grid(8, 6, [](int i, int j) { return i == 3 || i == 4 ? (j < 3 ? 0u : 1u) : i < 3 ? 2u : 3u; });
  for (size_t v = 0; v < g.mesh.vertex_count(); ++v) {
    float* p = &g.mesh.positions[3 * v];
    if (p[0] > 4) p[2] = p[0] - 4, p[0] = 4;
  }
  Mesh coarse;
  add_vertex(coarse, 4, 2.9, 0);  // A
  add_vertex(coarse, 4, 3.1, 0);  // B
  add_vertex(coarse, 1.5, 3, 0);  // C
  add_vertex(coarse, 4, 3, 2.5);  // D
  coarse.indices = {0, 1, 2, 1, 0, 3};
  const std::vector<float> surface = coarse.positions;
  REQUIRE(triangle_quality(coarse).min_angle_deg < 5);
  CHECK(detail::widen_toward_surface(coarse, surface, 20, g.mesh, g.labels) > 0);
  CHECK(triangle_quality(coarse).min_angle_deg >= 20);
  for (int v : {0, 1}) {  // still on the crease
    CHECK(coarse.positions[3 * v] == 4.0f);
    CHECK(coarse.positions[3 * v + 2] == 0.0f);
  }
  CHECK(coarse.positions[4] - coarse.positions[1] > 0.4f);  // A and B apart along it
}

TEST_CASE("coarsen: qem asks for ACVD's input resolution, which a creased mesh of a dozen faces per cluster lacks") {
  // The rule: 20 faces per cluster for qem (ACVD's 10 vertices), 10 for the others; only qem
  // subdivides when the command is not told.
  CHECK(subdivision_faces_per_cluster(VertexPlacement::qem) == 20);
  CHECK(subdivision_faces_per_cluster(VertexPlacement::projected) == 10);
  CHECK(subdivision_faces_per_cluster(VertexPlacement::closest) == 10);
  CHECK(subdivides_by_default(VertexPlacement::qem));
  CHECK(!subdivides_by_default(VertexPlacement::projected));
  CHECK(!subdivides_by_default(VertexPlacement::closest));
  // fandisk -> 1000: 12946 faces, one level for qem, none for the others.
  CHECK(subdivision_levels_for(12946, 1000, subdivision_faces_per_cluster(VertexPlacement::qem)) == 1);
  CHECK(subdivision_levels_for(12946, 1000, subdivision_faces_per_cluster(VertexPlacement::projected)) == 0);
  // Why: a cube at a dozen faces per cluster, clustered and coarsened with qem as given and after
  // one level of subdivision (the same surface). The finer clustering's coarse mesh lies closer.
  for (const auto& [levels, clusters] : {std::pair{3, 60u}, std::pair{4, 240u}}) {
    CAPTURE(clusters);
    const Mesh coarse_input = cube(levels);
    const Mesh fine_input = subdivide_midpoint(coarse_input, 1);
    REQUIRE(subdivision_levels_for(coarse_input.face_count(), clusters,
                                   subdivision_faces_per_cluster(VertexPlacement::qem)) == 1);
    double rms[2];
    for (int fine = 0; fine < 2; ++fine) {
      const Mesh& m = fine ? fine_input : coarse_input;
      CoarsenMeshOptions job;
      job.cluster.clusters = clusters;
      job.coarsen.placement = VertexPlacement::qem;
      CoarsenMeshResult r = coarsen_mesh(m, build_topology(m), job);
      REQUIRE(!r.defects_remain);
      rms[fine] = approximation_error(r.coarse.mesh, coarse_input).rms;
    }
    CHECK(rms[1] < 0.5 * rms[0]);  // measured: 12 and 36 times lower
  }
}

TEST_CASE("coarsen: projected placement lies on the surface, closest to the centroid") {
  Labeled s = sphere_four_clusters(3);
  std::vector<float> p = place_cluster_vertices(s.mesh, s.labels, 4, VertexPlacement::projected);
  std::vector<float> c = cluster_mass_centroids(s.mesh, s.labels, 4);
  for (uint32_t i = 0; i < 4; ++i) {
    CAPTURE(i);
    // Brute force over all faces: distance of p_i to the surface, and the surface's distance to c_i.
    double on_surface = INFINITY, to_centroid = INFINITY;
    for (size_t f = 0; f < s.mesh.face_count(); ++f) {
      double a[3], b[3], cc[3], pi[3], ci[3], x[3];
      for (int d = 0; d < 3; ++d) {
        a[d] = s.mesh.positions[3 * s.mesh.indices[3 * f] + d];
        b[d] = s.mesh.positions[3 * s.mesh.indices[3 * f + 1] + d];
        cc[d] = s.mesh.positions[3 * s.mesh.indices[3 * f + 2] + d];
        pi[d] = p[3 * i + d];
        ci[d] = c[3 * i + d];
      }
      on_surface = std::min(on_surface, closest_point_on_triangle(pi, a, b, cc, x));
      to_centroid = std::min(to_centroid, closest_point_on_triangle(ci, a, b, cc, x));
    }
    CHECK(on_surface < 1e-10);
    double d2 = 0;
    for (int d = 0; d < 3; ++d) d2 += (double(p[3 * i + d]) - c[3 * i + d]) * (double(p[3 * i + d]) - c[3 * i + d]);
    CHECK(d2 == doctest::Approx(to_centroid).epsilon(1e-4));
    CHECK(d2 > 1e-4);  // the centroid is inside the sphere, not on it
  }
  // The dual with projected vertices is still the tetrahedron.
  CoarsenResult r = coarsen(s, 4, VertexPlacement::projected);
  CHECK(r.defects.empty());
  CHECK(r.mesh.face_count() == 4);
}

TEST_CASE("coarsen: the result does not depend on the thread count") {
  // 72200 faces: large enough for the parallel paths (the dual's two halves and their shared vertex
  // pass from 4096 faces, the projected placement's split scan from 65536). Blocks of 10 x 10
  // quads, one annulus.
  Labeled g = grid(190, 190, [](int i, int j) {
    int bi = i / 10, bj = j / 10;
    if (std::max(std::abs(bi - 8), std::abs(bj - 8)) == 1) return 0u;  // a ring of 8 blocks
    return uint32_t(bj * 19 + bi);
  });
  REQUIRE(g.mesh.face_count() >= 65536);
  Topology topology = build_topology(g.mesh);
  for (VertexPlacement placement : {VertexPlacement::closest, VertexPlacement::projected, VertexPlacement::qem}) {
    CoarsenOptions one, many;
    one.placement = many.placement = placement;
    one.threads = 1;
    many.threads = 3;  // three parts even on a one-core machine
    CoarsenResult a = coarsen_clustering(g.mesh, topology, g.labels, 361, one);
    CoarsenResult b = coarsen_clustering(g.mesh, topology, g.labels, 361, many);
    CHECK(a.mesh.positions == b.mesh.positions);
    CHECK(a.mesh.indices == b.mesh.indices);
    CHECK(a.defects == b.defects);
    CHECK(has_defect(a.defects, DualDefect::cluster_not_disk, 0));
    CHECK(a.mesh.face_count() > 500);
  }
}

TEST_CASE("coarsen: qem's fitting passes put the input on both sides of the coarse mesh") {
  // A sphere of 32768 faces in 60 clusters: qem's points sit at their clusters' tangent planes, so
  // the chords between them are inside the sphere; the fitting moves them out.
  Labeled o = sphere_four_clusters(6);
  Mesh& sphere = o.mesh;
  for (size_t v = 0; v < sphere.vertex_count(); ++v) {
    float* p = &sphere.positions[3 * v];
    const double r = std::sqrt(double(p[0]) * p[0] + double(p[1]) * p[1] + double(p[2]) * p[2]);
    for (int d = 0; d < 3; ++d) p[d] = float(p[d] / r);
  }
  REQUIRE(sphere.face_count() >= 16384);
  Topology topology = build_topology(sphere);
  ClusterOptions co;
  co.clusters = 60;
  const std::vector<uint32_t> labels = cluster(sphere, topology, co).labels;
  // Signed distances of the input's vertices to the coarse mesh: inside (< 0) or outside, by the
  // side of the nearest coarse triangle's plane.
  auto mean_signed = [&](const Mesh& coarse) {
    double total = 0;
    for (size_t v = 0; v < sphere.vertex_count(); ++v) {
      const double x[3] = {sphere.positions[3 * v], sphere.positions[3 * v + 1], sphere.positions[3 * v + 2]};
      double best = INFINITY, side = 0;
      for (size_t t = 0; t < coarse.face_count(); ++t) {
        double c[3][3], point[3];
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 3; ++d) c[j][d] = coarse.positions[3 * size_t(coarse.indices[3 * t + j]) + d];
        const double d2 = closest_point_on_triangle(x, c[0], c[1], c[2], point);
        if (d2 < best) {
          best = d2;
          const double e1[3] = {c[1][0] - c[0][0], c[1][1] - c[0][1], c[1][2] - c[0][2]};
          const double e2[3] = {c[2][0] - c[0][0], c[2][1] - c[0][1], c[2][2] - c[0][2]};
          const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
          side = (x[0] - point[0]) * n[0] + (x[1] - point[1]) * n[1] + (x[2] - point[2]) * n[2] >= 0 ? 1 : -1;
        }
      }
      total += side * std::sqrt(best);
    }
    return total / double(sphere.vertex_count());
  };
  CoarsenOptions none, fitted, fitted_one_thread;
  none.placement = fitted.placement = fitted_one_thread.placement = VertexPlacement::qem;
  none.fit_passes = 0;
  fitted.fit_swaps = fitted_one_thread.fit_swaps = false;  // vertex moves alone (swaps: the cube test)
  fitted.threads = 3;  // several parts even on a one-core machine
  fitted_one_thread.threads = 1;
  CoarsenResult a = coarsen_clustering(sphere, topology, labels, 60, none);
  CoarsenResult b = coarsen_clustering(sphere, topology, labels, 60, fitted);
  REQUIRE(a.defects.empty());
  CHECK(a.fitted_moves == 0);
  CHECK(b.fitted_moves > 0);
  CHECK(b.mesh.indices == a.mesh.indices);  // vertices move, connectivity stays
  // Without the fitting the sphere is outside the coarse mesh nearly everywhere; with it, on both
  // sides: the mean signed distance shrinks by far more than half, and so does the RMS distance.
  const double before = mean_signed(a.mesh), after = mean_signed(b.mesh);
  CHECK(before > 0);
  CHECK(std::fabs(after) < 0.25 * before);
  CHECK(approximation_error(b.mesh, sphere).rms < 0.75 * approximation_error(a.mesh, sphere).rms);
  // The fixed-point sums make it independent of the thread count.
  CoarsenResult c = coarsen_clustering(sphere, topology, labels, 60, fitted_one_thread);
  CHECK(c.mesh.positions == b.mesh.positions);
}

TEST_CASE("coarsen: arbitrary labels and broken meshes give a mesh, never a crash") {
  // Small deterministic generator (xorshift64*).
  uint64_t state = 0x9e3779b97f4a7c15ull;
  auto next = [&](uint32_t bound) {
    state ^= state >> 12, state ^= state << 25, state ^= state >> 27;
    return uint32_t(((state * 0x2545f4914f6cdd1dull) >> 33) % bound);
  };
  auto check = [](const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters) {
    Topology topology = build_topology(mesh);
    for (VertexPlacement placement : {VertexPlacement::closest, VertexPlacement::qem}) {
      CoarsenOptions options;
      options.placement = placement;
      CoarsenResult r = coarsen_clustering(mesh, topology, labels, clusters, options);
      CHECK(r.mesh.vertex_count() == clusters);
      for (size_t f = 0; f < r.mesh.face_count(); ++f) {
        const uint32_t* t = &r.mesh.indices[3 * f];
        CHECK(t[0] < clusters);
        CHECK(t[1] < clusters);
        CHECK(t[2] < clusters);
        CHECK((t[0] != t[1] && t[1] != t[2] && t[0] != t[2]));
      }
      for (float x : r.mesh.positions) CHECK(std::isfinite(x));
      CHECK(find_dual_defects(mesh, topology, labels, clusters, options) == r.defects);
    }
  };
  // Random labels on a sphere: clusters of every shape, pinched, scattered.
  Labeled s = sphere_four_clusters(2);
  for (uint32_t clusters : {1u, 2u, 5u, 40u}) {
    std::vector<uint32_t> labels(s.mesh.face_count());
    for (uint32_t& l : labels) l = next(clusters);
    check(s.mesh, labels, clusters);
  }
  // A triangle soup on few vertices: non-manifold edges and vertices, flipped neighbours,
  // duplicated and collapsed faces.
  Mesh soup;
  for (int v = 0; v < 12; ++v) add_vertex(soup, next(1000) / 100.0, next(1000) / 100.0, next(1000) / 100.0);
  for (int f = 0; f < 60; ++f) {
    uint32_t a = next(12), b = next(12), c = next(12);
    if (f % 10 == 0) b = a;  // collapsed
    soup.indices.insert(soup.indices.end(), {a, b, c});
  }
  for (uint32_t clusters : {1u, 3u, 8u}) {
    std::vector<uint32_t> labels(soup.face_count());
    for (uint32_t& l : labels) l = next(clusters);
    check(soup, labels, clusters);
  }
  // Two cones sharing their apex (a non-manifold vertex), one cluster per cone side.
  Mesh cones;
  uint32_t apex = add_vertex(cones, 0, 0, 0);
  for (int side = 0; side < 2; ++side) {
    uint32_t first = uint32_t(cones.vertex_count());
    for (int k = 0; k < 6; ++k) {
      double a = 2 * std::numbers::pi * k / 6;
      add_vertex(cones, std::cos(a), std::sin(a), side ? 1 : -1);
    }
    for (uint32_t k = 0; k < 6; ++k) cones.indices.insert(cones.indices.end(), {apex, first + k, first + (k + 1) % 6});
  }
  std::vector<uint32_t> cone_labels(cones.face_count());
  for (size_t f = 0; f < cone_labels.size(); ++f) cone_labels[f] = uint32_t(f / 3);  // 4 clusters, 2 per cone
  check(cones, cone_labels, 4);
}
