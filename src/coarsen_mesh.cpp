// meshcvt: coarsening as one job with a valid result (Fan et al. Section 6.1; API in
// meshcvt/coarsen.h): clusters shared among the mesh components, the CVT clustering, a loop that
// fixes the clustering wherever its dual would not be a manifold, then the dual mesh.
//
// Why the clustering is fixed, not the mesh: the dual of a clustering is a closed manifold with the
// input's Euler characteristic when the clusters form a proper cell decomposition of the surface:
// every cluster a disk meeting the boundary in at most one arc, two clusters sharing at most one
// border, every cluster with three neighbours or more (with two, the triangle of its two corners
// comes out twice). Then clusters, borders and corners are the faces, edges and vertices of a map
// on the surface, V - E + F is the surface's chi, and the dual (corners -> polygons) has the same
// chi. find_dual_defects names the clusters that break this. One more condition lives at the
// corners where four or more clusters meet: coarsen_clustering triangulates their polygon, and
// where every diagonal it could take is already an edge of the dual (or another corner's only
// diagonal), that edge gets three or more triangles (nonmanifold_output) although every cluster is
// fit. Merges check it (CornerPolygons); cuts of a cluster cannot see it.
//
// Fixes, in rounds (fix_round):
//  - a double border roughened by the iteration (a face of a third cluster poking between the two)
//    loses that face to one of the two, when every cluster it changes stays fit;
//  - otherwise the offending cluster is cut (ClusterCutter) so that every piece is a disk meeting
//    one arc / sharing one border: in two, or in three for a ring around a handle (two halves of a
//    ring share two borders). For each extra piece, to keep exactly n clusters, the adjacent pair of
//    the same component whose merge raises the CVT energy least is merged (MergeFinder); for the cvt
//    energy that increase is exactly W_a W_b / (W_a + W_b) |c_a - c_b|^2, and the merged cluster
//    must be fit too. Cuts and merges are scored by RegionCheck (connected, V - E + F = 1, one arc
//    along the boundary, one border with each neighbour, enough neighbours).
// The rounds run on the labels without iterating in between: measured on the elephant, iterating
// after every round undoes the fixes (the energy prefers rings around thin limbs) and never
// settles, while fix-only rounds converge. Rounds that come back to labels they had before stop
// (they would repeat the cycle: a cut undone by a later merge, as on the elephant at n = 20 when
// merges did not check the corners). Once valid, the iteration smooths the fixed clusters
// (FixLoop): fully, or if that brings defects back that the rounds cannot remove, in steps that
// each keep the clustering valid.
//
// When the rounds cannot clean a component (a ring around a handle whose two sides touch the same
// cluster; a small component with no cluster to spare), a valid clustering at 2n, 4n, ... clusters,
// where the parts are resolved, is merged back to n (merge_down) with merges that keep the dual
// valid (the link condition of an edge contraction, and corner polygons that stay triangulable),
// and replaces that component. Close to the fewest vertices a surface allows, greedy merging stops
// above n at an irreducible triangulation (every merge would pinch the surface); edge flips
// (flip_then_merge: a strip of faces along a border handed to a cluster at its end) then open a
// merge again. Last, a small component may start from one cluster per face (valid on a manifold)
// merged down the same way.
// Every stage keeps the labels with the fewest defects, so the job always ends; what cannot be
// fixed is reported (CoarsenMeshResult::defects_remain).
//
// A cut is chosen among candidates: the planes through the mass centroid normal to each principal
// axis; two halves grown breadth-first from far-apart faces (of the whole cluster, of its faces next
// to the other cluster of a double border, of its faces on the boundary); for three pieces, sectors
// around each principal axis, thirds grown from three far-apart faces, and sectors along each
// border loop of the cluster (what cuts a ring across, from one of its sides to the other).
#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <optional>
#include <queue>
#include <span>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "coarse_fit.h"
#include "symmetric_eigen3.h"
#include "vec3.h"

namespace meshcvt {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

bool is_collapsed(const uint32_t* t) { return t[0] == t[1] || t[1] == t[2] || t[0] == t[2]; }


void check_density(const Mesh& mesh, const std::vector<float>* density) {
  if (!density || density->empty()) return;
  if (density->size() != mesh.face_count())
    throw OptionError("coarsen: the density has " + std::to_string(density->size()) + " entries for " +
                      std::to_string(mesh.face_count()) + " faces");
  for (float d : *density)
    if (!(d > 0) || !std::isfinite(d)) throw OptionError("coarsen: densities must be finite and > 0");
}

// ---- minimum clusters per component

// Fewest vertices of a triangulated closed surface of Euler characteristic chi: Heawood's bound
// (3F = 2E and E <= V(V-1)/2 give V^2 - 7V + 6 chi >= 0), attained by every surface but three.
uint32_t closed_minimum(int64_t chi, bool orientable) {
  if (orientable && chi == -2) return 10;  // genus 2 (Jungerman & Ringel)
  if (!orientable && chi == 0) return 8;   // Klein bottle (Franklin)
  if (!orientable && chi == -1) return 9;  // N3 (Ringel)
  int64_t v = 4;
  while (v * v - 7 * v + 6 * chi < 0) ++v;
  return uint32_t(v);
}

uint32_t surface_minimum(int64_t chi, uint64_t loops, bool manifold, bool orientable) {
  if (!manifold) return loops > 0 ? 3 : 4;
  if (loops == 0) return closed_minimum(chi, orientable);
  // Coning each loop off with a new vertex gives a closed triangulation of chi + loops.
  int64_t capped = int64_t(closed_minimum(chi + int64_t(loops), orientable)) - int64_t(loops);
  return uint32_t(std::max<int64_t>(3 * int64_t(loops), capped));
}

// The faces of each component, in face order, as CSR: component c's are
// faces[offsets[c], offsets[c + 1]).
void component_face_lists(const Topology& topology, std::vector<uint32_t>& offsets, std::vector<uint32_t>& faces) {
  const size_t face_count = topology.face_component.size();
  offsets.assign(size_t(topology.component_count) + 1, 0);
  faces.resize(face_count);
  for (size_t f = 0; f < face_count; ++f) ++offsets[topology.face_component[f] + 1];
  for (uint32_t c = 0; c < topology.component_count; ++c) offsets[c + 1] += offsets[c];
  std::vector<uint32_t> cursor(offsets.begin(), offsets.end() - 1);
  for (size_t f = 0; f < face_count; ++f) faces[cursor[topology.face_component[f]]++] = uint32_t(f);
}

// Faces, chi, loops and the minimum of every component, each component judged on its own.
void fill_components(const Mesh& mesh, const Topology& topology, ComponentAllocation& a) {
  const uint32_t nc = topology.component_count;
  a.minimum.assign(nc, 0);
  a.faces.assign(nc, 0);
  a.euler_characteristic.assign(nc, 0);
  a.boundary_loops.assign(nc, 0);
  a.manifold.assign(nc, 0);
  std::vector<uint32_t> collapsed(nc, 0);
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    uint32_t c = topology.face_component[f];
    ++a.faces[c];
    collapsed[c] += is_collapsed(&mesh.indices[3 * f]);
  }
  auto fill = [&](uint32_t c, const MeshInfo& info) {
    a.euler_characteristic[c] = info.euler_characteristic;
    a.boundary_loops[c] = info.boundary_loops;
    bool manifold = info.nonmanifold_edges == 0 && info.nonmanifold_vertices == 0 && info.collapsed_faces == 0;
    a.manifold[c] = manifold;
    // A component of collapsed faces only (left by welding) has no surface to keep: one cluster.
    a.minimum[c] = collapsed[c] == a.faces[c] ? 1
                                               : surface_minimum(info.euler_characteristic, info.boundary_loops,
                                                                 manifold, info.nonorientable_components == 0);
  };
  if (nc == 1) {
    fill(0, mesh_info(mesh, topology));
    return;
  }
  // Several components: each one copied out and measured alone (O(F + V) in all).
  std::vector<uint32_t> offsets, faces;
  component_face_lists(topology, offsets, faces);
  std::vector<uint32_t> vertex_map(mesh.vertex_count(), kNone), used;
  for (uint32_t c = 0; c < nc; ++c) {
    Mesh part;
    for (uint32_t i = offsets[c]; i < offsets[c + 1]; ++i)
      for (int k = 0; k < 3; ++k) {
        uint32_t v = mesh.indices[3 * size_t(faces[i]) + k];
        if (vertex_map[v] == kNone) {
          vertex_map[v] = uint32_t(part.vertex_count());
          used.push_back(v);
          part.positions.insert(part.positions.end(), &mesh.positions[3 * size_t(v)], &mesh.positions[3 * size_t(v)] + 3);
        }
        part.indices.push_back(vertex_map[v]);
      }
    fill(c, mesh_info(part, build_topology(part)));
    for (uint32_t v : used) vertex_map[v] = kNone;
    used.clear();
  }
}

std::string describe_component(const ComponentAllocation& a, uint32_t c) {
  std::string s = "component " + std::to_string(c) + " (";
  if (!a.manifold[c])
    s += "not a manifold";
  else if (a.boundary_loops[c] == 0)
    s += "closed";
  else
    s += std::to_string(a.boundary_loops[c]) + " boundary loop" + (a.boundary_loops[c] > 1 ? "s" : "");
  s += ", Euler characteristic " + std::to_string(a.euler_characteristic[c]) + ")";
  return s;
}

// ---- the fix loop

// CoarsenMeshOptions::max_face_start_faces, 65536: components up to this many faces, in all, may
// be rebuilt from one cluster per face when nothing else makes them valid (a priority queue over
// their faces and a fitness check per merge): about 1.5 s for polygon_mesh's 32k faces. At 20000
// (until the twenty-second session) polygon_mesh kept 16-26 defects at every count and the split
// cheese (40k faces) 442; this makes both valid. The limit is on the sum, smallest components
// first (until the twenty-fourth session it was per component): the merge's cost grows faster
// than its faces, and forty broken tetrahedra subdivided six times (16k faces each) ran for
// minutes.

// Per-face data of the fixes, computed once: weight w = rho * area and centroid, input units.
struct FaceData {
  std::vector<double> weight;
  std::vector<double> centroid;  // 3 per face
};

FaceData face_data(const Mesh& mesh, const std::vector<float>& density) {
  FaceData d;
  size_t nf = mesh.face_count();
  d.weight.resize(nf);
  d.centroid.resize(3 * nf);
  for (size_t f = 0; f < nf; ++f) {
    d.weight[f] = face_area(mesh, f) * (density.empty() ? 1.0 : double(density[f]));
    for (int k = 0; k < 3; ++k) {
      double s = 0;
      for (int c = 0; c < 3; ++c) s += mesh.positions[3 * size_t(mesh.indices[3 * f + c]) + k];
      d.centroid[3 * f + k] = s / 3;
    }
  }
  return d;
}

double squared_distance3(const double* a, const double* b) {
  double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return x * x + y * y + z * z;
}

// A clustering as the fixes see it at the start of a round.
struct ClusterView {
  uint32_t clusters = 0;
  std::vector<uint32_t> offsets, members;          // faces of each cluster, CSR, increasing face ids
  std::vector<double> weight, centroid;            // W_i and mass centroid (3 per cluster)
  std::vector<uint32_t> component;                 // mesh component of each cluster
  std::vector<uint32_t> neighbour_offsets, neighbours;  // adjacent clusters, sorted, CSR

  uint32_t size(uint32_t c) const { return offsets[c + 1] - offsets[c]; }
  uint32_t valence(uint32_t c) const { return neighbour_offsets[c + 1] - neighbour_offsets[c]; }
  // The CVT energy a merge of a and b adds: W_a W_b / (W_a + W_b) |c_a - c_b|^2.
  double merge_cost(uint32_t a, uint32_t b) const;
};

double ClusterView::merge_cost(uint32_t a, uint32_t b) const {
  double w = weight[a] + weight[b];
  return w > 0 ? weight[a] * weight[b] / w * squared_distance3(&centroid[3 * size_t(a)], &centroid[3 * size_t(b)])
               : 0.0;
}

ClusterView view_of(const Topology& topology, const FaceData& data, const std::vector<uint32_t>& labels,
                    uint32_t clusters) {
  ClusterView v;
  v.clusters = clusters;
  const uint32_t nf = uint32_t(labels.size());
  v.offsets.assign(size_t(clusters) + 1, 0);
  for (uint32_t l : labels) ++v.offsets[l + 1];
  for (uint32_t c = 0; c < clusters; ++c) v.offsets[c + 1] += v.offsets[c];
  v.members.resize(nf);
  std::vector<uint32_t> cursor(v.offsets.begin(), v.offsets.end() - 1);
  for (uint32_t f = 0; f < nf; ++f) v.members[cursor[labels[f]]++] = f;
  v.weight.assign(clusters, 0.0);
  v.centroid.assign(3 * size_t(clusters), 0.0);
  v.component.assign(clusters, kNone);
  for (uint32_t f = 0; f < nf; ++f) {
    uint32_t c = labels[f];
    v.weight[c] += data.weight[f];
    for (int k = 0; k < 3; ++k) v.centroid[3 * size_t(c) + k] += data.weight[f] * data.centroid[3 * size_t(f) + k];
    v.component[c] = topology.face_component[f];
  }
  for (uint32_t c = 0; c < clusters; ++c) {
    if (v.weight[c] > 0) {
      for (int k = 0; k < 3; ++k) v.centroid[3 * size_t(c) + k] /= v.weight[c];
    } else if (v.size(c) > 0) {  // weightless faces: plain mean of their centroids
      for (int k = 0; k < 3; ++k) v.centroid[3 * size_t(c) + k] = 0;
      for (uint32_t i = v.offsets[c]; i < v.offsets[c + 1]; ++i)
        for (int k = 0; k < 3; ++k) v.centroid[3 * size_t(c) + k] += data.centroid[3 * size_t(v.members[i]) + k];
      for (int k = 0; k < 3; ++k) v.centroid[3 * size_t(c) + k] /= v.size(c);
    }
  }
  std::vector<uint64_t> pairs;
  for (uint32_t f = 0; f < nf; ++f)
    for (int e = 0; e < 3; ++e) {
      uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
      if (o != kNone && labels[o] != labels[f]) pairs.push_back(uint64_t(labels[f]) << 32 | labels[o]);
    }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  v.neighbour_offsets.assign(size_t(clusters) + 1, 0);
  v.neighbours.resize(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) {
    ++v.neighbour_offsets[(pairs[i] >> 32) + 1];
    v.neighbours[i] = uint32_t(pairs[i]);
  }
  for (uint32_t c = 0; c < clusters; ++c) v.neighbour_offsets[c + 1] += v.neighbour_offsets[c];
  return v;
}

// Eigenvectors of a symmetric 3x3 matrix (symmetric_eigen3.h), ordered by decreasing eigenvalue
// (rows of `vectors`; ties by index, so the order is deterministic).
void symmetric_eigenvectors(const double a[3][3], double vectors[3][3]) {
  double values[3], columns[3][3];
  symmetric_eigen3(a, values, columns);
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int x, int y) { return values[x] != values[y] ? values[x] > values[y] : x < y; });
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) vectors[i][k] = columns[k][order[i]];
}

// Scores sets of faces as the clusters they would become, next to the other clusters of `labels`.
// What makes a cluster fit for the dual: edge-connected, a disk (V - E + F = 1), its edges along the
// mesh boundary in one arc at most, one border with each neighbouring cluster (the ends of its
// border edges with a neighbour, counted per vertex, are the chains' ends: two per chain), and
// three neighbours or more (two on the boundary). Scratch arrays are sized once per mesh.
class RegionCheck {
 public:
  RegionCheck(const Mesh& mesh, const Topology& topology, const FaceData& data)
      : mesh_(mesh), topology_(topology), data_(data), piece_(mesh.face_count(), kOutside),
        vertex_stamp_(mesh.vertex_count(), 0), border_edges_at_(mesh.vertex_count(), 0),
        first_neighbour_at_(mesh.vertex_count(), 0) {}

