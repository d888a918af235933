// STL (ASCII, binary) and Wavefront OBJ readers, and read_surface() (surface_io.hpp).
//
// Hostile input: the binary STL count is checked against the file size before anything
// is reserved; text readers grow with the lines they read (every node and every
// triangle needs bytes of its own), and the OBJ reader counts the `v` lines first, so no
// allocation is larger than the file calls for. Loops are bounded by the data.
#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"
#include "core/io/surface_io.hpp"

namespace tc {
namespace {

// The readers' shared scanning and error helpers (core/io/scan.hpp).
using namespace io_detail;

constexpr std::uint64_t kMaxIndex = static_cast<std::uint64_t>(std::numeric_limits<Index>::max());

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

std::string lower_extension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

// ---- STL ------------------------------------------------------------------------------

/// Corners of the facets in file order (3 per facet), before equal ones are merged.
struct Soup {
  std::vector<double> xyz;  ///< 3 per corner
};

/// Merges corners with bit-identical coordinates (-0 and +0 are one value) into nodes
/// numbered in order of first appearance; triangle t is corners 3t, 3t+1, 3t+2. Sorting
/// (not hashing) keeps the cost and the result independent of any hash seed.
SurfaceMesh merge_corners(const Soup& soup) {
  const std::size_t corners = soup.xyz.size() / 3;
  struct Key {
    std::uint64_t x, y, z;
    std::uint32_t corner;
  };
  const auto bits = [](double v) { return std::bit_cast<std::uint64_t>(v + 0.0); };
  std::vector<Key> keys(corners);
  for (std::size_t i = 0; i < corners; ++i)
    keys[i] = {bits(soup.xyz[3 * i]), bits(soup.xyz[3 * i + 1]), bits(soup.xyz[3 * i + 2]),
               static_cast<std::uint32_t>(i)};
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
    if (a.x != b.x) return a.x < b.x;
    if (a.y != b.y) return a.y < b.y;
    if (a.z != b.z) return a.z < b.z;
    return a.corner < b.corner;
  });
  // first[c] = the first corner (in file order) with the same coordinates as corner c.
  std::vector<std::uint32_t> first(corners);
  for (std::size_t i = 0; i < corners;) {
    std::size_t j = i;
    while (j < corners && keys[j].x == keys[i].x && keys[j].y == keys[i].y &&
           keys[j].z == keys[i].z)
      ++j;
    for (std::size_t k = i; k < j; ++k) first[keys[k].corner] = keys[i].corner;
    i = j;
  }
  std::vector<Index> node_of(corners, -1);
  SurfaceMesh mesh;
  Index nodes = 0;
  for (std::size_t c = 0; c < corners; ++c)
    if (first[c] == c) node_of[c] = nodes++;
  mesh.positions.resize(3, nodes);
  mesh.node_ids.resize(static_cast<std::size_t>(nodes));
  for (std::size_t c = 0; c < corners; ++c) {
    if (first[c] != c) continue;
    const Index n = node_of[c];
    mesh.positions.col(n) << soup.xyz[3 * c], soup.xyz[3 * c + 1], soup.xyz[3 * c + 2];
    mesh.node_ids[static_cast<std::size_t>(n)] = n + 1;
  }
  mesh.triangles.resize(corners / 3);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::size_t k = 0; k < 3; ++k) mesh.triangles[t][k] = node_of[first[3 * t + k]];
  return mesh;
}

Expected<SurfaceMesh> read_stl_binary(std::string_view data, const std::string& name) {
  const auto count = load_le<std::uint32_t>(data.data() + 80);
  // The caller checked data.size() == 84 + 50 count.
  if (count == 0)
    return binary_error(ErrorCode::kParse, name, 80,
                        "the binary STL header announces 0 triangles: an empty surface");
  if (3 * static_cast<std::uint64_t>(count) > kMaxIndex)
    return binary_error(ErrorCode::kUnsupported, name, 80,
                        std::to_string(count) + " triangles: more than 2^31-1 corners");
  Soup soup;
  soup.xyz.resize(9 * static_cast<std::size_t>(count));
  for (std::uint32_t t = 0; t < count; ++t) {
    const std::size_t facet = 84 + 50 * static_cast<std::size_t>(t);
    for (int k = 0; k < 9; ++k) {
      const std::size_t at = facet + 12 + 4 * static_cast<std::size_t>(k);
      const auto v = load_le<float>(data.data() + at);
      if (!std::isfinite(v))
        return binary_error(ErrorCode::kInvalidMesh, name, at,
                            "vertex " + std::to_string(k / 3 + 1) + " of triangle " +
                                std::to_string(t + 1) + " has a non-finite coordinate");
      soup.xyz[9 * static_cast<std::size_t>(t) + static_cast<std::size_t>(k)] = v;
    }
  }
  return merge_corners(soup);
}

