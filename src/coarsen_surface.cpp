// meshcvt: the whole coarsening of a mesh as read (`meshcvt coarsen` between reading and writing):
// the input refined where its faces are too large or too long for the clusters, then coarsen_mesh
// (Fan et al. Section 6.1 with the topology fixes of coarsen_mesh.cpp). The refinement is
// subdivide_midpoint (as ACVD and pyacvd subdivide a coarse input) and split_long_edges (Rivara's
// longest-edge bisection, for CAD exports' long thin faces: a cluster is a set of whole faces, so
// none can be round where faces are longer than a cluster is wide).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "parallel.h"
#include "vec3.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/density.h"
#include "meshcvt/error.h"
#include "meshcvt/mesh_order.h"
#include "meshcvt/subdivide.h"
#include "meshcvt/topology.h"

namespace meshcvt {

namespace {

// A number in a message, as %.4g writes it.
std::string format_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", x);
  return buf;
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Per fixed chunk of faces, on the worker pool: fn(first, last) -> a partial result, added in chunk
// order, so the total does not depend on the thread count (the sum sets the split's limit).
// (One thread for both passes cost the 4.8M bunny 0.16 s.)
template <typename T, typename Fn>
T sum_over_faces(WorkerPool& pool, size_t faces, const Fn& fn) {
  constexpr size_t kChunk = size_t(1) << 16;
  const size_t chunks = (faces + kChunk - 1) / kChunk;
  std::vector<T> partial(chunks, T(0));
  pool.run(chunks, [&](size_t first, size_t last, unsigned) {
    for (size_t c = first; c < last; ++c) partial[c] = fn(c * kChunk, std::min(faces, (c + 1) * kChunk));
  }, 2);
  T total = 0;
  for (T x : partial) total += x;
  return total;
}

// The sum of area x sqrt(density) over the faces (density empty: 1), in double: what
// coarse_edge_length takes.
double sqrt_density_area(WorkerPool& pool, const Mesh& mesh, const std::vector<float>& density) {
  return sum_over_faces<double>(pool, mesh.face_count(), [&](size_t first, size_t last) {
    double sum = 0;
    for (size_t f = first; f < last; ++f)
      sum += face_area(mesh, f) * (density.empty() ? 1.0 : std::sqrt(double(density[f])));
    return sum;
  });
}

// The coarse edge length where face f is: `length` where the density is 1 (coarse_edge_length).
double edge_length_at(double length, const std::vector<float>& density, size_t f) {
  return density.empty() ? length : length / std::sqrt(std::sqrt(double(density[f])));
}

// Edges longer than `length` where they are (edge_length_at): half the half-edges that long (an
// interior edge is two, a boundary edge one: close enough for a count that decides whether to split
// and is reported).
uint64_t edges_longer_than(WorkerPool& pool, const Mesh& mesh, double length, const std::vector<float>& density) {
  const uint64_t half_edges = sum_over_faces<uint64_t>(pool, mesh.face_count(), [&](size_t first, size_t last) {
    uint64_t count = 0;
    for (size_t f = first; f < last; ++f) {
      const double limit = edge_length_at(length, density, f), limit2 = limit * limit;
      const uint32_t* t = &mesh.indices[3 * f];
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = t[k], b = t[(k + 1) % 3];
        double s = 0;
        for (int d = 0; d < 3; ++d) {
          const double x = double(mesh.positions[3 * size_t(a) + d]) - mesh.positions[3 * size_t(b) + d];
          s += x * x;
        }
        count += s > limit2;
      }
    }
    return count;
  });
  return (half_edges + 1) / 2;
}

// Per-face values of a split mesh from those of the faces they came from (empty stays empty).
template <typename T>
std::vector<T> inherited(const std::vector<T>& values, const std::vector<uint32_t>& parent) {
  if (values.empty()) return {};
  std::vector<T> out(parent.size());
  for (size_t f = 0; f < out.size(); ++f) out[f] = values[parent[f]];
  return out;
}

// Per-face values of a mesh subdivided `levels` times from those of its faces (children of face f
// are [f 4^levels, (f + 1) 4^levels); empty stays empty).
template <typename T>
std::vector<T> to_children(const std::vector<T>& values, unsigned levels) {
  if (values.empty() || levels == 0) return values;
  std::vector<T> out(values.size() << (2 * levels));
  for (size_t f = 0; f < out.size(); ++f) out[f] = values[f >> (2 * levels)];
  return out;
}

// Components of fewer faces than they need clusters are refined below (by subdivide_faces) until
// they have enough. describe_components, which knows the need, copies out every component; a
// component can need more clusters than it has faces only where it has fewer faces than vertices
// (its need is at most its vertex count when it is a simplicial surface) or few faces at all (a
// pseudo-triangulation with repeated edges), so only then is it called.
constexpr uint32_t kFewFaces = 64;
// Levels at most for one component (a lone triangle needs one).
constexpr unsigned kMaxComponentLevels = 6;

// Each component of m with fewer faces than describe_components' minimum (a lone triangle needs
// 3 clusters, a closed pair of faces 4) midpoint-subdivided until it has at least that many
// faces, so that coarsen_mesh can give it its clusters instead of refusing the mesh
// (libcgal-demo's b9_mesh: lone triangles). A face of another component on one of its edges (a
// non-manifold edge: a fin on a scan's edge) is split at that edge's midpoint, so that no
// T-junction is left; the rest of m is untouched. (Until the twenty-fourth session such a
// component was subdivided whole with it: a fin on a scan's edge made four times the scan.)
// density (per face, may be empty) follows; parent: per face of the new m, its face in the m given
// (left empty when nothing is refined). topology is rebuilt when m changes. Returns the counts
// (RefinedComponents); throws OptionError where subdividing does not give a component room (see
// the end).
struct RefinedComponents {
  uint32_t too_small = 0;  // components with fewer faces than they need clusters
  uint32_t with_them = 0;  // other components with faces split at an edge they share with one
  uint64_t faces = 0;      // faces of m subdivided or split (before)
};

RefinedComponents refine_small_components(Mesh& m, Topology& topology, std::vector<float>& density,
                                          std::vector<uint32_t>& parent) {
  const uint32_t nc = topology.component_count;
  // (One component with at least as many faces as the mesh has vertices: no pass over the faces.)
  if (nc == 1 && m.face_count() >= std::max<size_t>(m.vertex_count(), kFewFaces)) return {};
  {
    std::vector<uint32_t> faces(nc, 0), vertices(nc, 0), last(m.vertex_count(), kNone);
    for (size_t f = 0; f < m.face_count(); ++f) {
      const uint32_t c = topology.face_component[f];
      ++faces[c];
      for (int k = 0; k < 3; ++k) {  // (a vertex of several components may count more than once: safe)
        uint32_t& seen_in = last[m.indices[3 * f + k]];
        if (seen_in != c) seen_in = c, ++vertices[c];
      }
    }
    bool suspect = false;
    for (uint32_t c = 0; c < nc && !suspect; ++c) suspect = faces[c] < vertices[c] || faces[c] < kFewFaces;
    if (!suspect) return {};
  }
  const ComponentAllocation a = describe_components(m, topology);
  std::vector<unsigned> levels(nc, 0);
  unsigned rounds = 0;
  RefinedComponents refined;
  for (uint32_t c = 0; c < nc; ++c) {
    for (uint64_t have = a.faces[c]; have < a.minimum[c] && levels[c] < kMaxComponentLevels; have *= 4) ++levels[c];
    if (levels[c] == 0) continue;
    ++refined.too_small;
    refined.faces += a.faces[c];
    rounds = std::max(rounds, levels[c]);
  }
  if (rounds == 0) return {};
  // Level by level (components may need different counts); children and pieces keep their face's
  // component.
  std::vector<uint32_t> component = topology.face_component;
  std::vector<uint8_t> split_in(nc, 0), split_face(m.face_count(), 0);  // components, faces of m split so far
  parent.resize(m.face_count());
  for (size_t f = 0; f < parent.size(); ++f) parent[f] = uint32_t(f);
  for (unsigned round = 0; round < rounds; ++round) {
    std::vector<uint8_t> selected(m.face_count());
    for (size_t f = 0; f < selected.size(); ++f) selected[f] = levels[component[f]] > round;
    SubdividedFaces fine = subdivide_faces(m, selected, 1, /*split_neighbours=*/true);
    std::vector<uint32_t> next_parent(fine.parent.size()), next_component(fine.parent.size());
    for (size_t f = 0; f < fine.parent.size(); ++f) {
      const uint32_t from = fine.parent[f];
      next_parent[f] = parent[from];
      next_component[f] = component[from];
      // A face not selected that came out in pieces: a neighbour split at a shared edge.
      if (!selected[from] && levels[component[from]] == 0 && ((f > 0 && fine.parent[f - 1] == from) ||
                              (f + 1 < fine.parent.size() && fine.parent[f + 1] == from))) {
        split_in[component[from]] = 1;
        if (!split_face[parent[from]]) split_face[parent[from]] = 1, ++refined.faces;
      }
    }
    density = inherited(density, fine.parent);
    parent = std::move(next_parent);
    component = std::move(next_component);
    m = std::move(fine.mesh);
  }
  for (uint32_t c = 0; c < nc; ++c) refined.with_them += split_in[c];
  // Where the refined surface still has a component too small, subdividing did not help: two
  // faces on the same three corners (a pillow of no volume) come apart at their non-manifold
  // edges into pieces as small (assimp-testmodels' concave_polygon.obj). That mesh cannot be
  // coarsened; the error says why rather than asking for a subdivision.
  Topology fine_topology = build_topology(m);
  const ComponentAllocation after = describe_components(m, fine_topology);
  for (uint32_t c = 0; c < fine_topology.component_count; ++c)
    if (after.faces[c] < after.minimum[c]) {
      uint32_t first = 0;  // the first component of the surface as given that was too small
      while (first < nc && a.faces[first] >= a.minimum[first]) ++first;
      throw OptionError("coarsen: component " + std::to_string(first) + " (" + std::to_string(a.faces[first]) +
                        " face" + (a.faces[first] == 1 ? "" : "s") + ") has fewer faces than the " +
                        std::to_string(a.minimum[first]) +
                        " clusters it needs to come out as a valid surface, and subdivided it comes apart at "
                        "non-manifold edges into parts as small (faces on the same corners, or dangling at "
                        "an edge of another part?): remove those faces first");
    }
  topology = std::move(fine_topology);
  return refined;
}

// One job on surface m with density d: the locality order (the output depends on the face order
// only through it), the topology, prepare_surface unless the gradation did it on the input,
// refine_small_components, and coarsen_mesh.
struct JobRun {
  Mesh surface;
  std::vector<uint32_t> origin;  // per surface face: the face of the mesh given to coarsen_surface
  LocalityOrder order;  // face i of the mesh given to run_job, reordered, is face order.face_of[i] of it
  std::vector<uint32_t> refine_parent;  // surface face -> reordered face (empty: none refined)
  RefinedComponents refined;
  std::vector<float> density;  // per face of surface (empty: uniform)
  Topology topology;
  SurfacePreparation prepared;
  size_t prepared_faces = 0;
  CoarsenMeshResult job;
  double order_seconds = 0;
  double topology_seconds = 0;  // the topology, prepare_surface and refine_small_components
};

// origin: per face of m, the face of the mesh given to coarsen_surface.
JobRun run_job(Mesh m, const std::vector<float>& d, const std::vector<uint32_t>& origin,
               const CoarsenSurfaceOptions& options, bool prepare) {
  JobRun run;
  const auto start = Clock::now();
  run.order = reorder_for_locality(m, kLocalityMinFaces, options.job.cluster.threads);
  CoarsenMeshOptions job = options.job;
  run.density = to_reordered(d, run.order);
  run.origin = run.order.identity() ? origin : inherited(origin, run.order.face_of);
  run.order_seconds = seconds_since(start);
  const auto topology_start = Clock::now();
  run.topology = build_topology(m, options.job.cluster.threads);
  if (prepare) {
    run.prepared = prepare_surface(m, run.topology);
    run.prepared_faces = m.face_count();
  }
  if (options.refine_small_components)
    run.refined = refine_small_components(m, run.topology, run.density, run.refine_parent);
  if (!run.refine_parent.empty()) run.origin = inherited(run.origin, run.refine_parent);
  run.topology_seconds = seconds_since(topology_start);
  job.cluster.density = run.density;  // coarsen_mesh weighs both the clusters and the dual with it
  run.job = coarsen_mesh(m, run.topology, job);
  run.surface = std::move(m);
  return run;
}

double seconds_of(const JobRun& run) {
  return run.order_seconds + run.topology_seconds + run.job.cluster_seconds + run.job.fix_seconds +
         run.job.coarsen_seconds;
}

// What the report lists of a job (kept: as the first job, until another is better).
CoarsenSurfaceJob job_record(const JobRun& run, CoarsenSurfaceJob::Surface surface) {
  CoarsenSurfaceJob record;
  record.surface = surface;
  record.faces = run.surface.face_count();
  record.initial_defects = run.job.initial_defects;
  record.defects = run.job.coarse.defects.size();
  record.seconds = seconds_of(run);
  record.kept = true;
  return record;
}

// The components of a job's surface that hold a cluster a defect names, as faces of the mesh the
// surface was split from (parent: split face -> face of that mesh). A split keeps components (the
// pieces of two faces that share an edge share its pieces), so the marked faces are whole
// components of that mesh too.
struct BrokenComponents {
  std::vector<uint8_t> faces;  // 1 for each face of the unsplit mesh in such a component
  size_t faces_marked = 0;
  uint32_t components = 0;
};

BrokenComponents broken_components(const JobRun& run, const std::vector<uint32_t>& parent, size_t unsplit_faces) {
  const std::vector<uint32_t>& labels = run.job.clustering.labels;
  const Topology& topology = run.topology;
  const uint32_t clusters = uint32_t(run.job.coarse.mesh.vertex_count());
  std::vector<uint32_t> component_of(clusters, kNone);
  for (size_t f = 0; f < labels.size(); ++f)
    if (labels[f] < clusters) component_of[labels[f]] = topology.face_component[f];
  std::vector<uint8_t> broken(topology.component_count, 0);
  for (const DualDefect& d : run.job.coarse.defects)
    for (uint32_t id : {d.cluster, d.other, d.third})
      if (id < clusters && component_of[id] != kNone) broken[component_of[id]] = 1;
  BrokenComponents out;
  out.faces.assign(unsplit_faces, 0);
  for (uint8_t b : broken) out.components += b;
  for (size_t f = 0; f < labels.size(); ++f) {
    if (!broken[topology.face_component[f]]) continue;
    const size_t reordered = run.refine_parent.empty() ? f : run.refine_parent[f];
    const size_t split_face = run.order.identity() ? reordered : run.order.face_of[reordered];
    uint8_t& mark = out.faces[parent[split_face]];
    out.faces_marked += !mark;
    mark = 1;
  }
  return out;
}

}  // namespace

