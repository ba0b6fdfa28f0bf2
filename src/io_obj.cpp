// meshcvt: Wavefront OBJ reader and writer.
//
// Values are parsed by tinyobjloader (its callback API: no per-face allocation, faces arrive in file
// order). tinyobjloader is lenient by design: a token it cannot read becomes 0, an index out of range
// is only a warning, and neither carries a line number. So before handing the text over, a strict
// validator walks the same lines with the same line and statement rules (statements are recognized
// after leading blanks by "v ", "vn ", "vt ", "f " with a space or tab) and rejects, with the line
// number: non-numeric tokens, wrong value counts, faces with fewer than 3 corners, malformed corners
// ("1/2/3/4", "1//"), zero or out-of-range indices (relative ones against the vertices defined so
// far, absolute ones against the final count) and NUL bytes. What is left for the callbacks is
// exactly what tinyobjloader reads correctly; coordinates that overflow float ("1e39") show up as
// values beyond float range afterwards and are traced back to their line. Coordinates come as
// doubles (tinyobjloader's double build), for read_mesh to move a far mesh before rounding.
//
// Only faces are read: points, lines, groups, materials, smoothing groups are ignored, and "mtllib"
// opens no file (no material reader is passed).
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <istream>
#include <streambuf>
#include <string>
#include <vector>

#include "io_internal.h"

namespace meshcvt::io {
namespace {

inline bool is_obj_space(char c) { return c == ' ' || c == '\t'; }  // tinyobjloader's IS_SPACE

enum class Statement { other, vertex, normal, texcoord, face };

// The statement a line holds, by tinyobjloader's rules; `p` is left after the keyword.
Statement classify(const char*& p, const char* line_end) {
  while (p < line_end && is_obj_space(*p)) ++p;
  if (p >= line_end) return Statement::other;
  const char c0 = p[0];
  const char c1 = p + 1 < line_end ? p[1] : '\0';
  const char c2 = p + 2 < line_end ? p[2] : '\0';
  if (c0 == 'v' && is_obj_space(c1)) {
    p += 2;
    return Statement::vertex;
  }
  if (c0 == 'v' && c1 == 'n' && is_obj_space(c2)) {
    p += 3;
    return Statement::normal;
  }
  if (c0 == 'v' && c1 == 't' && is_obj_space(c2)) {
    p += 3;
    return Statement::texcoord;
  }
  if (c0 == 'f' && is_obj_space(c1)) {
    p += 2;
    return Statement::face;
  }
  return Statement::other;
}

// Calls visit(line_number, begin, end) for every line, splitting like tinyobjloader's safeGetline:
// "\n", "\r\n" and a lone "\r" end a line. Stops early when visit returns false.
template <typename Visit>
void for_each_line(const FileData& file, Visit&& visit) {
  const char* p = file.begin();
  const char* end = file.end();
  uint64_t line = 1;
  while (p < end) {
    const char* line_begin = p;
    while (p < end && *p != '\n' && *p != '\r') ++p;
    const char* line_end = p;
    if (p < end) {
      if (*p == '\r' && p + 1 < end && p[1] == '\n') ++p;
      ++p;
    }
    if (!visit(line, line_begin, line_end)) return;
    ++line;
  }
}

// Next token of an OBJ line (tinyobjloader separates by spaces and tabs only).
std::string_view next_token(const char*& p, const char* line_end) {
  while (p < line_end && is_obj_space(*p)) ++p;
  const char* start = p;
  while (p < line_end && !is_obj_space(*p)) ++p;
  return std::string_view(start, static_cast<size_t>(p - start));
}

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// Result of checking one number against the grammar tinyobjloader parses exactly:
// [+-]? (digits ('.' digits*)? | '.' digits) ([eE] [+-]? digits)?
enum class NumberCheck { ok, not_a_number, not_finite, out_of_range };

NumberCheck check_real(std::string_view t) {
  size_t i = 0;
  const size_t n = t.size();
  if (i < n && (t[i] == '+' || t[i] == '-')) ++i;
  size_t digits = 0;
  bool nonzero = false;
  while (i < n && is_digit(t[i])) nonzero |= t[i] != '0', ++i, ++digits;
  if (i < n && t[i] == '.') {
    ++i;
    while (i < n && is_digit(t[i])) nonzero |= t[i] != '0', ++i, ++digits;
  }
  if (digits == 0) {
    // Name the usual suspects (nan, inf, infinity in any case) as what they are.
    std::string_view rest = t.substr(t[0] == '+' || t[0] == '-' ? 1 : 0);
    if (equals_ignoring_case(rest, "nan") || equals_ignoring_case(rest, "inf") ||
        equals_ignoring_case(rest, "infinity")) {
      return NumberCheck::not_finite;
    }
    return NumberCheck::not_a_number;
  }
  if (i < n && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    bool negative = false;
    if (i < n && (t[i] == '+' || t[i] == '-')) negative = t[i++] == '-';
    size_t exponent_digits = 0;
    int64_t exponent = 0;
    while (i < n && is_digit(t[i])) {
      if (exponent < 1000000) exponent = exponent * 10 + (t[i] - '0');
      ++i, ++exponent_digits;
    }
    if (exponent_digits == 0) return NumberCheck::not_a_number;
    // tinyobjloader gives up (and returns 0) on exponents past ~2e8; a huge positive one is an
    // overflow we must not let pass as 0. A huge negative one is a plain 0 either way.
    if (!negative && nonzero && exponent > 100000) return NumberCheck::out_of_range;
  }
  return i == n ? NumberCheck::ok : NumberCheck::not_a_number;
}

// One index of a face corner: [+-]? digits, not 0, within int range (tinyobjloader uses atoi).
bool parse_obj_index(std::string_view t, int64_t& value) {
  size_t i = 0;
  bool negative = false;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) negative = t[i++] == '-';
  if (i == t.size()) return false;
  int64_t v = 0;
  for (; i < t.size(); ++i) {
    if (!is_digit(t[i])) return false;
    v = v * 10 + (t[i] - '0');
    if (v > 2147483647) return false;
  }
  value = negative ? -v : v;
  return true;
}

// An absolute index that refers past the elements defined so far; resolved at the end of the file.
// Only references that raise the running maximum are kept: the first one (in file order) beyond
// the final count is necessarily among them.
struct ForwardReference {
  uint64_t line;
  int64_t index;  // 1-based as written
};

struct IndexKind {
  IndexKind(const char* name_, const char* plural_) : name(name_), plural(plural_) {}
  const char* name;  // for messages: "vertex", "texture coordinate", "normal"
  const char* plural;
  uint64_t defined = 0;     // elements defined so far
  int64_t max_forward = 0;  // largest absolute index seen that was past `defined`
  std::vector<ForwardReference> forward;

