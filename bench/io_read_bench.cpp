// meshcvt benchmark: how long reading a mesh file (read_mesh) and building its topology
// (build_topology) take. Also makes the big input: subdivides a mesh 1-to-4 (midpoint) until it
// has at least the requested number of faces and writes it in every format.
//
//   io_read_bench make INPUT OUT_PREFIX [MIN_FACES]   writes OUT_PREFIX.{ply,obj,off,stl}
//   io_read_bench read [--repeat N] FILE...           best of N runs per file (and the median sum)
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <unordered_map>
#include <vector>

#include "meshcvt/io.h"
#include "meshcvt/topology.h"

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// CPU time of this process: on a shared machine it shows the work apart from waiting for a core.
double cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// 1-to-4 midpoint subdivision: each edge gets one new vertex, shared by both faces.
meshcvt::Mesh subdivide(const meshcvt::Mesh& mesh) {
  meshcvt::Mesh out;
  out.positions = mesh.positions;
  std::unordered_map<uint64_t, uint32_t> midpoint;
  midpoint.reserve(mesh.indices.size());
  auto middle = [&](uint32_t a, uint32_t b) {
    const uint64_t key = uint64_t(std::min(a, b)) << 32 | std::max(a, b);
    auto [it, inserted] = midpoint.try_emplace(key, uint32_t(out.positions.size() / 3));
    if (inserted) {
      for (int axis = 0; axis < 3; ++axis) {
        out.positions.push_back(0.5f * (mesh.positions[3 * a + axis] + mesh.positions[3 * b + axis]));
      }
    }
    return it->second;
  };
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    const uint32_t a = mesh.indices[3 * f], b = mesh.indices[3 * f + 1], c = mesh.indices[3 * f + 2];
    const uint32_t ab = middle(a, b), bc = middle(b, c), ca = middle(c, a);
    out.indices.insert(out.indices.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
  }
  return out;
}

int make(const std::string& input, const std::string& prefix, size_t min_faces) {
  meshcvt::Mesh mesh = meshcvt::read_mesh(input);
  while (mesh.face_count() < min_faces) mesh = subdivide(mesh);
  for (const char* ext : {".ply", ".obj", ".off", ".stl"}) {
    const auto start = std::chrono::steady_clock::now();
    meshcvt::write_mesh(prefix + ext, mesh);
    std::printf("wrote %s%s: %zu vertices, %zu faces, %.3f s\n", prefix.c_str(), ext, mesh.vertex_count(),
                mesh.face_count(), seconds_since(start));
  }
  return 0;
}

int read(const std::vector<std::string>& files, int repeat) {
  std::printf("%-20s %-14s %8s | %9s %9s | %9s %9s | %9s %10s\n", "file", "format", "faces", "read wall", "read cpu",
              "topo wall", "topo cpu", "sum wall", "(median)");
  for (const std::string& file : files) {
    std::vector<double> read_wall, read_cpu, topo_wall, topo_cpu, sum_wall;
    meshcvt::ReadStats stats;
    size_t faces = 0;
    for (int r = 0; r < repeat; ++r) {
      const double cpu_start = cpu_seconds();
      const auto start = std::chrono::steady_clock::now();
      const meshcvt::Mesh mesh = meshcvt::read_mesh(file, {}, &stats);
      const double read_time = seconds_since(start);
      read_cpu.push_back(cpu_seconds() - cpu_start);
      const double topo_cpu_start = cpu_seconds();
      const auto topo_start = std::chrono::steady_clock::now();
      const meshcvt::Topology topology = meshcvt::build_topology(mesh);
      const double topo_time = seconds_since(topo_start);
      topo_cpu.push_back(cpu_seconds() - topo_cpu_start);  // all threads together
      faces = mesh.face_count();
      if (topology.face_adjacent.size() != 3 * faces) return 1;  // keeps the work observable
      read_wall.push_back(read_time);
      topo_wall.push_back(topo_time);
      sum_wall.push_back(read_time + topo_time);
    }
    for (auto* times : {&read_wall, &read_cpu, &topo_wall, &topo_cpu, &sum_wall}) {
      std::sort(times->begin(), times->end());
    }
    const size_t slash = file.find_last_of('/');
    std::printf("%-20s %-14s %8zu | %8.3fs %8.3fs | %8.3fs %8.3fs | %8.3fs %9.3fs\n",
                file.substr(slash == std::string::npos ? 0 : slash + 1).c_str(), stats.format.c_str(), faces,
                read_wall[0], read_cpu[0], topo_wall[0], topo_cpu[0], sum_wall[0], sum_wall[sum_wall.size() / 2]);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::vector<std::string> args(argv + 1, argv + argc);
    if (args.size() >= 3 && args[0] == "make") {
      return make(args[1], args[2], args.size() > 3 ? std::strtoull(args[3].c_str(), nullptr, 10) : 1000000);
    }
    if (args.size() >= 2 && args[0] == "read") {
      int repeat = 5;
      std::vector<std::string> files;
      for (size_t i = 1; i < args.size(); ++i) {
        if (args[i] == "--repeat" && i + 1 < args.size()) {
          repeat = std::max(1, std::atoi(args[++i].c_str()));
        } else {
          files.push_back(args[i]);
        }
      }
      return read(files, repeat);
    }
    std::fprintf(stderr,
                 "usage: io_read_bench make INPUT OUT_PREFIX [MIN_FACES]\n"
                 "       io_read_bench read [--repeat N] FILE...\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "io_read_bench: %s\n", e.what());
    return 1;
  }
}
