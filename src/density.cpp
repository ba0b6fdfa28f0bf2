// meshcvt: curvature-adaptive face density (ACVD's "gradation": Valette, Chassery, Prost, "Generic
// remeshing of 3D triangular meshes with metric-dependent discrete Voronoi diagrams", IEEE TVCG
// 2008, where rho = curvature indicator ^ gradation, clamped).
//
// Curvature: per face, the second fundamental form fitted to the change of the vertex normals along
// the face's three edges (Rusinkiewicz, "Estimating Curvatures and Their Derivatives on Triangle
// Meshes", 3DPVT 2004): in a frame (u, v) of the face plane, II [e.u, e.v] = [dn.u, dn.v] for every
// edge e and normal difference dn along it, a 6 x 3 least-squares problem for the symmetric II. Its
// Frobenius norm is sqrt(k1^2 + k2^2) without any eigen-solve. Why this and not the cotangent
// mean-curvature normal with the angle-deficit Gaussian curvature (Meyer et al. 2003): it is
// per face, which is what the clustering weights are; it needs no special case at the boundary
// (where the angle deficit and the cotangent Laplacian measure the boundary curve's bending, not the
// surface's) nor at non-manifold edges (only vertex -> faces is used); a degenerate face simply has
// no fit and takes its neighbours' value. Vertex normals use Max's weights (N. Max, "Weights for
// computing vertex normals from facet normals", JGT 1999: e1 x e2 / (|e1|^2 |e2|^2) over the
// corner's two edges), exact for vertices on a sphere, as in Rusinkiewicz's paper.
//
// Then: scale-free (times the bounding-box diagonal), smoothed four times over the faces around each
// face's vertices (area-weighted: a noisy or tiny face moves its neighbourhood little), mapped to
// rho = (1 + c)^g relative to the smallest, clamped to a ratio bound (ACVD clamps at 100 x mean).
//
// Every pass computes each face's or vertex's value alone, by gathering over a fixed-order list, in
// double from the float positions; passes split faces or vertices over up to two threads on large
// meshes, so the result does not depend on the split.
#include "meshcvt/density.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "meshcvt/error.h"
#include "parallel.h"
#include "vec3.h"

namespace meshcvt {

namespace {

// A face is too thin for a curvature fit when twice its area is below this fraction of its longest
// edge squared (its smallest angle is then below about 1e-6 rad): the edges no longer span the plane.
constexpr double kThinFace = 1e-6;
// Passes of smoothing over vertex rings. With none, one noisy face makes its own tiny cluster. Two
// (until the twenty-third session) let the density change faster than clusters can follow: at
// --gradation 1, fandisk -> 1000 / bunny00 -> 500 / refined_elephant -> 1000 kept 31 / 13 / 59
// angles below 30 degrees; four give 5 / 1 / 33 for an RMS distance 5% higher, 1% higher and 2.5%
// lower. Over libcgal-demo at n = faces / 40, four also lower RMS (geometric mean 0.994x) and
// angles below 30 (1829 -> 1481); at faces / 10 RMS is 1% higher, angles below 30 1486 -> 1342
// (bench/RESULTS.md, "Coarsening: gradation and subdivision"). Six smooth away more of the gain.
constexpr int kSmoothingPasses = 4;

// [0, count) in one range per thread (range_threads: one per core on large inputs). Every pass
// below computes each item on its own, so the split changes no result.
std::vector<uint32_t> split(size_t count) { return even_bounds(count, range_threads(count, 0)); }

void check_mesh(const Mesh& mesh) {
  if (mesh.indices.size() % 3 != 0 || mesh.positions.size() % 3 != 0)
    throw OptionError("mesh arrays are not whole triangles / vertices");
  if (mesh.face_count() > 0xffffffffu / 3)
    throw OptionError("mesh has " + std::to_string(mesh.face_count()) + " faces; at most 1431655765 are supported");
  for (uint32_t v : mesh.indices)
    if (v >= mesh.vertex_count())
      throw OptionError("mesh uses vertex " + std::to_string(v) + " but has " + std::to_string(mesh.vertex_count()) +
                        " vertices");
}

void check_topology(const Mesh& mesh, const Topology& topology) {
  if (topology.vertex_face_offsets.size() != mesh.vertex_count() + 1)
    throw OptionError("topology is for " + std::to_string(topology.vertex_face_offsets.size() - 1) +
                      " vertices but the mesh has " + std::to_string(mesh.vertex_count()) +
                      " (pass build_topology(mesh))");
  if (topology.vertex_faces.size() != topology.vertex_face_offsets.back())
    throw OptionError("topology's vertex -> faces lists are inconsistent");
  for (uint32_t f : topology.vertex_faces)
    if (f >= mesh.face_count())
      throw OptionError("topology names face " + std::to_string(f) + " but the mesh has " +
                        std::to_string(mesh.face_count()) + " faces (pass build_topology(mesh))");
}

// Diagonal of the bounding box of the referenced vertices (0 when there are none).
double bounding_diagonal(const Mesh& mesh) {
  if (mesh.indices.empty()) return 0;
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v : mesh.indices) {
    const float* p = &mesh.positions[3 * size_t(v)];
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min(lo[c], double(p[c]));
      hi[c] = std::max(hi[c], double(p[c]));
    }
  }
  double d2 = 0;
  for (int c = 0; c < 3; ++c) d2 += (hi[c] - lo[c]) * (hi[c] - lo[c]);
  return std::sqrt(d2);
}

