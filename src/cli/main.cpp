// meshcvt command-line tool: subcommands register themselves (see command.h); this file parses,
// dispatches and turns every error into "meshcvt: error: ..." with exit code 1 (2 for bad usage).
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <new>
#include <utility>
#include <vector>

#include "cli/command.h"
#include "meshcvt/error.h"

namespace meshcvt::cli {

namespace {
std::vector<std::pair<int, void (*)(CLI::App&)>>& registry() {
  static std::vector<std::pair<int, void (*)(CLI::App&)>> r;
  return r;
}
}  // namespace

RegisterCommand::RegisterCommand(int order, void (*add)(CLI::App& app)) { registry().emplace_back(order, add); }

bool stderr_is_terminal() { return isatty(STDERR_FILENO) == 1; }

std::string labels_text(const std::vector<uint32_t>& labels) {
  std::string s;
  s.reserve(labels.size() * 6);
  char buf[16];
  for (uint32_t l : labels) {
    int n = std::snprintf(buf, sizeof buf, "%u\n", l);
    s.append(buf, size_t(n));
  }
  return s;
}

void print_progress(const ClusterProgress& p) {
  std::fprintf(stderr, "\r%-8s iteration %5u  moves %10llu", p.phase, p.iteration, (unsigned long long)p.moves);
  std::fflush(stderr);
}

void prepare_allocator(const std::string& input_path) {
#if defined(__GLIBC__)
  // Every phase of a job allocates and frees arrays of a few bytes per face. glibc's default
  // raises its mmap threshold to the largest block freed so far (up to 32 MB), after which such
  // arrays come from the heap and stay in the process when freed, so the peak memory becomes the
  // sum of phases rather than the largest one (1.2M-face bunny: 149 -> 135 bytes per face). A
  // fixed 1 MB threshold avoids that, but then every such array is fresh pages from the kernel:
  // on small inputs the page faults cost more than the memory (bunny00 -> 500, 3 MB of OFF:
  // 5 ms of a 120 ms job), so the threshold is fixed only for inputs of kLargeInputBytes or more.
  //
  // Where the executable maps blocks of 2 MiB or more itself (huge_pages.cpp), glibc never sees
  // them, so its threshold no longer rises: it stayed at 128 KiB, every freed array between that
  // and 2 MiB was fresh pages again, and bunny00 -> 500's clustering took 56 instead of 48 ms
  // (iterate 11.0 against 8.2 ms). For small inputs the threshold is then set where glibc's own
  // rule would put it after the first such block: just below the mapped blocks, the trim
  // threshold at twice that.
  constexpr uintmax_t kLargeInputBytes = uintmax_t(8) << 20;
  std::error_code ec;
  const uintmax_t bytes = std::filesystem::file_size(input_path, ec);
  if (!ec && bytes >= kLargeInputBytes) {
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
  } else if (maps_large_blocks()) {
    mallopt(M_MMAP_THRESHOLD, int(huge_page_block_bytes()));
    mallopt(M_TRIM_THRESHOLD, int(2 * huge_page_block_bytes()));
  }
#else
  (void)input_path;
#endif
}

Mesh read_mesh_noted(const std::string& path, const ReadOptions& options, bool quiet, ReadStats* stats) {
  ReadStats local;
  // A mesh far from the origin for its size (a georeferenced scan) is moved near it as it is read,
  // so that 32-bit floats keep its shape; each command writes its outputs with WriteOptions::origin
  // set to the origin read, which moves them back.
  ReadOptions moved = options;
  moved.shift_far = true;
  Mesh mesh = read_mesh(path, moved, &local);
  if (!quiet && !options.origin && !(local.origin[0] == 0 && local.origin[1] == 0 && local.origin[2] == 0))
    std::fprintf(stderr,
                 "meshcvt: note: %s: coordinates reach %.6g while the mesh spans %.3g: held relative to "
                 "(%.17g, %.17g, %.17g) to keep their precision as 32-bit floats; outputs are written back in place\n",
                 path.c_str(), local.largest_coordinate, local.extent, local.origin[0], local.origin[1], local.origin[2]);
  if (local.skipped_header_lines > 0 && !quiet)
    std::fprintf(stderr, "meshcvt: note: %s: skipped %llu PLY header line%s that begin%s with no PLY keyword (line %llu%s)\n",
                 path.c_str(), (unsigned long long)local.skipped_header_lines, local.skipped_header_lines > 1 ? "s" : "",
                 local.skipped_header_lines > 1 ? "" : "s", (unsigned long long)local.first_skipped_header_line,
                 local.skipped_header_lines > 1 ? " first" : "");
  if (stats) *stats = std::move(local);
  return mesh;
}

InputMesh read_input(const std::string& path, bool weld, bool quiet, unsigned threads) {
  prepare_allocator(path);
  auto t0 = std::chrono::steady_clock::now();
  InputMesh in;
  ReadOptions ro;
  ro.weld = weld;
  in.mesh = read_mesh_noted(path, ro, quiet, &in.stats);
  in.order = reorder_for_locality(in.mesh, kLocalityMinFaces, threads);
  in.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return in;
}

void add_device_option(CLI::App* sub, std::string& device) {
  sub->add_option("--device", device,
                  "auto | cpu | gpu | gpu:N (default: $MESHCVT_DEVICE, else auto: a discrete or "
                  "integrated GPU for meshes of a million faces or more per two CPU threads (--threads, else "
                  "every core), else the CPU engine, which "
                  "also takes over, with a note, if that GPU fails; gpu and gpu:N stop with the error)");
}

}  // namespace meshcvt::cli

int main(int argc, char** argv) {
  CLI::App app{"meshcvt: mesh clustering by approximating Centroidal Voronoi Tessellation"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "meshcvt 0.1.0");
  auto& reg = meshcvt::cli::registry();
  std::stable_sort(reg.begin(), reg.end(), [](auto& a, auto& b) { return a.first < b.first; });
  for (auto& [order, add] : reg) add(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::fprintf(stderr, "meshcvt: error: %s\n", e.what());
    std::fprintf(stderr, "run 'meshcvt --help' (or 'meshcvt COMMAND --help') for usage\n");
    return 2;
  } catch (const meshcvt::OptionError& e) {
    std::fprintf(stderr, "meshcvt: error: %s\n", e.what());
    return 2;
  } catch (const meshcvt::Error& e) {
    std::fprintf(stderr, "meshcvt: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "meshcvt: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "meshcvt: error: internal: %s\n", e.what());
    return 1;
  }
  return 0;
}
