// meshcvt: reading and writing meshes (OBJ, OFF, PLY, STL).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "meshcvt/mesh.h"

namespace meshcvt {

/// How a file is turned into a Mesh.
struct ReadOptions {
  /// Merge vertices with bit-identical positions (default). Files exported with split normals or UVs
  /// otherwise fall apart into one component per face. Vertices whose merge would join two edges
  /// that are manifold in the file (two faces each, in opposite directions) into one edge of three
  /// or more faces stay apart (ReadStats::kept_apart_vertices).
  bool weld = true;
  /// Positions are kept as 32-bit floats, which hold a coordinate to about 2^-24 of its magnitude: a
  /// mesh far from the origin for its size (a georeferenced scan in UTM metres: coordinates of 4e6
  /// for a site of 100 m, kept to 0.25-0.5 m) would be rounded to a coarse grid. When true, such a
  /// mesh is moved near the origin as it is read, from the file's values in double precision:
  /// Mesh positions are then file positions less ReadStats::origin, and WriteOptions::origin moves
  /// them back when written. "Far" means the float spacing at the largest coordinate exceeds 1e-5 of
  /// the mesh's extent (the largest side of the box of its referenced vertices); the origin is the
  /// box's centre rounded to a multiple of the largest power of ten not above the extent (of two,
  /// for an extent below 1). A mesh near the origin reads exactly as with false.
  bool shift_far = false;
  /// When set, positions are file positions less this origin, whatever shift_far says: to read a
  /// second mesh into the frame of a first (a reference surface for an error measurement).
  std::optional<std::array<double, 3>> origin;
};

/// What reading did to the file's content, for reports.
struct ReadStats {
  std::string format;                  ///< "obj", "off", "ply-ascii", "ply-binary-le", "ply-binary-be", "stl-ascii", "stl-binary"
  uint64_t file_vertices = 0;          ///< vertices as stored in the file
  uint64_t file_polygons = 0;          ///< faces as stored in the file
  uint64_t triangulated_polygons = 0;  ///< polygons with more than 3 corners that were split
  uint64_t welded_vertices = 0;        ///< vertices merged into an earlier one with the same position
  /// Vertices that share a position with an earlier one but were not welded to it: welding would have
  /// made an edge of three or more faces out of edges that were manifold in the file (a surface that
  /// touches itself along an edge; counted in the mesh's vertices, not in welded_vertices).
  uint64_t kept_apart_vertices = 0;
  uint64_t unreferenced_vertices = 0;  ///< vertices no face uses, dropped
  /// PLY: header lines before the first `element` that start with no PLY keyword (Blender 2.4x
  /// wrote "Created by Blender3D ..." there), skipped; the first one's line number (1-based).
  uint64_t skipped_header_lines = 0;
  uint64_t first_skipped_header_line = 0;
  /// What was subtracted from every file position (ReadOptions::shift_far / origin); zeros when
  /// nothing was.
  std::array<double, 3> origin = {0, 0, 0};
  /// The largest absolute coordinate and the extent (largest side of the bounding box) of the
  /// referenced vertices in the file's own units, as read in double precision.
  double largest_coordinate = 0, extent = 0;
  // file_vertices == mesh.vertex_count() + welded_vertices + unreferenced_vertices.
  // file_polygons counts faces (STL: facets); the mesh has file_polygons triangles plus one more
  // per extra corner of each triangulated polygon.
};

/// Reads a triangle mesh; the format comes from the extension (.obj .off .ply .stl, any case).
/// Polygons are triangulated (fan from the first corner), `Mesh::source_polygon` records where each
/// triangle came from; it is left empty (identity) when every face of the file was a triangle.
/// Vertices keep the file's order (a welded vertex takes the place of its first occurrence);
/// unreferenced vertices are dropped. Positions are converted to float (PLY doubles are rounded),
/// after ReadOptions::shift_far / origin moved them. OFF, ASCII PLY and ASCII STL coordinates are
/// read correctly rounded (to double before a move, to float otherwise); OBJ's by tinyobjloader.
/// OBJ: v/f statements only (v, v/vt, v/vt/vn, v//vn corners, negative = relative indices);
/// OFF: [ST][C][N][n]OFF, data line based; PLY: ascii and binary of either byte order, a `face`
/// element with a `vertex_indices` or `vertex_index` list (a header line before the first element
/// that is no PLY keyword is skipped and counted in ReadStats, an unknown keyword after it is an
/// error); STL: ascii and binary (told apart by size).
/// Throws FileError (file name + line or byte offset + reason) for anything malformed: missing or
/// empty file, truncated data, counts that disagree with the data, indices out of range, NaN/Inf
/// coordinates, non-numeric tokens, faces with fewer than 3 corners, unsupported layouts, and a
/// mesh with no face.
Mesh read_mesh(const std::string& path, const ReadOptions& options = {}, ReadStats* stats = nullptr);

/// Per-face data written along with a mesh.
struct WriteOptions {
  /// Optional cluster id per face (face_count entries). PLY gets an int `cluster` property and
  /// uchar red/green/blue colors, distinct between neighbouring ids; other formats ignore it.
  const std::vector<uint32_t>* face_labels = nullptr;
  /// PLY only: ASCII instead of binary_little_endian.
  bool ascii = false;
  /// Added to every position as it is written (ReadStats::origin of the mesh read): text formats
  /// then write each coordinate as the shortest decimal of the double sum, PLY as `double`
  /// properties; binary STL holds 32-bit floats only, so its coordinates are the sums rounded.
  std::array<double, 3> origin = {0, 0, 0};
};

/// Throws FileError naming `path` unless its extension is one read_mesh and write_mesh know (.obj
/// .off .ply .stl, any case): for a command to check its output names before the work.
void check_mesh_format(const std::string& path);

/// Writes a mesh; the format comes from the extension (.obj .off .ply .stl). The file is written to
/// a temporary name beside `path` and renamed only when complete: a failure leaves no partial file.
/// Text formats write 9 significant digits, so reading the file back gives the same floats (with a
/// non-zero WriteOptions::origin: the shortest decimal that reads back as each double sum).
/// PLY: vertex float x y z (double with a non-zero origin), face `list uchar int vertex_indices`;
/// STL: binary, with facet normals.
/// Throws FileError (cannot create, write or rename; unknown extension), and OptionError before
/// creating anything when the mesh is inconsistent (index out of range, arrays not in threes) or
/// face_labels does not have one entry per face.
void write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

/// Writes text to `path` atomically (temporary file + rename). Throws FileError.
void write_text_file(const std::string& path, const std::string& content);

/// A distinct, stable color for a cluster id (r, g, b), shared by every writer. Consecutive ids get
/// hues about 137 degrees apart (golden ratio); kNone (no cluster) is grey 128.
void cluster_color(uint32_t id, uint8_t rgb[3]);

}  // namespace meshcvt
