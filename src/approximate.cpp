// meshcvt: anisotropic shape approximation with the L2,1 metric — Fan et al. Sections 4 and 6.2,
// meshing after Cohen-Steiner, Alliez, Desbrun, "Variational Shape Approximation" (VSA, 2004).
// API and overview in meshcvt/approximate.h.
//
// Partition (approximate_shape):
//  * fixed count: cluster() with Metric::l21 (hierarchical init with the normal-based cost of 5.1,
//    boundary testing of Section 4, repair of 5.3) on the requested device, then VSA's proxy
//    teleportation on the CPU engine (PartitionRefiner: merge the adjacent pair that costs least,
//    split the region of highest distortion, iterate; kept when the distortion dropped, repeated
//    until two teleports in a row gain little) — a greedy initialization can leave two proxies on
//    one plane while another straddles a sharp edge, a local minimum boundary testing cannot leave;
//  * error-driven (max_error): cluster() with a few proxies, then rounds that each split the regions
//    of highest distortion (restore_cluster_count of the engine: two connected halves grown from
//    far-apart faces) and iterate again (boundary testing + repair, as cluster() does), teleporting
//    after each, until E / A <= max_error. A round adds k = ceil(0.75 n (ratio - 1)) proxies
//    (ratio = (E/A) / max_error), at least 1 and at most n: about what E ~ 1/n predicts is still
//    missing, damped so the count is not overshot by much, and at most doubling. Every round adds
//    at least one proxy and the count is capped at the face count, where E = 0: the loop ends.
//
// Meshing (mesh_partition), everything on flat arrays:
//  1. Disks. Each region is regrown from its lowest face as a shelling: a face joins when it meets
//     the grown part in one or two of its edges (one edge: its third vertex must be new), which
//     keeps the grown part a topological disk. Faces left over (an annulus, a handle, a whole
//     closed component, a region pinched at a vertex) form new regions, regrown the same way.
//     Every region is then a disk with one border loop.
//  2. Border loops. The border of each region is walked once (around each vertex through the
//     region's faces), as a cycle of steps (vertex, region across).
//  3. Anchors. A vertex is a corner anchor when it has faces of three or more regions, or of two on
//     the mesh boundary (non-manifold edges count as boundary). Chords are the pieces of a loop
//     between consecutive anchors; each is processed once, from its "owner" side (the lower region,
//     or the region when the other side is the boundary), so both sides agree. Chord subdivision
//     splits a chord at its farthest vertex from the segment between its anchors while the chord
//     rule says so (ChordRule). Fixes, repeated until nothing changes: a loop with no anchor gets
//     3 evenly spaced by arc length, a loop with one anchor (a closed chord) is split at the vertex
//     farthest from it, two chords joining the same pair of anchors get all but the straightest
//     split (the pair would be an output edge of four triangles), a region with fewer than 3
//     anchors gets one on its most curved chord.
//  4. Positions: the mean of the vertex's projections onto the proxy planes (X_i, N_i) of its
//     regions, rounded to float (every later test is made on the coordinates written out).
//  5. Triangulation, the paper's multi-source Dijkstra coloring: border vertices take the color of
//     the chord end closest along the chord; interior vertices the color of the closest border
//     vertex by Dijkstra distance (seeded with the border vertices' own distances to their anchor,
//     so the colored cells are geodesic Voronoi cells of the anchors with the border pinned). Each
//     input triangle with three colors gives an output triangle. A region's triangles are accepted
//     when they are exactly a triangulation of its anchor polygon (m - 2 triangles, every polygon
//     edge once in border order, every diagonal twice in opposite directions), none faces away from
//     the proxy normal or is a sliver, and no diagonal is an edge of another region. Otherwise the
//     polygon is triangulated directly (interval dynamic programming: fewest bad triangles, then
//     the largest smallest angle).
//  6. A region whose polygon still has no acceptable triangulation is fixed and the round redone
//     (at most kMaxMeshingRounds rounds; only regions whose border changed are colored again):
//     chords that cross in the proxy plane are split at their farthest vertex (no unflipped
//     triangulation exists while they cross); else the region's anchors are put at their mesh
//     vertices (averaged projections can fold a thin region); else its most deviating chord is
//     split, a few times. A region left with flipped triangles after that is too curved for one
//     polygon: it is split in two by its normals and the whole meshing done again, until no region
//     is left with any (at most kMaxSplitPasses passes, and none once no such region can be
//     split); what remains is reported. A round's only use is its fixes until one has none: a
//     region that will take a fix is only tested for an acceptable triangulation
//     (has_perfect_triangulation), and a region out of fixes is not triangulated in a round that
//     is redone (the round kept is done again with it). Likewise a pass that will be followed by a
//     split stops once it knows a region to split: the regions left out of its last round's first
//     try are only tested.
//
// Why this gives a closed manifold for closed manifold input: every region is a disk with one
// polygon, every chord edge is shared by exactly the two polygons on its sides (in opposite
// directions), no two chords join the same anchors, and diagonals are never shared, so every output
// edge has two triangles; around an anchor the regions are disks meeting once each.
#include <algorithm>
#include <atomic>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <queue>
#include <string>
#include <vector>

#include "cluster_engine.h"
#include "meshcvt/approximate.h"
#include "meshcvt/error.h"
#include "parallel.h"
#include "polygon_triangulation.h"
#include "vec3.h"

namespace meshcvt {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Meshing rounds (redone after anchors were added for flipped polygons) before accepting the rest.
constexpr uint32_t kMaxMeshingRounds = 32;
// A region whose polygon is simple in its proxy plane but still has no unflipped triangulation gets
// anchors on its most deviating chord only while it has fewer flip anchors than this: beyond, it is
// too curved for one polygon and is split instead (split_curved).
constexpr uint32_t kMaxDeviationAnchors = 4;
// Passes of the anchor fixes; each pass that changes something adds anchors, so this only bounds
// pathological input (non-manifold borders).
constexpr uint32_t kMaxAnchorPasses = 64;
// Larger polygons are not triangulated by dynamic programming (O(m^3) time, O(m^2) memory).
constexpr uint32_t kMaxDynamicProgramming = 1024;
// A triangle faces along its proxy normal when the cosine between them is above this.
constexpr double kMinFacingCosine = 1e-6;
// Triangles whose smallest angle has a smaller sine are slivers (collinear anchors): never chosen.
constexpr double kMinSine = 1e-6;
constexpr PolygonTriangleRules kTriangleRules{.min_sine = kMinSine, .min_facing_cosine = kMinFacingCosine};
// A region that takes a fix whenever its polygon has no acceptable triangulation is first tested for
// one without making it (has_perfect_triangulation) from this many corners, giving the test up
// after this many triangles per pair of corners: below, the triangulation itself costs little.
constexpr size_t kMinPerfectTest = 16;
constexpr uint64_t kPerfectTestBudget = 4;
// Same as cluster(): repair rounds of the boundary iteration (stalls: run_iterations).
constexpr uint32_t kMaxRepairRounds = 8;
// Teleport attempts after a clustering (each costs a boundary iteration to convergence); the loop
// stops earlier at the first attempt that does not lower the distortion.
constexpr uint32_t kMaxTeleports = 32;
// Teleporting stops after two teleports in a row lower the distortion by less than this fraction:
// on CAD parts teleports remove whole misplaced proxies (fandisk: E / A 0.041 -> 0.016, gains of
// 5-90% between some of 1%), on smooth shapes they gain about 1% each for the cost of a boundary
// iteration to convergence.
constexpr double kTeleportMinGain = 0.02;
// Interior vertices to color below which one thread does it (waking the workers costs more).
constexpr uint64_t kMinParallelColoring = 4096;

// ---- small vector helpers (double)

// Distance from p to the segment ab (to a when a = b).
double segment_distance(Vec3 p, Vec3 a, Vec3 b) {
  Vec3 ab = b - a, ap = p - a;
  double len2 = dot(ab, ab);
  double t = len2 > 0 ? std::clamp(dot(ap, ab) / len2, 0.0, 1.0) : 0.0;
  return length(ap - t * ab);
}

// Sine of the smallest angle of triangle abc (0 when degenerate); the max-min-angle quality.
double min_angle_sine(Vec3 a, Vec3 b, Vec3 c) {
  double area2 = length(cross(b - a, c - a));
  double la = length(b - c), lb = length(c - a), lc = length(a - b);
  // sin(angle at a) = area2 / (lb lc), etc.; the smallest is at the corner opposite the shortest edge
  double m = std::max({la * lb, lb * lc, lc * la});
  return m > 0 ? area2 / m : 0.0;
}

// Triangle abc faces along n (or n is zero: a region without area has no direction to face) and is
// not a sliver: its smallest angle's sine is above kMinSine, so it stays a proper triangle in float.
bool faces_along(Vec3 a, Vec3 b, Vec3 c, Vec3 n) {
  Vec3 cr = cross(b - a, c - a);
  double len = length(cr);
  if (!(min_angle_sine(a, b, c) > kMinSine)) return false;
  if (dot(n, n) == 0) return true;
  return dot(cr, n) > kMinFacingCosine * len;
}

// What the output will hold: positions rounded to float, so every test is made on those.
Vec3 rounded(Vec3 p) { return {double(float(p.x)), double(float(p.y)), double(float(p.z))}; }

uint64_t edge_key(uint32_t a, uint32_t b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(a) << 32) | b;
}

// Undirected edges (edge_key) in an open-addressing table that keeps its memory from one meshing
// round to the next: every round fills it again with the ~1000 chords and diagonals of a
// 100-region approximation, one allocation per node in a std::unordered_set.
class EdgeSet {
 public:
  void clear() {
    std::fill(slots_.begin(), slots_.end(), kEmpty);
    size_ = 0;
  }
  void insert(uint64_t key) {
    assert(key != kEmpty);
    if (2 * (size_ + 1) > slots_.size()) grow();
    size_t i = slot(key);
    while (slots_[i] != kEmpty && slots_[i] != key) i = (i + 1) & (slots_.size() - 1);
    if (slots_[i] == kEmpty) slots_[i] = key, ++size_;
  }
  bool contains(uint64_t key) const {
    if (slots_.empty()) return false;
    for (size_t i = slot(key);; i = (i + 1) & (slots_.size() - 1)) {
      if (slots_[i] == key) return true;
      if (slots_[i] == kEmpty) return false;
    }
  }
  size_t size() const { return size_; }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t(0);  // edge_key of no edge: a < b always
  size_t slot(uint64_t key) const { return size_t((key * 0x9E3779B97F4A7C15ull) >> shift_); }
  void grow() {
    std::vector<uint64_t> old = std::move(slots_);
    size_t capacity = std::max<size_t>(64, 2 * old.size());
    slots_.assign(capacity, kEmpty);
    shift_ = 64 - std::countr_zero(capacity);
    size_ = 0;
    for (uint64_t key : old)
      if (key != kEmpty) insert(key);
  }
  std::vector<uint64_t> slots_;
  int shift_ = 64;
  size_t size_ = 0;
};

// ---- per-face geometry and proxies

struct FaceGeometry {
  std::vector<Vec3> normal;  // unit normal, (0,0,0) for a face without area
  std::vector<double> area;  // input units squared
  std::vector<Vec3> centroid;
  std::vector<uint8_t> collapsed;  // a repeated corner: no edges (see Topology), ignored by meshing
};

FaceGeometry face_geometry(const Mesh& mesh) {
  size_t nf = mesh.face_count();
  FaceGeometry g;
  g.normal.resize(nf);
  g.area.resize(nf);
  g.centroid.resize(nf);
  g.collapsed.resize(nf);
  for (size_t f = 0; f < nf; ++f) {
    uint32_t i0 = mesh.indices[3 * f], i1 = mesh.indices[3 * f + 1], i2 = mesh.indices[3 * f + 2];
    Vec3 a = mesh_vertex(mesh, i0), b = mesh_vertex(mesh, i1), c = mesh_vertex(mesh, i2);
    Vec3 n = cross(b - a, c - a);
    double len = length(n);
    g.area[f] = 0.5 * len;
    g.normal[f] = len > 0 ? (1.0 / len) * n : Vec3{};
    g.centroid[f] = (1.0 / 3.0) * (a + b + c);
    g.collapsed[f] = i0 == i1 || i1 == i2 || i2 == i0;
  }
  return g;
}

struct Proxies {
  std::vector<Vec3> normal;    // unit N_i, (0,0,0) for a region without area
  std::vector<Vec3> centroid;  // X_i
  std::vector<double> area;
};

Proxies compute_proxies(const FaceGeometry& g, const std::vector<uint32_t>& labels, uint32_t regions) {
  Proxies p;
  p.normal.assign(regions, Vec3{});
  p.centroid.assign(regions, Vec3{});
  p.area.assign(regions, 0.0);
  std::vector<Vec3> plain(regions);  // unweighted centroid sums, for regions without area
  std::vector<uint32_t> count(regions, 0);
  for (size_t f = 0; f < labels.size(); ++f) {
    uint32_t r = labels[f];
    double a = g.area[f];
    p.normal[r] = p.normal[r] + a * g.normal[f];
    p.centroid[r] = p.centroid[r] + a * g.centroid[f];
    p.area[r] += a;
    plain[r] = plain[r] + g.centroid[f];
    ++count[r];
  }
  for (uint32_t r = 0; r < regions; ++r) {
    double len = length(p.normal[r]);
    p.normal[r] = len > 0 ? (1.0 / len) * p.normal[r] : Vec3{};
    if (p.area[r] > 0)
      p.centroid[r] = (1.0 / p.area[r]) * p.centroid[r];
    else if (count[r] > 0)
      p.centroid[r] = (1.0 / count[r]) * plain[r];
  }
  return p;
}

double partition_distortion(const FaceGeometry& g, const std::vector<uint32_t>& labels, const Proxies& p) {
  double e = 0;
  for (size_t f = 0; f < labels.size(); ++f) {
    Vec3 d = g.normal[f] - p.normal[labels[f]];
    e += g.area[f] * dot(d, d);
  }
  return e;
}

void check_labels(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t regions) {
  if (labels.size() != mesh.face_count())
    throw OptionError(std::to_string(labels.size()) + " region labels for " + std::to_string(mesh.face_count()) +
                      " faces");
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] >= regions)
      throw OptionError("face " + std::to_string(f) + " has region " + std::to_string(labels[f]) + " of " +
                        std::to_string(regions));
}

void check_meshing_options(const MeshingOptions& o) {
  if (!(o.chord_error >= 0) || !std::isfinite(o.chord_error))
    throw OptionError("chord error must be a finite number >= 0 (got " + std::to_string(o.chord_error) + ")");
}

// ---- 1. every region a topological disk

