// meshcvt CLI: `meshcvt coarsen` — clusters a mesh (CVT or CCVT) and builds the coarse mesh from
// the clusters (Fan et al. Section 6.1), then measures it (Table 1 columns, distance to the input).
// Between reading and writing, the work is the library's coarsen_surface (subdivision, long edges
// split, the job); this file parses, prints notes, measures and reports.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/cluster.h"
#include "meshcvt/coarsen.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/quality.h"
#include "meshcvt/topology.h"

namespace meshcvt::cli {

namespace {

struct CoarsenArgs {
  std::string input, output, labels, partition, report, metric = "cvt", placement = "projected", device;
  uint32_t clusters = 0, fix_rounds = CoarsenMeshOptions{}.max_fix_rounds;
  uint32_t relax_passes = CoarsenOptions{}.relax_passes;
  uint32_t fit_passes = CoarsenOptions{}.fit_passes;
  double fit_swap_angle = CoarsenOptions{}.fit_swap_min_angle_deg;
  double fit_min_angle = CoarsenOptions{}.fit_min_angle_deg;
  unsigned threads = 0;
  bool quiet = false, no_weld = false, no_error = false, no_flips = false, no_fit_swaps = false, no_boundary_snap = false;
  double gradation = 0;   ///< --gradation g: curvature-adaptive density (meshcvt/density.h); 0 = uniform
  std::string subdivide;  ///< --subdivide auto|K: "" = the placement's default (subdivides_by_default)
  std::string split_edges = "auto";  ///< --split-edges auto|R (parse_split_edges)
};

// --split-edges: "auto" -> kSplitEdgesAuto, "off" -> 0, a number R in [0, 16] -> R (0 = off); else
// OptionError.
double parse_split_edges(const std::string& s) {
  if (s == "auto") return kSplitEdgesAuto;
  if (s == "off") return 0;
  char* end = nullptr;
  const double r = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !(r >= 0 && r <= 16))
    throw OptionError("--split-edges must be auto, off or a ratio within [0, 16], not '" + s + "'");
  return r;
}

// --subdivide: "" -> kSubdivideByPlacement, "auto" -> kSubdivideAuto, "0".."6" -> that many; else
// OptionError.
int parse_subdivide(const std::string& s) {
  if (s.empty()) return kSubdivideByPlacement;
  if (s == "auto") return kSubdivideAuto;
  if (s.size() == 1 && s[0] >= '0' && s[0] <= '6') return s[0] - '0';
  throw OptionError("--subdivide must be auto or a number of levels 0..6, not '" + s + "'");
}

// "cluster_not_disk 2, double_border 1": how many of each kind.
std::string count_kinds(const std::vector<DualDefect>& defects) {
  std::string s;
  for (int k = 0; k <= int(DualDefect::empty_cluster); ++k) {
    size_t count = 0;
    for (const DualDefect& d : defects) count += d.kind == k;
    if (count) s += (s.empty() ? "" : ", ") + std::string(to_string(DualDefect::Kind(k))) + " " + std::to_string(count);
  }
  return s;
}

// "fixes: 9 in 3 rounds (cut: cluster_not_disk 1, double_border 6; move_faces: double_border 2), 19 defects -> 0"
std::string describe_fixes(const CoarsenMeshResult& job) {
  std::string s = "fixes: " + std::to_string(job.fixes.size());
  if (!job.fixes.empty()) {
    s += " in " + std::to_string(job.fix_rounds) + " round" + (job.fix_rounds == 1 ? "" : "s") + " (";
    bool first = true;
    for (CoarsenFix::Action action : {CoarsenFix::cut, CoarsenFix::move_faces}) {
      std::vector<DualDefect> kinds;
      for (const CoarsenFix& f : job.fixes)
        if (f.action == action) kinds.push_back(f.defect);
      if (kinds.empty()) continue;
      s += std::string(first ? "" : "; ") + to_string(action) + ": " + count_kinds(kinds);
      first = false;
    }
    s += ")";
  }
  s += ", " + std::to_string(job.initial_defects) + " defects -> " + std::to_string(job.coarse.defects.size());
  if (job.refined_clusters)
    s += "; clustered at " + std::to_string(job.refined_clusters) + " and merged back (" +
         std::to_string(job.merged_back) + " merges)";
  if (job.reallocations)
    s += "; redone " + std::to_string(job.reallocations) + (job.reallocations == 1 ? " time" : " times") +
         " with more clusters for the broken components";
  if (job.face_start_components) {
    s += "; " + std::to_string(job.face_start_components) + " components rebuilt from single faces";
    if (job.face_start_from_finer == job.face_start_components)
      s += " around the defects of a finer clustering";
    else if (job.face_start_from_finer)
      s += " (" + std::to_string(job.face_start_from_finer) + " around the defects of a finer clustering)";
  }
  return s;
}

void run_coarsen(const CoarsenArgs& a) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  // Checked before reading, so a bad value costs no I/O.
  CoarsenSurfaceOptions so;
  ClusterOptions& options = so.job.cluster;
  options.clusters = a.clusters;
  options.metric = parse_metric(a.metric);
  if (options.metric == Metric::l21)
    throw OptionError("coarsen builds an isotropic mesh: use --metric cvt or ccvt (l21 is for `meshcvt approximate`)");
  options.threads = a.threads;
  options.device = a.device;
  CoarsenOptions& co = so.job.coarsen;
  co.placement = parse_vertex_placement(a.placement);
  so.subdivide = parse_subdivide(a.subdivide);
  so.split_edges = parse_split_edges(a.split_edges);
  if (!(a.gradation >= 0) || !std::isfinite(a.gradation))
    throw OptionError("--gradation must be a finite number >= 0, not " + std::to_string(a.gradation));
  so.gradation = a.gradation;
  co.threads = a.threads;
  co.flip_edges = !a.no_flips;
  co.boundary_onto_input = !a.no_boundary_snap;
  co.relax_passes = a.relax_passes;
  co.fit_passes = a.fit_passes;
  co.fit_swaps = !a.no_fit_swaps;
  if (!(a.fit_swap_angle >= 0 && a.fit_swap_angle <= 60))
    throw OptionError("--fit-swap-angle must be within [0, 60] degrees, not " + std::to_string(a.fit_swap_angle));
  co.fit_swap_min_angle_deg = a.fit_swap_angle;
  if (!(a.fit_min_angle >= 0 && a.fit_min_angle <= 60))
    throw OptionError("--fit-min-angle must be within [0, 60] degrees, not " + std::to_string(a.fit_min_angle));
  co.fit_min_angle_deg = a.fit_min_angle;
  so.job.max_fix_rounds = a.fix_rounds;
  // The count of long edges is for the note and the report; auto and R count them anyway.
  so.count_long_edges = !a.quiet || !a.report.empty();
  check_mesh_format(a.output);
  if (!a.partition.empty()) check_mesh_format(a.partition);

