// meshcvt: STL reader (ascii and binary) and binary writer.
//
// Telling the two apart: many binary files start their 80-byte header with "solid" too, so the
// size decides first: a file of exactly 84 + 50 * (triangle count at byte 80) bytes is binary.
// Otherwise a file that starts with "solid" and whose next token is "facet" or "endsolid" is ascii
// (and ascii errors carry line numbers); anything else is a binary file whose size disagrees with
// its count, reported at the byte where it goes wrong.
//
// STL stores three corners per triangle and no shared vertices; read_mesh welds them into an
// indexed mesh (ReadOptions::weld). Facet normals are ignored (they are often wrong or zero).
// ascii loops with more than three vertices are fanned like any polygon.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "io_internal.h"

namespace meshcvt::io {
namespace {

constexpr size_t kHeaderBytes = 84;    // 80-byte header + uint32 triangle count
constexpr size_t kTriangleBytes = 50;  // normal, 3 corners (float32 x 12), uint16 attribute

// Next token, crossing line ends; empty at the end of the text. `line` gets the token's line.
std::string_view stl_token(TextCursor& c, uint64_t& line) {
  for (;;) {
    const std::string_view token = c.token();
    if (!token.empty()) {
      line = c.line;
      return token;
    }
    if (c.at_end()) {
      line = c.last_line();
      return token;
    }
    c.next_line();
  }
}

bool looks_ascii(const FileData& file) {
  TextCursor c(file.begin(), file.end());
  uint64_t line = 0;
  if (!equals_ignoring_case(stl_token(c, line), "solid")) return false;
  c.next_line();  // the solid's name
  const std::string_view next = stl_token(c, line);
  return next.empty() || equals_ignoring_case(next, "facet") || equals_ignoring_case(next, "endsolid");
}

class AsciiStlReader {
 public:
  explicit AsciiStlReader(const FileData& file) : file_(file), c_(file.begin(), file.end()) {}

  ReadResult read() {
    expect("solid");
    c_.next_line();  // the name, if any
    for (;;) {
      const std::string_view token = next();
      if (token.empty()) fail("file ends before 'endsolid'");
      if (equals_ignoring_case(token, "facet")) {
        read_facet();
      } else if (equals_ignoring_case(token, "endsolid")) {
        c_.next_line();  // the name, if any
        // Some tools concatenate several solids into one file.
        const std::string_view after = next();
        if (after.empty()) break;
        if (!equals_ignoring_case(after, "solid"))
          fail("expected 'solid' or the end of the file, found " + quote(after));
        c_.next_line();
      } else {
        fail("expected 'facet' or 'endsolid', found " + quote(token));
      }
    }
    ReadResult result;
    result.mesh = std::move(mesh_);
    result.format = "stl-ascii";
    result.file_vertices = result.mesh.positions.size() / 3;
    return result;
  }

 private:
  [[noreturn]] void fail(const std::string& reason) const { throw FileError::at_line(file_.path, line_, reason); }

  std::string_view next() { return stl_token(c_, line_); }

  void expect(const char* keyword) {
    const std::string_view token = next();
    if (!equals_ignoring_case(token, keyword)) {
      fail(std::string("expected '") + keyword + "', found " +
           (token.empty() ? std::string("the end of the file") : quote(token)));
    }
  }

  // A coordinate (is_position) to double, a normal's component checked only.
  double number(bool is_position) {
    const std::string_view token = next();
    if (token.empty()) fail("file ends inside a facet");
    double value = 0;
    float ignored = 0;
    switch (is_position ? parse_coordinate(token, value) : parse_float(token, ignored)) {
      case NumberStatus::ok:
        break;
      case NumberStatus::not_a_number:
        fail("non-numeric token " + quote(token));
      case NumberStatus::not_finite:
        if (is_position) fail("NaN or infinite coordinate " + quote(token));
        break;
      case NumberStatus::out_of_range:
        if (is_position) fail("coordinate out of float range " + quote(token));
        break;
    }
    return value;
  }

  void read_facet() {
    expect("normal");
    for (int i = 0; i < 3; ++i) number(false);
    expect("outer");
    expect("loop");
    mesh_.begin_polygon();
    for (;;) {
      const std::string_view token = next();
      if (equals_ignoring_case(token, "endloop")) break;
      if (!equals_ignoring_case(token, "vertex")) {
        fail("expected 'vertex' or 'endloop', found " +
             (token.empty() ? std::string("the end of the file") : quote(token)));
      }
      const uint64_t vertex = mesh_.positions.size() / 3;
      if (vertex >= kMaxVertices) fail("too many vertices");
      for (int axis = 0; axis < 3; ++axis) mesh_.positions.push_back(number(true));
      mesh_.add_corner(static_cast<uint32_t>(vertex));
    }
    if (mesh_.corner_count() < 3) {
      fail("facet with " + std::to_string(mesh_.corner_count()) + " vertices (needs at least 3)");
    }
    mesh_.end_polygon();
    expect("endfacet");
  }

