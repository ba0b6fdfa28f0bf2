// meshcvt: triangle BVH with exact closest-point queries (see triangle_bvh.h).
//
// Build: top-down, binned surface-area heuristic (16 bins along the widest axis of the centroids'
// box: binning all three axes costs 1.6x the time for the same query speed on meshes), leaves of at
// most kMaxLeaf triangles, the top subtrees built by separate threads and joined in a fixed order.
// Below depth kSahDepth the split falls back to the object median, so the depth stays bounded (and
// the traversal stack fixed) whatever the triangle distribution. Or (Build::morton, MortonBuilder)
// along a Morton curve of the centroids: a radix sort and one linear pass, both in ranges side by
// side on several threads, for trees queried only a few times per face. Either way the tree is the
// same for any thread count.
// Traversal: depth first, nearer child first, a subtree skipped only when its box is farther than
// the best distance found so far plus a rounding tolerance.
#include "triangle_bvh.h"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <cstring>
#include <exception>
#include <system_error>
#include <thread>

#include "morton.h"

namespace meshcvt {

namespace {

constexpr uint32_t kMaxLeaf = 8;    // a leaf never holds more triangles
constexpr int kBins = 16;           // SAH bins per axis
constexpr uint32_t kSahDepth = 48;  // deeper than this: object-median splits only
constexpr int kStackSize = 128;     // > kSahDepth + log2(2^32) + 2: enough for any tree we build
// Cost of visiting a node relative to testing one triangle, for the SAH.
constexpr float kTraversalCost = 1.0f;

inline double dot3(const double a[3], const double b[3]) { return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]; }
inline void sub3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[0] - b[0];
  out[1] = a[1] - b[1];
  out[2] = a[2] - b[2];
}
inline void cross3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}
inline double distance2(const double a[3], const double b[3]) {
  double d[3];
  sub3(a, b, d);
  return dot3(d, d);
}
// out = a + t * d
inline void point_along(const double a[3], double t, const double d[3], double out[3]) {
  for (int k = 0; k < 3; ++k) out[k] = a[k] + t * d[k];
}

// Closest point of segment [a, b] to p; a zero-length segment is the point a.
double closest_point_on_segment(const double p[3], const double a[3], const double b[3], double out[3]) {
  double ab[3], ap[3];
  sub3(b, a, ab);
  sub3(p, a, ap);
  double len2 = dot3(ab, ab);
  double t = len2 > 0 ? std::clamp(dot3(ap, ab) / len2, 0.0, 1.0) : 0.0;
  point_along(a, t, ab, out);
  return distance2(p, out);
}

// Slivers and degenerate triangles: the closest point is either the projection onto the plane (when
// it falls inside) or on one of the three edges. The plane normal is taken from the two shortest
// edges, where the cross product loses the fewest digits; the inside test costs one factor of
// |n| in precision instead of the two lost by Ericson's products of dot products.
double closest_point_on_thin_triangle(const double p[3], const double* const v[3], double out[3]) {
  double e[3][3];  // e[i] = edge from corner i to corner i+1
  for (int i = 0; i < 3; ++i) sub3(v[(i + 1) % 3], v[i], e[i]);
  double len2[3] = {dot3(e[0], e[0]), dot3(e[1], e[1]), dot3(e[2], e[2])};
  int longest = len2[0] >= len2[1] ? (len2[0] >= len2[2] ? 0 : 2) : (len2[1] >= len2[2] ? 1 : 2);
  // The two edges other than the longest meet at the corner opposite to it.
  const double* e1 = e[(longest + 1) % 3];
  const double* e2 = e[(longest + 2) % 3];
  double n[3];
  cross3(e1, e2, n);
  double n2 = dot3(n, n);
  // Below this the triangle is a segment to within 1e-12 of its length: its edges are the answer.
  double lmax2 = len2[longest];
  if (n2 > 1e-24 * lmax2 * lmax2) {
    bool inside = true;
    for (int i = 0; i < 3 && inside; ++i) {
      double vp[3], c[3];
      sub3(p, v[i], vp);
      cross3(e[i], vp, c);
      inside = dot3(n, c) >= 0;
    }
    if (inside) {
      double ap[3];
      sub3(p, v[0], ap);
      double t = dot3(n, ap) / n2;
      point_along(p, -t, n, out);
      return distance2(p, out);
    }
  }
  double best = closest_point_on_segment(p, v[0], v[1], out);
  for (int i = 1; i < 3; ++i) {
    double c[3];
    double d2 = closest_point_on_segment(p, v[i], v[(i + 1) % 3], c);
    if (d2 < best) {
      best = d2;
      out[0] = c[0], out[1] = c[1], out[2] = c[2];
    }
  }
  return best;
}