/// ASCII STL: solid / facet normal / outer loop / 3 x vertex / endloop / endfacet /
/// endsolid, keywords case-insensitive, one record per line (as every exporter writes).
class StlAsciiParser {
 public:
  StlAsciiParser(std::string_view data, const std::string& name) : scan_(data), name_(name) {}

  Expected<SurfaceMesh> parse() {
    std::string_view line;
    if (!next(line)) return eof("'solid'");
    if (!starts_with_keyword(line, "solid"))
      return fail("expected 'solid', got " + quote(trim(line)));
    for (;;) {
      if (!next(line)) return eof("'facet normal nx ny nz' or 'endsolid'");
      Tokens tok(line);
      std::string_view word;
      tok.next(word);
      if (iequals(word, "endsolid")) {
        // More solids may follow (some exporters write one per part).
        if (!next(line)) break;
        if (!starts_with_keyword(line, "solid"))
          return fail("expected 'solid' or the end of the file after 'endsolid', got " +
                      quote(trim(line)));
        continue;
      }
      if (!iequals(word, "facet"))
        return fail("expected 'facet normal nx ny nz' or 'endsolid', got " + quote(trim(line)));
      if (Status st = facet(tok); !st) return st.error();
    }
    if (soup_.xyz.empty()) return fail("no facets: an empty surface");
    return merge_corners(soup_);
  }

 private:
  bool next(std::string_view& line) { return scan_.next_nonblank(line); }
  [[nodiscard]] Error fail(const std::string& message) const {
    return text_error(ErrorCode::kParse, name_, scan_.line() == 0 ? 1 : scan_.line(), message);
  }
  [[nodiscard]] Error eof(const std::string& expected) const {
    return text_error(ErrorCode::kParse, name_, scan_.line() + 1,
                      "unexpected end of file, expected " + expected);
  }
  static bool starts_with_keyword(std::string_view line, std::string_view keyword) {
    Tokens tok(line);
    std::string_view word;
    return tok.next(word) && iequals(word, keyword);
  }
  /// One line that must be exactly `words` (case-insensitive).
  Status expect(std::initializer_list<std::string_view> words) {
    std::string text;
    for (const std::string_view w : words) {
      if (!text.empty()) text += ' ';
      text.append(w);
    }
    std::string_view line;
    if (!next(line)) return eof("'" + text + "'");
    Tokens tok(line);
    std::string_view word;
    for (const std::string_view w : words)
      if (!tok.next(word) || !iequals(word, w))
        return fail("expected '" + text + "', got " + quote(trim(line)));
    if (!tok.at_end()) return fail("expected '" + text + "', got " + quote(trim(line)));
    return {};
  }

  /// The rest of a facet; `tok` is after the word 'facet' on its line.
  Status facet(Tokens& tok) {
    std::string_view word;
    if (!tok.next(word) || !iequals(word, "normal"))
      return fail("expected 'facet normal nx ny nz'");
    for (int k = 0; k < 3; ++k) {
      double n = 0.0;
      if (!tok.next(word) || !parse_double(word, n))
        return fail("expected 'facet normal nx ny nz', a normal component is missing or " +
                    std::string("not a number"));
    }
    if (!tok.at_end()) return fail("expected 'facet normal nx ny nz', got extra values");
    if (Status st = expect({"outer", "loop"}); !st) return st;
    if (soup_.xyz.size() / 3 + 3 > kMaxIndex) return fail("more than 2^31-1 triangle corners");
    for (int v = 0; v < 3; ++v) {
      std::string_view line;
      if (!next(line)) return eof("'vertex x y z'");
      Tokens vt(line);
      double x[3];
      bool ok = vt.next(word) && iequals(word, "vertex");
      for (int k = 0; ok && k < 3; ++k) ok = vt.next(word) && parse_double(word, x[k]);
      if (!ok || !vt.at_end()) {
        if (iequals(trim(line), "endloop"))
          return fail("expected 'vertex x y z' (a facet has 3 vertices), got 'endloop'");
        return fail("expected 'vertex x y z', got " + quote(trim(line)));
      }
      if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
        return text_error(ErrorCode::kInvalidMesh, name_, scan_.line(),
                          "vertex has a non-finite coordinate");
      soup_.xyz.insert(soup_.xyz.end(), x, x + 3);
    }
    if (Status st = expect({"endloop"}); !st) return st;
    return expect({"endfacet"});
  }