// Regrows every region as a shelling (see the file comment) and gives the faces left over new
// region ids. Returns the new region count; appends split_region fixes.
// changed (optional, one flag per region): only the flagged regions are regrown. A region that
// came out of this function and whose faces did not change since regrows into all of its faces
// (the same seed, and the same pops in the same order: the faces it left over before were never
// accepted, so they never changed a stamp), so skipping it changes nothing; the meshing passes
// after a split pass only the split regions (3.5 of bunny00's 22 ms per pass).
// pool (optional): the regions are first regrown side by side (a region's growth reads only its own
// faces' labels and stamps unique to it: it does not depend on the others), and only those that
// leave faces over go through the split below, in region order, as they did without it.
uint32_t make_disk_regions(const Mesh& mesh, const Topology& topology, const FaceGeometry& g,
                           std::vector<uint32_t>& labels, uint32_t regions, std::vector<MeshingFix>& fixes,
                           const std::vector<uint8_t>* changed = nullptr, WorkerPool* pool = nullptr) {
  const uint32_t nf = uint32_t(labels.size());
  std::vector<uint32_t> vertex_stamp(mesh.vertex_count(), 0), face_stamp(nf, 0);
  uint32_t stamp = 0;
  std::vector<uint32_t> queue;

  // Lowest face of every region (collapsed faces take part in nothing).
  std::vector<uint32_t> first_face(regions, kNone);
  for (uint32_t f = nf; f-- > 0;)
    if (!g.collapsed[f]) first_face[labels[f]] = f;

  // Grows `region` from `seed` with the stamp `mark` (unique to this growth) in the given stamp
  // arrays; returns the faces accepted.
  auto grow_with = [&](uint32_t region, uint32_t seed, uint32_t mark, uint32_t* vertex_mark, std::vector<uint32_t>& queue) {
    uint32_t accepted = 0;
    queue.assign(1, seed);
    for (size_t head = 0; head < queue.size(); ++head) {
      uint32_t f = queue[head];
      if (face_stamp[f] == mark) continue;
      const uint32_t* adj = &topology.face_adjacent[3 * size_t(f)];
      int shared = 0, shared_edge = 0;
      // (Only faces of the region carry its mark: the label test first keeps the growths of
      // different regions off each other's stamps when they run side by side.)
      for (int e = 0; e < 3; ++e)
        if (adj[e] != kNone && labels[adj[e]] == region && face_stamp[adj[e]] == mark) ++shared, shared_edge = e;
      if (f != seed) {
        if (shared == 0 || shared == 3) continue;
        // One shared edge: the opposite corner must be new, or the part would touch itself there.
        if (shared == 1 && vertex_mark[mesh.indices[3 * size_t(f) + (shared_edge + 2) % 3]] == mark) continue;
      }
      face_stamp[f] = mark;
      ++accepted;
      for (int j = 0; j < 3; ++j) vertex_mark[mesh.indices[3 * size_t(f) + j]] = mark;
      for (int e = 0; e < 3; ++e) {
        uint32_t o = adj[e];
        if (o != kNone && labels[o] == region && face_stamp[o] != mark && !g.collapsed[o]) queue.push_back(o);
      }
    }
    return accepted;
  };
  auto grow = [&](uint32_t region, uint32_t seed) {
    grow_with(region, seed, ++stamp, vertex_stamp.data(), queue);
    return stamp;
  };

  // Faces of every region, CSR.
  std::vector<uint32_t> region_faces;
  std::vector<uint32_t> face_offsets(size_t(regions) + 1, 0);
  for (uint32_t f = 0; f < nf; ++f) ++face_offsets[labels[f] + 1];
  for (uint32_t r = 0; r < regions; ++r) face_offsets[r + 1] += face_offsets[r];
  region_faces.resize(nf);
  {
    std::vector<uint32_t> fill(face_offsets.begin(), face_offsets.end() - 1);
    for (uint32_t f = 0; f < nf; ++f) region_faces[fill[labels[f]]++] = f;
  }

  // Side by side: each region grown once from its lowest face (the seed the loop below takes), with
  // stamps 1..regions (the loop's own start above them) and a vertex stamp array per worker. A
  // region that grows into all of its faces is a disk already: the loop below would find the same
  // and leave it as it is.
  std::vector<uint8_t> whole(regions, 0);
  if (pool != nullptr && pool->size() > 1) {
    std::vector<uint32_t> non_collapsed(regions, 0);
    for (uint32_t f = 0; f < nf; ++f) non_collapsed[labels[f]] += !g.collapsed[f];
    std::vector<std::vector<uint32_t>> worker_marks(pool->size());
    pool->run(regions, [&](size_t begin, size_t end, unsigned w) {
      std::vector<uint32_t>& marks = worker_marks[w];
      marks.assign(mesh.vertex_count(), 0);
      std::vector<uint32_t> own_queue;
      for (size_t r = begin; r < end; ++r) {
        if (first_face[r] == kNone || (changed && !(*changed)[r])) continue;
        const uint32_t r32 = uint32_t(r);
        whole[r] = grow_with(r32, first_face[r], r32 + 1, marks.data(), own_queue) == non_collapsed[r];
      }
    }, /*min_parallel=*/2);
    stamp = regions;
  }

  uint32_t count = regions;
  std::vector<uint32_t> members, component_queue;
  for (uint32_t r = 0; r < regions; ++r) {
    if (first_face[r] == kNone || (changed && !(*changed)[r]) || whole[r]) continue;
    // Work list of (region id, its faces): the region itself, then the pieces split off it.
    members.assign(region_faces.begin() + face_offsets[r], region_faces.begin() + face_offsets[r + 1]);
    std::vector<std::pair<uint32_t, std::vector<uint32_t>>> work;
    work.emplace_back(r, std::move(members));
    for (size_t w = 0; w < work.size(); ++w) {
      uint32_t id = work[w].first;
      std::vector<uint32_t> faces = std::move(work[w].second);
      uint32_t seed = kNone;
      for (uint32_t f : faces)
        if (!g.collapsed[f]) { seed = f; break; }
      if (seed == kNone) continue;
      uint32_t grown = grow(id, seed);
      // Left over: connected pieces (through faces of this region id) become new regions.
      uint32_t pieces = 0;
      for (uint32_t f : faces) {
        if (face_stamp[f] == grown || g.collapsed[f] || labels[f] != id) continue;
        uint32_t fresh = count++;
        ++pieces;
        std::vector<uint32_t> piece;
        component_queue.assign(1, f);
        labels[f] = fresh;
        for (size_t head = 0; head < component_queue.size(); ++head) {
          uint32_t x = component_queue[head];
          piece.push_back(x);
          for (int e = 0; e < 3; ++e) {
            uint32_t o = topology.face_adjacent[3 * size_t(x) + e];
            if (o != kNone && labels[o] == id && face_stamp[o] != grown && !g.collapsed[o]) {
              labels[o] = fresh;
              component_queue.push_back(o);
            }
          }
        }
        std::sort(piece.begin(), piece.end());
        work.emplace_back(fresh, std::move(piece));
      }
      if (pieces > 0) fixes.push_back({MeshingFix::split_region, id, kNone, kNone, pieces});
    }
  }
  return count;
}

// ---- 2-5. the mesher

struct Chord {
  uint32_t loop = 0;
  uint32_t begin = 0;  // step of the loop at its first anchor
  uint32_t steps = 0;  // edges; the last vertex is the anchor at step begin + steps (mod loop size)
};

// The mesh's edges as seen from each vertex, over the faces that are not collapsed: the graph of
// the coloring's shortest paths. Built once per partition and shared by its meshing passes; the
// coloring used to walk each vertex's faces, meeting each edge twice. (Storing the edge lengths
// too saved square roots but cost more to build than it saved: bunny00 -> 100 meshing 81 vs 79 ms.)
// The order of a vertex's neighbours does not matter: the heap pops in a strict total order.
struct EdgeGraph {
  // Vertex v's neighbours are neighbors[offsets[v], ends[v]) (room for two per face around v).
  std::vector<uint32_t> offsets, ends, neighbors;
};

EdgeGraph edge_graph(const Mesh& mesh, const Topology& topology, const FaceGeometry& geom, WorkerPool& pool) {
  const uint32_t nv = uint32_t(mesh.vertex_count()), nf = uint32_t(mesh.face_count());
  EdgeGraph g;
  g.offsets.resize(nv + 1);
  for (uint32_t v = 0; v <= nv; ++v) g.offsets[v] = 2 * topology.vertex_face_offsets[v];
  g.ends.assign(g.offsets.begin(), g.offsets.end() - 1);
  g.neighbors.resize(g.offsets[nv]);
  // The faces in order, each giving its corners to one another: the index array is read once, in
  // memory order (looking up the faces around each vertex read it in the order of vertex_faces,
  // a cache miss per face on bunny00). A vertex gets each neighbour once per face they share.
  uint32_t* const out = g.neighbors.data();
  uint32_t* const fill = g.ends.data();
  for (uint32_t f = 0; f < nf; ++f) {
    if (geom.collapsed[f]) continue;
    const uint32_t a = mesh.indices[3 * size_t(f)], b = mesh.indices[3 * size_t(f) + 1], c = mesh.indices[3 * size_t(f) + 2];
    out[fill[a]++] = b, out[fill[a]++] = c;
    out[fill[b]++] = c, out[fill[b]++] = a;
    out[fill[c]++] = a, out[fill[c]++] = b;
  }
  // Then each vertex's list without repeats, in order of first appearance (the order does not
  // matter: the coloring's result does not depend on the order in which a vertex's neighbours are
  // relaxed). Each vertex writes its own slots: any split of the vertices over the workers gives
  // the same arrays.
  pool.run(nv, [&](size_t first, size_t last, unsigned) {
    for (size_t v = first; v < last; ++v) {
      uint32_t* list = out + g.offsets[v];
      const uint32_t size = fill[v] - g.offsets[v];
      uint32_t kept = 0;
      for (uint32_t i = 0; i < size; ++i)
        if (std::find(list, list + kept, list[i]) == list + kept) list[kept++] = list[i];
      fill[v] = g.offsets[v] + kept;
    }
  });
  return g;
}

// Heap entries of the coloring, ordered by (distance, color, vertex): a strict total order (an entry
// is pushed only when strictly better than the vertex's label, so never twice), so any heap pops
// them in the same order. Distances are >= 0, whose bits order as the doubles do: two integer
// comparisons.
struct HeapEntry {
  uint64_t distance_bits;
  uint64_t color_vertex;
};

// The colorings of a meshing pass's first round, per region, with what they were computed from.
// A pass that splits curved regions is followed by another over the whole partition, in which most
// regions have the same faces and the same border seeds as before: their coloring (a function of
// exactly those) is copied rather than computed again (on bunny00 -> 100 the first round's
// coloring is ~4 of the second pass's ~15 ms).
struct FirstColorings {
  struct Region {
    bool kept = false;
    std::vector<uint32_t> faces, interior, border, candidates;  // input ids; border: the loop's vertices
    std::vector<uint32_t> border_color, interior_color;
    std::vector<double> border_distance, interior_distance;
  };
  std::vector<Region> regions;
};

class Mesher {
 public:
  Mesher(const Mesh& mesh, const Topology& topology, const FaceGeometry& geom, const EdgeGraph& edges,
         const std::vector<uint32_t>& labels, uint32_t regions, const Proxies& proxies, const MeshingOptions& options,
         WorkerPool& pool, ShapeApproximation& out, bool from_scratch, const FirstColorings* previous = nullptr,
         FirstColorings* current = nullptr, bool may_split = false)
      : mesh_(mesh), topology_(topology), geom_(geom), graph_(edges), labels_(labels), regions_(regions), proxies_(proxies),
        options_(options), pool_(pool), out_(out), nv_(uint32_t(mesh.vertex_count())),
        nf_(uint32_t(mesh.face_count())), from_scratch_(from_scratch), previous_(previous), current_(current),
        may_split_(may_split) {}

  void run();
  // False when the meshing stopped at finding curved regions (may_split; see triangulate()): then
  // the output is not a mesh of the partition, and the caller splits those regions.
  bool complete() const { return complete_; }

 private:
  enum AnchorKind : uint8_t { kNoAnchor = 0, kCorner, kChordAnchor, kFixAnchor };

  bool is_border(uint32_t half_edge) const {
    uint32_t o = topology_.face_adjacent[half_edge];
    return o == kNone || labels_[o] != labels_[half_edge / 3];
  }
  uint32_t across(uint32_t half_edge) const {
    uint32_t o = topology_.face_adjacent[half_edge];
    return o == kNone ? kNone : labels_[o];
  }
  Vec3 position(uint32_t v) const { return mesh_vertex(mesh_, v); }

  void find_open_vertices();
  void extract_loops();
  bool walk_loop(uint32_t start, std::vector<uint8_t>& visited);
  void mark_corner_anchors();

  uint32_t loop_size(uint32_t l) const { return loop_offsets_[l + 1] - loop_offsets_[l]; }
  uint32_t chord_vertex(const Chord& c, uint32_t i) const {
    return loop_vertex_[loop_offsets_[c.loop] + (c.begin + i) % loop_size(c.loop)];
  }
  uint32_t chord_region(const Chord& c) const { return loop_region_[c.loop]; }
  uint32_t chord_neighbor(const Chord& c) const { return loop_neighbor_[loop_offsets_[c.loop] + c.begin]; }
  // The side that decides for a chord: both sides must see the same anchors and colors.
  bool owns(uint32_t region, uint32_t neighbor) const {
    return region_ok_[region] && (neighbor == kNone || !region_ok_[neighbor] || region < neighbor);
  }
  void loop_chords(uint32_t l, std::vector<Chord>& chords) const;
  // Vertex of the chord's interior farthest from the segment of its ends (i in (lo, hi)), and its
  // distance; kNone when there is no interior vertex.
  uint32_t farthest(const Chord& c, uint32_t lo, uint32_t hi, double& distance) const;
  double chord_deviation(const Chord& c, uint32_t& split_at) const;  // d / |ab|, inf when closed
  uint32_t subdivide(const Chord& c);
  bool settle_anchors();
  void add_anchor(uint32_t v, AnchorKind kind);

  bool triangulate(bool last_round);
  void index_regions();
  void recolor();
  void color_region(uint32_t r, std::vector<HeapEntry>& heap, bool from_changed_seeds);
  bool copy_previous_coloring(uint32_t r);
  void keep_first_coloring(uint32_t r);
  void seed_changed(uint32_t v) {
    if (!seed_changed_[v]) seed_changed_[v] = 1, changed_seeds_.push_back(v);
  }
  std::vector<uint32_t> crossing_splits(uint32_t region, const std::vector<uint32_t>& polygon);
  uint32_t deviation_split(uint32_t region) const;
  bool valid_coloring(uint32_t region, const std::vector<uint32_t>& polygon, const std::vector<uint32_t>& tris);
  bool coloring_shape(uint32_t region, const std::vector<uint32_t>& polygon, const std::vector<uint32_t>& tris,
                      std::vector<uint32_t>& diagonals) const;
  uint32_t triangulate_polygon(uint32_t region, const std::vector<uint32_t>& polygon, std::vector<uint32_t>& tris) const;
  void polygon_tables(const std::vector<uint32_t>& polygon, std::vector<Vec3>& corners,
                      std::vector<uint8_t>& allowed) const;
  bool fix_without_triangulation(uint32_t region, const std::vector<uint32_t>& polygon) const;
  bool surely_imperfect(uint32_t region, const std::vector<uint32_t>& polygon) const;
  std::optional<bool> perfect_triangulation(uint32_t region, const std::vector<uint32_t>& polygon) const;
  bool curved_without_deferred(const std::vector<uint32_t>& deferred, std::vector<MeshingFix>& round_fixes);
  bool diagonal_free(uint32_t a, uint32_t b) const { return !edges_.contains(edge_key(a, b)); }
  // edges_ = the polygons' edges (the chords) only, as a try of a round starts.
  void chords_only() {
    edges_.clear();
    for (uint32_t r = 0; r < regions_; ++r) {
      const uint32_t first = polygon_offsets_[r], count = polygon_offsets_[r + 1] - first;
      for (uint32_t i = 0; i < count; ++i)
        edges_.insert(edge_key(polygon_vertices_[first + i], polygon_vertices_[first + (i + 1) % count]));
    }
  }
  void finish();

  const Mesh& mesh_;
  const Topology& topology_;
  const FaceGeometry& geom_;
  const EdgeGraph& graph_;
  const std::vector<uint32_t>& labels_;
  const uint32_t regions_;
  const Proxies& proxies_;
  const MeshingOptions& options_;
  WorkerPool& pool_;
  ShapeApproximation& out_;
  const uint32_t nv_, nf_;
  // detail::mesh_partition_from_scratch: no decrease-only recoloring, no kept crossing tests.
  const bool from_scratch_;
  const FirstColorings* previous_;  // the last pass's first colorings, or null
  FirstColorings* current_;         // where this pass keeps its own, or null
  // The caller splits the curved regions this pass finds (their flipped_triangles fixes) and
  // meshes again: the pass may stop once it knows they are there (triangulate()).
  const bool may_split_;
  bool complete_ = true;
  double mean_edge_ = 0;

