// meshcvt: Stanford PLY reader and writer (ascii, binary_little_endian, binary_big_endian).
//
// The header is read into a list of elements and their properties; then the data is walked element
// by element in header order, so any property order, any element order and any extra elements
// work. Only the vertex positions (x, y, z: any scalar type, converted to float) and the face
// element's vertex list (`vertex_indices` or `vertex_index`, any integer count and index type) are
// kept; every other property, list or element is skipped by its declared size. Layouts without a
// face list (point clouds, `tristrips`) are reported as such rather than read as "no faces".
//
// Errors name the header line for header problems, the byte offset for binary data and the line
// for ascii data. Counts are never trusted for allocation: binary elements are checked against the
// bytes left before anything is reserved, ascii reservations are capped by the file size.
// ascii data is line based: one element per line, as every writer does it, so a wrong value count
// is caught on its own line.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "io_internal.h"

namespace meshcvt::io {
namespace {

enum class Type : uint8_t { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

size_t type_size(Type type) {
  switch (type) {
    case Type::int8:
    case Type::uint8:
      return 1;
    case Type::int16:
    case Type::uint16:
      return 2;
    case Type::int32:
    case Type::uint32:
    case Type::float32:
      return 4;
    case Type::float64:
      return 8;
  }
  return 1;
}

bool is_integer(Type type) { return type != Type::float32 && type != Type::float64; }

bool parse_type(std::string_view name, Type& type) {
  struct Name {
    const char* name;
    Type type;
  };
  static const Name kNames[] = {
      {"char", Type::int8},     {"int8", Type::int8},       {"uchar", Type::uint8},    {"uint8", Type::uint8},
      {"short", Type::int16},   {"int16", Type::int16},     {"ushort", Type::uint16},  {"uint16", Type::uint16},
      {"int", Type::int32},     {"int32", Type::int32},     {"uint", Type::uint32},    {"uint32", Type::uint32},
      {"float", Type::float32}, {"float32", Type::float32}, {"double", Type::float64}, {"float64", Type::float64}};
  for (const Name& n : kNames) {
    if (name == n.name) {
      type = n.type;
      return true;
    }
  }
  return false;
}

// What a property is used for.
enum class Role : uint8_t { skip, x, y, z, corners };

struct Property {
  std::string name;
  bool is_list = false;
  Type count_type = Type::uint8;  // lists only
  Type type = Type::float32;      // scalar type, or list item type
  Role role = Role::skip;
  uint64_t line = 0;
};

struct Element {
  std::string name;
  uint64_t count = 0;
  uint64_t line = 0;
  std::vector<Property> properties;
};

enum class Format { ascii, binary_le, binary_be };

struct Header {
  Format format = Format::ascii;
  std::vector<Element> elements;
  size_t data_offset = 0;  // first byte after the end_header line
  uint64_t data_line = 0;  // its line number (ascii)
  int vertex_element = -1, face_element = -1;
};

class PlyReader {
 public:
  explicit PlyReader(const FileData& file) : file_(file) {}

  ReadResult read() {
    read_header();
    check_layout();
    if (header_.format == Format::ascii) {
      read_ascii();
    } else {
      swap_ = (header_.format == Format::binary_le) != host_is_little_endian();
      read_binary();
    }
    ReadResult result;
    result.mesh = std::move(mesh_);
    result.format = header_.format == Format::ascii       ? "ply-ascii"
                    : header_.format == Format::binary_le ? "ply-binary-le"
                                                          : "ply-binary-be";
    result.file_vertices = vertex_count_;
    result.skipped_header_lines = skipped_header_lines_;
    result.first_skipped_header_line = first_skipped_header_line_;
    return result;
  }

 private:
  [[noreturn]] void fail_line(uint64_t line, const std::string& reason) const {
    throw FileError::at_line(file_.path, line, reason);
  }
  [[noreturn]] void fail_byte(uint64_t byte, const std::string& reason) const {
    throw FileError::at_byte(file_.path, byte, reason);
  }

  // ---- header