// Squared distance from q to a node's box (0 inside). Branch-free: which side of a box a query lies
// is unpredictable, and (d + |d|) / 2 = max(d, 0) exactly.
inline double box_distance2(const TriangleBvh::Node& node, const double q[3]) {
  double dx = std::max(double(node.min[0]) - q[0], q[0] - double(node.max[0]));
  double dy = std::max(double(node.min[1]) - q[1], q[1] - double(node.max[1]));
  double dz = std::max(double(node.min[2]) - q[2], q[2] - double(node.max[2]));
  dx = 0.5 * (dx + std::fabs(dx));
  dy = 0.5 * (dy + std::fabs(dy));
  dz = 0.5 * (dz + std::fabs(dz));
  return (dx * dx + dy * dy) + dz * dz;
}

// Boxes during the build have four lanes (the fourth is 0 or unused) so that growing one is two
// vector min/max instructions: the build spends most of its time there.
struct Box {
  float min[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
  float max[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
  void grow(const Box& b) {
    for (int k = 0; k < 4; ++k) {
      min[k] = std::min(min[k], b.min[k]);
      max[k] = std::max(max[k], b.max[k]);
    }
  }
  void grow_point(const float p[4]) {
    for (int k = 0; k < 4; ++k) {
      min[k] = std::min(min[k], p[k]);
      max[k] = std::max(max[k], p[k]);
    }
  }
  // Grows by the three corners of a triangle, 3 floats each at corner[0..2] (fourth lane 0).
  void grow_corners(const float* const corner[3]) {
    for (int c = 0; c < 3; ++c) {
      const float point[4] = {corner[c][0], corner[c][1], corner[c][2], 0.0f};
      grow_point(point);
    }
  }
  // Half the surface area; infinite boxes (empty) give a meaningless value that is never used.
  float half_area() const {
    float dx = max[0] - min[0], dy = max[1] - min[1], dz = max[2] - min[2];
    return dx * dy + dy * dz + dz * dx;
  }
};

// Centroid -> bin factor for an axis of the given extent; 0 when the axis cannot be binned (zero
// extent, or so tiny that the factor overflows). Shared by binning and partitioning, so both put a
// triangle in the same bin.
inline float bin_scale(float extent) {
  float s = extent > 0 ? float(kBins) * (1.0f - 1e-6f) / extent : 0.0f;
  return std::isfinite(s) ? s : 0.0f;
}

// Corners of face f: 3 pointers to 3 floats each.
inline void face_corners(const float* positions, const uint32_t* indices, uint32_t f, const float* corner[3]) {
  for (int c = 0; c < 3; ++c) corner[c] = &positions[3 * size_t(indices[3 * size_t(f) + c])];
}

// The triangles of `faces`, in that order, 9 floats each: what the tree's leaves read. In `parts`
// ranges side by side.
void gather_triangles(const float* positions, const uint32_t* indices, const std::vector<uint32_t>& faces,
                      std::vector<float>& triangles, unsigned parts = 1) {
  triangles.resize(9 * faces.size());
  run_ranges(even_bounds(faces.size(), parts), [&](size_t begin, size_t end, size_t) {
    for (size_t i = begin; i < end; ++i) {
      const float* corner[3];
      face_corners(positions, indices, faces[i], corner);
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) triangles[9 * i + 3 * c + k] = corner[c][k];
    }
  });
}

// A triangle during the build is its box (fourth lanes 0); its face id travels in a parallel
// array. Its centroid is taken as min + max, twice the box center: the factor does not matter for
// binning and saves a multiply.
using PrimRef = Box;
inline void centroid2(const PrimRef& p, float c[4]) {
  for (int k = 0; k < 4; ++k) c[k] = p.min[k] + p.max[k];
}

// Triangles [begin, end) of the build array, with their box and the box of their centroids.
struct Range {
  uint32_t begin, end, depth;
  Box box, cbox;
};

// Nodes of a subtree: [0] is its root, sibling pairs follow at odd offsets (1,2), (3,4), ...; an
// inner node's index is the offset of its first child in the same list. Leaves index the build array.
using NodeList = std::vector<TriangleBvh::Node>;

// Subtrees with fewer triangles are built by one thread.
constexpr uint32_t kParallelMin = 1u << 16;

class Builder {
 public:
  Builder(std::vector<PrimRef>& prims, std::vector<uint32_t>& faces) : prims_(prims), faces_(faces) {}

