// meshcvt: moves the vertices of a coarse mesh over their own clusters to improve its triangles
// (declared in meshcvt/coarsen.h), the tangential-relaxation step of surface remeshing (Botsch and
// Kobbelt, SGP 2004) held to the clustering.
//
// Why: a coarse vertex is one point of its cluster (VertexPlacement), chosen from the cluster alone.
// Where clusters hold only a few input faces (fandisk -> 1000: 13 faces per cluster) their shapes
// follow the input's triangles, their centroids jitter by a fraction of an edge, and the dual gets
// obtuse triangles with angles below 30 degrees that no edge flip removes (flipping the long edge
// would make the neighbour worse). Moving the vertex a little toward the middle of its ring removes
// them, and moving it over its own cluster's faces keeps what makes it that cluster's vertex: it
// stays on the input surface, inside the region it stands for.
//
// One move of vertex v: the target is the mean of its ring's neighbours; the step toward it is
// restricted to the directions the ring's normals leave free (the eigenvectors of the normal tensor
// sum area n n^T with small eigenvalues: the tangent plane of a flat ring, the line of a crease,
// nothing at a corner), so features are not cut; the stepped point goes to a point of v's own
// cluster's faces (a walk over the cluster from the face under v toward the nearest point); half
// and quarter steps are tried when the full one is refused. A move is kept only when
//   * every incident triangle's normal turns by at most `max_normal_turn_deg` (no triangle folds
//     over its neighbours or turns its back on the surface it approximates); a cap whose apex is
//     the vertex (an angle above 170 degrees there) need only face the ring's side, its normal
//     being noise (cylinder_locally_refined -> 411 kept a 0.38-degree cap, its apex on the open
//     boundary's straight line: no move of it turned the cap by less than 20 degrees), and
//   * the smallest angle of v's incident triangles stays at or above min(its old value, 35 deg),
//     and either it grows or the sum of their qualities Q grows (Q as in quality.cpp).
// A vertex of a triangle below 33 degrees that no such move helps may also step across a feature
// (tangent to the ring), only if its smallest angle grows and its cluster's corners stay within 1.5x
// of their old largest squared distance to its triangles: what the worst triangles on creases and thin
// parts need (fandisk, the elephant), without cutting features elsewhere.
// So the mesh's smallest angle never drops below min(its old value, 35 deg). Only vertices whose
// every edge has two consistently oriented triangles move (boundaries keep their shape).
// A vertex off its cluster's faces (a qem point, placed off a curved cluster on purpose) floats:
// it is not taken back onto the faces, which would lose the offset that lowers the error; it
// steps only along the free directions of its own cluster's normal tensor (the plane of a flat
// cluster, the line of a crease cluster, nothing at a corner), where the cluster's quadric error
// barely changes, and only while the largest squared distance from (up to kFloatErrorPoints of)
// its cluster's corners to its triangles grows by at most kFloatErrorGrowth (kRescueErrorGrowth
// for a vertex of a triangle below 33 degrees). (Until the sixteenth session such points stayed
// where they were; then 130 of bunny00 -> 500's qem angles were below 30 degrees, against
// ACVDQ's 7.)
// Connectivity, orientation and the vertex count are never touched.
//
// Cost: a pass visits the vertices whose ring moved noticeably in the previous pass (all in the
// first), each trying up to three points, each a walk of a few faces. A pass goes through classes
// of vertices no two of which share a triangle (a greedy coloring in vertex order): the vertices of
// a class move side by side on the worker pool, and the result is that of moving them one after
// the other, class by class, so it does not depend on the thread count. (Until the eighth session
// the pass went in plain vertex order on one thread: 73 of the 200 ms of coarsening the 1.2M bunny
// -> 10k. The order changes single moves, not the quality: Table 1's rows moved by at most 0.3
// degrees of minimum angle.) Nearly every vertex moves in every pass (fandisk -> 1000: 2625 moves
// in 2996 visits), so a visit's cost is what counts; per visit, on fandisk: the ring's shapes and
// normal tensor, a Jacobi decomposition (~7 rotations), one walk of ~4 closest-point tests per
// tried point, the shapes at the tried point. Hence: a worker reads two rings of its class before
// decomposing both side by side (each rotation is a chain of dependent divisions and roots that
// the other fills), a shape takes Q's three roots and division only where the comparison comes
// down to Q, and a tried point is dropped at its first failing triangle. Each of these does the
// same operations on every value that decides anything, so the meshes are the same to the bit as
// before them (one thread, fandisk -> 1000: 3.5 -> 2.6 ms; bunny00 -> 500: 1.9 -> 1.4 ms).
#include <algorithm>
#include <cassert>
#include <cmath>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "coarse_rings.h"
#include "parallel.h"
#include "symmetric_eigen3.h"
#include "triangle_bvh.h"
#include "vec3.h"