  void read_header() {
    TextCursor c(file_.begin(), file_.end());
    if (c.token() != "ply" || !c.at_line_end()) fail_line(1, "not a PLY file: the first line must be 'ply'");
    c.next_line();
    bool have_format = false;
    for (;;) {
      if (c.at_end()) fail_line(c.last_line(), "header has no 'end_header' line");
      const uint64_t line = c.line;
      const std::string_view keyword = c.token();
      if (keyword.empty() || keyword == "comment" || keyword == "obj_info") {
        // blank lines are tolerated; comments are skipped
      } else if (keyword == "format") {
        const std::string_view name = c.token();
        const std::string_view version = c.token();
        if (name == "ascii") {
          header_.format = Format::ascii;
        } else if (name == "binary_little_endian") {
          header_.format = Format::binary_le;
        } else if (name == "binary_big_endian") {
          header_.format = Format::binary_be;
        } else {
          fail_line(line, "unknown PLY format " + quote(name));
        }
        if (version.empty() || !c.at_line_end()) fail_line(line, "expected 'format TYPE VERSION'");
        have_format = true;
      } else if (keyword == "element") {
        Element element;
        element.name = std::string(c.token());
        const std::string_view count = c.token();
        if (element.name.empty() || count.empty() || !c.at_line_end()) fail_line(line, "expected 'element NAME COUNT'");
        if (parse_count(count, element.count) != NumberStatus::ok) {
          fail_line(line, "bad element count " + quote(count));
        }
        for (const Element& other : header_.elements) {
          if (other.name == element.name) fail_line(line, "element '" + element.name + "' declared twice");
        }
        element.line = line;
        header_.elements.push_back(std::move(element));
      } else if (keyword == "property") {
        if (header_.elements.empty()) fail_line(line, "property before any element");
        Property property;
        property.line = line;
        std::string_view type = c.token();
        if (type == "list") {
          property.is_list = true;
          const std::string_view count_type = c.token();
          if (!parse_type(count_type, property.count_type))
            fail_line(line, "unknown list count type " + quote(count_type));
          type = c.token();
        }
        if (!parse_type(type, property.type)) fail_line(line, "unknown property type " + quote(type));
        property.name = std::string(c.token());
        if (property.name.empty() || !c.at_line_end()) {
          fail_line(line, "expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
        }
        header_.elements.back().properties.push_back(std::move(property));
      } else if (keyword == "end_header") {
        if (!have_format) fail_line(line, "header has no 'format' line");
        c.next_line();
        header_.data_offset = static_cast<size_t>(c.p - file_.begin());
        header_.data_line = c.line;
        return;
      } else if (header_.elements.empty()) {
        // Not a keyword, before any element: a line some exporters write without `comment`
        // (Blender 2.4x: "Created by Blender3D 247 - www.blender.org, ..."). Skipped and counted;
        // after an element it could be a misspelt property, and stays an error.
        if (skipped_header_lines_++ == 0) first_skipped_header_line_ = line;
      } else {
        fail_line(line, "unknown header keyword " + quote(keyword));
      }
      c.next_line();
    }
  }

  // Finds the vertex positions and the face list, or says why the layout cannot be read.
  void check_layout() {
    const std::vector<Element>& elements = header_.elements;
    for (size_t e = 0; e < elements.size(); ++e) {
      if (elements[e].name == "vertex") header_.vertex_element = static_cast<int>(e);
      if (elements[e].name == "face") header_.face_element = static_cast<int>(e);
    }
    if (header_.face_element < 0) {
      for (const Element& element : elements) {
        if (element.name == "tristrips") {
          fail_line(element.line, "not supported: triangle strips ('tristrips'); only a 'face' element is read");
        }
      }
      throw FileError(file_.path, "no faces (no 'face' element)");
    }
    if (header_.vertex_element < 0) throw FileError(file_.path, "no 'vertex' element");

    Element& vertex = header_.elements[size_t(header_.vertex_element)];
    if (vertex.count > kMaxVertices) fail_line(vertex.line, "too many vertices: " + std::to_string(vertex.count));
    vertex_count_ = vertex.count;
    const char* axes[3] = {"x", "y", "z"};
    for (int axis = 0; axis < 3; ++axis) {
      Property* found = nullptr;
      for (Property& property : vertex.properties) {
        if (property.name == axes[axis]) {
          found = &property;
          break;
        }
      }
      if (!found) fail_line(vertex.line, std::string("vertex element has no '") + axes[axis] + "' property");
      if (found->is_list) fail_line(found->line, std::string("not supported: '") + axes[axis] + "' is a list");
      found->role = static_cast<Role>(static_cast<int>(Role::x) + axis);
    }

    Element& face = header_.elements[size_t(header_.face_element)];
    if (face.count > kMaxTriangles) fail_line(face.line, "too many faces: " + std::to_string(face.count));
    Property* corners = nullptr;
    for (Property& property : face.properties) {
      if (property.name == "vertex_indices" || property.name == "vertex_index") {
        corners = &property;
        break;
      }
    }
    if (!corners || !corners->is_list) {
      fail_line(corners ? corners->line : face.line,
                "not supported: the face element has no 'vertex_indices' (or 'vertex_index') list");
    }
    if (!is_integer(corners->count_type) || !is_integer(corners->type)) {
      fail_line(corners->line, "not supported: face list with non-integer count or index type");
    }
    corners->role = Role::corners;
  }

  // ---- binary data

  int64_t load_integer(Type type, const char* p) const {
    switch (type) {
      case Type::int8:
        return load<int8_t>(p, swap_);
      case Type::uint8:
        return load<uint8_t>(p, swap_);
      case Type::int16:
        return load<int16_t>(p, swap_);
      case Type::uint16:
        return load<uint16_t>(p, swap_);
      case Type::int32:
        return load<int32_t>(p, swap_);
      case Type::uint32:
        return load<uint32_t>(p, swap_);
      case Type::float32:
      case Type::float64:
        break;
    }
    return 0;
  }

  double load_real(Type type, const char* p) const {
    if (type == Type::float32) return load<float>(p, swap_);
    if (type == Type::float64) return load<double>(p, swap_);
    return static_cast<double>(load_integer(type, p));
  }

  size_t left() const { return file_.size - pos_; }

  [[noreturn]] void truncated(size_t instance_start, const Element& element, uint64_t instance) const {
    fail_byte(instance_start, "file ends after " + std::to_string(instance) + " of " + std::to_string(element.count) +
                                  " " + element.name + " elements");
  }

  // Skips a list property at pos_ (its count must fit; checked here).
  void skip_list(const Property& property, size_t start, const Element& element, uint64_t instance) {
    const size_t count_size = type_size(property.count_type);
    if (left() < count_size) truncated(start, element, instance);
    const int64_t n = load_integer(property.count_type, file_.begin() + pos_);
    if (n < 0) fail_byte(pos_, "negative list count " + std::to_string(n));
    pos_ += count_size;
    if (uint64_t(n) > left() / type_size(property.type)) truncated(start, element, instance);
    pos_ += size_t(n) * type_size(property.type);
  }

  // Bytes of the scalar properties of an element, and whether it has lists.
  static size_t fixed_size(const Element& element, bool& has_lists) {
    size_t size = 0;
    has_lists = false;
    for (const Property& property : element.properties) {
      if (property.is_list) {
        has_lists = true;
        size += type_size(property.count_type);  // the least a list can take
      } else {
        size += type_size(property.type);
      }
    }
    return size;
  }

  void read_binary() {
    pos_ = header_.data_offset;
    for (size_t e = 0; e < header_.elements.size(); ++e) {
      const Element& element = header_.elements[e];
      if (int(e) == header_.vertex_element) {
        read_binary_vertices(element);
      } else if (int(e) == header_.face_element) {
        read_binary_faces(element);
      } else {
        skip_binary(element);
      }
    }
    // Trailing line breaks or spaces are harmless; anything else is data the header did not declare.
    for (size_t i = pos_; i < file_.size; ++i) {
      const char c = file_.begin()[i];
      if (c != '\n' && c != '\r' && c != ' ' && c != '\t') {
        fail_byte(pos_, std::to_string(file_.size - pos_) + " bytes after the last element the header declares");
      }
    }
  }

  void skip_binary(const Element& element) {
    bool has_lists = false;
    const size_t size = fixed_size(element, has_lists);
    if (!has_lists) {
      if (size == 0) return;
      if (element.count > left() / size) truncated(pos_ + (left() / size) * size, element, left() / size);
      pos_ += size_t(element.count) * size;
      return;
    }
    // Every instance takes at least one byte (a list count), so this loop ends with the file.
    for (uint64_t i = 0; i < element.count; ++i) {
      const size_t start = pos_;
      for (const Property& property : element.properties) {
        if (property.is_list) {
          skip_list(property, start, element, i);
        } else {
          if (left() < type_size(property.type)) truncated(start, element, i);
          pos_ += type_size(property.type);
        }
      }
    }
  }

  // A position value at byte `at`; non-finite values are errors.
  double position_value(Type type, size_t at) const {
    const double value = load_real(type, file_.begin() + at);
    if (std::isnan(value) || std::isinf(value)) fail_byte(at, "NaN or infinite coordinate");
    if (!std::isfinite(static_cast<float>(value))) fail_byte(at, "coordinate out of float range");
    return value;
  }

  void read_binary_vertices(const Element& element) {
    bool has_lists = false;
    const size_t size = fixed_size(element, has_lists);
    assert(size > 0);  // x, y and z are scalars
    mesh_.positions.reserve(size_t(std::min<uint64_t>(element.count, left() / size)) * 3);
    if (!has_lists) {
      // Fixed stride: check the whole element fits once, then read without per-value checks.
      if (element.count > left() / size) truncated(pos_ + (left() / size) * size, element, left() / size);
      size_t offset[3] = {0, 0, 0};
      Type type[3] = {Type::float32, Type::float32, Type::float32};
      size_t at = 0;
      for (const Property& property : element.properties) {
        if (property.role != Role::skip) {
          const int axis = static_cast<int>(property.role) - static_cast<int>(Role::x);
          offset[axis] = at;
          type[axis] = property.type;
        }
        at += type_size(property.type);
      }
      for (uint64_t i = 0; i < element.count; ++i, pos_ += size) {
        for (int axis = 0; axis < 3; ++axis) mesh_.positions.push_back(position_value(type[axis], pos_ + offset[axis]));
      }
      return;
    }
    for (uint64_t i = 0; i < element.count; ++i) {
      const size_t start = pos_;
      double xyz[3] = {0, 0, 0};
      for (const Property& property : element.properties) {
        if (property.is_list) {
          skip_list(property, start, element, i);
          continue;
        }
        if (left() < type_size(property.type)) truncated(start, element, i);
        if (property.role != Role::skip) {
          xyz[static_cast<int>(property.role) - static_cast<int>(Role::x)] = position_value(property.type, pos_);
        }
        pos_ += type_size(property.type);
      }
      mesh_.positions.insert(mesh_.positions.end(), xyz, xyz + 3);
    }
  }

  [[noreturn]] void index_out_of_range(int64_t index) const {
    fail_byte(pos_, "vertex index " + std::to_string(index) + " out of range: the file has " +
                        std::to_string(vertex_count_) + " vertices");
  }

  void read_binary_faces(const Element& element) {
    bool has_lists = false;
    size_t least = fixed_size(element, has_lists);
    for (const Property& property : element.properties) {
      if (property.role == Role::corners) least += 3 * type_size(property.type);
    }
    mesh_.indices.reserve(size_t(std::min<uint64_t>(element.count, left() / least)) * 3);
    for (uint64_t i = 0; i < element.count; ++i) {
      const size_t start = pos_;
      for (const Property& property : element.properties) {
        if (!property.is_list) {
          if (left() < type_size(property.type)) truncated(start, element, i);
          pos_ += type_size(property.type);
          continue;
        }
        if (property.role != Role::corners) {
          skip_list(property, start, element, i);
          continue;
        }
        const size_t count_size = type_size(property.count_type);
        const size_t index_size = type_size(property.type);
        if (left() < count_size) truncated(start, element, i);
        const int64_t n = load_integer(property.count_type, file_.begin() + pos_);
        if (n == 3 && left() - count_size >= 3 * index_size) {
          // The common case, a triangle, skips the polygon fan bookkeeping.
          pos_ += count_size;
          uint32_t corner[3];
          for (int k = 0; k < 3; ++k, pos_ += index_size) {
            const int64_t index = load_integer(property.type, file_.begin() + pos_);
            if (index < 0 || uint64_t(index) >= vertex_count_) index_out_of_range(index);
            corner[k] = static_cast<uint32_t>(index);
          }
          mesh_.add_triangle(corner[0], corner[1], corner[2]);
          continue;
        }
        if (n < 3) fail_byte(pos_, "face with " + std::to_string(n) + " corners (needs at least 3)");
        pos_ += count_size;
        if (uint64_t(n) > left() / index_size) truncated(start, element, i);
        mesh_.begin_polygon();
        for (int64_t k = 0; k < n; ++k, pos_ += index_size) {
          const int64_t index = load_integer(property.type, file_.begin() + pos_);
          if (index < 0 || uint64_t(index) >= vertex_count_) index_out_of_range(index);
          mesh_.add_corner(static_cast<uint32_t>(index));
        }
        mesh_.end_polygon();
        if (mesh_.indices.size() / 3 > kMaxTriangles) fail_byte(start, "too many triangles");
      }
    }
  }

  // ---- ascii data

  std::string_view value_token(TextCursor& c, uint64_t line, const Element& element) {
    const std::string_view token = c.token();
    if (token.empty()) fail_line(line, "line ends early: " + element.name + " needs more values");
    return token;
  }

  void read_ascii() {
    TextCursor c(file_.begin() + header_.data_offset, file_.end());
    c.line = header_.data_line;
    for (size_t e = 0; e < header_.elements.size(); ++e) {
      const Element& element = header_.elements[e];
      if (element.properties.empty()) continue;  // nothing to read, whatever the count says
      // A lying count must not reserve memory: an ascii vertex or face takes 6 bytes or more.
      const uint64_t fit = std::min<uint64_t>(element.count, file_.size / 6);
      if (int(e) == header_.vertex_element) mesh_.positions.reserve(size_t(fit) * 3);
      if (int(e) == header_.face_element) mesh_.indices.reserve(size_t(fit) * 3);
      for (uint64_t i = 0; i < element.count; ++i) {
        while (!c.at_end() && c.at_line_end()) c.next_line();
        if (c.at_end()) {
          fail_line(c.last_line(), "file ends after " + std::to_string(i) + " of " + std::to_string(element.count) +
                                       " " + element.name + " elements");
        }
        read_ascii_instance(c, element);
      }
    }
    while (!c.at_end() && c.at_line_end()) c.next_line();
    if (!c.at_end()) fail_line(c.line, "more data than the header declares");
  }

  void check_number(std::string_view token, uint64_t line) {
    float ignored;
    if (parse_float(token, ignored) == NumberStatus::not_a_number) fail_line(line, "non-numeric token " + quote(token));
  }

  void read_ascii_instance(TextCursor& c, const Element& element) {
    const uint64_t line = c.line;
    double xyz[3] = {0, 0, 0};
    for (const Property& property : element.properties) {
      if (!property.is_list) {
        const std::string_view token = value_token(c, line, element);
        if (property.role == Role::skip) {
          check_number(token, line);
          continue;
        }
        double value = 0;
        switch (parse_coordinate(token, value)) {
          case NumberStatus::ok:
            break;
          case NumberStatus::not_a_number:
            fail_line(line, "non-numeric token " + quote(token));
          case NumberStatus::not_finite:
            fail_line(line, "NaN or infinite coordinate " + quote(token));
          case NumberStatus::out_of_range:
            fail_line(line, "coordinate out of float range " + quote(token));
        }
        xyz[static_cast<int>(property.role) - static_cast<int>(Role::x)] = value;
        continue;
      }
      const std::string_view count_token = value_token(c, line, element);
      uint64_t n = 0;
      const NumberStatus status = parse_count(count_token, n);
      if (status == NumberStatus::not_a_number) fail_line(line, "bad list count " + quote(count_token));
      if (status != NumberStatus::ok) fail_line(line, "list count out of range " + quote(count_token));
      if (property.role != Role::corners) {
        for (uint64_t k = 0; k < n; ++k) check_number(value_token(c, line, element), line);
        continue;
      }
      if (n < 3) fail_line(line, "face with " + std::to_string(n) + " corners (needs at least 3)");
      mesh_.begin_polygon();
      for (uint64_t k = 0; k < n; ++k) {
        const std::string_view token = value_token(c, line, element);
        int64_t index = 0;
        const NumberStatus index_status = parse_int(token, index);
        if (index_status == NumberStatus::not_a_number) fail_line(line, "non-numeric token " + quote(token));
        if (index_status != NumberStatus::ok || index < 0 || uint64_t(index) >= vertex_count_) {
          fail_line(line, "vertex index " + std::string(token) + " out of range: the file has " +
                              std::to_string(vertex_count_) + " vertices");
        }
        mesh_.add_corner(static_cast<uint32_t>(index));
      }
      mesh_.end_polygon();
      if (mesh_.indices.size() / 3 > kMaxTriangles) fail_line(line, "too many triangles");
    }
    if (!c.at_line_end()) {
      fail_line(line, "more values than the " + element.name + " element declares: " + quote(c.token()));
    }
    c.next_line();
    if (&element == &header_.elements[size_t(header_.vertex_element)]) {
      mesh_.positions.insert(mesh_.positions.end(), xyz, xyz + 3);
    }
  }

  const FileData& file_;
  Header header_;
  bool swap_ = false;
  size_t pos_ = 0;
  uint64_t vertex_count_ = 0;
  uint64_t skipped_header_lines_ = 0, first_skipped_header_line_ = 0;
  RawMesh mesh_;
};

// Little-endian stores for the binary writer.
template <typename T>
inline char* store(char* p, T value) {
  std::memcpy(p, &value, sizeof(T));
  if (!host_is_little_endian()) std::reverse(p, p + sizeof(T));
  return p + sizeof(T);
}

}  // namespace

ReadResult read_ply(const FileData& file) { return PlyReader(file).read(); }

void write_ply(OutputFile& out, const Mesh& mesh, const WriteOptions& options) {
  const size_t vertex_count = mesh.vertex_count();
  const size_t face_count = mesh.face_count();
  const bool labels = options.face_labels != nullptr;
  const bool signed_indices = vertex_count <= 0x7fffffffu;  // "int" is what most tools expect
  std::string header = "ply\nformat ";
  header += options.ascii ? "ascii 1.0\n" : "binary_little_endian 1.0\n";
  header += "comment written by meshcvt\n";
  header += "element vertex " + std::to_string(vertex_count) + "\n";
  const bool doubles = !is_zero(options.origin);  // positions moved back to the file's frame
  header += doubles ? "property double x\nproperty double y\nproperty double z\n"
                    : "property float x\nproperty float y\nproperty float z\n";
  header += "element face " + std::to_string(face_count) + "\n";
  header += signed_indices ? "property list uchar int vertex_indices\n" : "property list uchar uint vertex_indices\n";
  if (labels) header += "property int cluster\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n";
  header += "end_header\n";
  out.write(header);

  if (options.ascii) {
    TextWriter text(out);
    for (size_t v = 0; v < vertex_count; ++v) {
      text.position(mesh.positions.data(), v, options.origin).ch('\n');
    }
    for (size_t f = 0; f < face_count; ++f) {
      text.text("3 ").number(uint64_t(mesh.indices[3 * f])).ch(' ').number(uint64_t(mesh.indices[3 * f + 1]));
      text.ch(' ').number(uint64_t(mesh.indices[3 * f + 2]));
      if (labels) {
        const uint32_t label = (*options.face_labels)[f];
        uint8_t rgb[3];
        cluster_color(label, rgb);
        text.ch(' ').number(label == kNone ? int64_t(-1) : int64_t(label));
        for (const uint8_t channel : rgb) text.ch(' ').number(uint64_t(channel));
      }
      text.ch('\n');
    }
    return;
  }
  for (size_t v = 0; v < vertex_count && !doubles; ++v) {
    char* p = out.reserve(12);
    for (int axis = 0; axis < 3; ++axis) p = store<float>(p, mesh.positions[3 * v + axis]);
    out.advance(12);
  }
  for (size_t v = 0; v < vertex_count && doubles; ++v) {
    char* p = out.reserve(24);
    for (int axis = 0; axis < 3; ++axis)
      p = store<double>(p, options.origin[axis] + double(mesh.positions[3 * v + axis]));
    out.advance(24);
  }
  const size_t face_bytes = 13 + (labels ? 7 : 0);
  for (size_t f = 0; f < face_count; ++f) {
    char* p = out.reserve(face_bytes);
    *p++ = 3;
    for (int corner = 0; corner < 3; ++corner) p = store<uint32_t>(p, mesh.indices[3 * f + corner]);
    if (labels) {
      const uint32_t label = (*options.face_labels)[f];
      p = store<int32_t>(p, label == kNone ? -1 : static_cast<int32_t>(label));
      cluster_color(label, reinterpret_cast<uint8_t*>(p));
    }
    out.advance(face_bytes);
  }
}

}  // namespace meshcvt::io
