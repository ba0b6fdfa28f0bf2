// meshcvt: mesh file I/O front end. Picks the reader or writer from the file extension, turns a
// reader's raw triangles into a Mesh (welding vertices with identical positions, dropping
// unreferenced vertices, both keeping first-occurrence order), writes files atomically
// (temporary file + rename) and hosts the number and token helpers the format files share.
#include "meshcvt/io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cassert>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <system_error>
#include <utility>

#include "io_internal.h"

namespace meshcvt {
namespace io {

// ---------------------------------------------------------------------------------------------
// Reading files

static std::string error_text(int error_number) { return std::strerror(error_number); }

FileData read_file(const std::string& path) {
  FileData file;
  file.path = path;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw FileError(path, "cannot open: " + error_text(errno));
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};

  struct stat info;
  if (::fstat(fd, &info) != 0) throw FileError(path, "cannot read: " + error_text(errno));
  if (S_ISDIR(info.st_mode)) throw FileError(path, "cannot read: is a directory");

  // Regular files are read in one go into a buffer of their size; pipes and other special files
  // (st_size 0) grow the buffer as they go.
  size_t capacity = S_ISREG(info.st_mode) ? static_cast<size_t>(info.st_size) : size_t(1) << 16;
  try {
    file.bytes.reset(new char[capacity + 1]);
  } catch (const std::bad_alloc&) {
    throw FileError(path, "not enough memory to read " + std::to_string(capacity) + " bytes");
  }
  for (;;) {
    if (file.size == capacity) {
      if (S_ISREG(info.st_mode)) {
        // The file may have grown since fstat; peek one byte to find out.
        char probe;
        const ssize_t got = ::read(fd, &probe, 1);
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) throw FileError(path, "cannot read: " + error_text(errno));
        if (got == 0) break;
        const size_t grown = capacity * 2 + 4096;
        std::unique_ptr<char[]> bigger(new char[grown + 1]);
        std::memcpy(bigger.get(), file.bytes.get(), file.size);
        bigger[file.size++] = probe;
        file.bytes = std::move(bigger);
        capacity = grown;
        continue;
      }
      const size_t grown = capacity * 2;
      std::unique_ptr<char[]> bigger(new char[grown + 1]);
      std::memcpy(bigger.get(), file.bytes.get(), file.size);
      file.bytes = std::move(bigger);
      capacity = grown;
    }
    const ssize_t got = ::read(fd, file.bytes.get() + file.size, capacity - file.size);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw FileError(path, "cannot read: " + error_text(errno));
    if (got == 0) break;
    file.size += static_cast<size_t>(got);
  }
  file.bytes[file.size] = '\0';
  if (file.size == 0) throw FileError(path, "empty file");
  return file;
}

// ---------------------------------------------------------------------------------------------
// Tokens and numbers

uint64_t TextCursor::last_line() const {
  // At the end of a text that ends with a line break, `line` already counts the empty line after
  // it; an editor shows the break as the end of the previous line.
  if (line > 1 && p >= end && is_line_end(end[-1])) return line - 1;
  return line;
}

// True when a syntactically valid decimal float token (as from_chars accepted it) has a magnitude
// below 1, i.e. an out-of-range result is an underflow rather than an overflow.
static bool decimal_magnitude_below_one(std::string_view token) {
  size_t i = 0;
  if (i < token.size() && (token[i] == '+' || token[i] == '-')) ++i;
  int64_t exponent10 = -1;  // decimal exponent of the first non-zero digit
  bool seen_nonzero = false, in_fraction = false;
  int64_t integer_digits = 0, leading_fraction_zeros = 0;
  for (; i < token.size(); ++i) {
    const char c = token[i];
    if (c == '.') {
      in_fraction = true;
    } else if (c >= '0' && c <= '9') {
      if (!in_fraction) {
        if (seen_nonzero || c != '0') {
          seen_nonzero = true;
          ++integer_digits;
        }
      } else if (!seen_nonzero) {
        if (c == '0') {
          ++leading_fraction_zeros;
        } else {
          seen_nonzero = true;
        }
      }
    } else {
      break;  // 'e' or 'E'
    }
  }
  if (!seen_nonzero) return true;
  exponent10 = integer_digits > 0 ? integer_digits - 1 : -(leading_fraction_zeros + 1);
  if (i < token.size()) {
    ++i;  // the 'e'
    bool negative = false;
    if (i < token.size() && (token[i] == '+' || token[i] == '-')) negative = token[i++] == '-';
    int64_t e = 0;
    for (; i < token.size() && token[i] >= '0' && token[i] <= '9'; ++i)
      e = std::min<int64_t>(e * 10 + (token[i] - '0'), int64_t(1) << 40);
    exponent10 += negative ? -e : e;
  }
  return exponent10 < 0;
}