  // faces[i] would become piece side[i] (0 .. pieces-1). Lower is better: 1000 per piece that is not
  // connected, 100 per piece that is not a disk, for each of its neighbours (the boundary, the other
  // pieces, other clusters) it would share two borders with, 10 per piece with too few neighbours
  // (3; 2 for a piece on the mesh boundary, where a cluster met only at a boundary vertex counts);
  // plus the weight imbalance (max - min) / total in [0, 1]. Below 10: every piece is fit.
  double score(const std::vector<uint32_t>& faces, const std::vector<uint8_t>& side, uint8_t pieces,
               const std::vector<uint32_t>& labels) {
    std::array<double, 3> weight{0, 0, 0};
    std::array<uint32_t, 3> count{0, 0, 0};
    for (size_t i = 0; i < faces.size(); ++i) {
      piece_[faces[i]] = side[i];
      ++count[side[i]];
      weight[side[i]] += data_.weight[faces[i]];
    }
    double s = 0;
    for (uint8_t p = 0; p < pieces; ++p)
      if (count[p] == 0) s = std::numeric_limits<double>::infinity();
    if (s == 0) {
      for (uint8_t p = 0; p < pieces; ++p) s += piece_score(faces, side, p, count[p], labels);
      double total = 0, lo = std::numeric_limits<double>::infinity(), hi = 0;
      for (uint8_t p = 0; p < pieces; ++p) total += weight[p], lo = std::min(lo, weight[p]), hi = std::max(hi, weight[p]);
      if (pieces > 1 && total > 0) s += (hi - lo) / total;
    }
    for (uint32_t f : faces) piece_[f] = kOutside;
    return s;
  }

 private:
  static constexpr uint8_t kOutside = 0xff;
  static constexpr uint32_t kBoundary = kNone;         // neighbour id of the mesh boundary
  static constexpr uint32_t kPiece = 0xfffffff0u;      // neighbour id of piece q: kPiece + q

  double piece_score(const std::vector<uint32_t>& faces, const std::vector<uint8_t>& side, uint8_t p,
                     uint32_t count, const std::vector<uint32_t>& labels) {
    double s = 0;
    uint32_t first = kNone;
    for (size_t i = 0; i < faces.size() && first == kNone; ++i)
      if (side[i] == p) first = faces[i];
    // connected: breadth-first over the piece, marking with p + 3 (pieces are 0..2), then back to p
    const uint8_t mark = uint8_t(p + 3);
    queue_.assign(1, first);
    piece_[first] = mark;
    for (size_t head = 0; head < queue_.size(); ++head)
      for (int e = 0; e < 3; ++e) {
        uint32_t o = topology_.face_adjacent[3 * size_t(queue_[head]) + e];
        if (o != kNone && piece_[o] == p) piece_[o] = mark, queue_.push_back(o);
      }
    for (uint32_t f : queue_) piece_[f] = p;
    if (queue_.size() != count) s += 1000;

    if (++stamp_ == 0) {  // wrapped: clear once
      std::fill(vertex_stamp_.begin(), vertex_stamp_.end(), 0);
      stamp_ = 1;
    }
    int64_t vertices = 0, border = 0;
    ends_.clear();
    // Per neighbour: vertices with exactly one border edge to it are chain ends; more than two ends
    // mean two borders (two arcs for the boundary). Where every vertex of the piece's border has
    // two border edges (the piece's border a set of simple loops: nearly always) a vertex is an end
    // of both its edges' neighbours when they differ, of neither when not: counted on the way
    // (neighbour_ends_). Elsewhere the ends are sorted by neighbour and vertex and counted (a third
    // of piece_score's time when always done).
    neighbour_ends_.clear();
    bool two_per_vertex = true;
    int64_t single = 0;  // vertices with one border edge so far
    auto slot_of = [&](uint32_t id) {  // (a few neighbours: a list)
      for (size_t i = 0; i < neighbour_ends_.size(); ++i)
        if (neighbour_ends_[i].first == id) return i;
      neighbour_ends_.push_back({id, 0});
      return neighbour_ends_.size() - 1;
    };
    for (size_t i = 0; i < faces.size(); ++i) {
      if (side[i] != p) continue;
      const uint32_t f = faces[i];
      const uint32_t* t = &mesh_.indices[3 * size_t(f)];
      for (int k = 0; k < 3; ++k)
        if (vertex_stamp_[t[k]] != stamp_) vertex_stamp_[t[k]] = stamp_, border_edges_at_[t[k]] = 0, ++vertices;
      for (int e = 0; e < 3; ++e) {
        uint32_t o = topology_.face_adjacent[3 * size_t(f) + e];
        if (o != kNone && piece_[o] == p) continue;
        ++border;
        uint32_t id = o == kNone ? kBoundary : piece_[o] != kOutside ? kPiece + piece_[o] : labels[o];
        ends_.push_back(end_key(id, t[e]));
        ends_.push_back(end_key(id, t[(e + 1) % 3]));
        if (!two_per_vertex) continue;
        const size_t own = slot_of(id);
        for (uint32_t v : {t[e], t[(e + 1) % 3]}) {
          const uint8_t edges = border_edges_at_[v]++;
          if (edges == 0) {
            first_neighbour_at_[v] = uint32_t(own), ++single;
          } else if (edges == 1) {
            --single;
            if (first_neighbour_at_[v] != own) {
              ++neighbour_ends_[own].second;
              ++neighbour_ends_[first_neighbour_at_[v]].second;
            }
          } else {
            two_per_vertex = false;
          }
        }
      }
    }
    if (2 * vertices - int64_t(count) - border != 2) s += 100;  // 2 chi = 2V - 2E + 2F, 2E = 3F + B
    if (!two_per_vertex || single != 0) {  // counted again from the sorted ends
      neighbour_ends_.clear();
      std::sort(ends_.begin(), ends_.end());
      for (size_t i = 0; i < ends_.size();) {
        size_t j = i;
        uint32_t chain_ends = 0;
        while (j < ends_.size() && end_id(ends_[j]) == end_id(ends_[i])) {
          size_t k = j;
          while (k < ends_.size() && ends_[k] == ends_[j]) ++k;
          chain_ends += k - j == 1;
          j = k;
        }
        neighbour_ends_.push_back({end_id(ends_[i]), chain_ends});
        i = j;
      }
    }
    uint32_t neighbours = 0;
    bool open = false;
    for (const auto& [id, ends] : neighbour_ends_) {
      if (id == kBoundary)
        open = true;
      else
        ++neighbours;
      if (ends > 2) s += 100;
    }
    if (open && neighbours < 2) neighbours += boundary_corner_neighbours(p, labels);
    if (neighbours < (open ? 2u : 3u)) s += 10;
    return s;
  }

  // Clusters (or other pieces) that share no border with piece p but meet it at a vertex on the
  // mesh boundary, at most 2. There the clusters of the vertex's fan, from one boundary edge to the
  // other, make a corner polygon with the boundary, so the dual joins them: at the end of a strip
  // one face wide (libcgal-demo's ALSTOM_TEST4), the end's cluster borders only the next one and
  // meets the cluster after that across the strip, and that is all the strip allows.
  uint32_t boundary_corner_neighbours(uint8_t p, const std::vector<uint32_t>& labels) {
    uint32_t found[2] = {kNone, kNone}, count = 0;
    auto bordering = [&](uint32_t id) {
      for (uint64_t e : ends_)
        if (end_id(e) == id) return true;
      return false;
    };
    for (uint64_t e : ends_) {
      if (end_id(e) != kBoundary) continue;
      const uint32_t v = uint32_t(e);
      for (uint32_t i = topology_.vertex_face_offsets[v]; i < topology_.vertex_face_offsets[v + 1] && count < 2; ++i) {
        const uint32_t g = topology_.vertex_faces[i];
        if (piece_[g] == p) continue;
        const uint32_t other = piece_[g] != kOutside ? kPiece + piece_[g] : labels[g];
        if (other == found[0] || other == found[1] || bordering(other)) continue;
        found[count++] = other;
      }
    }
    return count;
  }

  const Mesh& mesh_;
  const Topology& topology_;
  const FaceData& data_;
  std::vector<uint8_t> piece_;  // per face: its piece while a region is scored, else kOutside
  std::vector<uint32_t> vertex_stamp_;
  // Per vertex of the piece scored: its border edges (counted to 3 at most: then the ends are
  // sorted), and the neighbour of the first (its slot in neighbour_ends_).
  std::vector<uint8_t> border_edges_at_;
  std::vector<uint32_t> first_neighbour_at_;
  std::vector<std::pair<uint32_t, uint32_t>> neighbour_ends_;  // (neighbour id, chain ends) of the piece scored
  uint32_t stamp_ = 0;
  std::vector<uint32_t> queue_;
  // Per end of a border edge: (neighbour id, vertex) as one key, id in the high half, so that the
  // keys sort as the pairs would (sorted where a border vertex has other than two border edges).
  std::vector<uint64_t> ends_;
  static uint64_t end_key(uint32_t id, uint32_t v) { return uint64_t(id) << 32 | v; }
  static uint32_t end_id(uint64_t key) { return uint32_t(key >> 32); }
};

