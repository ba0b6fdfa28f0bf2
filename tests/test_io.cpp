// Tests for the mesh readers and writers (src/io*.cpp): every accepted variant of each format,
// welding, round trips through every writer, atomic writes, and the position (line or byte) named
// by each kind of malformed input. Binary files are generated here byte by byte.
#include <dirent.h>
#include <doctest/doctest.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "meshcvt/error.h"
#include "meshcvt/io.h"
#include "meshcvt/topology.h"
#include "io_internal.h"

namespace {

using meshcvt::FileError;
using meshcvt::Mesh;
using meshcvt::ReadStats;

std::string data_file(const std::string& name) { return std::string(MESHCVT_TEST_DATA) + "/io/" + name; }

// A fresh directory under the system temp dir, removed with everything in it at the end.
struct TempDir {
  std::string path;
  TempDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "meshcvt-test-io-XXXXXX").string();
    REQUIRE(::mkdtemp(pattern.data()) != nullptr);
    path = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
  std::string file(const std::string& name) const { return path + "/" + name; }
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string p = file(name);
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return p;
  }
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(path))
      names.push_back(entry.path().filename().string());
    return names;
  }
};

// Little/big-endian byte builder for binary PLY and STL files.
struct Bytes {
  std::string data;
  bool big_endian = false;
  template <typename T>
  Bytes& put(T value) {
    char b[sizeof(T)];
    std::memcpy(b, &value, sizeof(T));
    if (big_endian) std::reverse(b, b + sizeof(T));  // tests run on little-endian hosts
    data.append(b, sizeof(T));
    return *this;
  }
  Bytes& text(const std::string& s) {
    data += s;
    return *this;
  }
};

// Reading `path` must fail with a FileError at this kind of position; returns the error.
FileError read_error(const std::string& path, FileError::Where where, uint64_t position = 0) {
  try {
    meshcvt::read_mesh(path);
  } catch (const FileError& e) {
    CHECK(e.file() == path);
    CHECK(std::string(e.what()).find(path) == 0);  // the message starts with the file name
    CHECK(e.where() == where);
    if (where != FileError::Where::none) CHECK(e.position() == position);
    return e;
  } catch (const std::exception& e) {
    FAIL("expected FileError, got: " << e.what());
  }
  FAIL("expected FileError for " << path);
  return FileError(path, "unreachable");
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

std::vector<float> vertex(const Mesh& mesh, uint32_t v) {
  return {mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]};
}

std::vector<uint32_t> face(const Mesh& mesh, size_t f) {
  return {mesh.indices[3 * f], mesh.indices[3 * f + 1], mesh.indices[3 * f + 2]};
}

// The corner positions of every triangle, in order: compares meshes whatever their vertex order.
std::vector<float> triangle_soup(const Mesh& mesh) {
  std::vector<float> soup;
  for (const uint32_t index : mesh.indices) {
    for (int axis = 0; axis < 3; ++axis) soup.push_back(mesh.positions[3 * index + axis]);
  }
  return soup;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// A deterministic test mesh: a bumpy grid with coordinates that need all 9 digits, tiny and large
// magnitudes, and no two vertices at the same place.
Mesh make_grid(int n) {
  Mesh mesh;
  uint32_t state = 12345;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) / 16777216.0f;
  };
  for (int y = 0; y <= n; ++y) {
    for (int x = 0; x <= n; ++x) {
      mesh.positions.push_back(float(x) + next() * 0.1f);
      mesh.positions.push_back(float(y) * 1e-7f + next() * 1e-9f);
      mesh.positions.push_back((next() - 0.5f) * 3e7f);
    }
  }
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n) + 1, d = c + 1;
      mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
    }
  }
  return mesh;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// OBJ

TEST_CASE("io: OBJ quads with negative indices are fanned and mapped to their source polygon") {
  ReadStats stats;
  const Mesh mesh = meshcvt::read_mesh(data_file("quads_negative.obj"), {}, &stats);
  CHECK(stats.format == "obj");
  CHECK(stats.file_vertices == 9);
  CHECK(stats.file_polygons == 7);
  CHECK(stats.triangulated_polygons == 6);
  REQUIRE(mesh.vertex_count() == 9);
  REQUIRE(mesh.face_count() == 13);
  // "f -8 -5 -6 -7" after 8 vertices is the polygon 0 3 2 1, fanned from its first corner.
  CHECK(face(mesh, 0) == std::vector<uint32_t>{0, 3, 2});
  CHECK(face(mesh, 1) == std::vector<uint32_t>{0, 2, 1});
  // "f 5 6 9" uses absolute indices, including the vertex defined after the cube.
  CHECK(face(mesh, 12) == std::vector<uint32_t>{4, 5, 8});
  CHECK(vertex(mesh, 8) == std::vector<float>{0.5f, 0.5f, 2.0f});
  CHECK(mesh.source_polygon == std::vector<uint32_t>{0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6});
}

TEST_CASE("io: OBJ corner forms v, v/vt, v/vt/vn, v//vn; welding merges split vertices") {
  ReadStats stats;
  const Mesh welded = meshcvt::read_mesh(data_file("corner_forms.obj"), {}, &stats);
  CHECK(stats.file_vertices == 6);
  CHECK(stats.welded_vertices == 2);
  CHECK(stats.unreferenced_vertices == 0);
  CHECK(welded.vertex_count() == 4);
  REQUIRE(welded.face_count() == 4);
  CHECK(welded.source_polygon.empty());  // triangles only: identity
  CHECK(face(welded, 0) == std::vector<uint32_t>{0, 1, 2});
  CHECK(face(welded, 1) == std::vector<uint32_t>{3, 2, 1});
  CHECK(face(welded, 2) == std::vector<uint32_t>{0, 1, 2});
  CHECK(face(welded, 3) == std::vector<uint32_t>{3, 2, 1});

  meshcvt::ReadOptions apart;
  apart.weld = false;
  const Mesh split = meshcvt::read_mesh(data_file("corner_forms.obj"), apart, &stats);
  CHECK(stats.welded_vertices == 0);
  CHECK(split.vertex_count() == 6);
  CHECK(face(split, 1) == std::vector<uint32_t>{3, 5, 4});
}

