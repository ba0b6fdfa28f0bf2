// meshcvt CLI: each subcommand lives in its own file and registers itself here, so adding one
// touches no shared file.
#pragma once

#include <CLI/CLI.hpp>

#include <cstddef>
#include <string>
#include <vector>

#include "meshcvt/cluster.h"
#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/mesh.h"
#include "meshcvt/mesh_order.h"

namespace meshcvt::cli {

/// Registers a subcommand; `order` sorts them in --help. Use at namespace scope:
///   static const RegisterCommand reg(10, [](CLI::App& app) { ... app.add_subcommand(...) ... });
struct RegisterCommand {
  RegisterCommand(int order, void (*add)(CLI::App& app));
};

/// True when stderr is a terminal (progress lines are shown only then).
bool stderr_is_terminal();

/// One id per line ("3\n"), the --labels file format of `cluster`, `coarsen` and `approximate`.
std::string labels_text(const std::vector<uint32_t>& labels);

/// Progress line on stderr ("\rPHASE iteration N moves M"), for ClusterOptions::progress when
/// stderr is a terminal.
void print_progress(const ClusterProgress& progress);

/// Tunes the C allocator for a job on the mesh file `input_path` (from its size): large inputs get a
/// fixed mmap threshold, so that freed per-face arrays go back to the system and the peak memory
/// stays that of the largest phase. Call before reading the input. read_input() calls it.
void prepare_allocator(const std::string& input_path);

/// Whether this executable maps blocks of huge_page_block_bytes() or more itself, backed by huge
/// pages (huge_pages.cpp): false in sanitizer builds, off Linux and under MESHCVT_HUGE_PAGES=0.
bool maps_large_blocks();
/// The smallest block huge_pages.cpp maps (2 MiB).
std::size_t huge_page_block_bytes();

/// read_mesh with ReadOptions::shift_far on, plus notes on stderr (unless quiet): a mesh that was
/// moved near the origin (ReadStats::origin: outputs must add it back, WriteOptions::origin), PLY
/// header lines that are no keyword skipped. `stats` may be null.
Mesh read_mesh_noted(const std::string& path, const ReadOptions& options, bool quiet, ReadStats* stats = nullptr);

/// The input of a partitioning command: read (weld: merge duplicate vertices; read_mesh_noted),
/// then, when large, reordered for locality (reorder_for_locality, on `threads` threads, 0: one per
/// core); `order` restores the input's order for outputs.
struct InputMesh {
  Mesh mesh;
  LocalityOrder order;
  ReadStats stats;
  double seconds = 0;  ///< reading and reordering
};
InputMesh read_input(const std::string& path, bool weld, bool quiet, unsigned threads = 0);

/// fn(), with an OptionError it throws given `path: ` in front: a mesh that does not allow the
/// options (n too small for its components, more clusters than faces) is named in the message, so
/// that a run over many files says which one.
template <class Fn>
auto naming_input(const std::string& path, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const OptionError& e) {
    throw OptionError(path + ": " + e.what());
  }
}

/// Appends the --device option (auto|cpu|gpu|gpu:N) to a subcommand.
void add_device_option(CLI::App* sub, std::string& device);

}  // namespace meshcvt::cli
