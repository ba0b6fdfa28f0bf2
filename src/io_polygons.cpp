// meshcvt: writing polygon meshes (faces of any size) as OBJ or OFF, for the polygonal output of
// shape approximation (one face per region; API in meshcvt/approximate.h). Written through the
// same atomic OutputFile and float formatting as the triangle writers (io_internal.h).
#include <string>
#include <vector>

#include "io_internal.h"
#include "meshcvt/approximate.h"
#include "meshcvt/error.h"

namespace meshcvt {

void write_polygon_mesh(const std::string& path, const std::vector<float>& positions,
                        const std::vector<uint32_t>& offsets, const std::vector<uint32_t>& vertices,
                        const std::array<double, 3>& origin) {
  const std::string ext = io::lower_extension(path);
  const bool obj = ext == ".obj";
  if (!obj && ext != ".off")
    throw FileError(path, "unknown polygon mesh format '" + ext + "' (expected .obj or .off)");
  // Check everything before creating the file, so a bad call leaves nothing behind.
  if (positions.size() % 3 != 0) throw OptionError("write_polygon_mesh: positions must come in threes");
  const size_t vertex_count = positions.size() / 3;
  if (offsets.empty() || offsets.front() != 0 || offsets.back() != vertices.size())
    throw OptionError("write_polygon_mesh: offsets do not cover the vertex list");
  uint64_t polygons = 0;
  for (size_t p = 0; p + 1 < offsets.size(); ++p) {
    if (offsets[p + 1] < offsets[p]) throw OptionError("write_polygon_mesh: offsets decrease");
    uint32_t size = offsets[p + 1] - offsets[p];
    if (size == 0) continue;
    if (size < 3) throw OptionError("write_polygon_mesh: polygon " + std::to_string(p) + " has fewer than 3 vertices");
    ++polygons;
  }
  for (uint32_t v : vertices)
    if (v >= vertex_count) throw OptionError("write_polygon_mesh: vertex index out of range");

  io::OutputFile out(path);
  io::TextWriter text(out);
  if (obj) {
    text.text("# meshcvt polygon mesh\n");
  } else {
    text.text("OFF\n").number(uint64_t(vertex_count)).ch(' ').number(polygons).text(" 0\n");
  }
  for (size_t v = 0; v < vertex_count; ++v) {
    if (obj) text.text("v ");
    text.position(positions.data(), v, origin).ch('\n');
  }
  for (size_t p = 0; p + 1 < offsets.size(); ++p) {
    uint32_t size = offsets[p + 1] - offsets[p];
    if (size == 0) continue;
    if (obj) text.ch('f'); else text.number(uint64_t(size));
    for (uint32_t i = offsets[p]; i < offsets[p + 1]; ++i) text.ch(' ').number(uint64_t(vertices[i]) + (obj ? 1 : 0));
    text.ch('\n');
  }
  out.commit();
}

}  // namespace meshcvt