  std::vector<uint8_t> open_;       // per vertex: on a boundary or non-manifold edge
  std::vector<uint8_t> region_ok_;  // per region: one traceable border loop
  // Border loops, CSR: step i of loop l goes from loop_vertex_[i] to the next step's vertex, with
  // region loop_neighbor_[i] (kNone: boundary) across.
  std::vector<uint32_t> loop_offsets_{0}, loop_vertex_, loop_neighbor_, loop_region_;
  std::vector<uint32_t> region_loop_;  // loop of each region, kNone when it has none or several
  std::vector<uint8_t> anchor_;        // AnchorKind per vertex
  std::vector<uint32_t> anchor_list_;  // the vertices with an anchor (sorted by triangulate)
  std::vector<uint8_t> at_vertex_;     // per vertex: anchor placed at the vertex (anchor_position fix)
  std::vector<uint32_t> flip_anchors_; // per region: flip_anchor fixes so far
  std::vector<uint8_t> reverted_;      // per region: anchor_position fix applied
  std::vector<uint8_t> fell_back_;     // per region: its coloring failed once; triangulated directly since

  // Coloring, redone only for regions whose border changed (`dirty_`: an anchor was added on it).
  std::vector<uint8_t> dirty_;
  // Anchors are only ever added, so a border vertex's (distance, color) only ever decreases (a
  // chord split gives it a nearer end; but for a tie where vertices share a position, which
  // recolor() meets by coloring that round's regions from scratch): a region colored before is
  // colored again from the border vertices whose key decreased since, keeping the rest of its
  // coloring. The multi-source Dijkstra's result is the least fixed point of its relaxation in the
  // (distance, color) order, which that decrease-only update reaches as well as a coloring from
  // scratch: the same colors.
  std::vector<uint8_t> colored_;        // per region: colored from scratch once
  std::vector<uint8_t> seed_changed_;   // per vertex: its key decreased since the last recolor()
  std::vector<uint32_t> changed_seeds_;  // those vertices
  std::vector<uint8_t> unsettled_;  // per region: got an anchor since settle_anchors last looked at it
  std::vector<uint32_t> region_face_offsets_, region_faces_;          // non-collapsed faces, CSR
  std::vector<uint32_t> region_interior_offsets_, region_interior_;   // vertices on no border, CSR
  std::vector<uint8_t> on_border_;                                    // per vertex: on some loop
  std::vector<std::vector<uint32_t>> candidates_;  // per region: the coloring's triangles (input vertex ids)
  // Per region: the last direct triangulation and what it was made from, reused while they match.
  // Kept in input vertex ids: every round numbers the output vertices again, and an anchor added
  // anywhere with a lower input id renumbers all those after it, so output ids would not match
  // from one round to the next although the polygon is the same.
  struct CachedTriangulation {
    std::vector<uint32_t> polygon, tris;  // input vertex ids
    std::vector<Vec3> positions;
    uint32_t cost = 0;
  };
  // Per region: the last crossing_splits() and the polygon it was made from. The result depends
  // only on the polygon's positions and its chords, and a region that falls back tests its
  // crossings in every round while another region takes anchors.
  struct CachedCrossings {
    std::vector<uint32_t> polygon, splits;  // input vertex ids
    std::vector<Vec3> positions;
  };
  std::vector<CachedCrossings> crossings_cache_;
  // The polygon (output ids) and its positions are `ids` (input ids) and `positions`.
  bool same_polygon(const std::vector<uint32_t>& ids, const std::vector<Vec3>& positions,
                    const std::vector<uint32_t>& polygon) const;
  void keep_polygon(const std::vector<uint32_t>& polygon, std::vector<uint32_t>& ids, std::vector<Vec3>& positions) const;
  std::vector<CachedTriangulation> cache_;
  // Per region: what coloring_shape found of its coloring, and the polygon it was checked against.
  // Only the diagonals' use by other regions changes from one round to the next while the region
  // is not colored again (`checked` false) and its polygon and positions stay the same; most
  // regions are settled after a few rounds while a few take anchors for twenty more.
  struct CheckedColoring {
    bool checked = false;
    bool shape_ok = false;
    std::vector<uint32_t> polygon, diagonals;  // input vertex ids; diagonals as pairs of polygon places
    std::vector<Vec3> positions;
  };
  std::vector<CheckedColoring> checked_;
  // Per vertex: its anchor position, computed once per pass (it depends on the regions around the
  // vertex and their proxies, fixed for the pass, and on at_vertex_): position_state_ 0 none,
  // 1 + at_vertex_ when known.
  std::vector<uint8_t> position_state_;
  std::vector<Vec3> known_position_;

  // Output of a meshing round.
  std::vector<uint32_t> out_id_;                // per vertex: output vertex of an anchor, else kNone
  std::vector<uint32_t> anchors_;               // output vertex -> input vertex
  std::vector<Vec3> anchor_position_;
  std::vector<uint32_t> polygon_offsets_, polygon_vertices_;  // output vertex ids
  EdgeSet edges_;                               // chord edges and accepted diagonals
  std::vector<uint32_t> polygon_index_;         // per output vertex: its index in the polygon at hand, else kNone
  // Per vertex, side by side (the coloring's inner loop reads all three for each neighbour): the
  // input vertex of its anchor (kNone: none yet), the path length to it, and its region when on
  // no border (else kNone).
  struct VertexColor {
    double distance;
    uint32_t color;
    uint32_t interior_region;
  };
  std::vector<VertexColor> vc_;

  std::vector<uint32_t> triangles_, triangle_regions_;
};

void Mesher::find_open_vertices() {
  open_.assign(nv_, 0);
  // The mean edge length is ChordRule::cgal's unit alone: a square root per half-edge otherwise spent
  // for nothing.
  const bool measure = options_.chord_rule == ChordRule::cgal;
  double total = 0;
  uint64_t edges = 0;
  for (uint32_t f = 0; f < nf_; ++f) {
    if (geom_.collapsed[f]) continue;
    for (int e = 0; e < 3; ++e) {
      uint32_t a = mesh_.indices[3 * size_t(f) + e], b = mesh_.indices[3 * size_t(f) + (e + 1) % 3];
      if (measure) total += length(position(a) - position(b));
      ++edges;
      if (topology_.face_adjacent[3 * size_t(f) + e] == kNone) open_[a] = open_[b] = 1;
    }
  }
  mean_edge_ = edges ? total / double(edges) : 0.0;
}

// Walks the border loop that starts with half-edge `start` (a border half-edge of a non-collapsed
// face), appending its steps. Returns false (and appends nothing) when the walk does not close,
// which only a non-manifold configuration can cause.
bool Mesher::walk_loop(uint32_t start, std::vector<uint8_t>& visited) {
  const size_t first = loop_vertex_.size();
  uint32_t face = start / 3, edge = start % 3;
  // Each step goes along `edge` of `face` from `from` to `to`; the first one in the face's order.
  uint32_t from = mesh_.indices[start], to = mesh_.indices[3 * size_t(face) + (edge + 1) % 3];
  for (uint64_t guard = 3 * uint64_t(nf_) + 3; guard > 0; --guard) {
    const uint32_t h = 3 * face + edge;
    visited[h] = 1;
    loop_vertex_.push_back(from);
    loop_neighbor_.push_back(across(h));
    // Rotate around `to` through faces of the region (across non-border edges) to the next border
    // edge. A disk region's faces around `to` form one fan, so this is its other end.
    uint32_t g = face, came = edge;
    const uint32_t valence = topology_.vertex_face_offsets[to + 1] - topology_.vertex_face_offsets[to];
    bool found = false;
    for (uint32_t turn = 0; turn <= valence && !found; ++turn) {
      int corner = -1;
      for (int j = 0; j < 3; ++j)
        if (mesh_.indices[3 * size_t(g) + j] == to) corner = j;
      if (corner < 0) break;
      // The two edges of g at `to`: `corner` (to -> next corner) and corner + 2 (previous -> to).
      const uint32_t e1 = uint32_t(corner), e2 = uint32_t(corner + 2) % 3;
      const uint32_t other = came == e1 ? e2 : e1;
      if (is_border(3 * g + other)) {
        face = g, edge = other, found = true;
        break;
      }
      const uint32_t x = mesh_.indices[3 * size_t(g) + (other == e1 ? (corner + 1) % 3 : (corner + 2) % 3)];
      const uint32_t next = topology_.face_adjacent[3 * size_t(g) + other];
      int arrive = -1;
      for (int j = 0; j < 3; ++j) {
        uint32_t p = mesh_.indices[3 * size_t(next) + j], q = mesh_.indices[3 * size_t(next) + (j + 1) % 3];
        if ((p == to && q == x) || (p == x && q == to)) arrive = j;
      }
      if (arrive < 0) break;
      g = next, came = uint32_t(arrive);
    }
    if (!found) break;
    if (3 * face + edge == start) return true;
    if (visited[3 * face + edge]) break;  // ran into another loop: not a manifold border
    const uint32_t p = mesh_.indices[3 * size_t(face) + edge], q = mesh_.indices[3 * size_t(face) + (edge + 1) % 3];
    if (p != to && q != to) break;
    from = to;
    to = p == to ? q : p;
  }
  loop_vertex_.resize(first);
  loop_neighbor_.resize(first);
  return false;
}

void Mesher::extract_loops() {
  std::vector<uint8_t> visited(3 * size_t(nf_), 0);
  std::vector<uint32_t> loops_of_region(regions_, 0);
  std::vector<uint8_t> broken(regions_, 0), has_faces(regions_, 0);
  region_loop_.assign(regions_, kNone);
  for (uint32_t f = 0; f < nf_; ++f) {
    uint32_t r = labels_[f];
    has_faces[r] = 1;
    if (geom_.collapsed[f]) continue;
    for (uint32_t e = 0; e < 3; ++e) {
      uint32_t h = 3 * f + e;
      if (visited[h] || !is_border(h)) continue;
      if (!walk_loop(h, visited)) {
        broken[r] = 1;
        continue;
      }
      uint32_t l = uint32_t(loop_region_.size());
      loop_region_.push_back(r);
      loop_offsets_.push_back(uint32_t(loop_vertex_.size()));
      if (loops_of_region[r]++ == 0) region_loop_[r] = l;
    }
  }
  region_ok_.assign(regions_, 0);
  for (uint32_t r = 0; r < regions_; ++r) {
    region_ok_[r] = has_faces[r] && !broken[r] && loops_of_region[r] == 1 && loop_size(region_loop_[r]) >= 3;
    if (!region_ok_[r]) {
      region_loop_[r] = kNone;
      if (has_faces[r]) out_.fixes.push_back({MeshingFix::skipped_region, r, kNone, kNone, 0});
    }
  }
}

void Mesher::mark_corner_anchors() {
  anchor_.assign(nv_, kNoAnchor);
  for (uint32_t v = 0; v < nv_; ++v) {
    uint32_t seen[3] = {kNone, kNone, kNone}, distinct = 0;
    for (uint32_t i = topology_.vertex_face_offsets[v]; i < topology_.vertex_face_offsets[v + 1] && distinct < 3; ++i) {
      uint32_t f = topology_.vertex_faces[i];
      if (geom_.collapsed[f]) continue;
      uint32_t r = labels_[f];
      if (r != seen[0] && r != seen[1] && r != seen[2]) seen[distinct++] = r;
    }
    if (distinct >= 3 || (distinct == 2 && open_[v])) anchor_[v] = kCorner;
  }
  // Where the region across changes along a loop (only non-manifold borders add anything here).
  for (uint32_t l = 0; l + 1 < loop_offsets_.size(); ++l) {
    uint32_t off = loop_offsets_[l], m = loop_size(l);
    for (uint32_t i = 0; i < m; ++i)
      if (loop_neighbor_[off + (i + m - 1) % m] != loop_neighbor_[off + i] && !anchor_[loop_vertex_[off + i]])
        anchor_[loop_vertex_[off + i]] = kCorner;
  }
  anchor_list_.clear();
  for (uint32_t v = 0; v < nv_; ++v)
    if (anchor_[v]) anchor_list_.push_back(v);
  out_.stats.corner_anchors = uint32_t(anchor_list_.size());
}

void Mesher::add_anchor(uint32_t v, AnchorKind kind) {
  assert(anchor_[v] == kNoAnchor);
  anchor_[v] = kind;
  anchor_list_.push_back(v);
  vc_[v].color = v;
  vc_[v].distance = 0;
  seed_changed(v);
  // The chords through v changed: every region around v needs its anchors settled and its coloring
  // done again.
  for (uint32_t i = topology_.vertex_face_offsets[v]; i < topology_.vertex_face_offsets[v + 1]; ++i)
    dirty_[labels_[topology_.vertex_faces[i]]] = unsettled_[labels_[topology_.vertex_faces[i]]] = 1;
  if (kind == kChordAnchor)
    ++out_.stats.chord_anchors;
  else
    ++out_.stats.fix_anchors;
}

void Mesher::loop_chords(uint32_t l, std::vector<Chord>& chords) const {
  chords.clear();
  uint32_t off = loop_offsets_[l], m = loop_size(l);
  uint32_t first = kNone, previous = kNone;
  for (uint32_t i = 0; i < m; ++i) {
    if (!anchor_[loop_vertex_[off + i]]) continue;
    if (first == kNone) first = i;
    if (previous != kNone) chords.push_back({l, previous, i - previous});
    previous = i;
  }
  if (first != kNone) chords.push_back({l, previous, (first + m - previous) % m == 0 ? m : (first + m - previous) % m});
}

uint32_t Mesher::farthest(const Chord& c, uint32_t lo, uint32_t hi, double& distance) const {
  Vec3 a = position(chord_vertex(c, lo)), b = position(chord_vertex(c, hi));
  uint32_t best = kNone;
  distance = -1;
  for (uint32_t i = lo + 1; i < hi; ++i) {
    double d = segment_distance(position(chord_vertex(c, i)), a, b);
    if (d > distance) distance = d, best = i;
  }
  return best;
}

double Mesher::chord_deviation(const Chord& c, uint32_t& split_at) const {
  double d;
  split_at = farthest(c, 0, c.steps, d);
  if (split_at == kNone) return -1;
  uint32_t a = chord_vertex(c, 0), b = chord_vertex(c, c.steps);
  double ab = length(position(a) - position(b));
  if (a == b || !(ab > 0)) return std::numeric_limits<double>::infinity();
  return d / ab;
}

// Chord subdivision by the chord rule (a closed chord is always split once first). Returns the
// number of anchors added.
uint32_t Mesher::subdivide(const Chord& c) {
  uint32_t region = chord_region(c), neighbor = chord_neighbor(c);
  double sine = 1;
  if (neighbor != kNone) {
    Vec3 ni = proxies_.normal[region], nj = proxies_.normal[neighbor];
    if (dot(ni, ni) > 0 && dot(nj, nj) > 0) sine = length(cross(ni, nj));
  }
  uint32_t added = 0;
  std::vector<std::pair<uint32_t, uint32_t>> stack{{0, c.steps}};
  while (!stack.empty()) {
    auto [lo, hi] = stack.back();
    stack.pop_back();
    if (hi - lo < 2) continue;
    uint32_t a = chord_vertex(c, lo), b = chord_vertex(c, hi);
    double d;
    uint32_t split = farthest(c, lo, hi, d);
    if (a == b) {
      // A closed chord (a loop with one anchor): its two halves are separate chords.
      add_anchor(chord_vertex(c, split), kFixAnchor);
      out_.fixes.push_back({MeshingFix::loop_anchors, region, neighbor, chord_vertex(c, split), 1});
    } else {
      double criterion;
      if (options_.chord_rule == ChordRule::cgal) {
        criterion = mean_edge_ > 0 ? d / mean_edge_ : 0;
      } else {
        double ab = length(position(a) - position(b));
        criterion = d > 0 ? (ab > 0 ? d * sine / ab : std::numeric_limits<double>::infinity()) : 0;
      }
      if (!(criterion > options_.chord_error)) continue;
      add_anchor(chord_vertex(c, split), kChordAnchor);
    }
    ++added;
    stack.push_back({lo, split});
    stack.push_back({split, hi});
  }
  return added;
}