// Moves p past a leading '+', which from_chars refuses; false for an empty token or a sign with no
// number after it.
static bool skip_plus(const char*& p, const char* end) {
  if (p == end) return false;
  if (*p == '+') {
    ++p;
    if (p == end || *p == '+' || *p == '-') return false;
  }
  return true;
}

NumberStatus parse_float(std::string_view token, float& value) {
  const char* p = token.data();
  const char* end = p + token.size();
  if (!skip_plus(p, end)) return NumberStatus::not_a_number;
  float parsed = 0;
  const std::from_chars_result result = std::from_chars(p, end, parsed, std::chars_format::general);
  if (result.ptr != end || result.ec == std::errc::invalid_argument) {
    // "nan" / "inf" prefixes ("nanx") are still not numbers; only a complete match is accepted.
    return NumberStatus::not_a_number;
  }
  if (result.ec == std::errc::result_out_of_range) {
    if (decimal_magnitude_below_one(std::string_view(p, static_cast<size_t>(end - p)))) {
      value = *p == '-' ? -0.0f : 0.0f;
      return NumberStatus::ok;
    }
    return NumberStatus::out_of_range;
  }
  if (!std::isfinite(parsed)) return NumberStatus::not_finite;
  value = parsed;
  return NumberStatus::ok;
}

NumberStatus parse_coordinate(std::string_view token, double& value) {
  const char* p = token.data();
  const char* end = p + token.size();
  if (!skip_plus(p, end)) return NumberStatus::not_a_number;
  double parsed = 0;
  const std::from_chars_result result = std::from_chars(p, end, parsed, std::chars_format::general);
  if (result.ptr != end || result.ec == std::errc::invalid_argument) return NumberStatus::not_a_number;
  float single = static_cast<float>(parsed);
  // Beyond double's range, beyond float's, and below float's normal range (where parse_float's
  // underflow rule applies): parse_float decides, and gives the value. Rare in meshes.
  if (result.ec == std::errc::result_out_of_range || !std::isfinite(parsed) || !std::isfinite(single) ||
      (parsed != 0 && std::fabs(parsed) < double(std::numeric_limits<float>::min()))) {
    const NumberStatus status = parse_float(token, single);
    value = single;
    return status;
  }
  // Two roundings (decimal -> double -> float) differ from one (decimal -> float) only where the
  // double lies exactly halfway between two floats; there the direct parse says which way to go.
  if (static_cast<double>(single) != parsed) {
    const float other = std::nextafter(single, parsed > single ? INFINITY : -INFINITY);
    if ((static_cast<double>(single) + static_cast<double>(other)) * 0.5 == parsed) {
      float direct = 0;
      parse_float(token, direct);
      if (direct != single) parsed = std::nextafter(parsed, static_cast<double>(direct));
      assert(static_cast<float>(parsed) == direct);
    }
  }
  value = parsed;
  return NumberStatus::ok;
}

NumberStatus parse_int(std::string_view token, int64_t& value) {
  const char* p = token.data();
  const char* end = p + token.size();
  if (!skip_plus(p, end)) return NumberStatus::not_a_number;
  const std::from_chars_result result = std::from_chars(p, end, value);
  if (result.ptr != end || result.ec == std::errc::invalid_argument) return NumberStatus::not_a_number;
  if (result.ec == std::errc::result_out_of_range) return NumberStatus::out_of_range;
  return NumberStatus::ok;
}

NumberStatus parse_count(std::string_view token, uint64_t& value) {
  const char* p = token.data();
  const char* end = p + token.size();
  if (p == end) return NumberStatus::not_a_number;
  if (*p == '+') ++p;
  if (p == end || *p < '0' || *p > '9') return NumberStatus::not_a_number;
  const std::from_chars_result result = std::from_chars(p, end, value);
  if (result.ptr != end || result.ec == std::errc::invalid_argument) return NumberStatus::not_a_number;
  if (result.ec == std::errc::result_out_of_range) return NumberStatus::out_of_range;
  return NumberStatus::ok;
}

std::string quote(std::string_view token) {
  constexpr size_t kMaxShown = 40;
  std::string out = "'";
  for (size_t i = 0; i < token.size() && i < kMaxShown; ++i) {
    const unsigned char c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f && c != '\'' && c != '\\') {
      out += static_cast<char>(c);
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
      out += escaped;
    }
  }
  if (token.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

bool equals_ignoring_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  for (char& c : ext) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return ext;
}

bool host_is_little_endian() {
  const uint16_t one = 1;
  unsigned char first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

// ---------------------------------------------------------------------------------------------
// Welding and compaction

// Position bits with -0.0 folded into +0.0, so the two weld together.
static inline uint32_t position_key(float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, 4);
  return bits == 0x80000000u ? 0u : bits;
}

