// meshcvt CLI: `meshcvt approximate` — anisotropic shape approximation with the L2,1 metric (Fan et
// al. 6.2): an L2,1 partition with -n proxies or an error bound, meshed into a compact triangle
// mesh (and optionally its polygon mesh, one face per region).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/approximate.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/mesh_order.h"
#include "meshcvt/topology.h"

namespace meshcvt::cli {

namespace {

struct ApproximateArgs {
  std::string input, output, polygons, partition, labels, report, device, chord_rule = "paper";
  uint32_t proxies = 0, max_iter = 1000;
  double max_error = -1, chord_error = kDefaultChordError;
  unsigned threads = 0;
  bool quiet = false, no_weld = false, no_teleport = false;
  bool has_proxies = false, has_max_error = false;
};

std::string lower_extension(const std::string& path) {
  size_t slash = path.find_last_of('/'), dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  for (char& c : ext)
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
  return ext;
}

// Refuses unknown output formats before any work, so a typo costs nothing and writes nothing.
void check_output_names(const ApproximateArgs& a) {
  auto mesh_format = [](const std::string& path, const char* what) {
    std::string ext = lower_extension(path);
    if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl")
      throw OptionError(std::string(what) + " '" + path + "': unknown mesh format '" + ext +
                        "' (expected .obj, .off, .ply or .stl)");
  };
  mesh_format(a.output, "output");
  if (!a.partition.empty()) mesh_format(a.partition, "--partition");
  if (!a.polygons.empty()) {
    std::string ext = lower_extension(a.polygons);
    if (ext != ".obj" && ext != ".off")
      throw OptionError("--polygons '" + a.polygons + "': unknown polygon mesh format '" + ext +
                        "' (expected .obj or .off)");
  }
}

void write_report(const ApproximateArgs& a, const Mesh& mesh, const ReadStats& rs, const ShapeApproximation& s,
                  double read_s, double write_s) {
  Json j;
  j.begin_object();
  j.value("input", a.input).value("format", rs.format).value("faces", uint64_t(mesh.face_count()))
      .value("vertices", uint64_t(mesh.vertex_count()));
  j.begin_object("options");
  if (a.has_proxies) j.value("proxies", a.proxies);
  if (a.has_max_error) j.value("max_error", a.max_error);
  j.value("chord_error", a.chord_error).value("chord_rule", a.chord_rule).value("teleport", !a.no_teleport)
      .value("max_iterations", a.max_iter).value("threads", a.threads).end_object();
  const Clustering& c = s.clustering;
  j.begin_object("partition").value("device", c.device).value("device_notice", c.device_notice).value("proxies", s.partition_proxies)
      .value("iterations", c.iterations).value("converged", c.converged);
  j.begin_array("rounds");
  for (const RefinementRound& r : s.rounds)
    j.begin_object().value("proxies", r.proxies).value("relative_error", r.relative_error).end_object();
  j.end_array();
  j.begin_array("history");
  for (const IterationRecord& r : c.history)
    j.begin_object().value("energy", r.energy).value("moves", r.moves).value("round", r.round).end_object();
  j.end_array();
  j.end_object();
  j.value("reoriented_faces", s.reoriented_faces).value("collapsed_faces", s.collapsed_faces);
  j.value("regions", s.regions).value("distortion", s.distortion).value("total_area", s.total_area)
      .value("relative_error", s.relative_error);
  j.begin_object("output").value("vertices", uint64_t(s.mesh.vertex_count()))
      .value("triangles", uint64_t(s.mesh.face_count()))
      .value("polygons", uint64_t(s.regions))
      .value("boundary_edges", s.stats.boundary_edges).value("nonmanifold_edges", s.stats.nonmanifold_edges)
      .value("inconsistent_edges", s.stats.inconsistent_edges).value("flipped_triangles", s.stats.flipped_triangles)
      .end_object();
  j.begin_object("anchors").value("corner", s.stats.corner_anchors).value("chord", s.stats.chord_anchors)
      .value("fix", s.stats.fix_anchors).value("chords", s.stats.chords).end_object();
  j.begin_object("triangulation").value("coloring_regions", s.stats.coloring_regions)
      .value("fallback_regions", s.stats.fallback_regions).value("meshing_rounds", s.stats.meshing_rounds)
      .value("reused_triangulations", s.stats.reused_triangulations)
      .value("deferred_triangulations", s.stats.deferred_triangulations)
      .value("tested_polygons", s.stats.tested_polygons)
      .value("copied_colorings", s.stats.copied_colorings).value("meshing_passes", s.stats.meshing_passes)
      .value("shortened_passes", s.stats.shortened_passes).end_object();
  j.begin_array("fixes");
  for (const MeshingFix& f : s.fixes) {
    j.begin_object().value("kind", to_string(f.kind));
    if (f.region != kNone) j.value("region", f.region);
    if (f.other != kNone) j.value("other", f.other);
    if (f.vertex != kNone) j.value("vertex", f.vertex);
    if (f.count) j.value("count", f.count);
    j.end_object();
  }
  j.end_array();
  j.begin_object("timings_s").value("read", read_s).value("partition", s.partition_seconds)
      .value("cluster", c.timings.total).value("refine", s.refine_seconds).value("meshing", s.meshing_seconds)
      .value("write", write_s).end_object();
  j.end_object();
  write_text_file(a.report, j.str());
}

void run_approximate(ApproximateArgs& a) {
  using Clock = std::chrono::steady_clock;
  if (a.has_proxies == a.has_max_error)
    throw OptionError(a.has_proxies ? "give -n or --max-error, not both" : "give -n N or --max-error E");
  if (a.has_proxies && a.proxies == 0) throw OptionError("-n must be at least 1");
  if (a.has_max_error && !(a.max_error >= 0 && std::isfinite(a.max_error)))
    throw OptionError("--max-error must be a finite number >= 0");
  check_output_names(a);

  ApproximateOptions options;
  options.proxies = a.has_proxies ? a.proxies : 0;
  options.max_error = a.has_max_error ? a.max_error : -1;
  options.meshing.chord_error = a.chord_error;
  options.meshing.chord_rule = parse_chord_rule(a.chord_rule);
  options.teleport = !a.no_teleport;
  options.device = a.device;
  options.threads = a.threads;
  options.max_iterations = a.max_iter;
  bool progress = !a.quiet && stderr_is_terminal();
  if (progress)
    options.progress = print_progress;

  // Large meshes are partitioned in an order with locality (mesh_order.h); --partition is
  // written in the input's.
  InputMesh input = read_input(a.input, !a.no_weld, a.quiet, a.threads);
  const Mesh& mesh = input.mesh;
  const LocalityOrder& order = input.order;
  Topology topology = build_topology(mesh, a.threads);
  ShapeApproximation s = naming_input(a.input, [&] { return approximate_shape(mesh, topology, options); });
  if (progress) std::fprintf(stderr, "\r%60s\r", "");
  if (!s.clustering.device_notice.empty() && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s\n", s.clustering.device_notice.c_str());
  if (s.reoriented_faces > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: flipped %llu of %zu faces so that each part is consistently oriented\n",
                 a.input.c_str(), (unsigned long long)s.reoriented_faces, mesh.face_count());
  if (s.collapsed_faces > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: left out %llu face%s with a repeated corner (no area); each takes the region "
                 "of a face at one of its corners\n",
                 a.input.c_str(), (unsigned long long)s.collapsed_faces, s.collapsed_faces == 1 ? "" : "s");

  auto t0 = Clock::now();
  WriteOptions wo;
  wo.face_labels = &s.triangle_regions;
  wo.origin = input.stats.origin;
  write_mesh(a.output, s.mesh, wo);
  if (!a.polygons.empty())
    write_polygon_mesh(a.polygons, s.mesh.positions, s.polygon_offsets, s.polygon_vertices, input.stats.origin);
  if (!a.partition.empty() || !a.labels.empty()) {
    const std::vector<uint32_t> labels = to_input_order(s.labels, order);
    if (!a.labels.empty()) write_text_file(a.labels, labels_text(labels));
    if (!a.partition.empty()) {
      Mesh original = mesh;
      restore_input_order(original, order);
      WriteOptions po;
      po.face_labels = &labels;
      po.origin = input.stats.origin;
      write_mesh(a.partition, original, po);
    }
  }
  double write_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!a.report.empty()) write_report(a, mesh, input.stats, s, input.seconds, write_s);
  if (!a.quiet) {
    // Regions beyond the proxies come from splits: say which, or a user asking for 10 proxies and
    // getting 300 regions is left to guess.
    uint64_t curved = 0, not_disks = 0, solid = 0;
    for (const MeshingFix& f : s.fixes) {
      if (f.kind == MeshingFix::split_curved) ++curved;
      if (f.kind == MeshingFix::split_region) not_disks += f.count;
      if (f.kind == MeshingFix::solid_component) ++solid;
    }
    std::string splits;
    auto add = [&](uint64_t count, const char* why) {
      if (count == 0) return;
      splits += (splits.empty() ? "; split off: " : ", ") + std::to_string(count) + why;
    };
    add(curved, " as too curved for one polygon");
    add(not_disks, " as not disks");
    add(solid, " to keep closed parts solid");
    std::printf("%s: %zu faces -> %u regions (%u proxies%s), %zu vertices, %zu triangles; L2,1 E/A %.6g; "
                "%zu fixes; %.3f s partition + %.3f s meshing; wrote %s\n",
                a.input.c_str(), mesh.face_count(), s.regions, s.partition_proxies, splits.c_str(),
                s.mesh.vertex_count(), s.mesh.face_count(), s.relative_error, s.fixes.size(), s.partition_seconds,
                s.meshing_seconds, a.output.c_str());
    if (s.stats.flipped_triangles || s.stats.nonmanifold_edges)
      std::printf("warning: %llu triangles face away from their region, %llu non-manifold edges\n",
                  (unsigned long long)s.stats.flipped_triangles, (unsigned long long)s.stats.nonmanifold_edges);
  }
}

const RegisterCommand reg(40, [](CLI::App& app) {
  static ApproximateArgs args;  // options live as long as the process
  ApproximateArgs* a = &args;
  CLI::App* sub = app.add_subcommand(
      "approximate", "Approximate the shape with a compact mesh from an L2,1 partition (Fan et al. 6.2, VSA)");
  sub->add_option("input", a->input, "input mesh (.obj .off .ply .stl)")->required();
  CLI::Option* n = sub->add_option("-n,--proxies", a->proxies,
                                   "number of proxies: the partition's regions (the meshing splits regions that are "
                                   "not disks or too curved for one polygon)");
  CLI::Option* e = sub->add_option(
      "--max-error", a->max_error,
      "instead of -n: add proxies until the L2,1 distortion per area E/A is at most this (scale-free, 0..4)");
  n->excludes(e);
  sub->add_option("-o,--output", a->output, "output triangle mesh, per-face region ids and colors in .ply")
      ->required();
  sub->add_option("--polygons", a->polygons, "also write the polygon mesh, one face per region (.obj or .off)");
  sub->add_option("--partition", a->partition, "also write the input mesh with per-face region ids (.ply)");
  sub->add_option("--labels", a->labels,
                  "also write the region id of every input face, one per line, in the input's face order (polygons "
                  "expanded into triangles in order)");
  char chord_default[32];
  std::snprintf(chord_default, sizeof chord_default, "%g", kDefaultChordError);
  sub->add_option("--chord-error", a->chord_error,
                  std::string("split a border between anchors a, b at its farthest vertex while d*sin(Ni,Nj)/|ab| "
                              "exceeds this (default ") + chord_default + ")");
  sub->add_option("--chord-rule", a->chord_rule,
                  "paper (default) | cgal: d / mean edge length > chord error, as CGAL's VSA (its default is 5)");
  sub->add_option("--max-iter", a->max_iter, "maximum iterations per round of boundary testing (default 1000)");
  sub->add_option("--threads", a->threads, "worker threads, 0 = all cores (the result does not depend on it)");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_flag("--no-teleport", a->no_teleport,
                "skip VSA proxy teleportation after clustering (merge the cheapest pair, split the worst region)");
  sub->add_option("--report", a->report, "write a JSON report (partition, distortion, fixes, timings)");
  sub->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  add_device_option(sub, a->device);
  sub->callback([a, n, e] {
    a->has_proxies = n->count() > 0;
    a->has_max_error = e->count() > 0;
    run_approximate(*a);
  });
});

}  // namespace

}  // namespace meshcvt::cli
