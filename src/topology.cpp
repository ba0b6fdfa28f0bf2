// meshcvt: mesh connectivity (face adjacency, vertex -> faces, components, boundary loops,
// non-manifold, degenerate and duplicate elements) and the summary behind `meshcvt info`.
//
// How it stays fast and small: the vertex -> faces CSR is built first by a counting sort of the
// corners. Every undirected edge {v, w} is then found at each end from v's own faces alone: the
// faces on {v, w} are exactly v's faces that have w as a corner, so sorting the (w, face) pairs of
// v's faces in a per-vertex scratch buffer groups them. At the lower end the edge is counted and
// its faces linked; at both ends the groups of two join fans around v (non-manifold vertices). No
// global sort or hash table: the memory is the result itself (about 30 bytes per face) plus
// per-vertex scratch, and vertex ranges split over the threads (up to 16) without sharing
// anything. The one scattered read, the corners of v's faces, is prefetched a few faces ahead.
//
// While building, face_adjacent holds two extra marks (non-manifold edge, boundary edge already
// walked) next to kNone (boundary edge); they become kNone before returning.
#include "parallel.h"
#include "meshcvt/topology.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <exception>
#include <string>
#include <system_error>

#include "meshcvt/error.h"

namespace meshcvt {

namespace {

constexpr uint32_t kNonmanifoldMark = 0xfffffffdu;  // half-edge of an edge with >= 3 faces
constexpr uint32_t kBoundaryWalked = 0xfffffffeu;   // boundary half-edge already put in a loop
static_assert(kBoundaryWalked + 1 == kNone);

// Face ids stay below the marks: 3F half-edge ids must fit in 32 bits, so F < 0x55555556.
constexpr size_t kMaxFaces = 0xffffffffu / 3;

inline bool is_face(uint32_t adjacent) { return adjacent < kNonmanifoldMark; }
inline bool is_boundary(uint32_t adjacent) { return adjacent == kNone || adjacent == kBoundaryWalked; }

inline bool is_collapsed(const uint32_t* indices, size_t f) {
  uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
  return a == b || b == c || a == c;
}

// Half-edge h = 3f + e runs from indices[h] to indices[next(h)].
inline uint32_t next_half_edge(uint32_t h) { return h % 3 == 2 ? h - 2 : h + 1; }
inline uint32_t prev_half_edge(uint32_t h) { return h % 3 == 0 ? h + 2 : h - 1; }


// Vertex ranges with about the same number of incident faces each, so the threads get equal work.
std::vector<uint32_t> split_vertices(const Topology& t, size_t vertex_count, unsigned parts) {
  std::vector<uint32_t> bounds{0};
  uint64_t total = t.vertex_face_offsets[vertex_count];
  for (unsigned p = 1; p < parts; ++p) {
    uint32_t goal = uint32_t(total * p / parts);
    auto it = std::lower_bound(t.vertex_face_offsets.begin() + bounds.back(), t.vertex_face_offsets.end() - 1, goal);
    bounds.push_back(uint32_t(it - t.vertex_face_offsets.begin()));
  }
  bounds.push_back(uint32_t(vertex_count));
  return bounds;
}

// Vertex -> faces CSR, each face once per distinct corner, face ids increasing: a counting sort of
// the corners in face order. Each thread counts the corners of its range of faces into an array of
// its own; a vertex's slots of a later range follow those of the earlier ones, so the order stays
// increasing. Splitting by vertex instead (each thread reads every face and keeps the corners of
// its vertices) needs no extra arrays but mispredicts a branch at every other corner on a mesh
// without locality: 3.5x slower on the 1.2M bunny with shuffled faces. The arrays cost 4 bytes
// per vertex each, so at most kMaxVertexFaceParts threads do this.
constexpr unsigned kMaxVertexFaceParts = 4;
void build_vertex_faces(const Mesh& mesh, Topology& t, unsigned parts) {
  parts = std::min(parts, kMaxVertexFaceParts);
  const uint32_t* indices = mesh.indices.data();
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  std::vector<uint32_t>& offsets = t.vertex_face_offsets;
  offsets.assign(nv + 1, 0);
  // Part 0 counts into offsets[v + 1], part p > 0 into later[p - 1][v].
  std::vector<std::vector<uint32_t>> later(parts - 1, std::vector<uint32_t>(nv, 0));
  const std::vector<uint32_t> face_bounds = even_bounds(nf, parts);
  run_ranges(face_bounds, [&](uint32_t begin, uint32_t end, size_t part) {
    uint32_t* count = part == 0 ? offsets.data() + 1 : later[part - 1].data();
    for (size_t f = begin; f < end; ++f) {
      const uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
      ++count[a];
      if (b != a) ++count[b];
      if (c != a && c != b) ++count[c];
    }
  });
  // offsets[v] becomes the start of v (part 0's cursor), later[p - 1][v] the start of part p's slots.
  uint32_t running = 0;
  for (size_t v = 0; v < nv; ++v) {
    const uint32_t start = running;
    running += offsets[v + 1];
    for (std::vector<uint32_t>& cursor : later) {
      const uint32_t n = cursor[v];
      cursor[v] = running;
      running += n;
    }
    offsets[v] = start;
    t.referenced_vertices += running != start;
  }
  offsets[nv] = running;
  t.vertex_faces.resize(running);
  uint32_t* faces = t.vertex_faces.data();
  run_ranges(face_bounds, [&](uint32_t begin, uint32_t end, size_t part) {
    uint32_t* cursor = part == 0 ? offsets.data() : later[part - 1].data();
    for (size_t f = begin; f < end; ++f) {
      const uint32_t a = indices[3 * f], b = indices[3 * f + 1], c = indices[3 * f + 2];
      faces[cursor[a]++] = uint32_t(f);
      if (b != a) faces[cursor[b]++] = uint32_t(f);
      if (c != a && c != b) faces[cursor[c]++] = uint32_t(f);
    }
  });
  // The last part's cursor of each vertex stopped at the start of the next vertex.
  const std::vector<uint32_t>& last = later.empty() ? offsets : later.back();
  for (size_t v = nv; v > 0; --v) offsets[v] = last[v - 1];
  offsets[0] = 0;
}

struct VertexCounts {
  uint64_t edges = 0, boundary = 0, nonmanifold = 0, flips = 0, duplicates = 0, nonmanifold_vertices = 0;
};

// Counts faces (given by their third vertices, all > hi, so the edge is each face's lowest) that
// repeat an earlier face's vertex set: same edge {lo, hi} and same third vertex.
uint64_t count_repeats(std::vector<uint32_t>& thirds) {
  std::sort(thirds.begin(), thirds.end());
  uint64_t repeats = 0;
  for (size_t i = 1; i < thirds.size(); ++i) repeats += thirds[i] == thirds[i - 1];
  return repeats;
}

constexpr uint32_t kPrefetchDistance = 16;
inline void prefetch(const void* p) {
#if defined(__GNUC__)
  __builtin_prefetch(p);
#else
  (void)p;
#endif
}

inline uint32_t find_local(uint32_t* parent, uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

// Per-thread scratch for one vertex's faces, sized once for the largest fan of the range. Each
// non-collapsed face i of v has two slots, one per edge at v: slot 2i is v -> next, slot 2i + 1 is
// prev -> v, and other[slot] is that edge's far end w.
struct FanScratch {
  std::vector<uint32_t> other;     // per slot: the edge's other vertex
  std::vector<uint32_t> count;     // per slot: how many slots share its edge
  std::vector<uint32_t> partner;   // per slot: the other slot of its edge, when there are two
  std::vector<uint32_t> leaders;   // slots that stand for an edge {v, w > v}: its first slot
  std::vector<uint32_t> half;      // per slot: its half-edge (2i: v -> next, 2i + 1: prev -> v)
  std::vector<uint32_t> parent;    // per local face: union-find of the fan pieces (big fans)
  std::vector<uint32_t> group;     // slots of one edge
  std::vector<uint64_t> keys;      // (w << 32) | slot, to sort big fans
  std::vector<uint32_t> thirds;
};

// Up to this many slots (16 faces around a vertex) the slots of each edge are found by comparing
// every pair: a fixed amount of branch-free, vectorizable work, where insertion-sorting a dozen
// keys mispredicts about one branch per key (cachegrind, 1.2M-face mesh: a third of the
// mispredicts for 17% more instructions, a net win). Bigger fans are sorted.
constexpr uint32_t kPairwiseSlots = 32;

constexpr uint32_t kNextCorner[3] = {1, 2, 0};

// For each vertex v in [vbegin, vend): links the faces of every edge {v, w} with w > v (so each
// edge is handled once, at its lower end) and finds whether v's faces form one fan.
//
// Everything comes from v's own faces: the faces on edge {v, w} are exactly those of v that have
// w as a corner, so grouping the slots by w gives each edge's faces. An edge with two faces joins
// their two faces' fans.
void process_vertices(const Mesh& mesh, Topology& t, uint32_t vbegin, uint32_t vend, VertexCounts& out) {
  const uint32_t* indices = mesh.indices.data();
  const uint32_t* offsets = t.vertex_face_offsets.data();
  const uint32_t* faces = t.vertex_faces.data();
  uint32_t* adjacent = t.face_adjacent.data();
  const uint32_t face_end = offsets[vend];
  uint32_t max_faces = 0;
  for (uint32_t v = vbegin; v < vend; ++v) max_faces = std::max(max_faces, offsets[v + 1] - offsets[v]);
  FanScratch s;
  s.other.resize(2 * size_t(max_faces));
  s.count.resize(2 * size_t(max_faces));
  s.partner.resize(2 * size_t(max_faces));
  s.leaders.resize(2 * size_t(max_faces));
  s.half.resize(2 * size_t(max_faces));
  uint32_t* other = s.other.data();
  uint32_t* half = s.half.data();
  VertexCounts n;

  // Counts and links one edge {v, w}, w > v, given its slots (increasing).
  auto link_edge = [&](uint32_t w, const uint32_t* group, size_t count) {
    ++n.edges;
    // other[slot ^ 1] is the face's third corner (neither v nor w).
    if (count == 1) {
      ++n.boundary;  // face_adjacent already kNone
    } else if (count == 2) {
      uint32_t h1 = half[group[0]], h2 = half[group[1]];
      adjacent[h1] = h2 / 3;
      adjacent[h2] = h1 / 3;
      n.flips += group[0] % 2 == group[1] % 2;  // both v -> w or both w -> v
      uint32_t t1 = other[group[0] ^ 1], t2 = other[group[1] ^ 1];
      n.duplicates += t1 == t2 && t1 > w;
    } else {
      ++n.nonmanifold;
      s.thirds.clear();
      for (size_t k = 0; k < count; ++k) {
        adjacent[half[group[k]]] = kNonmanifoldMark;
        if (other[group[k] ^ 1] > w) s.thirds.push_back(other[group[k] ^ 1]);
      }
      n.duplicates += count_repeats(s.thirds);
    }
  };

  for (uint32_t v = vbegin; v < vend; ++v) {
    uint32_t fan_faces = 0;
    for (uint32_t i = offsets[v]; i < offsets[v + 1]; ++i) {
      // The faces' corners are the one scattered read here; vertex_faces runs on across vertices,
      // so fetch the corners of a face a few steps ahead.
      if (i + kPrefetchDistance < face_end) prefetch(indices + 3 * size_t(faces[i + kPrefetchDistance]));
      uint32_t f = faces[i], base = 3 * f;
      uint32_t a = indices[base], b = indices[base + 1], c = indices[base + 2];
      if (a == b || b == c || a == c) continue;  // collapsed: no edges, in no fan
      // Which corner is v is a coin toss for the branch predictor: compute it, do not branch.
      uint32_t corner = uint32_t(b == v) + 2 * uint32_t(c == v);
      uint32_t next = kNextCorner[corner], prev = kNextCorner[next];
      half[2 * fan_faces] = base + corner;  // slot 2i: v -> next
      half[2 * fan_faces + 1] = base + prev;  // slot 2i + 1: prev -> v
      other[2 * fan_faces] = indices[base + next];
      other[2 * fan_faces + 1] = indices[base + prev];
      ++fan_faces;
    }
    if (fan_faces == 0) continue;
    uint32_t slots = 2 * fan_faces;

    if (slots <= kPairwiseSlots) {
      uint32_t* count = s.count.data();
      uint32_t* partner = s.partner.data();
      uint32_t* leaders = s.leaders.data();
      uint32_t leader_count = 0, singles = 0, crowded = 0;
      for (uint32_t a = 0; a < slots; ++a) {
        uint32_t w = other[a], same = 0, earlier = 0, slot_sum = 0;
        for (uint32_t b = 0; b < slots; ++b) {
          uint32_t eq = other[b] == w;
          same += eq;
          earlier += eq & (b < a);
          slot_sum += eq * b;
        }
        count[a] = same;
        partner[a] = slot_sum - a;  // the other slot when same == 2
        singles += same == 1;
        crowded += same > 2;
        leaders[leader_count] = a;
        leader_count += (earlier == 0) & (w > v);  // a is the first slot of an edge {v, w > v}
      }
      for (uint32_t l = 0; l < leader_count; ++l) {
        uint32_t a = leaders[l];
        if (count[a] <= 2) {
          uint32_t group[2] = {a, partner[a]};
          link_edge(other[a], group, count[a]);
        } else {
          s.group.clear();
          for (uint32_t b = a; b < slots; ++b)
            if (other[b] == other[a]) s.group.push_back(b);
          link_edge(other[a], s.group.data(), s.group.size());
        }
      }
      // One fan: every edge at v has at most two faces, at most one chain end pair, and walking
      // from face 0 through two-face edges reaches every face.
      bool one_fan = crowded == 0 && singles <= 2;
      if (one_fan && fan_faces > 1) {
        uint32_t seen = 1, slot = 0;
        bool closed = false;
        while (count[slot] == 2 && seen <= fan_faces) {  // leave face 0 through slot 0
          uint32_t enter = partner[slot];
          if (enter / 2 == 0) {
            closed = true;
            break;
          }
          ++seen;
          slot = enter ^ 1;
        }
        for (slot = 1; !closed && count[slot] == 2 && seen <= fan_faces;) {  // and through slot 1
          ++seen;
          slot = partner[slot] ^ 1;
        }
        one_fan = seen == fan_faces;
      }
      n.nonmanifold_vertices += !one_fan;
      continue;
    }

    // Big fan: sort the slots by w; union-find counts the fans.
    s.keys.clear();
    for (uint32_t a = 0; a < slots; ++a) s.keys.push_back(uint64_t(other[a]) << 32 | a);
    std::sort(s.keys.begin(), s.keys.end());
    s.parent.resize(fan_faces);
    for (uint32_t i = 0; i < fan_faces; ++i) s.parent[i] = i;
    uint32_t fans = fan_faces;
    for (size_t i = 0; i < s.keys.size();) {
      uint32_t w = uint32_t(s.keys[i] >> 32);
      s.group.clear();
      for (; i < s.keys.size() && uint32_t(s.keys[i] >> 32) == w; ++i) s.group.push_back(uint32_t(s.keys[i]));
      if (s.group.size() == 2) {
        uint32_t x = find_local(s.parent.data(), s.group[0] / 2), y = find_local(s.parent.data(), s.group[1] / 2);
        if (x != y) {
          s.parent[std::max(x, y)] = std::min(x, y);
          --fans;
        }
      }
      if (w > v) link_edge(w, s.group.data(), s.group.size());
    }
    n.nonmanifold_vertices += fans > 1;
  }
  out = n;
}

// Around vertex v: from face f, leave through the edge at v that is not edge `e` of f. Returns the
// next face and the edge of it we entered through, or {kNone, h} when the edge to cross is not
// manifold (boundary or non-manifold), h being that half-edge of f.
struct FanStep {
  uint32_t face, edge;
};
inline FanStep fan_step(const uint32_t* indices, const uint32_t* adjacent, uint32_t v, uint32_t f, uint32_t e) {
  uint32_t h = 3 * f + e;
  // Edge e either starts at v (the other edge at v ends there: previous) or ends at v (next).
  uint32_t other = indices[h] == v ? prev_half_edge(h) : next_half_edge(h);
  uint32_t g = adjacent[other];
  if (!is_face(g)) return {kNone, other};
  uint32_t a = indices[other], b = indices[next_half_edge(other)];
  uint32_t q = a == v ? b : a;  // the far end of the shared edge
  for (uint32_t eg = 0; eg < 3; ++eg) {
    uint32_t x = indices[3 * g + eg], y = indices[3 * g + (eg + 1) % 3];
    if ((x == v && y == q) || (x == q && y == v)) return {g, eg};
  }
  assert(false && "face_adjacent is not symmetric");
  return {kNone, other};
}

// From boundary half-edge h, pivoting at its end vertex v, finds the boundary half-edge that closes
// the same fan around v, or kNone when a non-manifold edge comes first.
uint32_t next_boundary(const Mesh& mesh, const Topology& t, uint32_t h, uint32_t v) {
  const uint32_t* indices = mesh.indices.data();
  const uint32_t* adjacent = t.face_adjacent.data();
  FanStep s{h / 3, h % 3};
  size_t guard = t.vertex_face_offsets[v + 1] - t.vertex_face_offsets[v];
  for (size_t step = 0; step <= guard; ++step) {
    FanStep n = fan_step(indices, adjacent, v, s.face, s.edge);
    if (n.face == kNone) return is_boundary(adjacent[n.edge]) ? n.edge : kNone;
    s = n;
  }
  assert(false && "boundary fan walk did not end");
  return kNone;
}

// Follows the chain of boundary edges from h0 through vertex v, marking them walked. True when it
// comes back to h0.
bool walk_boundary(const Mesh& mesh, Topology& t, uint32_t h0, uint32_t v) {
  const uint32_t* indices = mesh.indices.data();
  uint32_t h = h0;
  for (;;) {
    uint32_t n = next_boundary(mesh, t, h, v);
    if (n == h0) return true;
    if (n == kNone || t.face_adjacent[n] == kBoundaryWalked) return false;
    t.face_adjacent[n] = kBoundaryWalked;
    uint32_t a = indices[n], b = indices[next_half_edge(n)];
    v = a == v ? b : a;
    h = n;
  }
}

uint64_t count_boundary_loops(const Mesh& mesh, Topology& t) {
  const uint32_t* indices = mesh.indices.data();
  uint64_t loops = 0;
  size_t half_edges = t.face_adjacent.size();
  for (uint32_t h = 0; h < half_edges; ++h) {
    if (t.face_adjacent[h] != kNone || is_collapsed(indices, h / 3)) continue;
    ++loops;
    t.face_adjacent[h] = kBoundaryWalked;
    // Forward through the end vertex; if the chain is open, also backward through the start.
    if (!walk_boundary(mesh, t, h, indices[next_half_edge(h)])) walk_boundary(mesh, t, h, indices[h]);
  }
  return loops;
}

// Union-find over faces with the lower root always kept, so parent[f] <= f: one pass in face
// order then numbers components by their lowest face.
inline uint32_t find_root(uint32_t* parent, uint32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

void label_components(Topology& t, size_t nf, unsigned parts) {
  uint32_t* parent = t.face_component.data();
  const uint32_t* adjacent = t.face_adjacent.data();
  auto join = [parent](uint32_t f, uint32_t g) {
    const uint32_t a = find_root(parent, f), b = find_root(parent, g);
    if (a < b) parent[b] = a;
    else if (b < a) parent[a] = b;
  };
  // Each thread joins the faces of its range across the edges inside it: a root is the lowest face
  // of its tree, so every tree (and every write) stays in the range. The edges that leave a range
  // are joined afterwards, on this thread; on a mesh in locality order they are few.
  const std::vector<uint32_t> bounds = even_bounds(nf, parts);
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, size_t) {
    for (uint32_t f = begin; f < end; ++f) parent[f] = f;
    for (uint32_t f = begin; f < end; ++f)
      for (uint32_t e = 0; e < 3; ++e) {
        const uint32_t g = adjacent[3 * f + e];
        if (is_face(g) && g > f && g < end) join(f, g);
      }
  });
  for (size_t p = 0; p + 1 < bounds.size(); ++p)
    for (uint32_t f = bounds[p]; f < bounds[p + 1]; ++f)
      for (uint32_t e = 0; e < 3; ++e) {
        const uint32_t g = adjacent[3 * f + e];
        if (is_face(g) && g >= bounds[p + 1]) join(f, g);
      }
  uint32_t count = 0;
  for (uint32_t f = 0; f < nf; ++f) {
    assert(parent[f] <= f);
    // parent[f] < f was relabeled already and is in f's component.
    parent[f] = parent[f] == f ? count++ : parent[parent[f]];
  }
  t.component_count = count;
}

// Two-colours each component by orientation: across a manifold edge run the same way, the
// neighbour must be flipped. flipped[f]: whether f must be flipped to agree with its component's
// lowest face; conflict[c]: component c has no consistent orientation (the colours are then those
// of a spanning tree, and some edge disagrees).
struct OrientationColours {
  std::vector<uint8_t> flipped;
  std::vector<uint8_t> conflict;
};

OrientationColours colour_orientation(const Mesh& mesh, const Topology& t) {
  const uint32_t* indices = mesh.indices.data();
  size_t nf = mesh.face_count();
  OrientationColours out;
  out.flipped.assign(nf, 2);  // 2: not reached yet
  out.conflict.assign(t.component_count, 0);
  std::vector<uint32_t> stack;
  for (uint32_t s = 0; s < nf; ++s) {
    if (out.flipped[s] != 2) continue;
    out.flipped[s] = 0;
    stack.push_back(s);
    while (!stack.empty()) {
      uint32_t f = stack.back();
      stack.pop_back();
      for (uint32_t e = 0; e < 3; ++e) {
        uint32_t h = 3 * f + e, g = t.face_adjacent[h];
        if (!is_face(g)) continue;
        uint32_t a = indices[h], b = indices[next_half_edge(h)];
        bool same_direction = false;
        for (uint32_t eg = 0; eg < 3; ++eg)
          if (indices[3 * g + eg] == a && indices[3 * g + (eg + 1) % 3] == b) same_direction = true;
        uint8_t want = uint8_t(out.flipped[f] ^ same_direction);
        if (out.flipped[g] == 2) {
          out.flipped[g] = want;
          stack.push_back(g);
        } else if (out.flipped[g] != want) {
          out.conflict[t.face_component[f]] = 1;
        }
      }
    }
  }
  return out;
}

uint32_t count_nonorientable(const Mesh& mesh, const Topology& t) {
  const OrientationColours colours = colour_orientation(mesh, t);
  return uint32_t(std::count(colours.conflict.begin(), colours.conflict.end(), 1));
}

// Twice the area vector of face f, in double.
inline void face_cross(const Mesh& mesh, size_t f, double out[3]) {
  const float* p = mesh.positions.data();
  const float* a = p + 3 * size_t(mesh.indices[3 * f]);
  const float* b = p + 3 * size_t(mesh.indices[3 * f + 1]);
  const float* c = p + 3 * size_t(mesh.indices[3 * f + 2]);
  double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  double w[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  out[0] = u[1] * w[2] - u[2] * w[1];
  out[1] = u[2] * w[0] - u[0] * w[2];
  out[2] = u[0] * w[1] - u[1] * w[0];
}

// Degenerate faces, and repeats among collapsed faces (the others are found with the edges).
void count_face_defects(const Mesh& mesh, Topology& t, unsigned parts) {
  const uint32_t* indices = mesh.indices.data();
  struct Triple {
    uint32_t a, b, c;
    bool operator<(const Triple& o) const { return a != o.a ? a < o.a : b != o.b ? b < o.b : c < o.c; }
    bool operator==(const Triple& o) const { return a == o.a && b == o.b && c == o.c; }
  };
  std::vector<std::vector<Triple>> triples(parts);
  std::vector<uint64_t> degenerate(parts, 0);
  run_ranges(even_bounds(mesh.face_count(), parts), [&](uint32_t begin, uint32_t end, size_t part) {
    uint64_t n = 0;
    for (size_t f = begin; f < end; ++f) {
      if (is_collapsed(indices, f)) {
        uint32_t v[3] = {indices[3 * f], indices[3 * f + 1], indices[3 * f + 2]};
        std::sort(v, v + 3);
        triples[part].push_back({v[0], v[1], v[2]});
        ++n;
        continue;
      }
      double cr[3];
      face_cross(mesh, f, cr);
      n += cr[0] == 0 && cr[1] == 0 && cr[2] == 0;
    }
    degenerate[part] = n;
  });
  std::vector<Triple> all;
  for (unsigned p = 0; p < parts; ++p) {
    t.degenerate_faces += degenerate[p];
    all.insert(all.end(), triples[p].begin(), triples[p].end());
  }
  t.collapsed_faces = all.size();
  std::sort(all.begin(), all.end());
  for (size_t i = 1; i < all.size(); ++i) t.duplicate_faces += all[i] == all[i - 1];
}

}  // namespace

Topology build_topology(const Mesh& mesh, unsigned threads_requested) {
  size_t nf = mesh.face_count(), nv = mesh.vertex_count();
  if (mesh.indices.size() % 3 != 0 || mesh.positions.size() % 3 != 0)
    throw OptionError("mesh arrays are not whole triangles / vertices (" + std::to_string(mesh.indices.size()) +
                      " indices, " + std::to_string(mesh.positions.size()) + " coordinates)");
  if (nf > kMaxFaces)
    throw OptionError("mesh has " + std::to_string(nf) + " faces; at most " + std::to_string(kMaxFaces) +
                      " are supported");
  if (nv >= kNone) throw OptionError("mesh has " + std::to_string(nv) + " vertices; at most 4294967294 are supported");
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= nv)
      throw OptionError("face " + std::to_string(i / 3) + " uses vertex " + std::to_string(mesh.indices[i]) +
                        " but the mesh has " + std::to_string(nv) + " vertices");

