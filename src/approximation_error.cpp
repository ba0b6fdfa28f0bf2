// meshcvt: distance between two surfaces (symmetric Hausdorff, RMS and mean), the usual measure of
// how well a coarsened mesh approximates its original (cf. Metro, Cignoni et al. 1998).
//
// Points: area-uniform samples on each surface plus its vertices; each point's exact distance to the
// other surface comes from a TriangleBvh closest-point query. Work is cut into fixed chunks whose
// partial results are combined in chunk order, so threads never change a digit.
#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <exception>
#include <future>
#include <optional>
#include <string>
#include <system_error>
#include <thread>

#include "meshcvt/error.h"
#include "meshcvt/quality.h"
#include "triangle_bvh.h"

namespace meshcvt {

namespace {

constexpr uint64_t kMinSamples = 100'000;
constexpr uint64_t kMaxSamples = 1'000'000;
constexpr size_t kChunk = 4096;  // points per work item; fixed, so sums do not depend on threads

// splitmix64's output function: a counter-based generator, so sample k is a function of (seed, k)
// alone and any thread can make any sample.
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
inline double uniform01(uint64_t seed, uint64_t counter) {  // in [0, 1)
  return double(mix64(seed + 0x9e3779b97f4a7c15ull * (counter + 1)) >> 11) * 0x1.0p-53;
}

// Where the samples of one surface come from: cumulative areas for picking faces.
struct Surface {
  const Mesh* mesh = nullptr;
  std::vector<double> cumulative_area;  // cumulative_area[f] = area of faces 0..f
  std::vector<uint32_t> vertices;       // referenced vertices, in order of first use by a face
  double total_area = 0;
  uint32_t last_face_with_area = 0;
  float bbox_min[3] = {0, 0, 0}, bbox_max[3] = {0, 0, 0};
};

Surface make_surface(const Mesh& mesh, const char* role) {
  Surface s;
  s.mesh = &mesh;
  const size_t F = mesh.face_count();
  if (F == 0) throw OptionError(std::string("approximation error: the ") + role + " mesh has no face");
  s.cumulative_area.resize(F);
  double sum = 0;
  for (size_t f = 0; f < F; ++f) {
    double p[3][3];
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) p[c][k] = mesh.positions[3 * size_t(mesh.indices[3 * f + c]) + k];
    double u[3], w[3];
    for (int k = 0; k < 3; ++k) u[k] = p[1][k] - p[0][k], w[k] = p[2][k] - p[0][k];
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    double area = 0.5 * std::sqrt((n[0] * n[0] + n[1] * n[1]) + n[2] * n[2]);
    if (area > 0) s.last_face_with_area = uint32_t(f);
    sum += area;
    s.cumulative_area[f] = sum;
  }
  s.total_area = sum;
  if (!(sum > 0) || !std::isfinite(sum))
    throw OptionError(std::string("approximation error: the ") + role + " mesh has zero total area");

  // Vertices in the order the faces first use them: neighbouring faces are usually neighbours in
  // the file, so consecutive queries stay close (warm caches, tight bounds from the previous hit);
  // index order can jump around (e.g. after subdivision appends edge midpoints).
  std::vector<bool> used(mesh.vertex_count(), false);
  bool first = true;
  for (uint32_t v : mesh.indices) {
    if (used[v]) continue;
    used[v] = true;
    s.vertices.push_back(v);
    for (int k = 0; k < 3; ++k) {
      float x = mesh.positions[3 * size_t(v) + k];
      s.bbox_min[k] = first ? x : std::min(s.bbox_min[k], x);
      s.bbox_max[k] = first ? x : std::max(s.bbox_max[k], x);
    }
    first = false;
  }
  return s;
}

// Sample k of n on a surface: jittered stratified along the cumulative area (stratum k is
// [k, k+1) / n of the total area), then uniform in the face picked. `face` is a hint, the face of
// the previous sample of the same chunk (samples come in increasing order of k), or 0.
void sample_point(const Surface& s, uint64_t seed, uint64_t k, uint64_t n, uint32_t& face, double out[3]) {
  const std::vector<double>& cdf = s.cumulative_area;
  double t = (double(k) + uniform01(seed, 3 * k)) / double(n) * s.total_area;
  // First face whose cumulative area exceeds t: walk a little from the hint, else bisect the rest.
  uint32_t f = face;
  for (int step = 0; step < 8 && f < cdf.size() && cdf[f] <= t; ++step) ++f;
  if (f < cdf.size() && cdf[f] <= t) f = uint32_t(std::upper_bound(cdf.begin() + f, cdf.end(), t) - cdf.begin());
  if (f >= cdf.size()) f = s.last_face_with_area;  // t rounded up to the total
  face = f;

  // Uniform in the triangle: sqrt of one variable for the distance from corner 0.
  double r1 = std::sqrt(uniform01(seed, 3 * k + 1)), r2 = uniform01(seed, 3 * k + 2);
  double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
  const Mesh& m = *s.mesh;
  const float* a = &m.positions[3 * size_t(m.indices[3 * size_t(f)])];
  const float* b = &m.positions[3 * size_t(m.indices[3 * size_t(f) + 1])];
  const float* c = &m.positions[3 * size_t(m.indices[3 * size_t(f) + 2])];
  for (int j = 0; j < 3; ++j) out[j] = (wa * a[j] + wb * b[j]) + wc * c[j];
}

// Distances from the points of `from` (n samples, then its vertices) to the surface in `to`.
struct OneSided {
  double max = 0, sum = 0, sum2 = 0;  // max over all points; sums over samples only
};

struct ChunkResult {
  double max = 0, sum = 0, sum2 = 0;
};

// Squared distance from q to face f of mesh m (the same routine as the BVH's, so the same value).
double face_distance2(const Mesh& m, uint32_t f, const double q[3]) {
  double v[3][3], p[3];
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) v[c][k] = m.positions[3 * size_t(m.indices[3 * size_t(f) + c]) + k];
  return closest_point_on_triangle(q, v[0], v[1], v[2], p);
}