namespace meshcvt {

namespace {

// Step fractions tried toward the target, largest first.
constexpr double kStepFractions[] = {1.0, 0.5, 0.25};
// A walk over a cluster's faces stops after this many steps (a cluster of thousands of faces).
constexpr uint32_t kMaxWalkSteps = 256;
// Eigenvalues of a ring's normal tensor below this fraction of the largest leave their direction
// free: a ring whose normals spread less than about +-13 degrees around an axis is flat across it.
constexpr double kFreeEigenvalue = 0.05;
// A move may lower the smallest incident angle when that stays at or above this (and the ring's Q
// grows): uniform triangles need give and take, and 35 degrees keeps a margin over the usual
// 30-degree target. Below it, the smallest angle never drops.
const double kSafeTan = std::tan(35 * std::numbers::pi / 180);
// A triangle whose angle at the moving vertex is above 180 degrees less this is a cap with the
// vertex at its apex, nearly on the segment between its other two corners: its normal says
// nothing (which side of the segment the apex lies on, in any direction around it), so its move is
// judged by whether the cap then faces the ring's side, not by its normal's turn.
const double kCapTan = std::tan(10 * std::numbers::pi / 180);
// A vertex whose incident triangles have an angle below this may also step across a feature.
const double kRescueTan = std::tan(33 * std::numbers::pi / 180);
// A rescue step (across a feature) may let the largest squared distance from its cluster's corners
// to the vertex's triangles grow by this factor at most (measured: 1 blocks the elephant's worst
// triangle, 1.5 keeps Hausdorff within 4% and RMS within 5% even for qem, whose points sit on
// features).
constexpr double kRescueErrorGrowth = 1.5;
// A vertex farther than this fraction of its mean ring edge from its cluster's faces is off the
// surface (float rounding of a point on a face is about 1e-7 of the coordinates).
constexpr double kOnSurface = 1e-4;
// A move shorter than this fraction of the mean ring edge does not wake the neighbours for the
// next pass: the tail of ever smaller moves would cost passes and change nothing visible.
constexpr double kWakeFraction = 0.01;
// A floating vertex's move may let the largest squared distance from its cluster's corners to its
// triangles grow by this factor (the distance by about 9.5%), judged on the corners of at most
// kFloatErrorPoints / 3 of its faces (evenly taken). Measured with qem (sixteenth session):
// without the check fandisk -> 1000's RMS distance rose 17%; with 1.0, bunny00 -> 500 kept 53
// angles below 30 degrees instead of 33; 64 corners instead of 24 cost the 1.2M bunny -> 10k
// 0.13 s more for the same numbers. A vertex of a triangle below 33 degrees may let it grow by
// kRescueErrorGrowth instead: the check refused the last move of half the vertices at the 1.2M
// bunny -> 10k's remaining thin triangles; with 1.5 for them its angles below 30 went 72 -> 41
// and bunny00's 32 -> 27, RMS within 0.4%.
constexpr double kFloatErrorGrowth = 1.2;
constexpr size_t kFloatErrorPoints = 24;
// Vertices (a few microseconds each) below which one thread does a class of the pass.
constexpr size_t kMinParallelVertices = 64;

struct Shape {
  // tan of the smallest angle: the smallest angle of a triangle is at most 60 degrees, where tan
  // grows with the angle, so comparing it compares angles without an atan2.
  double min_tan;
  // What Q (quality()) takes besides: twice the area and the squared edge lengths. Most tried
  // points are decided by the smallest angle alone, and Q's three square roots and division were
  // half the cost of a shape.
  double twice_area, ab2, bc2, ca2;
};

// sqrt(x) <= sqrt(y) for squared lengths, as the rounded roots compare, mostly without taking
// them: a correctly rounded sqrt never reverses an order, and squares more than 1e-12 apart
// (relative) have roots farther apart than their rounding. Near-ties, and values too small or
// not finite for that margin, take the roots.
bool root_le(double x, double y) {
  if (x <= y) return true;
  if (y > 1e-280 && x > y * (1 + 1e-12)) return false;
  return std::sqrt(x) <= std::sqrt(y);
}

// (inline: called out of line, its corners and result went through memory, 6% of the
// instructions of relax.)
inline Shape triangle_shape(Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 ab = b - a, bc = c - b, ca = a - c;
  const double ab2 = dot(ab, ab), bc2 = dot(bc, bc), ca2 = dot(ca, ca);
  const double twice_area = length(cross(ab, bc));
  // The smallest angle is opposite the shortest edge (edges compared as their lengths compare);
  // its cosine times the two edges beside it:
  const double adjacent = root_le(ab2, bc2) && root_le(ab2, ca2) ? -dot(bc, ca)   // at c
                          : root_le(bc2, ca2)                    ? -dot(ca, ab)   // at a
                                                                 : -dot(ab, bc);  // at b
  const double min_tan = twice_area > 0 ? (adjacent > 0 ? twice_area / adjacent : INFINITY) : 0.0;
  return {min_tan, twice_area, ab2, bc2, ca2};
}

// Q = (6 / sqrt 3) area / (semi-perimeter * longest edge), 1 when equilateral.
double quality(const Shape& s) {
  const double lab = std::sqrt(s.ab2), lbc = std::sqrt(s.bc2), lca = std::sqrt(s.ca2);
  const double longest = std::max({lab, lbc, lca});
  const double denominator = 0.5 * (lab + lbc + lca) * longest;
  return denominator > 0 ? (3.0 / std::sqrt(3.0)) * s.twice_area / denominator : 0.0;
}

// The sum of Q over the first `count` shapes, in order (every sum of a ring adds in one order).
double quality_sum(const std::vector<Shape>& shapes, uint32_t count) {
  double sum = 0;
  for (uint32_t i = 0; i < count; ++i) sum += quality(shapes[i]);
  return sum;
}

Vec3 point_of(const float* p) { return {p[0], p[1], p[2]}; }

// Whether every edge at v has exactly two triangles, using it in opposite directions, and no
// triangle at v repeats a vertex: then the corners after v in its triangles and the corners before
// v are the same neighbours, each once. Only triangles at v have an edge at v, so v's own ring
// decides (a bad edge makes both its ends stay; each end finds it in its own ring). [first, last):
// the triangles at v; after, before: scratch.
bool ring_is_closed_disk(const Mesh& coarse, const uint32_t* first, const uint32_t* last, uint32_t v,
                         std::vector<uint32_t>& after, std::vector<uint32_t>& before) {
  after.clear();
  before.clear();
  for (const uint32_t* t = first; t != last; ++t) {
    const uint32_t* tri = &coarse.indices[3 * size_t(*t)];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) return false;
    const int k = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
    after.push_back(tri[(k + 1) % 3]);
    before.push_back(tri[(k + 2) % 3]);
  }
  std::sort(after.begin(), after.end());
  std::sort(before.begin(), before.end());
  return after == before && std::adjacent_find(after.begin(), after.end()) == after.end();
}

}  // namespace