  prepare_allocator(a.input);
  auto t0 = Clock::now();
  ReadOptions ro;
  ro.weld = !a.no_weld;
  ReadStats read_stats;
  Mesh input = read_mesh_noted(a.input, ro, a.quiet, &read_stats);
  double read_s = seconds(t0);
  // Faces with a repeated corner are counted here (coarsen_surface leaves them out), so that the
  // messages about them name the file.
  uint64_t collapsed = 0;
  for (size_t f = 0; f < input.face_count(); ++f) {
    const uint32_t* t = &input.indices[3 * f];
    collapsed += t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
  }
  if (collapsed == input.face_count())
    throw FileError(a.input, "every face has a repeated corner index (no area): nothing to coarsen");
  if (collapsed > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: left out %llu face%s with a repeated corner (no area)\n", a.input.c_str(),
                 (unsigned long long)collapsed, collapsed == 1 ? "" : "s");

  // qem finer than the input: its clusters are smaller than the input's faces, and the point that
  // fits a cluster's planes best lies on the input's edges, most of its clusters' on the same few
  // lines (the elephant of tests/data, 2775 vertices: -> 1400 Q avg 0.839 and 39 angles below 30;
  // -> 2775 0.825 and 183; -> 5000 0.670, 3161 and degenerate triangles). Said, not changed: the
  // user asked for qem.
  if (co.placement == VertexPlacement::qem && a.clusters >= input.vertex_count() && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: --vertex qem with n = %u, not below the input's %zu vertices: clusters smaller "
                 "than its faces put their points on its edges, which makes thin triangles; projected (the "
                 "default) suits a mesh finer than the input\n",
                 a.input.c_str(), a.clusters, input.vertex_count());