// Max-weighted unit vertex normal; (0,0,0) where the sum vanishes (no face with area, opposite
// faces cancelling). Corners with a zero-length edge add nothing.
Vec3 vertex_normal(const Mesh& mesh, const Topology& topology, uint32_t v) {
  Vec3 sum{0, 0, 0};
  Vec3 p = mesh_vertex(mesh, v);
  for (uint32_t i = topology.vertex_face_offsets[v]; i < topology.vertex_face_offsets[v + 1]; ++i) {
    const uint32_t* t = &mesh.indices[3 * size_t(topology.vertex_faces[i])];
    int c = t[0] == v ? 0 : t[1] == v ? 1 : 2;
    Vec3 e1 = mesh_vertex(mesh, t[(c + 1) % 3]) - p, e2 = mesh_vertex(mesh, t[(c + 2) % 3]) - p;
    double l1 = dot(e1, e1), l2 = dot(e2, e2);
    if (l1 > 0 && l2 > 0) sum = sum + (1.0 / (l1 * l2)) * cross(e1, e2);
  }
  double len = length(sum);
  return len > 0 && std::isfinite(len) ? (1.0 / len) * sum : Vec3{0, 0, 0};
}

// sqrt(k1^2 + k2^2) of face f from Rusinkiewicz's fit, or -1 when the face is too thin to fit.
// Also returns twice the face's area.
double fitted_curvature(const Mesh& mesh, size_t f, const std::vector<float>& vertex_normals, double& twice_area) {
  const uint32_t* t = &mesh.indices[3 * f];
  Vec3 p[3] = {mesh_vertex(mesh, t[0]), mesh_vertex(mesh, t[1]), mesh_vertex(mesh, t[2])};
  Vec3 n = cross(p[1] - p[0], p[2] - p[0]);
  twice_area = length(n);
  if (!std::isfinite(twice_area)) twice_area = 0;
  double longest2 = std::max({dot(p[1] - p[0], p[1] - p[0]), dot(p[2] - p[1], p[2] - p[1]), dot(p[0] - p[2], p[0] - p[2])});
  if (!(twice_area >= kThinFace * longest2) || !(twice_area > 0)) return -1;
  n = (1.0 / twice_area) * n;
  Vec3 m[3];
  for (int c = 0; c < 3; ++c) {
    const float* q = &vertex_normals[3 * size_t(t[c])];
    m[c] = {q[0], q[1], q[2]};
    if (dot(m[c], m[c]) == 0) m[c] = n;  // no vertex normal: no bending seen from there
  }
  Vec3 u = p[1] - p[0];
  u = (1.0 / length(u)) * u;
  Vec3 v = cross(n, u);
  // Normal equations of the 6 x 3 system for II = [[a, b], [b, c]]: per edge e (opposite corner i)
  // with dn the normal change along it, a e_u + b e_v = dn_u and b e_u + c e_v = dn_v.
  double m00 = 0, m01 = 0, m11 = 0, m22 = 0, r0 = 0, r1 = 0, r2 = 0;
  for (int i = 0; i < 3; ++i) {
    int from = (i + 1) % 3, to = (i + 2) % 3;
    Vec3 e = p[to] - p[from], dn = m[to] - m[from];
    double eu = dot(e, u), ev = dot(e, v), du = dot(dn, u), dv = dot(dn, v);
    m00 += eu * eu;
    m01 += eu * ev;
    m11 += eu * eu + ev * ev;
    m22 += ev * ev;
    r0 += eu * du;
    r1 += ev * du + eu * dv;
    r2 += ev * dv;
  }
  // The matrix is [[m00, m01, 0], [m01, m11, m01], [0, m01, m22]]; Cramer's rule.
  double minor = m11 * m22 - m01 * m01;
  double det = m00 * minor - m01 * m01 * m22;
  if (!(det > 1e-12 * m11 * m11 * m11)) return -1;  // det ~ length^6; near 0 only for thin faces
  double a = (r0 * minor - m01 * (r1 * m22 - m01 * r2)) / det;
  double b = (m00 * (r1 * m22 - r2 * m01) - r0 * m01 * m22) / det;
  double c = (m00 * (m11 * r2 - m01 * r1) - m01 * m01 * r2 + r0 * m01 * m01) / det;
  double k2sum = a * a + 2 * b * b + c * c;  // ||II||_F^2 = k1^2 + k2^2
  return std::isfinite(k2sum) ? std::sqrt(k2sum) : -1;
}

