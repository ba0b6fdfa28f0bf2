// meshcvt CLI: `meshcvt stats` — triangle quality (the columns of Table 1 in Fan et al.), valence
// histogram and, with --ref, the surface distance (Hausdorff, RMS) to a reference mesh.
#include <chrono>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/quality.h"

namespace meshcvt::cli {

namespace {

struct StatsArgs {
  std::string input, ref;
  uint64_t samples = 0, seed = 1;
  unsigned threads = 0;
  bool json = false, no_weld = false;
};

// "valence: count" rows of a histogram, skipping empty valences.
void print_histogram(const TriangleQuality& q) {
  std::printf("valence  vertices  interior\n");
  for (size_t k = 0; k < q.valence_histogram.size(); ++k) {
    uint64_t all = q.valence_histogram[k];
    uint64_t interior = k < q.interior_valence_histogram.size() ? q.interior_valence_histogram[k] : 0;
    if (all == 0 && interior == 0) continue;
    std::printf("%7zu  %8llu  %8llu\n", k, (unsigned long long)all, (unsigned long long)interior);
  }
}

void json_histogram(Json& j, const char* key, const std::vector<uint64_t>& h) {
  j.begin_array(key);
  for (uint64_t c : h) j.item(c);
  j.end_array();
}

void run_stats(const StatsArgs& a) {
  using Clock = std::chrono::steady_clock;
  ReadOptions ro;
  ro.weld = !a.no_weld;
  ReadStats read_stats;
  Mesh mesh = read_mesh_noted(a.input, ro, false, &read_stats);
  // Read the reference before any measuring, so a bad --ref fails fast; in the mesh's frame (moved
  // by the same origin when the mesh is far from 0), so that distances compare the same places.
  Mesh ref;
  ReadOptions ref_options = ro;
  ref_options.origin = read_stats.origin;
  if (!a.ref.empty()) ref = read_mesh_noted(a.ref, ref_options, false);

  TriangleQuality q = triangle_quality(mesh);
  ApproximationError e;
  double error_s = 0;
  if (!a.ref.empty()) {
    auto t0 = Clock::now();
    e = approximation_error(mesh, ref, a.samples, a.threads, a.seed);
    error_s = std::chrono::duration<double>(Clock::now() - t0).count();
  }

  if (a.json) {
    Json j;
    j.begin_object();
    j.value("mesh", a.input).value("vertices", uint64_t(mesh.vertex_count())).value("faces", q.faces);
    j.value("referenced_vertices", q.referenced_vertices).value("total_area", q.total_area);
    j.begin_object("quality");
    j.value("min_angle_deg", q.min_angle_deg).value("avg_min_angle_deg", q.avg_min_angle_deg)
        .value("max_angle_deg", q.max_angle_deg).value("angles_below_30", q.angles_below_30)
        .value("q_min", q.q_min).value("q_avg", q.q_avg).value("degenerate_faces", q.degenerate_faces);
    j.end_object();
    json_histogram(j, "valence_histogram", q.valence_histogram);
    json_histogram(j, "interior_valence_histogram", q.interior_valence_histogram);
    if (!a.ref.empty()) {
      j.begin_object("error");
      j.value("ref", a.ref).value("ref_faces", uint64_t(ref.face_count())).value("ref_bbox_diagonal", e.diagonal);
      j.value("samples_per_mesh", e.samples).value("points", e.points).value("seed", a.seed);
      j.value("hausdorff", e.hausdorff).value("hausdorff_rel", e.hausdorff_rel);
      j.value("rms", e.rms).value("rms_rel", e.rms_rel);
      j.value("mesh_to_ref_max", e.a_to_b_max).value("ref_to_mesh_max", e.b_to_a_max);
      j.value("mesh_to_ref_rms", e.a_to_b_rms).value("ref_to_mesh_rms", e.b_to_a_rms);
      j.value("mesh_to_ref_mean", e.a_to_b_mean).value("ref_to_mesh_mean", e.b_to_a_mean);
      j.value("time_s", error_s);
      j.end_object();
    }
    j.end_object();
    std::fputs(j.str().c_str(), stdout);
    return;
  }

  const double corners = 3.0 * double(q.faces);
  std::printf("mesh                %s\n", a.input.c_str());
  std::printf("vertices            %zu\n", mesh.vertex_count());
  std::printf("faces               %llu\n", (unsigned long long)q.faces);
  std::printf("total area          %.9g\n", q.total_area);
  std::printf("min angle           %.4f deg\n", q.min_angle_deg);
  std::printf("avg min angle       %.4f deg\n", q.avg_min_angle_deg);
  std::printf("max angle           %.4f deg\n", q.max_angle_deg);
  std::printf("angles < 30 deg     %llu (%.2f%% of corners)\n", (unsigned long long)q.angles_below_30,
              corners > 0 ? 100.0 * double(q.angles_below_30) / corners : 0.0);
  std::printf("Q min               %.6f\n", q.q_min);
  std::printf("Q avg               %.6f\n", q.q_avg);
  std::printf("degenerate faces    %llu\n", (unsigned long long)q.degenerate_faces);
  print_histogram(q);
  if (!a.ref.empty()) {
    std::printf("error against %s (%zu faces; %llu samples per surface + all vertices, %.2f s)\n", a.ref.c_str(),
                ref.face_count(), (unsigned long long)e.samples, error_s);
    std::printf("                    absolute        / ref bbox diagonal (%.6g)\n", e.diagonal);
    std::printf("hausdorff           %-15.6g %.6g\n", e.hausdorff, e.hausdorff_rel);
    std::printf("rms                 %-15.6g %.6g\n", e.rms, e.rms_rel);
    std::printf("mesh -> ref  max    %-15.6g rms %-12.6g mean %.6g\n", e.a_to_b_max, e.a_to_b_rms, e.a_to_b_mean);
    std::printf("ref -> mesh  max    %-15.6g rms %-12.6g mean %.6g\n", e.b_to_a_max, e.b_to_a_rms, e.b_to_a_mean);
  }
}

const RegisterCommand reg(60, [](CLI::App& app) {
  static StatsArgs args;  // options live as long as the process
  StatsArgs* a = &args;
  CLI::App* sub = app.add_subcommand(
      "stats", "Triangle quality (Table 1 of the paper), valence histogram, and the distance to a reference mesh");
  sub->add_option("mesh", a->input, "mesh to measure (.obj .off .ply .stl)")->required();
  sub->add_option("--ref", a->ref,
                  "reference mesh: also report the symmetric Hausdorff and RMS distance, absolute and relative to "
                  "the reference's bounding-box diagonal");
  sub->add_option("--samples", a->samples,
                  "area-uniform samples per surface for --ref (default: the larger face count, at least 100000, "
                  "at most 1000000); every vertex is measured too")
      ->check(CLI::Range(uint64_t(1), uint64_t(1'000'000'000)));
  sub->add_option("--seed", a->seed, "seed of the sample positions (default 1)");
  sub->add_option("--threads", a->threads, "worker threads, 0 = all cores (the result does not depend on it)");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_flag("--json", a->json, "print one JSON object instead of text");
  sub->callback([a] { run_stats(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