  Topology t;
  unsigned threads = range_threads(nf, threads_requested);
  build_vertex_faces(mesh, t, threads);

  t.face_adjacent.assign(3 * nf, kNone);
  std::vector<uint32_t> bounds = split_vertices(t, nv, threads);
  std::vector<VertexCounts> counts(bounds.size() - 1);
  run_ranges(bounds, [&](uint32_t begin, uint32_t end, size_t part) { process_vertices(mesh, t, begin, end, counts[part]); });
  for (const VertexCounts& c : counts) {
    t.edge_count += c.edges;
    t.boundary_edges += c.boundary;
    t.nonmanifold_edges += c.nonmanifold;
    t.orientation_flips += c.flips;
    t.duplicate_faces += c.duplicates;
    t.nonmanifold_vertices += c.nonmanifold_vertices;
  }

  if (t.boundary_edges > 0) t.boundary_loops = count_boundary_loops(mesh, t);
  if (t.boundary_edges > 0 || t.nonmanifold_edges > 0)
    for (uint32_t& a : t.face_adjacent)
      if (!is_face(a)) a = kNone;

  t.face_component.resize(nf);
  label_components(t, nf, threads);
  if (t.orientation_flips > 0) t.nonorientable_components = count_nonorientable(mesh, t);
  count_face_defects(mesh, t, threads);
  return t;
}

MeshInfo mesh_info(const Mesh& mesh, const Topology& t) {
  assert(t.vertex_face_offsets.size() == mesh.vertex_count() + 1);
  MeshInfo info;
  info.vertices = t.referenced_vertices;
  info.faces = mesh.face_count();
  info.edges = t.edge_count;
  info.components = t.component_count;
  info.boundary_edges = t.boundary_edges;
  info.boundary_loops = t.boundary_loops;
  info.nonmanifold_edges = t.nonmanifold_edges;
  info.nonmanifold_vertices = t.nonmanifold_vertices;
  info.degenerate_faces = t.degenerate_faces;
  info.duplicate_faces = t.duplicate_faces;
  info.orientation_flips = t.orientation_flips;
  info.nonorientable_components = t.nonorientable_components;
  info.collapsed_faces = t.collapsed_faces;
  info.euler_characteristic = int64_t(info.vertices) - int64_t(info.edges) + int64_t(info.faces);

  bool manifold = info.faces > 0 && t.nonmanifold_edges == 0 && t.nonmanifold_vertices == 0 &&
                  t.collapsed_faces == 0 && t.nonorientable_components == 0;
  if (manifold) {
    int64_t twice = 2 * int64_t(info.components) - info.euler_characteristic - int64_t(info.boundary_loops);
    if (twice >= 0 && twice % 2 == 0) info.genus = twice / 2;
  }

  bool any = false;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (t.vertex_face_offsets[v + 1] == t.vertex_face_offsets[v]) continue;
    const float* p = mesh.positions.data() + 3 * v;
    for (int c = 0; c < 3; ++c) {
      info.bbox_min[c] = any ? std::min(info.bbox_min[c], p[c]) : p[c];
      info.bbox_max[c] = any ? std::max(info.bbox_max[c], p[c]) : p[c];
    }
    any = true;
  }
  double area = 0;
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    double cr[3];
    face_cross(mesh, f, cr);
    area += 0.5 * std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  }
  info.total_area = area;
  return info;
}