// One smoothing pass: every vertex takes the area-weighted mean of its faces' known values, every
// face the mean of its distinct vertices' known values. A value < 0 is unknown; it stays unknown
// only when no face around any of its vertices is known and has area.
void smooth_over_vertex_rings(const Mesh& mesh, const Topology& topology, const std::vector<float>& area,
                              std::vector<float>& value, std::vector<float>& vertex_value) {
  size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  run_ranges(split(nv), [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t vtx = begin; vtx < end; ++vtx) {
      double sum = 0, weight = 0;
      for (uint32_t i = topology.vertex_face_offsets[vtx]; i < topology.vertex_face_offsets[vtx + 1]; ++i) {
        uint32_t f = topology.vertex_faces[i];
        if (value[f] >= 0) {
          sum += double(area[f]) * value[f];
          weight += area[f];
        }
      }
      vertex_value[vtx] = weight > 0 ? float(sum / weight) : -1.0f;
    }
  });
  run_ranges(split(nf), [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t f = begin; f < end; ++f) {
      const uint32_t* t = &mesh.indices[3 * size_t(f)];
      double sum = 0;
      int count = 0;
      for (int c = 0; c < 3; ++c) {
        bool repeated = (c >= 1 && t[c] == t[0]) || (c == 2 && t[2] == t[1]);
        if (!repeated && vertex_value[t[c]] >= 0) {
          sum += vertex_value[t[c]];
          ++count;
        }
      }
      value[f] = count > 0 ? float(sum / count) : -1.0f;
    }
  });
}

// c_k per face (see density.h), >= 0 and finite.
std::vector<float> curvedness(const Mesh& mesh, const Topology& topology) {
  size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  double diagonal = bounding_diagonal(mesh);
  std::vector<float> value(nf, 0.0f);
  if (nf == 0 || !(diagonal > 0) || !std::isfinite(diagonal)) return value;

  std::vector<float> vertex_normals(3 * nv);
  run_ranges(split(nv), [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t v = begin; v < end; ++v) {
      Vec3 n = vertex_normal(mesh, topology, v);
      vertex_normals[3 * size_t(v)] = float(n.x);
      vertex_normals[3 * size_t(v) + 1] = float(n.y);
      vertex_normals[3 * size_t(v) + 2] = float(n.z);
    }
  });
  std::vector<float> area(nf);  // relative to diagonal^2, so float holds it at any scale
  // sqrt((k1^2 + k2^2) / 2) is Koenderink's curvedness, 1 / radius on a sphere; times the diagonal.
  const double scale = std::sqrt(0.5) * diagonal;
  run_ranges(split(nf), [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t f = begin; f < end; ++f) {
      double twice_area = 0;
      double k = fitted_curvature(mesh, f, vertex_normals, twice_area);
      area[f] = float(0.5 * twice_area / (diagonal * diagonal));
      double c = k * scale;
      value[f] = k >= 0 && c < 3e38 ? float(c) : -1.0f;
    }
  });
  vertex_normals = {};
  std::vector<float> vertex_value(nv);
  for (int pass = 0; pass < kSmoothingPasses; ++pass) smooth_over_vertex_rings(mesh, topology, area, value, vertex_value);
  for (float& x : value)
    if (!(x >= 0)) x = 0;  // nothing known around it: treat as flat
  return value;
}

void check_arguments(double gradation, double max_ratio) {
  if (!(gradation >= 0) || !std::isfinite(gradation))
    throw OptionError("gradation must be a finite number >= 0, not " + std::to_string(gradation));
  if (!(max_ratio >= 1) || !(max_ratio <= 1e30))
    throw OptionError("density ratio bound must be in [1, 1e30], not " + std::to_string(max_ratio));
}

std::vector<float> density_from_curvedness(const std::vector<float>& c, double gradation, double max_ratio) {
  // rho = ((1 + c) / (1 + c_min))^g, as exp(g (log1p c - log1p c_min)) so that no large g
  // overflows, capped at max_ratio.
  float c_min = c.empty() ? 0.0f : *std::min_element(c.begin(), c.end());
  double log_min = std::log1p(double(c_min));
  double log_cap = std::log(max_ratio);
  std::vector<float> rho(c.size());
  run_ranges(split(c.size()), [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t f = begin; f < end; ++f) {
      // The face with c_min gets exp(0) = 1 exactly, so min(rho) = 1.
      double exponent = std::min(gradation * (std::log1p(double(c[f])) - log_min), log_cap);
      rho[f] = float(std::min(std::exp(exponent), max_ratio));
      assert(rho[f] >= 1 && std::isfinite(rho[f]));
    }
  });
  return rho;
}

}  // namespace

std::vector<float> face_curvedness(const Mesh& mesh, const Topology& topology) {
  check_mesh(mesh);
  check_topology(mesh, topology);
  return curvedness(mesh, topology);
}

std::vector<float> curvature_density(const Mesh& mesh, const Topology& topology, double gradation, double max_ratio) {
  check_arguments(gradation, max_ratio);
  check_mesh(mesh);
  check_topology(mesh, topology);
  if (gradation == 0) return std::vector<float>(mesh.face_count(), 1.0f);
  return density_from_curvedness(
      curvedness(mesh, topology), gradation, max_ratio);
}

}  // namespace meshcvt