  // --labels and --partition need the input as read afterwards (input_face_clusters); otherwise
  // it is moved in.
  const bool per_input_face = !a.labels.empty() || !a.partition.empty();
  so.keep_surface_origin = per_input_face;
  CoarsenSurfaceResult result =
      naming_input(a.input, [&] { return coarsen_surface(per_input_face ? Mesh(input) : std::move(input), so); });
  const Mesh& mesh = result.surface;
  const Topology& topology = result.topology;
  const CoarsenMeshResult& job = result.job;
  if (so.split_edges == 0 && result.long_edges >= a.clusters && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: %llu edges are longer than the coarse mesh's edges (%.4g): faces that long "
                 "make thin clusters and thin triangles; --split-edges auto (the default) splits them first\n",
                 a.input.c_str(), (unsigned long long)result.long_edges, result.coarse_edge_length);
  if (result.split_refused_faces > 0 && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: %llu edges are longer than the coarse mesh's edges (%.4g), but splitting them "
                 "would make at least %.3g faces (slivers: long edges, little area): left as they are\n",
                 a.input.c_str(), (unsigned long long)result.long_edges, result.coarse_edge_length,
                 result.split_refused_faces);
  if (result.split_discarded && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: with its long edges split the coarse mesh kept %zu defects, as given %zu: "
                 "coarsened as given\n",
                 a.input.c_str(), result.jobs.front().defects, job.coarse.defects.size());
  if (result.unsplit_components > 0 && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: with its long edges split the coarse mesh kept %zu defects, with the %u "
                 "component%s that had them left as given %zu: coarsened so\n",
                 a.input.c_str(), result.jobs.front().defects, result.unsplit_components,
                 result.unsplit_components == 1 ? "" : "s", job.coarse.defects.size());
  if (result.retried_subdivided && !a.quiet) {
    size_t before = result.jobs.front().defects;  // the best of the jobs before the retry
    for (size_t i = 0; i + 1 < result.jobs.size(); ++i) before = std::min(before, result.jobs[i].defects);
    std::fprintf(stderr,
                 "meshcvt: note: %s: the coarse mesh kept %zu defects; with the surface subdivided once %zu: coarsened "
                 "so (--subdivide 0 turns this off)\n",
                 a.input.c_str(), before, job.coarse.defects.size());
  }
  if (result.refined_components > 0 && !a.quiet) {
    const std::string with_them =
        result.refined_with_them == 0
            ? std::string()
            : ", and split the faces of " + std::to_string(result.refined_with_them) + " other component" +
                  (result.refined_with_them == 1 ? "" : "s") + " at the non-manifold edges shared with " +
                  (result.refined_components == 1 ? "it" : "them");
    std::fprintf(stderr,
                 "meshcvt: note: %s: subdivided %u component%s with fewer faces than the clusters %s to "
                 "come out as a valid surface%s (%llu face%s in all)\n",
                 a.input.c_str(), result.refined_components, result.refined_components == 1 ? "" : "s",
                 result.refined_components == 1 ? "it needs" : "they need", with_them.c_str(),
                 (unsigned long long)result.refined_faces, result.refined_faces == 1 ? "" : "s");
  }
  const SurfacePreparation& prepared = result.prepared;
  if (prepared.split_vertices > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: split %llu pinched vert%s (where parts of the surface touch at a point)\n",
                 a.input.c_str(), (unsigned long long)prepared.split_vertices,
                 prepared.split_vertices == 1 ? "ex" : "ices");
  if (prepared.flipped_faces > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: flipped %llu of %zu faces so that each part is consistently oriented\n",
                 a.input.c_str(), (unsigned long long)prepared.flipped_faces, result.prepared_faces);
  // The dual of a clustering is a manifold: an edge of three faces or more has no place in it (the
  // clustering sees no link across it), and the output's boundary loops and chi follow the surface
  // cut open there (assimp-testmodels' 3DSMaxExport.STL, 16 such edges: 0 boundary loops -> 6).
  if (topology.nonmanifold_edges > 0 && !a.quiet)
    std::fprintf(stderr,
                 "meshcvt: note: %s: %llu non-manifold edge%s (three faces or more): the coarse mesh cannot keep %s, so its "
                 "boundary loops and Euler characteristic may differ from the input's\n",
                 a.input.c_str(), (unsigned long long)topology.nonmanifold_edges,
                 topology.nonmanifold_edges == 1 ? "" : "s", topology.nonmanifold_edges == 1 ? "it" : "them");
  const Clustering& c = job.clustering;
  const CoarsenResult& r = job.coarse;
  if (!c.device_notice.empty() && !a.quiet) std::fprintf(stderr, "meshcvt: note: %s\n", c.device_notice.c_str());
  const double coarsen_s = job.coarsen_seconds;
  const std::string fix_line = describe_fixes(job);
  // Where the input is a manifold and the fixes ran, what remains is mostly too few clusters for
  // the surface's handles and holes (libcgal-demo's cheese, genus 133: 421 defects at n = 200,
  // none at 300).
  const bool more_room = a.fix_rounds > 0 && topology.nonmanifold_edges == 0;
  if (job.defects_remain && !a.quiet)
    std::fprintf(stderr, "meshcvt: warning: %zu defects remain (%s): the output is not a valid manifold%s\n",
                 r.defects.size(), count_kinds(r.defects).c_str(),
                 more_room ? "; a larger -n gives the fixes more room" : "");
  t0 = Clock::now();
  WriteOptions wo;
  wo.origin = read_stats.origin;
  write_mesh(a.output, r.mesh, wo);
  if (per_input_face) {
    const std::vector<uint32_t> clusters = input_face_clusters(input, result);
    if (!a.labels.empty()) write_text_file(a.labels, labels_text(clusters));
    if (!a.partition.empty()) {
      WriteOptions po;
      po.face_labels = &clusters;
      po.origin = read_stats.origin;
      write_mesh(a.partition, input, po);
    }
  }
  double write_s = seconds(t0);
  TriangleQuality q = triangle_quality(r.mesh);
  Topology out_topology = build_topology(r.mesh);
  MeshInfo in_info = mesh_info(mesh, topology), out_info = mesh_info(r.mesh, out_topology);
  ApproximationError err;
  double error_s = 0;  // the error measurement alone (0 with --no-error)
  if (!a.no_error) {
    t0 = Clock::now();
    err = approximation_error(r.mesh, mesh, 0, a.threads);
    error_s = seconds(t0);
  }

