// meshcvt tests: small procedural meshes (sphere, torus, grids, several components, non-manifold
// edges, slivers), so tests need no files and cover the shapes that matter.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt::test {

inline uint32_t add_vertex(Mesh& m, double x, double y, double z) {
  m.positions.push_back(float(x));
  m.positions.push_back(float(y));
  m.positions.push_back(float(z));
  return uint32_t(m.vertex_count() - 1);
}

inline void add_triangle(Mesh& m, uint32_t a, uint32_t b, uint32_t c) {
  m.indices.push_back(a);
  m.indices.push_back(b);
  m.indices.push_back(c);
}

/// Flips about half of the faces of [begin, end) (swaps corners 1 and 2), chosen by a fixed
/// pseudo-random sequence from `seed`, as in libcgal-demo's *-shuffled meshes. Returns how many.
inline size_t shuffle_orientation(Mesh& m, size_t begin, size_t end, uint32_t seed) {
  size_t flipped = 0;
  for (size_t f = begin; f < end; ++f) {
    seed = seed * 1664525u + 1013904223u;
    if (seed >> 31) {
      std::swap(m.indices[3 * f + 1], m.indices[3 * f + 2]);
      ++flipped;
    }
  }
  return flipped;
}

/// Six times the signed volume enclosed by a closed mesh (positive: its faces point outward).
inline double signed_volume6(const Mesh& m) {
  double v = 0;
  for (size_t f = 0; f < m.face_count(); ++f) {
    const float* a = &m.positions[3 * size_t(m.indices[3 * f])];
    const float* b = &m.positions[3 * size_t(m.indices[3 * f + 1])];
    const float* c = &m.positions[3 * size_t(m.indices[3 * f + 2])];
    v += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
         double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
         double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  return v;
}

// `m` with `count` collapsed faces appended (as welding a sliver leaves them): for k < count, face
// k * stride's corners (a, b, c) give (a, b, a) when k is even and (b, b, c) when odd.
inline Mesh with_collapsed_faces(const Mesh& m, uint32_t count, uint32_t stride) {
  Mesh out = m;
  for (uint32_t k = 0; k < count; ++k) {
    const uint32_t* t = &m.indices[3 * size_t(k) * stride];
    if (k % 2 == 0)
      out.indices.insert(out.indices.end(), {t[0], t[1], t[0]});
    else
      out.indices.insert(out.indices.end(), {t[1], t[1], t[2]});
  }
  return out;
}

// The labels expected for `m` = a surface's first `surface_labels.size()` faces with collapsed
// faces after them: the surface's labels, then for each collapsed face the label of the lowest
// surface face at its lowest corner (kNone where no surface face has that corner).
inline std::vector<uint32_t> labels_at_lowest_corners(const Mesh& m, const std::vector<uint32_t>& surface_labels) {
  std::vector<uint32_t> expected = surface_labels;
  for (size_t f = surface_labels.size(); f < m.face_count(); ++f) {
    const uint32_t corner = std::min({m.indices[3 * f], m.indices[3 * f + 1], m.indices[3 * f + 2]});
    uint32_t label = kNone;
    for (size_t g = 0; g < surface_labels.size() && label == kNone; ++g)
      for (int i = 0; i < 3; ++i)
        if (m.indices[3 * g + i] == corner) label = surface_labels[g];
    expected.push_back(label);
  }
  return expected;
}

/// Open grid of nx*ny quads (2 triangles each) over [0,sx]x[0,sy], height z = bump*sin(x)cos(y).
inline Mesh grid(uint32_t nx, uint32_t ny, double sx = 1, double sy = 1, double bump = 0) {
  Mesh m;
  for (uint32_t j = 0; j <= ny; ++j)
    for (uint32_t i = 0; i <= nx; ++i) {
      double x = sx * i / nx, y = sy * j / ny;
      add_vertex(m, x, y, bump * std::sin(6 * x) * std::cos(5 * y));
    }
  for (uint32_t j = 0; j < ny; ++j)
    for (uint32_t i = 0; i < nx; ++i) {
      uint32_t a = j * (nx + 1) + i, b = a + 1, c = a + nx + 1, d = c + 1;
      add_triangle(m, a, b, d);
      add_triangle(m, a, d, c);
    }
  return m;
}

/// Closed torus, nu*nv quads split in two.
inline Mesh torus(uint32_t nu, uint32_t nv, double R = 1, double r = 0.35) {
  Mesh m;
  const double pi = 3.14159265358979323846;
  for (uint32_t j = 0; j < nv; ++j)
    for (uint32_t i = 0; i < nu; ++i) {
      double u = 2 * pi * i / nu, v = 2 * pi * j / nv;
      add_vertex(m, (R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v));
    }
  for (uint32_t j = 0; j < nv; ++j)
    for (uint32_t i = 0; i < nu; ++i) {
      uint32_t a = j * nu + i, b = j * nu + (i + 1) % nu, c = ((j + 1) % nv) * nu + i, d = ((j + 1) % nv) * nu + (i + 1) % nu;
      add_triangle(m, a, b, d);
      add_triangle(m, a, d, c);
    }
  return m;
}

/// Icosphere: an icosahedron subdivided `levels` times, vertices pushed onto the unit sphere.
inline Mesh icosphere(uint32_t levels) {
  Mesh m;
  const double t = (1 + std::sqrt(5.0)) / 2;
  double v[12][3] = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                     {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) {
    double l = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    add_vertex(m, p[0] / l, p[1] / l, p[2] / l);
  }
  uint32_t f[20][3] = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                       {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                       {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (auto& tri : f) add_triangle(m, tri[0], tri[1], tri[2]);
  for (uint32_t l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      double p[3];
      for (int c = 0; c < 3; ++c) p[c] = (double(m.positions[3 * a + c]) + m.positions[3 * b + c]) / 2;
      double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      uint32_t id = add_vertex(m, p[0] / len, p[1] / len, p[2] / len);
      mid[key] = id;
      return id;
    };
    std::vector<uint32_t> old = m.indices;
    m.indices.clear();
    for (size_t i = 0; i < old.size(); i += 3) {
      uint32_t a = old[i], b = old[i + 1], c = old[i + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      add_triangle(m, a, ab, ca);
      add_triangle(m, b, bc, ab);
      add_triangle(m, c, ca, bc);
      add_triangle(m, ab, bc, ca);
    }
  }
  return m;
}

/// b appended to a (translated by dx along x): a mesh of several components.
inline Mesh combine(Mesh a, const Mesh& b, double dx) {
  uint32_t base = uint32_t(a.vertex_count());
  for (size_t v = 0; v < b.vertex_count(); ++v)
    add_vertex(a, b.positions[3 * v] + dx, b.positions[3 * v + 1], b.positions[3 * v + 2]);
  for (uint32_t i : b.indices) a.indices.push_back(base + i);
  return a;
}

/// A bumpy grid with a vertical "wall" strip standing on one of its interior vertex lines: the
/// wall's bottom edges are shared by three faces (non-manifold), so the wall is a component of its own.
inline Mesh grid_with_wall(uint32_t n) {
  Mesh m = grid(n, n, 1, 1, 0.05);
  uint32_t row = n / 2;  // wall along y = row/n, x from 0 to 1
  uint32_t prev_bottom = row * (n + 1), prev_top = add_vertex(m, 0, double(row) / n, 0.3);
  for (uint32_t i = 1; i <= n; ++i) {
    uint32_t bottom = row * (n + 1) + i;
    uint32_t top = add_vertex(m, double(i) / n, double(row) / n, 0.3);
    add_triangle(m, prev_bottom, bottom, top);
    add_triangle(m, prev_bottom, top, prev_top);
    prev_bottom = bottom;
    prev_top = top;
  }
  return m;
}

}  // namespace meshcvt::test
