// meshcvt benchmark: TriangleBvh build and closest-point query times, Table-1 quality and
// approximation_error times, and (when built with -DWITH_EMBREE) the same closest-point queries
// through Embree's rtcPointQuery with the same exact point-triangle routine, for comparison.
// Built and run by bench/quality_bench.sh; numbers go to bench/RESULTS.md ("Quality and error").
//
// usage: quality_bench MESH [COARSE]
//   MESH, COARSE: a mesh file; "sphere:K" = an icosphere subdivided K times (20 * 4^K faces) with
//   smooth bumps; "subdiv:K:FILE" = FILE with every triangle split into 4^K (same surface).
//   With COARSE: approximation_error(COARSE, MESH) is timed too.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <string>
#include <vector>

#include "meshcvt/io.h"
#include "meshcvt/quality.h"
#include "meshcvt/subdivide.h"
#include "triangle_bvh.h"

#ifdef WITH_EMBREE
#include <embree3/rtcore.h>
#endif

using namespace meshcvt;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// CPU time of the whole process (all threads): on a busy machine wall time includes waiting.
double cpu_now() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

struct Timer {
  double wall0 = now(), cpu0 = cpu_now();
  double wall() const { return now() - wall0; }
  double cpu() const { return cpu_now() - cpu0; }
  std::string str() const {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3f s wall (%.3f s cpu)", wall(), cpu());
    return buf;
  }
};

