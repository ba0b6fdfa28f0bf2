// meshcvt fuzzing: the body shared by the libFuzzer targets fuzz_{obj,off,ply,stl}.cpp. The input is
// written to a temporary file with the reader's extension and read with read_mesh, exactly as a user
// file would be. A FileError is the expected outcome for garbage; anything else (another exception,
// a crash, a sanitizer report, a hang, a mesh that breaks the Mesh invariants, or an "internal error"
// where the OBJ validator and tinyobjloader disagree) aborts and is reported by libFuzzer.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/io.h"

namespace meshcvt_fuzz {

inline const std::string& temp_path(const char* extension) {
  static const std::string path = [extension] {
    // Rewriting a file on a disk file system can cost milliseconds; /dev/shm keeps it in memory.
    const char* dir = std::getenv("TMPDIR");
    if (!dir || !*dir) dir = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    std::string p = std::string(dir) + "/meshcvt-fuzz-" + std::to_string(::getpid()) + extension;
    static std::string to_remove;
    to_remove = p;
    std::atexit([] { ::unlink(to_remove.c_str()); });
    return p;
  }();
  return path;
}

[[noreturn]] inline void broken(const char* what) {
  std::fprintf(stderr, "meshcvt fuzz: %s\n", what);
  std::abort();
}

inline int read_one(const uint8_t* data, size_t size, const char* extension) {
  const std::string& path = temp_path(extension);
  FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) broken("cannot write the temporary file");
  if (size && std::fwrite(data, 1, size, file) != size) broken("cannot write the temporary file");
  std::fclose(file);

  meshcvt::ReadOptions options;
  options.weld = (size % 2) == 0;  // both welding paths, chosen by something the fuzzer controls
  try {
    const meshcvt::Mesh mesh = meshcvt::read_mesh(path, options);
    // The contract of a successful read.
    if (mesh.face_count() == 0 || mesh.indices.size() % 3 || mesh.positions.size() % 3) broken("bad array sizes");
    for (const uint32_t index : mesh.indices) {
      if (index >= mesh.vertex_count()) broken("index out of range");
    }
    for (const float value : mesh.positions) {
      if (!std::isfinite(value)) broken("non-finite position");
    }
    std::vector<bool> referenced(mesh.vertex_count(), false);
    for (const uint32_t index : mesh.indices) referenced[index] = true;
    for (size_t v = 0; v < referenced.size(); ++v) {
      if (!referenced[v]) broken("unreferenced vertex kept");
    }
    if (!mesh.source_polygon.empty()) {
      if (mesh.source_polygon.size() != mesh.face_count()) broken("source_polygon size");
      for (size_t f = 1; f < mesh.source_polygon.size(); ++f) {
        if (mesh.source_polygon[f] < mesh.source_polygon[f - 1]) broken("source_polygon order");
      }
    }
  } catch (const meshcvt::FileError& e) {
    if (std::strstr(e.what(), "internal error")) broken(e.what());
    if (e.file() != path) broken("FileError names another file");
  }
  return 0;
}

}  // namespace meshcvt_fuzz