TEST_CASE("io: OBJ malformed input names the line") {
  TempDir dir;
  const auto line = FileError::Where::line;
  const std::string header = "# test\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";  // lines 1-4
  SUBCASE("non-numeric coordinate") {
    const FileError e = read_error(dir.write("a.obj", header + "v 1 2 x\nf 1 2 3\n"), line, 5);
    CHECK(contains(e.reason(), "non-numeric"));
  }
  SUBCASE("trailing garbage in a number") {
    read_error(dir.write("a.obj", header + "v 1 2 3.5abc\nf 1 2 3\n"), line, 5);
  }
  SUBCASE("too few coordinates") { read_error(dir.write("a.obj", header + "\nv 1 2\nf 1 2 3\n"), line, 6); }
  SUBCASE("NaN token") {
    const FileError e = read_error(dir.write("a.obj", header + "v nan 0 0\nf 1 2 3\n"), line, 5);
    CHECK(contains(e.reason(), "NaN"));
  }
  SUBCASE("infinity token") { read_error(dir.write("a.obj", header + "v 0 -inf 0\nf 1 2 3\n"), line, 5); }
  SUBCASE("number beyond float range, found after parsing") {
    read_error(dir.write("a.obj", header + "f 1 2 3\nv 0 0 1e39\n"), line, 6);
  }
  SUBCASE("non-numeric index") { read_error(dir.write("a.obj", header + "f 1 2 3x\n"), line, 5); }
  SUBCASE("index 0") { read_error(dir.write("a.obj", header + "f 0 1 2\n"), line, 5); }
  SUBCASE("absolute index past the last vertex") {
    const FileError e = read_error(dir.write("a.obj", header + "f 1 2 3\nf 1 2 4\n# end\n"), line, 6);
    CHECK(contains(e.reason(), "out of range"));
  }
  SUBCASE("forward reference that a later vertex satisfies is fine, one that none does is not") {
    CHECK(meshcvt::read_mesh(dir.write("ok.obj", header + "f 1 2 4\nv 1 1 0\n")).face_count() == 1);
    read_error(dir.write("a.obj", header + "f 1 2 5\nf 1 2 6\nv 1 1 0\n"), line, 5);
  }
  SUBCASE("relative index before the first vertex") {
    read_error(dir.write("a.obj", header + "f -1 -2 -4\n"), line, 5);
  }
  SUBCASE("huge index") { read_error(dir.write("a.obj", header + "f 1 2 99999999999999999999\n"), line, 5); }
  SUBCASE("texture coordinate index out of range") {
    read_error(dir.write("a.obj", header + "vt 0 0\nf 1/1 2/2 3/1\n"), line, 6);
  }
  SUBCASE("malformed corners") {
    read_error(dir.write("a.obj", header + "f 1/1/1/1 2 3\n"), line, 5);
    read_error(dir.write("b.obj", header + "f 1// 2 3\n"), line, 5);
    read_error(dir.write("c.obj", header + "f /1 2 3\n"), line, 5);
  }
  SUBCASE("face with two corners") {
    const FileError e = read_error(dir.write("a.obj", header + "f 1 2 3\nf 1 2\n"), line, 6);
    CHECK(contains(e.reason(), "corners"));
  }
  SUBCASE("NUL byte") { read_error(dir.write("a.obj", header + std::string("f 1 2 3\0\n", 9)), line, 5); }
  SUBCASE("CR line ends count like LF") {
    read_error(dir.write("a.obj", "v 0 0 0\r\nv 1 0 0\rv 0 1 0\r\nf 1 2 4\n"), line, 4);
  }
  SUBCASE("no faces") {
    const FileError e = read_error(dir.write("a.obj", header + "l 1 2\n"), FileError::Where::none);
    CHECK(contains(e.reason(), "no faces"));
  }
}

// ---------------------------------------------------------------------------------------------
// OFF

TEST_CASE("io: OFF comments, blank lines and counts split over several lines") {
  const Mesh mesh = meshcvt::read_mesh(data_file("comments_split_header.off"));
  REQUIRE(mesh.vertex_count() == 4);
  REQUIRE(mesh.face_count() == 2);
  CHECK(vertex(mesh, 2) == std::vector<float>{1, 1, 0});
  CHECK(face(mesh, 1) == std::vector<uint32_t>{0, 2, 3});
  CHECK(meshcvt::read_mesh(data_file("crlf.off")).face_count() == 1);
}

TEST_CASE("io: OFF variants COFF, NOFF, STCNOFF, nOFF and polygons on a one-line header") {
  ReadStats stats;
  const Mesh coff = meshcvt::read_mesh(data_file("coff_colors.off"), {}, &stats);
  CHECK(stats.format == "off");
  CHECK(coff.face_count() == 2);  // one colored quad
  CHECK(coff.source_polygon == std::vector<uint32_t>{0, 0});
  CHECK(vertex(coff, 3) == std::vector<float>{0, 1, 0});

  const Mesh noff = meshcvt::read_mesh(data_file("noff_normals.off"));
  CHECK(noff.face_count() == 1);
  CHECK(vertex(noff, 1) == std::vector<float>{1, 0, 0});

  const Mesh stc = meshcvt::read_mesh(data_file("stcnoff.off"));
  CHECK(vertex(stc, 2) == std::vector<float>{0, 2, 0});

  CHECK(meshcvt::read_mesh(data_file("ndim.off")).face_count() == 1);

  const Mesh polygons = meshcvt::read_mesh(data_file("polygons_one_line.off"), {}, &stats);
  CHECK(stats.file_polygons == 3);
  CHECK(stats.triangulated_polygons == 2);
  REQUIRE(polygons.face_count() == 2 + 3 + 1);
  CHECK(polygons.source_polygon == std::vector<uint32_t>{0, 0, 1, 1, 1, 2});
  CHECK(face(polygons, 2) == std::vector<uint32_t>{1, 2, 3});
  CHECK(face(polygons, 4) == std::vector<uint32_t>{1, 6, 4});
}

TEST_CASE("io: OFF comments glued to values, lines of blanks and indented comments") {
  TempDir dir;
  const Mesh mesh = meshcvt::read_mesh(dir.write("a.off",
                                                 "OFF#glued to the keyword\n"
                                                 "4 2 0\n"
                                                 " \t \n"
                                                 "0 0 0\n"
                                                 "   # indented comment\n"
                                                 "1 0 0#glued to a coordinate\n"
                                                 "1 1 0\t\n"
                                                 "0 1 0 #\n"
                                                 "\t\n"
                                                 "3 0 1 2#glued to an index\n"
                                                 "3 0 2 3\r\n"
                                                 "  \t# last\n"));
  REQUIRE(mesh.vertex_count() == 4);
  REQUIRE(mesh.face_count() == 2);
  CHECK(vertex(mesh, 1) == std::vector<float>{1, 0, 0});
  CHECK(face(mesh, 0) == std::vector<uint32_t>{0, 1, 2});
  CHECK(face(mesh, 1) == std::vector<uint32_t>{0, 2, 3});
  // A comment cuts a token: "1#2" is the number 1, so the line then lacks a value.
  const FileError e = read_error(dir.write("b.off", "OFF\n3 1 0\n0 0 0\n1#0 0\n0 1 0\n3 0 1 2\n"),
                                 FileError::Where::line, 4);
  CHECK(contains(e.reason(), "1 values, needs 3"));
}

// Plain "3 a b c" lines take a fast path in the OFF reader; the same faces written so that they do
// not (signs, a corner count of another spelling, a polygon) must come out the same.
TEST_CASE("io: OFF face lines read the fast way and the general way agree") {
  TempDir dir;
  const std::string head = "OFF\n5 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n";
  const Mesh plain = meshcvt::read_mesh(dir.write("a.off", head + "3 0 1 2\n3 0 2 3\t\n3 1 4 2 #c\n"));
  const Mesh other = meshcvt::read_mesh(
      dir.write("b.off", head + "+3 +0 1 2\n3\t00 +2 3 255 0 0\n3 1 4 2#c\n"));
  CHECK(plain.indices == other.indices);
  CHECK(plain.indices == std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 1, 4, 2});
}