namespace {
// The public entry's checks of its inputs (OptionError on each). coarsen_mesh calls the detail
// version directly: it made the coarse mesh and the labels itself, and these passes over every
// face and its adjacency were 15 of its ~90 ms on the 1.2M bunny -> 10k.
void check_relax_inputs(const Mesh& coarse, const Mesh& mesh, const Topology& topology,
                        const std::vector<uint32_t>& labels) {
  const size_t n = coarse.vertex_count(), faces = mesh.face_count();
  if (labels.size() != faces)
    throw OptionError("relax: " + std::to_string(labels.size()) + " labels for " + std::to_string(faces) + " faces");
  for (uint32_t label : labels)
    if (label >= n) throw OptionError("relax: a label is not below the coarse vertex count " + std::to_string(n));
  for (uint32_t v : coarse.indices)
    if (v >= n) throw OptionError("relax: a coarse triangle has a vertex index out of range");
  for (uint32_t v : mesh.indices)
    if (v >= mesh.vertex_count()) throw OptionError("relax: a face has a vertex index out of range");
  if (topology.face_adjacent.size() != mesh.indices.size())
    throw OptionError("relax: the topology was not built for this mesh");
  for (uint32_t g : topology.face_adjacent)
    if (g != kNone && g >= faces) throw OptionError("relax: the topology was not built for this mesh");
}
}  // namespace