// Anchor fixes and chord subdivision until nothing changes. Returns true when anchors were added.
bool Mesher::settle_anchors() {
  bool any = false;
  std::vector<Chord> chords;
  struct Keyed {
    uint64_t key;
    Chord chord;
  };
  std::vector<Keyed> keyed;
  std::vector<uint8_t> todo;
  const uint32_t loops = uint32_t(loop_region_.size());
  for (uint32_t pass = 0; pass < kMaxAnchorPasses; ++pass) {
    // Only regions that got an anchor since they were last looked at can need more.
    todo.swap(unsettled_);
    unsettled_.assign(regions_, 0);
    bool changed = false;
    // Loops without anchor: three, evenly spaced by arc length.
    for (uint32_t l = 0; l < loops; ++l) {
      uint32_t off = loop_offsets_[l], m = loop_size(l), r = loop_region_[l];
      if (!todo[r] || !owns(r, loop_neighbor_[off])) continue;
      bool anchored = false;
      for (uint32_t i = 0; i < m && !anchored; ++i) anchored = anchor_[loop_vertex_[off + i]] != kNoAnchor;
      if (anchored) continue;
      std::vector<double> arc(m + 1, 0.0);
      for (uint32_t i = 0; i < m; ++i)
        arc[i + 1] = arc[i] + length(position(loop_vertex_[off + (i + 1) % m]) - position(loop_vertex_[off + i]));
      uint32_t picks[3] = {0, 0, 0};
      for (int k = 1; k < 3; ++k) {
        double target = arc[m] * k / 3.0;
        uint32_t i = uint32_t(std::lower_bound(arc.begin(), arc.end(), target) - arc.begin());
        if (i > 0 && target - arc[i - 1] <= arc[std::min(i, m)] - target) --i;
        picks[k] = std::clamp(i, picks[k - 1] + 1, m - 3 + uint32_t(k));
      }
      for (uint32_t i : picks) add_anchor(loop_vertex_[off + i], kFixAnchor);
      out_.fixes.push_back({MeshingFix::loop_anchors, r, loop_neighbor_[off], kNone, 3});
      changed = true;
    }
    // Chord subdivision (and closed chords).
    for (uint32_t l = 0; l < loops; ++l) {
      if (!todo[loop_region_[l]]) continue;
      loop_chords(l, chords);
      for (const Chord& c : chords)
        if (owns(chord_region(c), chord_neighbor(c)) && subdivide(c) > 0) changed = true;
    }
    // Chords joining the same two anchors: keep the straightest, split the others. Any chord can
    // pair with a new one, so all are listed (by their ends only; deviations for pairs alone).
    keyed.clear();
    for (uint32_t l = 0; l < loops; ++l) {
      loop_chords(l, chords);
      for (const Chord& c : chords) {
        if (!owns(chord_region(c), chord_neighbor(c))) continue;
        uint32_t a = chord_vertex(c, 0), b = chord_vertex(c, c.steps);
        if (a != b) keyed.push_back({edge_key(a, b), c});
      }
    }
    std::sort(keyed.begin(), keyed.end(), [](const Keyed& x, const Keyed& y) {
      if (x.key != y.key) return x.key < y.key;
      if (x.chord.loop != y.chord.loop) return x.chord.loop < y.chord.loop;
      return x.chord.begin < y.chord.begin;
    });
    for (size_t i = 0; i < keyed.size();) {
      size_t j = i + 1;
      while (j < keyed.size() && keyed[j].key == keyed[i].key) ++j;
      if (j - i >= 2) {
        // Keep the straightest (ties: the first listed); split the others at their farthest vertex.
        std::vector<std::pair<double, size_t>> group;
        std::vector<uint32_t> split(j - i);
        for (size_t k = i; k < j; ++k) group.push_back({chord_deviation(keyed[k].chord, split[k - i]), k});
        std::stable_sort(group.begin(), group.end(), [](auto& x, auto& y) { return x.first < y.first; });
        for (size_t g = 1; g < group.size(); ++g) {
          const Chord& c = keyed[group[g].second].chord;
          uint32_t at = split[group[g].second - i];
          if (at == kNone || anchor_[chord_vertex(c, at)]) continue;
          uint32_t v = chord_vertex(c, at);
          add_anchor(v, kFixAnchor);
          out_.fixes.push_back({MeshingFix::duplicate_chord, chord_region(c), chord_neighbor(c), v, 1});
          changed = true;
        }
      }
      i = j;
    }
    // Regions with fewer than three anchors: one more on the most curved chord.
    for (uint32_t r = 0; r < regions_; ++r) {
      if (!region_ok_[r] || !todo[r]) continue;
      loop_chords(region_loop_[r], chords);
      if (chords.size() >= 3) continue;
      double best = -1;
      uint32_t best_vertex = kNone;
      for (const Chord& c : chords) {
        uint32_t split;
        double dev = chord_deviation(c, split);
        if (split != kNone && dev > best) best = dev, best_vertex = chord_vertex(c, split);
      }
      if (best_vertex == kNone) continue;  // cannot happen: a loop has >= 3 vertices
      add_anchor(best_vertex, kFixAnchor);
      out_.fixes.push_back({MeshingFix::polygon_anchor, r, kNone, best_vertex, 1});
      changed = true;
    }
    if (!changed) break;
    any = true;
  }
  return any;
}

// Per-region lists the coloring works on: faces, and vertices on no border (interior vertices).
void Mesher::index_regions() {
  on_border_.assign(nv_, 0);
  for (uint32_t v : loop_vertex_) on_border_[v] = 1;
  region_face_offsets_.assign(size_t(regions_) + 1, 0);
  region_interior_offsets_.assign(size_t(regions_) + 1, 0);
  std::vector<uint32_t> vertex_region(nv_, kNone);
  for (uint32_t f = 0; f < nf_; ++f) {
    if (geom_.collapsed[f]) continue;
    ++region_face_offsets_[labels_[f] + 1];
    for (int j = 0; j < 3; ++j) vertex_region[mesh_.indices[3 * size_t(f) + j]] = labels_[f];
  }
  for (uint32_t v = 0; v < nv_; ++v)
    if (!on_border_[v] && vertex_region[v] != kNone) ++region_interior_offsets_[vertex_region[v] + 1];
  for (uint32_t r = 0; r < regions_; ++r) {
    region_face_offsets_[r + 1] += region_face_offsets_[r];
    region_interior_offsets_[r + 1] += region_interior_offsets_[r];
  }
  region_faces_.resize(region_face_offsets_.back());
  region_interior_.resize(region_interior_offsets_.back());
  std::vector<uint32_t> fill(region_face_offsets_.begin(), region_face_offsets_.end() - 1);
  for (uint32_t f = 0; f < nf_; ++f)
    if (!geom_.collapsed[f]) region_faces_[fill[labels_[f]]++] = f;
  fill.assign(region_interior_offsets_.begin(), region_interior_offsets_.end() - 1);
  for (uint32_t v = 0; v < nv_; ++v)
    if (!on_border_[v] && vertex_region[v] != kNone) region_interior_[fill[vertex_region[v]]++] = v;
  for (VertexColor& x : vc_) x.interior_region = kNone;
  for (uint32_t v = 0; v < nv_; ++v)
    if (!on_border_[v]) vc_[v].interior_region = vertex_region[v];
  candidates_.assign(regions_, {});
  checked_.assign(regions_, {});
  if (current_) current_->regions.assign(regions_, {});
  cache_.assign(regions_, {});
  crossings_cache_.assign(regions_, {});
}

// The paper's coloring, for the dirty regions. Border vertices: the anchor closest along their chord
// (ties: the lower vertex id), decided by the chord's owner. Interior vertices: multi-source Dijkstra
// from the region's border, seeded with the border vertices' distances to their anchor; a region's
// interior vertices only neighbour its own interior and border, so regions are independent.
void Mesher::recolor() {
  std::vector<Chord> chords;
  std::vector<double> from_a, from_b;
  // A border vertex whose (distance, color) rose: every region of this round is colored from
  // scratch (see below).
  bool key_rose = false;
  for (uint32_t r = 0; r < regions_; ++r) {
    if (!dirty_[r] || !region_ok_[r]) continue;
    loop_chords(region_loop_[r], chords);
    for (const Chord& c : chords) {
      if (!owns(chord_region(c), chord_neighbor(c))) continue;
      // Arc lengths summed outward from each end, so a vertex's distance to an end does not
      // depend on where the chord's other end is: splitting a chord never makes a key larger.
      from_a.assign(c.steps + 1, 0.0);
      from_b.assign(c.steps + 1, 0.0);
      for (uint32_t i = 0; i < c.steps; ++i)
        from_a[i + 1] = from_a[i] + length(position(chord_vertex(c, i + 1)) - position(chord_vertex(c, i)));
      for (uint32_t i = c.steps; i-- > 0;)
        from_b[i] = from_b[i + 1] + length(position(chord_vertex(c, i + 1)) - position(chord_vertex(c, i)));
      uint32_t a = chord_vertex(c, 0), b = chord_vertex(c, c.steps);
      for (uint32_t i = 1; i < c.steps; ++i) {
        double da = from_a[i], db = from_b[i];
        bool to_a = da < db || (da == db && a < b);
        uint32_t v = chord_vertex(c, i);
        const uint32_t color = to_a ? a : b;
        const double distance = to_a ? da : db;
        if (color == vc_[v].color && distance == vc_[v].distance) continue;
        // Only ever smaller, a chord being only ever split (see colored_), but for a tie: where the
        // arc from v to the new end has no length (vertices at one position, a damaged input), the
        // new end is as near as the old one and may have the higher id. The decrease-only update
        // would then keep colors from the old key.
        key_rose |= !(distance < vc_[v].distance || (distance == vc_[v].distance && color < vc_[v].color));
        vc_[v].color = color;
        vc_[v].distance = distance;
        seed_changed(v);
      }
    }
  }
  // The regions to color, cut into one range per worker with about equal work (interior vertices):
  // a region's interior vertices neighbour only its own interior and border, and the border colors
  // are set above, so regions are colored independently, in any order, by any thread.
  std::vector<uint32_t> todo;
  uint64_t work = 0;
  for (uint32_t r = 0; r < regions_; ++r) {
    if (!dirty_[r]) continue;
    dirty_[r] = 0;
    candidates_[r].clear();
    checked_[r].checked = false;
    if (!region_ok_[r] || fell_back_[r]) continue;  // triangulated directly from now on
    todo.push_back(r);
    work += region_interior_offsets_[r + 1] - region_interior_offsets_[r] + 1;
  }
  const unsigned parts = work >= kMinParallelColoring ? pool_.size() : 1;
  std::vector<size_t> bounds(parts + 1, todo.size());
  bounds[0] = 0;
  {
    // Part p ends after the region that brings it to p / parts of the work.
    uint64_t done = 0;
    size_t p = 1;
    for (size_t i = 0; i < todo.size() && p < parts; ++i) {
      const uint32_t r = todo[i];
      done += region_interior_offsets_[r + 1] - region_interior_offsets_[r] + 1;
      while (p < parts && done * parts >= work * p) bounds[p++] = i + 1;
    }
  }
  std::atomic<uint32_t> copied{0};
  pool_.run(parts, [&](size_t begin, size_t end, unsigned) {
    std::vector<HeapEntry> heap;
    for (size_t p = begin; p < end; ++p)
      for (size_t i = bounds[p]; i < bounds[p + 1]; ++i) {
        const uint32_t r = todo[i];
        if (colored_[r]) {
          color_region(r, heap, !from_scratch_ && !key_rose);
          continue;
        }
        if (copy_previous_coloring(r)) copied.fetch_add(1, std::memory_order_relaxed);
        else color_region(r, heap, false);
        keep_first_coloring(r);
        colored_[r] = 1;
      }
  }, /*min_parallel=*/2);
  out_.stats.copied_colorings += copied.load();
  for (uint32_t v : changed_seeds_) seed_changed_[v] = 0;
  changed_seeds_.clear();
}

// Region r's coloring from the previous pass when it was made from the same faces, interior and
// border seeds (colors and distances along its loop, set by recolor() before the regions are
// colored); false when anything differs. Writes only r's interior vertices and candidates.
bool Mesher::copy_previous_coloring(uint32_t r) {
  if (from_scratch_ || previous_ == nullptr || r >= previous_->regions.size()) return false;
  const FirstColorings::Region& p = previous_->regions[r];
  const uint32_t l = region_loop_[r];
  if (!p.kept || !std::equal(p.faces.begin(), p.faces.end(), region_faces_.begin() + region_face_offsets_[r],
                             region_faces_.begin() + region_face_offsets_[r + 1]) ||
      !std::equal(p.interior.begin(), p.interior.end(), region_interior_.begin() + region_interior_offsets_[r],
                  region_interior_.begin() + region_interior_offsets_[r + 1]) ||
      !std::equal(p.border.begin(), p.border.end(), loop_vertex_.begin() + loop_offsets_[l],
                  loop_vertex_.begin() + loop_offsets_[l + 1]))
    return false;
  for (size_t i = 0; i < p.border.size(); ++i) {
    const VertexColor& c = vc_[p.border[i]];
    if (c.color != p.border_color[i] || c.distance != p.border_distance[i]) return false;
  }
  for (size_t i = 0; i < p.interior.size(); ++i) {
    vc_[p.interior[i]].color = p.interior_color[i];
    vc_[p.interior[i]].distance = p.interior_distance[i];
  }
  candidates_[r] = p.candidates;
  return true;
}

// Keeps region r's first coloring of this pass for the next one (see FirstColorings).
void Mesher::keep_first_coloring(uint32_t r) {
  if (current_ == nullptr) return;
  FirstColorings::Region& k = current_->regions[r];
  const uint32_t l = region_loop_[r];
  k.kept = true;
  k.faces.assign(region_faces_.begin() + region_face_offsets_[r], region_faces_.begin() + region_face_offsets_[r + 1]);
  k.interior.assign(region_interior_.begin() + region_interior_offsets_[r],
                    region_interior_.begin() + region_interior_offsets_[r + 1]);
  k.border.assign(loop_vertex_.begin() + loop_offsets_[l], loop_vertex_.begin() + loop_offsets_[l + 1]);
  k.candidates = candidates_[r];
  k.border_color.resize(k.border.size());
  k.border_distance.resize(k.border.size());
  for (size_t i = 0; i < k.border.size(); ++i) {
    k.border_color[i] = vc_[k.border[i]].color;
    k.border_distance[i] = vc_[k.border[i]].distance;
  }
  k.interior_color.resize(k.interior.size());
  k.interior_distance.resize(k.interior.size());
  for (size_t i = 0; i < k.interior.size(); ++i) {
    k.interior_color[i] = vc_[k.interior[i]].color;
    k.interior_distance[i] = vc_[k.interior[i]].distance;
  }
}

