// meshcvt: Object File Format (OFF, Geomview) reader and writer.
//
// Accepted: the keyword with the optional prefixes ST, C, N and n with dimension 3 ("COFF", "NOFF",
// "CNOFF", "STCNOFF", "nOFF 3"), or no keyword at all; the counts "V F E" on the keyword's line or
// on following lines, even one per line; '#' comments anywhere and blank lines. After the header
// the data is line based, as every writer produces it: one vertex per line (x y z, then whatever the
// variant adds: normals, colors, texture coordinates, which are checked to be numbers and skipped),
// then one face per line (n, n vertex ids, then an optional color). Anything but blanks and
// comments after the last face is an error, as are fewer lines than declared.
// Not supported (clear error): 4D vertices (4OFF, nOFF with dimension other than 3), binary OFF.
#include <algorithm>
#include <string>

#include "io_internal.h"

namespace meshcvt::io {
namespace {

// Next token on the current line; '#' starts a comment that runs to the end of the line. One pass
// over the characters (looking for '#' in each token afterwards was a third of the reading time).
std::string_view off_token(TextCursor& c) {
  c.skip_blanks();
  const char* start = c.p;
  const char* p = c.p;
  while (p < c.end && !is_blank(*p) && !is_line_end(*p) && *p != '#') ++p;
  const std::string_view token(start, static_cast<size_t>(p - start));
  if (p < c.end && *p == '#')
    while (p < c.end && !is_line_end(*p)) ++p;
  c.p = p;
  return token;
}

// Moves to the start of the next line with content (past its leading blanks); false at the end
// of the file. A line has content when, after its blanks, neither its end nor a comment follows.
bool skip_empty_lines(TextCursor& c) {
  for (;;) {
    c.skip_blanks();
    if (c.at_end()) return false;
    if (!is_line_end(*c.p) && *c.p != '#') return true;
    c.next_line();
  }
}

// True when the line at the cursor holds nothing but blanks and comments (cursor unchanged).
bool line_is_empty(TextCursor c) { return off_token(c).empty(); }

// Next token of the header, crossing line ends, blank lines and comments; empty at the end.
std::string_view header_token(TextCursor& c) {
  for (;;) {
    const std::string_view token = off_token(c);
    if (!token.empty()) return token;
    if (c.at_end()) return token;
    c.next_line();
  }
}

class OffReader {
 public:
  explicit OffReader(const FileData& file) : file_(file), c_(file.begin(), file.end()) {}

  ReadResult read() {
    read_header();
    read_vertices();
    read_faces();
    if (skip_empty_lines(c_)) {
      fail(c_.line, "more data than the header declares (" + std::to_string(vertex_count_) + " vertices, " +
                        std::to_string(face_count_) + " faces)");
    }
    ReadResult result;
    result.mesh = std::move(mesh_);
    result.format = "off";
    result.file_vertices = vertex_count_;
    return result;
  }

 private:
  [[noreturn]] void fail(uint64_t line, const std::string& reason) {
    throw FileError::at_line(file_.path, line, reason);
  }

  uint64_t read_count(const char* what) {
    const std::string_view token = header_token(c_);
    if (token.empty()) fail(c_.last_line(), std::string("file ends before the ") + what + " count");
    uint64_t value = 0;
    if (parse_count(token, value) != NumberStatus::ok) {
      fail(c_.line, std::string("expected the ") + what + " count (header 'OFF V F E'), found " + quote(token));
    }
    return value;
  }

