// meshcvt benchmark tool: counts the coarse triangles that face against the surface they stand for,
// the check behind bench/RESULTS.md's fold counts ("meshcvt against ACVD", seventeenth session).
// A coarse triangle (a, b, c) stands for the input around the vertex where clusters a, b and c
// meet; it is counted as folded when its normal has a negative dot product with each of the three
// clusters' mean normals (the area-weighted sums of their faces' normals), and, more loosely,
// with their sum. A coarse mesh too coarse for its shape (a thin part spanned by one triangle)
// can give such triangles with any placement, so compare placements, not absolute counts.
//
// usage: fold_check MESH N [closest|projected|qem]
//   Runs coarsen_mesh as `meshcvt coarsen MESH -n N --vertex P` does with its defaults (qem
//   subdivides an input of fewer than 20 faces per cluster first) and prints one line:
//   MESH N P: triangles T, against all three clusters A, against their sum S
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/io.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"

using namespace meshcvt;

namespace {

// The normal (unnormalized, twice the area) of triangle (a, b, c).
void triangle_normal(const float* a, const float* b, const float* c, double n[3]) {
  const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  n[0] = u[1] * v[2] - u[2] * v[1];
  n[1] = u[2] * v[0] - u[0] * v[2];
  n[2] = u[0] * v[1] - u[1] * v[0];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: fold_check MESH N [closest|projected|qem]\n");
    return 2;
  }
  try {
    Mesh mesh = read_mesh(argv[1]);
    const uint32_t n = uint32_t(std::stoul(argv[2]));
    CoarsenMeshOptions options;
    options.cluster.clusters = n;
    options.coarsen.placement = parse_vertex_placement(argc > 3 ? argv[3] : "projected");
    if (subdivides_by_default(options.coarsen.placement)) {
      const unsigned levels = subdivision_levels_for(mesh.face_count(), n,
                                                     subdivision_faces_per_cluster(options.coarsen.placement));
      if (levels > 0) mesh = subdivide_midpoint(mesh, levels);
    }
    const Topology topology = build_topology(mesh);
    const CoarsenMeshResult result = coarsen_mesh(mesh, topology, options);
    const std::vector<uint32_t>& labels = result.clustering.labels;

    std::vector<double> mean_normal(3 * size_t(n), 0.0);  // per cluster, then unit length
    for (size_t f = 0; f < mesh.face_count(); ++f) {
      double m[3];
      triangle_normal(&mesh.positions[3 * size_t(mesh.indices[3 * f])], &mesh.positions[3 * size_t(mesh.indices[3 * f + 1])],
                      &mesh.positions[3 * size_t(mesh.indices[3 * f + 2])], m);
      for (int d = 0; d < 3; ++d) mean_normal[3 * size_t(labels[f]) + d] += m[d];
    }
    for (uint32_t c = 0; c < n; ++c) {
      double* m = &mean_normal[3 * size_t(c)];
      const double l = std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
      if (l > 0) m[0] /= l, m[1] /= l, m[2] /= l;
    }
    const Mesh& coarse = result.coarse.mesh;
    size_t against_all = 0, against_sum = 0;
    for (size_t t = 0; t < coarse.face_count(); ++t) {
      const uint32_t* v = &coarse.indices[3 * t];
      double m[3];
      triangle_normal(&coarse.positions[3 * size_t(v[0])], &coarse.positions[3 * size_t(v[1])],
                      &coarse.positions[3 * size_t(v[2])], m);
      int against = 0;
      double sum = 0;
      for (int k = 0; k < 3; ++k) {
        const double* c = &mean_normal[3 * size_t(v[k])];
        const double dot = m[0] * c[0] + m[1] * c[1] + m[2] * c[2];
        against += dot < 0;
        sum += dot;
      }
      against_all += against == 3;
      against_sum += sum < 0;
    }
    std::printf("%s %u %s: triangles %zu, against all three clusters %zu, against their sum %zu\n", argv[1], n,
                to_string(options.coarsen.placement), coarse.face_count(), against_all, against_sum);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fold_check: %s\n", e.what());
    return 1;
  }
  return 0;
}