  LineScanner scan_;
  const std::string& name_;
  Soup soup_;
};

// ---- OBJ ------------------------------------------------------------------------------

/// The statement of an OBJ line (its first token) with the '#' comment removed.
std::string_view obj_content(std::string_view line) {
  const std::size_t hash = line.find('#');
  return hash == std::string_view::npos ? line : line.substr(0, hash);
}

class ObjParser {
 public:
  ObjParser(std::string_view data, const std::string& name) : data_(data), name_(name) {}

  Expected<SurfaceMesh> parse() {
    // Pass 1: how many vertices, so that positive indices can be checked as they come
    // and the positions are allocated once (a `v` line has at least 8 bytes).
    std::uint64_t total = 0;
    {
      LineScanner scan(data_);
      std::string_view line;
      while (scan.next(line)) {
        Tokens tok(obj_content(line));
        std::string_view word;
        if (tok.next(word) && word == "v") ++total;
      }
    }
    if (total > kMaxIndex)
      return Error{ErrorCode::kUnsupported, name_ + ": more than 2^31-1 vertices"};
    SurfaceMesh mesh;
    mesh.positions.resize(3, static_cast<Eigen::Index>(total));
    mesh.node_ids.resize(static_cast<std::size_t>(total));
    LineScanner scan(data_);
    std::string_view line;
    Index read = 0;  // vertices so far
    std::vector<Index> corners;
    while (scan.next(line)) {
      Tokens tok(obj_content(line));
      std::string_view word;
      if (!tok.next(word)) continue;
      const auto fail = [&](ErrorCode code, const std::string& message) {
        return text_error(code, name_, scan.line(), message);
      };
      if (word == "v") {
        double x[6];
        std::size_t count = 0;
        std::string_view t;
        while (tok.next(t)) {
          if (count == 6 || !parse_double(t, x[count]))
            return fail(ErrorCode::kParse,
                        "expected 'v x y z [w]' or 'v x y z r g b', got " + quote(trim(line)));
          ++count;
        }
        if (count != 3 && count != 4 && count != 6)
          return fail(ErrorCode::kParse,
                      "expected 'v x y z [w]' or 'v x y z r g b', got " + quote(trim(line)));
        if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
          return fail(ErrorCode::kInvalidMesh,
                      "vertex " + std::to_string(read + 1) + " has a non-finite coordinate");
        mesh.positions.col(read) << x[0], x[1], x[2];
        mesh.node_ids[static_cast<std::size_t>(read)] = read + 1;
        ++read;
      } else if (word == "f") {
        corners.clear();
        std::string_view t;
        while (tok.next(t)) {
          Index v = -1;
          if (Status st = corner(t, read, static_cast<Index>(total), v); !st)
            return fail(st.error().code, st.error().message);
          corners.push_back(v);
        }
        if (corners.size() < 3)
          return fail(ErrorCode::kParse,
                      "a face needs at least 3 vertices, got " + std::to_string(corners.size()));
        if (mesh.triangles.size() + corners.size() - 2 > kMaxIndex)
          return fail(ErrorCode::kUnsupported, "more than 2^31-1 triangles");
        for (std::size_t i = 1; i + 1 < corners.size(); ++i)
          mesh.triangles.push_back({corners[0], corners[i], corners[i + 1]});
      }
      // Anything else (vt, vn, vp, g, o, s, usemtl, mtllib, l, p, ...) is ignored.
    }
    if (mesh.triangles.empty())
      return Error{ErrorCode::kParse, name_ + ": no faces ('f' lines): an empty surface"};
    return mesh;
  }

 private:
  /// One face corner "v", "v/vt", "v//vn" or "v/vt/vn" -> 0-based vertex index.
  static Status corner(std::string_view token, Index read, Index total, Index& out) {
    std::string_view parts[3];
    std::size_t count = 0;
    std::size_t start = 0;
    for (;;) {
      const std::size_t slash = token.find('/', start);
      if (count == 3) return Error{ErrorCode::kParse, "bad face corner " + quote(token)};
      parts[count++] = token.substr(start, slash == std::string_view::npos ? slash : slash - start);
      if (slash == std::string_view::npos) break;
      start = slash + 1;
    }
    std::int64_t v = 0, other = 0;
    if (!parse_int(parts[0], v) || v == 0)
      return Error{ErrorCode::kParse,
                   "expected a vertex index (1-based, or negative) in face corner " + quote(token)};
    // v/vt: vt is a number; v/vt/vn and v//vn: vn is a number, vt a number or nothing.
    const bool texture_ok =
        count < 2 || parse_int(parts[1], other) || (count == 3 && parts[1].empty());
    const bool normal_ok = count < 3 || parse_int(parts[2], other);
    if (!texture_ok || !normal_ok)
      return Error{ErrorCode::kParse,
                   "expected 'v', 'v/vt', 'v//vn' or 'v/vt/vn', got " + quote(token)};
    if (v < 0) {
      // Relative to the vertices read so far: -1 is the last one.
      if (-v > read)
        return Error{ErrorCode::kInvalidMesh, "face corner " + quote(token) + " refers to vertex " +
                                                  std::to_string(v) + ", but only " +
                                                  std::to_string(read) + " vertices precede it"};
      out = static_cast<Index>(read + v);
      return {};
    }
    if (v > total)
      return Error{ErrorCode::kInvalidMesh, "face corner " + quote(token) + " refers to vertex " +
                                                std::to_string(v) + ", but the file has " +
                                                std::to_string(total)};
    out = static_cast<Index>(v - 1);
    return {};
  }