  const FileData& file_;
  TextCursor c_;
  uint64_t line_ = 1;
  RawMesh mesh_;
};

ReadResult read_binary_stl(const FileData& file, uint64_t count) {
  const bool swap = !host_is_little_endian();
  ReadResult result;
  RawMesh& mesh = result.mesh;
  mesh.positions.resize(size_t(count) * 9);
  mesh.indices.resize(size_t(count) * 3);
  for (uint64_t t = 0; t < count; ++t) {
    const size_t record = kHeaderBytes + size_t(t) * kTriangleBytes;
    for (size_t k = 0; k < 9; ++k) {
      const size_t at = record + 12 + 4 * k;  // skip the normal
      const float value = load<float>(file.begin() + at, swap);
      if (!std::isfinite(value)) throw FileError::at_byte(file.path, at, "NaN or infinite coordinate");
      mesh.positions[size_t(t) * 9 + k] = value;
    }
    for (size_t k = 0; k < 3; ++k) mesh.indices[size_t(t) * 3 + k] = static_cast<uint32_t>(t * 3 + k);
  }
  mesh.polygons = count;
  result.format = "stl-binary";
  result.file_vertices = count * 3;
  return result;
}

}  // namespace

ReadResult read_stl(const FileData& file) {
  const bool swap = !host_is_little_endian();
  const uint64_t count = file.size >= kHeaderBytes ? load<uint32_t>(file.begin() + 80, swap) : 0;
  const uint64_t expected = kHeaderBytes + count * kTriangleBytes;
  if (file.size >= kHeaderBytes && file.size == expected) {
    if (count * 3 > kMaxVertices) throw FileError::at_byte(file.path, 80, "too many triangles");
    return read_binary_stl(file, count);
  }
  if (looks_ascii(file)) return AsciiStlReader(file).read();
  if (file.size < kHeaderBytes) {
    throw FileError::at_byte(file.path, file.size, "file ends inside the 84-byte binary STL header");
  }
  if (file.size < expected) {
    const uint64_t complete = (file.size - kHeaderBytes) / kTriangleBytes;
    throw FileError::at_byte(file.path, kHeaderBytes + complete * kTriangleBytes,
                             "file ends after " + std::to_string(complete) + " of " + std::to_string(count) +
                                 " triangles the binary STL header declares");
  }
  throw FileError::at_byte(file.path, expected,
                           std::to_string(file.size - expected) + " bytes after the " + std::to_string(count) +
                               " triangles the binary STL header declares");
}

void write_stl(OutputFile& out, const Mesh& mesh, const WriteOptions& options) {
  // The header must not start with "solid", or readers may take the file for ascii.
  char header[kHeaderBytes] = {};
  const char title[] = "binary STL written by meshcvt";
  std::memcpy(header, title, sizeof title - 1);
  const uint32_t count = static_cast<uint32_t>(mesh.face_count());
  std::memcpy(header + 80, &count, 4);
  if (!host_is_little_endian()) std::reverse(header + 80, header + 84);
  out.write(header, sizeof header);
  const bool moved = !is_zero(options.origin);  // (-0.0 stays -0.0 when nothing moves)
  for (size_t f = 0; f < mesh.face_count(); ++f) {
    // The normal from the positions as held (near the origin when moved: more precise); the
    // corners moved back by the origin and rounded to float, all binary STL can hold.
    float corner[3][3], written[3][3];
    for (int k = 0; k < 3; ++k) {
      for (int axis = 0; axis < 3; ++axis) {
        corner[k][axis] = mesh.positions[3 * size_t(mesh.indices[3 * f + k]) + axis];
        written[k][axis] = moved ? static_cast<float>(options.origin[axis] + double(corner[k][axis])) : corner[k][axis];
      }
    }
    const float u[3] = {corner[1][0] - corner[0][0], corner[1][1] - corner[0][1], corner[1][2] - corner[0][2]};
    const float v[3] = {corner[2][0] - corner[0][0], corner[2][1] - corner[0][1], corner[2][2] - corner[0][2]};
    float normal[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const float length = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    for (float& n : normal) n = length > 0 && std::isfinite(length) ? n / length : 0.0f;
    char* p = out.reserve(kTriangleBytes);
    float values[12];
    std::memcpy(values, normal, 12);
    std::memcpy(values + 3, written, 36);
    for (int i = 0; i < 12; ++i) {
      std::memcpy(p + 4 * i, &values[i], 4);
      if (!host_is_little_endian()) std::reverse(p + 4 * i, p + 4 * i + 4);
    }
    p[48] = p[49] = 0;
    out.advance(kTriangleBytes);
  }
}

}  // namespace meshcvt::io