// The input's boundary loops, an id per boundary half-edge. The dual keeps a loop as a hole only
// while three clusters or more meet it: with two, the output closes over it (missing_boundary_edge).
// Merges must not take a loop below three, which RegionCheck cannot see (each cluster alone is fit):
// a hole of three edges, a missing triangle (libcgal-demo's polygon_mesh has nine), starts with its
// three faces' clusters and may keep no fewer.
class BoundaryLoops {
 public:
  BoundaryLoops(const Mesh& mesh, const Topology& topology) : mesh_(mesh), topology_(topology) {
    // Union-find over the vertices joined by boundary edges (after prepare_surface, two per
    // boundary vertex, so each set is one loop; elsewhere loops touching at a vertex share an id,
    // which only makes the merges more careful).
    std::vector<uint32_t> parent(mesh.vertex_count(), kNone);
    auto find = [&](uint32_t x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (size_t h = 0; h < topology.face_adjacent.size(); ++h) {
      if (!is_boundary(h)) continue;
      uint32_t a = mesh.indices[h], b = mesh.indices[h % 3 == 2 ? h - 2 : h + 1];
      for (uint32_t v : {a, b})
        if (parent[v] == kNone) parent[v] = v;
      a = find(a), b = find(b);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
    vertex_loop_.assign(mesh.vertex_count(), kNone);
    for (uint32_t v = 0; v < mesh.vertex_count(); ++v)
      if (parent[v] != kNone) {
        const uint32_t r = find(v);
        if (vertex_loop_[r] == kNone) vertex_loop_[r] = count_++;
        vertex_loop_[v] = vertex_loop_[r];
      }
  }

  uint32_t count() const { return count_; }

  // The loop of half-edge h (3 f + e), or kNone when h is not on the boundary.
  uint32_t loop_of(size_t h) const { return is_boundary(h) ? vertex_loop_[mesh_.indices[h]] : kNone; }

  // The loops each cluster meets (sorted, each once), from the clusters' faces.
  std::vector<std::vector<uint32_t>> of_clusters(const std::vector<uint32_t>& labels, uint32_t clusters) const {
    std::vector<std::vector<uint32_t>> loops(clusters);
    if (count_ == 0) return loops;
    for (size_t h = 0; h < topology_.face_adjacent.size(); ++h)
      if (is_boundary(h)) loops[labels[h / 3]].push_back(vertex_loop_[mesh_.indices[h]]);
    for (std::vector<uint32_t>& l : loops) {
      std::sort(l.begin(), l.end());
      l.erase(std::unique(l.begin(), l.end()), l.end());
    }
    return loops;
  }

 private:
  bool is_boundary(size_t h) const {
    const uint32_t* t = &mesh_.indices[3 * (h / 3)];
    return topology_.face_adjacent[h] == kNone && t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
  }

  const Mesh& mesh_;
  const Topology& topology_;
  std::vector<uint32_t> vertex_loop_;  // loop id of each boundary vertex, else kNone
  uint32_t count_ = 0;
};

// The corners where four or more clusters meet, as the dual sees them: the clusters around the
// vertex in fan order are a polygon, which coarsen_clustering triangulates avoiding diagonals that
// are edges of the dual already (two clusters sharing a border or a boundary step) or diagonals
// another polygon took; where every triangulation has such a diagonal, that edge gets three or
// more triangles (nonmanifold_output). RegionCheck cannot see it: a corner of four is fine for
// each of its clusters, and only the dual's edges elsewhere decide which diagonals are free. So a
// merge, which turns the polygons around the merged cluster into smaller ones with new neighbours,
// checks them here. (A merge never adds a cluster to a corner: merging into a clustering whose
// corners are all triangles can only make more triangles.)
class CornerPolygons {
 public:
  // Polygons larger than this (a vertex of very high valence) are not checked.
  static constexpr size_t kMaxPolygon = 16;

  CornerPolygons(const Mesh& mesh, const Topology& topology)
      : mesh_(mesh), topology_(topology), vertex_stamp_(mesh.vertex_count(), 0) {}

  // The polygon at vertex v with label(f) the cluster of face f: true, and polygon() its clusters
  // in fan order (an open fan from one boundary edge to the other: open()), when 4 to kMaxPolygon
  // clusters meet at v in one manifold fan, each once, or 3 in an open fan. False elsewhere:
  // inside a cluster, an inner corner of three (a triangle, nothing to choose), or a cluster twice
  // around v (pinched: RegionCheck's). An open polygon's first and last clusters are closed by the
  // boundary: the dual's edge between them must be a boundary edge, the side of this polygon's
  // triangles alone, so they must not share a border nor close another open fan; with three
  // clusters that is all there is to check. (Before open fans were checked, merges
  // back to n made the two ends of a hole's corner neighbours: their edge got a triangle besides
  // the boundary's, seen on an irregular sphere with 40 missing triangles, tests/.)
  template <class Label>
  bool at(uint32_t v, Label label) {
    const uint32_t begin = topology_.vertex_face_offsets[v], end = topology_.vertex_face_offsets[v + 1];
    if (end - begin < 3) return false;
    const uint32_t first = topology_.vertex_faces[begin];
    uint32_t distinct = 0, seen[3];
    for (uint32_t i = begin; i < end && distinct < 3; ++i) {
      uint32_t l = label(topology_.vertex_faces[i]);
      if (std::find(seen, seen + distinct, l) == seen + distinct) seen[distinct++] = l;
    }
    if (distinct < 3) return false;
    // The face across the edge {v, x} of face g, kNone on the boundary.
    auto across = [&](uint32_t g, uint32_t x) {
      const uint32_t* t = &mesh_.indices[3 * size_t(g)];
      for (int e = 0; e < 3; ++e)
        if ((t[e] == v && t[(e + 1) % 3] == x) || (t[e] == x && t[(e + 1) % 3] == v))
          return topology_.face_adjacent[3 * size_t(g) + e];
      return kNone;
    };
    auto third = [&](uint32_t g, uint32_t x) {
      const uint32_t* t = &mesh_.indices[3 * size_t(g)];
      return t[0] != v && t[0] != x ? t[0] : t[1] != v && t[1] != x ? t[1] : t[2];
    };
    // From `first` one way round to the start of an open fan (or back to `first`), then the other
    // way round collecting the fan.
    const uint32_t* t = &mesh_.indices[3 * size_t(first)];
    const int cv = t[0] == v ? 0 : t[1] == v ? 1 : 2;
    uint32_t start = first, exit = t[(cv + 1) % 3];
    bool closed = false;
    for (uint32_t steps = 0; steps < end - begin; ++steps) {
      uint32_t h = across(start, exit);
      if (h == first) {
        closed = true;
        break;
      }
      if (h == kNone) break;
      exit = third(h, exit);
      start = h;
    }
    exit = closed ? t[(cv + 2) % 3] : third(start, exit);
    if (closed) start = first;
    fan_.assign(1, start);
    for (uint32_t g = start, steps = 0; steps < end - begin; ++steps) {
      uint32_t h = across(g, exit);
      if (h == kNone || h == start) break;
      fan_.push_back(h);
      exit = third(h, exit);
      g = h;
    }
    if (fan_.size() != end - begin) return false;  // not one manifold fan
    runs_.clear();
    for (uint32_t h : fan_)
      if (runs_.empty() || runs_.back() != label(h)) runs_.push_back(label(h));
    if (closed && runs_.size() > 1 && runs_.front() == runs_.back()) runs_.pop_back();
    open_ = !closed;
    if (runs_.size() < (closed ? 4u : 3u) || runs_.size() > kMaxPolygon) return false;
    sorted_ = runs_;
    std::sort(sorted_.begin(), sorted_.end());
    return std::adjacent_find(sorted_.begin(), sorted_.end()) == sorted_.end();
  }
  const std::vector<uint32_t>& polygon() const { return runs_; }
  bool open() const { return open_; }

  // Whether `polygon` (as at() gives it) has a triangulation none of whose diagonals (x, y) is
  // taken(x, y), and, when `open`, whose closing side (first, last) is free: !joined(first, last).
  // Interval dynamic programming: can[i][j], the part i..j closed by the chord (i, j) splits into
  // triangles with free diagonals. O(k^3) for k clusters.
  template <class Taken, class Joined>
  bool triangulable(const uint32_t* polygon, size_t k, Taken taken, bool open, Joined joined) {
    if (open && joined(polygon[0], polygon[k - 1])) return false;
    can_.assign(k * k, 0);
    for (size_t i = 0; i + 1 < k; ++i) can_[i * k + i + 1] = 1;
    for (size_t length = 2; length < k; ++length)
      for (size_t i = 0; i + length < k; ++i) {
        const size_t j = i + length;
        for (size_t m = i + 1; m < j && !can_[i * k + j]; ++m)
          can_[i * k + j] = can_[i * k + m] && can_[m * k + j] && (m - i < 2 || !taken(polygon[i], polygon[m])) &&
                            (j - m < 2 || !taken(polygon[m], polygon[j]));
      }
    return can_[k - 1] != 0;
  }

  // Whether every polygon at a vertex of `faces` is triangulable (clusters by label, diagonals
  // and closing sides refused by adjacent(x, y): the two share a border).
  template <class Label, class Adjacent>
  bool all_triangulable(const std::vector<uint32_t>& faces, Label label, Adjacent adjacent) {
    for (uint32_t v : vertices_of(faces))
      if (at(v, label) && !triangulable(runs_.data(), runs_.size(), adjacent, open_, adjacent)) return false;
    return true;
  }

  // The distinct vertices of `faces` on an edge whose other face is not inside(g), or on the mesh
  // boundary (scratch: valid until the next call). On a manifold these are the only vertices of
  // `faces` with faces of other clusters in their fan: a fan holding both has two of them next to
  // each other across an edge at the vertex. So where `faces` is a cluster, they are the only
  // vertices of its faces where a polygon can be, whether the faces outside are labelled as before
  // or after it changed (merge_down: the polygons around a merged pair, about half the vertices).
  template <class Inside>
  const std::vector<uint32_t>& border_vertices_of(const std::vector<uint32_t>& faces, Inside inside) {
    start_vertex_set();
    for (uint32_t f : faces)
      for (int e = 0; e < 3; ++e) {
        const uint32_t g = topology_.face_adjacent[3 * size_t(f) + e];
        if (g != kNone && inside(g)) continue;
        for (int k : {e, (e + 1) % 3}) add_to_vertex_set(mesh_.indices[3 * size_t(f) + k]);
      }
    return vertices_;
  }

  // The distinct vertices of `faces` (scratch: valid until the next call).
  const std::vector<uint32_t>& vertices_of(const std::vector<uint32_t>& faces) {
    start_vertex_set();
    for (uint32_t f : faces)
      for (int k = 0; k < 3; ++k) add_to_vertex_set(mesh_.indices[3 * size_t(f) + k]);
    return vertices_;
  }

 private:
  // vertices_ emptied; a vertex is in it when vertex_stamp_ holds stamp_.
  void start_vertex_set() {
    if (++stamp_ == 0) {  // wrapped: clear once
      std::fill(vertex_stamp_.begin(), vertex_stamp_.end(), 0);
      stamp_ = 1;
    }
    vertices_.clear();
  }
  void add_to_vertex_set(uint32_t v) {
    if (vertex_stamp_[v] != stamp_) vertex_stamp_[v] = stamp_, vertices_.push_back(v);
  }

  const Mesh& mesh_;
  const Topology& topology_;
  std::vector<uint32_t> vertex_stamp_, vertices_, fan_, runs_, sorted_;
  uint32_t stamp_ = 0;
  bool open_ = false;  // of the last polygon at() found
  std::vector<uint8_t> can_;
};

// How many corner polygons have each pair of clusters as a possible diagonal (the two not
// consecutive around the corner), and how many open polygons as their closing side (a boundary
// step: the dual's edge there, which coarsen_clustering's triangulation avoids as a diagonal
// elsewhere, as it avoids the edges of shared borders). coarsen_clustering triangulates the
// polygons one after the other, each taking its best free diagonals, so a polygon can count only
// on a diagonal that no other polygon may take: two corners facing the same pair across them
// (both of whose other diagonals are edges) would both take it. Polygons are added and removed as
// flat lists.
class DiagonalLedger {
 public:
  void add(const uint32_t* polygon, size_t k, int sign, bool open) {
    for (size_t i = 0; i < k; ++i)
      for (size_t j = i + 2; j < k; ++j)
        if (i > 0 || j + 1 < k) count_[key(polygon[i], polygon[j])] += uint32_t(sign);
    if (open) steps_[key(polygon[0], polygon[k - 1])] += uint32_t(sign);
  }
  uint32_t count(uint32_t x, uint32_t y) const { return find(count_, x, y); }
  uint32_t steps(uint32_t x, uint32_t y) const { return find(steps_, x, y); }

 private:
  static uint64_t key(uint32_t x, uint32_t y) { return x < y ? uint64_t(x) << 32 | y : uint64_t(y) << 32 | x; }
  static uint32_t find(const std::unordered_map<uint64_t, uint32_t>& map, uint32_t x, uint32_t y) {
    auto it = map.find(key(x, y));
    return it == map.end() ? 0 : it->second;
  }
  // lookups only: the order of the maps never matters
  std::unordered_map<uint64_t, uint32_t> count_, steps_;
};

// Ways to cut one cluster into 2 or 3 pieces, scored by RegionCheck.
//  - 2 pieces: the planes through the mass centroid normal to each principal axis (largest spread
//    first); halves grown breadth-first from two far-apart faces (of the whole cluster, of its faces
//    next to the partner of a double border, of its faces on the boundary).
//  - 3 pieces, tried when no 2-piece cut is fit: a ring around a handle cut in two gives two pieces
//    sharing two borders, so it needs three sectors: sectors of 120 degrees around each principal
//    axis through the centroid, and thirds grown from three far-apart faces.
class ClusterCutter {
 public:
  struct Plan {
    std::vector<uint8_t> side;  // piece of each face of the cluster (view order)
    uint8_t pieces = 0;
    double score = std::numeric_limits<double>::infinity();
  };

  ClusterCutter(const Mesh& mesh, const Topology& topology, const FaceData& data, RegionCheck& check,
                const BoundaryLoops& loops)
      : mesh_indices_(mesh.indices), topology_(topology), data_(data), check_(check), loops_(loops),
        grow_mark_(data.weight.size(), kNone) {}

  // The cut of `target` in two across its stretch of a boundary loop that `partner` meets too:
  // halves grown from two of target's faces on that loop, far apart. Two clusters alone along a
  // hole (missing_boundary_edge) need a third there, and only a cut that ends on the hole gives
  // one; the best cut by shape alone (plan) rarely does when the hole is much smaller than the
  // cluster. Each such cut halved the cluster and left the hole between two: ChineseDragon-10kv
  // -> 499 cut clusters of 61, 33, 15, ... faces around a hole of three edges, 0.036 long, for
  // 28 rounds. Score infinite when target has fewer than two faces on such a loop.
  Plan plan_across_loop(const ClusterView& view, const std::vector<uint32_t>& labels, uint32_t target,
                        uint32_t partner) {
    Plan none;
    shared_loops_.clear();
    for (uint32_t i = view.offsets[partner]; i < view.offsets[partner + 1]; ++i)
      for (int e = 0; e < 3; ++e) {
        const uint32_t loop = loops_.loop_of(3 * size_t(view.members[i]) + e);
        if (loop != kNone) shared_loops_.push_back(loop);
      }
    if (shared_loops_.empty()) return none;
    std::sort(shared_loops_.begin(), shared_loops_.end());
    members_.assign(view.members.begin() + view.offsets[target], view.members.begin() + view.offsets[target + 1]);
    std::vector<uint32_t> on_loop;  // indices into members_
    for (uint32_t i = 0; i < members_.size(); ++i)
      for (int e = 0; e < 3; ++e) {
        const uint32_t loop = loops_.loop_of(3 * size_t(members_[i]) + e);
        if (loop != kNone && std::binary_search(shared_loops_.begin(), shared_loops_.end(), loop)) {
          on_loop.push_back(i);
          break;
        }
      }
    std::vector<uint32_t> seeds = far_apart(on_loop, &view.centroid[3 * size_t(target)], 2);
    if (seeds.size() < 2) return none;
    std::vector<uint8_t> side = grow(seeds);
    const double s = check_.score(members_, side, 2, labels);
    return {std::move(side), 2, s};
  }

  // The best cut of `target` (>= 3 faces for 3 pieces, >= 2 for 2). `partner`: the other cluster
  // of a double border, or kNone; `boundary`: seed halves on the boundary too.
  Plan plan(const ClusterView& view, const std::vector<uint32_t>& labels, uint32_t target, uint32_t partner,
            bool boundary) {
    members_.assign(view.members.begin() + view.offsets[target], view.members.begin() + view.offsets[target + 1]);
    const uint32_t count = uint32_t(members_.size());
    const double* centre = &view.centroid[3 * size_t(target)];
    double axes[3][3];
    principal_axes(centre, axes);

    Plan two, three;
    auto consider = [&](Plan& best, std::vector<uint8_t> side, uint8_t pieces) {
      double s = check_.score(members_, side, pieces, labels);
      if (s < best.score) best = {std::move(side), pieces, s};
    };
    for (const auto& axis : axes) {
      std::vector<uint8_t> side(count);
      for (uint32_t i = 0; i < count; ++i) side[i] = offset(i, centre, axis) > 0;
      consider(two, std::move(side), 2);
    }
    std::vector<uint32_t> pool(count);
    for (uint32_t i = 0; i < count; ++i) pool[i] = i;
    std::vector<uint32_t> seeds = far_apart(pool, centre, 2);
    if (seeds.size() == 2) consider(two, grow(seeds), 2);
    auto seeded_on = [&](auto pred) {
      std::vector<uint32_t> some;
      for (uint32_t i = 0; i < count; ++i)
        for (int e = 0; e < 3; ++e)
          if (pred(topology_.face_adjacent[3 * size_t(members_[i]) + e])) {
            some.push_back(i);
            break;
          }
      std::vector<uint32_t> s = far_apart(some, centre, 2);
      if (s.size() == 2) consider(two, grow(s), 2);
    };
    if (partner != kNone) seeded_on([&](uint32_t o) { return o != kNone && labels[o] == partner; });
    if (boundary) seeded_on([](uint32_t o) { return o == kNone; });
    if (two.score < 10 || count < 3) return two;

    for (int k = 0; k < 3; ++k) {
      const double* u = axes[(k + 1) % 3];
      const double* w = axes[(k + 2) % 3];
      std::vector<uint8_t> side(count);
      for (uint32_t i = 0; i < count; ++i) {
        double angle = std::atan2(offset(i, centre, w), offset(i, centre, u));  // [-pi, pi]
        side[i] = uint8_t(std::min(2.0, std::floor((angle + std::numbers::pi) * 3 / (2 * std::numbers::pi))));
      }
      consider(three, std::move(side), 3);
    }
    seeds = far_apart(pool, centre, 3);
    if (seeds.size() == 3) consider(three, grow(seeds), 3);
    for (const std::vector<uint32_t>& loop : border_loops(labels, target))
      for (uint32_t shift = 0; shift < 2; ++shift) consider(three, loop_sectors(loop, 3, shift), 3);
    return three.score < two.score ? three : two;
  }

 private:
  double offset(uint32_t i, const double* centre, const double* axis) const {
    const double* p = &data_.centroid[3 * size_t(members_[i])];
    return (p[0] - centre[0]) * axis[0] + (p[1] - centre[1]) * axis[1] + (p[2] - centre[2]) * axis[2];
  }

  void principal_axes(const double* centre, double axes[3][3]) const {
    double cov[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    for (uint32_t f : members_) {
      double w = data_.weight[f] > 0 ? data_.weight[f] : 0;
      const double* p = &data_.centroid[3 * size_t(f)];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) cov[r][c] += w * (p[r] - centre[r]) * (p[c] - centre[c]);
    }
    symmetric_eigenvectors(cov, axes);
  }

  // Up to k faces of `pool` (indices into members_) far apart: the farthest from the centre, then
  // each next one maximizing its distance to the closest already chosen (ties: lower index).
  std::vector<uint32_t> far_apart(const std::vector<uint32_t>& pool, const double* centre, uint32_t k) const {
    std::vector<uint32_t> chosen;
    if (pool.size() < k) return chosen;
    std::vector<double> nearest(pool.size(), 0.0);
    for (size_t j = 0; j < pool.size(); ++j) nearest[j] = squared_distance3(&data_.centroid[3 * size_t(members_[pool[j]])], centre);
    while (chosen.size() < k) {
      size_t best = 0;
      for (size_t j = 1; j < pool.size(); ++j)
        if (nearest[j] > nearest[best]) best = j;
      chosen.push_back(pool[best]);
      const double* c = &data_.centroid[3 * size_t(members_[pool[best]])];
      for (size_t j = 0; j < pool.size(); ++j) {
        double d = squared_distance3(&data_.centroid[3 * size_t(members_[pool[j]])], c);
        nearest[j] = chosen.size() == 1 ? d : std::min(nearest[j], d);
      }
    }
    return chosen;
  }

  // The loops of the cluster's border, each as its faces in loop order (one entry per border edge,
  // a face repeated when several of its edges are on the loop). A border half-edge ending at vertex
  // b is followed by the next border half-edge leaving b, found by turning around b through the
  // cluster's faces. Empty when the walk does not close (inconsistent orientation, non-manifold).
  std::vector<std::vector<uint32_t>> border_loops(const std::vector<uint32_t>& labels, uint32_t target) const {
    std::vector<std::vector<uint32_t>> loops;
    std::vector<uint32_t> edges;  // border half-edges 3f + e, increasing
    for (uint32_t f : members_)
      for (int e = 0; e < 3; ++e) {
        uint32_t o = topology_.face_adjacent[3 * size_t(f) + e];
        if (o == kNone || labels[o] != target) edges.push_back(3 * f + uint32_t(e));
      }
    const std::vector<uint32_t>& idx = mesh_indices_;
    std::vector<uint8_t> done(edges.size(), 0);
    auto position = [&](uint32_t h) {
      auto it = std::lower_bound(edges.begin(), edges.end(), h);
      return it != edges.end() && *it == h ? size_t(it - edges.begin()) : edges.size();
    };
    for (size_t start = 0; start < edges.size(); ++start) {
      if (done[start]) continue;
      std::vector<uint32_t> loop;
      size_t at = start;
      bool closed = false;
      for (size_t steps = 0; steps <= edges.size(); ++steps) {
        done[at] = 1;
        uint32_t h = edges[at], f = h / 3;
        loop.push_back(f);
        // turn around the end vertex b of h, from the edge of f that leaves b
        uint32_t b = idx[3 * size_t(f) + (h % 3 + 1) % 3];
        uint32_t g = f, out = 3 * f + (h % 3 + 1) % 3;
        size_t next = edges.size();
        for (uint32_t turn = 0; turn < 64; ++turn) {
          uint32_t o = topology_.face_adjacent[out];
          if (o == kNone || labels[o] != target) {
            next = position(out);
            break;
          }
          // in the neighbour o, the edge leaving b
          int cb = idx[3 * size_t(o)] == b ? 0 : idx[3 * size_t(o) + 1] == b ? 1 : idx[3 * size_t(o) + 2] == b ? 2 : 3;
          if (cb == 3 || o == g) break;
          g = o;
          out = 3 * o + uint32_t(cb);
        }
        if (next == edges.size()) break;
        if (next == start) {
          closed = true;
          break;
        }
        if (done[next]) break;
        at = next;
      }
      if (!closed) return {};
      loops.push_back(std::move(loop));
    }
    return loops;
  }

  // k sectors of the cluster along one border loop: the loop's faces split into k runs of equal
  // length (starting `shift` sixths of a run in), every other face taking the sector of the loop
  // face it is reached from first, breadth-first. A ring around a handle comes out as k pieces
  // across it, each from one boundary of the ring to the other.
  std::vector<uint8_t> loop_sectors(const std::vector<uint32_t>& loop, uint32_t k, uint32_t shift) {
    for (uint32_t m : members_) grow_mark_[m] = kUnclaimed;
    queue_.clear();
    const size_t length = loop.size();
    const size_t offset = length * shift / (6 * k);
    for (size_t j = 0; j < length; ++j) {
      uint32_t f = loop[(j + offset) % length];
      if (grow_mark_[f] != kUnclaimed) continue;
      grow_mark_[f] = uint32_t(j * k / length);
      queue_.push_back(f);
    }
    return spread_marks();
  }

  // Pieces grown breadth-first inside the cluster from the seeds (piece = seed's position); faces
  // not reached (a cluster in pieces) go to piece 0.
  std::vector<uint8_t> grow(const std::vector<uint32_t>& seeds) {
    for (uint32_t m : members_) grow_mark_[m] = kUnclaimed;
    queue_.clear();
    for (uint32_t s = 0; s < seeds.size(); ++s) {
      grow_mark_[members_[seeds[s]]] = s;
      queue_.push_back(members_[seeds[s]]);
    }
    return spread_marks();
  }

  // The faces in queue_ (marked with their piece) spread their marks breadth-first over the
  // cluster's unclaimed faces; returns each member's piece (0 when not reached) and clears the marks.
  static constexpr uint32_t kUnclaimed = kNone - 1;
  std::vector<uint8_t> spread_marks() {
    for (size_t head = 0; head < queue_.size(); ++head)
      for (int e = 0; e < 3; ++e) {
        uint32_t o = topology_.face_adjacent[3 * size_t(queue_[head]) + e];
        if (o != kNone && grow_mark_[o] == kUnclaimed) grow_mark_[o] = grow_mark_[queue_[head]], queue_.push_back(o);
      }
    std::vector<uint8_t> side(members_.size());
    for (size_t i = 0; i < members_.size(); ++i) {
      uint32_t m = grow_mark_[members_[i]];
      side[i] = m == kUnclaimed ? 0 : uint8_t(m);
      grow_mark_[members_[i]] = kNone;
    }
    return side;
  }

  const std::vector<uint32_t>& mesh_indices_;
  const Topology& topology_;
  const FaceData& data_;
  RegionCheck& check_;
  const BoundaryLoops& loops_;
  std::vector<uint32_t> grow_mark_;  // per face: seed that claimed it while growing, else kNone
  std::vector<uint32_t> members_, queue_, shared_loops_;
};

// The clusters of a defect that could be cut to remove it, best first (empty: not fixable by a cut).
std::vector<uint32_t> cut_choices(const DualDefect& d, const ClusterView& view) {
  auto heavier_first = [&](uint32_t a, uint32_t b) {
    return view.weight[a] != view.weight[b] ? view.weight[a] > view.weight[b] : a < b;
  };
  std::vector<uint32_t> c;
  switch (d.kind) {
    case DualDefect::cluster_not_disk:
    case DualDefect::boundary_arcs:
      c = {d.cluster};
      break;
    case DualDefect::double_border:
    case DualDefect::nonmanifold_output:
    case DualDefect::inconsistent_orientation:
    case DualDefect::missing_boundary_edge:
      c = {d.cluster, d.other};
      std::sort(c.begin(), c.end(), heavier_first);
      break;
    case DualDefect::duplicate_triangle:
      // Usually one of the three has only two neighbours (both corners give its triangle): cut it.
      c = {d.cluster, d.other, d.third};
      std::sort(c.begin(), c.end(), [&](uint32_t a, uint32_t b) {
        return view.valence(a) != view.valence(b) ? view.valence(a) < view.valence(b) : heavier_first(a, b);
      });
      break;
    case DualDefect::degenerate_triangle:  // geometry, not topology
    case DualDefect::empty_cluster:        // cluster() never leaves one
      break;
  }
  return c;
}

bool uses(const DualDefect& d, uint32_t c) { return d.cluster == c || d.other == c || d.third == c; }

// Merges that keep n while cuts add clusters: adjacent pairs by the energy their merge adds,
// W_a W_b / (W_a + W_b) |c_a - c_b|^2, cheapest first, taken when the merged cluster is fit
// (RegionCheck) and, preferably, away from every defect and from the round's other changes.
class MergeFinder {
 public:
  MergeFinder(const ClusterView& view, RegionCheck& check, CornerPolygons& corners)
      : view_(view), check_(check), corners_(corners) {
    const uint32_t n = view.clusters;
    for (uint32_t a = 0; a < n; ++a)
      for (uint32_t i = view.neighbour_offsets[a]; i < view.neighbour_offsets[a + 1]; ++i) {
        uint32_t b = view.neighbours[i];
        if (b <= a) continue;
        pairs_.push_back({view.merge_cost(a, b), a, b});
      }
    std::sort(pairs_.begin(), pairs_.end(), [](const Pair& x, const Pair& y) {
      if (x.cost != y.cost) return x.cost < y.cost;
      return x.a != y.a ? x.a < y.a : x.b < y.b;
    });
    taken_.assign(pairs_.size(), 0);
  }

  struct Pair {
    double cost;
    uint32_t a, b;
  };

  // The cheapest fit pair of `component` whose clusters are not `blocked` (cut, partner or merged
  // this round), trying in turn: (0) clusters in no defect (`involved`), not next to a blocked
  // cluster nor to another merge (`nearby`), whose common neighbours keep three neighbours;
  // (1) any fit pair; (2) any pair. Returns kNone-filled pair when the component has none.
  Pair find(uint32_t component, const std::vector<uint8_t>& blocked, const std::vector<uint8_t>& involved,
            const std::vector<uint8_t>& nearby, const std::vector<uint32_t>& labels) {
    for (int tier = 0; tier < 2; ++tier) {
      uint32_t scored = 0;
      for (size_t i = 0; i < pairs_.size(); ++i) {
        const Pair& p = pairs_[i];
        if (taken_[i] || view_.component[p.a] != component || blocked[p.a] || blocked[p.b]) continue;
        if (tier == 0 && (involved[p.a] || involved[p.b] || nearby[p.a] || nearby[p.b])) continue;
        if (!keeps_valence(p.a, p.b)) continue;
        if (++scored > kMaxScored) break;  // bounded work per search
        if (!fit(p, labels)) continue;
        taken_[i] = 1;
        return p;
      }
    }
    return {0, kNone, kNone};
  }

 private:
  static constexpr uint32_t kMaxScored = 64;

  bool keeps_valence(uint32_t a, uint32_t b) {
    auto ab = view_.neighbours.begin() + view_.neighbour_offsets[a], ae = view_.neighbours.begin() + view_.neighbour_offsets[a + 1];
    auto bb = view_.neighbours.begin() + view_.neighbour_offsets[b], be = view_.neighbours.begin() + view_.neighbour_offsets[b + 1];
    common_.clear();
    std::set_intersection(ab, ae, bb, be, std::back_inserter(common_));
    for (uint32_t c : common_)
      if (view_.valence(c) < 4) return false;
    return true;
  }

  bool fit(const Pair& p, const std::vector<uint32_t>& labels) {
    faces_.clear();
    for (uint32_t c : {p.a, p.b})
      faces_.insert(faces_.end(), view_.members.begin() + view_.offsets[c], view_.members.begin() + view_.offsets[c + 1]);
    side_.assign(faces_.size(), 0);
    if (!(check_.score(faces_, side_, 1, labels) < 10)) return false;
    // The corners around the merged cluster (b now a) against the round's starting neighbours;
    // the round's other changes are kept away from it (`nearby`), and the next round's defect
    // search sees everything anyway.
    return corners_.all_triangulable(
        faces_, [&](uint32_t f) { return labels[f] == p.b ? p.a : labels[f]; },
        [&](uint32_t x, uint32_t y) {
          if (y == p.a) std::swap(x, y);
          if (x == p.a) return adjacent(p.a, y) || adjacent(p.b, y);
          return adjacent(x, y);
        });
  }

  bool adjacent(uint32_t x, uint32_t y) const {
    auto begin = view_.neighbours.begin() + view_.neighbour_offsets[x];
    return std::binary_search(begin, view_.neighbours.begin() + view_.neighbour_offsets[x + 1], y);
  }

  const ClusterView& view_;
  RegionCheck& check_;
  CornerPolygons& corners_;
  std::vector<Pair> pairs_;
  std::vector<uint8_t> taken_;
  std::vector<uint32_t> common_, faces_;
  std::vector<uint8_t> side_;
};

// One round of fixes on `labels` (the clustering of `view`): separating faces moved out of double
// borders, then the clusters the other defects name cut into 2 or 3 fit pieces with as many fit
// merges in the same components. Each cluster takes part in one change per round (the view's face
// lists stay exact for the others). Returns the fixes.
std::vector<CoarsenFix> fix_round(const Topology& topology, const ClusterView& view,
                                  const std::vector<DualDefect>& defects, uint32_t round, ClusterCutter& cutter,
                                  RegionCheck& check, CornerPolygons& corners, std::vector<uint32_t>& labels) {
  const uint32_t n = view.clusters;
  std::vector<uint8_t> involved(n, 0), blocked(n, 0), nearby(n, 0);
  for (const DualDefect& d : defects)
    for (uint32_t c : {d.cluster, d.other, d.third})
      if (c < n) involved[c] = 1;
  auto mark_neighbours = [&](uint32_t c) {
    for (uint32_t i = view.neighbour_offsets[c]; i < view.neighbour_offsets[c + 1]; ++i) nearby[view.neighbours[i]] = 1;
  };

  std::vector<CoarsenFix> fixes;
  // Double borders first by moving a separating face: a face of a third cluster with edges on both
  // clusters, moved into one of them when both clusters it changes stay fit. Cheap (n unchanged)
  // and what a border roughened by the iteration needs (one face of a neighbour poking between the
  // two, splitting their border in two).
  std::vector<uint32_t> faces;
  std::vector<uint8_t> side;
  auto fit_without = [&](uint32_t cluster, uint32_t face) {
    faces.clear();
    for (uint32_t i = view.offsets[cluster]; i < view.offsets[cluster + 1]; ++i)
      if (view.members[i] != face) faces.push_back(view.members[i]);
    if (faces.empty()) return false;
    side.assign(faces.size(), 0);
    return check.score(faces, side, 1, labels) < 10;
  };
  auto fit_with = [&](uint32_t cluster, uint32_t face) {
    faces.assign(view.members.begin() + view.offsets[cluster], view.members.begin() + view.offsets[cluster + 1]);
    faces.push_back(face);
    side.assign(faces.size(), 0);
    return check.score(faces, side, 1, labels) < 10;
  };
  for (const DualDefect& d : defects) {
    if (d.kind != DualDefect::double_border || blocked[d.cluster] || blocked[d.other]) continue;
    bool done = false;
    for (uint32_t i = view.offsets[d.cluster]; i < view.offsets[d.cluster + 1] && !done; ++i)
      for (int e = 0; e < 3 && !done; ++e) {
        uint32_t f = topology.face_adjacent[3 * size_t(view.members[i]) + e];
        if (f == kNone || labels[f] == d.cluster || labels[f] == d.other || blocked[labels[f]]) continue;
        bool touches_other = false;
        for (int k = 0; k < 3; ++k) {
          uint32_t g = topology.face_adjacent[3 * size_t(f) + k];
          touches_other = touches_other || (g != kNone && labels[g] == d.other);
        }
        if (!touches_other) continue;
        uint32_t from = labels[f];
        if (!fit_without(from, f)) continue;
        for (uint32_t to : {d.cluster, d.other}) {
          if (!fit_with(to, f)) continue;
          labels[f] = to;
          for (uint32_t c : {from, d.cluster, d.other}) blocked[c] = 1, mark_neighbours(c);
          CoarsenFix fix;
          fix.action = CoarsenFix::move_faces;
          fix.defect = d;
          fix.cluster = from;
          fix.other = to;
          fix.faces = 1;
          fix.round = round;
          fixes.push_back(fix);
          done = true;
          break;
        }
      }
  }

  // Which cluster to cut for each defect: one cut per cluster, none for a defect whose clusters
  // already have one this round (that cut may remove it).
  struct Cut {
    DualDefect defect;
    uint32_t target, partner;
    ClusterCutter::Plan plan;  // planned already (across a loop), else to plan
  };
  std::vector<Cut> cuts;
  for (const DualDefect& d : defects) {
    bool handled = false;
    for (const Cut& c : cuts) handled = handled || uses(d, c.target);
    if (handled) continue;
    const std::vector<uint32_t> choices = cut_choices(d, view);
    auto available = [&](uint32_t c) { return c < n && view.size(c) >= 2 && !blocked[c]; };
    auto take = [&](uint32_t c, ClusterCutter::Plan plan) {
      uint32_t partner = d.kind == DualDefect::double_border ? (c == d.cluster ? d.other : d.cluster) : kNone;
      cuts.push_back({d, c, partner, std::move(plan)});
      blocked[c] = 1;
      mark_neighbours(c);
      if (partner != kNone) blocked[partner] = 1, mark_neighbours(partner);
    };
    bool planned = false;
    if (d.kind == DualDefect::missing_boundary_edge)  // the one of the two that can be cut across the loop
      for (uint32_t c : choices) {
        if (!available(c)) continue;
        ClusterCutter::Plan plan = cutter.plan_across_loop(view, labels, c, c == d.cluster ? d.other : d.cluster);
        if (plan.score < 10) {
          take(c, std::move(plan));
          planned = true;
          break;
        }
      }
    if (!planned)
      for (uint32_t c : choices)
        if (available(c)) {
          take(c, {});
          break;
        }
  }

  if (cuts.empty()) return fixes;
  MergeFinder merges(view, check, corners);
  for (Cut& cut : cuts) {
    ClusterCutter::Plan plan = std::move(cut.plan);
    if (!(plan.score < 10))
      plan = cutter.plan(view, labels, cut.target, cut.partner, cut.defect.kind == DualDefect::boundary_arcs);
    if (!(plan.score < 10)) continue;  // no cut gives fit pieces: leave it to a later round
    std::vector<MergeFinder::Pair> chosen;
    for (uint8_t k = 1; k < plan.pieces; ++k) {
      MergeFinder::Pair p = merges.find(view.component[cut.target], blocked, involved, nearby, labels);
      if (p.a == kNone) break;
      chosen.push_back(p);
      blocked[p.a] = blocked[p.b] = 1;  // each cluster in one change per round
      mark_neighbours(p.a);
      mark_neighbours(p.b);
    }
    if (chosen.size() + 1 < plan.pieces) continue;  // no room in this component this round
    const uint32_t* members = &view.members[view.offsets[cut.target]];
    for (size_t k = 0; k < chosen.size(); ++k) {
      for (uint32_t i = view.offsets[chosen[k].b]; i < view.offsets[chosen[k].b + 1]; ++i)
        labels[view.members[i]] = chosen[k].a;
      uint32_t piece = uint32_t(k + 1);
      for (uint32_t i = 0; i < view.size(cut.target); ++i)
        if (plan.side[i] == piece) labels[members[i]] = chosen[k].b;
      CoarsenFix fix;
      fix.action = CoarsenFix::cut;
      fix.defect = cut.defect;
      fix.cluster = cut.target;
      fix.merged_into = chosen[k].a;
      fix.freed = chosen[k].b;
      fix.round = round;
      fixes.push_back(fix);
    }
  }
  return fixes;
}

// Defects per mesh component (through the first cluster each names).
std::vector<uint32_t> defects_per_component(const Topology& topology, const std::vector<uint32_t>& labels,
                                            uint32_t clusters, const std::vector<DualDefect>& defects) {
  std::vector<uint32_t> component(clusters, kNone), count(topology.component_count, 0);
  for (size_t f = 0; f < labels.size(); ++f) component[labels[f]] = topology.face_component[f];
  for (const DualDefect& d : defects)
    if (d.cluster < clusters && component[d.cluster] != kNone) ++count[component[d.cluster]];
  return count;
}

// Clusters per mesh component.
std::vector<uint32_t> clusters_per_component(const Topology& topology, const std::vector<uint32_t>& labels,
                                             uint32_t clusters) {
  std::vector<uint32_t> component(clusters, kNone), count(topology.component_count, 0);
  for (size_t f = 0; f < labels.size(); ++f) component[labels[f]] = topology.face_component[f];
  for (uint32_t c = 0; c < clusters; ++c)
    if (component[c] != kNone) ++count[component[c]];
  return count;
}

// Component `c` of `base` takes the clusters of `other` there (the same number of them): the ids
// base uses in c, in increasing order, go to other's clusters of c in increasing order.
void replace_component(const Topology& topology, std::vector<uint32_t>& base, const std::vector<uint32_t>& other,
                       uint32_t c) {
  std::vector<uint32_t> base_ids, other_ids;
  for (size_t f = 0; f < base.size(); ++f)
    if (topology.face_component[f] == c) base_ids.push_back(base[f]), other_ids.push_back(other[f]);
  std::sort(base_ids.begin(), base_ids.end());
  base_ids.erase(std::unique(base_ids.begin(), base_ids.end()), base_ids.end());
  std::vector<uint32_t> sorted_other = other_ids;
  std::sort(sorted_other.begin(), sorted_other.end());
  sorted_other.erase(std::unique(sorted_other.begin(), sorted_other.end()), sorted_other.end());
  assert(base_ids.size() == sorted_other.size());
  for (size_t f = 0; f < base.size(); ++f)
    if (topology.face_component[f] == c) {
      size_t rank = size_t(std::lower_bound(sorted_other.begin(), sorted_other.end(), other[f]) - sorted_other.begin());
      base[f] = base_ids[rank];
    }
}


// The work merge_down may do: faces scored (a candidate's two clusters, checked by RegionCheck and
// the corner polygons), shared by the calls of one merge_down_with_flips. A pair that does not fit
// is scored again whenever a cluster next to it merges, which is cheap while clusters are small;
// merged down to a few clusters of thousands of faces each it is quadratic (a closed tetrahedron
// subdivided six times, 16k faces, rebuilt from single faces toward its 4 clusters: 78 s). Over
// libcgal-demo at faces / 10 and / 40 (also with --gradation 1) one call scored at most 77 faces
// per face of the components it merged (b9_mesh -> 254), and with this budget every output there
// is the same. When the budget is spent merge_down stops where it is: those components stay above
// their targets, as where no merge fits. The budget per face is
// CoarsenMeshOptions::merge_budget_per_face (512).
struct MergeBudget {
  uint64_t left = UINT64_MAX;
};

// Merges adjacent clusters of a valid clustering, cheapest energy first, until every component
// holds its target count, taking only merges that keep the dual valid: the merged cluster is fit
// (RegionCheck: a disk, one border with each neighbour, enough neighbours), the clusters next to
// both keep three neighbours or more, and every corner polygon around the merged cluster keeps a
// triangulation whose diagonals are neither edges nor possible diagonals of another corner, and,
// at the boundary, two end clusters that share no border (their edge is the boundary's there)
// (CornerPolygons, DiagonalLedger), and no boundary loop is left to fewer than three clusters
// (BoundaryLoops). In the dual that is an edge contraction meeting the link condition, so the dual
// stays a manifold of the same topology. Returns the merges made; the
// targets are met when it equals clusters - sum(targets). Labels come out renumbered to
// [0, sum(targets)) in the order of their old ids. by_weight: lightest pair first instead (even
// sizes; a second chance when the energy order runs into a dead end, where every merge left would
// leave some cluster with two neighbours).
uint32_t merge_down(const Topology& topology, const FaceData& data, RegionCheck& check, CornerPolygons& corners,
                    const BoundaryLoops& boundary_loops, std::vector<uint32_t>& labels, uint32_t clusters,
                    const std::vector<uint32_t>& targets, MergeBudget& budget, bool by_weight = false) {
  ClusterView view = view_of(topology, data, labels, clusters);
  // The boundary loops each cluster meets, and how many clusters meet each loop.
  std::vector<std::vector<uint32_t>> loops = boundary_loops.of_clusters(labels, clusters);
  std::vector<uint32_t> loop_clusters(boundary_loops.count(), 0);
  for (const std::vector<uint32_t>& l : loops)
    for (uint32_t id : l) ++loop_clusters[id];
  std::vector<uint32_t> shared_loops;
  std::vector<std::vector<uint32_t>> members(clusters), neighbours(clusters);
  std::vector<double> weight = view.weight, sum(3 * size_t(clusters));
  std::vector<uint32_t> stamp(clusters, 0), count(targets.size(), 0);
  std::vector<uint8_t> alive(clusters, 1);
  for (uint32_t c = 0; c < clusters; ++c) {
    members[c].assign(view.members.begin() + view.offsets[c], view.members.begin() + view.offsets[c + 1]);
    neighbours[c].assign(view.neighbours.begin() + view.neighbour_offsets[c],
                         view.neighbours.begin() + view.neighbour_offsets[c + 1]);
    for (int k = 0; k < 3; ++k) sum[3 * size_t(c) + k] = weight[c] * view.centroid[3 * size_t(c) + k];
    if (!members[c].empty()) ++count[view.component[c]];
  }
  struct Entry {
    double cost;
    uint32_t a, b, stamp_a, stamp_b;
    bool operator>(const Entry& o) const {
      if (cost != o.cost) return cost > o.cost;
      return a != o.a ? a > o.a : b > o.b;
    }
  };
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  auto push = [&](uint32_t a, uint32_t b) {
    if (a > b) std::swap(a, b);
    double w = weight[a] + weight[b], d = 0;
    for (int k = 0; k < 3; ++k) {
      double x = (w > 0 && weight[a] > 0 ? sum[3 * size_t(a) + k] / weight[a] : 0) -
                 (w > 0 && weight[b] > 0 ? sum[3 * size_t(b) + k] / weight[b] : 0);
      d += x * x;
    }
    heap.push({by_weight ? w : w > 0 ? weight[a] * weight[b] / w * d : 0.0, a, b, stamp[a], stamp[b]});
  };
  // The pairs with a valid entry not popped yet, each listed with the lower id of the two (a few
  // per cluster: its current neighbours at most). A merge changes the cost of the merged cluster's
  // pairs only; its neighbours' other pairs keep theirs and need an entry again only where theirs
  // was popped.
  std::vector<std::vector<uint32_t>> pending(clusters);
  auto mark_pending = [&](uint32_t x, uint32_t y) {  // false: it was already
    if (x > y) std::swap(x, y);
    std::vector<uint32_t>& p = pending[x];
    if (std::find(p.begin(), p.end(), y) != p.end()) return false;
    p.push_back(y);
    return true;
  };
  auto unmark_pending = [&](uint32_t x, uint32_t y) {
    if (x > y) std::swap(x, y);
    std::vector<uint32_t>& p = pending[x];
    auto it = std::find(p.begin(), p.end(), y);
    if (it != p.end()) *it = p.back(), p.pop_back();
  };
  for (uint32_t a = 0; a < clusters; ++a)
    for (uint32_t b : neighbours[a])
      if (a < b) push(a, b), mark_pending(a, b);
  std::vector<uint32_t> common, faces;
  std::vector<uint8_t> side;
  DiagonalLedger ledger;
  auto current = [&](uint32_t f) { return labels[f]; };
  for (uint32_t v = 0; v + 1 < topology.vertex_face_offsets.size(); ++v)
    if (corners.at(v, current)) ledger.add(corners.polygon().data(), corners.polygon().size(), +1, corners.open());
  std::vector<uint32_t> old_polygons, new_polygons, kept_polygons, old_offsets, new_offsets, kept_offsets;
  std::vector<uint8_t> old_open, new_open, kept_open;
  auto fit = [&](uint32_t a, uint32_t b) {
    shared_loops.clear();
    std::set_intersection(loops[a].begin(), loops[a].end(), loops[b].begin(), loops[b].end(),
                          std::back_inserter(shared_loops));
    for (uint32_t id : shared_loops)
      if (loop_clusters[id] <= 3) return false;  // the loop would be left to two clusters
    common.clear();
    std::set_intersection(neighbours[a].begin(), neighbours[a].end(), neighbours[b].begin(), neighbours[b].end(),
                          std::back_inserter(common));
    for (uint32_t c : common)
      if (neighbours[c].size() < 4) return false;
    faces = members[a];
    faces.insert(faces.end(), members[b].begin(), members[b].end());
    side.assign(faces.size(), 0);
    if (!(check.score(faces, side, 1, labels) < 10)) return false;
    // The polygons around the merged cluster, before and after, swapped in the ledger; every
    // polygon after needs a triangulation whose diagonals are neither edges nor another
    // polygon's possible diagonals.
    auto before = [&](uint32_t f) { return labels[f]; };
    auto after = [&](uint32_t f) { return labels[f] == b ? a : labels[f]; };
    old_polygons.clear(), new_polygons.clear(), kept_polygons.clear(), old_open.clear(), new_open.clear();
    kept_open.clear();
    old_offsets.assign(1, 0), new_offsets.assign(1, 0), kept_offsets.assign(1, 0);
    auto append = [&](std::vector<uint32_t>& polygons, std::vector<uint32_t>& offsets, std::vector<uint8_t>& open) {
      polygons.insert(polygons.end(), corners.polygon().begin(), corners.polygon().end());
      offsets.push_back(uint32_t(polygons.size()));
      open.push_back(corners.open());
    };
    // Only the merged pair's border vertices can hold a polygon (the ledger's sums and the checks
    // do not depend on their order). A polygon without b is the same after the merge: checked
    // again (its neighbours' borders change), but its diagonals stay in the ledger as they are.
    for (uint32_t v : corners.border_vertices_of(faces, [&](uint32_t g) { return labels[g] == a || labels[g] == b; })) {
      if (corners.at(v, before)) {
        const std::vector<uint32_t>& polygon = corners.polygon();
        if (std::find(polygon.begin(), polygon.end(), b) == polygon.end()) {
          append(kept_polygons, kept_offsets, kept_open);
          continue;
        }
        append(old_polygons, old_offsets, old_open);
      }
      if (corners.at(v, after)) append(new_polygons, new_offsets, new_open);
    }
    auto swap_in = [&](const std::vector<uint32_t>& out, const std::vector<uint32_t>& out_offsets,
                       const std::vector<uint8_t>& out_open, const std::vector<uint32_t>& in,
                       const std::vector<uint32_t>& in_offsets, const std::vector<uint8_t>& in_open) {
      for (size_t i = 0; i + 1 < out_offsets.size(); ++i)
        ledger.add(&out[out_offsets[i]], out_offsets[i + 1] - out_offsets[i], -1, out_open[i]);
      for (size_t i = 0; i + 1 < in_offsets.size(); ++i)
        ledger.add(&in[in_offsets[i]], in_offsets[i + 1] - in_offsets[i], +1, in_open[i]);
    };
    swap_in(old_polygons, old_offsets, old_open, new_polygons, new_offsets, new_open);
    auto contains = [](const std::vector<uint32_t>& list, uint32_t x) {
      return std::binary_search(list.begin(), list.end(), x);
    };
    auto adjacent = [&](uint32_t x, uint32_t y) {
      if (y == a) std::swap(x, y);
      if (x == a) return contains(neighbours[a], y) || contains(neighbours[b], y);
      return contains(neighbours[x], y);
    };
    auto taken = [&](uint32_t x, uint32_t y) {
      // this polygon's own candidacy is one; a boundary step is an edge of the dual
      return ledger.count(x, y) > 1 || ledger.steps(x, y) > 0 || adjacent(x, y);
    };
    auto joined = [&](uint32_t x, uint32_t y) {  // a closing side: the boundary step (x, y) is its own
      return ledger.steps(x, y) > 1 || adjacent(x, y);
    };
    auto all_triangulable = [&](const std::vector<uint32_t>& polygons, const std::vector<uint32_t>& offsets,
                                const std::vector<uint8_t>& open) {
      for (size_t i = 0; i + 1 < offsets.size(); ++i)
        if (!corners.triangulable(&polygons[offsets[i]], offsets[i + 1] - offsets[i], taken, open[i], joined))
          return false;
      return true;
    };
    if (!all_triangulable(new_polygons, new_offsets, new_open) ||
        !all_triangulable(kept_polygons, kept_offsets, kept_open)) {
      swap_in(new_polygons, new_offsets, new_open, old_polygons, old_offsets, old_open);
      return false;
    }
    return true;  // the merge follows: the ledger already holds its polygons
  };
  uint32_t merges = 0;
  while (!heap.empty()) {
    Entry e = heap.top();
    heap.pop();
    uint32_t a = e.a, b = e.b;
    if (!alive[a] || !alive[b] || e.stamp_a != stamp[a] || e.stamp_b != stamp[b]) continue;  // stale
    unmark_pending(a, b);
    uint32_t component = view.component[a];
    if (count[component] <= targets[component]) continue;
    const uint64_t cost = members[a].size() + members[b].size();
    if (cost > budget.left) break;
    budget.left -= cost;
    if (!fit(a, b)) continue;
    // b joins a
    for (uint32_t f : members[b]) labels[f] = a;
    members[a].insert(members[a].end(), members[b].begin(), members[b].end());
    members[b].clear();
    for (uint32_t id : shared_loops) --loop_clusters[id];  // (fit(a, b) left them)
    if (!loops[b].empty()) {
      std::vector<uint32_t> joined_loops;
      std::set_union(loops[a].begin(), loops[a].end(), loops[b].begin(), loops[b].end(), std::back_inserter(joined_loops));
      loops[a] = std::move(joined_loops);
      loops[b].clear();
    }
    weight[a] += weight[b];
    for (int k = 0; k < 3; ++k) sum[3 * size_t(a) + k] += sum[3 * size_t(b) + k];
    std::vector<uint32_t> joined;
    std::set_union(neighbours[a].begin(), neighbours[a].end(), neighbours[b].begin(), neighbours[b].end(),
                   std::back_inserter(joined));
    joined.erase(std::remove_if(joined.begin(), joined.end(), [&](uint32_t c) { return c == a || c == b; }), joined.end());
    neighbours[a] = joined;
    for (uint32_t r : neighbours[b]) {
      if (r == a) continue;
      unmark_pending(r, b);  // (its entries are stale now)
      std::vector<uint32_t>& nr = neighbours[r];
      nr.erase(std::find(nr.begin(), nr.end(), b));
      auto at = std::lower_bound(nr.begin(), nr.end(), a);
      if (at == nr.end() || *at != a) nr.insert(at, a);
    }
    neighbours[b].clear();
    pending[b].clear();
    alive[b] = 0;
    --count[component];
    ++merges;
    // Everything around the merged cluster may have become (un)fit: its pairs get new costs, its
    // neighbours' other pairs are scored again when next popped (pushed again where popped).
    ++stamp[a];
    for (uint32_t r : neighbours[a]) {
      push(a, r), mark_pending(a, r);
      for (uint32_t s : neighbours[r])
        if (s != a && mark_pending(r, s)) push(r, s);
    }
  }
  std::vector<uint32_t> renumber(clusters, kNone);
  uint32_t next = 0;
  for (uint32_t c = 0; c < clusters; ++c)
    if (alive[c] && !members[c].empty()) renumber[c] = next++;
  for (uint32_t& l : labels) l = renumber[l];
  return merges;
}

// When merge_down stops above a target, every merge left would break the dual: in the dual's terms
// the triangulation is irreducible, each edge (a, b) on a triangle (a, b, z) that bounds no face (z
// next to both a and b away from the ends of their border), whose contraction would pinch the
// surface. Near the fewest vertices a surface allows (10 for genus 3) greedy contraction stops
// there, well above the target. An edge flip takes such a triangle apart: the strip of faces of one
// of x, z (x one of a, b) along their border goes to a cluster u at an end of that border, so x and
// z no longer touch (the dual edge (x, z) becomes the edge from u to the other end). One flip that
// makes a merge valid, and that merge, are made here: pairs cheapest first; a candidate must leave
// every cluster it touches fit (RegionCheck), with three neighbours or more, and the corner polygons
// around it triangulable, and then pass find_dual_defects on the whole component (at most
// kMaxFullChecks of those per call). Returns the labels with one cluster less (the last id takes the
// merged one's), or empty when no flip helps.
template <class DefectsOf>
std::vector<uint32_t> flip_then_merge(const Mesh& mesh, const Topology& topology, const FaceData& data,
                                      RegionCheck& check, CornerPolygons& corners, const std::vector<uint32_t>& labels,
                                      uint32_t clusters, const std::vector<uint32_t>& targets, DefectsOf defects_of) {
  constexpr size_t kMaxPairs = 64;         // cheapest pairs tried per call
  constexpr uint32_t kMaxFullChecks = 16;  // find_dual_defects calls per call
  const ClusterView view = view_of(topology, data, labels, clusters);
  const std::vector<uint32_t> held = clusters_per_component(topology, labels, clusters);
  struct Pair {
    double cost;
    uint32_t a, b;
  };
  std::vector<Pair> pairs;
  for (uint32_t a = 0; a < clusters; ++a)
    for (uint32_t i = view.neighbour_offsets[a]; i < view.neighbour_offsets[a + 1]; ++i) {
      uint32_t b = view.neighbours[i], c = view.component[a];
      if (b <= a || held[c] <= targets[c]) continue;
      pairs.push_back({view.merge_cost(a, b), a, b});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    return x.cost != y.cost ? x.cost < y.cost : x.a != y.a ? x.a < y.a : x.b < y.b;
  });
  if (pairs.size() > kMaxPairs) pairs.resize(kMaxPairs);

  auto members_of = [&](uint32_t c) {
    return std::span<const uint32_t>(view.members.data() + view.offsets[c], view.size(c));
  };
  auto neighbours_of = [&](uint32_t c) {
    return std::span<const uint32_t>(view.neighbours.data() + view.neighbour_offsets[c], view.valence(c));
  };
  // `work`: the labels with the candidate flip and merge applied (b's faces labelled a), undone
  // after each candidate.
  std::vector<uint32_t> work = labels, vertex_mark(mesh.vertex_count(), kNone);
  std::vector<uint32_t> strip, touched, faces;
  std::vector<uint8_t> side;
  std::vector<std::vector<uint32_t>> touched_neighbours;
  const std::vector<DualDefect> before = defects_of(labels, clusters);
  const std::vector<uint32_t> broken_before = defects_per_component(topology, labels, clusters, before);
  uint32_t full_checks = 0;
  for (const Pair& p : pairs) {
    std::vector<uint32_t> common;
    std::span<const uint32_t> na = neighbours_of(p.a), nb = neighbours_of(p.b);
    std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
    // A valid merge needs a and b to have exactly the two clusters at the ends of their border in
    // common (one on the boundary); one flip takes one away, so more than three is out of reach.
    if (common.size() > 3) continue;
    for (uint32_t z : common)
      for (uint32_t x : {p.a, p.b})
        for (uint32_t giver : {x, z}) {
          const uint32_t other = giver == x ? z : x;
          // The strip: faces of giver with a corner on a face of other.
          for (uint32_t f : members_of(other))
            for (int k = 0; k < 3; ++k) vertex_mark[mesh.indices[3 * size_t(f) + k]] = other;
          strip.clear();
          for (uint32_t f : members_of(giver))
            for (int k = 0; k < 3; ++k)
              if (vertex_mark[mesh.indices[3 * size_t(f) + k]] == other) {
                strip.push_back(f);
                break;
              }
          for (uint32_t f : members_of(other))
            for (int k = 0; k < 3; ++k) vertex_mark[mesh.indices[3 * size_t(f) + k]] = kNone;
          if (strip.empty() || strip.size() == view.size(giver)) continue;
          // Every other cluster at a corner of the strip: the ends of the border (receivers), and
          // whatever else the strip touches (their borders change too).
          std::vector<uint32_t> around;
          for (uint32_t f : strip)
            for (int k = 0; k < 3; ++k) {
              uint32_t v = mesh.indices[3 * size_t(f) + k];
              for (uint32_t i = topology.vertex_face_offsets[v]; i < topology.vertex_face_offsets[v + 1]; ++i) {
                uint32_t l = labels[topology.vertex_faces[i]];
                if (l != giver) around.push_back(l);
              }
            }
          std::sort(around.begin(), around.end());
          around.erase(std::unique(around.begin(), around.end()), around.end());
          for (uint32_t u : around) {
            if (u == x || u == z) continue;
            const uint32_t merged_into = p.a;
            auto after = [&](uint32_t c) { return c == p.b ? merged_into : c; };
            for (uint32_t f : strip) work[f] = after(u);
            for (uint32_t f : members_of(p.b))
              if (work[f] == p.b) work[f] = merged_into;
            // The clusters whose faces or borders change, as they are after the flip and merge:
            // those around the strip and the merged one get their faces scored and their
            // neighbours listed again; the other neighbours of a and b keep their faces and lose at
            // most b (now a): their lists are the old ones renamed, and need three entries.
            // Those rescored come first, the likeliest to fail first: the merged cluster, giver, u.
            touched.clear();
            auto touch = [&](uint32_t c) {
              if (std::find(touched.begin(), touched.end(), c) == touched.end()) touched.push_back(c);
            };
            for (uint32_t c : {merged_into, after(giver), after(u)}) touch(c);
            for (uint32_t c : around) touch(after(c));
            const size_t rescored = touched.size();
            for (uint32_t k : {p.a, p.b})
              for (uint32_t c : neighbours_of(k)) touch(after(c));
            bool ok = true;
            touched_neighbours.assign(touched.size(), {});
            for (size_t t = 0; t < touched.size() && ok; ++t) {
              const uint32_t c = touched[t];
              std::vector<uint32_t>& nc = touched_neighbours[t];
              if (t >= rescored) {
                for (uint32_t o : neighbours_of(c)) nc.push_back(after(o));
              } else {
                // Its faces now: its own still labelled c, b's if it is the merged one, the strip
                // if it is u.
                uint32_t sources[3] = {c, kNone, kNone};
                if (c == merged_into) sources[1] = p.b;
                if (c == after(u) && giver != c && giver != sources[1]) sources[2] = giver;
                faces.clear();
                for (uint32_t k : sources)
                  if (k != kNone)
                    for (uint32_t f : members_of(k))
                      if (work[f] == c) faces.push_back(f);
                for (uint32_t f : faces)
                  for (int e = 0; e < 3; ++e) {
                    uint32_t o = topology.face_adjacent[3 * size_t(f) + e];
                    if (o != kNone && work[o] != c) nc.push_back(work[o]);
                  }
                side.assign(faces.size(), 0);
                ok = !faces.empty() && check.score(faces, side, 1, work) < 10;
              }
              std::sort(nc.begin(), nc.end());
              nc.erase(std::unique(nc.begin(), nc.end()), nc.end());
              nc.erase(std::remove(nc.begin(), nc.end(), c), nc.end());
              ok = ok && nc.size() >= 3;
            }
            // Corner polygons around the changed clusters, with the neighbours as they are now.
            auto adjacent = [&](uint32_t s, uint32_t t) {
              auto it = std::find(touched.begin(), touched.end(), s);
              if (it == touched.end()) {
                it = std::find(touched.begin(), touched.end(), t);
                if (it == touched.end()) {  // neither changed: as before
                  std::span<const uint32_t> ns = neighbours_of(s);
                  return std::binary_search(ns.begin(), ns.end(), t);
                }
                std::swap(s, t);
              }
              const std::vector<uint32_t>& ns = touched_neighbours[size_t(it - touched.begin())];
              return std::binary_search(ns.begin(), ns.end(), t);
            };
            if (ok) {
              faces.clear();
              for (uint32_t k : {p.a, p.b, u})
                for (uint32_t f : members_of(k)) faces.push_back(f);
              faces.insert(faces.end(), strip.begin(), strip.end());
              ok = corners.all_triangulable(faces, [&](uint32_t f) { return work[f]; }, adjacent);
            }
            if (ok && full_checks < kMaxFullChecks) {
              ++full_checks;
              std::vector<uint32_t> merged = work;
              if (p.b != clusters - 1)
                for (uint32_t& l : merged)
                  if (l == clusters - 1) l = p.b;
              std::vector<DualDefect> found = defects_of(merged, clusters - 1);
              std::vector<uint32_t> broken = defects_per_component(topology, merged, clusters - 1, found);
              const uint32_t c = view.component[p.a];
              if (broken[c] == 0 && found.size() <= before.size() - broken_before[c]) return merged;
            }
            for (uint32_t f : members_of(p.b)) work[f] = p.b;
            for (uint32_t f : strip) work[f] = giver;
            if (full_checks >= kMaxFullChecks) return {};
          }
        }
  }
  return {};
}

// merge_down by energy, and per component where that stops above its target, by weight.
std::vector<uint32_t> merge_down_twice(const Topology& topology, const FaceData& data, RegionCheck& check,
                                       CornerPolygons& corners, const BoundaryLoops& boundary_loops,
                                       const std::vector<uint32_t>& labels,
                                       uint32_t clusters, const std::vector<uint32_t>& targets, MergeBudget& budget) {
  std::vector<uint32_t> by_energy = labels;
  merge_down(topology, data, check, corners, boundary_loops, by_energy, clusters, targets, budget);
  std::vector<uint32_t> held = clusters_per_component(topology, by_energy, *std::max_element(by_energy.begin(), by_energy.end()) + 1);
  bool stuck = false;
  for (size_t c = 0; c < targets.size(); ++c) stuck = stuck || held[c] > targets[c];
  if (!stuck) return by_energy;
  std::vector<uint32_t> by_weight = labels;
  merge_down(topology, data, check, corners, boundary_loops, by_weight, clusters, targets, budget, true);
  std::vector<uint32_t> held_w = clusters_per_component(topology, by_weight, *std::max_element(by_weight.begin(), by_weight.end()) + 1);
  // Take each stuck component from the weight order where that one reached its target.
  for (size_t c = 0; c < targets.size(); ++c)
    if (held[c] > targets[c] && held_w[c] == targets[c]) {
      // both labelings are renumbered; carry component c over by rank into fresh ids above the rest
      uint32_t top = *std::max_element(by_energy.begin(), by_energy.end()) + 1;
      for (size_t f = 0; f < labels.size(); ++f)
        if (topology.face_component[f] == c) by_energy[f] = top + by_weight[f];
    }
  // Compact the ids again.
  std::vector<uint32_t> ids = by_energy;
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  for (uint32_t& l : by_energy) l = uint32_t(std::lower_bound(ids.begin(), ids.end(), l) - ids.begin());
  return by_energy;
}

// merge_down_twice, then where both orders stop above a target, flips (flip_then_merge) and
// merge_down again until the targets are met or no flip helps.
// Flips are for the last few clusters above a target (irreducible triangulations of the surfaces
// met so far stop within a few dozen of it); further above, or once kMaxFlips are made, it stops:
// each flip costs a few linear passes.
template <class DefectsOf>
std::vector<uint32_t> merge_down_with_flips(const Mesh& mesh, const Topology& topology, const FaceData& data,
                                            RegionCheck& check, CornerPolygons& corners,
                                            const BoundaryLoops& boundary_loops,
                                            const std::vector<uint32_t>& labels, uint32_t clusters,
                                            const std::vector<uint32_t>& targets, uint64_t budget_per_face,
                                            DefectsOf defects_of) {
  constexpr uint32_t kMaxFlips = 64;
  MergeBudget budget;  // budget_per_face per face of the components above their targets
  {
    const std::vector<uint32_t> held = clusters_per_component(topology, labels, clusters);
    uint64_t faces = 0;
    for (size_t f = 0; f < labels.size(); ++f) {
      const uint32_t c = topology.face_component[f];
      faces += held[c] > targets[c];
    }
    budget.left = faces > 0 && budget_per_face > UINT64_MAX / faces ? UINT64_MAX : budget_per_face * faces;
  }
  std::vector<uint32_t> result =
      merge_down_twice(topology, data, check, corners, boundary_loops, labels, clusters, targets, budget);
  for (uint32_t flips = 0;; ++flips) {
    uint32_t count = *std::max_element(result.begin(), result.end()) + 1;
    std::vector<uint32_t> held = clusters_per_component(topology, result, count);
    uint32_t excess = 0;
    for (size_t c = 0; c < targets.size(); ++c) excess += held[c] > targets[c] ? held[c] - targets[c] : 0;
    if (excess == 0 || excess + flips > kMaxFlips) return result;
    std::vector<uint32_t> flipped =
        flip_then_merge(mesh, topology, data, check, corners, result, count, targets, defects_of);
    if (flipped.empty()) return result;
    result = std::move(flipped);
    merge_down(topology, data, check, corners, boundary_loops, result, count - 1, targets, budget);
  }
}

// The fix loop on one clustering: rounds of fix_round until no defect is left; once valid, the
// iteration smooths the fixed clusters: fully (it may bring defects back: the energy can prefer a
// ring around a thin part; rounds without iterating then fix them), else in growing steps that
// each keep the clustering valid. Returns the labels with the fewest defects (the latest valid).
class FixLoop {
  static constexpr uint32_t kSmoothingSteps = 12;