TEST_CASE("io: OFF malformed input names the line") {
  TempDir dir;
  const auto line = FileError::Where::line;
  const std::string tri = "0 0 0\n1 0 0\n0 1 0\n";
  SUBCASE("fewer vertices than declared") {
    const FileError e = read_error(dir.write("a.off", "OFF\n4 1 0\n" + tri), line, 5);
    CHECK(contains(e.reason(), "3 of 4 vertices"));
  }
  SUBCASE("fewer faces than declared") { read_error(dir.write("a.off", "OFF\n3 2 0\n" + tri + "3 0 1 2\n"), line, 6); }
  SUBCASE("more faces than declared") {
    read_error(dir.write("a.off", "OFF\n3 1 0\n" + tri + "3 0 1 2\n\n3 0 2 1\n"), line, 8);
  }
  SUBCASE("index out of range") { read_error(dir.write("a.off", "OFF\n3 1 0\n" + tri + "3 0 1 3\n"), line, 6); }
  SUBCASE("negative index") { read_error(dir.write("a.off", "OFF\n3 1 0\n" + tri + "3 0 -1 2\n"), line, 6); }
  SUBCASE("face with two corners") { read_error(dir.write("a.off", "OFF\n3 1 0\n" + tri + "2 0 1\n"), line, 6); }
  SUBCASE("face line shorter than its count") {
    read_error(dir.write("a.off", "OFF\n3 1 0\n" + tri + "4 0 1 2\n"), line, 6);
  }
  SUBCASE("non-numeric coordinate") {
    read_error(dir.write("a.off", "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"), line, 4);
  }
  SUBCASE("NaN and infinity") {
    read_error(dir.write("a.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 NaN\n3 0 1 2\n"), line, 5);
    read_error(dir.write("b.off", "OFF\n3 1 0\n0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n"), line, 4);
  }
  SUBCASE("4D and binary OFF are not supported") {
    CHECK(contains(read_error(dir.write("a.off", "4OFF\n3 1 0\n"), line, 1).reason(), "not supported"));
    CHECK(contains(read_error(dir.write("b.off", "OFF BINARY\n"), line, 1).reason(), "not supported"));
  }
  SUBCASE("not an OFF file") { read_error(dir.write("a.off", "\nPLY\n"), line, 2); }
  SUBCASE("missing edge count") { read_error(dir.write("a.off", "OFF\n3 1\n0 0 0\n"), line, 3); }
  SUBCASE("lying count does not allocate") {
    const FileError e = read_error(dir.write("a.off", "OFF\n4000000000 4000000000 0\n" + tri), line, 5);
    CHECK(contains(e.reason(), "file ends"));
  }
  SUBCASE("no faces") { read_error(dir.write("a.off", "OFF\n3 0 0\n" + tri), FileError::Where::none); }
}

// ---------------------------------------------------------------------------------------------
// PLY

TEST_CASE("io: PLY ascii with Windows line ends") {
  TempDir dir;
  const std::string text =
      "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n"
      "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n3 0 1 "
      "2\r\n";
  CHECK(meshcvt::read_mesh(dir.write("a.ply", text)).face_count() == 1);
  // ...and errors still name the right line.
  const std::string bad = text.substr(0, text.size() - 9) + "3 0 1 7\r\n";
  read_error(dir.write("b.ply", bad), FileError::Where::line, 13);
}

TEST_CASE("io: PLY ascii with a quad") {
  ReadStats stats;
  const Mesh mesh = meshcvt::read_mesh(data_file("ascii_quad.ply"), {}, &stats);
  CHECK(stats.format == "ply-ascii");
  CHECK(mesh.face_count() == 3);
  CHECK(mesh.source_polygon == std::vector<uint32_t>{0, 0, 1});
  CHECK(face(mesh, 2) == std::vector<uint32_t>{1, 4, 2});
}

TEST_CASE("io: PLY ascii with shuffled properties, double positions, unknown elements with lists, vertex_index") {
  const Mesh mesh = meshcvt::read_mesh(data_file("ascii_shuffled.ply"));
  REQUIRE(mesh.vertex_count() == 4);
  CHECK(vertex(mesh, 0) == std::vector<float>{0, 0, 0});
  CHECK(vertex(mesh, 1) == std::vector<float>{0, 1, 0});
  CHECK(vertex(mesh, 2) == std::vector<float>{1, 1, 0.5f});
  CHECK(vertex(mesh, 3) == std::vector<float>{0, 0, 0.25f});
  REQUIRE(mesh.face_count() == 2);
  CHECK(face(mesh, 0) == std::vector<uint32_t>{0, 1, 2});
  CHECK(face(mesh, 1) == std::vector<uint32_t>{0, 2, 3});
}

namespace {

// A binary PLY of one quad and one triangle over 5 vertices, with the given types, an unknown
// element with a list before and after, and properties in a shuffled order.
std::string binary_ply(bool big_endian, const std::string& position_type, const std::string& count_type,
                       const std::string& index_type, const std::string& list_name = "vertex_indices") {
  Bytes b;
  b.big_endian = big_endian;
  b.text("ply\nformat ").text(big_endian ? "binary_big_endian" : "binary_little_endian").text(" 1.0\n");
  b.text("element extra 2\nproperty list uchar int values\nproperty short tag\n");
  b.text("element vertex 5\nproperty " + position_type + " y\nproperty uchar red\nproperty " + position_type +
         " x\nproperty list ushort float normals\nproperty " + position_type + " z\n");
  b.text("element face 2\nproperty uint flags\nproperty list " + count_type + " " + index_type + " " + list_name +
         "\n");
  b.text("element tail 1\nproperty list int double values\nend_header\n");
  b.put<uint8_t>(2).put<int32_t>(7).put<int32_t>(8).put<int16_t>(-3);
  b.put<uint8_t>(0).put<int16_t>(4);
  const float xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0.5f, -1.25f}};
  auto put_position = [&](float v) {
    if (position_type == "double") {
      b.put<double>(v);
    } else {
      b.put<float>(v);
    }
  };
  auto put_integer = [&](const std::string& type, int64_t v) {
    if (type == "uchar" || type == "uint8") b.put<uint8_t>(uint8_t(v));
    if (type == "char" || type == "int8") b.put<int8_t>(int8_t(v));
    if (type == "ushort" || type == "uint16") b.put<uint16_t>(uint16_t(v));
    if (type == "short" || type == "int16") b.put<int16_t>(int16_t(v));
    if (type == "uint" || type == "uint32") b.put<uint32_t>(uint32_t(v));
    if (type == "int" || type == "int32") b.put<int32_t>(int32_t(v));
  };
  for (int v = 0; v < 5; ++v) {
    put_position(xyz[v][1]);
    b.put<uint8_t>(uint8_t(v));
    put_position(xyz[v][0]);
    b.put<uint16_t>(v == 2 ? 1 : 0);
    if (v == 2) b.put<float>(1.0f);
    put_position(xyz[v][2]);
  }
  b.put<uint32_t>(0xdeadbeef);
  put_integer(count_type, 4);
  for (const int i : {0, 1, 2, 3}) put_integer(index_type, i);
  b.put<uint32_t>(1);
  put_integer(count_type, 3);
  for (const int i : {1, 4, 2}) put_integer(index_type, i);
  b.put<int32_t>(1).put<double>(3.5);
  return b.data;
}

}  // namespace

TEST_CASE("io: PLY binary little and big endian, every count and index type, any order") {
  TempDir dir;
  const char* count_types[] = {"uchar", "uint8", "char", "ushort", "short", "int", "uint", "int32", "uint32"};
  const char* index_types[] = {"uchar", "int8", "ushort", "uint16", "int", "uint", "int32", "uint32"};
  // Every type in each role, paired round-robin (the full product only costs time).
  for (const bool big : {false, true}) {
    for (const char* position_type : {"float", "double"}) {
      for (size_t i = 0; i < 9; ++i) {
        {
          const char* count_type = count_types[i];
          const char* index_type = index_types[(i + (big ? 3 : 0)) % 8];
          CAPTURE(big);
          CAPTURE(position_type);
          CAPTURE(count_type);
          CAPTURE(index_type);
          const std::string path = dir.write("b.ply", binary_ply(big, position_type, count_type, index_type));
          ReadStats stats;
          const Mesh mesh = meshcvt::read_mesh(path, {}, &stats);
          CHECK(stats.format == (big ? "ply-binary-be" : "ply-binary-le"));
          REQUIRE(mesh.face_count() == 3);
          CHECK(face(mesh, 0) == std::vector<uint32_t>{0, 1, 2});
          CHECK(face(mesh, 2) == std::vector<uint32_t>{1, 4, 2});
          CHECK(vertex(mesh, 4) == std::vector<float>{2, 0.5f, -1.25f});
          CHECK(mesh.source_polygon == std::vector<uint32_t>{0, 0, 1});
        }
      }
    }
  }
  // The face list may also be called vertex_index.
  const std::string path = dir.write("c.ply", binary_ply(false, "float", "uchar", "int", "vertex_index"));
  CHECK(meshcvt::read_mesh(path).face_count() == 3);
  // Windows line ends in the header: the binary data starts after "end_header\r\n".
  const std::string lf = binary_ply(true, "float", "uchar", "int");
  const size_t data_start = lf.find("end_header\n") + 11;
  std::string crlf;
  for (size_t i = 0; i < data_start; ++i) crlf += lf[i] == '\n' ? std::string("\r\n") : std::string(1, lf[i]);
  crlf += lf.substr(data_start);
  const Mesh from_crlf = meshcvt::read_mesh(dir.write("d.ply", crlf));
  CHECK(vertex(from_crlf, 4) == std::vector<float>{2, 0.5f, -1.25f});
}