// Multi-source Dijkstra over region r's interior from its border (colors and distances set), then
// the region's three-colored faces as candidate triangles.
void Mesher::color_region(uint32_t r, std::vector<HeapEntry>& heap, bool from_changed_seeds) {
  auto later = [](const HeapEntry& a, const HeapEntry& b) {
    return a.distance_bits != b.distance_bits ? a.distance_bits > b.distance_bits : a.color_vertex > b.color_vertex;
  };
  auto push = [&](double d, uint32_t color, uint32_t v) {
    assert(d >= 0);
    heap.push_back({std::bit_cast<uint64_t>(d), uint64_t(color) << 32 | v});
    std::push_heap(heap.begin(), heap.end(), later);
  };
  const uint32_t l = region_loop_[r];
  if (!from_changed_seeds)
    for (uint32_t i = region_interior_offsets_[r]; i < region_interior_offsets_[r + 1]; ++i) {
      uint32_t v = region_interior_[i];
      vc_[v].color = kNone;
      vc_[v].distance = std::numeric_limits<double>::infinity();
    }
  heap.clear();
  for (uint32_t i = loop_offsets_[l]; i < loop_offsets_[l + 1]; ++i) {
    uint32_t v = loop_vertex_[i];
    if (vc_[v].color != kNone && (!from_changed_seeds || seed_changed_[v])) push(vc_[v].distance, vc_[v].color, v);
  }
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end(), later);
    const HeapEntry e = heap.back();
    heap.pop_back();
    const double top_d = std::bit_cast<double>(e.distance_bits);
    const uint32_t top_color = uint32_t(e.color_vertex >> 32), top_v = uint32_t(e.color_vertex);
    if (top_d != vc_[top_v].distance || top_color != vc_[top_v].color) continue;  // stale
    // The edges from top_v into this region's interior. A neighbour already closer than top_v
    // cannot improve (d >= top_d).
    for (uint32_t i = graph_.offsets[top_v]; i < graph_.ends[top_v]; ++i) {
      const uint32_t u = graph_.neighbors[i];
      if (vc_[u].interior_region != r || vc_[u].distance < top_d) continue;
      const double d = top_d + length(position(u) - position(top_v));
      if (d < vc_[u].distance || (d == vc_[u].distance && top_color < vc_[u].color)) {
        vc_[u].distance = d;
        vc_[u].color = top_color;
        push(d, top_color, u);
      }
    }
  }
  for (uint32_t i = region_face_offsets_[r]; i < region_face_offsets_[r + 1]; ++i) {
    uint32_t f = region_faces_[i], c[3];
    for (int j = 0; j < 3; ++j) c[j] = vc_[mesh_.indices[3 * size_t(f) + j]].color;
    if (c[0] != kNone && c[1] != kNone && c[2] != kNone && c[0] != c[1] && c[1] != c[2] && c[0] != c[2])
      candidates_[r].insert(candidates_[r].end(), {c[0], c[1], c[2]});
  }
}

// Polygon edges of `region` that cross another one in the proxy plane (their chords cut across the
// region): for each crossing pair, the farthest vertex of the chord that deviates more from its
// segment, where to split it. Empty when the projected polygon is simple.
std::vector<uint32_t> Mesher::crossing_splits(uint32_t region, const std::vector<uint32_t>& polygon) {
  std::vector<uint32_t> splits;
  const Vec3 n = proxies_.normal[region];
  if (dot(n, n) == 0) return splits;
  Vec3 u = std::abs(n.x) < 0.6 ? cross(n, Vec3{1, 0, 0}) : cross(n, Vec3{0, 1, 0});
  u = (1.0 / length(u)) * u;
  const Vec3 w = cross(n, u);
  const size_t m = polygon.size();
  std::vector<double> x(m), y(m);
  for (size_t i = 0; i < m; ++i) x[i] = dot(anchor_position_[polygon[i]], u), y[i] = dot(anchor_position_[polygon[i]], w);
  auto orient = [&](size_t a, size_t b, size_t c) {
    double o = (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a]);
    return (o > 0) - (o < 0);
  };
  // The chords in polygon order (both start at the loop's first anchor), with their split vertex.
  std::vector<Chord> chords;
  loop_chords(region_loop_[region], chords);
  // Anchors added earlier in this pass (another region's split on a shared border) are not in
  // `polygon` yet: nothing to split from it then; the round is redone with the new anchors.
  if (chords.size() != m) return splits;
  CachedCrossings& cached = crossings_cache_[region];
  if (!from_scratch_ && same_polygon(cached.polygon, cached.positions, polygon)) return cached.splits;
  std::vector<double> deviation(m);
  std::vector<uint32_t> split(m);
  for (size_t i = 0; i < m; ++i) split[i] = farthest(chords[i], 0, chords[i].steps, deviation[i]);
  for (size_t i = 0; i < m; ++i)
    for (size_t j = i + 2; j < m; ++j) {
      if (i == 0 && j == m - 1) continue;  // adjacent through the wrap
      size_t i1 = i + 1, j1 = (j + 1) % m;
      if (orient(i, i1, j) * orient(i, i1, j1) > 0 || orient(j, j1, i) * orient(j, j1, i1) > 0) continue;
      size_t pick = split[j] == kNone || (split[i] != kNone && deviation[i] >= deviation[j]) ? i : j;
      if (split[pick] != kNone) splits.push_back(chord_vertex(chords[pick], split[pick]));
    }
  std::sort(splits.begin(), splits.end());
  splits.erase(std::unique(splits.begin(), splits.end()), splits.end());
  keep_polygon(polygon, cached.polygon, cached.positions);
  cached.splits = splits;
  return splits;
}

// The farthest vertex of the region's chord farthest from its segment (largest d); kNone when no
// chord has an interior vertex.
uint32_t Mesher::deviation_split(uint32_t region) const {
  std::vector<Chord> chords;
  loop_chords(region_loop_[region], chords);
  double best = -1;
  uint32_t best_vertex = kNone;
  for (const Chord& c : chords) {
    double d;
    uint32_t split = farthest(c, 0, c.steps, d);
    if (split != kNone && d > best) best = d, best_vertex = chord_vertex(c, split);
  }
  return best_vertex;
}

// The coloring's triangles of `region` (output vertex ids, 3 per triangle) form a triangulation of
// its polygon that faces along the proxy normal and shares no diagonal with another region.
bool Mesher::valid_coloring(uint32_t region, const std::vector<uint32_t>& polygon, const std::vector<uint32_t>& tris) {
  CheckedColoring& c = checked_[region];
  if (from_scratch_ || !c.checked || !same_polygon(c.polygon, c.positions, polygon)) {
    c.checked = true;
    keep_polygon(polygon, c.polygon, c.positions);
    c.diagonals.clear();
    c.shape_ok = coloring_shape(region, polygon, tris, c.diagonals);
  }
  if (!c.shape_ok) return false;
  for (size_t i = 0; i < c.diagonals.size(); i += 2)
    if (!diagonal_free(polygon[c.diagonals[i]], polygon[c.diagonals[i + 1]])) return false;
  return true;
}

// valid_coloring without the diagonals' use elsewhere: the triangles form a triangulation of the
// polygon that faces along the proxy normal; `diagonals` gets its diagonals (pairs of places u < v).
bool Mesher::coloring_shape(uint32_t region, const std::vector<uint32_t>& polygon, const std::vector<uint32_t>& tris,
                            std::vector<uint32_t>& diagonals) const {
  const size_t m = polygon.size();
  if (tris.size() != 3 * (m - 2)) return false;
  // Place of each output vertex in the polygon: polygon_index_, set for `polygon` by triangulate();
  // kNone for ids of no polygon vertex (or of no anchor yet).
  auto local = [&](uint32_t id) { return id < polygon_index_.size() ? polygon_index_[id] : kNone; };
  std::vector<uint64_t> directed;
  directed.reserve(tris.size());
  for (size_t t = 0; t < tris.size(); t += 3) {
    uint32_t l[3];
    for (int j = 0; j < 3; ++j)
      if ((l[j] = local(tris[t + j])) == kNone) return false;
    if (!faces_along(anchor_position_[tris[t]], anchor_position_[tris[t + 1]], anchor_position_[tris[t + 2]],
                     proxies_.normal[region]))
      return false;
    for (int j = 0; j < 3; ++j) directed.push_back(uint64_t(l[j]) << 32 | l[(j + 1) % 3]);
  }
  std::sort(directed.begin(), directed.end());
  if (std::adjacent_find(directed.begin(), directed.end()) != directed.end()) return false;
  size_t polygon_edges = 0;
  for (uint64_t e : directed) {
    uint32_t u = uint32_t(e >> 32), v = uint32_t(e);
    if (v == (u + 1) % m) {
      ++polygon_edges;
      continue;
    }
    if (u == (v + 1) % m) return false;  // a polygon edge against the border's direction
    if (!std::binary_search(directed.begin(), directed.end(), uint64_t(v) << 32 | u)) return false;
    if (u < v) diagonals.insert(diagonals.end(), {u, v});
  }
  return polygon_edges == m;
}

// Triangulation of `polygon` by interval dynamic programming (polygon_triangulation.cpp): fewest bad
// triangles first (a diagonal used elsewhere costs m, a triangle facing away from the proxy normal
// or a sliver costs 1), then the largest smallest angle. Returns the cost (0: every triangle
// acceptable); triangles (output ids) go to `tris`.
uint32_t Mesher::triangulate_polygon(uint32_t region, const std::vector<uint32_t>& polygon,
                                     std::vector<uint32_t>& tris) const {
  const uint32_t m = uint32_t(polygon.size());
  tris.clear();
  if (m > kMaxDynamicProgramming) {  // a fan: no guarantee, reported by the caller if it fails
    uint32_t cost = 0;
    for (uint32_t i = 1; i + 1 < m; ++i) {
      tris.insert(tris.end(), {polygon[0], polygon[i], polygon[i + 1]});
      cost += !faces_along(anchor_position_[polygon[0]], anchor_position_[polygon[i]],
                           anchor_position_[polygon[i + 1]], proxies_.normal[region]);
    }
    return cost;
  }
  std::vector<Vec3> corners;
  std::vector<uint8_t> allowed;
  polygon_tables(polygon, corners, allowed);
  const uint32_t cost =
      meshcvt::triangulate_polygon(corners, proxies_.normal[region], allowed, kTriangleRules, &pool_, tris);
  for (uint32_t& t : tris) t = polygon[t];
  return cost;
}

// The corners of `polygon` (output ids) and its m x m flags of diagonals other regions left free,
// as polygon_triangulation.h takes them.
void Mesher::polygon_tables(const std::vector<uint32_t>& polygon, std::vector<Vec3>& corners,
                            std::vector<uint8_t>& allowed) const {
  const uint32_t m = uint32_t(polygon.size());
  corners.resize(m);
  for (uint32_t i = 0; i < m; ++i) corners[i] = anchor_position_[polygon[i]];
  allowed.assign(size_t(m) * m, 1);
  for (uint32_t i = 0; i < m; ++i)
    for (uint32_t j = i + 2; j < m; ++j)
      if (!(i == 0 && j == m - 1))
        allowed[size_t(i) * m + j] = allowed[size_t(j) * m + i] = diagonal_free(polygon[i], polygon[j]);
}

// Whether `region`'s polygon, found to have no acceptable triangulation, then takes a fix that
// does not need its triangulation (its anchors to their vertices, or an anchor on its most
// deviating chord), as triangulate() decides it for a round that is not the last.
bool Mesher::fix_without_triangulation(uint32_t region, const std::vector<uint32_t>& polygon) const {
  if (!reverted_[region])
    for (uint32_t id : polygon)
      if (!at_vertex_[anchors_[id]]) return true;
  if (flip_anchors_[region] >= kMaxDeviationAnchors || flip_anchors_[region] >= kMaxFlipAnchors) return false;
  const uint32_t v = deviation_split(region);
  return v != kNone && !anchor_[v];
}

// Whether the polygon surely has no acceptable triangulation (triangulate_polygon's cost > 0),
// found without making one; false also when the test gave up.
bool Mesher::surely_imperfect(uint32_t region, const std::vector<uint32_t>& polygon) const {
  if (polygon.size() < kMinPerfectTest) return false;
  const std::optional<bool> perfect = perfect_triangulation(region, polygon);
  return perfect.has_value() && !*perfect;
}

// Whether the polygon has an acceptable triangulation (triangulate_polygon's cost == 0) with the
// diagonals now in edges_, found without making one; nullopt when the test gave up or the
// polygon is too large for the dynamic programming.
std::optional<bool> Mesher::perfect_triangulation(uint32_t region, const std::vector<uint32_t>& polygon) const {
  const size_t m = polygon.size();
  if (m > kMaxDynamicProgramming) return std::nullopt;
  std::vector<Vec3> corners;
  std::vector<uint8_t> allowed;
  polygon_tables(polygon, corners, allowed);
  return has_perfect_triangulation(corners, proxies_.normal[region], allowed, kTriangleRules,
                                   kPerfectTestBudget * m * m);
}

bool Mesher::same_polygon(const std::vector<uint32_t>& ids, const std::vector<Vec3>& positions,
                          const std::vector<uint32_t>& polygon) const {
  if (ids.size() != polygon.size()) return false;
  for (size_t i = 0; i < polygon.size(); ++i) {
    Vec3 a = positions[i], b = anchor_position_[polygon[i]];
    if (ids[i] != anchors_[polygon[i]] || a.x != b.x || a.y != b.y || a.z != b.z) return false;
  }
  return true;
}

void Mesher::keep_polygon(const std::vector<uint32_t>& polygon, std::vector<uint32_t>& ids,
                          std::vector<Vec3>& positions) const {
  ids.resize(polygon.size());
  positions.resize(polygon.size());
  for (size_t i = 0; i < polygon.size(); ++i) ids[i] = anchors_[polygon[i]], positions[i] = anchor_position_[polygon[i]];
}

// After a try of a round that left out the regions `deferred` (ascending) and asked for no fix:
// whether a region is curved, its flipped triangles found by the try (in round_fixes) or, for the
// regions left out, a polygon with no acceptable triangulation given the diagonals of the regions
// before it (each gets a flipped_triangles fix, count 0: its triangles were not made). The
// diagonals are those of the try's triangles, put into edges_ again region by region. False also
// when a test gave up: then only the whole round can tell.
bool Mesher::curved_without_deferred(const std::vector<uint32_t>& deferred, std::vector<MeshingFix>& round_fixes) {
  bool curved = std::any_of(round_fixes.begin(), round_fixes.end(),
                            [](const MeshingFix& f) { return f.kind == MeshingFix::flipped_triangles; });
  std::vector<MeshingFix> found;
  chords_only();
  std::vector<uint32_t> polygon;
  size_t t = 0, next = 0;  // the next triangle of the try, the next region left out
  for (uint32_t r = 0; r < regions_; ++r) {
    if (next < deferred.size() && deferred[next] == r) {
      ++next;
      polygon.assign(polygon_vertices_.begin() + polygon_offsets_[r], polygon_vertices_.begin() + polygon_offsets_[r + 1]);
      const std::optional<bool> perfect = perfect_triangulation(r, polygon);
      if (!perfect.has_value()) return false;
      if (!*perfect) found.push_back({MeshingFix::flipped_triangles, r, kNone, kNone, 0});
      continue;
    }
    for (; t < triangle_regions_.size() && triangle_regions_[t] == r; ++t)
      for (int j = 0; j < 3; ++j) edges_.insert(edge_key(triangles_[3 * t + j], triangles_[3 * t + (j + 1) % 3]));
  }
  assert(next == deferred.size() && t == triangle_regions_.size());
  if (!curved && found.empty()) return false;
  round_fixes.insert(round_fixes.end(), found.begin(), found.end());
  return true;
}