// The points of `from` (n samples, then its vertices) measured against the tree of `to`, cut into
// fixed chunks that any thread may take (work() until none is left): the chunks' results are
// combined in chunk order, so who took which changes nothing.
class OneSidedJob {
 public:
  OneSidedJob(const Surface& from, const Mesh& to_mesh, const TriangleBvh& to, uint64_t n, uint64_t seed)
      : from_(from), to_mesh_(to_mesh), to_(to), n_(n), seed_(seed), points_(n + from.vertices.size()),
        results_(size_t((points_ + kChunk - 1) / kChunk)) {}

  size_t chunks() const { return results_.size(); }

  // Takes chunks until every chunk is taken (safe to call from several threads at once).
  void work() {
    for (size_t chunk; (chunk = next_.fetch_add(1)) < results_.size();) results_[chunk] = measure_chunk(chunk);
  }

  // Once every work() call has returned.
  OneSided result() const {
    OneSided out;
    for (const ChunkResult& r : results_) {  // fixed order: the same sums for any thread count
      out.max = std::max(out.max, r.max);
      out.sum += r.sum;
      out.sum2 += r.sum2;
    }
    return out;
  }

 private:
  ChunkResult measure_chunk(size_t chunk) const {
    ChunkResult r;
    uint64_t begin = uint64_t(chunk) * kChunk, end = std::min<uint64_t>(points_, begin + kChunk);
    uint32_t face = 0, previous_face = kNone;
    if (begin < n_) {  // start the face walk where this chunk's first stratum lies
      double t = double(begin) / double(n_) * from_.total_area;
      face = uint32_t(std::upper_bound(from_.cumulative_area.begin(), from_.cumulative_area.end(), t) -
                      from_.cumulative_area.begin());
      if (face >= from_.cumulative_area.size()) face = from_.last_face_with_area;
    }
    for (uint64_t i = begin; i < end; ++i) {
      double q[3];
      bool is_sample = i < n_;
      if (is_sample) {
        sample_point(from_, seed_, i, n_, face, q);
      } else {
        const float* p = &from_.mesh->positions[3 * size_t(from_.vertices[i - n_])];
        q[0] = p[0], q[1] = p[1], q[2] = p[2];
      }
      // A vertex counts only towards the largest distance, and the previous point's nearest face
      // bounds its distance (consecutive points are close together): when that bound is no more
      // than the chunk's largest distance so far, the vertex changes nothing and is not queried.
      // Most vertices of a fine mesh end here (the 4.8M bunny against its 10k coarsening: 2.4M
      // vertices). The chunk's maximum is the same as with every query made. The queries
      // themselves go unbounded: the nearest-first descent finds as tight a bound on its own (the
      // 10k coarsening's 1M samples against the 4.8M bunny: 0.92 s unbounded, 1.10 s bounded by the
      // previous face; 0.97M of its face centroids against the 10k tree: 0.39 s either way).
      if (!is_sample && previous_face != kNone && std::sqrt(face_distance2(to_mesh_, previous_face, q)) <= r.max)
        continue;
      const TriangleBvh::Hit hit = to_.closest_point(q);
      assert(hit.face != kNone);  // the tree is not empty
      previous_face = hit.face;
      const double d2 = hit.distance2;
      double d = std::sqrt(d2);
      r.max = std::max(r.max, d);
      if (is_sample) {
        r.sum += d;
        r.sum2 += d2;
      }
    }
    return r;
  }

  const Surface& from_;
  const Mesh& to_mesh_;
  const TriangleBvh& to_;
  const uint64_t n_, seed_, points_;
  std::vector<ChunkResult> results_;
  std::atomic<size_t> next_{0};
};

// Runs `work` on the calling thread and up to threads - 1 more (fewer when no more threads are to
// be had: the ones running take every chunk anyway), and waits for all of them.
template <class Work>
void run_on_threads(unsigned threads, const Work& work) {
  std::vector<std::thread> pool;
  try {
    pool.reserve(threads);
    for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
  } catch (const std::exception&) {  // std::system_error, or std::bad_alloc for the list
  }
  work();
  for (auto& t : pool) t.join();
}

}  // namespace