static inline uint32_t hash_position(const uint32_t key[3]) {
  // MurmurHash2 mixing of the three 32-bit words: cheap and spreads grid-like coordinates.
  const uint32_t m = 0x5bd1e995u;
  uint32_t h = 0x9747b28cu;
  for (int i = 0; i < 3; ++i) {
    uint32_t k = key[i] * m;
    k ^= k >> 24;
    k *= m;
    h = (h * m) ^ k;
  }
  h ^= h >> 13;
  h *= m;
  h ^= h >> 15;
  return h;
}

// representative[v]: the first vertex with v's position (v itself when it is the first).
// Open addressing with linear probing over a power-of-two table at most half full. Each slot keeps
// the full 32-bit hash beside the vertex id, so a collision costs a compare in the table (already
// in cache) instead of a random read of the other vertex's position.
static std::vector<uint32_t> weld_representatives(const std::vector<float>& positions, uint64_t& welded) {
  const size_t vertex_count = positions.size() / 3;
  std::vector<uint32_t> representative(vertex_count);
  size_t table_size = 16;
  while (table_size < vertex_count * 2) table_size *= 2;
  constexpr uint64_t kEmpty = ~uint64_t(0);
  std::vector<uint64_t> table(table_size, kEmpty);  // hash << 32 | vertex id
  const size_t mask = table_size - 1;
  welded = 0;
  for (size_t v = 0; v < vertex_count; ++v) {
    const uint32_t key[3] = {position_key(positions[3 * v]), position_key(positions[3 * v + 1]),
                             position_key(positions[3 * v + 2])};
    const uint32_t hash = hash_position(key);
    size_t slot = hash & mask;
    for (;;) {
      const uint64_t entry = table[slot];
      if (entry == kEmpty) {
        table[slot] = uint64_t(hash) << 32 | v;
        representative[v] = static_cast<uint32_t>(v);
        break;
      }
      const uint32_t other = static_cast<uint32_t>(entry);
      if (uint32_t(entry >> 32) == hash && position_key(positions[3 * size_t(other)]) == key[0] &&
          position_key(positions[3 * size_t(other) + 1]) == key[1] &&
          position_key(positions[3 * size_t(other) + 2]) == key[2]) {
        representative[v] = other;
        ++welded;
        break;
      }
      slot = (slot + 1) & mask;
    }
  }
  return representative;
}