// One meshing round with the current anchors. Returns false when anchors were added (redo).
bool Mesher::triangulate(bool last_round) {
  // Output vertices (in increasing input vertex order) and their positions. Anchors are only ever
  // added: every round numbers all of them again, the other vertices keep kNone (set by run()).
  std::sort(anchor_list_.begin(), anchor_list_.end());
  anchors_.clear();
  anchor_position_.clear();
  for (uint32_t v : anchor_list_) {
    assert(anchor_[v]);
    out_id_[v] = uint32_t(anchors_.size());
    anchors_.push_back(v);
    if (position_state_[v] == 1 + at_vertex_[v]) {
      anchor_position_.push_back(known_position_[v]);
      continue;
    }
    position_state_[v] = uint8_t(1 + at_vertex_[v]);
    uint32_t seen[64], distinct = 0;
    Vec3 sum{}, p = position(v);
    if (at_vertex_[v]) {
      anchor_position_.push_back(known_position_[v] = rounded(p));
      continue;
    }
    for (uint32_t i = topology_.vertex_face_offsets[v]; i < topology_.vertex_face_offsets[v + 1]; ++i) {
      uint32_t f = topology_.vertex_faces[i];
      if (geom_.collapsed[f]) continue;
      uint32_t r = labels_[f];
      if (std::find(seen, seen + distinct, r) != seen + distinct || distinct == 64) continue;
      seen[distinct++] = r;
      Vec3 nr = proxies_.normal[r];
      sum = sum + (p - dot(p - proxies_.centroid[r], nr) * nr);
    }
    anchor_position_.push_back(known_position_[v] = rounded(distinct ? (1.0 / distinct) * sum : p));
  }
  polygon_index_.assign(anchors_.size(), kNone);
  // Polygons (their edges go into edges_ at the start of each try below).
  polygon_offsets_.assign(1, 0);
  polygon_vertices_.clear();
  for (uint32_t r = 0; r < regions_; ++r) {
    if (region_ok_[r]) {
      uint32_t l = region_loop_[r], off = loop_offsets_[l], m = loop_size(l);
      for (uint32_t i = 0; i < m; ++i)
        if (anchor_[loop_vertex_[off + i]]) polygon_vertices_.push_back(out_id_[loop_vertex_[off + i]]);
    }
    polygon_offsets_.push_back(uint32_t(polygon_vertices_.size()));
  }

  recolor();

  std::vector<MeshingFix> round_fixes;
  std::vector<uint32_t> polygon, tris, deferred_regions;
  std::vector<Chord> chords;
  // A region out of fixes (its anchors back at their vertices, its deviation anchors spent) takes
  // none whatever its triangulation, and a round that is redone drops every triangle it made. So
  // the round first goes without the direct triangulations of such regions (when their polygon
  // changed since the last): they only forbid their diagonals to the regions after them, which
  // the round that is kept sees. If it ends with no fix to make, it is done again with them, and
  // that is the round kept (or, if a region then needs a fix after all, redone as any other). On
  // scans with holes 80% of the dynamic programming's steps were such regions' large polygons,
  // made again in every round while their neighbours took anchors.
  for (int attempt = 0;; ++attempt) {
    const bool defer = attempt == 0 && !last_round;
    // Each try starts from the polygons' edges (the chords); each region it accepts adds its diagonals.
    chords_only();
    out_.stats.chords = uint32_t(edges_.size());
    triangles_.clear();
    triangle_regions_.clear();
    out_.stats.coloring_regions = out_.stats.fallback_regions = 0;
    out_.stats.flipped_triangles = 0;
    round_fixes.clear();
    bool redo = false;
    deferred_regions.clear();
    for (uint32_t r = 0; r < regions_; ++r) {
      if (!region_ok_[r]) continue;
      polygon.assign(polygon_vertices_.begin() + polygon_offsets_[r],
                     polygon_vertices_.begin() + polygon_offsets_[r + 1]);
      const size_t m = polygon.size();
      if (m < 3) continue;  // cannot happen: settle_anchors gives every polygon three anchors
      // polygon_index_ gives each vertex of this polygon its place in it while the region is looked at.
      struct PolygonIndex {
        std::vector<uint32_t>& index;
        const std::vector<uint32_t>& polygon;
        PolygonIndex(std::vector<uint32_t>& i, const std::vector<uint32_t>& p) : index(i), polygon(p) {
          for (uint32_t k = 0; k < p.size(); ++k)
            if (index[p[k]] == kNone) index[p[k]] = k;  // the first, should an anchor come twice
        }
        ~PolygonIndex() {
          for (uint32_t id : polygon) index[id] = kNone;
        }
      } indexed(polygon_index_, polygon);
      auto is_diagonal = [&](uint32_t a, uint32_t b) {
        size_t ia = polygon_index_[a], ib = polygon_index_[b];
        assert(ia != kNone && ib != kNone);
        return (ia + 1) % m != ib && (ib + 1) % m != ia;
      };
      tris.resize(candidates_[r].size());
      for (size_t i = 0; i < tris.size(); ++i) tris[i] = out_id_[candidates_[r][i]];
      if (!fell_back_[r] && valid_coloring(r, polygon, tris)) {
        ++out_.stats.coloring_regions;
      } else {
        fell_back_[r] = 1;
        // Chords crossing in the proxy plane leave no unflipped triangulation: split them first.
        std::vector<uint32_t> splits;
        if (!last_round && flip_anchors_[r] < kMaxFlipAnchors) splits = crossing_splits(r, polygon);
        // Else the direct triangulation of the last round, if the polygon did not change and it still
        // holds; else a new one.
        CachedTriangulation& cached = cache_[r];
        uint32_t cost = 1;
        bool untriangulated = false;  // tested only: `tris` holds no triangulation of the polygon
        if (splits.empty()) {
          bool reused = same_polygon(cached.polygon, cached.positions, polygon);
          if (reused) {
            // Same polygon, same positions: only diagonals used elsewhere can have changed.
            tris.resize(cached.tris.size());
            for (size_t i = 0; i < tris.size(); ++i) tris[i] = out_id_[cached.tris[i]];
            uint32_t recount = 0;
            for (size_t t = 0; t < tris.size(); t += 3) {
              const uint32_t* tri = &tris[t];
              recount += !faces_along(anchor_position_[tri[0]], anchor_position_[tri[1]], anchor_position_[tri[2]],
                                      proxies_.normal[r]);
              for (int j = 0; j < 3; ++j)
                if (is_diagonal(tri[j], tri[(j + 1) % 3]) && !diagonal_free(tri[j], tri[(j + 1) % 3]))
                  recount += uint32_t(m);
            }
            reused = recount <= cached.cost;
            cost = recount;
            out_.stats.reused_triangulations += reused;
          }
          if (!reused && defer && reverted_[r] && flip_anchors_[r] >= kMaxDeviationAnchors) {
            deferred_regions.push_back(r);
            continue;
          }
          if (reused) {
          } else if (!last_round && fix_without_triangulation(r, polygon) && surely_imperfect(r, polygon)) {
            // It takes a fix below, and the round is redone: no triangulation is needed (in the first
            // rounds of a scan with holes, most of the dynamic programming's steps went to such
            // polygons). The polygon changes with the fix, so nothing is cached.
            cost = 1;
            untriangulated = true;
            ++out_.stats.tested_polygons;
          } else {
            cost = triangulate_polygon(r, polygon, tris);
            keep_polygon(polygon, cached.polygon, cached.positions);
            cached.tris.resize(tris.size());
            for (size_t i = 0; i < tris.size(); ++i) cached.tris[i] = anchors_[tris[i]];
            cached.cost = cost;
          }
        }
        if (cost > 0 && !last_round) {
          // No acceptable triangulation: the region's anchors go back to their mesh vertices (the
          // averaged projections can fold a thin region); else its most deviating chord is split.
          if (splits.empty() && !reverted_[r]) {
            reverted_[r] = 1;
            uint32_t moved = 0;
            for (uint32_t id : polygon)
              if (!at_vertex_[anchors_[id]]) at_vertex_[anchors_[id]] = 1, ++moved;
            if (moved > 0) {
              out_.stats.vertex_anchors += moved;
              out_.fixes.push_back({MeshingFix::anchor_position, r, kNone, kNone, moved});
              redo = true;
              continue;
            }
          }
          if (splits.empty() && flip_anchors_[r] < kMaxDeviationAnchors) {
            uint32_t v = deviation_split(r);
            if (v != kNone) splits.push_back(v);
          }
          bool added = false;
          for (uint32_t v : splits) {
            if (anchor_[v] || flip_anchors_[r] >= kMaxFlipAnchors) continue;
            ++flip_anchors_[r];
            add_anchor(v, kFixAnchor);
            out_.fixes.push_back({MeshingFix::flip_anchor, r, kNone, v, 1});
            added = true;
          }
          if (added) {
            redo = true;
            continue;
          }
        }
        // Out of anchors: take the best. (A tested region always took its fix above, as
        // fix_without_triangulation foresaw; were the two ever to disagree, it is triangulated here.)
        assert(!untriangulated);
        if (!splits.empty() || untriangulated) cost = triangulate_polygon(r, polygon, tris);
        ++out_.stats.fallback_regions;
        round_fixes.push_back({MeshingFix::fallback_triangulation, r, kNone, kNone, 0});
        if (cost > 0) {  // kept as it is: count what is wrong with it
          uint32_t bad = 0;
          for (size_t t = 0; t < tris.size(); t += 3) {
            bool ok = faces_along(anchor_position_[tris[t]], anchor_position_[tris[t + 1]],
                                  anchor_position_[tris[t + 2]], proxies_.normal[r]);
            for (int j = 0; j < 3 && ok; ++j) {
              uint32_t a = tris[t + j], b = tris[t + (j + 1) % 3];
              if (is_diagonal(a, b) && !diagonal_free(a, b)) ok = false;
            }
            bad += !ok;
          }
          out_.stats.flipped_triangles += bad;
          round_fixes.push_back({MeshingFix::flipped_triangles, r, kNone, kNone, bad});
        }
      }
      // Accepted: its diagonals may not be used by any other region.
      for (size_t t = 0; t < tris.size(); t += 3) {
        for (int j = 0; j < 3; ++j) {
          uint32_t a = tris[t + j], b = tris[t + (j + 1) % 3];
          if (is_diagonal(a, b)) edges_.insert(edge_key(a, b));
        }
        triangles_.insert(triangles_.end(), {tris[t], tris[t + 1], tris[t + 2]});
        triangle_regions_.push_back(r);
      }
    }
    out_.stats.deferred_triangulations += uint32_t(deferred_regions.size());
    if (redo) return false;
    if (deferred_regions.empty()) break;
    // A pass followed by a split of its curved regions (may_split_) needs only to know which they
    // are: its meshes are dropped, and the regions split and meshed again in the next pass. So the
    // regions left out are tested, each where the try left it out, for an acceptable
    // triangulation. If one has none, or another region came out with flipped triangles, the pass
    // stops here. (Left out, the regions forbade no diagonals to the ones after them, so a try may
    // find fewer curved regions than the whole round would; a pass that finds none is done in full
    // and checked, and the next pass splits what that finds. On scans with holes the full rounds of
    // the passes followed by a split were nearly all of the dynamic programming's steps.)
    if (may_split_ && curved_without_deferred(deferred_regions, round_fixes)) {
      complete_ = false;
      break;
    }
  }
  out_.fixes.insert(out_.fixes.end(), round_fixes.begin(), round_fixes.end());
  return true;
}

// Copies the round's result into the output and checks the output's edges.
void Mesher::finish() {
  Mesh& m = out_.mesh;
  m.positions.resize(3 * anchors_.size());
  for (size_t i = 0; i < anchors_.size(); ++i) {
    m.positions[3 * i] = float(anchor_position_[i].x);
    m.positions[3 * i + 1] = float(anchor_position_[i].y);
    m.positions[3 * i + 2] = float(anchor_position_[i].z);
  }
  m.indices = std::move(triangles_);
  m.source_polygon.clear();
  out_.triangle_regions = std::move(triangle_regions_);
  out_.anchor_vertices = std::move(anchors_);
  out_.polygon_offsets = std::move(polygon_offsets_);
  out_.polygon_vertices = std::move(polygon_vertices_);

  std::vector<uint64_t> directed;
  directed.reserve(m.indices.size());
  for (size_t t = 0; t < m.indices.size(); t += 3)
    for (int j = 0; j < 3; ++j) directed.push_back(uint64_t(m.indices[t + j]) << 32 | m.indices[t + (j + 1) % 3]);
  std::vector<uint64_t> undirected(directed.size());
  for (size_t i = 0; i < directed.size(); ++i) undirected[i] = edge_key(uint32_t(directed[i] >> 32), uint32_t(directed[i]));
  std::sort(undirected.begin(), undirected.end());
  std::sort(directed.begin(), directed.end());
  for (size_t i = 0; i < undirected.size();) {
    size_t j = i;
    while (j < undirected.size() && undirected[j] == undirected[i]) ++j;
    if (j - i == 1) ++out_.stats.boundary_edges;
    if (j - i >= 3) ++out_.stats.nonmanifold_edges;
    i = j;
  }
  for (size_t i = 0; i + 1 < directed.size(); ++i)
    if (directed[i] == directed[i + 1]) ++out_.stats.inconsistent_edges;
}

void Mesher::run() {
  find_open_vertices();
  extract_loops();
  mark_corner_anchors();
  at_vertex_.assign(nv_, 0);
  position_state_.assign(nv_, 0);
  known_position_.resize(nv_);
  flip_anchors_.assign(regions_, 0);
  reverted_.assign(regions_, 0);
  fell_back_.assign(regions_, 0);
  dirty_.assign(regions_, 1);
  colored_.assign(regions_, 0);
  seed_changed_.assign(nv_, 0);
  changed_seeds_.clear();
  unsettled_.assign(regions_, 1);
  vc_.assign(nv_, VertexColor{std::numeric_limits<double>::infinity(), kNone, kNone});
  index_regions();
  out_id_.assign(nv_, kNone);
  for (uint32_t v = 0; v < nv_; ++v)
    if (anchor_[v]) vc_[v].color = v, vc_[v].distance = 0;
  settle_anchors();
  for (uint32_t round = 0;; ++round) {
    out_.stats.meshing_rounds = round + 1;
    if (triangulate(round + 1 >= kMaxMeshingRounds)) break;
    settle_anchors();
  }
  finish();
}

// ---- partition

void validate(const Mesh& mesh, const ApproximateOptions& o) {
  bool fixed = o.proxies > 0, driven = o.max_error >= 0;
  if (std::isnan(o.max_error)) throw OptionError("max error must be a number >= 0");
  if (fixed == driven)
    throw OptionError(fixed ? "give either a number of proxies or a maximum error, not both"
                            : "give a number of proxies (> 0) or a maximum error (>= 0)");
  if (driven && !std::isfinite(o.max_error)) throw OptionError("max error must be finite");
  check_meshing_options(o.meshing);
  if (mesh.face_count() == 0) throw OptionError("the mesh has no face");
}

ClusterOptions cluster_options(const ApproximateOptions& o, uint32_t clusters) {
  ClusterOptions c;
  c.clusters = clusters;
  c.metric = Metric::l21;
  c.init = Init::hierarchical;
  c.topology = TopologyMode::preserving;
  c.max_iterations = o.max_iterations;
  c.threads = o.threads;
  c.device = o.device;
  c.progress = o.progress;
  return c;
}


// Iterate + repair rounds from the iteration's current labels, as cluster() does. Returns the next
// free round number.
uint32_t converge(BoundaryIteration& it, const ClusterProblem& problem, const Topology& topology,
                  const ApproximateOptions& o, uint32_t round, Clustering& out, WorkerPool& pool,
                  RepairCheck& check) {
  for (uint32_t repairs = 0;; ++repairs, ++round) {
    out.converged = run_iterations(it, o.max_iterations, o.progress, round, out);
    std::vector<uint32_t> current = it.labels();
    std::vector<float> generators = it.generators();
    // (repair_connectivity first checks, in two passes, whether anything needs repairing: the usual
    // case after a topology-preserving run. On one thread that check was a quarter of a teleport
    // that changed nothing, hence the pool.)
    bool repaired = repair_connectivity(problem, topology, generators, current, problem.clusters, out.repair, &pool,
                                        &check);
    uint32_t restored = restore_cluster_count(problem, topology, generators, current, problem.clusters);
    out.repair.restored_clusters += restored;
    if (!repaired && restored == 0) return round + 1;
    it.relabel(current);  // the repaired faces as moves: the same decisions as a reset, less testing
    out.history.push_back(IterationRecord{it.energy(), 0, 0, round + 1});
    if (repairs + 1 >= kMaxRepairRounds) {
      out.converged = false;
      return round + 2;
    }
    ++out.repair.rounds;
  }
}

// Continues a clustering on the CPU engine: adds proxies by splitting the regions of highest
// distortion, and teleports proxies (VSA): the adjacent pair whose merge costs least is merged and
// the region of highest distortion split in two, then the boundary iteration runs again; the
// result is kept only when the distortion dropped. Teleports repair what a greedy initialization
// can leave behind (two proxies on one plane, one proxy across a sharp edge).
class PartitionRefiner {
 public:
  PartitionRefiner(const Mesh& mesh, const Topology& topology, const ApproximateOptions& o, Clustering& out)
      : topology_(topology), o_(o), out_(out), problem_(make_problem(mesh, o, out)), pool_(o.threads),
        it_(problem_, mesh, topology, TopologyMode::preserving, true, pool_) {
    it_.reset(out.labels);
    for (const IterationRecord& r : out.history) round_ = std::max(round_, r.round + 1);
  }