  // Checks one index of this kind on `line`; returns an error reason or "".
  std::string check(int64_t index, uint64_t line) {
    if (index == 0) return std::string("index 0 (OBJ indices start at 1)");
    if (index < 0) {
      if (uint64_t(-index) > defined) {
        return "relative " + std::string(name) + " index " + std::to_string(index) +
               " out of range: " + std::to_string(defined) + " " + plural + " defined before this line";
      }
      return "";
    }
    if (uint64_t(index) > defined && index > max_forward) {
      max_forward = index;
      forward.push_back({line, index});
    }
    return "";
  }
};

// Walks every line and throws FileError at the first thing tinyobjloader would misread.
// Returns the vertex count.
uint64_t validate(const FileData& file) {
  IndexKind vertices("vertex", "vertices"), texcoords("texture coordinate", "texture coordinates"),
      normals("normal", "normals");
  auto fail = [&](uint64_t line, const std::string& reason) -> void {
    throw FileError::at_line(file.path, line, reason);
  };
  auto check_numbers = [&](uint64_t line, const char*& p, const char* line_end, size_t min_count, size_t max_count,
                           const char* what) {
    size_t count = 0;
    for (;;) {
      const std::string_view token = next_token(p, line_end);
      if (token.empty()) break;
      ++count;
      if (count > max_count) {
        fail(line, std::string(what) + " has more than " + std::to_string(max_count) + " values");
      }
      switch (check_real(token)) {
        case NumberCheck::ok:
          break;
        case NumberCheck::not_a_number:
          fail(line, "non-numeric token " + quote(token));
          break;
        case NumberCheck::not_finite:
          fail(line, "NaN or infinite value " + quote(token));
          break;
        case NumberCheck::out_of_range:
          fail(line, "value out of range " + quote(token));
          break;
      }
    }
    if (count < min_count) {
      fail(line, std::string(what) + " has " + std::to_string(count) + " values, needs " + std::to_string(min_count));
    }
  };

  for_each_line(file, [&](uint64_t line, const char* begin, const char* end) {
    if (std::memchr(begin, '\0', static_cast<size_t>(end - begin))) fail(line, "NUL byte in a text file");
    const char* p = begin;
    switch (classify(p, end)) {
      case Statement::other:
        break;
      case Statement::vertex:
        // x y z, optionally w, or the common "x y z r g b" color extension
        check_numbers(line, p, end, 3, 7, "vertex");
        if (++vertices.defined > kMaxVertices) fail(line, "too many vertices");
        break;
      case Statement::normal:
        check_numbers(line, p, end, 3, 3, "normal");
        ++normals.defined;
        break;
      case Statement::texcoord:
        check_numbers(line, p, end, 1, 3, "texture coordinate");
        ++texcoords.defined;
        break;
      case Statement::face: {
        size_t corners = 0;
        for (;;) {
          const std::string_view corner = next_token(p, end);
          if (corner.empty()) break;
          ++corners;
          // v, v/t, v/t/n or v//n
          std::string_view parts[3];
          size_t part_count = 0;
          size_t start = 0;
          for (size_t i = 0; i <= corner.size(); ++i) {
            if (i == corner.size() || corner[i] == '/') {
              if (part_count == 3) fail(line, "malformed face corner " + quote(corner));
              parts[part_count++] = corner.substr(start, i - start);
              start = i + 1;
            }
          }
          IndexKind* kinds[3] = {&vertices, &texcoords, &normals};
          for (size_t k = 0; k < part_count; ++k) {
            if (parts[k].empty() && k == 1 && part_count == 3) continue;  // v//n
            int64_t index = 0;
            if (!parse_obj_index(parts[k], index)) {
              if (parts[k].empty()) fail(line, "malformed face corner " + quote(corner));
              // a long run of digits is a number, just not one any file can index
              bool digits_only = true;
              for (size_t i = (parts[k][0] == '-' || parts[k][0] == '+') ? 1 : 0; i < parts[k].size(); ++i) {
                digits_only &= is_digit(parts[k][i]);
              }
              if (digits_only && parts[k].size() > 1)
                fail(line, std::string(kinds[k]->name) + " index out of range " + quote(parts[k]));
              fail(line, "non-numeric token " + quote(corner));
            }
            const std::string reason = kinds[k]->check(index, line);
            if (!reason.empty()) fail(line, reason);
          }
        }
        if (corners < 3) fail(line, "face with " + std::to_string(corners) + " corners (needs at least 3)");
        break;
      }
    }
    return true;
  });

  // Absolute indices past the end: report the earliest line among the three kinds.
  uint64_t bad_line = 0;
  std::string reason;
  for (const IndexKind* kind : {&vertices, &texcoords, &normals}) {
    for (const ForwardReference& ref : kind->forward) {
      if (uint64_t(ref.index) > kind->defined) {
        if (bad_line == 0 || ref.line < bad_line) {
          bad_line = ref.line;
          reason = std::string(kind->name) + " index " + std::to_string(ref.index) + " out of range: the file has " +
                   std::to_string(kind->defined) + " " + kind->plural;
        }
        break;
      }
    }
  }
  if (bad_line) fail(bad_line, reason);
  return vertices.defined;
}

// The line of the n-th (0-based) vertex statement, to report a value tinyobjloader turned into
// an infinity.
uint64_t line_of_vertex(const FileData& file, uint64_t n) {
  uint64_t found = 0, result = 0;
  for_each_line(file, [&](uint64_t line, const char* begin, const char* end) {
    const char* p = begin;
    if (classify(p, end) == Statement::vertex && found++ == n) {
      result = line;
      return false;
    }
    return true;
  });
  return result;
}

// An istream over the file's bytes without copying them.
struct MemoryBuffer : std::streambuf {
  MemoryBuffer(const char* begin, const char* end) {
    char* b = const_cast<char*>(begin);  // only read through the get area
    setg(b, b, const_cast<char*>(end));
  }
};

struct Collector {
  RawMesh mesh;
  uint64_t vertex_count = 0;
  uint64_t face_count = 0;
  bool failed = false;  // tinyobjloader disagreed with the validator; reported after it returns
  uint64_t failed_face = 0;
};

// tinyobjloader's double build (TINYOBJLOADER_USE_DOUBLE, from its CMake target): its float build
// rounds the same double parse to float, so a mesh read_mesh does not move reads the same floats.
static_assert(sizeof(tinyobj::real_t) == sizeof(double), "link tinyobjloader::tinyobjloader_double");

void on_vertex(void* user, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z, tinyobj::real_t) {
  Collector& c = *static_cast<Collector*>(user);
  c.mesh.positions.push_back(x);
  c.mesh.positions.push_back(y);
  c.mesh.positions.push_back(z);
  ++c.vertex_count;
}

void on_face(void* user, tinyobj::index_t* corners, int count) {
  Collector& c = *static_cast<Collector*>(user);
  const uint64_t face = c.face_count++;
  if (c.failed) return;
  if (count < 3) {
    c.failed = true;
    c.failed_face = face;
    return;
  }
  c.mesh.begin_polygon();
  for (int i = 0; i < count; ++i) {
    const int64_t raw = corners[i].vertex_index;
    // Relative indices count back from the vertices defined so far; absolute ones may point
    // forward and are checked once the whole file is read.
    const int64_t resolved = raw > 0 ? raw - 1 : int64_t(c.vertex_count) + raw;
    if (raw == 0 || resolved < 0 || uint64_t(resolved) > kMaxVertices) {
      c.failed = true;
      c.failed_face = face;
      return;
    }
    c.mesh.add_corner(static_cast<uint32_t>(resolved));
  }
  c.mesh.end_polygon();
}

}  // namespace