// Welding undone where it breaks a manifold. Two vertices at one position are usually one vertex
// written twice (split normals or UVs, STL), and welding zips the surface together there. But a
// surface that touches itself may have two vertices at one position on purpose: diplodocus (libcgal-
// demo) is a closed genus-0 manifold in its file whose two pairs of coincident vertices each have
// an edge to a common neighbour. Welding made each such pair of edges one edge of four faces, and
// coarsening the non-manifold result left defects and thin triangles (diplodocus -> 6851: 2 defects,
// 120 angles below 30 degrees; none of either with --no-weld). So where an edge of the welded mesh
// has three or more faces and each of the file's edges that made it has exactly two faces, using
// it in opposite directions (a manifold edge in the file), the vertices at each end of those file
// edges are kept apart again: one keeps the shared vertex, the others their own. Not where a vertex
// to be kept apart also zips two of the file's edges into one elsewhere (a seam that welding
// closes): the seam matters more; nor where a face at the edge or at a vertex to be kept apart has
// two corners at one position (see below).
// Returns the number of vertices kept apart; `representative` and `welded` are updated. Cost: the
// reading of a 1.2M-face binary PLY with 11% of its vertices written twice (seams) 92-107 -> 122-129
// ms; nothing measurable for the same mesh as binary STL (no vertex used twice), none where
// nothing was welded.
static uint64_t keep_manifold_edges_apart(const std::vector<uint32_t>& indices, std::vector<uint32_t>& representative,
                                          uint64_t& welded) {
  const size_t vertex_count = representative.size();
  // Welded groups of two or more file vertices (CSR by representative), and the faces at their
  // members (CSR by vertex). Only a file edge with two faces can be kept apart, so both its ends
  // are used twice or more: STL (three vertices of its own per facet) stops at the first check.
  std::vector<uint32_t> group_offsets, members, face_offsets, vertex_faces;
  auto build_groups = [&] {
    group_offsets.assign(vertex_count + 1, 0);
    for (size_t v = 0; v < vertex_count; ++v) ++group_offsets[representative[v] + 1];
    for (size_t v = 0; v < vertex_count; ++v) group_offsets[v + 1] += group_offsets[v];
    members.resize(vertex_count);
    std::vector<uint32_t> fill(group_offsets.begin(), group_offsets.end() - 1);
    for (size_t v = 0; v < vertex_count; ++v) members[fill[representative[v]]++] = uint32_t(v);
  };
  std::vector<uint8_t> multi(vertex_count, 0);  // v shares its position with another vertex welded to it
  for (size_t v = 0; v < vertex_count; ++v)
    if (representative[v] != v) multi[v] = multi[representative[v]] = 1;
  {
    bool shared = false;  // (2 in multi: used before)
    for (uint32_t v : indices)
      if (multi[v] == 2)
        shared = true;
      else if (multi[v] == 1)
        multi[v] = 2;
    if (!shared) return 0;
    for (uint8_t& m : multi) m = m != 0;
  }
  // The groups of one position, as welded at first: what makes a face a sliver does not change
  // when vertices are kept apart.
  const std::vector<uint32_t> position_group = representative;
  build_groups();
  face_offsets.assign(vertex_count + 1, 0);
  for (uint32_t v : indices)
    if (multi[v]) ++face_offsets[v + 1];
  for (size_t v = 0; v < vertex_count; ++v) face_offsets[v + 1] += face_offsets[v];
  vertex_faces.resize(face_offsets.back());
  {
    std::vector<uint32_t> fill(face_offsets.begin(), face_offsets.end() - 1);
    for (size_t i = 0; i < indices.size(); ++i)
      if (multi[indices[i]]) vertex_faces[fill[indices[i]]++] = uint32_t(i / 3);
  }
  // One face's edge at a member of the group being looked at, toward a vertex of another group.
  struct Incidence {
    uint32_t other_group;  // the representative at the edge's other end
    uint32_t a, b;         // the file's edge, in the face's direction (one of them the member)
    bool collapses;        // the face has two corners welded into one
    uint64_t file_key() const { return uint64_t(std::min(a, b)) << 32 | std::max(a, b); }
  };
  std::vector<Incidence> at, candidates;  // candidates: runs of `at`, kept whole
  std::vector<uint32_t> candidate_offsets, ends, separate;
  std::vector<uint8_t> zips(vertex_count, 0), apart(vertex_count, 0);
  // Whether some welded edge at group g has three or more faces: counted per neighbouring group
  // without sorting, and only where one does is every group sorted below (the files that get here
  // are mostly seams that welding zips, every edge of two faces: a 1.2M-face mesh whose every
  // vertex was written twice reads in 0.15 s without this check, 0.35 s with it, 0.6 s when every
  // group was sorted).
  std::vector<uint32_t> count(vertex_count, 0), touched;
  auto heavy_edge_at = [&](uint32_t g) {
    bool heavy = false;
    touched.clear();
    for (uint32_t i = group_offsets[g]; i < group_offsets[g + 1]; ++i)
      for (uint32_t j = face_offsets[members[i]]; j < face_offsets[members[i] + 1]; ++j) {
        const uint32_t* c = &indices[3 * size_t(vertex_faces[j])];
        for (int k = 0; k < 3; ++k) {
          const uint32_t x = representative[c[k]];
          if (x == g) continue;
          if (count[x]++ == 0) touched.push_back(x);
          heavy |= count[x] >= 3;  // (a face at two members of g counts twice: checked below)
        }
      }
    for (uint32_t x : touched) count[x] = 0;
    return heavy;
  };
  uint64_t kept_apart = 0;
  for (bool changed = true; changed;) {
    changed = false;
    bool any_heavy = false;
    for (uint32_t g = 0; g < vertex_count && !any_heavy; ++g)
      any_heavy = group_offsets[g + 1] - group_offsets[g] > 1 && heavy_edge_at(g);
    if (!any_heavy) break;
    std::fill(zips.begin(), zips.end(), uint8_t(0));
    candidates.clear();
    candidate_offsets.assign(1, 0);
    for (uint32_t g = 0; g < vertex_count; ++g) {
      if (group_offsets[g + 1] - group_offsets[g] < 2) continue;
      at.clear();
      for (uint32_t i = group_offsets[g]; i < group_offsets[g + 1]; ++i) {
        const uint32_t m = members[i];
        for (uint32_t j = face_offsets[m]; j < face_offsets[m + 1]; ++j) {
          if (j > face_offsets[m] && vertex_faces[j] == vertex_faces[j - 1]) continue;  // m twice in a face
          const uint32_t* c = &indices[3 * size_t(vertex_faces[j])];
          const uint32_t r[3] = {representative[c[0]], representative[c[1]], representative[c[2]]};
          const uint32_t p[3] = {position_group[c[0]], position_group[c[1]], position_group[c[2]]};
          const bool collapses = p[0] == p[1] || p[1] == p[2] || p[0] == p[2];
          const int k = c[0] == m ? 0 : c[1] == m ? 1 : 2;
          const int next = (k + 1) % 3, previous = (k + 2) % 3;
          if (r[next] != g) at.push_back({r[next], m, c[next], collapses});
          if (r[previous] != g) at.push_back({r[previous], c[previous], m, collapses});
        }
      }
      std::sort(at.begin(), at.end(), [](const Incidence& x, const Incidence& y) {
        return x.other_group != y.other_group ? x.other_group < y.other_group : x.file_key() < y.file_key();
      });
      for (size_t i = 0, last = 0; i < at.size(); i = last) {
        last = i;
        while (last < at.size() && at[last].other_group == at[i].other_group) ++last;
        // Two faces from two file edges: welding zipped them (a seam). Its members at this end.
        if (last - i == 2 && at[i].file_key() != at[i + 1].file_key()) {
          for (size_t j = i; j < last; ++j) zips[representative[at[j].a] == g ? at[j].a : at[j].b] = 1;
          continue;
        }
        // Three or more faces, none collapsing (a face the weld collapses is left out later, and
        // its neighbours then share the edge: welding removed a sliver there), each of the file's
        // edges with two faces in opposite directions. Seen from both ends: taken at the lower.
        const uint32_t x = at[i].other_group;
        if (last - i < 3 || (group_offsets[x + 1] - group_offsets[x] > 1 && x < g)) continue;
        bool manifold_in_file = true;
        for (size_t j = i; j < last && manifold_in_file; j += 2)
          manifold_in_file = !at[j].collapses && j + 1 < last && !at[j + 1].collapses &&
                             at[j + 1].file_key() == at[j].file_key() && at[j + 1].a == at[j].b &&
                             (j + 2 == last || at[j + 2].file_key() != at[j].file_key());
        if (!manifold_in_file) continue;
        candidates.insert(candidates.end(), at.begin() + i, at.begin() + last);
        candidate_offsets.push_back(uint32_t(candidates.size()));
      }
    }
    // At each end of a candidate edge, the file's vertices there: all but one (the shared vertex
    // itself when it is among them, else the lowest) are kept apart, unless one of those zips a seam.
    for (size_t c = 0; c + 1 < candidate_offsets.size(); ++c) {
      const Incidence* first = candidates.data() + candidate_offsets[c];
      const Incidence* last = candidates.data() + candidate_offsets[c + 1];
      separate.clear();
      for (const uint32_t end_group : {representative[first->a], representative[first->b]}) {
        ends.clear();
        for (const Incidence* e = first; e != last; ++e)
          ends.push_back(representative[e->a] == end_group ? e->a : e->b);
        std::sort(ends.begin(), ends.end());
        ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
        const uint32_t keep = std::binary_search(ends.begin(), ends.end(), end_group) ? end_group : ends.front();
        for (uint32_t v : ends)
          if (v != keep) separate.push_back(v);
      }
      // Nor one with a face whose corners share a position (a sliver the weld collapses): kept
      // apart, it would stay as a face of no area. (Corners all moved onto a few points, a damaged
      // file, came apart one round after another: every round made more faces seem whole.)
      auto in_sliver = [&](uint32_t v) {
        for (uint32_t j = face_offsets[v]; j < face_offsets[v + 1]; ++j) {
          const uint32_t* corner = &indices[3 * size_t(vertex_faces[j])];
          for (int k = 0; k < 3; ++k)
            if (corner[k] != v && position_group[corner[k]] == position_group[v]) return true;
        }
        return false;
      };
      if (std::none_of(separate.begin(), separate.end(), [&](uint32_t v) { return zips[v] != 0 || in_sliver(v); }))
        for (uint32_t v : separate) apart[v] = 1;
    }
    for (size_t v = 0; v < vertex_count; ++v)
      if (apart[v]) {
        apart[v] = 0;
        if (representative[v] == v) continue;
        representative[v] = uint32_t(v);
        --welded;
        ++kept_apart;
        changed = true;
      }
    if (changed) build_groups();
  }
  return kept_apart;
}