  uint32_t clusters() const { return problem_.clusters; }
  const std::vector<uint32_t>& labels() const { return it_.labels(); }

  // Splits the `add` regions of highest distortion (fewer when not enough have two faces), then
  // iterates to convergence.
  void add_proxies(uint32_t add) {
    std::vector<uint32_t> labels = it_.labels();
    uint32_t grown = problem_.clusters + add;
    problem_.clusters = grown;
    // The engine's generators are those of its sums; the new clusters are empty (generator 0, as
    // compute_generator leaves an empty cluster's).
    std::vector<float> generators = it_.generators();
    generators.resize(3 * size_t(grown), 0.0f);
    restore_cluster_count(problem_, topology_, generators, labels, grown);
    restart(std::move(labels), /*same_count=*/false);
  }

  // Up to `attempts` teleports, stopping at the first that does not lower the distortion or when no
  // merge is cheap enough (less than half the worst region's distortion, as in VSA). Returns the
  // number kept.
  uint32_t teleport(uint32_t attempts) {
    uint32_t kept = 0, low_gains = 0;
    const uint32_t n = problem_.clusters;
    for (uint32_t attempt = 0; attempt < attempts && n >= 3; ++attempt) {
      const std::vector<int64_t>& sums = it_.sums();
      auto S = [&](uint32_t c) {
        const int64_t* s = &sums[size_t(c) * kSumComponents];
        return Vec3{double(s[1]), double(s[2]), double(s[3])};
      };
      uint32_t worst = 0;
      double worst_energy = -1;
      for (uint32_t c = 0; c < n; ++c) {
        double e = cluster_energy(problem_, &sums[size_t(c) * kSumComponents], &it_.generators()[3 * size_t(c)]);
        if (e > worst_energy) worst_energy = e, worst = c;
      }
      // Merge cost of adjacent clusters i, j with their optimal normals: 2 (|S_i| + |S_j| - |S_i + S_j|).
      // |S_c| once per cluster rather than twice per border edge (the same values).
      std::vector<double> norm(n);
      for (uint32_t c = 0; c < n; ++c) norm[c] = length(S(c));
      const std::vector<uint32_t>& labels = it_.labels();
      double best = std::numeric_limits<double>::infinity();
      uint32_t keep = kNone, drop = kNone;
      for (uint32_t f = 0; f < labels.size(); ++f)
        for (int e = 0; e < 3; ++e) {
          uint32_t o = topology_.face_adjacent[3 * size_t(f) + e];
          if (o == kNone || o < f) continue;
          uint32_t i = labels[f], j = labels[o];
          if (i == j || i == worst || j == worst) continue;
          double cost = 2 * (norm[i] + norm[j] - length(S(i) + S(j))) / problem_.fixed_scale;
          if (cost < best || (cost == best && std::min(i, j) < std::min(keep, drop)))
            best = cost, keep = std::min(i, j), drop = std::max(i, j);
        }
      if (keep == kNone || !(best < 0.5 * worst_energy)) break;
      const double before = it_.energy();
      std::vector<uint32_t> saved = it_.labels();
      const size_t history = out_.history.size();
      const uint32_t iterations = out_.iterations, round = round_;
      const bool converged = out_.converged;
      std::vector<uint32_t> merged = saved;
      for (uint32_t& l : merged)
        if (l == drop) l = keep;
      std::vector<float> generators = generators_after_merge(keep, drop);
      restore_cluster_count(problem_, topology_, generators, merged, n);  // splits the worst, into `drop`
      restart(std::move(merged));
      if (it_.energy() < before * (1 - 1e-9)) {
        ++kept;
        // Kept; but two small gains in a row say the partition has settled.
        low_gains = it_.energy() > before * (1 - kTeleportMinGain) ? low_gains + 1 : 0;
        if (low_gains >= 2) break;
        continue;
      }
      // Not better: back to where it was. The moves back (relabel) give the same labels, sums and
      // generators as a reset, for a pass over the labels instead of rebuilding the engine's state;
      // nothing iterates from here before the next reset (add_proxies) or the end.
      it_.relabel(saved);
      out_.history.resize(history);
      out_.iterations = iterations;
      out_.converged = converged;
      round_ = round;
      break;
    }
    return kept;
  }

  void finish() {
    out_.labels = it_.labels();
    out_.generators = it_.generators();
  }

 private:
  static ClusterProblem make_problem(const Mesh& mesh, const ApproximateOptions& o, const Clustering& out) {
    ClusterOptions co = cluster_options(o, uint32_t(out.generators.size() / 3));
    co.device.clear();
    return make_cluster_problem(mesh, co);
  }
  // The generators once `drop` is merged into `keep`, from the engine's sums (exact integers, the
  // same as summing the merged labels again): keep's from the two sums, drop's 0 (empty).
  std::vector<float> generators_after_merge(uint32_t keep, uint32_t drop) const {
    std::vector<float> g = it_.generators();
    int64_t merged[kSumComponents];
    for (int k = 0; k < kSumComponents; ++k)
      merged[k] = it_.sums()[size_t(keep) * kSumComponents + k] + it_.sums()[size_t(drop) * kSumComponents + k];
    compute_generator(problem_, merged, &g[3 * size_t(keep)]);
    std::fill(&g[3 * size_t(drop)], &g[3 * size_t(drop)] + 3, 0.0f);
    return g;
  }
  // Iterates again from `labels`. With the cluster count unchanged (teleports) the engine goes on
  // from its converged state, the changed faces taken as moves (BoundaryIteration::relabel: the
  // same decisions as a reset, testing only what the change can affect); a new count needs a reset.
  void restart(std::vector<uint32_t> labels, bool same_count = true) {
    if (same_count) it_.relabel(labels);
    else it_.reset(std::move(labels));
    out_.history.push_back(IterationRecord{it_.energy(), 0, 0, round_});
    round_ = converge(it_, problem_, topology_, o_, round_, out_, pool_, repair_check_);
  }

  const Topology& topology_;
  const ApproximateOptions& o_;
  Clustering& out_;
  ClusterProblem problem_;
  WorkerPool pool_;
  BoundaryIteration it_;
  RepairCheck repair_check_;  // the last repair check, so the next looks only at what changed since
  uint32_t round_ = 0;
};

double relative_distortion(const FaceGeometry& geom, const std::vector<uint32_t>& labels, uint32_t n) {
  Proxies p = compute_proxies(geom, labels, n);
  double area = std::accumulate(p.area.begin(), p.area.end(), 0.0);
  return area > 0 ? partition_distortion(geom, labels, p) / area : 0.0;
}

// The partition: cluster() with the fixed count, or error-driven rounds (see the file comment),
// with teleports after each.
Clustering make_partition(const Mesh& mesh, const Topology& topology, const FaceGeometry& geom,
                          const ApproximateOptions& o, std::vector<RefinementRound>& rounds, double& refine_seconds) {
  const uint32_t nf = uint32_t(mesh.face_count());
  const bool driven = o.proxies == 0;
  uint32_t n = driven ? std::max(topology.component_count, std::min(nf, 4u)) : o.proxies;
  Clustering out = cluster(mesh, topology, cluster_options(o, n));
  if (!o.teleport && !driven) return out;
  auto t = Clock::now();
  PartitionRefiner refiner(mesh, topology, o, out);
  for (;;) {
    if (o.teleport) refiner.teleport(kMaxTeleports);
    if (!driven) break;
    double relative = relative_distortion(geom, refiner.labels(), n);
    rounds.push_back({n, relative});
    if (relative <= o.max_error || n >= nf) break;
    // E ~ 1/n: about n (ratio - 1) more proxies reach the bound; damped, at least 1, at most n.
    double ratio = o.max_error > 0 ? relative / o.max_error : 2.0;
    uint64_t add = std::clamp<uint64_t>(uint64_t(std::ceil(0.75 * n * (ratio - 1))), 1, n);
    add = std::min<uint64_t>(add, nf - n);
    refiner.add_proxies(uint32_t(add));
    n = refiner.clusters();
  }
  refiner.finish();
  refine_seconds = seconds_since(t);
  return out;
}

}  // namespace

double l21_distortion(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t regions, double* total_area) {
  check_labels(mesh, labels, regions);
  FaceGeometry g = face_geometry(mesh);
  Proxies p = compute_proxies(g, labels, regions);
  if (total_area) *total_area = std::accumulate(p.area.begin(), p.area.end(), 0.0);
  return partition_distortion(g, labels, p);
}

namespace {

// split_by_normals: rounds of area-weighted smoothing of the normals, and rounds of 2-means after
// the first flood by them (bench/RESULTS.md, thirty-sixth session). With one round of smoothing,
// or one of 2-means or none, the halves of a noisy half cylinder came out lopsided or crossing its
// middle (test_approximate.cpp, "split by normals"); with one round of 2-means the outputs at 4 and
// 30 proxies also kept 3% more vertices (sweep C there).
constexpr int kSplitSmoothing = 4;
constexpr int kSplitRounds = 2;
// The split by the faces' own normals is kept where its distortion is below this share of the
// smoothed split's. On a scan the two are within a few percent (noise is most of it: 0.0489
// against 0.0474 for halves of 10 + 683 and 383 + 310 faces of the test elephant), on a CAD part
// the split along the sharp edge has next to none (the chamfered box: 1e-13 against 0.03). Over the
// sweeps 0.7 and 0.8 gave about what 0.9 gives; 1 (the lower distortion wins) left more triangles
// facing away and saved fewer output vertices.
constexpr double kSplitOwnShare = 0.9;

// Splits each listed region in two by its normals. Returns the new region count. Both halves are
// grown over the region's faces from a seed each, in order of the distance of a face's normal to
// the seed normal (a flood like VSA's), so both are connected. Two such splits are made, region by
// region, and the second is kept unless the first has clearly less L2,1 distortion (kSplitOwnShare):
//   * by the faces' own normals, seeded at the face farthest from the proxy normal and the face
//     farthest from that one: on a CAD part, the far side of the sharp edge the split belongs on;
//   * by normals smoothed over the region (kSplitSmoothing rounds of area-weighted means over each
//     face and its edge neighbours), seeded the same way and then moved to the means of the
//     halves (kSplitRounds rounds of 2-means). Why: on a scan the normals are noisy, the farthest
//     faces are noise, and a flood by noisy normals does not reach the faces nearest its seed's
//     normal, which lie scattered: the first split kept a handful of faces in one half (the man at
//     10 proxies: 8 + 5245, 2 + 5243 ...), so large regions lost a few faces per meshing pass.
// The distortion is measured with the faces' own normals, about each half's mean. Ties in a flood
// (equal distances: a flat region) go to the face offered first.
uint32_t split_by_normals(const Topology& topology, const FaceGeometry& g, const Proxies& proxies,
                          std::vector<uint32_t>& labels, uint32_t regions, const std::vector<uint32_t>& split,
                          MeshingFix::Kind kind, std::vector<MeshingFix>& fixes, WorkerPool* pool = nullptr) {
  std::vector<uint8_t> wanted(regions, 0);
  for (uint32_t r : split) wanted[r] = 1;
  // The wanted regions' faces (members, in face order) and where each is among them (slot).
  std::vector<uint32_t> members, slot(labels.size(), kNone);
  for (uint32_t f = 0; f < labels.size(); ++f)
    if (wanted[labels[f]] && !g.collapsed[f]) slot[f] = uint32_t(members.size()), members.push_back(f);
  const size_t m = members.size();
  // Split regions (two members or more) and their new labels.
  std::vector<uint32_t> size(regions, 0), fresh_of(regions, kNone);
  for (uint32_t f : members) ++size[labels[f]];
  uint32_t count = regions;
  for (uint32_t r = 0; r < regions; ++r)
    if (wanted[r] && size[r] >= 2) {
      fresh_of[r] = count++;
      fixes.push_back({kind, r, fresh_of[r], kNone, 1});
    }
  // The floods of different regions never meet: they run side by side, the split regions dealt to
  // the pool's threads largest first, each to the thread with the fewest faces so far (a region's
  // own pushes and pops keep their order, so the halves do not depend on the thread count).
  const unsigned parts = pool != nullptr ? pool->size() : 1;
  std::vector<std::vector<uint32_t>> part_regions(parts);
  {
    std::vector<uint32_t> by_size;
    for (uint32_t r = 0; r < regions; ++r)
      if (fresh_of[r] != kNone) by_size.push_back(r);
    std::stable_sort(by_size.begin(), by_size.end(), [&](uint32_t a, uint32_t b) { return size[a] > size[b]; });
    std::vector<size_t> load(parts, 0);
    for (uint32_t r : by_size) {
      const size_t p = size_t(std::min_element(load.begin(), load.end()) - load.begin());
      part_regions[p].push_back(r);
      load[p] += size[r];
    }
  }
  auto each_region = [&](const auto& fn) {
    if (parts == 1) {
      for (uint32_t r : part_regions[0]) fn(r);
      return;
    }
    pool->run(parts, [&](size_t first, size_t last, unsigned) {
      for (size_t p = first; p < last; ++p)
        for (uint32_t r : part_regions[p]) fn(r);
    }, 1);
  };

  // Each member's edge neighbours in its region, as members (kNone: none there).
  std::vector<uint32_t> adjacent(3 * m);
  for (size_t i = 0; i < m; ++i)
    for (int k = 0; k < 3; ++k) {
      const uint32_t o = topology.face_adjacent[3 * size_t(members[i]) + k];
      adjacent[3 * i + k] = o != kNone && labels[o] == labels[members[i]] ? slot[o] : kNone;
    }
  // A face offered to a half: the distance of its normal to the half's (squared), the order of the
  // offers (ties go to the earlier: breadth first, so a flat region comes apart in space), the
  // member and the half (bit 31: the fresh one). 16 bytes: the heap holds a few entries per face.
  struct Entry {
    double d;
    uint32_t order, member_half;
    bool operator>(const Entry& o) const { return d != o.d ? d > o.d : order > o.order; }
  };
  constexpr uint32_t kFreshHalf = 1u << 31;
  assert(m < kFreshHalf);
  std::vector<uint32_t> seed(count, kNone);  // per half, a member
  std::vector<Vec3> seed_normal(count);
  // Per member, the halves that were offered it (bit 0: the kept label's, bit 1: the fresh one's):
  // a half offers a face once, its distance being the same from every neighbour, and a later
  // offer (a later order) would only be popped after the first and passed over.
  std::vector<uint8_t> offered(m);
  // One split by the normals `n` (per member): seeds, then the flood, into `out` (per member).
  auto grow = [&](const std::vector<Vec3>& n, std::vector<uint32_t>& out) {
    out.assign(m, kNone);
    std::fill(offered.begin(), offered.end(), uint8_t(0));
    each_region([&](uint32_t r) {  // (writes only r's members and reads only theirs)
      std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
      uint32_t order = 0;
      const uint32_t a = seed[r], b = seed[fresh_of[r]];
      heap.push({0, order++, a}), heap.push({0, order++, b | kFreshHalf});
      offered[a] |= 1, offered[b] |= 2;
      while (!heap.empty()) {
        const Entry e = heap.top();
        heap.pop();
        const uint32_t i = e.member_half & ~kFreshHalf;
        if (out[i] != kNone) continue;
        const uint32_t fresh = e.member_half & kFreshHalf;
        const uint32_t half = fresh ? fresh_of[r] : r;
        const uint8_t bit = fresh ? 2 : 1;
        out[i] = half;
        for (int k = 0; k < 3; ++k) {
          const uint32_t o = adjacent[3 * i + k];
          if (o == kNone || out[o] != kNone || (offered[o] & bit)) continue;
          offered[o] |= bit;
          const Vec3 d = n[o] - seed_normal[half];
          heap.push({dot(d, d), order++, o | fresh});
        }
      }
    });
  };
  // The first seeds by the normals n: the member farthest from the proxy normal, the member
  // farthest from that one (ties: the first in face order).
  auto seed_far = [&](const std::vector<Vec3>& n) {
    std::vector<double> far(regions, 2);
    for (size_t i = 0; i < m; ++i) {
      const uint32_t r = labels[members[i]];
      const double c = dot(n[i], proxies.normal[r]);
      if (fresh_of[r] != kNone && c < far[r]) far[r] = c, seed[r] = uint32_t(i);
    }
    std::fill(far.begin(), far.end(), 2.0);
    for (size_t i = 0; i < m; ++i) {
      const uint32_t r = labels[members[i]];
      if (fresh_of[r] == kNone || i == seed[r]) continue;
      const double c = dot(n[i], n[seed[r]]);
      if (c < far[r]) far[r] = c, seed[fresh_of[r]] = uint32_t(i);
    }
    for (uint32_t r = 0; r < regions; ++r)
      if (fresh_of[r] != kNone)
        seed_normal[r] = n[seed[r]], seed_normal[fresh_of[r]] = n[seed[fresh_of[r]]];
  };
  // Per half of `halves` (labels per member): the area-weighted mean of the normals n, unit (zero
  // where it has none).
  auto halves_mean = [&](const std::vector<uint32_t>& halves, const std::vector<Vec3>& n) {
    std::vector<Vec3> mean(count, Vec3{0, 0, 0});
    for (size_t i = 0; i < m; ++i)
      if (halves[i] != kNone) mean[halves[i]] = mean[halves[i]] + g.area[members[i]] * n[i];
    for (Vec3& v : mean) {
      const double l = length(v);
      v = l > 0 ? (1.0 / l) * v : Vec3{0, 0, 0};
    }
    return mean;
  };
  std::vector<Vec3> own(m);
  for (size_t i = 0; i < m; ++i) own[i] = g.normal[members[i]];
  // Per half: the L2,1 distortion, sum of area |n - mean|^2 with the faces' own normals.
  auto distortion = [&](const std::vector<uint32_t>& halves) {
    const std::vector<Vec3> mean = halves_mean(halves, own);
    std::vector<double> e(count, 0.0);
    for (size_t i = 0; i < m; ++i)
      if (halves[i] != kNone) {
        const Vec3 d = own[i] - mean[halves[i]];
        e[halves[i]] += g.area[members[i]] * dot(d, d);
      }
    return e;
  };

  // By the faces' own normals.
  std::vector<uint32_t> by_own, by_smooth;
  seed_far(own);
  grow(own, by_own);
  // By smoothed normals, with rounds of 2-means.
  std::vector<Vec3> smooth = own, next(m);
  for (int round = 0; round < kSplitSmoothing; ++round) {
    auto smooth_range = [&](size_t first, size_t last, unsigned) {
      for (size_t i = first; i < last; ++i) {
        Vec3 sum = g.area[members[i]] * smooth[i];
        for (int k = 0; k < 3; ++k) {
          const uint32_t o = adjacent[3 * i + k];
          if (o != kNone) sum = sum + g.area[members[o]] * smooth[o];
        }
        const double l = length(sum);
        next[i] = l > 0 ? (1.0 / l) * sum : smooth[i];
      }
    };
    if (pool != nullptr) pool->run(m, smooth_range);
    else smooth_range(0, m, 0);
    smooth.swap(next);
  }
  seed_far(smooth);
  grow(smooth, by_smooth);
  for (int round = 0; round < kSplitRounds; ++round) {
    const std::vector<Vec3> mean = halves_mean(by_smooth, smooth);
    std::vector<double> nearest(count, -2);
    for (size_t i = 0; i < m; ++i) {
      const uint32_t l = by_smooth[i];
      if (l == kNone || !(dot(mean[l], mean[l]) > 0)) continue;  // (no area: the seed stays)
      const double c = dot(smooth[i], mean[l]);
      if (c > nearest[l]) nearest[l] = c, seed[l] = uint32_t(i);
    }
    for (uint32_t l = 0; l < count; ++l)
      if (dot(mean[l], mean[l]) > 0) seed_normal[l] = mean[l];
    grow(smooth, by_smooth);
  }
  // Region by region, the split by smoothed normals unless the other has clearly less distortion.
  const std::vector<double> e_own = distortion(by_own), e_smooth = distortion(by_smooth);
  for (size_t i = 0; i < m; ++i) {
    const uint32_t r = labels[members[i]];
    if (fresh_of[r] == kNone) continue;
    const bool own_better =
        e_own[r] + e_own[fresh_of[r]] < kSplitOwnShare * (e_smooth[r] + e_smooth[fresh_of[r]]);
    const uint32_t half = own_better ? by_own[i] : by_smooth[i];
    if (half != kNone) labels[members[i]] = half;  // (kNone: a part of the region the seeds do not reach)
  }
  return count;
}

}  // namespace

