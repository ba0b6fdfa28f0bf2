// meshcvt: uniform coarsening, the dual mesh of a face clustering (Fan et al. Section 6.1, second
// step; API in meshcvt/coarsen.h, vertex placement in vertex_placement.cpp).
//
// "Two vertices are connected with an edge in the coarsened mesh if the corresponding clusters are
// adjacent. A vertex point shared by three clusters corresponds to a triangle; shared by n >= 4
// clusters, to an n-sided polygon, triangulated into n - 2 triangles." Here:
//
//  * Each mesh vertex's face fan is walked in orientation order (across the edge (v, b) of the face
//    (v, a, b)), giving its clusters as a cyclic sequence of runs. Three or more runs make a
//    polygon whose order is the fan's, so the output keeps the input's orientation.
//  * On the boundary the fan is open: two or more runs give the polygon closed by the boundary
//    (the corner is not cut off), and its closing edge from the last run to the first is exactly
//    the step the input's boundary loop takes there. So each pair of clusters consecutive along an
//    input boundary loop gets one output boundary edge, and loops stay loops.
//  * n-gons (n >= 4) get the triangulation maximizing the minimum angle (interval dynamic
//    programming, O(n^3)), first avoiding diagonals that are already edges of the dual (they would
//    give an edge three triangles).
//
// Nothing here needs maps per vertex: one pass over faces in face order (cluster face and border
// counts, connectivity by union-find, and per vertex the one cluster of its faces, if one), one over
// vertices where only those on a cluster border or the mesh boundary (about a tenth) walk their fan
// through the CSR vertex->faces arrays. On a second thread the mass centroids and the vertex
// placement run beside the face pass, and the two threads share the vertex pass (see run). The few
// records per corner vertex are sorted afterwards, by a counting sort on cluster ids.
//
// Defects (see DualDefect) are found from counts a disk cluster must have: it is edge-connected and
// V - E + F = 1 where E = (3F + B) / 2 with B its border half-edges (a connected surface with
// boundary and chi = 1 is a disk). A cluster seen in two separate runs around a vertex (pinched) is
// reported too; with the two counts above that only adds cases at non-manifold vertices. Two clusters whose border has more than two chain ends share two borders. The
// output is checked for duplicate triangles, edges of three or more triangles, orientation
// disagreements, input boundary steps without an output edge and degenerate triangles.
#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <numbers>
#include <exception>
#include <functional>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "meshcvt/quality.h"
#include "coarse_boundary.h"
#include "coarse_fit.h"
#include "coarse_toward_surface.h"
#include "triangle_angle.h"

