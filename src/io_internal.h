// meshcvt: helpers shared by the mesh readers and writers (src/io*.cpp); not part of the installed API.
//
// Every reader works on the whole file in memory (FileData), reports positions through FileError
// (line for text, byte offset for binary), and hands its triangles to a RawMesh, which io.cpp then
// welds and compacts into a Mesh. Writers go through OutputFile, which writes to a temporary file
// beside the target and renames it only when complete.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/mesh.h"

namespace meshcvt::io {

// ---------------------------------------------------------------------------------------------
// Input

/// A whole file in memory. bytes[size] is a NUL byte, so scanners may always peek one past the end.
struct FileData {
  std::string path;  ///< as given by the caller, used in messages
  std::unique_ptr<char[]> bytes;
  size_t size = 0;

  const char* begin() const { return bytes.get(); }
  const char* end() const { return bytes.get() + size; }
};

/// Reads `path` completely. Throws FileError for a missing, unreadable or empty file or a directory.
FileData read_file(const std::string& path);

/// Triangles as a reader produced them, before welding and removal of unreferenced vertices.
/// Polygons are fanned from their first corner as they arrive (begin_polygon / add_corner /
/// end_polygon), so no reader needs a per-polygon buffer.
struct RawMesh {
  /// 3 per file vertex, as the file gives them (a float file's floats, a text file's decimals read
  /// to double by parse_coordinate): read_mesh may move them before rounding to float.
  std::vector<double> positions;
  std::vector<uint32_t> indices;  // 3 per triangle, into positions
  /// Source polygon of each triangle; stays empty while it is the identity (only triangles so far).
  std::vector<uint32_t> source_polygon;
  uint64_t polygons = 0;      // polygons ended so far
  uint64_t triangulated = 0;  // of which had more than 3 corners

  void begin_polygon() { corner_count_ = 0; }

  /// Adds the next corner of the current polygon (a vertex id the reader already range-checked).
  void add_corner(uint32_t vertex) {
    if (corner_count_ == 0) {
      first_ = vertex;
    } else if (corner_count_ >= 2) {
      emit_triangle(first_, previous_, vertex);
    }
    previous_ = vertex;
    ++corner_count_;
  }

  /// Ends the polygon; the reader has checked it had at least 3 corners.
  void end_polygon() {
    if (corner_count_ > 3) ++triangulated;
    ++polygons;
  }

  uint64_t corner_count() const { return corner_count_; }

  void add_triangle(uint32_t a, uint32_t b, uint32_t c) {
    emit_triangle(a, b, c);
    ++polygons;
  }

 private:
  void emit_triangle(uint32_t a, uint32_t b, uint32_t c) {
    const size_t triangle = indices.size() / 3;
    if (source_polygon.empty() && triangle != polygons) {
      // First polygon that yields a second triangle: until now triangle t came from polygon t.
      source_polygon.resize(triangle);
      for (size_t t = 0; t < triangle; ++t) source_polygon[t] = static_cast<uint32_t>(t);
    }
    if (!source_polygon.empty()) source_polygon.push_back(static_cast<uint32_t>(polygons));
    indices.push_back(a);
    indices.push_back(b);
    indices.push_back(c);
  }

  uint64_t corner_count_ = 0;
  uint32_t first_ = 0, previous_ = 0;
};

/// What a reader returns: its triangles and what the file declared.
struct ReadResult {
  RawMesh mesh;
  std::string format;          // ReadStats::format
  uint64_t file_vertices = 0;  // vertices stored in the file
  uint64_t skipped_header_lines = 0, first_skipped_header_line = 0;  // ReadStats'
};

// The readers (io_obj.cpp, io_off.cpp, io_ply.cpp, io_stl.cpp). They throw FileError naming
// file.path and the line or byte of the problem. They check indices and finiteness but do not weld.
ReadResult read_obj(const FileData& file);
ReadResult read_off(const FileData& file);
ReadResult read_ply(const FileData& file);
ReadResult read_stl(const FileData& file);

/// Largest vertex count an index can address (kNone is reserved).
inline constexpr uint64_t kMaxVertices = 0xfffffffeull;
/// Largest triangle count (face ids are uint32 too).
inline constexpr uint64_t kMaxTriangles = 0xfffffffeull;

// ---------------------------------------------------------------------------------------------
// Text scanning

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; }
inline bool is_line_end(char c) { return c == '\n' || c == '\r'; }

/// Walks a text buffer that ends with a NUL byte, counting lines (1-based). "\n", "\r\n" and a lone
/// "\r" each end a line. Tokens are runs of characters other than blanks and line ends.
struct TextCursor {
  const char* p = nullptr;
  const char* end = nullptr;
  uint64_t line = 1;

  TextCursor(const char* begin, const char* end_) : p(begin), end(end_) {}

  bool at_end() const { return p >= end; }

  void skip_blanks() {
    while (p < end && is_blank(*p)) ++p;
  }

  /// True at a line end or at the end of the text (after skipping blanks).
  bool at_line_end() {
    skip_blanks();
    return p >= end || is_line_end(*p);
  }