  void read_header() {
    std::string_view token = header_token(c_);
    if (token.empty()) fail(c_.last_line(), "no OFF header");
    uint64_t dummy = 0;
    if (parse_count(token, dummy) != NumberStatus::ok) {
      // A keyword: [ST][C][N][4][n]OFF
      const uint64_t line = c_.line;
      if (token.size() < 3 || !equals_ignoring_case(token.substr(token.size() - 3), "off")) {
        fail(line, "not an OFF file: expected the 'OFF' keyword, found " + quote(token));
      }
      std::string_view prefix = token.substr(0, token.size() - 3);
      bool four_d = false, n_dim = false;
      auto take = [&](std::string_view p) {
        if (prefix.size() >= p.size() && prefix.substr(0, p.size()) == p) {
          prefix.remove_prefix(p.size());
          return true;
        }
        return false;
      };
      take("ST");
      take("C");
      take("N");
      four_d = take("4");
      n_dim = take("n");
      if (!prefix.empty()) fail(line, "unknown OFF variant " + quote(token));
      if (n_dim) {
        const uint64_t dimension = read_count("dimension");
        if (dimension + (four_d ? 1 : 0) != 3) {
          fail(c_.line, "not supported: " + std::to_string(dimension + (four_d ? 1 : 0)) + "-dimensional OFF vertices");
        }
      } else if (four_d) {
        fail(line, "not supported: 4-dimensional OFF vertices (" + std::string(token) + ")");
      }
      // "OFF BINARY" announces binary data on the same line.
      TextCursor peek = c_;
      const std::string_view next = off_token(peek);
      if (equals_ignoring_case(next, "binary")) fail(line, "not supported: binary OFF");
      vertex_count_ = read_count("vertex");
    } else {
      vertex_count_ = dummy;  // the keyword is optional
    }
    const uint64_t counts_line = c_.line;
    face_count_ = read_count("face");
    read_count("edge");
    if (!line_is_empty(c_)) {
      fail(c_.line, "unexpected " + quote(off_token(c_)) + " after the counts 'V F E'");
    }
    c_.next_line();
    if (vertex_count_ > kMaxVertices) fail(counts_line, "too many vertices: " + std::to_string(vertex_count_));
    if (face_count_ > kMaxTriangles) fail(counts_line, "too many faces: " + std::to_string(face_count_));
  }

  // Parses a number and names the problem; positions must also be finite.
  void number(std::string_view token, float& value, bool must_be_finite) {
    check(parse_float(token, value), token, must_be_finite);
  }
  void coordinate(std::string_view token, double& value) { check(parse_coordinate(token, value), token, true); }

  void check(NumberStatus status, std::string_view token, bool must_be_finite) {
    switch (status) {
      case NumberStatus::ok:
        return;
      case NumberStatus::not_a_number:
        fail(c_.line, "non-numeric token " + quote(token));
      case NumberStatus::not_finite:
        if (must_be_finite) fail(c_.line, "NaN or infinite coordinate " + quote(token));
        return;
      case NumberStatus::out_of_range:
        if (must_be_finite) fail(c_.line, "coordinate out of float range " + quote(token));
        return;
    }
  }

  // Checks the optional trailing values of a line (normals, colors, ...) are numbers.
  void skip_extra_values() {
    for (std::string_view token = off_token(c_); !token.empty(); token = off_token(c_)) {
      float ignored;
      number(token, ignored, false);
    }
  }

  void read_vertices() {
    // A lying count must not reserve memory the file cannot fill: a vertex takes 6 bytes or more.
    mesh_.positions.reserve(static_cast<size_t>(std::min<uint64_t>(vertex_count_, file_.size / 6)) * 3);
    for (uint64_t v = 0; v < vertex_count_; ++v) {
      if (!skip_empty_lines(c_)) {
        fail(c_.last_line(),
             "file ends after " + std::to_string(v) + " of " + std::to_string(vertex_count_) + " vertices");
      }
      for (int axis = 0; axis < 3; ++axis) {
        const std::string_view token = off_token(c_);
        if (token.empty()) fail(c_.line, "vertex line has " + std::to_string(axis) + " values, needs 3");
        double value = 0;
        coordinate(token, value);
        mesh_.positions.push_back(value);
      }
      skip_extra_values();
      c_.next_line();
    }
  }