// The box of the vertices the faces use, in the file's units (double): ReadStats' largest
// coordinate and extent, and the corners for choosing an origin.
static void referenced_box(const RawMesh& raw, double lo[3], double hi[3], ReadStats& stats) {
  const size_t vertex_count = raw.positions.size() / 3;
  std::vector<uint8_t> used(vertex_count, 0);
  for (const uint32_t index : raw.indices) used[index] = 1;
  for (int k = 0; k < 3; ++k) lo[k] = INFINITY, hi[k] = -INFINITY;
  for (size_t v = 0; v < vertex_count; ++v) {
    if (!used[v]) continue;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], raw.positions[3 * v + k]);
      hi[k] = std::max(hi[k], raw.positions[3 * v + k]);
    }
  }
  stats.largest_coordinate = stats.extent = 0;
  for (int k = 0; k < 3; ++k) {
    stats.largest_coordinate = std::max({stats.largest_coordinate, std::fabs(lo[k]), std::fabs(hi[k])});
    stats.extent = std::max(stats.extent, hi[k] - lo[k]);
  }
}

// The origin ReadOptions asks for: the given one, or for a far mesh (the float spacing at its
// largest coordinate above kFarSpacing of its extent) its box's centre rounded to a multiple of
// a unit: the largest power of ten not above the extent when that is 1 or more (a round number to
// read in a note), else the largest power of two (an exact binary fraction, where a power of ten
// below 1 has none). Either way the positions moved by it stay within about one extent of 0.
// kFarSpacing: a mesh placed a few hundred of its sizes away gets 1e-5 of its size; none of the
// libcgal-demo meshes comes near (the elephant of tests/data scaled to 100 units and moved to
// (1e5, 4e5) came out of coarsening with its smallest angle at 22.35 degrees instead of 30.25).
static std::array<double, 3> choose_origin(const ReadOptions& options, const double lo[3], const double hi[3],
                                           const ReadStats& stats) {
  constexpr double kFarSpacing = 1e-5;
  if (options.origin) return *options.origin;
  if (!options.shift_far || !(stats.extent > 0)) return {0, 0, 0};
  const float largest = static_cast<float>(stats.largest_coordinate);
  const double spacing = double(std::nextafter(largest, INFINITY)) - double(largest);
  if (!(spacing > kFarSpacing * stats.extent)) return {0, 0, 0};
  const double unit = stats.extent >= 1 ? std::pow(10.0, std::floor(std::log10(stats.extent)))
                                         : std::ldexp(1.0, std::ilogb(stats.extent));
  std::array<double, 3> origin;
  for (int k = 0; k < 3; ++k) origin[k] = std::round(0.5 * (lo[k] + hi[k]) / unit) * unit;
  return origin;
}