  if (!a.report.empty()) {
    Json j;
    j.begin_object();
    j.value("input", a.input).value("faces", uint64_t(mesh.face_count())).value("clusters", a.clusters)
        .value("metric", a.metric).value("placement", a.placement).value("device", c.device)
        .value("device_notice", c.device_notice)
        .value("iterations", c.iterations).value("converged", c.converged);
    j.value("input_faces", uint64_t(result.input_faces)).value("split_vertices", prepared.split_vertices + job.split_vertices)
        .value("reoriented_faces", prepared.flipped_faces + job.reoriented_faces)
        .value("collapsed_faces", result.collapsed_faces + job.collapsed_faces)
        .value("subdivision_levels", result.subdivision_levels)
        .value("coarse_edge_length", result.coarse_edge_length).value("long_edges", result.long_edges)
        .value("split_edges_option", a.split_edges).value("split_edges_ratio", result.split_ratio)
        .value("split_edges", result.split_edges).value("split_discarded", result.split_discarded)
        .value("split_refused_faces", result.split_refused_faces)
        .value("discarded_job_defects", result.discarded_job_defects)
        .value("unsplit_components", result.unsplit_components)
        .value("retried_subdivided", result.retried_subdivided)
        .value("refined_components", result.refined_components)
        .value("refined_with_them", result.refined_with_them).value("refined_faces", result.refined_faces)
        .value("gradation", a.gradation);
    j.begin_object("output").value("vertices", uint64_t(r.mesh.vertex_count())).value("faces", uint64_t(r.mesh.face_count()))
        .value("euler_characteristic", out_info.euler_characteristic).value("input_euler_characteristic", in_info.euler_characteristic)
        .value("boundary_loops", out_info.boundary_loops).value("input_boundary_loops", in_info.boundary_loops)
        .value("components", out_info.components).value("input_components", in_info.components)
        .value("nonmanifold_edges", out_info.nonmanifold_edges).value("nonmanifold_vertices", out_info.nonmanifold_vertices)
        .end_object();
    j.begin_object("quality").value("min_angle_deg", q.min_angle_deg).value("avg_min_angle_deg", q.avg_min_angle_deg)
        .value("angles_below_30", q.angles_below_30).value("q_min", q.q_min).value("q_avg", q.q_avg).end_object();
    if (!a.no_error)
      j.begin_object("error").value("hausdorff", err.hausdorff).value("hausdorff_rel", err.hausdorff_rel)
          .value("rms", err.rms).value("rms_rel", err.rms_rel).end_object();
    j.value("flipped_edges", r.flipped_edges).value("relax_passes", a.relax_passes)
        .value("relax_max_normal_turn_deg", co.relax_max_normal_turn_deg).value("relaxed_moves", r.relaxed_moves)
        .value("fit_passes", a.fit_passes).value("fitted_moves", r.fitted_moves)
        .value("fit_swaps", co.fit_swaps).value("fit_swap_min_angle_deg", co.fit_swap_min_angle_deg)
        .value("swapped_edges", r.swapped_edges).value("unfolded_vertices", r.unfolded_vertices)
        .value("fit_min_angle_deg", co.fit_min_angle_deg).value("angle_floor_moves", r.angle_floor_moves)
        .value("surface_points", r.surface_points).value("boundary_snap", !a.no_boundary_snap)
        .value("boundary_vertices_moved", r.boundary_vertices_moved).value("boundary_corners", r.boundary_corners)
        .value("boundary_backed_off", r.boundary_backed_off).value("boundary_left_inside", r.boundary_left_inside);
    j.begin_array("jobs");
    for (const CoarsenSurfaceJob& sj : result.jobs)
      j.begin_object().value("surface", to_string(sj.surface)).value("faces", uint64_t(sj.faces))
          .value("initial_defects", uint64_t(sj.initial_defects)).value("defects", uint64_t(sj.defects))
          .value("seconds", sj.seconds).value("kept", sj.kept).end_object();
    j.end_array();
    j.begin_array("defects");
    for (const DualDefect& d : r.defects)
      j.begin_object().value("kind", to_string(d.kind)).value("cluster", d.cluster).value("other", d.other).end_object();
    j.end_array();
    j.begin_object("fix_loop").value("initial_defects", uint64_t(job.initial_defects))
        .value("fixes", uint64_t(job.fixes.size())).value("rounds", job.fix_rounds)
        .value("remaining_defects", uint64_t(r.defects.size())).value("defects_remain", job.defects_remain)
        .value("refined_clusters", job.refined_clusters).value("merged_back", job.merged_back)
        .value("face_start_components", job.face_start_components)
        .value("face_start_from_finer", job.face_start_from_finer)
        .value("reallocations", job.reallocations)
        .value("abandoned_fixes", uint64_t(job.abandoned_fixes)).value("iterations", job.fix_iterations);
    j.end_object();
    j.begin_array("fixes");
    for (const CoarsenFix& f : job.fixes) {
      j.begin_object().value("round", f.round).value("action", to_string(f.action))
          .value("defect", to_string(f.defect.kind)).value("clusters", f.clusters);
      j.begin_array("defect_clusters");
      for (uint32_t id : {f.defect.cluster, f.defect.other, f.defect.third})
        if (id != kNone) j.item(id);
      j.end_array();
      j.value("cluster", f.cluster);
      if (f.action == CoarsenFix::cut)
        j.value("merged_into", f.merged_into).value("freed", f.freed);
      else
        j.value("to", f.other).value("faces", f.faces);
      j.end_object();
    }
    j.end_array();
    j.begin_array("component_clusters");
    for (uint32_t k : job.allocation.clusters) j.item(k);
    j.end_array();
    j.begin_object("timings_s").value("read", read_s).value("subdivide_density", result.prepare_seconds)
        .value("topology", result.topology_seconds)
        .value("cluster", job.cluster_seconds).value("fix", job.fix_seconds).value("coarsen", coarsen_s)
        .value("write", write_s).value("discarded_job", result.discarded_seconds).value("error", error_s).end_object();
    j.end_object();
    write_text_file(a.report, j.str());
  }
  if (!a.quiet) {
    if (result.subdivision_levels > 0 || a.gradation > 0)
      std::printf("%s: %zu faces, subdivided %u times -> %zu faces; gradation %g\n", a.input.c_str(), result.input_faces,
                  result.subdivision_levels, result.subdivided_faces, a.gradation);
    if (result.split_edges > 0)
      std::printf("%s: split %llu edges longer than %.4g (the coarse edge length %.4g%s / %g) -> %zu faces\n",
                  a.input.c_str(), (unsigned long long)result.split_edges, result.coarse_edge_length / result.split_ratio,
                  result.coarse_edge_length, a.gradation > 0 ? " where the density is lowest" : "", result.split_ratio,
                  mesh.face_count());
    std::printf("%s: %zu faces -> %zu vertices, %zu triangles (%s, %s placement); chi %lld -> %lld, %llu boundary loops"
                " -> %llu; %zu defects\n",
                a.input.c_str(), mesh.face_count(), r.mesh.vertex_count(), r.mesh.face_count(), a.metric.c_str(),
                a.placement.c_str(), (long long)in_info.euler_characteristic, (long long)out_info.euler_characteristic,
                (unsigned long long)in_info.boundary_loops, (unsigned long long)out_info.boundary_loops, r.defects.size());
    std::printf("quality: min angle %.2f deg, avg min angle %.2f deg, angles < 30: %llu, Q min %.3f, Q avg %.3f",
                q.min_angle_deg, q.avg_min_angle_deg, (unsigned long long)q.angles_below_30, q.q_min, q.q_avg);
    if (!a.no_error) std::printf("; Hausdorff %.3g%% of the diagonal, RMS %.3g%%", 100 * err.hausdorff_rel, 100 * err.rms_rel);
    std::printf("\n%s; %llu edges flipped, %llu vertex moves\n", fix_line.c_str(), (unsigned long long)r.flipped_edges,
                (unsigned long long)r.relaxed_moves);
    if (r.boundary_vertices_moved > 0)
      std::printf("boundary: %llu vertices onto the input's boundary, %llu of them onto its corners\n",
                  (unsigned long long)r.boundary_vertices_moved, (unsigned long long)r.boundary_corners);
    else if (r.boundary_left_inside > 0)
      std::printf("boundary: left inside the input's (onto it, its triangles would have had smaller angles)\n");
    std::printf("time: cluster %.3f s, fixes %.3f s, coarsen %.3f s; wrote %s\n", job.cluster_seconds,
                job.fix_seconds, coarsen_s, a.output.c_str());
  }
}

