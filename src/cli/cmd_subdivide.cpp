// meshcvt CLI: `meshcvt subdivide` — midpoint subdivision (each level splits every triangle into
// four), e.g. to make 1.2M and 4.8M-face benchmark meshes from 75k-face ones.
#include <chrono>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "meshcvt/io.h"
#include "meshcvt/subdivide.h"

namespace meshcvt::cli {

namespace {

struct SubdivideArgs {
  std::string input, output;
  unsigned levels = 0;
  bool quiet = false, no_weld = false;
};

void run_subdivide(const SubdivideArgs& a) {
  using Clock = std::chrono::steady_clock;
  auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  check_mesh_format(a.output);  // before the work
  ReadOptions ro;
  ro.weld = !a.no_weld;
  auto t0 = Clock::now();
  ReadStats read_stats;
  Mesh mesh = read_mesh_noted(a.input, ro, a.quiet, &read_stats);
  double read_s = seconds_since(t0);
  t0 = Clock::now();
  Mesh fine = subdivide_midpoint(mesh, a.levels);
  double subdivide_s = seconds_since(t0);
  t0 = Clock::now();
  WriteOptions wo;
  wo.origin = read_stats.origin;
  write_mesh(a.output, fine, wo);
  double write_s = seconds_since(t0);
  if (!a.quiet)
    std::printf("%s: %zu faces -> %zu faces, %zu vertices (%u levels); wrote %s (read %.3f s, subdivide %.3f s, "
                "write %.3f s)\n",
                a.input.c_str(), mesh.face_count(), fine.face_count(), fine.vertex_count(), a.levels, a.output.c_str(),
                read_s, subdivide_s, write_s);
}

const RegisterCommand reg(80, [](CLI::App& app) {
  static SubdivideArgs args;  // options live as long as the process
  SubdivideArgs* a = &args;
  CLI::App* sub = app.add_subcommand("subdivide", "Split every triangle into 4 at its edge midpoints, K times");
  sub->add_option("input", a->input, "input mesh (.obj .off .ply .stl)")->required();
  sub->add_option("-k,--levels", a->levels, "subdivision levels: faces are multiplied by 4^K")->required();
  sub->add_option("-o,--output", a->output, "output mesh (.obj .off .ply .stl)")->required();
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->add_flag("-q,--quiet", a->quiet, "print nothing on success");
  sub->callback([a] { run_subdivide(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