  std::string_view data_;
  const std::string& name_;
};

}  // namespace

Expected<SurfaceMesh> read_stl_buffer(std::string_view data, const std::string& name) {
  std::string_view head = data.substr(0, 512);
  while (!head.empty() && (io_detail::is_blank(head.front()) || head.front() == '\n'))
    head.remove_prefix(1);
  const bool says_solid = head.size() >= 5 && iequals(head.substr(0, 5), "solid");
  if (data.size() >= 84) {
    const std::uint64_t count = load_le<std::uint32_t>(data.data() + 80);
    const std::uint64_t expected = 84 + 50 * count;
    if (expected == data.size()) return read_stl_binary(data, name);
    if (!says_solid)
      return binary_error(ErrorCode::kParse, name, 80,
                          "binary STL header announces " + std::to_string(count) + " triangles (" +
                              std::to_string(expected) + " bytes), the file has " +
                              std::to_string(data.size()));
  }
  if (!says_solid) {
    if (data.empty()) return Error{ErrorCode::kParse, name + ": empty file, expected an STL"};
    return binary_error(ErrorCode::kParse, name, data.size(),
                        "unexpected end of file: shorter than the 84-byte binary STL header, "
                        "and not ASCII STL (no 'solid')");
  }
  auto ascii = StlAsciiParser(data, name).parse();
  if (!ascii && data.size() >= 84 && data.find('\0') != std::string_view::npos) {
    // Text has no NUL byte: a binary file whose header begins with "solid" but whose size
    // is off ends here; say so.
    const std::uint64_t count = load_le<std::uint32_t>(data.data() + 80);
    Error e = ascii.error();
    e.message += " (read as ASCII STL: it begins with 'solid' and its size " +
                 std::to_string(data.size()) + " is not the binary 84 + 50 x " +
                 std::to_string(count) + " = " + std::to_string(84 + 50 * count) + ")";
    return e;
  }
  return ascii;
}

Expected<SurfaceMesh> read_stl(const std::filesystem::path& path) {
  auto data = io_detail::read_whole_file(path);
  if (!data) return data.error();
  return read_stl_buffer(*data, path.string());
}

Expected<SurfaceMesh> read_obj_buffer(std::string_view data, const std::string& name) {
  return ObjParser(data, name).parse();
}

Expected<SurfaceMesh> read_obj(const std::filesystem::path& path) {
  auto data = io_detail::read_whole_file(path);
  if (!data) return data.error();
  return read_obj_buffer(*data, path.string());
}

bool is_surface_extension(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  return ext == ".stl" || ext == ".obj";
}

Expected<SurfaceMesh> read_surface(const std::filesystem::path& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".stl") return read_stl(path);
  if (ext == ".obj") return read_obj(path);
  if (ext == ".msh") return read_gmsh_surface(path);
  return Error{ErrorCode::kUnsupported,
               path.string() + ": unknown surface file extension " +
                   (ext.empty() ? std::string("(none)") : "'" + ext + "'") +
                   " (expected .stl, .obj or .msh)"};
}

Expected<ObjectMesh> read_object_mesh(const std::filesystem::path& path) {
  if (is_surface_extension(path)) {
    auto surface = read_surface(path);
    if (!surface) return surface.error();
    return ObjectMesh{std::move(*surface)};
  }
  auto mesh = read_mesh(path);
  if (!mesh) return mesh.error();
  if (mesh->num_tets() == 0) {
    // A .msh with 3-node triangles and no tets is a surface; with neither, the empty tet
    // mesh says what the file holds.
    auto surface = read_gmsh_surface(path);
    if (surface) return ObjectMesh{std::move(*surface)};
  }
  return ObjectMesh{std::move(*mesh)};
}

}  // namespace tc