TEST_CASE("io: PLY malformed input names the header line, data line or byte") {
  TempDir dir;
  const auto line = FileError::Where::line;
  const auto byte = FileError::Where::byte;
  const std::string good = binary_ply(false, "float", "uchar", "int");
  const size_t data_start = good.find("end_header\n") + 11;
  // Layout after the header: extra (1 + 8 + 2, then 1 + 2) = 14 bytes, then 5 vertices of 15 bytes
  // (the third has one float more), then faces: uint flags, uchar count, int indices.
  const size_t vertices_start = data_start + 14;
  const size_t faces_start = vertices_start + 5 * 15 + 4;
  const size_t tail_start = faces_start + (4 + 1 + 16) + (4 + 1 + 12);
  REQUIRE(good.size() == tail_start + 12);

  SUBCASE("truncated in the vertices") {
    const FileError e = read_error(dir.write("a.ply", good.substr(0, vertices_start + 40)), byte, vertices_start + 30);
    CHECK(contains(e.reason(), "2 of 5 vertex"));
  }
  SUBCASE("truncated inside a face list") {
    read_error(dir.write("a.ply", good.substr(0, faces_start + 4 + 1 + 16 + 4 + 1 + 5)), byte, faces_start + 21);
  }
  SUBCASE("truncated in an unknown element") {
    read_error(dir.write("a.ply", good.substr(0, tail_start + 6)), byte, tail_start);
  }
  SUBCASE("more data than declared") {
    const FileError e = read_error(dir.write("a.ply", good + std::string(12, '\x01')), byte, good.size());
    CHECK(contains(e.reason(), "bytes after the last element"));
  }
  SUBCASE("index out of range, at the byte of the index") {
    std::string bad = good;
    const int32_t index = 5;
    std::memcpy(&bad[faces_start + 5 + 8], &index, 4);
    const FileError e = read_error(dir.write("a.ply", bad), byte, faces_start + 5 + 8);
    CHECK(contains(e.reason(), "out of range"));
  }
  SUBCASE("face with two corners, at the byte of the count") {
    std::string bad = good;
    bad[faces_start + 4] = 2;
    read_error(dir.write("a.ply", bad), byte, faces_start + 4);
  }
  SUBCASE("NaN coordinate, at the byte of the value") {
    std::string bad = good;
    const float nan = std::nanf("");
    std::memcpy(&bad[vertices_start + 15 + 5], &nan, 4);  // x of vertex 1
    const FileError e = read_error(dir.write("a.ply", bad), byte, vertices_start + 15 + 5);
    CHECK(contains(e.reason(), "NaN"));
  }
  SUBCASE("lying vertex count is refused without allocating") {
    Bytes b;
    b.text(
        "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
        "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n");
    const size_t start = b.data.size();
    for (int i = 0; i < 9; ++i) b.put<float>(float(i));
    b.put<uint8_t>(3).put<int32_t>(0).put<int32_t>(1).put<int32_t>(2);
    const FileError e = read_error(dir.write("a.ply", b.data), byte, start + 48);  // 4 whole vertices fit
    CHECK(contains(e.reason(), "4 of 4000000000"));
  }

  const std::string ascii_head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";  // 9 lines
  const std::string tri = "0 0 0\n1 0 0\n0 1 0\n";                             // lines 10-12
  SUBCASE("ascii: fewer elements than declared") { read_error(dir.write("a.ply", ascii_head + tri), line, 12); }
  SUBCASE("ascii: more elements than declared") {
    read_error(dir.write("a.ply", ascii_head + tri + "3 0 1 2\n3 2 1 0\n"), line, 14);
  }
  SUBCASE("ascii: extra value on a line") {
    read_error(dir.write("a.ply", ascii_head + "0 0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), line, 10);
  }
  SUBCASE("ascii: missing value on a line") { read_error(dir.write("a.ply", ascii_head + tri + "3 0 1\n"), line, 13); }
  SUBCASE("ascii: index out of range") { read_error(dir.write("a.ply", ascii_head + tri + "3 0 1 3\n"), line, 13); }
  SUBCASE("ascii: face with two corners") { read_error(dir.write("a.ply", ascii_head + tri + "2 0 1\n"), line, 13); }
  SUBCASE("ascii: NaN") { read_error(dir.write("a.ply", ascii_head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"), line, 11); }
  SUBCASE("ascii: non-numeric") {
    read_error(dir.write("a.ply", ascii_head + "0 0 0\n1 0 0\n0 1 O\n3 0 1 2\n"), line, 12);
  }

  SUBCASE("header: tristrips without faces is not supported") {
    const std::string strips =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element tristrips 1\nproperty list int int vertex_indices\nend_header\n" +
        tri + "3 0 1 2\n";
    const FileError e = read_error(dir.write("a.ply", strips), line, 7);
    CHECK(contains(e.reason(), "not supported"));
  }
  SUBCASE("header: face element without a vertex list is not supported") {
    std::string bad = ascii_head;
    bad.replace(bad.find("vertex_indices"), 14, "corner_ids");
    CHECK(contains(read_error(dir.write("a.ply", bad + tri + "3 0 1 2\n"), line, 7).reason(), "not supported"));
  }
  SUBCASE("header: unknown type") {
    std::string bad = ascii_head;
    bad.replace(bad.find("property float y"), 16, "property real y");
    read_error(dir.write("a.ply", bad), line, 5);
  }
  SUBCASE("header: no end_header") {
    read_error(dir.write("a.ply", "ply\nformat ascii 1.0\nelement vertex 0\n"), line, 3);
  }
  SUBCASE("header: not a PLY file") { read_error(dir.write("a.ply", "OFF\n"), line, 1); }
  SUBCASE("header: a line without a keyword before the first element is skipped and counted") {
    // Blender 2.4x wrote its banner without `comment` (assimp-testmodels' PLY/Wuson.ply).
    std::string head = ascii_head;
    head.insert(head.find("element vertex"), "Created by Blender3D 247 - www.blender.org, source file: \nmade 2008\n");
    meshcvt::ReadStats stats;
    const Mesh mesh = meshcvt::read_mesh(dir.write("a.ply", head + tri + "3 0 1 2\n"), {}, &stats);
    CHECK(mesh.face_count() == 1);
    CHECK(stats.skipped_header_lines == 2);
    CHECK(stats.first_skipped_header_line == 3);
    meshcvt::ReadStats plain;
    meshcvt::read_mesh(dir.write("b.ply", ascii_head + tri + "3 0 1 2\n"), {}, &plain);
    CHECK(plain.skipped_header_lines == 0);
  }
  SUBCASE("header: an unknown keyword after an element is an error") {
    std::string bad = ascii_head;
    bad.replace(bad.find("property float y"), 16, "propery float y");  // line 5
    const FileError e = read_error(dir.write("a.ply", bad + tri + "3 0 1 2\n"), line, 5);
    CHECK(contains(e.reason(), "propery"));
  }
  SUBCASE("header: missing y") {
    std::string bad = ascii_head;
    bad.replace(bad.find("property float y\n"), 17, "");
    read_error(dir.write("a.ply", bad), line, 3);
  }
  SUBCASE("no faces") {
    std::string empty = ascii_head;
    empty.replace(empty.find("element face 1"), 14, "element face 0");
    read_error(dir.write("a.ply", empty + tri), FileError::Where::none);
    read_error(dir.write("b.ply",
                         "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                         "property float z\nend_header\n0 0 0\n"),
               FileError::Where::none);
  }
}

// ---------------------------------------------------------------------------------------------
// STL

namespace {

std::string binary_stl(const std::vector<std::vector<float>>& triangles, const std::string& header_text) {
  Bytes b;
  std::string header = header_text;
  header.resize(80, ' ');
  b.text(header).put<uint32_t>(uint32_t(triangles.size()));
  for (const auto& t : triangles) {
    b.put<float>(0).put<float>(0).put<float>(1);
    for (const float v : t) b.put<float>(v);
    b.put<uint16_t>(0);
  }
  return b.data;
}

}  // namespace

TEST_CASE("io: STL ascii and binary are welded into an indexed mesh") {
  TempDir dir;
  ReadStats stats;
  const Mesh ascii = meshcvt::read_mesh(data_file("ascii_facets.stl"), {}, &stats);
  CHECK(stats.format == "stl-ascii");
  CHECK(stats.file_vertices == 6);
  CHECK(stats.welded_vertices == 2);
  CHECK(ascii.vertex_count() == 4);
  CHECK(face(ascii, 1) == std::vector<uint32_t>{0, 2, 3});

  // A binary file whose header starts with "solid" is still binary: its size says so.
  const std::vector<std::vector<float>> square = {{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, -0.0f, 1, 0}};
  const std::string path = dir.write("b.stl", binary_stl(square, "solid but binary"));
  const Mesh binary = meshcvt::read_mesh(path, {}, &stats);
  CHECK(stats.format == "stl-binary");
  CHECK(stats.welded_vertices == 2);
  CHECK(binary.vertex_count() == 4);
  CHECK(face(binary, 1) == std::vector<uint32_t>{0, 2, 3});
  CHECK(std::signbit(binary.positions[9]));  // the first occurrence of (-0, 1, 0) is kept as written

  meshcvt::ReadOptions apart;
  apart.weld = false;
  CHECK(meshcvt::read_mesh(path, apart).vertex_count() == 6);
}

TEST_CASE("io: STL malformed input") {
  TempDir dir;
  const auto byte = FileError::Where::byte;
  const auto line = FileError::Where::line;
  const std::vector<std::vector<float>> two = {{0, 0, 0, 1, 0, 0, 1, 1, 0}, {0, 0, 0, 1, 1, 0, 0, 1, 0}};
  const std::string good = binary_stl(two, "test");
  SUBCASE("truncated binary: the byte where the incomplete triangle starts") {
    const FileError e = read_error(dir.write("a.stl", good.substr(0, 84 + 50 + 20)), byte, 84 + 50);
    CHECK(contains(e.reason(), "1 of 2"));
  }
  SUBCASE("binary with bytes after the declared triangles") {
    read_error(dir.write("a.stl", good + "xyz"), byte, 84 + 100);
  }
  SUBCASE("binary shorter than its header") { read_error(dir.write("a.stl", good.substr(0, 50)), byte, 50); }
  SUBCASE("binary NaN at its byte") {
    std::string bad = good;
    const float inf = INFINITY;
    std::memcpy(&bad[84 + 50 + 12 + 4 * 4], &inf, 4);
    read_error(dir.write("a.stl", bad), byte, 84 + 50 + 12 + 16);
  }
  SUBCASE("binary with no triangles") {
    read_error(dir.write("a.stl", binary_stl({}, "empty")), FileError::Where::none);
  }
  const std::string facet_head = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n";  // lines 1-4
  SUBCASE("ascii non-numeric") {
    read_error(dir.write("a.stl", facet_head + "vertex 1 0 zero\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n"), line,
               5);
  }
  SUBCASE("ascii NaN") {
    read_error(dir.write("a.stl", facet_head + "vertex 1 0 0\nvertex nan 1 0\nendloop\nendfacet\nendsolid t\n"), line,
               6);
  }
  SUBCASE("ascii facet with two vertices") {
    read_error(dir.write("a.stl", facet_head + "vertex 1 0 0\nendloop\nendfacet\nendsolid t\n"), line, 6);
  }
  SUBCASE("ascii truncated") { read_error(dir.write("a.stl", facet_head + "vertex 1 0 0\n"), line, 5); }
  SUBCASE("ascii empty solid") {
    read_error(dir.write("a.stl", "solid empty\nendsolid empty\n"), FileError::Where::none);
  }
}

// ---------------------------------------------------------------------------------------------
// Welding and files

TEST_CASE("io: welding keeps first-occurrence order, merges -0.0 with 0.0, drops unreferenced vertices") {
  TempDir dir;
  // v1 unreferenced, v3 duplicates v0 (as -0), v5 duplicates v2, v6 unreferenced duplicate of v4.
  const std::string path = dir.write("w.obj",
                                     "v 0 0 0\nv 9 9 9\nv 1 0 0\nv -0 0 -0.0\nv 0 1 0\nv 1 0 0\nv 0 1 0\n"
                                     "f 5 4 6\nf 3 5 1\n");
  ReadStats stats;
  const Mesh mesh = meshcvt::read_mesh(path, {}, &stats);
  CHECK(stats.file_vertices == 7);
  CHECK(stats.welded_vertices == 3);
  CHECK(stats.unreferenced_vertices == 1);
  REQUIRE(mesh.vertex_count() == 3);
  // Output order = file order of the first occurrences: (0,0,0), (1,0,0), (0,1,0).
  CHECK(vertex(mesh, 0) == std::vector<float>{0, 0, 0});
  CHECK(vertex(mesh, 1) == std::vector<float>{1, 0, 0});
  CHECK(vertex(mesh, 2) == std::vector<float>{0, 1, 0});
  CHECK(face(mesh, 0) == std::vector<uint32_t>{2, 0, 1});
  CHECK(face(mesh, 1) == std::vector<uint32_t>{1, 2, 0});

  meshcvt::ReadOptions apart;
  apart.weld = false;
  const Mesh split = meshcvt::read_mesh(path, apart, &stats);
  CHECK(stats.welded_vertices == 0);
  CHECK(stats.unreferenced_vertices == 2);  // v1 and v6
  CHECK(split.vertex_count() == 5);
}

// Two closed tetrahedra whose edges P0-P1 lie at the same place. `second_p1` is what the second
// one's faces at P1 use (its vertex 5, or the duplicate 8 in some faces: a seam in the file).
static std::string two_tetrahedra_off(bool seam) {
  std::string off = "OFF\n" + std::string(seam ? "9" : "8") + " 8 0\n";
  // 0-3: the first (P0, P1, apex, apex); 4-7: the second (P0, P1 again, its apexes elsewhere).
  off += "0 0 0\n1 0 0\n0.5 1 0.2\n0.5 0.3 1\n0 0 0\n1 0 0\n0.5 -1 0.2\n0.5 -0.3 -1\n";
  if (seam) off += "1 0 0\n";
  off += "3 0 1 2\n3 0 3 1\n3 0 2 3\n3 1 3 2\n";  // outward, consistently oriented
  off += seam ? "3 4 6 5\n3 4 5 7\n3 4 7 6\n3 8 6 7\n" : "3 4 6 5\n3 4 5 7\n3 4 7 6\n3 5 6 7\n";
  return off;
}

TEST_CASE("io: welding leaves apart the vertices that would make a manifold edge of the file non-manifold") {
  TempDir dir;
  ReadStats stats;
  SUBCASE("two closed parts touching along an edge stay two closed parts") {
    const Mesh mesh = meshcvt::read_mesh(dir.write("t.off", two_tetrahedra_off(false)), {}, &stats);
    CHECK(stats.welded_vertices == 0);
    CHECK(stats.kept_apart_vertices == 2);
    CHECK(mesh.vertex_count() == 8);
    const meshcvt::Topology t = meshcvt::build_topology(mesh);
    CHECK(t.nonmanifold_edges == 0);
    CHECK(t.nonmanifold_vertices == 0);
    CHECK(t.component_count == 2);
    CHECK(t.boundary_edges == 0);
  }
  SUBCASE("the same as STL facets: nothing was shared in the file, so the weld stands") {
    const Mesh tets = meshcvt::read_mesh(dir.write("t.off", two_tetrahedra_off(false)), {}, &stats);
    std::string stl = "solid t\n";
    for (size_t f = 0; f < tets.face_count(); ++f) {
      stl += "facet normal 0 0 0\nouter loop\n";
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = tets.indices[3 * f + k];
        stl += "vertex " + std::to_string(tets.positions[3 * v]) + " " + std::to_string(tets.positions[3 * v + 1]) +
               " " + std::to_string(tets.positions[3 * v + 2]) + "\n";
      }
      stl += "endloop\nendfacet\n";
    }
    const Mesh mesh = meshcvt::read_mesh(dir.write("t.stl", stl + "endsolid t\n"), {}, &stats);
    CHECK(stats.kept_apart_vertices == 0);
    CHECK(mesh.vertex_count() == 6);
    CHECK(meshcvt::build_topology(mesh).nonmanifold_edges == 1);
  }
  SUBCASE("a vertex the weld also needs to close a seam stays welded") {
    const Mesh mesh = meshcvt::read_mesh(dir.write("t.off", two_tetrahedra_off(true)), {}, &stats);
    CHECK(stats.kept_apart_vertices == 0);
    CHECK(stats.welded_vertices == 3);
    const meshcvt::Topology t = meshcvt::build_topology(mesh);
    CHECK(t.boundary_edges == 0);  // the second tetrahedron's seam closed
    CHECK(t.nonmanifold_edges == 1);
  }
  SUBCASE("a grid whose corners were all moved onto three points welds as before") {
    // (A damaged corner.off from bench/pipeline_stress.py. Kept apart, its vertices would leave
    // faces of no area with distinct corners; before the check looked at the positions, every
    // vertex kept apart made the next faces seem whole, and 6 came apart.)
    const std::string damaged =
        "OFF\n16 29 0\n"
        "1.0 0.0 0.0\n1.0 0.0 0.0\n1.0 1.0 0.0\n1.0 1.0 0.0\n2.0 0.0 1.0\n2.0 0.0 1.0\n"
        "1.0 0.0 0.0\n1.0 0.0 0.0\n1.0 0.0 0.0\n1.0 1.0 0.0\n1.0 0.0 0.0\n1.0 0.0 0.0\n"
        "1.0 0.0 0.0\n1.0 0.0 0.0\n1.0 0.0 0.0\n1.0 0.0 0.0\n"
        "3 0 1 4\n3 0 4 3\n3 1 2 5\n3 1 5 4\n3 3 4 7\n3 3 7 6\n3 8 9 1\n3 8 1 0\n3 9 10 2\n"
        "3 9 2 1\n3 2 10 13\n3 2 13 5\n3 4 5 13\n3 4 13 12\n3 4 12 15\n3 4 15 7\n3 6 7 15\n"
        "3 6 15 14\n3 3 6 14\n3 3 14 11\n3 0 3 11\n3 0 11 8\n3 11 14 15\n3 11 15 12\n3 8 11 12\n"
        "3 8 12 9\n3 9 12 13\n3 9 13 10\n3 3 6 14\n";
    const Mesh mesh = meshcvt::read_mesh(dir.write("d.off", damaged), {}, &stats);
    CHECK(stats.kept_apart_vertices == 0);
    CHECK(stats.welded_vertices == 13);
    CHECK(meshcvt::build_topology(mesh).collapsed_faces == 25);
  }
  SUBCASE("a sliver face the weld collapses is collapsed, its neighbours joined") {
    // A tetrahedron whose edge 0-1 was split at a point m (vertex 4) at vertex 0's position: the
    // faces 0-m-2 and m-0-3 have no area; welding m into 0 collapses them and gives back the
    // tetrahedron's edge 0-1 between its other two faces there.
    const Mesh mesh = meshcvt::read_mesh(dir.write("s.off",
                                                   "OFF\n5 6 0\n0 0 0\n1 0 0\n0.5 1 0.2\n0.5 0.3 1\n0 0 0\n"
                                                   "3 0 4 2\n3 4 1 2\n3 1 4 3\n3 4 0 3\n3 0 2 3\n3 1 3 2\n"),
                                         {}, &stats);
    CHECK(stats.welded_vertices == 1);
    CHECK(stats.kept_apart_vertices == 0);
    const meshcvt::Topology t = meshcvt::build_topology(mesh);
    CHECK(t.collapsed_faces == 2);
  }
}

TEST_CASE("io: the 5.5k-face elephant reads with all its vertices and faces") {
  ReadStats stats;
  const Mesh mesh = meshcvt::read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off", {}, &stats);
  CHECK(mesh.face_count() == 5558);
  CHECK(mesh.vertex_count() == 2775);
  CHECK(stats.unreferenced_vertices == 0);
}

TEST_CASE("io: every writer round-trips the mesh exactly") {
  TempDir dir;
  const Mesh original = make_grid(12);
  for (const char* name : {"m.obj", "m.off", "m.ply", "m.stl", "M.PLY"}) {
    CAPTURE(name);
    const std::string path = dir.file(name);
    meshcvt::write_mesh(path, original);
    const Mesh back = meshcvt::read_mesh(path);
    CHECK(same_bits(triangle_soup(back), triangle_soup(original)));
    if (std::string(name) != "m.stl") {  // STL renumbers vertices by first use
      CHECK(same_bits(back.positions, original.positions));
      CHECK(back.indices == original.indices);
    }
  }
  meshcvt::WriteOptions ascii;
  ascii.ascii = true;
  meshcvt::write_mesh(dir.file("a.ply"), original, ascii);
  ReadStats stats;
  const Mesh back = meshcvt::read_mesh(dir.file("a.ply"), {}, &stats);
  CHECK(stats.format == "ply-ascii");
  CHECK(same_bits(back.positions, original.positions));
  CHECK(back.indices == original.indices);
  // Nothing but the outputs is left in the directory (no temporary files).
  CHECK(dir.entries().size() == 6);
}

TEST_CASE("io: PLY face labels carry the cluster id and its color") {
  TempDir dir;
  const Mesh mesh = make_grid(2);  // 8 faces
  const std::vector<uint32_t> labels = {0, 0, 1, 1, 2, 7, meshcvt::kNone, 3};
  meshcvt::WriteOptions options;
  options.face_labels = &labels;
  options.ascii = true;
  meshcvt::write_mesh(dir.file("l.ply"), mesh, options);
  std::ifstream in(dir.file("l.ply"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(contains(text, "property int cluster\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"));
  // The last face line: "3 a b c 3 R G B".
  std::istringstream lines(text.substr(text.rfind("\n3 ", text.size() - 2) + 1));
  int count, a, b, c, cluster, r, g, bl;
  lines >> count >> a >> b >> c >> cluster >> r >> g >> bl;
  uint8_t rgb[3];
  meshcvt::cluster_color(3, rgb);
  CHECK(cluster == 3);
  CHECK(r == rgb[0]);
  CHECK(g == rgb[1]);
  CHECK(bl == rgb[2]);
  CHECK(contains(text, " -1 128 128 128\n"));  // unlabeled face
  // Binary labels read back as a valid mesh (the extra properties are skipped).
  options.ascii = false;
  meshcvt::write_mesh(dir.file("b.ply"), mesh, options);
  CHECK(meshcvt::read_mesh(dir.file("b.ply")).indices == mesh.indices);
  // A label count that does not match is refused before any file is created.
  const std::vector<uint32_t> short_labels = {0, 1};
  options.face_labels = &short_labels;
  CHECK_THROWS_AS(meshcvt::write_mesh(dir.file("c.ply"), mesh, options), meshcvt::OptionError);
  CHECK(!std::filesystem::exists(dir.file("c.ply")));
}

TEST_CASE("io: cluster colors are stable and distinct") {
  uint8_t a[3], b[3];
  std::set<uint32_t> seen;
  for (uint32_t id = 0; id < 64; ++id) {
    meshcvt::cluster_color(id, a);
    meshcvt::cluster_color(id, b);
    CHECK(std::memcmp(a, b, 3) == 0);
    seen.insert(uint32_t(a[0]) << 16 | uint32_t(a[1]) << 8 | a[2]);
  }
  CHECK(seen.size() == 64);
  // Consecutive ids (typical of neighbouring seeds) differ clearly.
  int closest = 1 << 30;
  for (uint32_t id = 0; id < 1000; ++id) {
    meshcvt::cluster_color(id, a);
    meshcvt::cluster_color(id + 1, b);
    int d = 0;
    for (int k = 0; k < 3; ++k) d += (int(a[k]) - int(b[k])) * (int(a[k]) - int(b[k]));
    closest = std::min(closest, d);
  }
  CHECK(closest > 40 * 40);
}

TEST_CASE("io: missing, empty, directory and unknown-extension inputs") {
  TempDir dir;
  const auto none = FileError::Where::none;
  CHECK(contains(read_error(dir.file("missing.obj"), none).reason(), "cannot open"));
  for (const char* name : {"e.obj", "e.off", "e.ply", "e.stl"}) {
    CHECK(contains(read_error(dir.write(name, ""), none).reason(), "empty"));
  }
  std::filesystem::create_directory(dir.file("d.ply"));
  CHECK(contains(read_error(dir.file("d.ply"), none).reason(), "directory"));
  CHECK(contains(read_error(dir.write("m.xyz", "x"), none).reason(), "unknown mesh format"));
}

TEST_CASE("io: a failed write leaves no file behind") {
  TempDir dir;
  const Mesh mesh = make_grid(2);
  // Directory that does not exist: nothing can be created.
  CHECK_THROWS_AS(meshcvt::write_mesh(dir.file("nowhere/m.ply"), mesh), FileError);
  // Target is a directory: the data is written, the rename fails, the temporary must go.
  std::filesystem::create_directory(dir.file("taken.obj"));
  try {
    meshcvt::write_mesh(dir.file("taken.obj"), mesh);
    FAIL("expected FileError");
  } catch (const FileError& e) {
    CHECK(e.file() == dir.file("taken.obj"));
  }
  CHECK(dir.entries() == std::vector<std::string>{"taken.obj"});
  CHECK(std::filesystem::is_empty(dir.file("taken.obj")));
  CHECK_THROWS_AS(meshcvt::write_mesh(dir.file("m.dat"), mesh), FileError);
  CHECK_THROWS_AS(meshcvt::write_text_file(dir.file("nowhere/x.txt"), "x"), FileError);
  CHECK(dir.entries() == std::vector<std::string>{"taken.obj"});
  // An existing file is replaced whole.
  meshcvt::write_text_file(dir.file("t.txt"), "first version, longer\n");
  meshcvt::write_text_file(dir.file("t.txt"), "second\n");
  std::ifstream in(dir.file("t.txt"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(text == "second\n");
}

// ---------------------------------------------------------------------------------------------
// Meshes far from the origin (ReadOptions::shift_far, WriteOptions::origin)

namespace {

// The elephant of tests/data scaled to 100 units: the near mesh whose far copies the tests write.
Mesh scaled_elephant() {
  Mesh mesh = meshcvt::read_mesh(std::string(MESHCVT_TEST_DATA) + "/elephant.off");
  for (float& x : mesh.positions) x *= 100;
  return mesh;
}

std::string shortest(double x) {
  char buf[32];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

// `mesh` moved by `shift` (each coordinate double(p) + shift, exactly as written) in FORMAT: "obj",
// "off", "ply" (ascii), "plyd" (binary, double x y z), "stl" (ascii: every facet lists its corners).
std::string far_file(const Mesh& mesh, const double shift[3], const std::string& format) {
  auto coordinate = [&](size_t v, int k) { return double(mesh.positions[3 * v + k]) + shift[k]; };
  auto line = [&](size_t v) {
    return shortest(coordinate(v, 0)) + " " + shortest(coordinate(v, 1)) + " " + shortest(coordinate(v, 2));
  };
  std::string s;
  const size_t nv = mesh.vertex_count(), nf = mesh.face_count();
  if (format == "stl") {
    s = "solid far\n";
    for (size_t f = 0; f < nf; ++f) {
      s += "facet normal 0 0 1\nouter loop\n";
      for (int c = 0; c < 3; ++c) s += "vertex " + line(mesh.indices[3 * f + c]) + "\n";
      s += "endloop\nendfacet\n";
    }
    return s + "endsolid far\n";
  }
  if (format == "plyd") {
    Bytes b;
    b.text("ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(nv) +
           "\nproperty double x\nproperty double y\nproperty double z\nelement face " + std::to_string(nf) +
           "\nproperty list uchar int vertex_indices\nend_header\n");
    for (size_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k) b.put<double>(coordinate(v, k));
    for (size_t f = 0; f < nf; ++f) {
      b.put<uint8_t>(3);
      for (int c = 0; c < 3; ++c) b.put<int32_t>(int32_t(mesh.indices[3 * f + c]));
    }
    return b.data;
  }
  if (format == "off") s = "OFF\n" + std::to_string(nv) + " " + std::to_string(nf) + " 0\n";
  if (format == "ply")
    s = "ply\nformat ascii 1.0\nelement vertex " + std::to_string(nv) +
        "\nproperty double x\nproperty double y\nproperty double z\nelement face " + std::to_string(nf) +
        "\nproperty list uchar int vertex_indices\nend_header\n";
  for (size_t v = 0; v < nv; ++v) s += (format == "obj" ? "v " : "") + line(v) + "\n";
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t* t = &mesh.indices[3 * f];
    if (format == "obj")
      s += "f " + std::to_string(t[0] + 1) + " " + std::to_string(t[1] + 1) + " " + std::to_string(t[2] + 1) + "\n";
    else
      s += "3 " + std::to_string(t[0]) + " " + std::to_string(t[1]) + " " + std::to_string(t[2]) + "\n";
  }
  return s;
}

// The largest difference between a coordinate of `read` (plus `origin`) and the same of `near`
// plus `shift`, corner by corner of their triangles (STL numbers its vertices its own way), in
// double.
double largest_offset(const Mesh& read, const std::array<double, 3>& origin, const Mesh& near, const double shift[3]) {
  REQUIRE(read.indices.size() == near.indices.size());
  double worst = 0;
  for (size_t i = 0; i < read.indices.size(); ++i)
    for (int k = 0; k < 3; ++k)
      worst = std::max(worst, std::fabs((origin[k] + double(read.positions[3 * read.indices[i] + k])) -
                                        (double(near.positions[3 * near.indices[i] + k]) + shift[k])));
  return worst;
}

}  // namespace

TEST_CASE("io: a mesh far from the origin is moved near it as read, from doubles, and written back in place") {
  TempDir dir;
  const Mesh near = scaled_elephant();  // about 100 units across
  // A georeferenced site in UTM metres: floats there are 0.25-0.5 apart.
  const double utm[3] = {412345.0, 5312345.0, 231.5};
  for (const std::string format : {"obj", "off", "ply", "plyd", "stl"}) {
    CAPTURE(format);
    const std::string path =
        dir.write("far-" + format + (format == "plyd" ? ".ply" : "." + format), far_file(near, utm, format));
    meshcvt::ReadOptions shifted;
    shifted.shift_far = true;
    ReadStats stats;
    const Mesh mesh = meshcvt::read_mesh(path, shifted, &stats);
    if (format != "stl") CHECK(mesh.indices == near.indices);  // (STL numbers vertices by first use)
    // The origin is the box's centre rounded to a multiple of 100 (the extent is 100 and a hair):
    // the moved positions are within about 100 of 0, where floats are 7.6e-6 apart.
    CHECK(stats.extent >= 100);
    CHECK(stats.extent < 101);
    CHECK(stats.largest_coordinate > 5.3e6);
    for (int k = 0; k < 3; ++k) {
      CHECK(std::fmod(stats.origin[k], 100.0) == 0);
      CHECK(std::fabs(stats.origin[k] - utm[k]) < 100);
    }
    CHECK(largest_offset(mesh, stats.origin, near, utm) < 4e-6);
    // Unmoved, the same file keeps its coordinates only to the floats' 0.25-0.5 spacing up there.
    ReadStats plain_stats;
    const Mesh plain = meshcvt::read_mesh(path, {}, &plain_stats);
    CHECK(plain_stats.origin == std::array<double, 3>{0, 0, 0});
    CHECK(largest_offset(plain, plain_stats.origin, near, utm) > 0.1);
    // A given origin is used as it is.
    meshcvt::ReadOptions given;
    given.origin = std::array<double, 3>{412000, 5312000, 0};
    ReadStats given_stats;
    const Mesh in_given = meshcvt::read_mesh(path, given, &given_stats);
    CHECK(given_stats.origin == *given.origin);
    CHECK(largest_offset(in_given, given_stats.origin, near, utm) < 4e-5);  // within ~500 of 0
  }

  // Written with its origin, the mesh is back in place: to the double, in every format but binary
  // STL (floats: the format's own limit); read again it moves by the same origin.
  ReadStats stats;
  meshcvt::ReadOptions shifted;
  shifted.shift_far = true;
  const Mesh mesh = meshcvt::read_mesh(dir.write("far.off", far_file(near, utm, "off")), shifted, &stats);
  meshcvt::WriteOptions back;
  back.origin = stats.origin;
  for (const char* name : {"b.obj", "b.off", "b.ply", "b-ascii.ply", "b.stl"}) {
    CAPTURE(name);
    back.ascii = std::string(name) == "b-ascii.ply";
    meshcvt::write_mesh(dir.file(name), mesh, back);
    ReadStats again_stats;
    const Mesh again = meshcvt::read_mesh(dir.file(name), shifted, &again_stats);
    CHECK(again_stats.origin == stats.origin);
    if (std::string(name) == "b.stl") {
      CHECK(again.face_count() == mesh.face_count());
      CHECK(largest_offset(meshcvt::read_mesh(dir.file(name)), {0, 0, 0}, near, utm) < 0.5);
      continue;
    }
    CHECK(again.indices == mesh.indices);
    for (size_t i = 0; i < mesh.positions.size(); ++i)
      CHECK(std::fabs(double(again.positions[i]) - double(mesh.positions[i])) <= 1e-9);
  }
  // A PLY written with an origin holds doubles.
  std::ifstream ply(dir.file("b.ply"), std::ios::binary);
  std::string header(200, '\0');
  ply.read(header.data(), 200);
  CHECK(contains(header, "property double x\nproperty double y\nproperty double z\n"));
}

TEST_CASE("io: a mesh near the origin reads the same floats whether or not far meshes move") {
  TempDir dir;
  const Mesh near = scaled_elephant();
  const double none[3] = {0, 0, 0}, close[3] = {40, -20, 7};  // float spacing 4e-6 of 100: not far
  for (const double* shift : {none, close})
    for (const std::string format : {"obj", "off", "ply", "plyd", "stl"}) {
      CAPTURE(format);
      const std::string path = dir.write("m-" + format + (format == "plyd" ? ".ply" : "." + format),
                                         far_file(near, shift, format));
      meshcvt::ReadOptions shifted;
      shifted.shift_far = true;
      ReadStats stats;
      const Mesh a = meshcvt::read_mesh(path, shifted, &stats), b = meshcvt::read_mesh(path);
      CHECK(stats.origin == std::array<double, 3>{0, 0, 0});
      CHECK(same_bits(a.positions, b.positions));
      CHECK(a.indices == b.indices);
    }
}

TEST_CASE("io: coordinates read to double round to the floats parse_float gives") {
  using meshcvt::io::NumberStatus;
  // Decimals a hair off the midpoint between two floats: the nearest double is the midpoint
  // itself, and rounding it to float (ties to even) would go the wrong way for two of them.
  const char* tokens[] = {
      "1.0000000596046447753906250001",   // above 1 + 2^-24: 1 + 2^-23 (even rounding says 1)
      "1.0000000596046447753906249999",   // below: 1
      "1.000000059604644775390625",       // the midpoint: ties to even, 1
      "1.0000001788139343261718749999",   // below 1 + 3 * 2^-24: 1 + 2^-23 (even rounding says 1 + 2^-22)
      "-1.0000001788139343261718750001",  // above in magnitude: -(1 + 2^-22)
      "412345.03125000000000000000001",
      "0", "-0", "+2.5", "1e-40", "-1e-45", "3.4028235e38", "1e-400"};
  for (const char* token : tokens) {
    CAPTURE(token);
    float single = 0;
    double value = 0;
    REQUIRE(meshcvt::io::parse_float(token, single) == NumberStatus::ok);
    REQUIRE(meshcvt::io::parse_coordinate(token, value) == NumberStatus::ok);
    const float rounded = static_cast<float>(value);
    CHECK(std::memcmp(&rounded, &single, sizeof(float)) == 0);
  }
  // Many random decimals of 9 to 20 digits agree too.
  uint64_t state = 7;
  auto next = [&] { return state = state * 6364136223846793005ull + 1442695040888963407ull; };
  for (int i = 0; i < 200000; ++i) {
    std::string token = (next() >> 63) ? "-" : "";
    const int digits = 9 + int((next() >> 33) % 12), dot = 1 + int((next() >> 40) % 7);
    for (int d = 0; d < digits; ++d) {
      if (d == dot) token += '.';
      token += char('0' + (next() >> 33) % 10);
    }
    token += 'e';
    token += std::to_string(int((next() >> 33) % 56) - 30);
    float single = 0;
    double value = 0;
    REQUIRE(meshcvt::io::parse_float(token, single) == NumberStatus::ok);
    REQUIRE(meshcvt::io::parse_coordinate(token, value) == NumberStatus::ok);
    CHECK(static_cast<float>(value) == single);
  }
  // The same refusals.
  double value = 0;
  CHECK(meshcvt::io::parse_coordinate("1e39", value) == NumberStatus::out_of_range);
  CHECK(meshcvt::io::parse_coordinate("nan", value) == NumberStatus::not_finite);
  CHECK(meshcvt::io::parse_coordinate("1.5x", value) == NumberStatus::not_a_number);
  CHECK(meshcvt::io::parse_coordinate("+-1", value) == NumberStatus::not_a_number);
}