const RegisterCommand reg(30, [](CLI::App& app) {
  static CoarsenArgs args;  // options live as long as the process
  CoarsenArgs* a = &args;
  CLI::App* sub = app.add_subcommand("coarsen", "Cluster the faces and build a coarse mesh with one vertex per cluster");
  sub->add_option("input", a->input, "input mesh (.obj .off .ply .stl)")->required();
  sub->add_option("-n,--vertices", a->clusters, "vertices of the coarse mesh (= clusters)")->required();
  sub->add_option("-o,--output", a->output, "coarse mesh (.obj .off .ply .stl)")->required();
  sub->add_option("--metric", a->metric, "cvt | ccvt (default cvt)");
  sub->add_option("--vertex", a->placement, "projected (default: closest point of the cluster to its centroid) | closest (the paper: the cluster's mesh vertex nearest its centroid) | qem");
  sub->add_option("--gradation", a->gradation,
                  "curvature-adaptive density: 0 uniform (default), larger = more, smaller triangles where the "
                  "surface bends (edge length ~ (1 + curvature x diagonal)^(-g/4))");
  sub->add_option("--subdivide", a->subdivide,
                  "auto | K (0..6): subdivide the input first, K times or (auto) until it has >= 10 faces per vertex (qem: "
                  "20, as ACVD's 10 vertices; qem's default is auto, the others' 0). Without it, where the coarse mesh "
                  "keeps defects, the input subdivided once is tried too and kept if it has fewer");
  sub->add_option("--split-edges", a->split_edges,
                  "auto | off | R in [0, 16]: first split every input edge longer than 1/R of the coarse mesh's edge "
                  "length (sqrt(2 area / (sqrt 3 n)); with --gradation, where the density is), so that no face is "
                  "longer than a cluster is wide: CAD exports' long thin triangles (libcgal-demo's pinion_small -> 130: Q avg "
                  "0.51 -> 0.84). auto (the default): R = 1.5 when at least one edge per cluster is that long or the input "
                  "has fewer than 5 faces per cluster (but at least one), and "
                  "the components that keep defects split (or all of it) as given instead where that leaves fewer; off = 0");
  sub->add_option("--fix-rounds", a->fix_rounds,
                  "rounds of fixing the clustering where its dual is not a manifold (default 12; 0 = report only)");
  sub->add_option("--threads", a->threads, "worker threads, 0 = all cores");
  sub->add_option("--relax-passes", a->relax_passes,
                  "passes moving each coarse vertex over its own cluster toward the middle of its ring where that "
                  "improves its triangles (smallest angle never drops), then edge flips again (default " +
                      std::to_string(CoarsenOptions{}.relax_passes) + "; 0 = off)");
  sub->add_option("--fit-passes", a->fit_passes,
                  "with --vertex qem: passes moving each vertex so the input lies on both sides of the coarse mesh "
                  "and swapping edges where the other diagonal lies closer to it (lower RMS distance; default " +
                      std::to_string(CoarsenOptions{}.fit_passes) + "; 0 = off)");
  sub->add_flag("--no-fit-swaps", a->no_fit_swaps, "with --vertex qem: the fitting passes move vertices only");
  sub->add_option("--fit-swap-angle", a->fit_swap_angle,
                  "with --vertex qem: degrees in [0, 60]; a swap may not make its triangles' smallest angle smaller "
                  "than this unless it removes 90% of their distance (default 30; 10: lower distance, thinner triangles)");
  sub->add_option("--fit-min-angle", a->fit_min_angle,
                  "with --vertex qem: degrees in [0, 60]; last, the corners of triangles with a smaller angle move "
                  "part of the way back to the surface until it is reached, where that widens them (default 20; 0 = off)");
  sub->add_flag("--no-flips", a->no_flips, "keep the dual's triangles as built (no edge flips improving angles)");
  sub->add_flag("--no-boundary-snap", a->no_boundary_snap,
                "open surfaces: leave the vertices of the clusters along the input's boundary where the placement puts "
                "them, inside it (by default they go onto the boundary and its corners, where that costs no angle "
                "below 30 degrees)");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_flag("--no-error", a->no_error, "skip measuring the distance to the input");
  sub->add_option("--labels", a->labels,
                  "also write the coarse vertex (cluster) of every input face, one per line, in the input's face "
                  "order (polygons expanded into triangles in order); a face subdivided or split for the clustering "
                  "takes the cluster holding most of its area");
  sub->add_option("--partition", a->partition,
                  "also write the input mesh with each face's coarse vertex id (as --labels) and colors (.ply)");
  sub->add_option("--report", a->report, "write a JSON report (clustering, topology, quality, error, defects)");
  sub->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  add_device_option(sub, a->device);
  sub->callback([a] { run_coarsen(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
