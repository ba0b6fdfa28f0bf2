// meshcvt CLI: `meshcvt cluster` — clusters a mesh's faces and writes them colored by cluster.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/cluster.h"
#include "meshcvt/density.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/mesh_order.h"
#include "meshcvt/topology.h"

namespace meshcvt::cli {

namespace {

struct ClusterArgs {
  std::string input, output, labels, report, metric = "cvt", init = "hierarchical", topology = "preserving", device;
  uint32_t clusters = 0, max_iter = 1000, lloyd_steps = 64;
  unsigned threads = 0;
  uint64_t seed = 1;
  double gradation = 0;  ///< --gradation g: curvature-adaptive density (meshcvt/density.h); 0 = uniform
  bool quiet = false, no_weld = false, no_accelerate = false;
};

void write_report(const ClusterArgs& a, const Mesh& mesh, const Clustering& c, const ReadStats& rs, double read_s,
                  double topology_s, double write_s) {
  Json j;
  j.begin_object();
  j.value("input", a.input).value("format", rs.format).value("faces", uint64_t(mesh.face_count()))
      .value("vertices", uint64_t(mesh.vertex_count()));
  j.begin_object("options").value("clusters", a.clusters).value("metric", a.metric).value("init", a.init)
      .value("topology", a.topology).value("max_iterations", a.max_iter).value("accelerate", !a.no_accelerate).value("lloyd_steps", a.lloyd_steps)
      .value("threads", a.threads).value("seed", a.seed).value("gradation", a.gradation).end_object();
  j.value("device", c.device).value("device_notice", c.device_notice).value("iterations", c.iterations).value("converged", c.converged);
  j.value("energy_initial", c.history.front().energy).value("energy_final", c.history.back().energy);
  j.begin_object("repair").value("rounds", c.repair.rounds).value("split_pieces", c.repair.split_pieces)
      .value("reassigned_faces", c.repair.reassigned_faces).value("dissolved_isolated", c.repair.dissolved_isolated)
      .value("restored_clusters", c.repair.restored_clusters).end_object();
  j.begin_object("timings_s").value("read", read_s).value("setup", c.timings.setup).value("init", c.timings.init)
      .value("init_lloyd", c.timings.init_lloyd).value("topology", topology_s).value("iterate", c.timings.iterate)
      .value("repair", c.timings.repair).value("cluster_total", c.timings.total)
      .value("write", write_s).end_object();
  j.begin_array("history");
  for (const IterationRecord& r : c.history)
    j.begin_object().value("energy", r.energy).value("moves", r.moves).value("evaluated_faces", r.evaluated_faces)
        .value("round", r.round).end_object();
  j.end_array();
  j.end_object();
  write_text_file(a.report, j.str());
}

void run_cluster(const ClusterArgs& a) {
  using Clock = std::chrono::steady_clock;
  ClusterOptions options;
  options.clusters = a.clusters;
  options.metric = parse_metric(a.metric);
  options.init = parse_init(a.init);
  options.topology = parse_topology_mode(a.topology);
  options.max_iterations = a.max_iter;
  options.accelerate = !a.no_accelerate;
  options.lloyd_steps = a.lloyd_steps;
  options.threads = a.threads;
  options.seed = a.seed;
  options.device = a.device;
  if (!(a.gradation >= 0) || !std::isfinite(a.gradation))
    throw OptionError("--gradation must be a finite number >= 0, not " + std::to_string(a.gradation));
  if (a.gradation > 0 && options.metric == Metric::l21)
    throw OptionError("--gradation sizes clusters by curvature for cvt and ccvt; l21 already adapts to the normals");
  bool progress = !a.quiet && stderr_is_terminal();
  if (progress)
    options.progress = print_progress;

  check_mesh_format(a.output);  // before the work
  // Large meshes are clustered in an order with locality (mesh_order.h); outputs use the input's.
  InputMesh input = read_input(a.input, !a.no_weld, a.quiet, a.threads);
  Mesh& mesh = input.mesh;
  const LocalityOrder& order = input.order;
  Clustering c;
  uint64_t collapsed = 0;  // left out by cluster(), see cluster.h
  double topology_s = 0;   // build_topology: not file I/O, yet outside cluster()'s own timings
  {
    const auto t_topology = Clock::now();
    Topology topology = build_topology(mesh, a.threads);
    topology_s = std::chrono::duration<double>(Clock::now() - t_topology).count();
    if (a.gradation > 0) {
      // As `coarsen --gradation`: the curvature of a copy whose parts are consistently oriented
      // (prepare_surface flips faces and splits pinched vertices, but keeps the faces' order, so the
      // density is per face of `mesh` too).
      Mesh prepared = mesh;
      Topology prepared_topology = topology;
      prepare_surface(prepared, prepared_topology);
      options.density = curvature_density(prepared, prepared_topology, a.gradation);
    }
    c = naming_input(a.input, [&] { return cluster(mesh, topology, options); });
    if (topology.collapsed_faces < mesh.face_count()) collapsed = topology.collapsed_faces;
  }
  if (collapsed > 0 && !a.quiet)
    std::fprintf(stderr, "meshcvt: note: %s: left out %llu face%s with a repeated corner (no area); each takes the cluster "
                 "of a face at one of its corners\n",
                 a.input.c_str(), (unsigned long long)collapsed, collapsed == 1 ? "" : "s");
  restore_input_order(mesh, order);
  c.labels = to_input_order(c.labels, order);
  if (progress) std::fprintf(stderr, "\r%60s\r", "");
  if (!c.device_notice.empty() && !a.quiet) std::fprintf(stderr, "meshcvt: note: %s\n", c.device_notice.c_str());

  auto t0 = Clock::now();
  WriteOptions wo;
  wo.face_labels = &c.labels;
  wo.origin = input.stats.origin;
  write_mesh(a.output, mesh, wo);
  if (!a.labels.empty()) write_text_file(a.labels, labels_text(c.labels));
  double write_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!a.report.empty()) write_report(a, mesh, c, input.stats, input.seconds, topology_s, write_s);
  if (!a.quiet)
    std::printf("%s: %zu faces -> %u clusters (%s, %s init) on %s: %u iterations, %s, energy %.6g -> %.6g, "
                "%.3f s clustering; wrote %s\n",
                a.input.c_str(), mesh.face_count(), a.clusters, a.metric.c_str(), a.init.c_str(), c.device.c_str(),
                c.iterations, c.converged ? "converged" : "not converged", c.history.front().energy,
                c.history.back().energy, c.timings.total, a.output.c_str());
}

const RegisterCommand reg(20, [](CLI::App& app) {
  static ClusterArgs args;  // options live as long as the process
  ClusterArgs* a = &args;
  CLI::App* sub = app.add_subcommand("cluster", "Partition the faces into N clusters (CVT, CCVT or L2,1)");
  sub->add_option("input", a->input, "input mesh (.obj .off .ply .stl)")->required();
  sub->add_option("-n,--clusters", a->clusters, "number of clusters")->required();
  sub->add_option("-o,--output", a->output, "output mesh with per-face cluster ids and colors (.ply recommended)")
      ->required();
  sub->add_option("--metric", a->metric, "cvt | ccvt | l21 (default cvt)");
  sub->add_option("--init", a->init, "hierarchical | random (default hierarchical)");
  sub->add_option("--topology", a->topology,
                  "preserving (default: clusters stay disks while iterating) | paper (the paper's rule, repaired after)");
  sub->add_option("--max-iter", a->max_iter, "maximum iterations per round (default 1000)");
  sub->add_option("--threads", a->threads, "worker threads, 0 = all cores (the result does not depend on it)");
  sub->add_option("--seed", a->seed, "seed for --init random");
  sub->add_option("--gradation", a->gradation,
                  "cvt, ccvt: curvature-adaptive density, 0 uniform (default), larger = more, smaller clusters where "
                  "the surface bends (as coarsen --gradation)");
  sub->add_option("--lloyd-steps", a->lloyd_steps, "at most this many Lloyd steps after initialization (default 64, 0 = none)");
  sub->add_flag("--no-accelerate", a->no_accelerate, "test every border face every iteration (same result, slower)");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_option("--labels", a->labels, "also write one cluster id per line, in the input's face order");
  sub->add_option("--report", a->report, "write a JSON report (options, iterations, energies, timings)");
  sub->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  add_device_option(sub, a->device);
  sub->callback([a] { run_cluster(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
