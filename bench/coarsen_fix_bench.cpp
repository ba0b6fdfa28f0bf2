// meshcvt benchmark: the fix loop of coarsen_mesh (src/coarsen_mesh.cpp) on real meshes: how many
// defects the plain clustering's dual has, what the loop did about them, whether the output is a
// manifold with the input's Euler characteristic, boundary loops, components and exactly n vertices,
// and what the loop costs next to the clustering. Built and run by bench/coarsen_bench.sh; numbers go
// to bench/RESULTS.md ("Coarsening: topology fixes").
//
// usage: coarsen_fix_bench MESH CLUSTERS [MESH CLUSTERS ...]
//   MESH: a mesh file, or sphere:K = an octahedron subdivided K times onto the unit sphere
//         (8 * 4^K faces; K = 7 gives 131,072).
// Environment: COARSEN_FIX_OUT=DIR writes each coarse mesh to DIR/NAME-N.off (to cross-check with
// /work/shared/tools/meshstats.py).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/io.h"
#include "meshcvt/quality.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"

using namespace meshcvt;

namespace {

Mesh octahedron_sphere(unsigned levels) {
  Mesh m;
  const float p[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (auto& v : p) m.positions.insert(m.positions.end(), v, v + 3);
  const uint32_t f[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (auto& t : f) m.indices.insert(m.indices.end(), t, t + 3);
  m = subdivide_midpoint(m, levels);
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    float* q = &m.positions[3 * v];
    double l = std::sqrt(double(q[0]) * q[0] + double(q[1]) * q[1] + double(q[2]) * q[2]);
    for (int k = 0; k < 3; ++k) q[k] = float(q[k] / l);
  }
  return m;
}

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc % 2 == 0) {
    std::fprintf(stderr, "usage: coarsen_fix_bench MESH CLUSTERS [MESH CLUSTERS ...]\n");
    return 2;
  }
  std::printf("| input | faces | n | defects before | fixes (cut / move) | rounds | refined to | defects after |"
              " chi in -> out | loops in -> out | parts in -> out | vertices used | cluster s | fix loop s |"
              " coarsen s | min angle | Q avg |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string path = argv[i];
    uint32_t n = uint32_t(std::atol(argv[i + 1]));
    Mesh mesh = path.rfind("sphere:", 0) == 0 ? octahedron_sphere(unsigned(std::atoi(path.c_str() + 7))) : read_mesh(path);
    Topology topology = build_topology(mesh);
    CoarsenMeshOptions options;
    options.cluster.clusters = n;
    options.cluster.device = "cpu";
    double t0 = now();
    CoarsenMeshResult r = coarsen_mesh(mesh, topology, options);
    double total = now() - t0;
    MeshInfo in = mesh_info(mesh, topology);
    MeshInfo out = mesh_info(r.coarse.mesh, build_topology(r.coarse.mesh));
    TriangleQuality q = triangle_quality(r.coarse.mesh);
    size_t cuts = 0, moves = 0;
    for (const CoarsenFix& f : r.fixes) (f.action == CoarsenFix::cut ? cuts : moves)++;
    std::string name = path.substr(path.find_last_of('/') + 1);
    std::printf("| %s | %zu | %u | %zu | %zu (%zu / %zu) | %u | %s | %zu | %lld -> %lld | %llu -> %llu | %u -> %u |"
                " %llu of %zu | %.3f | %.3f | %.3f | %.1f | %.3f |\n",
                name.c_str(), mesh.face_count(), n, r.initial_defects, r.fixes.size(), cuts, moves, r.fix_rounds,
                r.refined_clusters ? std::to_string(r.refined_clusters).c_str() : "-", r.coarse.defects.size(),
                (long long)in.euler_characteristic, (long long)out.euler_characteristic,
                (unsigned long long)in.boundary_loops, (unsigned long long)out.boundary_loops, in.components,
                out.components, (unsigned long long)out.vertices, r.coarse.mesh.vertex_count(), r.cluster_seconds,
                r.fix_seconds, r.coarsen_seconds, q.min_angle_deg, q.q_avg);
    std::fflush(stdout);
    (void)total;
    if (const char* dir = std::getenv("COARSEN_FIX_OUT"))
      write_mesh(std::string(dir) + "/" + name.substr(0, name.find('.')) + "-" + std::to_string(n) + ".off",
                 r.coarse.mesh);
  }
  return 0;
}