uint32_t detail::split_regions_by_normals(const Mesh& mesh, const Topology& topology, std::vector<uint32_t>& labels,
                                          uint32_t regions, const std::vector<uint32_t>& split) {
  check_labels(mesh, labels, regions);
  for (uint32_t r : split)
    if (r >= regions) throw OptionError("split_regions_by_normals: region " + std::to_string(r) + " >= " + std::to_string(regions));
  const FaceGeometry g = face_geometry(mesh);
  const Proxies proxies = compute_proxies(g, labels, regions);
  std::vector<MeshingFix> fixes;
  return split_by_normals(topology, g, proxies, labels, regions, split, MeshingFix::split_curved, fixes);
}

namespace {

// A closed component covered by fewer than 4 regions would come out flat (2 regions: two copies of
// one triangle): its largest region is split by its normals until it has 4 (or nothing splits).
uint32_t make_solid_components(const Mesh& mesh, const Topology& topology, const FaceGeometry& g,
                               std::vector<uint32_t>& labels, uint32_t count, std::vector<MeshingFix>& fixes) {
  const uint32_t components = topology.component_count;
  std::vector<uint8_t> open(components, 0);
  for (size_t h = 0; h < topology.face_adjacent.size(); ++h)
    if (topology.face_adjacent[h] == kNone) open[topology.face_component[h / 3]] = 1;
  for (int pass = 0; pass < 3; ++pass) {
    // The usual case first: every closed component has 4 or more regions (a region lies in one
    // component: regions are connected), found without sorting a pair per face or the proxies.
    {
      std::vector<uint32_t> region_component(count, kNone), regions_in(components, 0);
      bool spans = false;
      for (uint32_t f = 0; f < labels.size(); ++f) {
        const uint32_t c = topology.face_component[f];
        if (open[c] || g.collapsed[f]) continue;
        uint32_t& rc = region_component[labels[f]];
        if (rc == kNone) rc = c, ++regions_in[c];
        else spans |= rc != c;
      }
      bool few = false;
      for (uint32_t c = 0; c < components && !few; ++c) few = regions_in[c] > 0 && regions_in[c] < 4;
      if (!spans && !few) break;
    }
    // Regions of each closed component.
    std::vector<uint64_t> pairs;
    for (uint32_t f = 0; f < labels.size(); ++f)
      if (!open[topology.face_component[f]] && !g.collapsed[f])
        pairs.push_back(uint64_t(topology.face_component[f]) << 32 | labels[f]);
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    Proxies proxies = compute_proxies(g, labels, count);
    std::vector<uint32_t> split;
    for (size_t i = 0; i < pairs.size();) {
      size_t j = i;
      uint32_t largest = kNone;
      while (j < pairs.size() && pairs[j] >> 32 == pairs[i] >> 32) {
        uint32_t r = uint32_t(pairs[j]);
        if (largest == kNone || proxies.area[r] > proxies.area[largest]) largest = r;
        ++j;
      }
      if (j - i < 4) split.push_back(largest);
      i = j;
    }
    if (split.empty()) break;
    uint32_t before = count;
    count = split_by_normals(topology, g, proxies, labels, count, split, MeshingFix::solid_component, fixes);
    count = make_disk_regions(mesh, topology, g, labels, count, fixes);
    if (count == before) break;  // single faces: nothing left to split
  }
  return count;
}

ShapeApproximation mesh_partition_with(const Mesh& mesh, const Topology& topology, const FaceGeometry& geom,
                                       std::vector<uint32_t> labels, uint32_t regions, const MeshingOptions& options,
                                       unsigned threads, bool from_scratch = false) {
  auto t = Clock::now();
  WorkerPool pool(threads);
  ShapeApproximation out;
  out.partition_proxies = regions;
  std::vector<MeshingFix> partition_fixes;  // region splits, kept over the passes
  uint32_t count = make_disk_regions(mesh, topology, geom, labels, regions, partition_fixes, nullptr, &pool);
  count = make_solid_components(mesh, topology, geom, labels, count, partition_fixes);
  const EdgeGraph edges = edge_graph(mesh, topology, geom, pool);
  Proxies proxies;
  FirstColorings previous, current;
  bool unsplittable = false;  // the last split changed nothing: the next pass is the last
  uint32_t pass = 0, shortened = 0;
  for (;; ++pass) {
    proxies = compute_proxies(geom, labels, count);
    out.fixes = partition_fixes;
    out.stats = MeshingStats{};
    const bool may_split = !unsplittable && pass + 1 < kMaxSplitPasses;
    Mesher mesher(mesh, topology, geom, edges, labels, count, proxies, options, pool, out, from_scratch,
                  pass > 0 ? &previous : nullptr, &current, may_split);
    mesher.run();
    std::swap(previous, current);
    // Regions still with flipped triangles are too curved for one polygon: split them, mesh again.
    std::vector<uint32_t> curved;
    for (const MeshingFix& f : out.fixes)
      if (f.kind == MeshingFix::flipped_triangles) curved.push_back(f.region);
    std::sort(curved.begin(), curved.end());  // (a pass that stopped early lists the tested ones last)
    if (curved.empty() || !may_split) {
      assert(mesher.complete());
      break;
    }
    shortened += !mesher.complete();
    const uint32_t before = count;
    count = split_by_normals(topology, geom, proxies, labels, count, curved, MeshingFix::split_curved, partition_fixes,
                             &pool);
    std::vector<uint8_t> changed(count, 0);  // the split regions and their new halves
    for (uint32_t r : curved) changed[r] = 1;
    std::fill(changed.begin() + before, changed.end(), uint8_t(1));
    count = make_disk_regions(mesh, topology, geom, labels, count, partition_fixes, &changed, &pool);
    if (count == before) {  // regions of one face: the same partition again
      if (mesher.complete()) break;
      unsplittable = true;   // mesh it in full once more
    }
  }
  out.stats.meshing_passes = pass + 1;
  out.stats.shortened_passes = shortened;
  out.regions = count;
  out.labels = std::move(labels);
  out.proxy_normals.resize(3 * size_t(out.regions));
  out.proxy_centroids.resize(3 * size_t(out.regions));
  for (uint32_t r = 0; r < out.regions; ++r) {
    const Vec3 n = proxies.normal[r], x = proxies.centroid[r];
    out.proxy_normals[3 * r] = float(n.x), out.proxy_normals[3 * r + 1] = float(n.y), out.proxy_normals[3 * r + 2] = float(n.z);
    out.proxy_centroids[3 * r] = float(x.x), out.proxy_centroids[3 * r + 1] = float(x.y), out.proxy_centroids[3 * r + 2] = float(x.z);
  }
  out.total_area = std::accumulate(proxies.area.begin(), proxies.area.end(), 0.0);
  out.distortion = partition_distortion(geom, out.labels, proxies);
  out.relative_error = out.total_area > 0 ? out.distortion / out.total_area : 0.0;
  out.meshing_seconds = seconds_since(t);
  return out;
}

}  // namespace

namespace {
ShapeApproximation checked_mesh_partition(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                          uint32_t regions, const MeshingOptions& options, bool from_scratch) {
  check_labels(mesh, labels, regions);
  check_meshing_options(options);
  if (topology.face_adjacent.size() != 3 * mesh.face_count())
    throw OptionError("topology does not belong to this mesh");
  FaceGeometry geom = face_geometry(mesh);
  return mesh_partition_with(mesh, topology, geom, labels, regions, options, /*threads=*/0, from_scratch);
}
}  // namespace

ShapeApproximation mesh_partition(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                  uint32_t regions, const MeshingOptions& options) {
  return checked_mesh_partition(mesh, topology, labels, regions, options, false);
}

namespace detail {
ShapeApproximation mesh_partition_from_scratch(const Mesh& mesh, const Topology& topology,
                                               const std::vector<uint32_t>& labels, uint32_t regions,
                                               const MeshingOptions& options) {
  return checked_mesh_partition(mesh, topology, labels, regions, options, true);
}
}  // namespace detail

ShapeApproximation approximate_shape(const Mesh& mesh, const Topology& topology, const ApproximateOptions& options) {
  validate(mesh, options);
  // Faces with a repeated corner (welded slivers) have no area and no edges: left out, as
  // cluster() and coarsen_mesh leave them out (each would be a region of its own, or a piece its
  // region's repair cannot reach), and given the region of a face at a corner afterwards.
  if (topology.collapsed_faces > 0 && topology.collapsed_faces < mesh.face_count()) {
    Mesh kept = mesh;
    std::vector<uint32_t> kept_index;
    remove_collapsed_faces(kept, &kept_index);
    ShapeApproximation out = approximate_shape(kept, build_topology(kept, options.threads), options);
    out.labels = labels_with_collapsed_faces(mesh, topology, kept_index, out.labels, 0);
    if (!out.clustering.labels.empty())
      out.clustering.labels = labels_with_collapsed_faces(mesh, topology, kept_index, out.clustering.labels, 0);
    out.collapsed_faces = topology.collapsed_faces;
    return out;
  }
  // The L2,1 metric compares face normals: on a mesh whose triangles are ordered at random (boeing,
  // the *-shuffled meshes of libcgal-demo) half of them point the wrong way. Orient a copy first.
  if (topology.orientation_flips > 0) {
    Mesh oriented = mesh;
    Topology oriented_topology = topology;
    const uint64_t flipped = orient_consistently(oriented, oriented_topology);
    if (flipped > 0) {
      ShapeApproximation out = approximate_shape(oriented, oriented_topology, options);
      out.reoriented_faces = flipped;
      return out;
    }
  }
  auto t = Clock::now();
  FaceGeometry geom = face_geometry(mesh);
  std::vector<RefinementRound> rounds;
  double refine_s = 0;
  Clustering c = make_partition(mesh, topology, geom, options, rounds, refine_s);
  double partition_s = seconds_since(t);
  uint32_t n = uint32_t(c.generators.size() / 3);
  ShapeApproximation out = mesh_partition_with(mesh, topology, geom, c.labels, n, options.meshing, options.threads);
  out.clustering = std::move(c);
  out.requested_proxies = options.proxies;
  out.rounds = std::move(rounds);
  out.partition_seconds = partition_s;
  out.refine_seconds = refine_s;
  return out;
}

ShapeApproximation approximate_shape(const Mesh& mesh, const ApproximateOptions& options) {
  validate(mesh, options);
  return approximate_shape(mesh, build_topology(mesh, options.threads), options);
}

ChordRule parse_chord_rule(const std::string& s) {
  if (s == "paper") return ChordRule::paper;
  if (s == "cgal") return ChordRule::cgal;
  throw OptionError("unknown chord rule '" + s + "' (expected paper or cgal)");
}

const char* to_string(ChordRule r) { return r == ChordRule::paper ? "paper" : "cgal"; }

const char* to_string(MeshingFix::Kind k) {
  switch (k) {
    case MeshingFix::split_region: return "split_region";
    case MeshingFix::loop_anchors: return "loop_anchors";
    case MeshingFix::polygon_anchor: return "polygon_anchor";
    case MeshingFix::duplicate_chord: return "duplicate_chord";
    case MeshingFix::fallback_triangulation: return "fallback_triangulation";
    case MeshingFix::anchor_position: return "anchor_position";
    case MeshingFix::flip_anchor: return "flip_anchor";
    case MeshingFix::flipped_triangles: return "flipped_triangles";
    case MeshingFix::skipped_region: return "skipped_region";
    case MeshingFix::split_curved: return "split_curved";
    case MeshingFix::solid_component: return "solid_component";
  }
  return "?";
}

}  // namespace meshcvt