// Welds (optionally), drops unreferenced vertices and moves the result into a Mesh, its positions
// the file's less `origin`, rounded to float.
static Mesh finish_mesh(RawMesh&& raw, const std::array<double, 3>& origin, bool weld, ReadStats& stats) {
  const size_t vertex_count = raw.positions.size() / 3;
  std::vector<float> positions(raw.positions.size());
  if (is_zero(origin)) {
    for (size_t i = 0; i < positions.size(); ++i) positions[i] = static_cast<float>(raw.positions[i]);
  } else {
    for (size_t v = 0; v < vertex_count; ++v)
      for (int k = 0; k < 3; ++k) positions[3 * v + k] = static_cast<float>(raw.positions[3 * v + k] - origin[k]);
  }
  raw.positions = std::vector<double>();  // freed before the weld's table
  std::vector<uint32_t> new_id;  // file vertex -> output vertex (via its representative)
  uint64_t welded = 0;
  uint64_t kept_apart = 0;
  if (weld) {
    new_id = weld_representatives(positions, welded);
    if (welded > 0) kept_apart = keep_manifold_edges_apart(raw.indices, new_id, welded);
  } else {
    new_id.resize(vertex_count);
    for (size_t v = 0; v < vertex_count; ++v) new_id[v] = static_cast<uint32_t>(v);
  }
  // Point every index at its representative and mark the representatives in use.
  std::vector<uint8_t> used(vertex_count, 0);
  if (welded == 0) {  // every vertex is its own representative
    for (const uint32_t index : raw.indices) used[index] = 1;
  } else {
    for (uint32_t& index : raw.indices) {
      assert(index < vertex_count);
      index = new_id[index];
      used[index] = 1;
    }
  }
  // Output ids in file order of the representatives (first occurrence), skipping unused ones.
  uint32_t kept = 0;
  uint64_t unreferenced = 0;
  std::vector<uint32_t> output_id(vertex_count, kNone);
  for (size_t v = 0; v < vertex_count; ++v) {
    if (new_id[v] != v) continue;  // welded into an earlier vertex
    if (!used[v]) {
      ++unreferenced;
      continue;
    }
    output_id[v] = kept++;
  }
  Mesh mesh;
  if (kept == vertex_count) {
    mesh.positions = std::move(positions);
  } else {
    mesh.positions.resize(size_t(kept) * 3);
    for (size_t v = 0; v < vertex_count; ++v) {
      const uint32_t out = output_id[v];
      if (out == kNone) continue;
      mesh.positions[3 * size_t(out)] = positions[3 * v];
      mesh.positions[3 * size_t(out) + 1] = positions[3 * v + 1];
      mesh.positions[3 * size_t(out) + 2] = positions[3 * v + 2];
    }
    for (uint32_t& index : raw.indices) index = output_id[index];
  }
  mesh.indices = std::move(raw.indices);
  mesh.source_polygon = std::move(raw.source_polygon);
  stats.welded_vertices = welded;
  stats.kept_apart_vertices = kept_apart;
  stats.unreferenced_vertices = unreferenced;
  assert(stats.welded_vertices + stats.unreferenced_vertices + kept == vertex_count);
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// Writing files

// The process umask, read without changing it (umask(2) can only be read by setting it, which
// would race with other threads creating files).
static mode_t current_umask() {
  mode_t mask = 022;
  if (FILE* status = std::fopen("/proc/self/status", "re")) {
    char line[256];
    while (std::fgets(line, sizeof line, status)) {
      unsigned value;
      if (std::sscanf(line, "Umask: %o", &value) == 1) {
        mask = static_cast<mode_t>(value);
        break;
      }
    }
    std::fclose(status);
  }
  return mask;
}

OutputFile::OutputFile(std::string path) : path_(std::move(path)) {
  std::string pattern = path_ + ".tmp-XXXXXX";
  fd_ = ::mkostemp(pattern.data(), O_CLOEXEC);
  if (fd_ < 0) throw FileError(path_, "cannot create file: " + error_text(errno));
  temp_path_ = std::move(pattern);
  // mkstemp creates the file 0600; give the result the permissions a plain open() would.
  if (::fchmod(fd_, static_cast<mode_t>(0666) & ~current_umask()) != 0) fail("cannot set permissions", errno);
  buffer_.resize(size_t(1) << 20);
}

OutputFile::~OutputFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_path_.empty()) ::unlink(temp_path_.c_str());
}