 public:
  FixLoop(const Mesh& mesh, const Topology& topology, const CoarsenMeshOptions& options, const FaceData& data,
          RegionCheck& check, CornerPolygons& corners, ClusterCutter& cutter)
      : mesh_(mesh), topology_(topology), options_(options), data_(data), check_(check), corners_(corners),
        cutter_(cutter),
        weights_(options.cluster.density.empty() ? nullptr : &options.cluster.density) {}

  struct Outcome {
    std::vector<uint32_t> labels;
    std::vector<DualDefect> defects;
    std::optional<Clustering> clustering;  // set when `labels` are exactly this cluster() result's
    std::vector<CoarsenFix> fixes;
    uint32_t rounds = 0, iterations = 0;
  };

  std::vector<DualDefect> defects_of(const std::vector<uint32_t>& labels, uint32_t n) const {
    return find_dual_defects(mesh_, topology_, labels, n, options_.coarsen, weights_);
  }

  // `source`: the converged cluster() result the labels are (not smoothed again), or null.
  // `ro`: options for the iteration (clusters, component counts). `smooth`: smooth at all.
  // `first_round`: number of the first fix round. `known_defects`: defects_of(labels) when the
  // caller has them already (the coarse mesh that found them was built from the same labels).
  Outcome run(std::vector<uint32_t> labels, const Clustering* source, ClusterOptions ro, bool smooth,
              uint32_t first_round, const std::vector<DualDefect>* known_defects = nullptr) {
    Outcome out;
    ro.topology = TopologyMode::preserving;  // keeps the fixed clusters disks while they settle
    out.labels = labels;
    out.defects = known_defects ? *known_defects : defects_of(labels, ro.clusters);
    if (source) out.clustering = *source;
    next_round_ = first_round;
    clusters_ = ro.clusters;
    fix_rounds(out, labels);
    if (!out.defects.empty() || !smooth || out.clustering) return out;

    // Valid but not smoothed. Fully first:
    const std::vector<uint32_t> valid = out.labels;
    Clustering s = iterate(out, valid, ro, ro.max_iterations);
    labels = s.labels;
    std::vector<DualDefect> defects = defects_of(labels, ro.clusters);
    if (defects.empty()) {
      out.labels = std::move(labels), out.clustering = std::move(s);
      return out;
    }
    Outcome again;
    again.labels = labels;
    again.defects = std::move(defects);
    fix_rounds(again, labels);
    out.rounds += again.rounds;  // run, kept or not (the fixes are reported only where kept)
    if (again.defects.empty()) {
      out.labels = std::move(again.labels);
      out.fixes.insert(out.fixes.end(), again.fixes.begin(), again.fixes.end());
      return out;
    }
    // In steps from the valid labels: a step whose result is valid, or made valid again by fix
    // rounds, is taken and the next one is twice as long; one that cannot be made valid is tried
    // again half as long. At most kSmoothingSteps steps.
    uint32_t remaining = ro.max_iterations, step = 4;
    for (uint32_t steps = 0; remaining > 0 && step > 0 && steps < kSmoothingSteps; ++steps) {
      Clustering c = iterate(out, out.labels, ro, std::min(step, remaining));
      if (c.iterations == 0) break;
      std::vector<DualDefect> d = defects_of(c.labels, ro.clusters);
      if (!d.empty()) {
        Outcome repaired;
        repaired.labels = c.labels;
        repaired.defects = std::move(d);
        std::vector<uint32_t> work = c.labels;
        fix_rounds(repaired, work);
        out.rounds += repaired.rounds;
        if (!repaired.defects.empty()) {
          step /= 2;
          continue;
        }
        remaining -= std::min(remaining, c.iterations);
        out.labels = std::move(repaired.labels);
        out.clustering.reset();
        out.fixes.insert(out.fixes.end(), repaired.fixes.begin(), repaired.fixes.end());
        step *= 2;
        continue;
      }
      remaining -= std::min(remaining, c.iterations);
      out.labels = c.labels;
      bool converged = c.converged;
      out.clustering = std::move(c);
      if (converged) break;
      step *= 2;
    }
    return out;
  }

