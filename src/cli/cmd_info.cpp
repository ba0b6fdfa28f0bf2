// meshcvt CLI: `meshcvt info` — reads a mesh and prints its counts, topology (components, boundary
// loops, non-manifold and degenerate elements, Euler characteristic, genus), bounding box, area,
// what reading did, and how long reading and building the topology took.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>

#include "cli/command.h"
#include "cli/json.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"

namespace meshcvt::cli {

namespace {

struct InfoArgs {
  std::string input;
  bool json = false, no_weld = false;
};

// Why the genus is -1, for the human-readable output.
const char* genus_undefined_reason(const MeshInfo& i) {
  if (i.faces == 0) return "no faces";
  if (i.nonmanifold_edges || i.nonmanifold_vertices) return "non-manifold";
  if (i.collapsed_faces) return "collapsed faces";
  if (i.nonorientable_components) return "non-orientable";
  return "odd 2C - chi - B";
}

void row(const char* name, const std::string& value) { std::printf("%-24s %s\n", name, value.c_str()); }
void row(const char* name, uint64_t value) { row(name, std::to_string(value)); }

// A corner of the box in the file's frame: the mesh's float corner plus the origin it was moved by
// (zero unless the mesh is far from it).
std::array<double, 3> in_file_frame(const float p[3], const ReadStats& rs) {
  return {rs.origin[0] + double(p[0]), rs.origin[1] + double(p[1]), rs.origin[2] + double(p[2])};
}

bool moved(const ReadStats& rs) { return rs.origin[0] != 0 || rs.origin[1] != 0 || rs.origin[2] != 0; }

// The corner in the file's frame. A moved mesh's corner is shown to the float spacing of the
// moved box's largest coordinate (digits below it are the rounding of the moved floats, not data).
std::string xyz(const float p[3], const MeshInfo& i, const ReadStats& rs) {
  char buf[160];
  const std::array<double, 3> q = in_file_frame(p, rs);
  if (!moved(rs)) {
    std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g", q[0], q[1], q[2]);
    return buf;
  }
  float largest = 0;
  for (int k = 0; k < 3; ++k) largest = std::max({largest, std::fabs(i.bbox_min[k]), std::fabs(i.bbox_max[k])});
  const double spacing = double(std::nextafter(largest, INFINITY)) - double(largest);
  const int decimals = std::clamp(int(-std::floor(std::log10(spacing))), 0, 17);
  std::snprintf(buf, sizeof buf, "%.*f %.*f %.*f", decimals, q[0], decimals, q[1], decimals, q[2]);
  return buf;
}

std::string milliseconds(double ms) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f", ms);
  return buf;
}

void print_text(const InfoArgs& a, const ReadStats& rs, const MeshInfo& i, double read_ms, double topology_ms,
                double info_ms) {
  row("file", a.input);
  row("format", rs.format);
  row("vertices", i.vertices);
  row("faces", i.faces);
  row("edges", i.edges);
  row("components", uint64_t(i.components));
  row("boundary edges", i.boundary_edges);
  row("boundary loops", i.boundary_loops);
  row("non-manifold edges", i.nonmanifold_edges);
  row("non-manifold vertices", i.nonmanifold_vertices);
  row("degenerate faces", std::to_string(i.degenerate_faces) + " (" + std::to_string(i.collapsed_faces) +
                              " with a repeated corner)");
  row("duplicate faces", i.duplicate_faces);
  row("orientation flips", std::to_string(i.orientation_flips) + " (" + std::to_string(i.nonorientable_components) +
                               " non-orientable components)");
  row("euler characteristic", std::to_string(i.euler_characteristic));
  row("genus", i.genus >= 0 ? std::to_string(i.genus) : std::string("undefined (") + genus_undefined_reason(i) + ")");
  row("bbox min", xyz(i.bbox_min, i, rs));
  row("bbox max", xyz(i.bbox_max, i, rs));
  if (moved(rs)) {
    char origin[128];
    std::snprintf(origin, sizeof origin, "%.17g %.17g %.17g (far from 0: moved near it as read)", rs.origin[0],
                  rs.origin[1], rs.origin[2]);
    row("read origin", origin);
  }
  char area[64];
  std::snprintf(area, sizeof area, "%.10g", i.total_area);
  row("total area", area);
  row("file vertices", rs.file_vertices);
  row("file polygons", rs.file_polygons);
  row("triangulated polygons", rs.triangulated_polygons);
  row("welded vertices", a.no_weld ? std::string("0 (--no-weld)") : std::to_string(rs.welded_vertices));
  row("kept apart (weld)", rs.kept_apart_vertices);
  row("unreferenced dropped", rs.unreferenced_vertices);
  row("skipped header lines", rs.skipped_header_lines);
  row("read ms", milliseconds(read_ms));
  row("topology ms", milliseconds(topology_ms));
  row("summary ms", milliseconds(info_ms));
}

void print_json(const InfoArgs& a, const ReadStats& rs, const MeshInfo& i, double read_ms, double topology_ms,
                double info_ms) {
  Json j;
  j.begin_object();
  j.value("file", a.input).value("format", rs.format);
  j.value("vertices", i.vertices).value("faces", i.faces).value("edges", i.edges).value("components", i.components);
  j.value("boundary_edges", i.boundary_edges).value("boundary_loops", i.boundary_loops);
  j.value("nonmanifold_edges", i.nonmanifold_edges).value("nonmanifold_vertices", i.nonmanifold_vertices);
  j.value("degenerate_faces", i.degenerate_faces).value("collapsed_faces", i.collapsed_faces);
  j.value("duplicate_faces", i.duplicate_faces);
  j.value("orientation_flips", i.orientation_flips).value("nonorientable_components", i.nonorientable_components);
  j.value("euler_characteristic", i.euler_characteristic);
  j.value("genus", i.genus);  // -1: not defined (see MeshInfo::genus)
  const std::array<double, 3> lo = in_file_frame(i.bbox_min, rs), hi = in_file_frame(i.bbox_max, rs);
  if (moved(rs)) {
    j.begin_array("bbox_min").exact({}, lo[0]).exact({}, lo[1]).exact({}, lo[2]).end_array();
    j.begin_array("bbox_max").exact({}, hi[0]).exact({}, hi[1]).exact({}, hi[2]).end_array();
  } else {  // the floats as they were, to their digits
    j.begin_array("bbox_min").item(i.bbox_min[0]).item(i.bbox_min[1]).item(i.bbox_min[2]).end_array();
    j.begin_array("bbox_max").item(i.bbox_max[0]).item(i.bbox_max[1]).item(i.bbox_max[2]).end_array();
  }
  j.begin_array("origin").exact({}, rs.origin[0]).exact({}, rs.origin[1]).exact({}, rs.origin[2]).end_array();
  j.value("total_area", i.total_area);
  j.begin_object("read")
      .value("format", rs.format)
      .value("weld", !a.no_weld)
      .value("file_vertices", rs.file_vertices)
      .value("file_polygons", rs.file_polygons)
      .value("triangulated_polygons", rs.triangulated_polygons)
      .value("welded_vertices", rs.welded_vertices)
      .value("kept_apart_vertices", rs.kept_apart_vertices)
      .value("skipped_header_lines", rs.skipped_header_lines)
      .value("unreferenced_vertices", rs.unreferenced_vertices)
      .end_object();
  j.begin_object("timings_ms").value("read", read_ms).value("topology", topology_ms).value("summary", info_ms).end_object();
  j.end_object();
  std::fputs(j.str().c_str(), stdout);
}

void run_info(const InfoArgs& a) {
  using Clock = std::chrono::steady_clock;
  auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
  ReadOptions ro;
  ro.weld = !a.no_weld;
  ReadStats rs;
  auto t0 = Clock::now();
  Mesh mesh = read_mesh_noted(a.input, ro, false, &rs);
  double read_ms = ms_since(t0);
  t0 = Clock::now();
  Topology topology = build_topology(mesh);
  double topology_ms = ms_since(t0);
  t0 = Clock::now();
  MeshInfo info = mesh_info(mesh, topology);
  double info_ms = ms_since(t0);
  if (a.json)
    print_json(a, rs, info, read_ms, topology_ms, info_ms);
  else
    print_text(a, rs, info, read_ms, topology_ms, info_ms);
}

const RegisterCommand reg(10, [](CLI::App& app) {
  static InfoArgs args;  // options live as long as the process
  InfoArgs* a = &args;
  CLI::App* sub = app.add_subcommand("info", "Print a mesh's counts, topology, bounding box and area");
  sub->add_option("mesh", a->input, "input mesh (.obj .off .ply .stl)")->required();
  sub->add_flag("--json", a->json, "print one JSON object instead of aligned lines");
  sub->add_flag("--no-weld", a->no_weld, "do not merge vertices with identical positions");
  sub->callback([a] { run_info(*a); });
});

}  // namespace

}  // namespace meshcvt::cli