uint64_t default_error_samples(const Mesh& a, const Mesh& ref) {
  uint64_t faces = std::max<uint64_t>(a.face_count(), ref.face_count());
  return std::clamp(faces, kMinSamples, kMaxSamples);
}

ApproximationError approximation_error(const Mesh& a, const Mesh& ref, uint64_t samples_per_mesh, unsigned threads,
                                       uint64_t seed) {
  const uint64_t n = samples_per_mesh ? samples_per_mesh : default_error_samples(a, ref);
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());

  // Each side's points are measured against the other side's tree. Morton trees: each is queried
  // about once per sample or vertex of the other mesh, so a build three times cheaper than the
  // SAH's outweighs its somewhat slower queries (measured by `meshcvt stats`: the 4.8M bunny's
  // error 2.73 -> 2.06 s and 753 -> 583 MB peak, the 1.2M bunny's 1.04 -> 0.87 s, bunny00's 0.09 s
  // either way). The distances are the same (TriangleBvh's exactness).
  // The larger tree's build (0.65 s at 4.8M faces on one thread) overlaps the measurement that
  // does not need it: one thread builds it while the others measure the larger mesh's points
  // against the smaller tree, and joins them once built; then every thread measures against it.
  // From four threads on, half of them build it (its passes and subtrees side by side: 0.49 s on
  // two) and the other half measure: built by one thread, it was the longest part of the job on
  // many cores.
  const unsigned build_threads = threads >= 4 ? threads / 2 : 1;
  const unsigned measure_threads = std::max(1u, threads - build_threads);
  const bool a_is_small = a.face_count() <= ref.face_count();
  const Mesh& small = a_is_small ? a : ref;
  const Mesh& big = a_is_small ? ref : a;
  // Different seeds for the two sides, so that a mesh compared with itself gets distinct samples.
  const uint64_t seed_a = mix64(seed), seed_ref = mix64(seed ^ 0x5bd1e995u);
  Surface sa, sr;
  TriangleBvh small_tree, big_tree;
  std::optional<OneSidedJob> against_small;
  auto prepare = [&] {
    sa = make_surface(a, "measured");
    sr = make_surface(ref, "reference");
    small_tree = TriangleBvh(small, measure_threads, TriangleBvh::Build::morton);
    against_small.emplace(a_is_small ? sr : sa, small, small_tree, n, a_is_small ? seed_ref : seed_a);
  };
  auto build_big = [&] { big_tree = TriangleBvh(big, build_threads, TriangleBvh::Build::morton); };
  std::thread builder;
  std::promise<bool> prepared;  // true: against_small is ready for the builder to join
  std::exception_ptr build_failure;
  if (threads > 1) {
    try {
      builder = std::thread([&, ready = prepared.get_future()]() mutable {
        try {
          build_big();
        } catch (...) {
          build_failure = std::current_exception();
          return;
        }
        if (ready.get()) against_small->work();
      });
    } catch (const std::system_error&) {
      // No thread to be had: the tree is built below, on this one.
    }
  }
  try {
    prepare();
  } catch (...) {
    if (builder.joinable()) {
      prepared.set_value(false);
      builder.join();
    }
    throw;
  }
  if (builder.joinable()) {
    prepared.set_value(true);
    run_on_threads(unsigned(std::min<size_t>(measure_threads, against_small->chunks())),
                   [&] { against_small->work(); });
    builder.join();
    if (build_failure) std::rethrow_exception(build_failure);
  } else {
    build_big();
    run_on_threads(unsigned(std::min<size_t>(threads, against_small->chunks())), [&] { against_small->work(); });
  }
  OneSidedJob against_big(a_is_small ? sa : sr, big, big_tree, n, a_is_small ? seed_a : seed_ref);
  run_on_threads(unsigned(std::min<size_t>(threads, against_big.chunks())), [&] { against_big.work(); });
  const OneSided ab = a_is_small ? against_big.result() : against_small->result();
  const OneSided ba = a_is_small ? against_small->result() : against_big.result();

  ApproximationError e;
  e.samples = n;
  e.points = 2 * n + sa.vertices.size() + sr.vertices.size();
  e.a_to_b_max = ab.max;
  e.b_to_a_max = ba.max;
  e.a_to_b_rms = std::sqrt(ab.sum2 / double(n));
  e.b_to_a_rms = std::sqrt(ba.sum2 / double(n));
  e.a_to_b_mean = ab.sum / double(n);
  e.b_to_a_mean = ba.sum / double(n);
  e.hausdorff = std::max(ab.max, ba.max);
  e.rms = std::sqrt((ab.sum2 + ba.sum2) / double(2 * n));
  double d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double d = double(sr.bbox_max[k]) - double(sr.bbox_min[k]);
    d2 += d * d;
  }
  e.diagonal = std::sqrt(d2);
  e.hausdorff_rel = e.diagonal > 0 ? e.hausdorff / e.diagonal : 0.0;
  e.rms_rel = e.diagonal > 0 ? e.rms / e.diagonal : 0.0;
  return e;
}

}  // namespace meshcvt