CoarsenSurfaceResult coarsen_surface(Mesh mesh, const CoarsenSurfaceOptions& options) {
  const uint32_t n = options.job.cluster.clusters;
  const VertexPlacement placement = options.job.coarsen.placement;
  // Options first, so a bad value costs no work.
  if (!(options.gradation >= 0) || !std::isfinite(options.gradation))
    throw OptionError("coarsen: the gradation must be a finite number >= 0, not " + std::to_string(options.gradation));
  if (options.subdivide < kSubdivideByPlacement || options.subdivide > 6)
    throw OptionError("coarsen: subdivide must be kSubdivideByPlacement, kSubdivideAuto or 0..6 levels, not " +
                      std::to_string(options.subdivide));
  const bool auto_split = options.split_edges == kSplitEdgesAuto;
  if (!auto_split && !(options.split_edges >= 0 && options.split_edges <= 16))
    throw OptionError("coarsen: split_edges must be kSplitEdgesAuto or a ratio within [0, 16], not " +
                      std::to_string(options.split_edges));
  std::vector<float> density = options.job.cluster.density;  // empty: uniform
  if (!density.empty() && options.gradation > 0)
    throw OptionError("coarsen: a density and a gradation were both given: the gradation makes the density");
  if (!density.empty() && density.size() != mesh.face_count())
    throw OptionError("coarsen: the density has " + std::to_string(density.size()) + " entries for " +
                      std::to_string(mesh.face_count()) + " faces");

  CoarsenSurfaceResult result;
  auto t0 = Clock::now();
  // Faces with a repeated corner (welding a sliver leaves them) have no area and no edges: left out
  // here, as coarsen_mesh would leave them out, so that every count below is of the surface.
  result.given_faces = mesh.face_count();
  // Per face of `mesh`, at each step below: the face of the mesh given that it is or lies in (only
  // where asked for: empty, every step leaves it empty).
  std::vector<uint32_t> origin;
  {
    std::vector<uint32_t> kept_index;
    const bool keep_index = options.keep_surface_origin || !density.empty();
    result.collapsed_faces = remove_collapsed_faces(mesh, keep_index ? &kept_index : nullptr);
    if (options.keep_surface_origin) {
      origin.resize(mesh.face_count());
      for (size_t f = 0; f < kept_index.size(); ++f)
        if (kept_index[f] != kNone) origin[kept_index[f]] = uint32_t(f);
    }
    if (result.collapsed_faces > 0 && !density.empty()) {
      std::vector<float> kept(mesh.face_count());
      for (size_t f = 0; f < kept_index.size(); ++f)
        if (kept_index[f] != kNone) kept[kept_index[f]] = density[f];
      density = std::move(kept);
    }
  }
  if (mesh.face_count() == 0)
    throw Error("coarsen: every face has a repeated corner index (no area): nothing to coarsen");
  result.input_faces = mesh.face_count();

  // The gradation's density is estimated on the input's own faces (a midpoint subdivision adds no
  // curvature information, and its finer faces would make creases look sharper), after
  // prepare_surface: the curvature needs consistent normals as much as the dual does.
  result.prepared_faces = mesh.face_count();
  if (options.gradation > 0) {
    Topology input_topology = build_topology(mesh);
    result.prepared = prepare_surface(mesh, input_topology);
    density = curvature_density(mesh, input_topology, options.gradation);
  }
  const int subdivide = options.subdivide == kSubdivideByPlacement
                            ? (subdivides_by_default(placement) ? kSubdivideAuto : 0)
                            : options.subdivide;
  result.subdivision_levels =
      subdivide == kSubdivideAuto
          ? subdivision_levels_for(result.input_faces, n, subdivision_faces_per_cluster(placement))
          : unsigned(subdivide);
  if (result.subdivision_levels > 0) {
    mesh = subdivide_midpoint(mesh, result.subdivision_levels, options.job.cluster.threads);
    origin = to_children(origin, result.subdivision_levels);
    density = to_children(density, result.subdivision_levels);
  }
  result.subdivided_faces = mesh.face_count();

  // Long edges: longer than the coarse mesh's edge (where the density is 1; per face below).
  const double split_option = auto_split ? 0 : options.split_edges;
  const bool measure = auto_split || split_option > 0 || options.count_long_edges;
  if (measure && n > 0) {
    WorkerPool pool(options.job.cluster.threads);
    const double area = sqrt_density_area(pool, mesh, density);
    if (area > 0) {
      result.coarse_edge_length = coarse_edge_length(area, n);
      result.long_edges = edges_longer_than(pool, mesh, result.coarse_edge_length, density);
    }
  }
  // (Not where n is above the face count: for an n far beyond what the input holds the split would
  // go on until memory ran out; the error below names the remedy instead.)
  const bool too_coarse =
      n <= mesh.face_count() && double(mesh.face_count()) < kAutoSplitFacesPerCluster * double(n);
  const double ratio =
      auto_split ? ((result.long_edges >= n || too_coarse) && n > 0 ? kAutoSplitEdgesRatio : 0) : split_option;
  // auto: the mesh before the split, its density, the split's limits and the parents of the split
  // faces, for the fallbacks below.
  Mesh unsplit;
  std::vector<float> unsplit_density;
  std::vector<uint32_t> unsplit_origin, split_parent;
  // The split's limit on face f of a mesh whose density is d: 1 / ratio of the coarse edge there.
  auto limit_of = [&](const std::vector<float>& d, size_t f) {
    return edge_length_at(result.coarse_edge_length, d, f) / ratio;
  };
  if (ratio > 0 && result.coarse_edge_length > 0) {
    std::vector<double> face_limit;  // with a density: where clusters are smaller, so are the limits
    if (!density.empty()) {
      face_limit.resize(mesh.face_count());
      for (size_t f = 0; f < mesh.face_count(); ++f) face_limit[f] = limit_of(density, f);
    }
    // Not where the split would run away (slivers: see kAutoSplitMaxGrowth): auto leaves the edges
    // as they are, an explicit ratio is refused (it would take minutes and gigabytes). The budget
    // stops the split itself too: the refinement's propagation along slivers can make many times
    // split_long_edges_min_faces, which alone refuses only what is beyond it for sure.
    const double budget = kAutoSplitMaxGrowth * double(std::max<size_t>(n, mesh.face_count()));
    SplitEdgesResult split = split_long_edges(mesh, result.coarse_edge_length / ratio, face_limit,
                                              uint64_t(std::min(budget, 1e18)));
    if (split.over_budget && !auto_split)
      throw OptionError("coarsen: splitting the edges longer than 1/" + format_number(ratio) +
                        " of the coarse edge length (" + format_number(result.coarse_edge_length) +
                        ") would make more than " + format_number(double(split.over_budget_faces)) + " faces from " +
                        std::to_string(mesh.face_count()) +
                        " (slivers: long edges, little area); use --split-edges auto or off");
    if (split.over_budget) result.split_refused_faces = double(split.over_budget_faces);
    if (split.split_edges > 0) {
      result.split_ratio = ratio;
      result.split_edges = split.split_edges;
      if (auto_split) {
        unsplit = mesh;
        unsplit_density = density;
        unsplit_origin = origin;
        split_parent = split.parent;
      }
      density = inherited(density, split.parent);
      origin = inherited(origin, split.parent);
      mesh = std::move(split.mesh);
    }
  }
  result.prepare_seconds = seconds_since(t0);
  // coarsen_mesh's own message names the numbers too; this one also knows the remedy.
  if (n > mesh.face_count() && result.subdivision_levels == 0)
    throw OptionError("coarsen: cannot make " + std::to_string(n) + " vertices from the " +
                      std::to_string(mesh.face_count()) +
                      " faces of the input: ask for fewer, or subdivide it first (--subdivide auto, kSubdivideAuto)");

  const bool prepare = options.gradation == 0;
  JobRun run = run_job(std::move(mesh), density, origin, options, prepare);
  // Where the GPU failed over to the CPU engine (coarsen_mesh), the other surfaces below are
  // clustered on the CPU engine from the start; the job kept says why.
  std::optional<CoarsenSurfaceOptions> on_cpu;
  const bool fell_back = run.job.clustering.fell_back;
  const std::string fallback_notice = run.job.clustering.device_notice;
  if (fell_back) {
    on_cpu = options;
    on_cpu->job.cluster.device = "cpu";
  }
  const CoarsenSurfaceOptions& later = on_cpu ? *on_cpu : options;
  // Where the coarse mesh keeps defects, other surfaces are tried, each kept only if its coarse
  // mesh has fewer defects than the best so far (result.jobs lists them).
  JobRun as_given;  // the input as given's job, where it ran after a split and was not kept
  auto keep_if_better = [&](JobRun&& other, CoarsenSurfaceJob::Surface surface) {
    if (result.jobs.empty())
      result.jobs.push_back(job_record(run, result.split_edges > 0 ? CoarsenSurfaceJob::split : CoarsenSurfaceJob::as_given));
    const bool better = other.job.coarse.defects.size() < run.job.coarse.defects.size();
    result.jobs.push_back(job_record(other, surface));
    result.jobs.back().kept = better;
    if (!better) return false;
    for (size_t i = 0; i + 1 < result.jobs.size(); ++i) result.jobs[i].kept = false;
    run = std::move(other);
    return true;
  };
  // auto's fallbacks, where the split surface's coarse mesh keeps defects: first the split without
  // the components that have them, then the input as it was (ties: the more split one). A
  // component narrower than a cluster (ALSTOM_TEST4's strip of 34 faces, all on its boundary, at
  // -> 203) has a valid coarse mesh as given, found from its own faces, and none split; its other
  // components gain from the split.
  if (auto_split && result.split_edges > 0 && run.job.defects_remain && unsplit.face_count() >= n) {
    const BrokenComponents broken = broken_components(run, split_parent, unsplit.face_count());
    if (broken.faces_marked > 0 && broken.faces_marked < unsplit.face_count()) {
      // Unreachable limits leave the broken components' faces as they are (a component shares no
      // edge with another, so no neighbour's split reaches in).
      std::vector<double> partial_limit(unsplit.face_count());
      for (size_t f = 0; f < partial_limit.size(); ++f)
        partial_limit[f] = broken.faces[f] ? std::numeric_limits<double>::max() : limit_of(unsplit_density, f);
      SplitEdgesResult partial = split_long_edges(unsplit, 1.0, partial_limit);
      if (partial.split_edges > 0 && partial.mesh.face_count() >= n) {
        const uint64_t partial_edges = partial.split_edges;
        if (keep_if_better(run_job(std::move(partial.mesh), inherited(unsplit_density, partial.parent),
                                   inherited(unsplit_origin, partial.parent), later, prepare),
                           CoarsenSurfaceJob::partly_split)) {
          result.split_edges = partial_edges;
          result.unsplit_components = broken.components;
        }
      }
    }
    if (run.job.defects_remain) {
      JobRun plain = run_job(std::move(unsplit), unsplit_density, unsplit_origin, later, prepare);
      if (keep_if_better(std::move(plain), CoarsenSurfaceJob::as_given)) {
        result.split_discarded = true;
        result.split_ratio = 0;
        result.split_edges = 0;
        result.unsplit_components = 0;
      } else {
        as_given = std::move(plain);  // (keep_if_better moves only what it keeps)
      }
    }
  }
  // Last, where defects remain and no subdivision was asked for: the surface as given (without a
  // long-edge split) subdivided once, as --subdivide one level more would. Clusters of four times
  // the faces have more room to be disks (assimp-testmodels' Wuson -> 373: 21 defects -> 0; its
  // partly split surface subdivided kept 60). Only up to max_retry_faces faces subdivided: the
  // limit used to be on the surface before its subdivision, and a damaged dino's stray parts,
  // auto-subdivided three times for qem at 15856 (507k faces), were retried at 2M faces for 35 s
  // (after a 4 s job) to keep 21 defects instead of 17.
  const JobRun& base = as_given.surface.face_count() > 0 ? as_given : run;
  if (run.job.defects_remain && options.subdivide == kSubdivideByPlacement && options.retry_subdivided &&
      4 * uint64_t(base.surface.face_count()) <= options.max_retry_faces) {
    // Its density and origins (reordered with its surface), to the children.
    if (keep_if_better(run_job(subdivide_midpoint(base.surface, 1, options.job.cluster.threads), to_children(base.density, 1),
                               to_children(base.origin, 1), later, prepare),
                       CoarsenSurfaceJob::subdivided)) {
      result.retried_subdivided = true;
      if (&base == &as_given) {  // (else the surface subdivided is the one kept, split as it was)
        result.split_discarded = true;
        result.split_ratio = 0;
        result.split_edges = 0;
        result.unsplit_components = 0;
      }
    }
  }
  for (const CoarsenSurfaceJob& job : result.jobs)
    if (!job.kept) {
      result.discarded_seconds += job.seconds;
      result.discarded_job_defects = result.discarded_job_defects < 0
                                         ? int64_t(job.defects)
                                         : std::min(result.discarded_job_defects, int64_t(job.defects));
    }
  result.prepare_seconds += run.order_seconds;
  result.topology_seconds = run.topology_seconds;
  if (prepare) {
    result.prepared = run.prepared;
    result.prepared_faces = run.prepared_faces;
  }
  result.refined_components = run.refined.too_small;
  result.refined_with_them = run.refined.with_them;
  result.refined_faces = run.refined.faces;
  result.surface_origin = std::move(run.origin);
  result.surface = std::move(run.surface);
  result.topology = std::move(run.topology);
  result.job = std::move(run.job);
  if (fell_back) result.job.clustering.fell_back = true, result.job.clustering.device_notice = fallback_notice;
  return result;
}