  // Builds the subtree of r; the top `parallel_depth` levels hand one child to another thread.
  // The tree does not depend on the threads: each subtree is built alone and the lists are joined
  // in a fixed order.
  NodeList build(const Range& r, int parallel_depth) {
    NodeList nodes(1);
    Range left, right;
    if (parallel_depth > 0 && r.end - r.begin >= kParallelMin && split(r, left, right)) {
      NodeList left_nodes, right_nodes;
      std::exception_ptr failure;
      auto build_left = [&] {
        try {
          left_nodes = build(left, parallel_depth - 1);
        } catch (...) {
          failure = std::current_exception();
        }
      };
      std::thread helper;
      try {
        helper = std::thread(build_left);
      } catch (const std::system_error&) {
        build_left();  // no thread to be had: the same subtree, built here
      }
      try {
        right_nodes = build(right, parallel_depth - 1);
      } catch (...) {
        if (helper.joinable()) helper.join();
        throw;
      }
      if (helper.joinable()) helper.join();
      if (failure) std::rethrow_exception(failure);
      // [root, left root, right root, rest of left, rest of right]: left offset i -> i + 2,
      // right offset i -> i + |left| + 1 (both keep pairs at odd offsets since |left| is odd).
      set_inner(nodes[0], r.box, 1);
      nodes.reserve(left_nodes.size() + right_nodes.size() + 1);
      const uint32_t left_shift = 2, right_shift = uint32_t(left_nodes.size()) + 1;
      auto shifted = [](TriangleBvh::Node n, uint32_t shift) {
        if (n.count == 0) n.index += shift;
        return n;
      };
      nodes.push_back(shifted(left_nodes[0], left_shift));
      nodes.push_back(shifted(right_nodes[0], right_shift));
      for (size_t i = 1; i < left_nodes.size(); ++i) nodes.push_back(shifted(left_nodes[i], left_shift));
      for (size_t i = 1; i < right_nodes.size(); ++i) nodes.push_back(shifted(right_nodes[i], right_shift));
      return nodes;
    }

    struct Task {
      uint32_t node;
      Range range;
    };
    std::vector<Task> tasks;
    tasks.push_back({0, r});
    while (!tasks.empty()) {
      Task t = tasks.back();
      tasks.pop_back();
      if (!split(t.range, left, right)) {
        TriangleBvh::Node& leaf = nodes[t.node];
        set_box(leaf, t.range.box);
        leaf.index = t.range.begin;
        leaf.count = t.range.end - t.range.begin;
        continue;
      }
      uint32_t first = uint32_t(nodes.size());
      assert(first % 2 == 1);
      set_inner(nodes[t.node], t.range.box, first);
      nodes.resize(nodes.size() + 2);
      tasks.push_back({first + 1, right});
      tasks.push_back({first, left});
    }
    return nodes;
  }

 private:
  static void set_box(TriangleBvh::Node& n, const Box& b) {
    for (int k = 0; k < 3; ++k) n.min[k] = b.min[k], n.max[k] = b.max[k];
  }
  static void set_inner(TriangleBvh::Node& n, const Box& b, uint32_t first_child) {
    set_box(n, b);
    n.index = first_child;
    n.count = 0;
  }

  // Splits r in two (false: r is a leaf). Binned SAH along the widest axis of the centroids;
  // the object median below kSahDepth or when the centroids coincide.
  bool split(const Range& r, Range& left, Range& right) const {
    const uint32_t n = r.end - r.begin;
    if (n <= 2) return false;
    const int axis = widest_axis(r.cbox);
    const float lo = r.cbox.min[axis], s = bin_scale(r.cbox.max[axis] - lo);
    if (r.depth >= kSahDepth || s == 0) {
      if (n <= kMaxLeaf) return false;
      median_split(r, left, right);
      return true;
    }

    Box bin_box[kBins];
    uint32_t bin_count[kBins] = {};
    for (uint32_t i = r.begin; i < r.end; ++i) {
      const PrimRef& p = prims_[i];
      int b = bin_of(p.min[axis] + p.max[axis], lo, s);
      bin_box[b].grow(p);
      bin_count[b]++;
    }
    // Sweep: cost of each bin boundary = area(left) * count(left) + area(right) * count(right).
    float right_area[kBins];
    uint32_t right_count[kBins];
    Box acc;
    uint32_t count = 0;
    for (int b = kBins - 1; b > 0; --b) {
      acc.grow(bin_box[b]);
      count += bin_count[b];
      right_area[b] = acc.half_area();
      right_count[b] = count;
    }
    int split_bin = -1;  // left: bins [0, split_bin]
    float best_cost = INFINITY;
    acc = Box();
    count = 0;
    for (int b = 0; b < kBins - 1; ++b) {
      acc.grow(bin_box[b]);
      count += bin_count[b];
      if (count == 0 || right_count[b + 1] == 0) continue;
      float cost = acc.half_area() * float(count) + right_area[b + 1] * float(right_count[b + 1]);
      if (cost < best_cost) best_cost = cost, split_bin = b;
    }
    float area = r.box.half_area();
    float split_cost = area > 0 ? kTraversalCost + best_cost / area : INFINITY;
    if (n <= kMaxLeaf && float(n) <= split_cost) return false;
    // The centroids' extremes fall in the first and the last bin, so some boundary separates them;
    // the median is only a safety net.
    assert(split_bin >= 0);
    if (split_bin < 0) {
      median_split(r, left, right);
      return true;
    }

    // Hoare partition by bin (the same bin_of as above), growing both sides' boxes as triangles are
    // placed. The boxes are locals, which the compiler keeps in registers (through the output
    // references every update would go to memory and wait for the previous one).
    Box left_box, left_cbox, right_box, right_cbox;
    auto goes_left = [&](const PrimRef& p) { return bin_of(p.min[axis] + p.max[axis], lo, s) <= split_bin; };
    auto place = [](Box& box, Box& cbox, const PrimRef& p) {
      box.grow(p);
      float c[4];
      centroid2(p, c);
      cbox.grow_point(c);
    };
    uint32_t first = r.begin, last = r.end;  // [first, last) is still unplaced
    for (;;) {
      while (first < last && goes_left(prims_[first])) place(left_box, left_cbox, prims_[first++]);
      while (first < last && !goes_left(prims_[last - 1])) place(right_box, right_cbox, prims_[--last]);
      if (first == last) break;
      --last;
      std::swap(prims_[first], prims_[last]);
      std::swap(faces_[first], faces_[last]);
      place(left_box, left_cbox, prims_[first++]);
      place(right_box, right_cbox, prims_[last]);
    }
    const uint32_t mid = first;
    assert(mid > r.begin && mid < r.end);
    left = Range{r.begin, mid, r.depth + 1, left_box, left_cbox};
    right = Range{mid, r.end, r.depth + 1, right_box, right_cbox};
    return true;
  }