 private:
  Clustering iterate(Outcome& out, const std::vector<uint32_t>& from, ClusterOptions ro, uint32_t iterations) {
    ro.initial_labels = from;
    ro.max_iterations = iterations;
    Clustering c = cluster(mesh_, topology_, ro);
    out.iterations += c.iterations;
    return c;
  }

  // Rounds of fix_round from `labels` (whose defects are out.defects) until clean or stuck; out
  // keeps the best labels.
  void fix_rounds(Outcome& out, std::vector<uint32_t>& labels) {
    std::vector<DualDefect> defects = out.defects;
    const uint32_t clusters = clusters_;
    // Rounds are a function of the labels: labels seen before mean the rounds go round in a cycle
    // (a cut undone by a later round's merge), and the rest of them would only repeat it.
    std::vector<uint64_t> seen{labels_hash(labels)};
    for (uint32_t r = 0; !defects.empty() && r < options_.max_fix_rounds; ++r) {
      ClusterView view = view_of(topology_, data_, labels, clusters);
      std::vector<CoarsenFix> fixes =
          fix_round(topology_, view, defects, next_round_, cutter_, check_, corners_, labels);
      if (fixes.empty()) break;  // nothing this loop can change any more
      ++out.rounds;
      ++next_round_;
      for (CoarsenFix& f : fixes) f.clusters = clusters;
      out.fixes.insert(out.fixes.end(), fixes.begin(), fixes.end());
      defects = defects_of(labels, clusters);
      if (defects.size() < out.defects.size() || defects.empty())
        out.labels = labels, out.defects = defects, out.clustering.reset();
      uint64_t h = labels_hash(labels);
      if (std::find(seen.begin(), seen.end(), h) != seen.end()) break;
      seen.push_back(h);
    }
  }