std::vector<uint8_t> faces_to_orient(const Mesh& mesh, const Topology& topology) {
  assert(topology.face_adjacent.size() == mesh.indices.size());
  std::vector<uint8_t> flip;
  if (topology.orientation_flips == 0) return flip;
  const OrientationColours colours = colour_orientation(mesh, topology);
  // Which colour keeps its orientation, per component. A closed component's faces are made to face
  // outward: the colour under which its signed volume is positive (computed about a corner of its
  // lowest face, so that a mesh far from the origin loses no digits). An open one has no inside:
  // the colour with the larger area keeps its orientation, the lowest face's on a tie.
  const uint32_t nc = topology.component_count;
  std::vector<double> volume(nc, 0.0), area[2];
  area[0].assign(nc, 0.0);
  area[1].assign(nc, 0.0);
  std::vector<uint8_t> open(nc, 0);
  std::vector<uint32_t> origin(nc, kNone);
  const float* p = mesh.positions.data();
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t c = topology.face_component[f];
    const uint32_t* corner = &mesh.indices[3 * f];
    if (origin[c] == kNone) origin[c] = corner[0];
    for (int e = 0; e < 3; ++e) open[c] |= topology.face_adjacent[3 * f + e] == kNone;
    double cr[3];
    face_cross(mesh, f, cr);
    area[colours.flipped[f]][c] += std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
    const float* o = p + 3 * size_t(origin[c]);
    const float* a = p + 3 * size_t(corner[0]);
    const double det = cr[0] * (double(a[0]) - o[0]) + cr[1] * (double(a[1]) - o[1]) + cr[2] * (double(a[2]) - o[2]);
    volume[c] += colours.flipped[f] ? -det : det;  // six times the volume, all faces as the lowest face runs
  }
  std::vector<uint8_t> keep(nc, 0);
  for (uint32_t c = 0; c < nc; ++c)
    keep[c] = !open[c] && volume[c] != 0 ? uint8_t(volume[c] < 0) : uint8_t(area[1][c] > area[0][c]);
  flip.assign(mesh.face_count(), 0);
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t c = topology.face_component[f];
    flip[f] = !colours.conflict[c] && colours.flipped[f] != keep[c];
  }
  return flip;
}