  // Splits at the median centroid on the widest centroid axis; ties by face id, so the split is a
  // function of the input alone.
  void median_split(const Range& r, Range& left, Range& right) const {
    const int k = widest_axis(r.cbox);
    const uint32_t n = r.end - r.begin, half = n / 2;
    struct Key {
      float c;
      uint32_t face, prim;
    };
    std::vector<Key> keys(n);
    for (uint32_t i = 0; i < n; ++i) {
      const PrimRef& p = prims_[r.begin + i];
      keys[i] = {p.min[k] + p.max[k], faces_[r.begin + i], r.begin + i};
    }
    std::nth_element(keys.begin(), keys.begin() + half, keys.end(),
                     [](const Key& x, const Key& y) { return x.c < y.c || (x.c == y.c && x.face < y.face); });
    std::vector<PrimRef> moved(n);
    for (uint32_t i = 0; i < n; ++i) moved[i] = prims_[keys[i].prim];
    for (uint32_t i = 0; i < n; ++i) {
      prims_[r.begin + i] = moved[i];
      faces_[r.begin + i] = keys[i].face;
    }
    const uint32_t mid = r.begin + half;
    left = Range{r.begin, mid, r.depth + 1, Box(), Box()};
    right = Range{mid, r.end, r.depth + 1, Box(), Box()};
    for (Range* side : {&left, &right})
      for (uint32_t i = side->begin; i < side->end; ++i) {
        side->box.grow(prims_[i]);
        float c[4];
        centroid2(prims_[i], c);
        side->cbox.grow_point(c);
      }
  }

  static int widest_axis(const Box& b) {
    float e[3];
    for (int k = 0; k < 3; ++k) e[k] = b.max[k] - b.min[k];
    return e[0] >= e[1] ? (e[0] >= e[2] ? 0 : 2) : (e[1] >= e[2] ? 1 : 2);
  }
  static int bin_of(float c, float lo, float scale) { return std::min(kBins - 1, int((c - lo) * scale)); }

  std::vector<PrimRef>& prims_;
  std::vector<uint32_t>& faces_;  // input face id of prims_[i]
};

// The Morton build (TriangleBvh::Build::morton): the faces sorted along a Morton curve of their
// centroids (10 bits per axis of the centroids' box), then split top-down where the leading bit of
// the range's codes changes, so that each split is a plane of the curve's octree; ranges of one
// code split at their middle. No surface-area sweep and no partition: the radix sort of the
// locality order (morton.h) and one pass that fills the boxes on the way back up. Depth at most
// 30 (the code's bits) + 32 (middles).
// On several threads every pass runs in ranges side by side, and the subtrees below the top
// levels are built side by side, each into a list of its own, then laid out where one thread
// puts them: the tree is the same to the byte for any thread count.
class MortonBuilder {
 public:
  // The mesh's faces (3 indices each into xyz positions), as the constructor takes them; `parts`
  // threads (1: this one only).
  MortonBuilder(const float* positions, const uint32_t* indices, uint32_t faces, unsigned parts)
      : positions_(positions), indices_(indices), n_(faces), parts_(std::max(1u, parts)) {}