// Icosphere with bumps: r = 1 + 0.1 sin(5x) sin(7y) sin(3z), so the surface is not a sphere.
Mesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<double> p = {-1, t,  0,  1, t, 0,  -1, -t, 0,  1, -t, 0, 0,  -1, t,  0,  1, t,
                           0,  -1, -t, 0, 1, -t, t,  0,  -1, t, 0,  1, -t, 0,  -1, -t, 0, 1};
  std::vector<uint32_t> f = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                             4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                             6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      uint32_t id = uint32_t(p.size() / 3);
      for (int k = 0; k < 3; ++k) p.push_back(0.5 * (p[3 * a + k] + p[3 * b + k]));
      mid.emplace(key, id);
      return id;
    };
    std::vector<uint32_t> g;
    g.reserve(f.size() * 4);
    for (size_t i = 0; i < f.size(); i += 3) {
      uint32_t a = f[i], b = f[i + 1], c = f[i + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      g.insert(g.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    f.swap(g);
  }
  Mesh m;
  m.indices = f;
  for (size_t v = 0; v < p.size() / 3; ++v) {
    double x = p[3 * v], y = p[3 * v + 1], z = p[3 * v + 2];
    double len = std::sqrt(x * x + y * y + z * z);
    x /= len, y /= len, z /= len;
    double r = 1 + 0.1 * std::sin(5 * x) * std::sin(7 * y) * std::sin(3 * z);
    m.positions.insert(m.positions.end(), {float(r * x), float(r * y), float(r * z)});
  }
  return m;
}

Mesh load(const std::string& spec) {
  if (spec.rfind("sphere:", 0) == 0) return icosphere(std::stoi(spec.substr(7)));
  if (spec.rfind("subdiv:", 0) == 0) {  // subdiv:K:FILE = FILE split K times (4^K faces per face)
    size_t colon = spec.find(':', 7);
    return subdivide_midpoint(read_mesh(spec.substr(colon + 1)), unsigned(std::stoi(spec.substr(7, colon - 7))));
  }
  return read_mesh(spec);
}

// Queries: points near the surface (a vertex pushed off by up to 2% of the box) and anywhere in
// the box enlarged by 20%; fixed seed.
std::vector<double> make_queries(const Mesh& m, size_t count, bool near_surface) {
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (size_t i = 0; i < m.positions.size(); ++i)
    lo[i % 3] = std::min(lo[i % 3], m.positions[i]), hi[i % 3] = std::max(hi[i % 3], m.positions[i]);
  uint64_t s = 12345;
  auto rnd = [&] {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return double(s >> 11) * 0x1.0p-53;
  };
  std::vector<double> q(3 * count);
  for (size_t i = 0; i < count; ++i) {
    size_t v = size_t(rnd() * double(m.vertex_count())) % m.vertex_count();
    for (int k = 0; k < 3; ++k) {
      double ext = hi[k] - lo[k];
      q[3 * i + k] =
          near_surface ? m.positions[3 * v + k] + 0.02 * ext * (2 * rnd() - 1) : lo[k] - 0.2 * ext + 1.4 * ext * rnd();
    }
  }
  return q;
}

#ifdef WITH_EMBREE
struct EmbreeHit {
  const Mesh* mesh;
  double q[3];
  double best2;
  uint32_t face;
};
bool embree_callback(RTCPointQueryFunctionArguments* args) {
  EmbreeHit* h = static_cast<EmbreeHit*>(args->userPtr);
  const Mesh& m = *h->mesh;
  uint32_t f = args->primID;
  double v[3][3];
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) v[c][k] = m.positions[3 * size_t(m.indices[3 * size_t(f) + c]) + k];
  double p[3];
  double d2 = closest_point_on_triangle(h->q, v[0], v[1], v[2], p);
  if (d2 < h->best2 || (d2 == h->best2 && f < h->face)) {
    h->best2 = d2;
    h->face = f;
    args->query->radius = float(std::sqrt(d2)) * (1 + 1e-6f);  // shrink, conservatively
    return true;
  }
  return false;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: quality_bench MESH [COARSE]\n");
    return 2;
  }
  Timer t;
  Mesh mesh = load(argv[1]);
  std::printf("mesh %s: %zu vertices, %zu faces (made in %.2f s)\n", argv[1], mesh.vertex_count(), mesh.face_count(),
              t.wall());

  t = Timer();
  TriangleQuality tq = triangle_quality(mesh);
  std::printf("triangle_quality: %s (min angle %.3f, Q avg %.4f)\n", t.str().c_str(), tq.min_angle_deg, tq.q_avg);

  t = Timer();
  { TriangleBvh one_thread(mesh, 1); }
  std::printf("TriangleBvh build, 1 thread: %s\n", t.str().c_str());
  t = Timer();
  TriangleBvh bvh(mesh);
  std::printf("TriangleBvh build, all cores: %s, %zu nodes (%.1f bytes/face)\n", t.str().c_str(), bvh.node_count(),
              double(bvh.node_count() * sizeof(TriangleBvh::Node) + bvh.face_count() * 40) / double(bvh.face_count()));

  const size_t nq = 200000;
  for (bool near_surface : {true, false}) {
    std::vector<double> q = make_queries(mesh, nq, near_surface);
    std::vector<TriangleBvh::Hit> hits(nq);
    t = Timer();
    for (size_t i = 0; i < nq; ++i) hits[i] = bvh.closest_point(&q[3 * i]);
    double single_wall = t.wall(), single_cpu = t.cpu();
    t = Timer();
    bvh.closest_points(q.data(), nq, hits.data(), 0);
    std::printf(
        "closest_point, random queries %s: 1 thread %.3f us/query wall (%.3f cpu), all cores %.3f us/query wall\n",
        near_surface ? "near the surface" : "in the box x1.4", 1e6 * single_wall / nq, 1e6 * single_cpu / nq,
        1e6 * t.wall() / nq);
#ifdef WITH_EMBREE
    RTCDevice device = rtcNewDevice("threads=1");
    RTCScene scene = rtcNewScene(device);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    t = Timer();
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, mesh.positions.data(), 0,
                               3 * sizeof(float), mesh.vertex_count());
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, mesh.indices.data(), 0,
                               3 * sizeof(uint32_t), mesh.face_count());
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);
    std::string ebuild = t.str();
    size_t closer = 0, ties = 0;
    t = Timer();
    for (size_t i = 0; i < nq; ++i) {
      EmbreeHit h{&mesh, {q[3 * i], q[3 * i + 1], q[3 * i + 2]}, INFINITY, kNone};
      RTCPointQuery query;
      query.x = float(q[3 * i]), query.y = float(q[3 * i + 1]), query.z = float(q[3 * i + 2]);
      query.time = 0;
      query.radius = INFINITY;
      RTCPointQueryContext context;
      rtcInitPointQueryContext(&context);
      rtcPointQuery(scene, &query, &context, embree_callback, &h);
      if (h.best2 < hits[i].distance2) ++closer;  // Embree found a closer face: ours would be wrong
      if (h.face != hits[i].face && h.best2 == hits[i].distance2) ++ties;
    }
    std::printf(
        "  embree, 1 thread: build %s, %.3f us/query wall (%.3f cpu); closer than ours: %zu/%zu, same distance but "
        "another face: %zu\n",
        ebuild.c_str(), 1e6 * t.wall() / nq, 1e6 * t.cpu() / nq, closer, nq, ties);
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
#endif
  }

  if (argc > 2) {
    Mesh coarse = load(argv[2]);
    std::printf("coarse %s: %zu faces\n", argv[2], coarse.face_count());
    for (uint64_t samples : {uint64_t(0), uint64_t(100000), uint64_t(2000000)}) {
      t = Timer();
      ApproximationError e = approximation_error(coarse, mesh, samples);
      std::printf(
          "approximation_error(coarse, mesh, samples=%llu): %s: hausdorff %.6g (rel %.6g) rms %.6g (rel %.6g), "
          "%llu points\n",
          (unsigned long long)e.samples, t.str().c_str(), e.hausdorff, e.hausdorff_rel, e.rms, e.rms_rel,
          (unsigned long long)e.points);
    }
  }
  return 0;
}