std::vector<uint32_t> input_face_clusters(const Mesh& given, const CoarsenSurfaceResult& result) {
  const size_t faces = given.face_count();
  if (faces != result.given_faces)
    throw OptionError("input_face_clusters: the mesh has " + std::to_string(faces) + " faces, the coarsening was of " +
                      std::to_string(result.given_faces));
  const std::vector<uint32_t>& origin = result.surface_origin;
  const std::vector<uint32_t>& labels = result.job.clustering.labels;
  if (origin.empty() && faces > 0)
    throw OptionError("input_face_clusters: the result has no surface_origin: run coarsen_surface with "
                      "keep_surface_origin set");
  if (origin.size() != result.surface.face_count() || labels.size() != origin.size())
    throw OptionError("input_face_clusters: the result's surface, origins and labels disagree");
  // Faces kept (no repeated corner) in order, as remove_collapsed_faces numbered them.
  std::vector<uint32_t> kept_index(faces, kNone);
  uint32_t kept = 0;
  for (size_t f = 0; f < faces; ++f) {
    const uint32_t* t = &given.indices[3 * f];
    if (!(t[0] == t[1] || t[1] == t[2] || t[0] == t[2])) kept_index[f] = kept++;
  }
  // Pieces per face of the mesh given: one where it was clustered as it is.
  std::vector<uint32_t> pieces(faces, 0);
  for (uint32_t f : origin) {
    if (f >= faces || kept_index[f] == kNone)
      throw OptionError("input_face_clusters: the result's origins are not faces of this mesh");
    ++pieces[f];
  }
  std::vector<uint32_t> kept_labels(kept, 0);
  bool split = false;
  for (size_t i = 0; i < origin.size(); ++i) {
    if (pieces[origin[i]] > 1) split = true;
    kept_labels[kept_index[origin[i]]] = labels[i];
  }
  if (split) {
    // (face, cluster, area) of every piece, summed per face and cluster; the largest sum wins.
    struct Piece {
      uint32_t face, cluster;
      double area;
    };
    std::vector<Piece> all(origin.size());
    for (size_t i = 0; i < origin.size(); ++i) all[i] = {origin[i], labels[i], face_area(result.surface, i)};
    std::sort(all.begin(), all.end(), [](const Piece& x, const Piece& y) {
      return x.face != y.face ? x.face < y.face : x.cluster < y.cluster;
    });
    for (size_t i = 0; i < all.size();) {
      const uint32_t f = all[i].face;
      double best = -1;
      uint32_t best_cluster = 0;
      while (i < all.size() && all[i].face == f) {
        const uint32_t c = all[i].cluster;
        double sum = 0;
        for (; i < all.size() && all[i].face == f && all[i].cluster == c; ++i) sum += all[i].area;
        if (sum > best) best = sum, best_cluster = c;  // strictly: ties keep the lower id
      }
      kept_labels[kept_index[f]] = best_cluster;
    }
  }
  if (kept == faces) return kept_labels;
  return labels_with_collapsed_faces(given, build_topology(given), kept_index, kept_labels, 0);
}

const char* to_string(CoarsenSurfaceJob::Surface s) {
  switch (s) {
    case CoarsenSurfaceJob::split: return "split";
    case CoarsenSurfaceJob::partly_split: return "partly_split";
    case CoarsenSurfaceJob::as_given: return "as_given";
    case CoarsenSurfaceJob::subdivided: return "subdivided";
  }
  return "?";
}

}  // namespace meshcvt