  // Fills `faces` (input face per leaf slot) and `triangles` (9 floats per slot, leaf order) and
  // returns the nodes. No per-face box is kept: the codes need only the centroids, and a leaf's
  // box is that of its triangles' corners, which are read in leaf order anyway (at 4.8M faces the
  // boxes were 150 MB written, copied in sorted order and read once).
  NodeList build(std::vector<uint32_t>& faces, std::vector<float>& triangles) {
    const uint32_t n = n_;
    const std::vector<uint32_t> bounds = even_bounds(n, parts_);
    // Twice each face's box center (centroid2 of its PrimRef, to the bit), and their box (min and
    // max: the same whatever the ranges).
    std::vector<float> center2(3 * size_t(n));
    std::vector<Box> part_cbox(parts_);
    run_ranges(bounds, [&](size_t begin, size_t end, size_t part) {
      Box cbox;
      for (size_t f = begin; f < end; ++f) {
        const float* corner[3];
        face_corners(positions_, indices_, uint32_t(f), corner);
        Box box;
        box.grow_corners(corner);
        float c2[4];
        centroid2(box, c2);
        cbox.grow_point(c2);
        for (int k = 0; k < 3; ++k) center2[3 * f + k] = c2[k];
      }
      part_cbox[part] = cbox;
    });
    Box cbox;
    for (const Box& b : part_cbox) cbox.grow(b);
    float lo[3], scale[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = cbox.min[k];
      const float extent = cbox.max[k] - lo[k];
      scale[k] = extent > 0 ? 1023.0f / extent : 0.0f;
      if (!std::isfinite(scale[k])) scale[k] = 0.0f;
    }
    std::vector<uint32_t> code(n);
    run_ranges(bounds, [&](size_t begin, size_t end, size_t) {
      for (size_t i = begin; i < end; ++i) {
        uint32_t key = 0;
        for (int k = 0; k < 3; ++k) {
          const float t = std::clamp((center2[3 * i + k] - lo[k]) * scale[k], 0.0f, 1023.0f);
          key |= spread_bits(uint32_t(t)) << k;
        }
        code[i] = key;
      }
    });
    center2 = std::vector<float>();
    // Stable: equal codes keep the faces' order, so the tree is a function of the mesh alone.
    faces = sort_by_key(code, parts_);
    codes_.resize(n);
    run_ranges(bounds, [&](size_t begin, size_t end, size_t) {
      for (size_t i = begin; i < end; ++i) codes_[i] = code[faces[i]];
    });
    code = std::vector<uint32_t>();
    gather_triangles(positions_, indices_, faces, triangles, parts_);
    triangles_ = triangles.data();
    NodeList nodes;
    if (parts_ == 1 || n <= kParallelMin) {
      nodes.assign(1, TriangleBvh::Node{});
      subtree(nodes, 0, 0, n);
    } else {
      nodes = build_side_by_side(n);
    }
    codes_ = std::vector<uint32_t>();  // freed before the caller turns the nodes into pairs
    return nodes;
  }

 private:
  static constexpr uint32_t kLeaf = 4;  // ranges this small are leaves

  // Where [begin, end) (more than kLeaf triangles) splits: the first code with the leading bit in
  // which the range's codes differ set (codes are sorted), or the middle when they are all equal.
  uint32_t split_at(uint32_t begin, uint32_t end) const {
    uint32_t mid = begin + (end - begin) / 2;
    const uint32_t differ = codes_[begin] ^ codes_[end - 1];
    if (differ != 0) {
      const uint32_t bit = 1u << (31 - __builtin_clz(differ));
      mid = uint32_t(std::partition_point(codes_.begin() + begin, codes_.begin() + end,
                                          [bit](uint32_t c) { return (c & bit) == 0; }) -
                     codes_.begin());
    }
    assert(mid > begin && mid < end);
    return mid;
  }

  // Fills nodes[at] with the subtree of [begin, end), its descendants appended to `nodes` (a
  // node's two children side by side, the left one's subtree before the right one's), and
  // returns its box.
  Box subtree(NodeList& nodes, uint32_t at, uint32_t begin, uint32_t end) const {
    Box box;
    if (end - begin <= kLeaf) {
      for (uint32_t i = begin; i < end; ++i) {
        const float* t = &triangles_[9 * size_t(i)];
        const float* corner[3] = {t, t + 3, t + 6};
        box.grow_corners(corner);
      }
      TriangleBvh::Node& leaf = nodes[at];
      for (int k = 0; k < 3; ++k) leaf.min[k] = box.min[k], leaf.max[k] = box.max[k];
      leaf.index = begin;
      leaf.count = end - begin;
      return box;
    }
    const uint32_t mid = split_at(begin, end);
    const uint32_t first = uint32_t(nodes.size());
    nodes.resize(nodes.size() + 2);
    box = subtree(nodes, first, begin, mid);
    box.grow(subtree(nodes, first + 1, mid, end));
    TriangleBvh::Node& inner = nodes[at];
    for (int k = 0; k < 3; ++k) inner.min[k] = box.min[k], inner.max[k] = box.max[k];
    inner.index = first;
    inner.count = 0;
    return box;
  }