namespace meshcvt {

namespace detail {
// In vertex_placement.cpp: validates labels and weights (OptionError), and places the vertices given
// each vertex's cluster (vertex_cluster[v], when below `clusters`: all faces of v are in that
// cluster; other values: several clusters or none).
void check_placement_inputs(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                            const std::vector<float>* face_weights);
// Mass centroids in double, 3 per cluster.
std::vector<double> mass_centroids(const Mesh& mesh, const std::vector<uint32_t>& labels, uint32_t clusters,
                                   const std::vector<float>* face_weights);
std::vector<float> place_cluster_vertices(const Mesh& mesh, const Topology* topology,
                                          const std::vector<uint32_t>& labels, uint32_t clusters,
                                          VertexPlacement placement, const std::vector<float>* face_weights,
                                          const std::vector<uint32_t>& vertex_cluster,
                                          const std::vector<double>& centroids, unsigned threads,
                                          std::vector<uint32_t>* faces, const std::vector<uint8_t>* own_planes_only);
// In coarse_relax.cpp: relax_coarse_vertices, starting from a face per vertex where start_faces
// gives one (the face under the vertex; kNone or a missing array: found by a walk).
uint64_t relax_coarse_vertices(Mesh& coarse, const Mesh& mesh, const Topology& topology,
                               const std::vector<uint32_t>& labels, uint32_t passes, double max_normal_turn_deg,
                               const std::vector<uint32_t>* start_faces, unsigned threads);
}  // namespace detail

namespace {

using detail::check_placement_inputs;

// Polygons larger than this (a vertex of enormous valence with a cluster per face) are fanned from
// their first cluster instead of paying O(n^3).
constexpr uint32_t kMaxDynamicProgramming = 128;
// A triangle whose smallest angle has a sine below this is reported as degenerate.
constexpr double kDegenerateSine = 1e-9;
// Vertices per chunk of the vertex pass (about 50 us of walking).
constexpr size_t kVertexChunk = 2048;
// Faces from which the dual's two halves run on two threads. A thread costs 15 us to start and
// join (75 us the first in a process); with the placement in the second half, the fastest of 300
// bare runs on two threads against one: elephant (5.5k faces) 0.35 against 0.47 ms, femur (7.8k)
// 0.52 against 0.68, fandisk (12.9k) 0.62 against 0.88, horizons (3.2k) 0.107 against 0.116.
constexpr size_t kMinParallelHalves = 4096;

// Vertex state: the cluster of all the vertex's (non-collapsed) faces, kSeveral, or kUnset (no face).
// A vertex inside one cluster needs no fan walk, on the mesh boundary or not: its fans are single
// runs, which count the vertex once for that cluster and give no polygon.
constexpr uint32_t kSeveral = 0x7fffffffu;
constexpr uint32_t kUnset = 0x7ffffffeu;
constexpr uint32_t kMaxClusters = kUnset;
// Relax passes after the boundary's vertices went onto it (at most CoarsenOptions::relax_passes):
// the sweep of the thirty-eighth session gave the same quality with 2 and 3.
constexpr uint32_t kBoundaryRelaxPasses = 2;

uint64_t undirected_key(uint32_t a, uint32_t b) {
  if (a > b) std::swap(a, b);
  return (uint64_t(a) << 32) | b;
}
uint64_t directed_key(uint32_t from, uint32_t to) { return (uint64_t(from) << 32) | to; }
uint32_t key_high(uint64_t k) { return uint32_t(k >> 32); }
uint32_t key_low(uint64_t k) { return uint32_t(k); }

// Sorts `items` by `less`, where less orders by cluster(item) (below `clusters`) first: a counting
// sort by that cluster, then each cluster's few items (a dual vertex has about six edges) by
// insertion sort. For a strict total order (no two distinct items equivalent) that is the order
// std::sort gives, in O(n + clusters) and without its unpredictable branches, which made the sorts
// of the edge and triangle lists a third of the dual's time. On return offsets[c]..offsets[c + 1]
// are cluster c's items.
template <class T, class Cluster, class Less>
void sort_by_cluster(std::vector<T>& items, uint32_t clusters, Cluster cluster, Less less,
                     std::vector<uint32_t>& offsets) {
  offsets.assign(size_t(clusters) + 1, 0);
  for (const T& x : items) {
    assert(cluster(x) < clusters);
    ++offsets[cluster(x) + 1];
  }
  for (uint32_t c = 0; c < clusters; ++c) offsets[c + 1] += offsets[c];
  std::vector<T> sorted(items.size());
  for (const T& x : items) sorted[offsets[cluster(x)]++] = x;  // offsets[c] ends at cluster c's end
  for (uint32_t c = clusters; c > 0; --c) offsets[c] = offsets[c - 1];
  offsets[0] = 0;
  for (uint32_t c = 0; c < clusters; ++c) {
    T *begin = sorted.data() + offsets[c], *end = sorted.data() + offsets[c + 1];
    if (end - begin > 16) {  // a cluster of many neighbours (a poor clustering): no quadratic time
      std::sort(begin, end, less);
      continue;
    }
    for (T* i = begin + 1; i < end; ++i) {
      T x = *i;
      T* j = i;
      for (; j > begin && less(x, j[-1]); --j) *j = j[-1];
      *j = x;
    }
  }
  items.swap(sorted);
}

void check_topology(const Mesh& mesh, const Topology& topology, uint32_t clusters) {
  if (clusters >= kMaxClusters) throw OptionError("coarsen: too many clusters (" + std::to_string(clusters) + ")");
  if (topology.face_adjacent.size() != mesh.indices.size() ||
      topology.vertex_face_offsets.size() != mesh.vertex_count() + 1 ||
      topology.vertex_faces.size() != topology.vertex_face_offsets.back())
    throw OptionError("coarsen: the topology was not built for this mesh");
}

// Everything the topology pass learns: the polygons of corner vertices, the ends of the border
// chains between clusters, the steps the boundary loops take between clusters, per-cluster counts.
struct DualStructure {
  std::vector<uint32_t> polygon_offsets{0};
  std::vector<uint32_t> polygon_clusters;
  std::vector<uint64_t> chain_ends;      // undirected_key per end of a border chain (two per chain)
  std::vector<uint64_t> boundary_steps;  // directed_key(from, to) where a boundary loop changes cluster
  // per cluster
  std::vector<uint32_t> all_faces;       // every face, collapsed ones included (0: empty cluster)
  std::vector<uint32_t> faces;           // non-collapsed faces, F
  std::vector<uint64_t> border_half_edges;  // B: edges of its faces with no neighbour in the cluster
  std::vector<uint32_t> vertices;        // V: distinct vertices of its non-collapsed faces
  std::vector<uint32_t> boundary_ends;   // ends of its arcs along the mesh boundary (2 per arc)
  std::vector<uint32_t> components;      // edge-connected pieces
  std::vector<uint8_t> pinched;          // seen in two runs around some vertex
  std::vector<uint8_t> collapsed;        // per face, only filled when any face is collapsed
  bool any_collapsed = false;
  // Per vertex, when every vertex of the mesh has one closed fan (see single_closed_fans): twice the
  // number of its edges between two clusters, saturating at 255. In a closed fan that number is
  // the number of runs of clusters around the vertex.
  std::vector<uint8_t> twice_border_edges;
  std::vector<uint32_t> vertex_state;    // per vertex: its faces' cluster, kSeveral or kUnset
};

bool is_collapsed(const uint32_t* t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }

// Whether the faces around every vertex form one closed fan: no boundary, no non-manifold edge or
// vertex, no collapsed face. Then a vertex between exactly two clusters is two runs of faces, and
// needs no walk to say so (see walk_vertices).
bool single_closed_fans(const Topology& topology) {
  return topology.boundary_edges == 0 && topology.nonmanifold_edges == 0 && topology.nonmanifold_vertices == 0 &&
         topology.collapsed_faces == 0;
}

// The root of x's tree in a union-find forest, halving the path on the way.
uint32_t find_root(uint32_t* parent, uint32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

// One pass over faces, in face order (sequential reads but for the neighbour's label): F, B, the
// collapsed flags, the vertex state: which cluster a vertex's faces are in (kSeveral when more
// than one), and the components.
//
// Components: union-find over the edges to earlier faces of the same cluster, each merge of two
// pieces taking one from the cluster's F. The adjacency is symmetric and collapsed faces have none,
// so that is every edge inside a cluster once, and the count a flood fill from every unseen face
// would give, without the flood's walk over the mesh in no useful order (1.1 ms of bunny00's 5).
void count_faces(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                 DualStructure& dual) {
  const size_t faces = mesh.face_count();
  std::vector<uint32_t> piece(faces);  // union-find parent per face, a root its own
  dual.vertex_state.assign(mesh.vertex_count(), kUnset);
  uint8_t* twice_border = nullptr;
  if (single_closed_fans(topology)) {
    dual.twice_border_edges.assign(mesh.vertex_count(), 0);
    twice_border = dual.twice_border_edges.data();
  }
  // The arrays by local pointers: the byte stores (twice_border, collapsed) may alias anything, so
  // through the vectors every data pointer was loaded again after each of them.
  const uint32_t* label_of = labels.data();
  const uint32_t* corners = mesh.indices.data();
  const uint32_t* adjacent = topology.face_adjacent.data();
  uint32_t* state = dual.vertex_state.data();
  uint32_t* all_faces = dual.all_faces.data();
  uint32_t* kept_faces = dual.faces.data();
  uint32_t* components = dual.components.data();
  uint64_t* border_half_edges = dual.border_half_edges.data();
  uint32_t* parent = piece.data();
  for (size_t f = 0; f < faces; ++f) {
    const uint32_t label = label_of[f];
    ++all_faces[label];
    parent[f] = uint32_t(f);
    const uint32_t* t = corners + 3 * f;
    if (is_collapsed(t)) {
      if (!dual.any_collapsed) dual.collapsed.assign(faces, 0);
      dual.any_collapsed = true;
      dual.collapsed[f] = 1;
      continue;
    }
    ++kept_faces[label];
    ++components[label];
    uint32_t borders = 0;
    uint32_t mine = uint32_t(f);  // the root of f's piece, kept through its merges
    for (int e = 0; e < 3; ++e) {
      const uint32_t across = adjacent[3 * f + e];
      if (across != kNone && across >= faces) throw OptionError("coarsen: the topology was not built for this mesh");
      const bool border = across == kNone || label_of[across] != label;
      if (!border && across < f) {
        const uint32_t theirs = find_root(parent, across);
        if (mine != theirs) {
          parent[std::max(mine, theirs)] = std::min(mine, theirs);
          mine = std::min(mine, theirs);
          --components[label];
        }
      }
      borders += border;
      if (border && twice_border) {  // both faces of the edge count it: twice per edge
        uint8_t& a = twice_border[t[e]];
        uint8_t& b = twice_border[t[e == 2 ? 0 : e + 1]];
        a = uint8_t(a + (a < 255));
        b = uint8_t(b + (b < 255));
      }
    }
    border_half_edges[label] += borders;
    for (int c = 0; c < 3; ++c) {
      uint32_t& vertex = state[t[c]];
      if (vertex != label) vertex = vertex == kUnset ? label : kSeveral;
    }
  }
}

// Walks the fans of one vertex whose faces lie in two or more clusters and records what they give:
// reads the face pass's results in `faces_pass`, writes the vertex pass's fields of `out`.
class FanWalker {
 public:
  FanWalker(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
            const DualStructure& faces_pass, DualStructure& out)
      : mesh_(mesh),
        topology_(topology),
        labels_(labels),
        in_(faces_pass),
        out_(out),
        cluster_seen_at_(faces_pass.faces.size(), kNone),
        one_fan_each_(topology.nonmanifold_edges == 0 && topology.nonmanifold_vertices == 0 &&
                      topology.collapsed_faces == 0) {}

  void vertex(uint32_t v) {
    v_ = v;
    uint32_t begin = topology_.vertex_face_offsets[v], end = topology_.vertex_face_offsets[v + 1];
    if (begin > end || end > topology_.vertex_faces.size())
      throw OptionError("coarsen: the topology was not built for this mesh");
    span_begin_ = topology_.vertex_faces.data() + begin;
    degree_ = end - begin;
    if (!in_.twice_border_edges.empty() && in_.twice_border_edges[v] == 4) {
      two_runs();
      return;
    }
    if (one_fan_each_ && closed_fan()) {
      emit();
      return;
    }
    visited_.assign(degree_, 0);
    for (uint32_t s = 0; s < degree_; ++s) {
      if (visited_[s]) continue;
      uint32_t f = span_begin_[s];
      if (f >= labels_.size() || corner_of(tri(f), v_) == 3)
        throw OptionError("coarsen: the topology was not built for this mesh");
      if (in_.any_collapsed && in_.collapsed[f]) continue;  // part of no fan
      walk(f);
      runs_from_fan();
      emit();
    }
  }

 private:
  const uint32_t* tri(uint32_t f) const { return &mesh_.indices[3 * size_t(f)]; }
  static int corner_of(const uint32_t* t, uint32_t v) { return t[0] == v ? 0 : t[1] == v ? 1 : t[2] == v ? 2 : 3; }
  // The edge joining corners a != b: edge e joins corners e and e + 1. (Not % 3 of a signed int,
  // a multiply and shifts.)
  static int edge_between(int a, int b) { return (a == 2 ? 0 : a + 1) == b ? a : b; }

  // The face across the edge {v, x} of face g, or kNone.
  uint32_t across(uint32_t g, uint32_t x) const {
    const uint32_t* t = tri(g);
    int cv = corner_of(t, v_), cx = corner_of(t, x);
    if (cv == 3 || cx == 3 || cv == cx) return kNone;
    int edge = edge_between(cv, cx);
    uint32_t h = topology_.face_adjacent[3 * size_t(g) + edge];
    if (h == kNone) return kNone;
    const uint32_t* th = tri(h);
    if (corner_of(th, v_) == 3 || corner_of(th, x) == 3) return kNone;  // not this vertex's fan
    return h;
  }
  // The corner of face g that is neither v nor x (g is not collapsed, so it is well defined).
  uint32_t third(uint32_t g, uint32_t x) const {
    const uint32_t* t = tri(g);
    return t[0] != v_ && t[0] != x ? t[0] : t[1] != v_ && t[1] != x ? t[1] : t[2];
  }
  // Position of face g in the vertex's sorted face list, degree_ when absent.
  uint32_t slot(uint32_t g) const {
    if (degree_ <= 16) {  // the usual fan: a short scan beats the binary search
      for (uint32_t s = 0; s < degree_; ++s)
        if (span_begin_[s] == g) return s;
      return degree_;
    }
    const uint32_t* end = span_begin_ + degree_;
    const uint32_t* it = std::lower_bound(span_begin_, end, g);
    return it != end && *it == g ? uint32_t(it - span_begin_) : degree_;
  }
  // Marks g visited; false when g is not a face of this vertex or was visited already (only
  // possible around non-manifold configurations, where the walk then stops).
  bool visit(uint32_t g) {
    uint32_t s = slot(g);
    if (s == degree_ || visited_[s]) return false;
    visited_[s] = 1;
    return true;
  }

  // Collects the fan of f in forward order (counter-clockwise seen from the side the face (v, a, b)
  // faces, i.e. from face (v, a, b) across its edge (v, b)), starting at the first face of an open
  // fan. Sets closed_. Forward first: a closed fan (the usual case) is walked once.
  void walk(uint32_t f) {
    const uint32_t* t = tri(f);
    int cv = corner_of(t, v_);
    fan_.clear();
    closed_ = false;
    visit(f);
    fan_.push_back(f);
    uint32_t g = f, exit = t[(cv + 2) % 3];
    for (uint32_t steps = 0; steps < degree_; ++steps) {
      uint32_t h = across(g, exit);
      if (h == f) {
        closed_ = true;
        return;
      }
      if (h == kNone || !visit(h)) break;
      fan_.push_back(h);
      exit = third(h, exit);
      g = h;
    }
    // Open: walk backward from f (across its other edge at v) and put those faces in front.
    back_.clear();
    g = f;
    exit = t[(cv + 1) % 3];
    for (uint32_t steps = 0; steps < degree_; ++steps) {
      uint32_t h = across(g, exit);
      if (h == kNone || !visit(h)) break;
      back_.push_back(h);
      exit = third(h, exit);
      g = h;
    }
    if (!back_.empty()) {
      fan_.insert(fan_.begin(), back_.rbegin(), back_.rend());
    }
  }

  // Where every vertex has one fan: when the vertex's fan is closed, the runs of what walk() finds
  // for its first face, the whole fan, without marking faces visited (the marks' searches were half
  // the walks' time). The walk must come back to that face after exactly degree_ steps. False,
  // with nothing recorded, when it does not: an open fan (or a topology not built for this mesh),
  // left to the general walk.
  bool closed_fan() {
    const uint32_t f = span_begin_[0];
    if (degree_ == 0 || f >= labels_.size()) return false;
    const uint32_t* t = tri(f);
    const int cv = corner_of(t, v_);
    if (cv == 3) return false;
    runs_.clear();
    uint32_t g = f, exit = t[(cv + 2) % 3];
    for (uint32_t steps = 1; steps <= degree_; ++steps) {
      if (runs_.empty() || runs_.back() != labels_[g]) runs_.push_back(labels_[g]);
      const uint32_t h = across(g, exit);
      if (h == kNone || (h == f) != (steps == degree_)) return false;
      exit = third(h, exit);
      g = h;
    }
    if (runs_.size() > 1 && runs_.front() == runs_.back()) runs_.pop_back();  // as runs_from_fan
    closed_ = true;
    return true;
  }

  // A vertex with one closed fan and two edges between clusters: two runs of two clusters, which
  // count the vertex once each and make no polygon (what walk, runs_from_fan and emit would find).
  void two_runs() {
    if (degree_ == 0 || span_begin_[0] >= labels_.size())
      throw OptionError("coarsen: the topology was not built for this mesh");
    const uint32_t a = labels_[span_begin_[0]];
    uint32_t b = a;
    for (uint32_t s = 0; s < degree_; ++s) {
      const uint32_t f = span_begin_[s];
      if (f >= labels_.size() || corner_of(tri(f), v_) == 3)
        throw OptionError("coarsen: the topology was not built for this mesh");
      if (labels_[f] != a) b = labels_[f];
    }
    if (b == a) throw OptionError("coarsen: the topology was not built for this mesh");
    ++out_.vertices[a];
    ++out_.vertices[b];
  }

  void runs_from_fan() {
    runs_.clear();
    for (uint32_t g : fan_)
      if (runs_.empty() || runs_.back() != labels_[g]) runs_.push_back(labels_[g]);
    if (closed_ && runs_.size() > 1 && runs_.front() == runs_.back()) runs_.pop_back();
  }

  void emit() {
    size_t n = runs_.size();
    for (uint32_t c : runs_) {
      if (cluster_seen_at_[c] == v_) {
        out_.pinched[c] = 1;  // the cluster's faces around v are not one wedge
      } else {
        cluster_seen_at_[c] = v_;
        ++out_.vertices[c];
      }
    }
    if (closed_) {
      if (n < 3) return;  // inside a cluster, or in the middle of a border chain
      for (size_t i = 0; i < n; ++i) out_.chain_ends.push_back(undirected_key(runs_[i], runs_[(i + 1) % n]));
    } else {
      for (size_t i = 0; i + 1 < n; ++i) out_.chain_ends.push_back(undirected_key(runs_[i], runs_[i + 1]));
      if (n >= 2 && runs_.front() != runs_.back()) {
        // The boundary enters v along the last face's edge and leaves along the first face's.
        out_.boundary_steps.push_back(directed_key(runs_.back(), runs_.front()));
        ++out_.boundary_ends[runs_.back()];
        ++out_.boundary_ends[runs_.front()];
      }
      if (n < 3) return;
    }
    out_.polygon_clusters.insert(out_.polygon_clusters.end(), runs_.begin(), runs_.end());
    out_.polygon_offsets.push_back(uint32_t(out_.polygon_clusters.size()));
  }

  const Mesh& mesh_;
  const Topology& topology_;
  const std::vector<uint32_t>& labels_;
  const DualStructure& in_;
  DualStructure& out_;
  std::vector<uint32_t> cluster_seen_at_;  // per cluster: the last vertex that counted it
  const bool one_fan_each_;                // every vertex's faces are one fan, open or closed
  uint32_t v_ = 0, degree_ = 0;
  const uint32_t* span_begin_ = nullptr;
  std::vector<uint8_t> visited_;
  std::vector<uint32_t> fan_, back_, runs_;
  bool closed_ = false;
};

// The vertex pass in chunks of vertices that the threads of run() take in turn, so the one that
// finishes its other work first does more of it; the chunks' records are put back in vertex
// order afterwards (merge_vertex_pass), so the dual does not depend on who walked what.
struct VertexChunks {
  struct Record {
    uint32_t part;                                           // whose output holds it
    size_t chain_ends, boundary_steps, polygons, clusters;  // that output's sizes after it
  };
  explicit VertexChunks(size_t vertices) : count((vertices + kVertexChunk - 1) / kVertexChunk), records(count) {}
  size_t count;
  std::atomic<size_t> next{0};
  std::vector<Record> records;
};

// Vertices inside one cluster only count for its V; the others (on a cluster border, about a
// tenth) walk their fans, but for those between two clusters on a mesh of closed fans (most of
// them: 2.2 -> 1.2 ms of bunny00 -> 500's walk). Vertex order: in most files it follows face
// order closely enough that the walks' reads of faces, neighbours and labels stay in cache.
// Takes chunks until none is left; writes the vertex pass's fields of `out` (part `part`).
void walk_vertices(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                   const DualStructure& faces_pass, DualStructure& out, uint32_t part, VertexChunks& chunks) {
  FanWalker walker(mesh, topology, labels, faces_pass, out);
  const size_t vertices = mesh.vertex_count();
  for (size_t k; (k = chunks.next.fetch_add(1, std::memory_order_relaxed)) < chunks.count;) {
    for (size_t v = k * kVertexChunk; v < std::min(vertices, (k + 1) * kVertexChunk); ++v) {
      uint32_t state = faces_pass.vertex_state[v];
      if (state == kUnset) continue;  // unreferenced, or in collapsed faces only
      if (state != kSeveral)
        ++out.vertices[state];
      else
        walker.vertex(uint32_t(v));
    }
    chunks.records[k] = {part, out.chain_ends.size(), out.boundary_steps.size(), out.polygon_offsets.size() - 1,
                         out.polygon_clusters.size()};
  }
}

// Puts the chunks that part 1 walked (into `other`) back in vertex order among part 0's (in dual).
void merge_vertex_pass(DualStructure& dual, const DualStructure& other, const VertexChunks& chunks) {
  for (size_t c = 0; c < dual.vertices.size(); ++c) {
    dual.vertices[c] += other.vertices[c];
    dual.boundary_ends[c] += other.boundary_ends[c];
    dual.pinched[c] |= other.pinched[c];
  }
  const DualStructure* parts[2] = {&dual, &other};
  DualStructure merged;
  merged.polygon_offsets.reserve(dual.polygon_offsets.size() + other.polygon_offsets.size());
  VertexChunks::Record at[2] = {};  // each part's records up to here
  for (size_t k = 0; k < chunks.count; ++k) {
    const VertexChunks::Record& end = chunks.records[k];
    VertexChunks::Record& begin = at[end.part];
    const DualStructure& from = *parts[end.part];
    merged.chain_ends.insert(merged.chain_ends.end(), from.chain_ends.begin() + begin.chain_ends,
                             from.chain_ends.begin() + end.chain_ends);
    merged.boundary_steps.insert(merged.boundary_steps.end(), from.boundary_steps.begin() + begin.boundary_steps,
                                 from.boundary_steps.begin() + end.boundary_steps);
    const uint32_t shift = uint32_t(merged.polygon_clusters.size() - begin.clusters);
    for (size_t p = begin.polygons; p < end.polygons; ++p)
      merged.polygon_offsets.push_back(from.polygon_offsets[p + 1] + shift);
    merged.polygon_clusters.insert(merged.polygon_clusters.end(), from.polygon_clusters.begin() + begin.clusters,
                                   from.polygon_clusters.begin() + end.clusters);
    begin = end;
  }
  dual.chain_ends.swap(merged.chain_ends);
  dual.boundary_steps.swap(merged.boundary_steps);
  dual.polygon_offsets.swap(merged.polygon_offsets);
  dual.polygon_clusters.swap(merged.polygon_clusters);
}

void init_dual(DualStructure& dual, uint32_t clusters) {
  dual.all_faces.assign(clusters, 0);
  dual.faces.assign(clusters, 0);
  dual.border_half_edges.assign(clusters, 0);
  dual.vertices.assign(clusters, 0);
  dual.boundary_ends.assign(clusters, 0);
  dual.components.assign(clusters, 0);
  dual.pinched.assign(clusters, 0);
  // A disk-like clustering of a closed surface has about 2 corner vertices per cluster (the dual's
  // triangles), each with 3 runs and 3 chain ends: room for that, not a series of regrowths.
  dual.polygon_offsets.reserve(2 * size_t(clusters) + 1);
  dual.polygon_clusters.reserve(6 * size_t(clusters));
  dual.chain_ends.reserve(6 * size_t(clusters));
}

// dual.chain_ends sorted.
void cluster_defects(const DualStructure& dual, std::vector<DualDefect>& defects) {
  uint32_t clusters = uint32_t(dual.faces.size());
  for (uint32_t i = 0; i < clusters; ++i) {
    if (dual.all_faces[i] == 0) {
      defects.push_back({DualDefect::empty_cluster, i, kNone, kNone});
      continue;
    }
    // 2 chi = 2V - 2E + 2F with 2E = 3F + B.
    int64_t twice_chi = 2 * int64_t(dual.vertices[i]) - int64_t(dual.faces[i]) - int64_t(dual.border_half_edges[i]);
    if (dual.faces[i] == 0 || dual.components[i] != 1 || dual.pinched[i] || twice_chi != 2)
      defects.push_back({DualDefect::cluster_not_disk, i, kNone, kNone});
    if (dual.boundary_ends[i] > 2) defects.push_back({DualDefect::boundary_arcs, i, kNone, kNone});
  }
  // A border chain has two ends; more than two ends between the same pair means separate borders.
  const std::vector<uint64_t>& ends = dual.chain_ends;
  assert(std::is_sorted(ends.begin(), ends.end()));
  for (size_t i = 0; i < ends.size();) {
    size_t j = i;
    while (j < ends.size() && ends[j] == ends[i]) ++j;
    if (j - i > 2) defects.push_back({DualDefect::double_border, key_high(ends[i]), key_low(ends[i]), kNone});
    i = j;
  }
}

// The pairs of adjacent clusters (undirected keys, sorted, each once): those with a border chain
// or a boundary step between them. dual.chain_ends sorted.
std::vector<uint64_t> dual_edges(const DualStructure& dual, uint32_t clusters) {
  std::vector<uint64_t> edges;
  edges.reserve(dual.chain_ends.size() / 2);
  std::unique_copy(dual.chain_ends.begin(), dual.chain_ends.end(), std::back_inserter(edges));
  if (dual.boundary_steps.empty()) return edges;
  std::vector<uint64_t> steps;
  steps.reserve(dual.boundary_steps.size());
  for (uint64_t step : dual.boundary_steps) steps.push_back(undirected_key(key_high(step), key_low(step)));
  std::vector<uint32_t> offsets;
  sort_by_cluster(steps, clusters, [](uint64_t k) { return key_high(k); }, std::less<uint64_t>(), offsets);
  std::vector<uint64_t> merged;
  merged.reserve(edges.size() + steps.size());
  std::merge(edges.begin(), edges.end(), steps.begin(), steps.end(), std::back_inserter(merged));
  merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
  return merged;
}

// ---- n-gon triangulation

class PolygonTriangulator {
 public:
  // dual_edges: sorted, each once.
  PolygonTriangulator(const std::vector<float>& positions, std::vector<uint64_t> dual_edges)
      : positions_(positions), dual_edges_(std::move(dual_edges)), first_diagonal_(positions.size() / 3, kNone) {
    assert(std::adjacent_find(dual_edges_.begin(), dual_edges_.end(), std::greater_equal<uint64_t>()) ==
           dual_edges_.end());
  }

  uint64_t polygons_triangulated = 0;

  // Triangulates the polygon q[0..n) (clusters in fan order) into `triangles`. A cluster repeated in
  // the polygon (a pinched cluster) splits it into simple polygons at the repeats first.
  void polygon(const uint32_t* q, size_t n, std::vector<uint32_t>& triangles) {
    if (n == 3 && q[0] != q[1] && q[1] != q[2] && q[0] != q[2]) {  // most corners: what the rest gives
      triangles.insert(triangles.end(), {q[0], q[1], q[2]});
      return;
    }
    stack_.clear();
    for (size_t i = 0; i < n; ++i) {
      auto it = std::find(stack_.begin(), stack_.end(), q[i]);
      if (it == stack_.end()) {
        stack_.push_back(q[i]);
        continue;
      }
      // q[i] closes the loop it..end: that part is a polygon of its own.
      simple_.assign(it, stack_.end());
      simple_polygon(triangles);
      stack_.erase(it + 1, stack_.end());
    }
    simple_ = stack_;
    simple_polygon(triangles);
  }

 private:
  struct Score {
    uint32_t bad = 0;   // diagonals that are already edges of the dual
    double angle = 0;   // smallest angle of the triangles
  };
  static bool better(const Score& a, const Score& b) {
    return a.bad < b.bad || (a.bad == b.bad && a.angle > b.angle);
  }
  const float* at(uint32_t cluster) const { return &positions_[3 * size_t(cluster)]; }
  bool existing_edge(uint32_t a, uint32_t b) const {
    uint64_t key = undirected_key(a, b);
    return std::binary_search(dual_edges_.begin(), dual_edges_.end(), key) || chosen_diagonal(a, b);
  }

  // The diagonals chosen so far: per smaller cluster, a list of the larger ones. (A few per
  // polygon; a hash set's node per key cost more than the lookups.)
  bool chosen_diagonal(uint32_t a, uint32_t b) const {
    if (a > b) std::swap(a, b);
    for (uint32_t d = first_diagonal_[a]; d != kNone; d = diagonals_[d].next)
      if (diagonals_[d].other == b) return true;
    return false;
  }
  void add_diagonal(uint32_t a, uint32_t b) {
    if (chosen_diagonal(a, b)) return;
    if (a > b) std::swap(a, b);
    diagonals_.push_back({b, first_diagonal_[a]});
    first_diagonal_[a] = uint32_t(diagonals_.size() - 1);
  }

  void simple_polygon(std::vector<uint32_t>& triangles) {
    const std::vector<uint32_t>& q = simple_;
    uint32_t n = uint32_t(q.size());
    if (n < 3) return;  // two clusters: an edge, no triangle
    if (n == 3) {
      triangles.insert(triangles.end(), {q[0], q[1], q[2]});
      return;
    }
    ++polygons_triangulated;
    if (n > kMaxDynamicProgramming) {
      for (uint32_t k = 1; k + 1 < n; ++k) {
        triangles.insert(triangles.end(), {q[0], q[k], q[k + 1]});
        if (k >= 2) add_diagonal(q[0], q[k]);
      }
      return;
    }
    // best[i][j]: the best triangulation of the sub-polygon q[i..j] closed by the edge (i, j);
    // every triangulation of q contains the polygon edge (0, n-1), so best[0][n-1] is the answer.
    best_.assign(size_t(n) * n, Score{});
    split_.assign(size_t(n) * n, 0);
    for (uint32_t length = 2; length < n; ++length) {
      for (uint32_t i = 0; i + length < n; ++i) {
        uint32_t j = i + length;
        Score chosen{~0u, -1.0};
        uint32_t chosen_k = i + 1;
        for (uint32_t k = i + 1; k < j; ++k) {
          Score s{0, smallest_angle(at(q[i]), at(q[k]), at(q[j]))};
          if (k - i >= 2) {  // (i, k) is a diagonal
            const Score& left = best_[size_t(i) * n + k];
            s.bad += left.bad + existing_edge(q[i], q[k]);
            s.angle = std::min(s.angle, left.angle);
          }
          if (j - k >= 2) {
            const Score& right = best_[size_t(k) * n + j];
            s.bad += right.bad + existing_edge(q[k], q[j]);
            s.angle = std::min(s.angle, right.angle);
          }
          if (better(s, chosen)) {
            chosen = s;
            chosen_k = k;
          }
        }
        best_[size_t(i) * n + j] = chosen;
        split_[size_t(i) * n + j] = chosen_k;
      }
    }
    pending_.assign(1, {0, n - 1});
    while (!pending_.empty()) {
      auto [i, j] = pending_.back();
      pending_.pop_back();
      uint32_t k = split_[size_t(i) * n + j];
      triangles.insert(triangles.end(), {q[i], q[k], q[j]});
      if (k - i >= 2) {
        add_diagonal(q[i], q[k]);
        pending_.push_back({i, k});
      }
      if (j - k >= 2) {
        add_diagonal(q[k], q[j]);
        pending_.push_back({k, j});
      }
    }
  }

  const std::vector<float>& positions_;
  std::vector<uint64_t> dual_edges_;         // sorted: pairs of clusters with a border chain or boundary step
  struct Diagonal {
    uint32_t other, next;  // the larger cluster; the smaller cluster's next diagonal or kNone
  };
  std::vector<uint32_t> first_diagonal_;     // per cluster, kNone when none
  std::vector<Diagonal> diagonals_;
  std::vector<uint32_t> stack_, simple_;
  std::vector<Score> best_;
  std::vector<uint32_t> split_;
  std::vector<std::pair<uint32_t, uint32_t>> pending_;
};

// ---- checks on the output triangles

// Drops same-orientation copies of a triangle (keeping the first), reports opposite-orientation
// copies. Returns the number dropped.
uint64_t merge_duplicates(std::vector<uint32_t>& triangles, uint32_t clusters, std::vector<DualDefect>& defects) {
  struct Entry {
    uint32_t a, b, c, index;
  };
  size_t count = triangles.size() / 3;
  std::vector<Entry> entries(count);
  for (size_t t = 0; t < count; ++t) {
    uint32_t a = triangles[3 * t], b = triangles[3 * t + 1], c = triangles[3 * t + 2];
    // Rotate the smallest id first: keeps the orientation, makes equal triangles equal.
    if (b < a && b < c)
      entries[t] = {b, c, a, uint32_t(t)};
    else if (c < a && c < b)
      entries[t] = {c, a, b, uint32_t(t)};
    else
      entries[t] = {a, b, c, uint32_t(t)};
  }
  auto less = [](const Entry& x, const Entry& y) {
    if (x.a != y.a) return x.a < y.a;
    if (x.b != y.b) return x.b < y.b;
    if (x.c != y.c) return x.c < y.c;
    return x.index < y.index;
  };
  std::vector<uint32_t> offsets;  // entries of smallest cluster a: offsets[a]..offsets[a + 1]
  sort_by_cluster(entries, clusters, [](const Entry& e) { return e.a; }, less, offsets);
  std::vector<uint8_t> drop(count, 0);
  uint64_t dropped = 0;
  for (size_t k = 1; k < entries.size(); ++k) {
    const Entry &p = entries[k - 1], &e = entries[k];
    if (p.a == e.a && p.b == e.b && p.c == e.c) {
      drop[e.index] = 1;
      ++dropped;
    }
  }
  for (const Entry& e : entries) {
    if (e.b > e.c || drop[e.index]) continue;  // look for (a, c, b) from the (a, b, c) side only
    Entry reversed{e.a, e.c, e.b, 0};
    auto end = entries.begin() + offsets[e.a + 1];
    auto it = std::lower_bound(entries.begin() + offsets[e.a], end, reversed, less);
    if (it != end && it->b == e.c && it->c == e.b)
      defects.push_back({DualDefect::duplicate_triangle, e.a, e.b, e.c});
  }
  if (dropped) {
    size_t kept = 0;
    for (size_t t = 0; t < count; ++t) {
      if (drop[t]) continue;
      for (int k = 0; k < 3; ++k) triangles[3 * kept + k] = triangles[3 * t + k];
      ++kept;
    }
    triangles.resize(3 * kept);
  }
  return dropped;
}

// Edge checks; returns the number of boundary edges (edges of one triangle).
uint64_t check_edges(const std::vector<uint32_t>& triangles, uint32_t clusters,
                     const std::vector<uint64_t>& boundary_steps, std::vector<DualDefect>& defects) {
  // undirected_key << 1 | direction (cluster ids are below 2^31), so the copies of an edge sort
  // together; bucketed by the edge's smaller cluster, the key's top bits.
  std::vector<uint64_t> edges;
  edges.reserve(triangles.size());
  for (size_t t = 0; t < triangles.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      uint32_t from = triangles[t + k], to = triangles[t + (k + 1) % 3];
      edges.push_back(undirected_key(from, to) << 1 | uint64_t(from < to));
    }
  std::vector<uint32_t> offsets;
  sort_by_cluster(edges, clusters, [](uint64_t e) { return uint32_t(e >> 33); }, std::less<uint64_t>(), offsets);
  uint64_t boundary = 0;
  for (size_t i = 0; i < edges.size();) {
    const uint64_t key = edges[i] >> 1;
    size_t j = i;
    while (j < edges.size() && edges[j] >> 1 == key) ++j;
    uint32_t a = key_high(key), b = key_low(key);
    if (j - i == 1) ++boundary;
    if (j - i > 2) defects.push_back({DualDefect::nonmanifold_output, a, b, kNone});
    if (j - i == 2 && (edges[i] & 1) == (edges[i + 1] & 1))
      defects.push_back({DualDefect::inconsistent_orientation, a, b, kNone});
    i = j;
  }
  // Each step of an input boundary loop needs an output edge of exactly one triangle. An edge of
  // two is a loop closed over: two clusters alone along a hole (A -> B -> A) give the steps of both
  // directions one edge, which both their triangles share, and the hole disappears.
  for (uint64_t step : boundary_steps) {
    uint32_t from = key_high(step), to = key_low(step);
    const uint64_t key = undirected_key(from, to);
    auto end = edges.begin() + offsets[key_high(key) + 1];
    auto it = std::lower_bound(edges.begin() + offsets[key_high(key)], end, key << 1);
    if (it == end || *it >> 1 != key || (it + 1 != end && it[1] >> 1 == key))
      defects.push_back({DualDefect::missing_boundary_edge, from, to, kNone});
  }
  return boundary;
}

void check_degenerate(const std::vector<uint32_t>& triangles, const std::vector<float>& positions,
                      std::vector<DualDefect>& defects) {
  for (size_t t = 0; t < triangles.size(); t += 3) {
    const float* p[3];
    for (int k = 0; k < 3; ++k) p[k] = &positions[3 * size_t(triangles[t + k])];
    double u[3], w[3], longest2 = 0;
    for (int d = 0; d < 3; ++d) {
      u[d] = double(p[1][d]) - p[0][d];
      w[d] = double(p[2][d]) - p[0][d];
    }
    for (int k = 0; k < 3; ++k) {
      double e2 = 0;
      for (int d = 0; d < 3; ++d) {
        double x = double(p[(k + 1) % 3][d]) - p[k][d];
        e2 += x * x;
      }
      longest2 = std::max(longest2, e2);
    }
    double cross[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    double twice_area = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    // twice_area / longest^2 is at most the sine of the smallest angle (times a factor <= 2/sqrt3).
    if (!(twice_area > kDegenerateSine * longest2))
      defects.push_back({DualDefect::degenerate_triangle, triangles[t], triangles[t + 1], triangles[t + 2]});
  }
}

void sort_defects(std::vector<DualDefect>& defects) {
  auto less = [](const DualDefect& x, const DualDefect& y) {
    if (x.kind != y.kind) return x.kind < y.kind;
    if (x.cluster != y.cluster) return x.cluster < y.cluster;
    if (x.other != y.other) return x.other < y.other;
    return x.third < y.third;
  };
  std::sort(defects.begin(), defects.end(), less);
  defects.erase(std::unique(defects.begin(), defects.end()), defects.end());
}

// vertex_faces: when not null, the face under each vertex where the placement knows it (see
// detail::place_cluster_vertices).
// own_planes_only: qem only, when not null: clusters (flag 1) whose point ignores the planes lent
// across their border; with flag 2, clusters whose point is instead surface_points' (3 per
// cluster), before the polygons are triangulated.
// centroids_out: when not null, the clusters' mass centroids (3 per cluster).
CoarsenResult build_dual(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                         uint32_t clusters, const CoarsenOptions& options, const std::vector<float>* face_weights,
                         std::vector<uint32_t>* vertex_faces, const std::vector<uint8_t>* own_planes_only,
                         std::vector<double>* centroids_out, const std::vector<float>* surface_points = nullptr) {
  check_topology(mesh, topology, clusters);
  check_placement_inputs(mesh, labels, clusters, face_weights);
  DualStructure dual;
  init_dual(dual, clusters);
  // Two halves of similar cost side by side: the face pass of the dual; the mass centroids and the
  // vertex placement (closest's after the face pass, whose vertex states it reads). Then both take
  // chunks of the vertex pass, which needs the face pass, until none is left: on meshes in no
  // useful order the face pass alone outlasts the other half (bunny00 -> 500: 1.8 against 1.0 ms
  // on one thread). Each writes its own arrays, so the result is the same whether they run side by
  // side or one after the other.
  std::vector<double> centroids;
  std::vector<float> positions;
  const bool place_beside = options.placement != VertexPlacement::closest;
  const std::vector<uint32_t> no_vertex_states;
  VertexChunks chunks(mesh.vertex_count());
  auto other_half = [&](unsigned place_threads) {
    centroids = detail::mass_centroids(mesh, labels, clusters, face_weights);
    if (place_beside)
      positions = detail::place_cluster_vertices(mesh, &topology, labels, clusters, options.placement, face_weights,
                                                 no_vertex_states, centroids, place_threads, vertex_faces,
                                                 own_planes_only);
  };
  auto place_on_vertex_states = [&](unsigned place_threads) {
    if (!place_beside)
      positions = detail::place_cluster_vertices(mesh, &topology, labels, clusters, options.placement, face_weights,
                                                 dual.vertex_state, centroids, place_threads, vertex_faces,
                                                 own_planes_only);
  };
  if (options.threads == 1 || mesh.face_count() < kMinParallelHalves) {
    count_faces(mesh, topology, labels, dual);
    walk_vertices(mesh, topology, labels, dual, dual, 0, chunks);
    other_half(options.threads);
    place_on_vertex_states(options.threads);
  } else {
    // The dual's half keeps a core; the placement may spread over the others.
    const unsigned cores = options.threads == 0 ? std::thread::hardware_concurrency() : options.threads;
    const unsigned place_threads = std::max(cores, 2u) - 1;
    DualStructure other_walks;  // the vertex pass's records of the chunks the second thread took
    other_walks.vertices.assign(clusters, 0);
    other_walks.boundary_ends.assign(clusters, 0);
    other_walks.pinched.assign(clusters, 0);
    std::atomic<int> face_pass{0};  // 1: done, 2: failed
    std::exception_ptr other_error;
    std::thread other([&] {
      try {
        other_half(place_threads);
        face_pass.wait(0);
        if (face_pass.load() == 1) {
          place_on_vertex_states(place_threads);
          walk_vertices(mesh, topology, labels, dual, other_walks, 1, chunks);
        }
      } catch (...) {
        other_error = std::current_exception();
      }
    });
    try {
      try {
        count_faces(mesh, topology, labels, dual);
      } catch (...) {
        face_pass.store(2);
        face_pass.notify_one();
        throw;
      }
      face_pass.store(1);
      face_pass.notify_one();
      walk_vertices(mesh, topology, labels, dual, dual, 0, chunks);
    } catch (...) {
      other.join();
      throw;
    }
    other.join();
    if (other_error) std::rethrow_exception(other_error);
    if (std::any_of(chunks.records.begin(), chunks.records.end(), [](const auto& r) { return r.part == 1; }))
      merge_vertex_pass(dual, other_walks, chunks);
  }

  if (surface_points && own_planes_only)
    for (uint32_t c = 0; c < clusters; ++c)
      if ((*own_planes_only)[c] == 2)
        for (int d = 0; d < 3; ++d) positions[3 * size_t(c) + d] = (*surface_points)[3 * size_t(c) + d];

  CoarsenResult result;
  std::vector<uint32_t> chain_offsets;
  sort_by_cluster(dual.chain_ends, clusters, [](uint64_t k) { return key_high(k); }, std::less<uint64_t>(),
                  chain_offsets);
  cluster_defects(dual, result.defects);

  PolygonTriangulator triangulator(positions, dual_edges(dual, clusters));
  std::vector<uint32_t> triangles;
  size_t polygons = dual.polygon_offsets.size() - 1;
  triangles.reserve(6 * polygons);
  for (size_t p = 0; p < polygons; ++p) {
    uint32_t begin = dual.polygon_offsets[p], end = dual.polygon_offsets[p + 1];
    triangulator.polygon(&dual.polygon_clusters[begin], end - begin, triangles);
  }
  result.corner_vertices = polygons;
  result.polygons_triangulated = triangulator.polygons_triangulated;
  result.merged_triangles = merge_duplicates(triangles, clusters, result.defects);
  result.boundary_edges = check_edges(triangles, clusters, dual.boundary_steps, result.defects);
  check_degenerate(triangles, positions, result.defects);
  sort_defects(result.defects);

  result.mesh.positions = std::move(positions);
  result.mesh.indices = std::move(triangles);
  if (centroids_out) *centroids_out = std::move(centroids);
  return result;
}

// CoarsenOptions::boundary_onto_input, after the relax: the vertices of the clusters along the
// input's boundary go onto it (coarse_boundary.cpp), the other vertices relax around them again
// (two passes, where relax runs), and those left with a triangle below 30 degrees go back toward
// their placed points. All of it is undone when the coarse mesh's smallest angle then falls below
// min(its value before, 30 degrees) or it has more angles below 30 degrees than before: the
// boundary is worth some Q avg, not the quality columns' limits (bench/RESULTS.md, "Coarsening:
// open surfaces' boundaries": 26 of 84 coarsenings of the open libcgal-demo meshes came out as
// without it, undone or with nothing to move).
void put_boundary_onto_input(CoarsenResult& result, const Mesh& mesh, const Topology& topology,
                             const std::vector<uint32_t>& labels, const CoarsenOptions& options,
                             std::vector<uint32_t>& vertex_faces, bool flat_slivers) {
  Mesh before = result.mesh;  // what an undo restores, and the points the back-off returns toward
  std::vector<uint8_t> moved;
  const detail::BoundarySnapCounts snapped = detail::snap_boundary_vertices(result.mesh, mesh, topology, labels, moved);
  if (snapped.moved == 0) return;
  const TriangleQuality quality_before = triangle_quality(before);
  uint64_t relaxed = 0, flipped = 0, backed_off = 0;
  const uint32_t again = std::min(options.relax_passes, kBoundaryRelaxPasses);
  if (again > 0) {
    relaxed = detail::relax_coarse_vertices(result.mesh, mesh, topology, labels, again, options.relax_max_normal_turn_deg,
                                            &vertex_faces, options.threads);
    if (options.flip_edges)
      flipped += flip_coarse_edges(result.mesh, options.flip_max_dihedral_deg, /*max_passes=*/8, flat_slivers);
  }
  backed_off = detail::back_off_boundary_vertices(result.mesh, before.positions, moved);
  if (backed_off > 0 && options.flip_edges)
    flipped += flip_coarse_edges(result.mesh, options.flip_max_dihedral_deg, /*max_passes=*/8, flat_slivers);
  const TriangleQuality quality_after = triangle_quality(result.mesh);  // (the report's columns)
  if (quality_after.min_angle_deg < std::min(quality_before.min_angle_deg, 30.0) ||
      quality_after.angles_below_30 > quality_before.angles_below_30) {
    result.mesh = std::move(before);
    result.boundary_left_inside = snapped.moved;
    return;
  }
  result.boundary_vertices_moved = snapped.moved;
  result.boundary_corners = snapped.corners;
  result.boundary_backed_off = backed_off;
  result.relaxed_moves += relaxed;
  result.flipped_edges += flipped;
}

// The dual, for `qem` built again when the lent planes gave it degenerate triangles (three
// clusters pulled onto one straight crease make a triangle of no area): those triangles' clusters
// then keep the points of their own planes, as without the lending. Where their own faces straddle
// the crease too (a mesh midpoint-subdivided before the clustering, whose old edges are straight
// creases: the armadillo -> 52000 with qem kept 6 such triangles, and with them no relax, flips
// or fitting, Q avg 0.67), a cluster of each triangle still degenerate takes its `projected` point,
// on the surface, and the dual is built a third time, and a fourth with all three of a triangle
// that still has no area (CoarsenOptions::degenerate_to_surface).
CoarsenResult run(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                  uint32_t clusters, const CoarsenOptions& options, const std::vector<float>* face_weights,
                  std::vector<uint32_t>* vertex_faces = nullptr, std::vector<double>* centroids = nullptr) {
  std::vector<double> own_centroids;
  if (!centroids) centroids = &own_centroids;
  CoarsenResult result =
      build_dual(mesh, topology, labels, clusters, options, face_weights, vertex_faces, nullptr, centroids);
  if (options.placement != VertexPlacement::qem) return result;
  std::vector<uint8_t> flags(clusters, 0);
  // Flags the clusters of the degenerate triangles with `flag`; whether there was one.
  auto flag_degenerate = [&](const CoarsenResult& r, uint8_t flag) {
    bool any = false;
    for (const DualDefect& d : r.defects)
      if (d.kind == DualDefect::degenerate_triangle) {
        any = true;
        for (uint32_t v : {d.cluster, d.other, d.third})
          if (v < clusters) flags[v] = flag;
      }
    return any;
  };
  if (!flag_degenerate(result, 1)) return result;
  result = build_dual(mesh, topology, labels, clusters, options, face_weights, vertex_faces, &flags, centroids);
  if (!options.degenerate_to_surface ||
      std::none_of(result.defects.begin(), result.defects.end(),
                   [](const DualDefect& d) { return d.kind == DualDefect::degenerate_triangle; }))
    return result;
  const std::vector<float> surface =
      detail::place_cluster_vertices(mesh, &topology, labels, clusters, VertexPlacement::projected, face_weights, {},
                                     *centroids, options.threads, nullptr, nullptr);
  // One cluster per triangle first, the one whose projected point gives the triangle the largest
  // area with the other two points (the other two keep their points on the crease); all three of
  // a triangle that is still degenerate then.
  for (const DualDefect& d : result.defects) {
    if (d.kind != DualDefect::degenerate_triangle) continue;
    const uint32_t corner[3] = {d.cluster, d.other, d.third};
    if (corner[0] >= clusters || corner[1] >= clusters || corner[2] >= clusters) continue;
    double best_area = -1;
    uint32_t best = corner[0];
    for (int k = 0; k < 3; ++k) {
      double p[3][3];
      for (int j = 0; j < 3; ++j) {
        const std::vector<float>& from = j == k ? surface : result.mesh.positions;
        for (int e = 0; e < 3; ++e) p[j][e] = from[3 * size_t(corner[j]) + e];
      }
      const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
      const double w[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
      const double c[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
      const double area2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
      if (area2 > best_area) best_area = area2, best = corner[k];
    }
    flags[best] = 2;
  }
  CoarsenResult moved =
      build_dual(mesh, topology, labels, clusters, options, face_weights, vertex_faces, &flags, centroids, &surface);
  if (flag_degenerate(moved, 2))
    moved = build_dual(mesh, topology, labels, clusters, options, face_weights, vertex_faces, &flags, centroids,
                       &surface);
  moved.surface_points = uint64_t(std::count(flags.begin(), flags.end(), uint8_t(2)));
  return moved;
}

}  // namespace

CoarsenResult coarsen_clustering(const Mesh& mesh, const Topology& topology, const std::vector<uint32_t>& labels,
                                 uint32_t clusters, const CoarsenOptions& options,
                                 const std::vector<float>* face_weights) {
  detail::check_fit_angles(options);
  std::vector<uint32_t> vertex_faces;
  std::vector<double> centroids;
  CoarsenResult result = run(mesh, topology, labels, clusters, options, face_weights, &vertex_faces, &centroids);
  // qem: the clusters' projected points, on the surface, toward which qem points that fold or thin
  // triangles move (coarse_toward_surface.cpp): first those whose triangles turned over, so that
  // relax and the fitting start from a mesh without folds.
  std::vector<float> surface;
  if (options.placement == VertexPlacement::qem && result.defects.empty()) {
    surface = detail::place_cluster_vertices(mesh, &topology, labels, clusters, VertexPlacement::projected,
                                             face_weights, {}, centroids, options.threads, nullptr, nullptr);
    result.unfolded_vertices = detail::unfold_toward_surface(result.mesh, surface);
  }
  // Flips need a clean manifold dual: with defects, edges may have more than two triangles.
  // Flips across slivers' pairs (flat_slivers) for the placements on the surface only: with qem
  // they were a wash on the 69 libcgal-demo meshes (angles below 30 2500 -> 2492, but mask_cone's
  // smallest angle 15.7 -> 12.2 degrees and rotor_small's RMS +9%), and the elephant of tests/data
  // at 100 ended at 8.4 degrees instead of 11.5.
  const bool flat_slivers = options.placement != VertexPlacement::qem;
  if (options.flip_edges && result.defects.empty())
    result.flipped_edges = flip_coarse_edges(result.mesh, options.flip_max_dihedral_deg, /*max_passes=*/8, flat_slivers);
  if (options.relax_passes > 0 && result.defects.empty()) {
    result.relaxed_moves = detail::relax_coarse_vertices(result.mesh, mesh, topology, labels, options.relax_passes,
                                                         options.relax_max_normal_turn_deg, &vertex_faces, options.threads);
    if (options.flip_edges && result.relaxed_moves > 0)
      result.flipped_edges += flip_coarse_edges(result.mesh, options.flip_max_dihedral_deg, /*max_passes=*/8, flat_slivers);
  }
  if (options.boundary_onto_input && result.defects.empty() && topology.boundary_edges > 0)
    put_boundary_onto_input(result, mesh, topology, labels, options, vertex_faces, flat_slivers);
  if (options.placement == VertexPlacement::qem && result.defects.empty()) {
    const detail::FitCounts fit =
        detail::fit_coarse_mesh(result.mesh, mesh, labels, options.fit_passes, options.fit_swaps,
                                options.fit_swap_min_angle_deg, options.threads);
    result.fitted_moves = fit.moves;
    result.swapped_edges = fit.swaps;
    // The fit's swaps keep each new pair facing the side of the old one, but a new triangle can
    // still face against itself on the projected points (the elephant of tests/data at 80).
    result.unfolded_vertices += detail::unfold_toward_surface(result.mesh, surface);
    if (options.fit_min_angle_deg > 0)
      result.angle_floor_moves = detail::widen_toward_surface(result.mesh, surface, options.fit_min_angle_deg, mesh, labels);
    // Last, the slivers' flips alone. The fitting pulls points onto creases, and three of them in
    // a row along one leave a cap between them that no move widens; the flip of its long edge
    // sweeps almost no volume, so the distance to the input barely moves (fandisk -> 6000: smallest
    // angle 0.76 -> 16.6 degrees, angles below 30 81 -> 51, RMS +0.3%, Hausdorff the same: 55
    // flips). A dihedral allowance of 0 flips nothing else but pairs in one plane to the last
    // bit, whose flip moves no surface. At faces / 40 no libcgal-demo mesh changes.
    if (options.flip_edges)
      result.flipped_edges += flip_coarse_edges(result.mesh, 0.0, /*max_passes=*/8, /*flat_slivers=*/true);
  }
  return result;
}

std::vector<DualDefect> find_dual_defects(const Mesh& mesh, const Topology& topology,
                                          const std::vector<uint32_t>& labels, uint32_t clusters,
                                          const CoarsenOptions& options, const std::vector<float>* face_weights) {
  return run(mesh, topology, labels, clusters, options, face_weights).defects;
}

const char* to_string(DualDefect::Kind k) {
  switch (k) {
    case DualDefect::cluster_not_disk: return "cluster_not_disk";
    case DualDefect::boundary_arcs: return "boundary_arcs";
    case DualDefect::double_border: return "double_border";
    case DualDefect::duplicate_triangle: return "duplicate_triangle";
    case DualDefect::nonmanifold_output: return "nonmanifold_output";
    case DualDefect::inconsistent_orientation: return "inconsistent_orientation";
    case DualDefect::missing_boundary_edge: return "missing_boundary_edge";
    case DualDefect::degenerate_triangle: return "degenerate_triangle";
    case DualDefect::empty_cluster: return "empty_cluster";
  }
  return "?";
}

}  // namespace meshcvt