  /// Moves past the rest of the current line and its line end.
  void next_line() {
    while (p < end && !is_line_end(*p)) ++p;
    if (p < end) {
      if (*p == '\r' && p + 1 < end && p[1] == '\n') ++p;
      ++p;
      ++line;
    }
  }

  /// Next token on the current line (empty at the line end); blanks before it are skipped.
  std::string_view token() {
    skip_blanks();
    const char* start = p;
    while (p < end && !is_blank(*p) && !is_line_end(*p)) ++p;
    return std::string_view(start, static_cast<size_t>(p - start));
  }

  /// The line to report when the text ends early: the last line that has content or a line end.
  uint64_t last_line() const;
};

/// Result of parsing one numeric token.
enum class NumberStatus { ok, not_a_number, not_finite, out_of_range };

/// Parses a whole token as a float (decimal, optional sign and exponent; correctly rounded).
/// "nan"/"inf" give not_finite, values beyond float range out_of_range, anything else with
/// trailing characters not_a_number. Values too small for float become (signed) zero or denormals.
NumberStatus parse_float(std::string_view token, float& value);

/// Parses a whole token as a coordinate: the same statuses as parse_float (a coordinate must fit a
/// float), the value to double precision, nudged by one unit in its last place where rounding the
/// double to float would not give parse_float's correctly rounded float (a double exactly halfway
/// between two floats, from a decimal that was not): static_cast<float>(value) is always what
/// parse_float gives, so a mesh that read_mesh does not move reads exactly as from floats.
NumberStatus parse_coordinate(std::string_view token, double& value);

/// Parses a whole token as a decimal integer with optional sign.
NumberStatus parse_int(std::string_view token, int64_t& value);

/// Parses a whole token as a non-negative decimal integer (a count).
NumberStatus parse_count(std::string_view token, uint64_t& value);

/// Message fragment for a token in an error message: quoted, cut to a reasonable length, with
/// unprintable bytes escaped.
std::string quote(std::string_view token);

/// ASCII case-insensitive comparison.
bool equals_ignoring_case(std::string_view a, std::string_view b);

/// Lower-cased extension including the dot (".ply"), or "" when there is none.
std::string lower_extension(const std::string& path);

// ---------------------------------------------------------------------------------------------
// Binary scanning

/// Reads little- or big-endian scalars from a byte buffer. Callers check `remaining()` first.
template <typename T>
inline T load(const char* p, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) {
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  T value;
  std::memcpy(&value, b, sizeof(T));
  return value;
}

/// True when the host is little-endian (the byte order binary STL and our PLY output use).
bool host_is_little_endian();

// ---------------------------------------------------------------------------------------------
// Output

/// A file written atomically: bytes go to `path.tmp-XXXXXX` in the same directory (mkstemp) through
/// a buffer; commit() closes and renames it onto `path`. If commit() is never reached (an exception),
/// the destructor removes the temporary file. All failures throw FileError naming `path`.
class OutputFile {
 public:
  explicit OutputFile(std::string path);
  ~OutputFile();
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  void write(const void* data, size_t size);
  void write(std::string_view text) { write(text.data(), text.size()); }

  /// Space for at least `size` more bytes in the buffer; call advance() with what was used.
  char* reserve(size_t size);
  void advance(size_t size) { used_ += size; }

  void commit();
  const std::string& path() const { return path_; }

 private:
  void flush();
  [[noreturn]] void fail(const std::string& what, int error_number);

  std::string path_, temp_path_;
  int fd_ = -1;
  std::vector<char> buffer_;
  size_t used_ = 0;
  bool committed_ = false;
};

/// Appends numbers as text to an OutputFile.
class TextWriter {
 public:
  explicit TextWriter(OutputFile& out) : out_(out) {}
  /// 9 significant digits (like %.9g): reading the text back gives the same float bit for bit.
  TextWriter& number(float value);
  TextWriter& number(uint64_t value);
  TextWriter& number(int64_t value);
  /// The shortest decimal that reads back as this double.
  TextWriter& number(double value);
  /// "x y z" of position v (3 floats each) plus `origin`: floats as number(float) does when the
  /// origin is zero, else each double sum as number(double) does.
  TextWriter& position(const float* positions, size_t v, const std::array<double, 3>& origin);
  TextWriter& text(std::string_view text) {
    out_.write(text);
    return *this;
  }
  TextWriter& ch(char c) {
    *out_.reserve(1) = c;
    out_.advance(1);
    return *this;
  }

 private:
  OutputFile& out_;
};

/// Whether an origin moves anything (WriteOptions::origin).
inline bool is_zero(const std::array<double, 3>& origin) { return origin[0] == 0 && origin[1] == 0 && origin[2] == 0; }

// The writers (io_*.cpp); io.cpp has checked the mesh (indices in range, label count).
void write_obj(OutputFile& out, const Mesh& mesh, const WriteOptions& options);
void write_off(OutputFile& out, const Mesh& mesh, const WriteOptions& options);
void write_ply(OutputFile& out, const Mesh& mesh, const WriteOptions& options);
void write_stl(OutputFile& out, const Mesh& mesh, const WriteOptions& options);

}  // namespace meshcvt::io