  // The tree of [0, n) as subtree() makes it on one thread, made on parts_ threads. The top levels
  // are split here down to ranges of at most `grain` triangles (tasks); the tasks' subtrees are
  // built side by side, each into a list of its own (its root first, its descendants from 1 on, as
  // subtree() makes it), then copied to where one thread would have put them: walking the top
  // levels in the same order, a task's root goes where its parent put it and its descendants
  // follow the nodes placed so far, so list entry i >= 1 lands at (cursor + i - 1) and an inner
  // node's child index moves by cursor - 1.
  NodeList build_side_by_side(uint32_t n) const {
    struct Top {
      uint32_t left = kNone, right = kNone;  // its children among the top nodes (an inner node), or
      uint32_t task = kNone;                 // the task building its range
    };
    const uint32_t grain = std::max(kParallelMin, uint32_t(n / (8 * size_t(parts_))));
    std::vector<Top> top;
    std::vector<std::pair<uint32_t, uint32_t>> tasks;  // ranges, in depth-first order
    auto split_top = [&](auto& self, uint32_t begin, uint32_t end) -> uint32_t {
      const uint32_t id = uint32_t(top.size());
      top.push_back({});
      if (end - begin <= grain) {
        top[id].task = uint32_t(tasks.size());
        tasks.push_back({begin, end});
        return id;
      }
      const uint32_t mid = split_at(begin, end);
      const uint32_t left = self(self, begin, mid);
      const uint32_t right = self(self, mid, end);
      top[id].left = left, top[id].right = right;
      return id;
    };
    split_top(split_top, 0, n);

    std::vector<NodeList> lists(tasks.size());
    std::atomic<size_t> next{0};  // tasks are claimed in order by whichever thread is free
    run_ranges(even_bounds(parts_, parts_), [&](size_t, size_t, size_t) {
      for (size_t t; (t = next.fetch_add(1)) < tasks.size();) {
        lists[t].assign(1, TriangleBvh::Node{});
        subtree(lists[t], 0, tasks[t].first, tasks[t].second);
      }
    });

    // Positions: a top inner node's children get the next two slots, then its left subtree's
    // descendants, then its right one's, as in subtree().
    std::vector<uint32_t> task_root(tasks.size()), task_cursor(tasks.size());
    std::vector<std::pair<uint32_t, uint32_t>> inner;  // top inner nodes: (position, first child), parents first
    uint32_t cursor = 1;
    auto place = [&](auto& self, uint32_t id, uint32_t at) -> void {
      const Top& t = top[id];
      if (t.task != kNone) {
        task_root[t.task] = at;
        task_cursor[t.task] = cursor;
        cursor += uint32_t(lists[t.task].size()) - 1;
        return;
      }
      const uint32_t first = cursor;
      cursor += 2;
      inner.push_back({at, first});
      self(self, t.left, first);
      self(self, t.right, first + 1);
    };
    place(place, 0, 0);
    NodeList nodes(cursor);
    run_ranges(even_bounds(tasks.size(), unsigned(std::min<size_t>(parts_, tasks.size()))),
               [&](size_t begin, size_t end, size_t) {
                 for (size_t t = begin; t < end; ++t) {
                   const uint32_t shift = task_cursor[t] - 1;
                   const NodeList& list = lists[t];
                   for (size_t i = 0; i < list.size(); ++i) {
                     TriangleBvh::Node node = list[i];
                     if (node.count == 0) node.index += shift;
                     nodes[i == 0 ? task_root[t] : shift + i] = node;
                   }
                   NodeList().swap(lists[t]);  // (freed as it goes: the lists hold as many nodes as the tree)
                 }
               });
    // The top inner nodes, children before parents: the box of both children (min and max, as
    // subtree() grows it).
    for (size_t k = inner.size(); k-- > 0;) {
      const auto [at, first] = inner[k];
      const TriangleBvh::Node &a = nodes[first], &b = nodes[first + 1];
      TriangleBvh::Node& node = nodes[at];
      for (int d = 0; d < 3; ++d) node.min[d] = std::min(a.min[d], b.min[d]), node.max[d] = std::max(a.max[d], b.max[d]);
      node.index = first;
      node.count = 0;
    }
    return nodes;
  }

  const float* positions_;
  const uint32_t* indices_;
  const uint32_t n_;
  const unsigned parts_;
  const float* triangles_ = nullptr;
  std::vector<uint32_t> codes_;  // Morton code of leaf slot i, after the sort
};

}  // namespace

