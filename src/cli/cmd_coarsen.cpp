// meshcvt CLI: `meshcvt coarsen` — clusters a mesh (CVT or CCVT) and builds the coarse mesh from
// the clusters (Fan et al. Section 6.1), then measures it (Table 1 columns, distance to the input).
#include <chrono>
#include <cstdio>
#include <string>

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
  std::string input, output, report, metric = "cvt", placement = "closest", device;
  uint32_t clusters = 0;
  unsigned threads = 0;
  bool quiet = false, no_weld = false, no_error = false;
};

void run_coarsen(const CoarsenArgs& a) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  ClusterOptions options;
  options.clusters = a.clusters;
  options.metric = parse_metric(a.metric);
  if (options.metric == Metric::l21)
    throw OptionError("coarsen builds an isotropic mesh: use --metric cvt or ccvt (l21 is for `meshcvt approximate`)");
  options.threads = a.threads;
  options.device = a.device;
  CoarsenOptions co;
  co.placement = parse_vertex_placement(a.placement);
  co.threads = a.threads;

  auto t0 = Clock::now();
  ReadOptions ro;
  ro.weld = !a.no_weld;
  Mesh mesh = read_mesh(a.input, ro);
  double read_s = seconds(t0);
  Topology topology = build_topology(mesh);
  Clustering c = cluster(mesh, topology, options);
  if (!c.device_notice.empty() && !a.quiet) std::fprintf(stderr, "meshcvt: note: %s\n", c.device_notice.c_str());
  t0 = Clock::now();
  CoarsenResult r = coarsen_clustering(mesh, topology, c.labels, a.clusters, co);
  double coarsen_s = seconds(t0);
  t0 = Clock::now();
  write_mesh(a.output, r.mesh);
  double write_s = seconds(t0);
  TriangleQuality q = triangle_quality(r.mesh);
  Topology out_topology = build_topology(r.mesh);
  MeshInfo in_info = mesh_info(mesh, topology), out_info = mesh_info(r.mesh, out_topology);
  ApproximationError err;
  if (!a.no_error) err = approximation_error(r.mesh, mesh, 0, a.threads);

  if (!a.report.empty()) {
    Json j;
    j.begin_object();
    j.value("input", a.input).value("faces", uint64_t(mesh.face_count())).value("clusters", a.clusters)
        .value("metric", a.metric).value("placement", a.placement).value("device", c.device)
        .value("iterations", c.iterations).value("converged", c.converged);
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
    j.begin_array("defects");
    for (const DualDefect& d : r.defects)
      j.begin_object().value("kind", to_string(d.kind)).value("cluster", d.cluster).value("other", d.other).end_object();
    j.end_array();
    j.begin_object("timings_s").value("read", read_s).value("cluster", c.timings.total).value("coarsen", coarsen_s)
        .value("write", write_s).end_object();
    j.end_object();
    write_text_file(a.report, j.str());
  }
  if (!a.quiet) {
    std::printf("%s: %zu faces -> %zu vertices, %zu triangles (%s, %s placement); chi %lld -> %lld, %llu boundary loops"
                " -> %llu; %zu defects\n",
                a.input.c_str(), mesh.face_count(), r.mesh.vertex_count(), r.mesh.face_count(), a.metric.c_str(),
                a.placement.c_str(), (long long)in_info.euler_characteristic, (long long)out_info.euler_characteristic,
                (unsigned long long)in_info.boundary_loops, (unsigned long long)out_info.boundary_loops, r.defects.size());
    std::printf("quality: min angle %.2f deg, avg min angle %.2f deg, angles < 30: %llu, Q min %.3f, Q avg %.3f",
                q.min_angle_deg, q.avg_min_angle_deg, (unsigned long long)q.angles_below_30, q.q_min, q.q_avg);
    if (!a.no_error) std::printf("; Hausdorff %.3g%% of the diagonal, RMS %.3g%%", 100 * err.hausdorff_rel, 100 * err.rms_rel);
    std::printf("\ntime: cluster %.3f s, coarsen %.3f s; wrote %s\n", c.timings.total, coarsen_s, a.output.c_str());
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
  sub->add_option("--vertex", a->placement, "closest (default) | projected | qem: where each cluster's vertex goes");
  sub->add_option("--threads", a->threads, "worker threads, 0 = all cores");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_flag("--no-error", a->no_error, "skip measuring the distance to the input");
  sub->add_option("--report", a->report, "write a JSON report (clustering, topology, quality, error, defects)");
  sub->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  add_device_option(sub, a->device);
  sub->callback([a] { run_coarsen(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