  void read_faces() {
    mesh_.indices.reserve(static_cast<size_t>(std::min<uint64_t>(face_count_, file_.size / 8)) * 3);
    for (uint64_t f = 0; f < face_count_; ++f) {
      if (!skip_empty_lines(c_)) {
        fail(c_.last_line(), "file ends after " + std::to_string(f) + " of " + std::to_string(face_count_) + " faces");
      }
      if (fast_triangle()) continue;
      const std::string_view count_token = off_token(c_);
      uint64_t corners = 0;
      if (parse_count(count_token, corners) != NumberStatus::ok) {
        fail(c_.line, "expected the corner count of a face, found " + quote(count_token));
      }
      if (corners < 3) fail(c_.line, "face with " + std::to_string(corners) + " corners (needs at least 3)");
      mesh_.begin_polygon();
      for (uint64_t k = 0; k < corners; ++k) {
        const std::string_view token = off_token(c_);
        if (token.empty()) {
          fail(c_.line, "face line ends after " + std::to_string(k) + " of " + std::to_string(corners) + " corners");
        }
        int64_t index = 0;
        const NumberStatus status = parse_int(token, index);
        if (status == NumberStatus::not_a_number) fail(c_.line, "non-numeric token " + quote(token));
        if (status != NumberStatus::ok || index < 0 || uint64_t(index) >= vertex_count_) {
          fail(c_.line, "vertex index " + std::string(token) + " out of range: the file has " +
                            std::to_string(vertex_count_) + " vertices");
        }
        mesh_.add_corner(static_cast<uint32_t>(index));
      }
      mesh_.end_polygon();
      if (mesh_.indices.size() / 3 > kMaxTriangles) fail(c_.line, "too many triangles");
      skip_extra_values();  // an optional face color
      c_.next_line();
    }
  }

  // The usual face line, "3 a b c" with plain decimal indices in range, read without the token
  // machinery (a third of the time of reading bunny00.off went there). Any other line, or one that
  // does not fit (signs, long numbers, an index out of range, a missing corner), is left untouched
  // for the general reader, which then gives the same result or names the same error. True when
  // the line was read, cursor on the next line.
  bool fast_triangle() {
    const char* p = c_.p;
    const char* end = c_.end;
    if (end - p < 2 || p[0] != '3' || !is_blank(p[1])) return false;
    ++p;
    uint32_t corner[3];
    for (uint32_t& index : corner) {
      while (p < end && is_blank(*p)) ++p;
      const char* start = p;
      uint64_t value = 0;
      while (p < end && *p >= '0' && *p <= '9' && p - start < 10) value = value * 10 + uint64_t(*p++ - '0');
      if (p == start || value >= vertex_count_) return false;
      if (p < end && !is_blank(*p) && !is_line_end(*p) && *p != '#') return false;
      index = uint32_t(value);
    }
    c_.p = p;
    mesh_.begin_polygon();
    for (uint32_t index : corner) mesh_.add_corner(index);
    mesh_.end_polygon();
    if (mesh_.indices.size() / 3 > kMaxTriangles) fail(c_.line, "too many triangles");
    skip_extra_values();  // an optional face color
    c_.next_line();
    return true;
  }

  const FileData& file_;
  TextCursor c_;
  uint64_t vertex_count_ = 0, face_count_ = 0;
  RawMesh mesh_;
};

}  // namespace

ReadResult read_off(const FileData& file) { return OffReader(file).read(); }

void write_off(OutputFile& out, const Mesh& mesh, const WriteOptions& options) {
  TextWriter text(out);
  text.text("OFF\n").number(uint64_t(mesh.vertex_count())).ch(' ').number(uint64_t(mesh.face_count())).text(" 0\n");
  const size_t vertex_count = mesh.vertex_count();
  for (size_t v = 0; v < vertex_count; ++v) {
    text.position(mesh.positions.data(), v, options.origin).ch('\n');
  }
  const size_t face_count = mesh.face_count();
  for (size_t f = 0; f < face_count; ++f) {
    text.text("3 ").number(uint64_t(mesh.indices[3 * f])).ch(' ').number(uint64_t(mesh.indices[3 * f + 1]));
    text.ch(' ').number(uint64_t(mesh.indices[3 * f + 2])).ch('\n');
  }
}

}  // namespace meshcvt::io