double closest_point_on_triangle(const double p[3], const double a[3], const double b[3], const double c[3],
                                 double closest[3]) {
  // Ericson, Real-Time Collision Detection, 5.1.5: find the Voronoi region of p (vertex, edge or
  // face) with dot products. Its face-region test multiplies dot products, losing about twice as
  // many digits as the triangle is thin, so well-shaped triangles only: the rest go the slower way.
  double ab[3], ac[3], ap[3];
  sub3(b, a, ab);
  sub3(c, a, ac);
  double n[3];
  cross3(ab, ac, n);
  double lmax2 = std::max(std::max(dot3(ab, ab), dot3(ac, ac)), distance2(b, c));
  // |n|^2 = (2 area)^2; 1e-8 lmax^4 is a height/length ratio of 1e-4.
  if (!(dot3(n, n) > 1e-8 * lmax2 * lmax2)) {
    const double* v[3] = {a, b, c};
    return closest_point_on_thin_triangle(p, v, closest);
  }
  sub3(p, a, ap);
  double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  if (d1 <= 0 && d2 <= 0) {  // vertex region a
    closest[0] = a[0], closest[1] = a[1], closest[2] = a[2];
    return distance2(p, closest);
  }
  double bp[3];
  sub3(p, b, bp);
  double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) {  // vertex region b
    closest[0] = b[0], closest[1] = b[1], closest[2] = b[2];
    return distance2(p, closest);
  }
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {  // edge region ab (d1 - d3 = |ab|^2 > 0 here)
    point_along(a, d1 / (d1 - d3), ab, closest);
    return distance2(p, closest);
  }
  double cp[3];
  sub3(p, c, cp);
  double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) {  // vertex region c
    closest[0] = c[0], closest[1] = c[1], closest[2] = c[2];
    return distance2(p, closest);
  }
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {  // edge region ac
    point_along(a, d2 / (d2 - d6), ac, closest);
    return distance2(p, closest);
  }
  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {  // edge region bc
    double bc[3];
    sub3(c, b, bc);
    point_along(b, (d4 - d3) / ((d4 - d3) + (d5 - d6)), bc, closest);
    return distance2(p, closest);
  }
  // Face region: va + vb + vc = |n|^2 > 0 in exact arithmetic; rounding can only make the
  // barycentrics slightly off, so clamp them to keep the point on the triangle.
  double denom = va + vb + vc;
  double v = std::clamp(vb / denom, 0.0, 1.0);
  double w = std::clamp(vc / denom, 0.0, 1.0 - v);
  for (int k = 0; k < 3; ++k) closest[k] = a[k] + ab[k] * v + ac[k] * w;
  return distance2(p, closest);
}

TriangleBvh::TriangleBvh(const float* positions, const uint32_t* indices, size_t face_count, unsigned threads,
                         Build build) {
  if (face_count == 0) return;
  assert(face_count < size_t(kNone));
  const uint32_t F = uint32_t(face_count);
  if (build == Build::morton) {
    // (range_threads: one thread per 32k faces at most when threads is 0; below kParallelMin
    // faces starting threads costs more than it saves.)
    const unsigned parts = F > kParallelMin ? range_threads(F, threads) : 1;
    set_nodes(MortonBuilder(positions, indices, F, parts).build(faces_, triangles_), parts);
    return;
  }

  std::vector<PrimRef> prims(F);
  std::vector<uint32_t> prim_faces(F);
  Range all{0, F, 0, Box(), Box()};
  for (uint32_t f = 0; f < F; ++f) {
    PrimRef& p = prims[f];
    const float* corner[3];
    face_corners(positions, indices, f, corner);
    p.grow_corners(corner);
    prim_faces[f] = f;
    all.box.grow(p);
    float c[4];
    centroid2(p, c);
    all.cbox.grow_point(c);
  }

  // Subtrees are handed to other threads near the top only: 2^depth subtrees for `threads` threads,
  // one level more than needed since SAH splits are uneven.
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  int parallel_depth = 0;
  while (threads > 1 && (1u << parallel_depth) < threads && parallel_depth < 4) ++parallel_depth;
  if (parallel_depth > 0) ++parallel_depth;
  set_nodes(Builder(prims, prim_faces).build(all, parallel_depth));

  // Triangles in leaf order: a leaf reads one contiguous run.
  prims = std::vector<PrimRef>();  // free before allocating the triangles
  faces_ = std::move(prim_faces);
  gather_triangles(positions, indices, faces_, triangles_);
}

void TriangleBvh::set_nodes(const std::vector<Node>& nodes, unsigned parts) {
  // Node i of the list becomes node i + 1 (the root stays 0, node 1 is unused), so sibling pairs
  // start at even indices and fill one NodePair each.
  pairs_.resize((nodes.size() + 1) / 2);
  run_ranges(even_bounds(nodes.size(), parts), [&](size_t begin, size_t end, size_t) {
    for (size_t i = begin; i < end; ++i) {
      Node n = nodes[i];
      if (n.count == 0) n.index += 1;
      size_t at = i == 0 ? 0 : i + 1;
      pairs_[at / 2].node[at % 2] = n;
    }
  });
}