  // FNV-1a over the labels.
  static uint64_t labels_hash(const std::vector<uint32_t>& labels) {
    uint64_t h = 14695981039346656037ull;
    for (uint32_t l : labels) h = (h ^ l) * 1099511628211ull;
    return h;
  }

  const Mesh& mesh_;
  const Topology& topology_;
  const CoarsenMeshOptions& options_;
  const FaceData& data_;
  RegionCheck& check_;
  CornerPolygons& corners_;
  ClusterCutter& cutter_;
  const std::vector<float>* weights_;
  uint32_t next_round_ = 1, clusters_ = 0;  // the number the next fix round takes (over all its fix_rounds)
};

}  // namespace

ComponentAllocation describe_components(const Mesh& mesh, const Topology& topology) {
  if (topology.face_component.size() != mesh.face_count())
    throw OptionError("coarsen: the topology was not built for this mesh");
  ComponentAllocation a;
  fill_components(mesh, topology, a);
  return a;
}

namespace {
// allocate_component_clusters, each component given at least floors[c] (>= its minimum) instead
// of its minimum where floors is given and their sum is at most n.
ComponentAllocation allocate_with_floors(const Mesh& mesh, const Topology& topology, uint32_t n,
                                         const std::vector<float>* density, const std::vector<uint32_t>* floors) {
  if (topology.face_component.size() != mesh.face_count())
    throw OptionError("coarsen: the topology was not built for this mesh");
  check_density(mesh, density);
  ComponentAllocation a;
  fill_components(mesh, topology, a);
  const uint32_t nc = topology.component_count;
  if (n == 0) throw OptionError("coarsen: the number of vertices must be at least 1");
  if (n > mesh.face_count())
    throw OptionError("coarsen: cannot make " + std::to_string(n) + " clusters from " +
                      std::to_string(mesh.face_count()) + " faces");
  uint64_t needed = 0;
  for (uint32_t c = 0; c < nc; ++c) {
    if (a.faces[c] < a.minimum[c])
      throw OptionError("coarsen: " + describe_component(a, c) + " has " + std::to_string(a.faces[c]) +
                        " faces, fewer than the " + std::to_string(a.minimum[c]) +
                        " clusters it needs to come out as a valid surface: subdivide it first (coarsen_surface "
                        "does, with refine_small_components)");
    needed += a.minimum[c];
  }
  if (n < needed) {
    std::string msg = "coarsen: n = " + std::to_string(n) + " is too small: the mesh's " + std::to_string(nc) +
                      " component" + (nc > 1 ? "s need" : " needs") + " at least " + std::to_string(needed) +
                      " clusters to come out as valid surfaces (";
    for (uint32_t c = 0; c < nc && c < 6; ++c)
      msg += (c ? "; " : "") + describe_component(a, c) + ": " + std::to_string(a.minimum[c]);
    if (nc > 6) msg += "; ...";
    throw OptionError(msg + ")");
  }

  std::vector<uint32_t> least(a.minimum);  // what the water filling gives a component at least
  if (floors) {
    uint64_t sum = 0;
    for (uint32_t c = 0; c < nc; ++c) sum += std::clamp((*floors)[c], a.minimum[c], a.faces[c]);
    if (sum <= n)
      for (uint32_t c = 0; c < nc; ++c) least[c] = std::clamp((*floors)[c], a.minimum[c], a.faces[c]);
  }
  // Share of each component: integral of sqrt(rho) dA.
  std::vector<double> share(nc, 0.0);
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    double rho = density && !density->empty() ? double((*density)[f]) : 1.0;
    share[topology.face_component[f]] += std::sqrt(rho) * face_area(mesh, f);
  }
  // Water filling: components whose proportional share is below their minimum (or above their
  // face count) are fixed there and the rest is shared again among the others.
  a.clusters.assign(nc, 0);
  std::vector<uint8_t> fixed(nc, 0);
  std::vector<double> target(nc, 0.0);
  for (;;) {
    uint64_t rest = n;
    double total = 0;
    uint32_t open = 0;
    for (uint32_t c = 0; c < nc; ++c) {
      if (fixed[c])
        rest -= a.clusters[c];
      else
        total += share[c], ++open;
    }
    if (open == 0) break;
    for (uint32_t c = 0; c < nc; ++c)
      if (!fixed[c]) target[c] = total > 0 ? double(rest) * share[c] / total : double(rest) / open;
    bool changed = false;
    for (uint32_t c = 0; c < nc; ++c)
      if (!fixed[c] && target[c] < least[c]) fixed[c] = 1, a.clusters[c] = least[c], changed = true;
    if (changed) continue;
    for (uint32_t c = 0; c < nc; ++c)
      if (!fixed[c] && target[c] > a.faces[c]) fixed[c] = 1, a.clusters[c] = a.faces[c], changed = true;
    if (!changed) break;
  }
  // Largest remainders for the components left open.
  uint64_t assigned = 0;
  std::vector<uint32_t> order;
  for (uint32_t c = 0; c < nc; ++c) {
    if (!fixed[c]) {
      a.clusters[c] = std::clamp(uint32_t(std::floor(target[c])), least[c], a.faces[c]);
      order.push_back(c);
    }
    assigned += a.clusters[c];
  }
  std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) {
    double fx = target[x] - std::floor(target[x]), fy = target[y] - std::floor(target[y]);
    return fx != fy ? fx > fy : x < y;
  });
  // Round-off may leave the sum a little off n either way; every component in the loop below has
  // room (n <= faces, n >= minimums), so this ends with exactly n.
  while (assigned < n) {
    bool placed = false;
    for (uint32_t c : order)
      if (assigned < n && a.clusters[c] < a.faces[c]) ++a.clusters[c], ++assigned, placed = true;
    for (uint32_t c = 0; c < nc && !placed; ++c)
      if (a.clusters[c] < a.faces[c]) ++a.clusters[c], ++assigned, placed = true;
    assert(placed);
    if (!placed) break;
  }
  while (assigned > n) {
    bool removed = false;
    for (auto it = order.rbegin(); it != order.rend(); ++it)
      if (assigned > n && a.clusters[*it] > least[*it]) --a.clusters[*it], --assigned, removed = true;
    for (uint32_t c = 0; c < nc && !removed; ++c)
      if (a.clusters[c] > least[c]) --a.clusters[c], --assigned, removed = true;
    assert(removed);
    if (!removed) break;
  }
  return a;
}
}  // namespace