void OutputFile::fail(const std::string& what, int error_number) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  ::unlink(temp_path_.c_str());
  temp_path_.clear();
  throw FileError(path_, what + ": " + error_text(error_number));
}

void OutputFile::flush() {
  size_t done = 0;
  while (done < used_) {
    const ssize_t wrote = ::write(fd_, buffer_.data() + done, used_ - done);
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote < 0) fail("cannot write", errno);
    if (wrote == 0) fail("cannot write", ENOSPC);
    done += static_cast<size_t>(wrote);
  }
  used_ = 0;
}

char* OutputFile::reserve(size_t size) {
  assert(fd_ >= 0 && !committed_);
  if (buffer_.size() - used_ < size) {
    flush();
    if (buffer_.size() < size) buffer_.resize(size);
  }
  return buffer_.data() + used_;
}

void OutputFile::write(const void* data, size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    if (used_ == buffer_.size()) flush();
    const size_t chunk = std::min(size, buffer_.size() - used_);
    std::memcpy(buffer_.data() + used_, bytes, chunk);
    used_ += chunk;
    bytes += chunk;
    size -= chunk;
  }
}

void OutputFile::commit() {
  assert(fd_ >= 0 && !committed_);
  flush();
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("cannot write", errno);
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) fail("cannot rename temporary file into place", errno);
  committed_ = true;
}

TextWriter& TextWriter::number(float value) {
  char* p = out_.reserve(32);
  const std::to_chars_result result = std::to_chars(p, p + 32, value, std::chars_format::general, 9);
  assert(result.ec == std::errc());
  out_.advance(static_cast<size_t>(result.ptr - p));
  return *this;
}

TextWriter& TextWriter::number(double value) {
  char* p = out_.reserve(32);
  const std::to_chars_result result = std::to_chars(p, p + 32, value);
  assert(result.ec == std::errc());
  out_.advance(static_cast<size_t>(result.ptr - p));
  return *this;
}

TextWriter& TextWriter::position(const float* positions, size_t v, const std::array<double, 3>& origin) {
  if (is_zero(origin))
    return number(positions[3 * v]).ch(' ').number(positions[3 * v + 1]).ch(' ').number(positions[3 * v + 2]);
  return number(origin[0] + double(positions[3 * v])).ch(' ').number(origin[1] + double(positions[3 * v + 1]))
      .ch(' ').number(origin[2] + double(positions[3 * v + 2]));
}

TextWriter& TextWriter::number(uint64_t value) {
  char* p = out_.reserve(24);
  const std::to_chars_result result = std::to_chars(p, p + 24, value);
  out_.advance(static_cast<size_t>(result.ptr - p));
  return *this;
}

TextWriter& TextWriter::number(int64_t value) {
  char* p = out_.reserve(24);
  const std::to_chars_result result = std::to_chars(p, p + 24, value);
  out_.advance(static_cast<size_t>(result.ptr - p));
  return *this;
}

}  // namespace io

// ---------------------------------------------------------------------------------------------
// Public API