bool operator==(const TriangleBvh& a, const TriangleBvh& b) {
  // (Bytes, not values: the boxes' floats are compared as stored. memcmp takes no null pointer,
  // even for no bytes.)
  auto same_bytes = [](const auto& x, const auto& y) {
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  return same_bytes(a.pairs_, b.pairs_) && same_bytes(a.triangles_, b.triangles_) && a.faces_ == b.faces_;
}

void TriangleBvh::bounds(float min[3], float max[3]) const {
  for (int k = 0; k < 3; ++k) {
    min[k] = pairs_.empty() ? 0.0f : node(0).min[k];
    max[k] = pairs_.empty() ? 0.0f : node(0).max[k];
  }
}

// What a node points to: its children's pair, or its first triangles.
inline void TriangleBvh::prefetch_target(const Node& n) const {
  if (n.count == 0) {
    __builtin_prefetch(&pairs_[n.index >> 1]);
  } else {
    const float* t = &triangles_[9 * size_t(n.index)];
    __builtin_prefetch(t);
    __builtin_prefetch(t + 16);
  }
}

TriangleBvh::Hit TriangleBvh::closest_point(const float q[3]) const {
  double qd[3] = {q[0], q[1], q[2]};
  return closest_point(qd);
}

TriangleBvh::Hit TriangleBvh::closest_point(const double q[3]) const { return closest_point(q, INFINITY); }

TriangleBvh::Hit TriangleBvh::closest_point(const double q[3], double max_distance2) const {
  Hit hit;
  if (pairs_.empty() || !(max_distance2 >= 0)) return hit;

  // A box is skipped when it is farther than the best distance plus `tolerance`: the point-triangle
  // distance is computed with rounding errors of about 1e-16 of the coordinates' magnitude, so a
  // triangle whose computed distance ties the best may lie in a box whose computed distance is a
  // hair larger. 1e-12 of the magnitude covers that with room to spare and costs no extra visits
  // in practice.
  const Node& root = node(0);
  double magnitude = 0;
  for (int k = 0; k < 3; ++k) {
    magnitude = std::max(magnitude, std::fabs(q[k]));
    magnitude = std::max(magnitude, std::fabs(double(root.min[k])));
    magnitude = std::max(magnitude, std::fabs(double(root.max[k])));
  }
  const double tolerance = 1e-12 * magnitude;
  double best2 = max_distance2;
  auto limit_of = [tolerance](double d2) {
    double d = std::sqrt(d2) + tolerance;
    return d * d;
  };
  double limit = limit_of(best2);

  uint32_t stack_node[kStackSize];
  double stack_dist[kStackSize];
  int top = 0;
  double root_d2 = box_distance2(root, q);
  if (root_d2 > limit) return hit;
  stack_node[0] = 0;
  stack_dist[0] = root_d2;
  top = 1;

  while (top > 0) {
    --top;
    if (stack_dist[top] > limit) continue;
    const Node* n = &node(stack_node[top]);
    // Descend nearer child first; the farther one waits on the stack.
    for (;;) {
      if (n->count > 0) {
        for (uint32_t i = n->index, e = n->index + n->count; i < e; ++i) {
          const float* t = &triangles_[9 * size_t(i)];
          // The triangle's own box is a cheap lower bound that spares most exact tests.
          Node box;
          for (int k = 0; k < 3; ++k) {
            box.min[k] = std::min(std::min(t[k], t[3 + k]), t[6 + k]);
            box.max[k] = std::max(std::max(t[k], t[3 + k]), t[6 + k]);
          }
          if (box_distance2(box, q) > limit) continue;
          double a[3] = {t[0], t[1], t[2]}, b[3] = {t[3], t[4], t[5]}, c[3] = {t[6], t[7], t[8]};
          double p[3];
          double d2 = closest_point_on_triangle(q, a, b, c, p);
          if (d2 > hit.distance2 || d2 > max_distance2) continue;
          // Ties go to the lower face id, so the answer does not depend on the tree's order.
          uint32_t f = faces_[i];
          if (d2 == hit.distance2 && f > hit.face) continue;
          hit.distance2 = d2;
          hit.face = f;
          for (int k = 0; k < 3; ++k) hit.point_exact[k] = p[k];
          if (d2 < best2) {
            best2 = d2;
            limit = limit_of(best2);
          }
        }
        break;
      }
      const NodePair& children = pairs_[n->index >> 1];
      // Traversal is bound by memory latency: ask for what both children point to now, so the two
      // fetches overlap (the farther child is usually visited later, from the stack).
      prefetch_target(children.node[0]);
      prefetch_target(children.node[1]);
      double d0 = box_distance2(children.node[0], q), d1 = box_distance2(children.node[1], q);
      uint32_t near = n->index, far = n->index + 1;
      if (d1 < d0) std::swap(near, far), std::swap(d0, d1);
      if (d0 > limit) break;
      if (d1 <= limit) {
        assert(top < kStackSize);
        stack_node[top] = far;
        stack_dist[top] = d1;
        ++top;
      }
      n = &node(near);
    }
  }
  if (hit.face != kNone)
    for (int k = 0; k < 3; ++k) hit.point[k] = float(hit.point_exact[k]);
  return hit;
}

void TriangleBvh::closest_points(const double* queries, size_t count, Hit* hits, unsigned threads) const {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  constexpr size_t kChunk = 1024;
  size_t chunks = (count + kChunk - 1) / kChunk;
  threads = unsigned(std::min<size_t>(threads, chunks));
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t c; (c = next.fetch_add(1)) < chunks;) {
      size_t end = std::min(count, (c + 1) * kChunk);
      for (size_t i = c * kChunk; i < end; ++i) hits[i] = closest_point(&queries[3 * i]);
    }
  };
  std::vector<std::thread> pool;
  try {
    for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
  } catch (const std::system_error&) {
    // No more threads to be had: the ones running (and this one) pull every chunk anyway.
  }
  work();
  for (auto& th : pool) th.join();
}

}  // namespace meshcvt