namespace detail {

uint64_t relax_coarse_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                               const std::vector<uint32_t>& labels, uint32_t passes, double max_normal_turn_deg,
                               const std::vector<uint32_t>* start_faces, unsigned threads) {
  const size_t n = coarse.vertex_count(), faces = mesh.face_count(), triangles = coarse.face_count();
  if (!(max_normal_turn_deg >= 0 && max_normal_turn_deg <= 180))  // (an option: checked on every path)
    throw OptionError("relax: the normal turn limit must be within [0, 180] degrees");
  if (passes == 0 || n == 0 || triangles == 0) return 0;

  std::vector<uint32_t> ring_offsets, ring;  // triangles per coarse vertex (CSR)
  coarse_triangle_rings(coarse, ring_offsets, ring);
  // The face each vertex stands on: given, or walked to from its cluster's first face.
  std::vector<uint32_t> home(n, kNone);
  bool any_missing = start_faces == nullptr || start_faces->size() != n;
  if (!any_missing)
    for (size_t v = 0; v < n; ++v) {
      const uint32_t f = (*start_faces)[v];
      if (f < faces && labels[f] == v)
        home[v] = f;
      else
        any_missing = true;
    }
  std::vector<uint8_t> walk_home(n, 0);  // 1: home is the cluster's first face, not the one under the vertex
  if (any_missing)
    for (size_t f = faces; f-- > 0;)
      if (home[labels[f]] == kNone || walk_home[labels[f]]) {
        home[labels[f]] = uint32_t(f);
        walk_home[labels[f]] = 1;
      }
  // Movable (1, or kFloating once the vertex is found off its cluster's faces): every edge at the
  // vertex has exactly two triangles using it in opposite directions, no triangle repeats the
  // vertex, it has three or more triangles and its cluster has faces.
  constexpr uint8_t kFloating = 2;
  std::vector<uint8_t> movable(n, 0);
  {
    std::vector<uint32_t> after, before;  // per ring triangle of v: the corner after v, before v
    for (uint32_t v = 0; v < n; ++v)
      if (home[v] != kNone && ring_offsets[v + 1] - ring_offsets[v] >= 3)
        movable[v] = ring_is_closed_disk(coarse, ring.data() + ring_offsets[v], ring.data() + ring_offsets[v + 1], v,
                                         after, before);
  }

  // A point of cluster c's faces near q: from the face `home` (in c), step to the edge-neighbour
  // in c whose closest point to q is nearest while that is strictly nearer, and take the closest
  // point of the face where it stops. O(steps), no search structure; the closest point of the
  // cluster unless the cluster folds back toward q (then a point of the cluster nearer the start,
  // still on its faces). `home` becomes the face where the walk stopped.
  auto project = [&](uint32_t c, const double q[3], uint32_t& at, double out[3]) {
    auto distance = [&](uint32_t f, double point[3]) {
      double corner[3][3];
      for (int j = 0; j < 3; ++j)
        for (int d = 0; d < 3; ++d) corner[j][d] = mesh.positions[3 * size_t(mesh.indices[3 * size_t(f) + j]) + d];
      return closest_point_on_triangle(q, corner[0], corner[1], corner[2], point);
    };
    double best = distance(at, out);
    // The face the walk came from is strictly farther than `at`: never taken again, not measured.
    uint32_t from = kNone;
    for (uint32_t steps = 0; steps < kMaxWalkSteps; ++steps) {
      uint32_t next = kNone;
      double next_point[3] = {0, 0, 0}, next_best = best;
      for (int e = 0; e < 3; ++e) {
        const uint32_t g = topology.face_adjacent[3 * size_t(at) + e];
        if (g == kNone || g == from || labels[g] != c) continue;
        double point[3];
        const double d2 = distance(g, point);
        if (d2 < next_best) {  // ties: the lower edge index
          next_best = d2;
          next = g;
          for (int d = 0; d < 3; ++d) next_point[d] = point[d];
        }
      }
      if (next == kNone) break;
      best = next_best;
      from = at;
      at = next;
      for (int d = 0; d < 3; ++d) out[d] = next_point[d];
    }
  };
  // A point placed off the surface on purpose (qem at a curved cluster) floats (see the top). A
  // walk stops early where a cluster folds back toward the point, so a point the walk leaves off
  // the faces is measured against every face of its cluster before it floats: a point on them
  // gets the face under it instead.
  // (Each vertex reads the positions and writes its own home and movable flag; `seen` is marked
  // and cleared only at the vertex's own cluster's faces: any split.)
  std::vector<uint8_t> seen(faces, 0);
  WorkerPool pool(threads);
  std::vector<std::vector<uint32_t>> setup_flood(pool.size());
  pool.run(n, [&](size_t first, size_t last, unsigned worker) {
    for (size_t v = first; v < last; ++v) {
      if (!movable[v]) continue;
      const double p[3] = {coarse.positions[3 * v], coarse.positions[3 * v + 1], coarse.positions[3 * v + 2]};
      double edge_sum = 0;
      for (uint32_t i = ring_offsets[v]; i < ring_offsets[v + 1]; ++i)
        for (int k = 0; k < 3; ++k)
          edge_sum += length(point_of(&coarse.positions[3 * size_t(coarse.indices[3 * size_t(ring[i]) + k])]) -
                             Vec3{p[0], p[1], p[2]});
      const double limit = kOnSurface * edge_sum / (2.0 * (ring_offsets[v + 1] - ring_offsets[v]));
      // Where the vertex lies on the face given for it (the placement's own face: nearly always)
      // that face is its start; a walk only where it does not (a third of the setup's time was
      // walks from faces the vertex was already on).
      const uint32_t f = home[v];
      double corner[3][3], onto[3];
      for (int j = 0; j < 3; ++j)
        for (int d = 0; d < 3; ++d) corner[j][d] = mesh.positions[3 * size_t(mesh.indices[3 * size_t(f) + j]) + d];
      if (closest_point_on_triangle(p, corner[0], corner[1], corner[2], onto) <= limit * limit) continue;
      project(uint32_t(v), p, home[v], onto);
      const double off = length(Vec3{onto[0] - p[0], onto[1] - p[1], onto[2] - p[2]});
      if (off <= limit) continue;
      // Every face of the cluster (a flood from home) until one lies within the limit: it becomes
      // home. A face whose plane is farther than the limit is passed without the full test.
      std::vector<uint32_t>& flood = setup_flood[worker];
      flood.assign(1, home[v]);
      seen[home[v]] = 1;
      uint32_t under = kNone;
      for (size_t i = 0; i < flood.size() && under == kNone; ++i) {
        const uint32_t g = flood[i];
        for (int j = 0; j < 3; ++j)
          for (int d = 0; d < 3; ++d) corner[j][d] = mesh.positions[3 * size_t(mesh.indices[3 * size_t(g) + j]) + d];
        const Vec3 a = {corner[0][0], corner[0][1], corner[0][2]};
        const Vec3 normal = cross(Vec3{corner[1][0], corner[1][1], corner[1][2]} - a,
                                  Vec3{corner[2][0], corner[2][1], corner[2][2]} - a);
        const double height = dot(Vec3{p[0], p[1], p[2]} - a, normal);
        if (!(height * height > limit * limit * dot(normal, normal)) &&
            closest_point_on_triangle(p, corner[0], corner[1], corner[2], onto) <= limit * limit)
          under = g;
        for (int e = 0; e < 3; ++e) {
          const uint32_t h = topology.face_adjacent[3 * size_t(g) + e];
          if (h != kNone && labels[h] == v && !seen[h]) {
            seen[h] = 1;
            flood.push_back(h);
          }
        }
      }
      for (uint32_t g : flood) seen[g] = 0;
      if (under != kNone)
        home[v] = under;
      else
        movable[v] = kFloating;
    }
  }, kMinParallelVertices);

  // Vertices in classes of which no two share a triangle (greedy coloring in index order, among
  // movable vertices): a move reads the positions of its ring and writes only its own vertex, so
  // the vertices of one class move independently, side by side, and the result is that of moving
  // them one after the other class by class, whatever the thread count.
  std::vector<uint32_t> class_offsets, class_vertices;
  {
    // used_by[c] == v: a neighbour of v already has color c (no sort of the neighbours' colors).
    std::vector<uint32_t> color(n, kNone), used_by;
    uint32_t classes = 0;
    for (uint32_t v = 0; v < n; ++v) {
      if (!movable[v]) continue;
      for (uint32_t i = ring_offsets[v]; i < ring_offsets[v + 1]; ++i)
        for (int k = 0; k < 3; ++k) {
          const uint32_t w = coarse.indices[3 * size_t(ring[i]) + k];
          if (w == v || color[w] == kNone) continue;
          if (color[w] >= used_by.size()) used_by.resize(color[w] + 1, kNone);
          used_by[color[w]] = v;
        }
      uint32_t c = 0;
      while (c < used_by.size() && used_by[c] == v) ++c;
      color[v] = c;
      classes = std::max(classes, c + 1);
    }
    class_offsets.assign(classes + 1, 0);
    for (uint32_t v = 0; v < n; ++v)
      if (color[v] != kNone) ++class_offsets[color[v] + 1];
    for (uint32_t c = 0; c < classes; ++c) class_offsets[c + 1] += class_offsets[c];
    class_vertices.resize(class_offsets.back());
    std::vector<uint32_t> fill(class_offsets.begin(), class_offsets.end() - 1);
    for (uint32_t v = 0; v < n; ++v)
      if (color[v] != kNone) class_vertices[fill[color[v]]++] = v;
  }

  // A vertex's ring before its move, what its tried points are judged against (read_ring).
  struct RingBefore {
    uint32_t v, count;  // the vertex, its triangles
    Vec3 p, full;       // its position, the step to the mean of its neighbours
    Vec3 side;          // the sum of its triangles' area vectors: the side the ring faces
    double min_tan;     // the smallest angle's tan over its triangles
    // Per triangle: its other two corners (2 per triangle, in its orientation after v), its unit
    // normal, its shape.
    std::vector<Vec3> corners, normals;
    std::vector<Shape> shapes;
    std::vector<uint8_t> cap;  // per triangle: v is the apex of a cap (its angle above 170 degrees)
  };
  // Vertices whose rings are read before their decompositions run side by side (kLanes of them,
  // symmetric_eigen3_lanes: most of its time is the latency of its chain of roots and divisions).
  constexpr int kLanes = 2;
  struct Scratch {
    std::vector<uint32_t> flood, visited;
    std::vector<Vec3> cluster_points;
    RingBefore before[kLanes];
    std::vector<Shape> new_shapes;  // per triangle at the vertex being moved, at the tried point
    std::vector<double> ring_corners;  // ring_error's
  };
  // The corners of cluster c's faces (a flood from `start` over faces of c), for the rescue's
  // error check. Repeated corners are harmless: only the largest distance is used.
  // seen is shared by the workers: a flood marks only faces of its own cluster, and unmarks them
  // when done (so a later flood of the same cluster, in the next pass, starts clean).
  auto gather = [&](uint32_t c, uint32_t start, Scratch& w) {
    w.cluster_points.clear();
    w.flood.assign(1, start);
    w.visited.assign(1, start);
    seen[start] = 1;
    while (!w.flood.empty()) {
      const uint32_t f = w.flood.back();
      w.flood.pop_back();
      for (int k = 0; k < 3; ++k) {
        w.cluster_points.push_back(point_of(&mesh.positions[3 * size_t(mesh.indices[3 * size_t(f) + k])]));
        const uint32_t g = topology.face_adjacent[3 * size_t(f) + k];
        if (g != kNone && labels[g] == c && !seen[g]) {
          seen[g] = 1;
          w.flood.push_back(g);
          w.visited.push_back(g);
        }
      }
    }
    for (uint32_t f : w.visited) seen[f] = 0;
  };
  // The largest squared distance from the cluster's points to the triangles around v with v at
  // `at`: how far the coarse mesh is from this part of the input, as far as v's move changes it.
  // Once it is above stop_above the rest is not measured (the move is refused whatever it is).
  auto ring_error = [&](uint32_t v, Vec3 at, std::span<const Vec3> cluster_points, double stop_above,
                        std::vector<double>& corners) {
    // The ring's corners with v at `at`, read once (9 per triangle).
    const uint32_t count = ring_offsets[v + 1] - ring_offsets[v];
    corners.resize(9 * size_t(count));
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t* tri = &coarse.indices[3 * size_t(ring[ring_offsets[v] + i])];
      for (int j = 0; j < 3; ++j) {
        const Vec3 y = tri[j] == v ? at : point_of(&coarse.positions[3 * size_t(tri[j])]);
        corners[9 * i + 3 * j] = y.x, corners[9 * i + 3 * j + 1] = y.y, corners[9 * i + 3 * j + 2] = y.z;
      }
    }
    // A point's scan over the ring starts at the triangle nearest the previous point (the points
    // come face by face, neighbours mostly nearest the same triangle) and ends once the point is
    // within `worst`: whether it is, and its distance when it is not, do not depend on the order
    // (the 1.2M bunny -> 10k with qem: 5.7M closest-point tests in ring order).
    double worst = 0;
    uint32_t start = 0;
    for (const Vec3& x : cluster_points) {
      if (worst > stop_above) break;
      const double q[3] = {x.x, x.y, x.z};
      double nearest = INFINITY;
      uint32_t hit = start;
      for (uint32_t k = 0; k < count && nearest > worst; ++k) {
        const uint32_t i = start + k < count ? start + k : start + k - count;
        const double* c = &corners[9 * size_t(i)];
        double point[3];
        const double d2 = closest_point_on_triangle(q, c, c + 3, c + 6, point);
        if (d2 < nearest) nearest = d2, hit = i;
      }
      start = hit;
      worst = std::max(worst, nearest);
    }
    return worst;
  };

  const double min_cos = std::cos(max_normal_turn_deg * std::numbers::pi / 180.0);
  // For floating vertices: their clusters' normal tensors (sum of area * n n^T over the cluster's
  // faces, 9 per vertex, row-major), whose free directions their steps take, and the corners their
  // moves are checked against (CSR; the corners of every stride-th face of the cluster, in face
  // order, at most kFloatErrorPoints: gathered once, not per visit).
  std::vector<double> cluster_tensor;
  std::vector<uint32_t> float_point_offsets;
  std::vector<Vec3> float_points;
  if (std::find(movable.begin(), movable.end(), kFloating) != movable.end()) {
    std::vector<uint8_t> floating(n, 0);
    for (size_t c = 0; c < n; ++c) floating[c] = movable[c] == kFloating;
    sample_cluster_corners(mesh, labels, n, kFloatErrorPoints, &floating, float_point_offsets, float_points);
    cluster_tensor.assign(9 * n, 0.0);
    for (size_t f = 0; f < faces; ++f) {
      const uint32_t c = labels[f];
      if (!floating[c]) continue;
      Vec3 q[3];
      for (int j = 0; j < 3; ++j) q[j] = point_of(&mesh.positions[3 * size_t(mesh.indices[3 * f + j])]);
      const Vec3 m = cross(q[1] - q[0], q[2] - q[0]);
      const double l = length(m);
      if (!(l > 0)) continue;
      const double e[3] = {m.x / l, m.y / l, m.z / l};
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) cluster_tensor[9 * size_t(c) + 3 * i + k] += 0.5 * l * e[i] * e[k];
    }
  }
  std::vector<uint8_t> active = movable, next_active(n, 0);
  // Per vertex in this pass: 1 moved, 2 moved far enough to wake its ring for the next pass.
  std::vector<uint8_t> outcome(n, 0);
  std::vector<Scratch> scratch(pool.size());
  // Reads v's ring before its move into r, and the sum of area * n n^T over its triangles.
  auto read_ring = [&](uint32_t v, RingBefore& r, double tensor[3][3]) {
    const uint32_t* triangles_at = ring.data() + ring_offsets[v];
    const uint32_t count = ring_offsets[v + 1] - ring_offsets[v];
    const Vec3 p = point_of(&coarse.positions[3 * size_t(v)]);
    r.v = v;
    r.count = count;
    r.p = p;
    // The corners, read once: every tried point reads them again.
    r.corners.resize(2 * size_t(count));
    r.normals.resize(count);
    r.shapes.resize(count);
    r.cap.resize(count);
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t* tri = &coarse.indices[3 * size_t(triangles_at[i])];
      const int k = tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
      r.corners[2 * i] = point_of(&coarse.positions[3 * size_t(tri[(k + 1) % 3])]);
      r.corners[2 * i + 1] = point_of(&coarse.positions[3 * size_t(tri[(k + 2) % 3])]);
    }
    double old_min = INFINITY;
    Vec3 target = {0, 0, 0}, side = {0, 0, 0};
    for (int row = 0; row < 3; ++row)
      for (int k = 0; k < 3; ++k) tensor[row][k] = 0;
    for (uint32_t i = 0; i < count; ++i) {
      const Vec3 b = r.corners[2 * i], c = r.corners[2 * i + 1];
      r.shapes[i] = triangle_shape(p, b, c);
      old_min = std::min(old_min, r.shapes[i].min_tan);
      // In a closed fan every neighbour is a corner of two triangles: this sums each twice.
      target = target + 0.5 * (b + c);
      const Vec3 m = cross(b - p, c - p);
      side = side + m;
      const double l = length(m);
      const double at_v = dot(b - p, c - p);
      r.cap[i] = at_v < 0 && l < kCapTan * -at_v;
      const Vec3 u = l > 0 ? (1.0 / l) * m : Vec3{0, 0, 0};
      r.normals[i] = u;
      const double e[3] = {u.x, u.y, u.z};
      for (int row = 0; row < 3; ++row)
        for (int k = 0; k < 3; ++k) tensor[row][k] += 0.5 * l * e[row] * e[k];
    }
    target = (1.0 / double(count)) * target;
    r.full = target - p;
    r.side = side;
    r.min_tan = old_min;
  };
  // r.v's move (or none), given its ring and the decomposition of its tensor: writes v's position,
  // home and outcome only.
  auto move_vertex = [&](const RingBefore& r, const double values[3], const double vectors[3][3], Scratch& w) {
    const uint32_t v = r.v, count = r.count;
    const Vec3 p = r.p, full = r.full;
    const double old_min = r.min_tan;  // old_min, new_min: tan of the smallest angle
    w.new_shapes.resize(count);
    // The directions the ring's normals leave free: both tangent directions on a flat ring, the
    // crease's direction on a crease, none at a corner. Steps along them keep the ring's shape;
    // across them they would cut the crease or corner and take the coarse mesh off the input.
    const double largest = std::max({values[0], values[1], values[2]});
    if (!(largest > 0)) return;
    Vec3 free_step = {0, 0, 0};
    int stiffest = 0;
    for (int k = 0; k < 3; ++k) {
      if (values[k] > values[stiffest]) stiffest = k;
      const Vec3 axis = {vectors[0][k], vectors[1][k], vectors[2][k]};
      if (values[k] < kFreeEigenvalue * largest) free_step = free_step + dot(full, axis) * axis;
    }
    const Vec3 normal = {vectors[0][stiffest], vectors[1][stiffest], vectors[2][stiffest]};
    const Vec3 tangent_step = full - dot(full, normal) * normal;
    // A vertex of a triangle below kRescueTan (33 degrees) may also step across a feature, tangent to the
    // ring's mean plane, if that lifts its smallest angle: rare, and what it takes on creases.
    const bool rescue = old_min < kRescueTan;
    double old_q = 0;  // the ring's sum of Q before the move, once a tried point needs it
    bool have_old_q = false;
    const bool floating = movable[v] == kFloating;  // no rescue: its steps keep to its own cluster's features
    for (int attempt = 0; attempt < (rescue && !floating ? 2 : 1); ++attempt) {
      const Vec3 step = attempt == 0 ? free_step : tangent_step;
      if (!(dot(step, step) > 0)) continue;
      double old_error = 0;
      std::span<const Vec3> error_points;  // what the move's distance check measures from
      if (floating) {
        error_points = std::span<const Vec3>(float_points).subspan(
            float_point_offsets[v], float_point_offsets[v + 1] - float_point_offsets[v]);
        old_error = ring_error(v, p, error_points, INFINITY, w.ring_corners);
      } else if (attempt == 1) {
        gather(v, home[v], w);
        error_points = w.cluster_points;
        old_error = ring_error(v, p, error_points, INFINITY, w.ring_corners);
      }
      // A better point keeps the smallest angle at or above `floor` and lifts it or (along the
      // free directions only) the sum of Q; across a feature the floor is the old angle itself.
      const double floor = attempt == 0 ? std::min(old_min, kSafeTan) : old_min;
      bool moved = false;
      for (double fraction : kStepFractions) {
        const double q[3] = {p.x + fraction * step.x, p.y + fraction * step.y, p.z + fraction * step.z};
        uint32_t face = home[v];
        double onto[3] = {q[0], q[1], q[2]};
        if (!floating) project(v, q, face, onto);
        // Judged at the float position it will be stored as.
        const float stored[3] = {float(onto[0]), float(onto[1]), float(onto[2])};
        const Vec3 np = point_of(stored);
        // No move left: the stored floats are v's. (Compared as floats: GCC 12.2's SLP vectorizer
        // dropped the float round trip of np.x and np.y, here and in the judging below; this file
        // is now built without it, see CMakeLists.txt.)
        const float* at = &coarse.positions[3 * size_t(v)];
        if (stored[0] == at[0] && stored[1] == at[1] && stored[2] == at[2]) break;
        // Refused at the first triangle that folds, or once the smallest angle is below what a
        // better point needs: new_min only falls as triangles are added (std::min keeps the
        // number when a min_tan is NaN, so the whole ring's new_min would fail the same test).
        double new_min = INFINITY;
        bool refused = false;
        for (uint32_t i = 0; i < count && !refused; ++i) {
          const Vec3 b = r.corners[2 * i], c = r.corners[2 * i + 1];
          const Vec3 m = cross(b - np, c - np);
          const double l = length(m);
          // (A floating vertex's caps keep the turn limit: measured on the 69 libcgal-demo meshes
          // with qem, the side test moved mask_cone's RMS +10% and bones' smallest angle 7.5 -> 5.6.)
          if (!(l > 0) || !(r.cap[i] && !floating ? dot(m, r.side) > 0 : dot(m, r.normals[i]) >= min_cos * l)) {
            refused = true;
            break;
          }
          w.new_shapes[i] = triangle_shape(np, b, c);
          new_min = std::min(new_min, w.new_shapes[i].min_tan);
          refused = attempt == 0 ? new_min < floor : !(new_min > floor);
        }
        if (refused) continue;
        if (attempt == 0 && !(new_min > old_min)) {
          if (!have_old_q) old_q = quality_sum(r.shapes, count), have_old_q = true;
          if (!(quality_sum(w.new_shapes, count) > old_q)) continue;
        }
        // Across a feature the move must not take the ring farther from its cluster's points.
        // (A floating vertex of a triangle below kRescueTan is allowed what a rescue step is.)
        const double error_growth = attempt == 1 || (floating && rescue) ? kRescueErrorGrowth
                                    : floating                          ? kFloatErrorGrowth
                                                                        : 0;
        if (error_growth > 0 &&
            ring_error(v, np, error_points, error_growth * old_error, w.ring_corners) > error_growth * old_error)
          continue;
        for (int d = 0; d < 3; ++d) coarse.positions[3 * size_t(v) + d] = stored[d];
        home[v] = face;
        double edge_sum = 0;  // for the mean ring edge
        for (uint32_t i = 0; i < count; ++i) edge_sum += length(r.corners[2 * i] - p);
        outcome[v] = length(np - p) >= kWakeFraction * edge_sum / double(count) ? 2 : 1;
        moved = true;
        break;
      }
      if (moved) break;
    }
  };
  // Vertices of one class, kLanes at a time: their rings, their decompositions side by side,
  // their moves. They share no triangle: no order among them changes anything.
  auto relax_vertices = [&](const uint32_t* vs, int lanes, Scratch& w) {
    double tensors[kLanes][3][3], values[kLanes][3], vectors[kLanes][3][3];
    for (int lane = 0; lane < lanes; ++lane) {
      read_ring(vs[lane], w.before[lane], tensors[lane]);
      if (movable[vs[lane]] == kFloating)  // its cluster's free directions, not its ring's
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) tensors[lane][i][k] = cluster_tensor[9 * size_t(vs[lane]) + 3 * i + k];
    }
    symmetric_eigen3_lanes<kLanes>(lanes, tensors, values, vectors);
    for (int lane = 0; lane < lanes; ++lane) move_vertex(w.before[lane], values[lane], vectors[lane], w);
  };
  uint64_t moves = 0;
  for (uint32_t pass = 0; pass < passes; ++pass) {
    std::fill(outcome.begin(), outcome.end(), uint8_t(0));
    for (size_t c = 0; c + 1 < class_offsets.size(); ++c) {
      const uint32_t* members = &class_vertices[class_offsets[c]];
      pool.run(class_offsets[c + 1] - class_offsets[c], [&](size_t first, size_t last, unsigned worker) {
        uint32_t lane_vertices[kLanes];
        int lanes = 0;
        for (size_t i = first; i < last; ++i) {
          if (!active[members[i]]) continue;
          lane_vertices[lanes++] = members[i];
          if (lanes == kLanes) relax_vertices(lane_vertices, lanes, scratch[worker]), lanes = 0;
        }
        if (lanes > 0) relax_vertices(lane_vertices, lanes, scratch[worker]);
      }, kMinParallelVertices);
    }
    bool awake = false;
    std::fill(next_active.begin(), next_active.end(), uint8_t(0));
    for (uint32_t v = 0; v < n; ++v) {
      if (outcome[v] == 0) continue;
      ++moves;
      if (outcome[v] < 2) continue;
      awake = true;
      for (uint32_t i = ring_offsets[v]; i < ring_offsets[v + 1]; ++i)
        for (int k = 0; k < 3; ++k) {
          const uint32_t w = coarse.indices[3 * size_t(ring[i]) + k];
          next_active[w] = movable[w];
        }
    }
    if (!awake) break;
    active.swap(next_active);
  }
  return moves;
}

}  // namespace detail

uint64_t relax_coarse_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                               const std::vector<uint32_t>& labels, uint32_t passes, double max_normal_turn_deg,
                               unsigned threads) {
  check_relax_inputs(coarse, mesh, topology, labels);
  return detail::relax_coarse_vertices(coarse, mesh, topology, labels, passes, max_normal_turn_deg, nullptr, threads);
}

}  // namespace meshcvt