ComponentAllocation allocate_component_clusters(const Mesh& mesh, const Topology& topology, uint32_t n,
                                                const std::vector<float>* density) {
  return allocate_with_floors(mesh, topology, n, density, nullptr);
}

namespace {

// coarsen_mesh of `mesh` without its collapsed faces (see coarsen_mesh), the labels given back to
// every face: a collapsed face takes the cluster of the lowest face with area at its lowest
// corner that has one; a collapsed face whose corners are on no other face takes cluster 0.
CoarsenMeshResult coarsen_without_collapsed_faces(const Mesh& mesh, const Topology& topology,
                                                  const CoarsenMeshOptions& options) {
  const size_t faces = mesh.face_count();
  Mesh kept = mesh;
  std::vector<uint32_t> kept_index;
  remove_collapsed_faces(kept, &kept_index);
  CoarsenMeshOptions kept_options = options;
  if (!options.cluster.density.empty()) {
    check_density(mesh, &options.cluster.density);
    std::vector<float>& density = kept_options.cluster.density;
    density.clear();
    for (size_t f = 0; f < faces; ++f)
      if (kept_index[f] != kNone) density.push_back(options.cluster.density[f]);
  }
  CoarsenMeshResult out = coarsen_mesh(kept, build_topology(kept, options.cluster.threads), kept_options);
  std::vector<uint32_t> labels = labels_with_collapsed_faces(mesh, topology, kept_index, out.clustering.labels, 0);
  out.clustering.labels = std::move(labels);
  out.collapsed_faces = topology.collapsed_faces;
  return out;
}

}  // namespace