uint64_t orient_consistently(Mesh& mesh, Topology& topology) {
  const std::vector<uint8_t> flip = faces_to_orient(mesh, topology);
  uint64_t flipped = 0;
  for (size_t f = 0; f < flip.size(); ++f)
    if (flip[f]) {
      std::swap(mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]);
      ++flipped;
    }
  if (flipped > 0) topology = build_topology(mesh);
  return flipped;
}

uint64_t split_pinched_vertices(Mesh& mesh, Topology& topology) {
  assert(topology.vertex_face_offsets.size() == mesh.vertex_count() + 1);
  if (topology.nonmanifold_vertices == 0) return 0;
  const uint32_t* indices = mesh.indices.data();
  // The fans of every vertex are found on the unchanged mesh first, then the copies are made:
  // (vertex, first face of the fan's list, end) per fan that gets a copy.
  struct Fan {
    uint32_t vertex, begin, end;
  };
  std::vector<Fan> fans;
  std::vector<uint32_t> fan_faces, parent, others, order;
  std::vector<uint8_t> seen;
  const size_t nv = mesh.vertex_count();
  for (uint32_t v = 0; v < nv; ++v) {
    const uint32_t* faces = topology.vertex_faces.data() + topology.vertex_face_offsets[v];
    const uint32_t count = topology.vertex_face_offsets[v + 1] - topology.vertex_face_offsets[v];
    if (count < 2) continue;
    // Fans: v's faces joined across the manifold edges at v (face_adjacent). Collapsed faces have
    // no edges; they stay on v.
    parent.resize(count);
    for (uint32_t i = 0; i < count; ++i) parent[i] = i;
    auto find = [&](uint32_t i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    auto local = [&](uint32_t f) {  // f's position in v's (increasing) list
      return uint32_t(std::lower_bound(faces, faces + count, f) - faces);
    };
    others.clear();
    for (uint32_t i = 0; i < count; ++i) {
      const uint32_t f = faces[i];
      if (is_collapsed(indices, f)) continue;
      for (uint32_t e = 0; e < 3; ++e) {
        const uint32_t a = indices[3 * f + e], b = indices[3 * f + (e + 1) % 3];
        if (a != v && b != v) continue;
        others.push_back(a == v ? b : a);
        const uint32_t g = topology.face_adjacent[3 * f + e];
        if (g == kNone) continue;
        const uint32_t j = local(g);
        assert(j < count && faces[j] == g);
        parent[find(i)] = find(j);
      }
    }
    // A vertex of a non-manifold edge (an edge of three or more faces: some w met three times or
    // more among v's edges) is left as it is: copies would open the edge into a slit.
    std::sort(others.begin(), others.end());
    bool nonmanifold_edge = false;
    for (size_t i = 2; i < others.size() && !nonmanifold_edge; ++i) nonmanifold_edge = others[i] == others[i - 2];
    if (nonmanifold_edge) continue;
    // Fans (their roots) in the order of their lowest face; the first keeps v.
    order.clear();
    seen.assign(count, 0);
    for (uint32_t i = 0; i < count; ++i) {
      if (is_collapsed(indices, faces[i])) continue;
      const uint32_t r = find(i);
      if (!seen[r]) seen[r] = 1, order.push_back(r);
    }
    if (order.size() < 2) continue;
    for (size_t k = 1; k < order.size(); ++k) {
      Fan fan{v, uint32_t(fan_faces.size()), 0};
      for (uint32_t i = 0; i < count; ++i)
        if (!is_collapsed(indices, faces[i]) && find(i) == order[k]) fan_faces.push_back(faces[i]);
      fan.end = uint32_t(fan_faces.size());
      fans.push_back(fan);
    }
  }
  if (fans.empty()) return 0;
  mesh.positions.reserve(mesh.positions.size() + 3 * fans.size());
  for (const Fan& fan : fans) {
    const uint32_t copy = uint32_t(mesh.vertex_count());
    for (int k = 0; k < 3; ++k) mesh.positions.push_back(mesh.positions[3 * size_t(fan.vertex) + k]);
    for (uint32_t i = fan.begin; i < fan.end; ++i)
      for (int k = 0; k < 3; ++k) {
        uint32_t& corner = mesh.indices[3 * size_t(fan_faces[i]) + k];
        if (corner == fan.vertex) corner = copy;
      }
  }
  topology = build_topology(mesh);
  return fans.size();
}

uint64_t remove_collapsed_faces(Mesh& mesh, std::vector<uint32_t>* kept_index) {
  const size_t faces = mesh.face_count();
  assert(mesh.source_polygon.empty() || mesh.source_polygon.size() == faces);
  auto collapsed = [&](size_t f) {
    const uint32_t* t = &mesh.indices[3 * f];
    return t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
  };
  if (kept_index) kept_index->assign(faces, kNone);
  size_t removed = 0;
  for (size_t f = 0; f < faces; ++f) removed += collapsed(f);
  if (removed > 0 && mesh.source_polygon.empty()) {  // identity: made explicit before faces move
    mesh.source_polygon.resize(faces);
    for (size_t f = 0; f < faces; ++f) mesh.source_polygon[f] = uint32_t(f);
  }
  size_t kept = 0;
  for (size_t f = 0; f < faces; ++f) {
    if (removed > 0 && collapsed(f)) continue;
    if (kept_index) (*kept_index)[f] = uint32_t(kept);
    if (kept != f) {
      for (int k = 0; k < 3; ++k) mesh.indices[3 * kept + k] = mesh.indices[3 * f + k];
      mesh.source_polygon[kept] = mesh.source_polygon[f];
    }
    ++kept;
  }
  mesh.indices.resize(3 * kept);
  if (removed > 0) mesh.source_polygon.resize(kept);
  return removed;
}

std::vector<uint32_t> labels_with_collapsed_faces(const Mesh& mesh, const Topology& topology,
                                                  const std::vector<uint32_t>& kept_index,
                                                  const std::vector<uint32_t>& kept_labels, uint32_t fallback) {
  const size_t faces = mesh.face_count();
  assert(kept_index.size() == faces);
  std::vector<uint32_t> labels(faces, fallback);
  for (size_t f = 0; f < faces; ++f) {
    if (kept_index[f] != kNone) {
      labels[f] = kept_labels[kept_index[f]];
      continue;
    }
    uint32_t corners[3] = {mesh.indices[3 * f], mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]};
    std::sort(corners, corners + 3);
    bool found = false;
    for (int k = 0; k < 3 && !found; ++k)
      for (uint32_t i = topology.vertex_face_offsets[corners[k]]; i < topology.vertex_face_offsets[corners[k] + 1]; ++i) {
        const uint32_t g = topology.vertex_faces[i];
        if (kept_index[g] == kNone) continue;
        labels[f] = kept_labels[kept_index[g]];
        found = true;
        break;
      }
  }
  return labels;
}

SurfacePreparation prepare_surface(Mesh& mesh, Topology& topology) {
  SurfacePreparation p;
  p.split_vertices = split_pinched_vertices(mesh, topology);
  p.flipped_faces = orient_consistently(mesh, topology);
  return p;
}

}  // namespace meshcvt