Mesh read_mesh(const std::string& path, const ReadOptions& options, ReadStats* stats) {
  const std::string ext = io::lower_extension(path);
  io::ReadResult (*reader)(const io::FileData&) = nullptr;
  if (ext == ".obj") reader = io::read_obj;
  if (ext == ".off") reader = io::read_off;
  if (ext == ".ply") reader = io::read_ply;
  if (ext == ".stl") reader = io::read_stl;
  if (!reader) {
    throw FileError(path, "unknown mesh format '" + ext + "' (expected .obj, .off, .ply or .stl)");
  }
  try {
    io::ReadResult result;
    {
      const io::FileData file = io::read_file(path);
      result = reader(file);
    }  // the file's bytes are freed before welding allocates
    if (result.mesh.indices.empty()) throw FileError(path, "no faces");
    assert(result.mesh.positions.size() / 3 == result.file_vertices);
    ReadStats local;
    local.format = result.format;
    local.file_vertices = result.file_vertices;
    local.file_polygons = result.mesh.polygons;
    local.triangulated_polygons = result.mesh.triangulated;
    local.skipped_header_lines = result.skipped_header_lines;
    local.first_skipped_header_line = result.first_skipped_header_line;
    double lo[3], hi[3];
    io::referenced_box(result.mesh, lo, hi, local);
    local.origin = io::choose_origin(options, lo, hi, local);
    Mesh mesh = io::finish_mesh(std::move(result.mesh), local.origin, options.weld, local);
    if (stats) *stats = std::move(local);
    return mesh;
  } catch (const std::bad_alloc&) {
    // Allocation is bounded by the file size, so only a file too big for this machine gets here.
    throw FileError(path, "not enough memory to read this mesh");
  }
}

void check_mesh_format(const std::string& path) {
  const std::string ext = io::lower_extension(path);
  if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl") {
    throw FileError(path, "unknown mesh format '" + ext + "' (expected .obj, .off, .ply or .stl)");
  }
}

void write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  check_mesh_format(path);
  const std::string ext = io::lower_extension(path);
  // A mesh that would produce an unreadable file is a caller bug; refuse before creating anything.
  if (mesh.positions.size() % 3 != 0 || mesh.indices.size() % 3 != 0) {
    throw OptionError("write_mesh: positions and indices must come in threes");
  }
  const size_t vertex_count = mesh.vertex_count();
  if (vertex_count > io::kMaxVertices || mesh.face_count() > io::kMaxTriangles) {
    throw OptionError("write_mesh: mesh too large for 32-bit indices");
  }
  for (const uint32_t index : mesh.indices) {
    if (index >= vertex_count) throw OptionError("write_mesh: vertex index out of range");
  }
  if (options.face_labels && options.face_labels->size() != mesh.face_count()) {
    throw OptionError("write_mesh: " + std::to_string(options.face_labels->size()) + " face labels for " +
                      std::to_string(mesh.face_count()) + " faces");
  }
  io::OutputFile out(path);
  if (ext == ".obj") io::write_obj(out, mesh, options);
  if (ext == ".off") io::write_off(out, mesh, options);
  if (ext == ".ply") io::write_ply(out, mesh, options);
  if (ext == ".stl") io::write_stl(out, mesh, options);
  out.commit();
}

void write_text_file(const std::string& path, const std::string& content) {
  io::OutputFile out(path);
  out.write(content);
  out.commit();
}

void cluster_color(uint32_t id, uint8_t rgb[3]) {
  if (id == kNone) {  // unassigned faces: neutral grey
    rgb[0] = rgb[1] = rgb[2] = 128;
    return;
  }
  // Hue walks the circle by the golden ratio, so consecutive ids land far apart and any run of ids
  // stays evenly spread; saturation and value take a few hashed levels so that ids whose hues come
  // close again (every ~89 steps) still differ.
  const double hue = std::fmod(double(id) * 0.6180339887498949, 1.0) * 6.0;
  uint32_t h = id * 0x9e3779b1u;
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  const double saturation = 0.55 + 0.15 * double(h & 3);    // 0.55 .. 1.0
  const double value = 0.70 + 0.10 * double((h >> 2) % 4);  // 0.70 .. 1.0
  const int sector = static_cast<int>(hue) % 6;
  const double f = hue - std::floor(hue);
  const double p = value * (1 - saturation), q = value * (1 - saturation * f), t = value * (1 - saturation * (1 - f));
  double r = 0, g = 0, b = 0;
  switch (sector) {
    case 0:
      r = value, g = t, b = p;
      break;
    case 1:
      r = q, g = value, b = p;
      break;
    case 2:
      r = p, g = value, b = t;
      break;
    case 3:
      r = p, g = q, b = value;
      break;
    case 4:
      r = t, g = p, b = value;
      break;
    default:
      r = value, g = p, b = q;
      break;
  }
  rgb[0] = static_cast<uint8_t>(std::lround(r * 255));
  rgb[1] = static_cast<uint8_t>(std::lround(g * 255));
  rgb[2] = static_cast<uint8_t>(std::lround(b * 255));
}

}  // namespace meshcvt