ReadResult read_obj(const FileData& file) {
  const uint64_t declared_vertices = validate(file);

  Collector collector;
  // Reserve from what the file can hold, not from a guess: ~6 bytes per coordinate at the least.
  collector.mesh.positions.reserve(static_cast<size_t>(std::min<uint64_t>(declared_vertices, file.size / 6) * 3));
  MemoryBuffer buffer(file.begin(), file.end());
  std::istream stream(&buffer);
  tinyobj::callback_t callbacks;
  callbacks.vertex_cb = on_vertex;
  callbacks.index_cb = on_face;
  std::string warnings, errors;
  const bool ok = tinyobj::LoadObjWithCallback(stream, callbacks, &collector, nullptr, &warnings, &errors);
  if (!ok || !errors.empty()) {
    std::string reason = errors.empty() ? std::string("tinyobjloader failed") : errors;
    while (!reason.empty() && (reason.back() == '\n' || reason.back() == '.')) reason.pop_back();
    throw FileError(file.path, reason);
  }
  if (collector.failed || collector.vertex_count != declared_vertices) {
    // The validator accepted what tinyobjloader then read differently: a bug, but still not a crash.
    throw FileError(file.path, "internal error: tinyobjloader and the validator disagree (face " +
                                   std::to_string(collector.failed_face + 1) + ")");
  }
  for (const uint32_t index : collector.mesh.indices) {
    if (index >= collector.vertex_count) {
      throw FileError(file.path, "internal error: vertex index out of range after validation");
    }
  }
  // Tokens that are numbers but exceed float range arrive as values that round to infinities (or
  // are infinite already): find their line.
  const std::vector<double>& positions = collector.mesh.positions;
  for (size_t i = 0; i < positions.size(); ++i) {
    if (!std::isfinite(static_cast<float>(positions[i]))) {
      throw FileError::at_line(file.path, line_of_vertex(file, i / 3), "coordinate out of float range");
    }
  }
  ReadResult result;
  result.mesh = std::move(collector.mesh);
  result.format = "obj";
  result.file_vertices = collector.vertex_count;
  return result;
}

void write_obj(OutputFile& out, const Mesh& mesh, const WriteOptions& options) {
  TextWriter text(out);
  text.text("# meshcvt\n");
  const size_t vertex_count = mesh.vertex_count();
  for (size_t v = 0; v < vertex_count; ++v) {
    text.text("v ").position(mesh.positions.data(), v, options.origin).ch('\n');
  }
  const size_t face_count = mesh.face_count();
  for (size_t f = 0; f < face_count; ++f) {
    text.text("f ").number(uint64_t(mesh.indices[3 * f]) + 1).ch(' ').number(uint64_t(mesh.indices[3 * f + 1]) + 1);
    text.ch(' ').number(uint64_t(mesh.indices[3 * f + 2]) + 1).ch('\n');
  }
}

}  // namespace meshcvt::io