namespace {

// Rounds in which broken components get more clusters (see coarsen_mesh), and the fewest faces a
// cluster of theirs keeps then (clusters of fewer than 4 faces resolve nothing: as the finer
// clusterings' limit).
constexpr uint32_t kReallocationRounds = 3;
constexpr uint32_t kReallocationFacesPerCluster = 4;
// Finer clusterings are tried only where the broken components hold at least 1/this of the faces.
constexpr uint64_t kFinerClusteringShare = 100;

// coarsen_mesh's steps 1-4 (see meshcvt/coarsen.h) with the given allocation of the n clusters to
// the components. given: the caller's options; options: the same with degenerate_to_surface off.
CoarsenMeshResult coarsen_allocated(const Mesh& mesh, const Topology& topology, const CoarsenMeshOptions& given,
                                    const CoarsenMeshOptions& options, ComponentAllocation allocation) {
  const uint32_t n = options.cluster.clusters;
  CoarsenMeshResult out;
  out.allocation = std::move(allocation);

  ClusterOptions co = options.cluster;
  // One component: the plain clustering (its count is n anyway); several: the allocation.
  if (topology.component_count > 1) co.component_clusters = out.allocation.clusters;
  auto t = Clock::now();
  Clustering clustering = cluster(mesh, topology, co);
  out.cluster_seconds = seconds_since(t);
  // Where the GPU failed over to the CPU engine, the fix loop's clusterings below would set it up
  // again, and likely see it fail again (an out-of-memory setup fails in every round): they ask for
  // the CPU engine, whose labels are the GPU engine's anyway. The notice stays with the result.
  const bool fell_back = clustering.fell_back;
  const std::string fallback_notice = clustering.device_notice;
  if (fell_back) co.device = "cpu";

  // The coarse mesh of the clustering as it is: its defects are what the fix loop starts from, and
  // without any it is the result (finding the defects is building it, so it is built once).
  t = Clock::now();
  const std::vector<float>* weights = options.cluster.density.empty() ? nullptr : &options.cluster.density;
  out.coarse = coarsen_clustering(mesh, topology, clustering.labels, n, options.coarsen, weights);
  out.coarsen_seconds = seconds_since(t);
  out.initial_defects = out.coarse.defects.size();
  if (out.initial_defects > 0 && options.max_fix_rounds > 0) {
    t = Clock::now();
    std::vector<uint32_t> labels = clustering.labels;
    FaceData data = face_data(mesh, options.cluster.density);
    RegionCheck check(mesh, topology, data);
    CornerPolygons corners(mesh, topology);
    const BoundaryLoops boundary_loops(mesh, topology);
    ClusterCutter cutter(mesh, topology, data, check, boundary_loops);
    FixLoop loop(mesh, topology, options, data, check, corners, cutter);
    auto defects_of = [&](const std::vector<uint32_t>& l, uint32_t clusters) { return loop.defects_of(l, clusters); };
    // (The first coarse mesh was built from these labels with the same options: its defects are
    // defects_of(labels), which would cost another pass over the mesh, 5 of refined_elephant's
    // 38 ms of fixes.)
    FixLoop::Outcome result = loop.run(labels, &clustering, co, true, 1, &out.coarse.defects);
    out.fix_rounds = result.rounds;
    out.fix_iterations = result.iterations;

    // Components still broken (a ring around a thin handle needs changes on both its sides, a
    // small component has no cluster to spare): a valid clustering with more clusters, where the
    // parts are better resolved, merged back to n keeping it valid, replaces those components.
    // Only manifold components: elsewhere no clustering gives a manifold dual, so no attempt pays.
    auto broken_manifolds = [&](const std::vector<uint32_t>& l, uint32_t clusters, const std::vector<DualDefect>& d) {
      std::vector<uint32_t> broken = defects_per_component(topology, l, clusters, d);
      for (uint32_t c = 0; c < topology.component_count; ++c)
        if (!out.allocation.manifold[c]) broken[c] = 0;
      return broken;
    };
    const uint64_t faces = mesh.face_count();
    // Per component, the finer clustering that left it with the fewest defects (ties: the finer):
    // where it stays broken, the start from single faces begins from it instead (see below).
    struct FineStart {
      std::vector<uint32_t> labels;
      std::vector<DualDefect> defects;
      uint32_t clusters = 0;
    };
    std::vector<FineStart> fine_starts;
    std::vector<uint32_t> best_fine(topology.component_count, kNone), best_fine_defects(topology.component_count, 0);
    // Dual triangles of no area alone (qem points on one line) are no reason to cluster a whole
    // component again at 2n, 4n, ...: the last dual puts one point of each on the surface
    // (CoarsenOptions::degenerate_to_surface). The armadillo -> 52000 with qem spent 20 s there,
    // clustering its 3.3M faces four times, and kept nothing. Small components still start from
    // single faces below (a cube keeps its corners so).
    const bool geometry_only =
        given.coarsen.degenerate_to_surface && given.coarsen.placement == VertexPlacement::qem &&
        std::all_of(result.defects.begin(), result.defects.end(),
                    [](const DualDefect& d) { return d.kind == DualDefect::degenerate_triangle; });
    // Each finer clustering clusters the whole mesh again. Where the broken components hold under
    // 1% of its faces (a strip of 48 faces beside a 1.2M-face scan: 5 clusterings of the scan, 11.4
    // s, before the strip was rebuilt from single faces anyway), they go to that rebuild directly.
    const auto worth_a_finer_clustering = [&] {
      const std::vector<uint32_t> broken = broken_manifolds(result.labels, n, result.defects);
      uint64_t broken_faces = 0;
      for (uint32_t c = 0; c < topology.component_count; ++c)
        if (broken[c] > 0) broken_faces += out.allocation.faces[c];
      return broken_faces > 0 && broken_faces * kFinerClusteringShare >= faces;
    };
    for (uint64_t factor = 2; !geometry_only && factor <= 32 && worth_a_finer_clustering(); factor *= 2) {
      uint64_t finer = n * factor;
      if (finer > faces / 4) break;  // clusters of fewer than 4 faces resolve nothing
      ClusterOptions fo = co;
      fo.clusters = uint32_t(finer);
      std::vector<uint32_t> fine_counts =
          allocate_component_clusters(mesh, topology, fo.clusters, &options.cluster.density).clusters;
      if (topology.component_count > 1) fo.component_clusters = fine_counts;
      Clustering fine = cluster(mesh, topology, fo);
      out.fix_iterations += fine.iterations;
      FixLoop::Outcome fixed = loop.run(fine.labels, &fine, fo, false, out.fix_rounds + 1);
      out.fix_rounds += fixed.rounds;
      std::vector<uint32_t> broken = broken_manifolds(result.labels, n, result.defects);
      std::vector<uint32_t> broken_fine = defects_per_component(topology, fixed.labels, fo.clusters, fixed.defects);
      {
        bool kept = false;
        for (uint32_t c = 0; c < topology.component_count; ++c)
          if (broken[c] > 0 && broken_fine[c] > 0 &&
              (best_fine[c] == kNone || broken_fine[c] <= best_fine_defects[c])) {
            best_fine[c] = uint32_t(fine_starts.size());
            best_fine_defects[c] = broken_fine[c];
            kept = true;
          }
        if (kept) fine_starts.push_back({fixed.labels, fixed.defects, fo.clusters});
      }
      std::vector<uint32_t> targets = fine_counts;  // components not merged back keep their count
      for (uint32_t c = 0; c < topology.component_count; ++c)
        if (broken[c] > 0 && broken_fine[c] == 0) targets[c] = out.allocation.clusters[c];
      std::vector<uint32_t> merged =
          merge_down_with_flips(mesh, topology, data, check, corners, boundary_loops, fixed.labels, fo.clusters, targets,
                                options.merge_budget_per_face, defects_of);
      uint32_t merged_count = *std::max_element(merged.begin(), merged.end()) + 1;
      std::vector<uint32_t> held = clusters_per_component(topology, merged, merged_count);
      std::vector<uint32_t> composed = result.labels;
      uint32_t replaced = 0, merges = 0;
      for (uint32_t c = 0; c < topology.component_count; ++c)
        if (broken[c] > 0 && broken_fine[c] == 0 && held[c] == out.allocation.clusters[c]) {
          replace_component(topology, composed, merged, c);
          ++replaced;
          merges += fine_counts[c] - out.allocation.clusters[c];
        }
      if (replaced == 0) {
        out.abandoned_fixes += fixed.fixes.size();
        continue;
      }
      FixLoop::Outcome back = loop.run(std::move(composed), nullptr, co, true, out.fix_rounds + 1);
      out.fix_rounds += back.rounds;
      out.fix_iterations += back.iterations;
      if (back.defects.size() >= result.defects.size()) {
        out.abandoned_fixes += fixed.fixes.size() + back.fixes.size();
        continue;
      }
      out.refined_clusters = fo.clusters;
      out.merged_back += merges;
      result.fixes.insert(result.fixes.end(), fixed.fixes.begin(), fixed.fixes.end());
      result.fixes.insert(result.fixes.end(), back.fixes.begin(), back.fixes.end());
      back.fixes = std::move(result.fixes);
      result = std::move(back);
    }
    // Last resort for broken components: one cluster per face (a valid clustering of a manifold:
    // faces are disks, two faces share at most one edge, vertices have valence >= 3) merged down
    // to the component's count the same way. First only around the defects of the finer
    // clustering that left the component the fewest (its clusters in a defect and their
    // neighbours in single faces, the others kept): libcgal-demo's cheese -> 444 merges 3314
    // times instead of 39538 (fixes 0.89 -> 0.65 s, Q avg 0.717 -> 0.745, angles below 30
    // 332 -> 216), polygon_mesh -> 3224 3313 instead of 29021 (0.72 -> 0.22 s); over libcgal-demo
    // at faces / 10 and / 40, 6 and 8 defects fewer, 23 and 156 angles below 30 fewer (boeing ->
    // 64 loses: Q avg 0.62 -> 0.58). Where that leaves as many defects, every face.
    // Each start takes components smallest first (ties: lower id) while what it merges from stays
    // within max_face_start_faces in all (a component that would pass it, and those after it, are
    // not taken): every face of the component from single faces; the finer clusters kept plus the
    // faces made single from a finer clustering. The latter grows with the defects, not with the
    // component: libcgal-demo's femur -> 1949 with qem (subdivided twice to 125k faces) is rebuilt
    // from 8957 clusters; when the limit counted the component's faces, 3 defects remained.
    const std::vector<uint32_t> broken = broken_manifolds(result.labels, n, result.defects);
    std::vector<uint32_t> component_offsets, component_faces;
    component_face_lists(topology, component_offsets, component_faces);
    auto faces_of = [&](uint32_t c) {
      return std::span<const uint32_t>(component_faces.data() + component_offsets[c],
                                       component_offsets[c + 1] - component_offsets[c]);
    };
    // Per cluster of the finer clustering that left component c the fewest defects: 1 when its faces
    // become single faces (in a defect, or next to a cluster in one).
    auto single_clusters = [&](uint32_t c) {
      const FineStart& start = fine_starts[best_fine[c]];
      std::vector<uint8_t> core(start.clusters, 0);
      for (const DualDefect& d : start.defects)
        for (uint32_t k : {d.cluster, d.other, d.third})
          if (k < start.clusters) core[k] = 1;
      std::vector<uint8_t> single = core;
      for (uint32_t f : faces_of(c)) {
        if (!core[start.labels[f]]) continue;
        for (int e = 0; e < 3; ++e) {
          const uint32_t g = topology.face_adjacent[3 * size_t(f) + e];
          if (g != kNone) single[start.labels[g]] = 1;
        }
      }
      return single;
    };
    std::vector<uint32_t> candidates;  // broken, smallest first (ties: lower id)
    for (uint32_t c = 0; c < topology.component_count; ++c)
      if (broken[c] > 0) candidates.push_back(c);
    std::stable_sort(candidates.begin(), candidates.end(), [&](uint32_t x, uint32_t y) {
      return out.allocation.faces[x] < out.allocation.faces[y];
    });
    for (int from_fine = fine_starts.empty() ? 0 : 1; !candidates.empty() && from_fine >= 0; --from_fine) {
      std::vector<uint32_t> direct = result.labels;
      std::vector<uint32_t> targets = clusters_per_component(topology, result.labels, n);
      std::vector<uint8_t> face_start(topology.component_count, 0);  // rebuilt from this start
      // Selected in order of size; numbered in component order, as the merge's ties go by id.
      std::vector<std::vector<uint8_t>> singles(topology.component_count);  // single_clusters(c), where taken
      uint32_t selected = 0;
      uint64_t taken = 0;
      for (uint32_t c : candidates) {
        uint64_t units = faces_of(c).size();
        std::vector<uint8_t> single;
        if (from_fine && best_fine[c] != kNone) {
          const std::vector<uint32_t>& fine = fine_starts[best_fine[c]].labels;
          single = single_clusters(c);
          std::vector<uint8_t> seen(single.size(), 0);
          units = 0;
          for (uint32_t f : faces_of(c)) {
            const uint32_t l = fine[f];
            if (single[l] || !seen[l]) ++units;
            seen[l] = 1;
          }
        }
        if (taken + units > options.max_face_start_faces) break;
        taken += units;
        face_start[c] = 1;
        singles[c] = std::move(single);
        targets[c] = out.allocation.clusters[c];
        ++selected;
      }
      uint32_t next_id = n;
      for (uint32_t c = 0; c < topology.component_count; ++c) {
        if (!face_start[c]) continue;
        if (!from_fine || best_fine[c] == kNone) {  // no finer clustering of it kept: single faces
          for (uint32_t f : faces_of(c)) direct[f] = next_id++;
          continue;
        }
        const FineStart& start = fine_starts[best_fine[c]];
        const std::vector<uint8_t>& single = singles[c];
        std::vector<uint32_t> fresh(start.clusters, kNone);  // per fine cluster id: its id in direct
        for (uint32_t f : faces_of(c)) {
          const uint32_t l = start.labels[f];
          if (single[l]) {
            direct[f] = next_id++;
          } else {
            if (fresh[l] == kNone) fresh[l] = next_id++;
            direct[f] = fresh[l];
          }
        }
      }
      if (selected == 0) continue;
      std::vector<uint32_t> start_counts = clusters_per_component(topology, direct, next_id);
      direct = merge_down_with_flips(mesh, topology, data, check, corners, boundary_loops, direct, next_id, targets,
                                     options.merge_budget_per_face, defects_of);
      uint32_t merged_count = *std::max_element(direct.begin(), direct.end()) + 1;
      std::vector<uint32_t> held = clusters_per_component(topology, direct, merged_count);
      std::vector<uint32_t> composed = result.labels;
      uint32_t replaced = 0, replaced_from_finer = 0, merges = 0;
      for (uint32_t c = 0; c < topology.component_count; ++c)
        if (face_start[c] && held[c] == out.allocation.clusters[c]) {
          replace_component(topology, composed, direct, c);
          ++replaced;
          replaced_from_finer += from_fine && best_fine[c] != kNone;
          merges += start_counts[c] - held[c];
        }
      if (replaced > 0) {
        FixLoop::Outcome back = loop.run(std::move(composed), nullptr, co, true, out.fix_rounds + 1);
        out.fix_rounds += back.rounds;
        out.fix_iterations += back.iterations;
        if (back.defects.size() < result.defects.size()) {
          out.merged_back += merges;
          out.face_start_components = replaced;
          out.face_start_from_finer = replaced_from_finer;
          result.fixes.insert(result.fixes.end(), back.fixes.begin(), back.fixes.end());
          back.fixes = std::move(result.fixes);
          result = std::move(back);
          break;
        } else {
          out.abandoned_fixes += back.fixes.size();
        }
      }
    }
    out.fixes = std::move(result.fixes);
    if (result.clustering) {
      clustering = std::move(*result.clustering);
    } else {
      // The clustering of the chosen labels without iterating: generators, and repair as a safety net.
      ClusterOptions ro = co;
      ro.topology = TopologyMode::preserving;
      ro.initial_labels = std::move(result.labels);
      ro.max_iterations = 0;
      clustering = cluster(mesh, topology, ro);
    }
    out.fix_seconds = out.coarsen_seconds + seconds_since(t);  // the first coarse mesh found the defects
    t = Clock::now();
    out.coarse = coarsen_clustering(mesh, topology, clustering.labels, n, options.coarsen, weights);
    out.coarsen_seconds = seconds_since(t);
  }
  if (given.coarsen.degenerate_to_surface && given.coarsen.placement == VertexPlacement::qem &&
      !out.coarse.defects.empty() &&
      std::all_of(out.coarse.defects.begin(), out.coarse.defects.end(),
                  [](const DualDefect& d) { return d.kind == DualDefect::degenerate_triangle; })) {
    t = Clock::now();
    out.coarse = coarsen_clustering(mesh, topology, clustering.labels, n, given.coarsen, weights);
    out.coarsen_seconds += seconds_since(t);
  }
  out.defects_remain = !out.coarse.defects.empty();
  out.clustering = std::move(clustering);
  if (fell_back) out.clustering.fell_back = true, out.clustering.device_notice = fallback_notice;
  return out;
}

}  // namespace

CoarsenMeshResult coarsen_mesh(const Mesh& mesh, const Topology& topology, const CoarsenMeshOptions& given) {
  // While fixing, qem's degenerate triangles stay defects: the fix rounds may find a clustering
  // whose points are apart (a cube keeps its corners so). Only the last dual, where they remain,
  // puts their clusters' points on the surface (CoarsenOptions::degenerate_to_surface).
  CoarsenMeshOptions options = given;
  options.coarsen.degenerate_to_surface = false;
  if (!options.cluster.component_clusters.empty() || !options.cluster.initial_labels.empty())
    throw OptionError("coarsen_mesh sets component_clusters and initial_labels itself: leave them empty");
  // Options coarsen_clustering and relax would refuse, refused before the clustering's work.
  detail::check_fit_angles(options.coarsen);
  if (!(options.coarsen.relax_max_normal_turn_deg >= 0 && options.coarsen.relax_max_normal_turn_deg <= 180))
    throw OptionError("relax: the normal turn limit must be within [0, 180] degrees");
  // Faces with a repeated corner (left by welding: assimp-testmodels' spider.obj has 56) have no
  // area and no edges: each is a component of its own, which took a cluster and so a coarse
  // vertex of the n (spider -> 136 came out with 82 triangles and 56 defects), and a cluster
  // holding one is no disk. They are left out of the whole job, and afterwards take the cluster
  // of a face sharing a corner with them. Unless every face is collapsed (nothing else to keep).
  if (topology.collapsed_faces > 0 && topology.collapsed_faces < mesh.face_count())
    return coarsen_without_collapsed_faces(mesh, topology, given);
  // A surface that is a manifold but for pinched vertices (cow: two parts touching at a point) or
  // whose triangles are ordered at random (boeing, the *-shuffled meshes of libcgal-demo) has a
  // dual that is pinched too, or whose triangles face every way: prepare a copy first. The labels
  // and the coarse mesh's vertices depend on neither, only the dual's triangles do.
  if (topology.orientation_flips > 0 || topology.nonmanifold_vertices > 0) {
    Mesh prepared = mesh;
    Topology prepared_topology = topology;
    const SurfacePreparation p = prepare_surface(prepared, prepared_topology);
    if (p.split_vertices > 0 || p.flipped_faces > 0) {
      CoarsenMeshResult out = coarsen_mesh(prepared, prepared_topology, given);
      out.split_vertices = p.split_vertices;
      out.reoriented_faces = p.flipped_faces;
      return out;
    }
  }
  const uint32_t n = options.cluster.clusters;
  CoarsenMeshResult out = coarsen_allocated(mesh, topology, given, options,
                                            allocate_component_clusters(mesh, topology, n, &options.cluster.density));
  // Components of several that stay broken at their share (b9_mesh -> 1453: a 186-face plate with
  // 7 holes at 16 clusters, a 25-face strip at 3) are given twice their clusters, taken from the
  // others by the same shares, and the whole job is done again; kept when it leaves fewer
  // defects. (Every attempt above works within each component's count.) Floors only rise: a
  // component grown in one round and clean in the next keeps its count.
  std::vector<uint32_t> floors(topology.component_count, 0);
  for (uint32_t round = 0; round < kReallocationRounds && topology.component_count > 1 && out.defects_remain; ++round) {
    const std::vector<uint32_t> broken = defects_per_component(topology, out.clustering.labels, n, out.coarse.defects);
    uint32_t grown = 0;
    for (uint32_t c = 0; c < topology.component_count; ++c) {
      if (broken[c] == 0 || !out.allocation.manifold[c]) continue;
      const uint32_t more = std::min(out.allocation.faces[c] / kReallocationFacesPerCluster,
                                     2 * out.allocation.clusters[c]);
      if (more <= out.allocation.clusters[c]) continue;
      floors[c] = more;
      ++grown;
    }
    uint64_t wanted = 0;  // (allocate_with_floors would fall back to the minimums past n)
    for (uint32_t c = 0; c < topology.component_count; ++c)
      wanted += std::clamp(floors[c], out.allocation.minimum[c], out.allocation.faces[c]);
    if (grown == 0 || wanted > n) break;  // no room for it among the others
    ComponentAllocation more = allocate_with_floors(mesh, topology, n, &options.cluster.density, &floors);
    CoarsenMeshResult again = coarsen_allocated(mesh, topology, given, options, std::move(more));
    if (again.coarse.defects.size() >= out.coarse.defects.size()) break;
    again.reallocations = out.reallocations + 1;
    again.initial_defects = out.initial_defects;  // (the first clustering's, as without a redo)
    again.cluster_seconds += out.cluster_seconds;
    again.fix_seconds += out.fix_seconds + out.coarsen_seconds;  // the abandoned attempt's
    again.abandoned_fixes += out.abandoned_fixes + out.fixes.size();
    out = std::move(again);
  }
  return out;
}

const char* to_string(CoarsenFix::Action a) { return a == CoarsenFix::cut ? "cut" : "move_faces"; }

}  // namespace meshcvt
