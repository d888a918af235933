// TetGen .node + .ele reader.
//
// .node: "<#points> [<dim = 3> [<#attributes> [<#boundary markers: 0 or 1>]]]", then one
// line per point: "<index> <x> <y> <z> [attributes] [marker]".
// .ele:  "<#tets> [<nodes per tet = 4> [<#attributes>]]", then one line per tet:
// "<index> <n1> <n2> <n3> <n4> [attributes]".
// '#' starts a comment anywhere on a line; blank lines are skipped.
//
// Numbering follows TetGen (tetgenio::load_node_call): the first point's index (0 or
// 1) sets the base, and the .ele refers to points by position from that base. We
// also require the point indices to run consecutively from the base, since a file
// whose indices skip would mean different things to TetGen and to a reader that
// trusts the indices. Missing attributes and markers are accepted (TetGen reads them as
// 0); extra values on a line, or lines beyond the announced count, are errors.
#include <cctype>
#include <cmath>
#include <limits>
#include <string>

#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"

namespace tc {
namespace {

// The readers' shared scanning and error helpers (core/io/scan.hpp).
using namespace io_detail;

/// The next line with content once its '#' comment is removed.
bool next_record(LineScanner& scan, std::string_view& line) {
  std::string_view l;
  while (scan.next(l)) {
    const std::size_t hash = l.find('#');
    if (hash != std::string_view::npos) l = l.substr(0, hash);
    if (!trim(l).empty()) {
      line = l;
      return true;
    }
  }
  return false;
}

/// Reads up to `max` non-negative integers from a header line; returns how many.
bool header_values(std::string_view line, std::int64_t* values, std::size_t max,
                   std::size_t& count) {
  Tokens tok(line);
  std::string_view t;
  count = 0;
  while (tok.next(t)) {
    if (count == max || !parse_int(t, values[count]) || values[count] < 0) return false;
    ++count;
  }
  return true;
}

constexpr std::int64_t kMaxCount = std::numeric_limits<Index>::max();

/// Reads a file's header line (its first record); `expected` says what it should hold.
Status read_header(LineScanner& scan, const std::string& file, const char* expected,
                   std::string_view& line) {
  if (!next_record(scan, line))
    return text_error(
        ErrorCode::kParse, file, scan.line() + 1,
        "unexpected end of file, expected " + std::string(expected) + " (empty file)");
  return {};
}

/// Reads record `i` (0-based) of the `n` `kind`s ("point", "tet") a file announced, and the
/// index it starts with; `tok` is left at the values after the index.
Status read_record_index(LineScanner& scan, const std::string& file, const char* kind,
                         std::int64_t i, std::int64_t n, std::string_view& line, Tokens& tok,
                         std::int64_t& index) {
  const auto what = [&] {
    return std::string(kind) + " " + std::to_string(i + 1) + " of " + std::to_string(n);
  };
  if (!next_record(scan, line))
    return text_error(ErrorCode::kParse, file, scan.line() + 1,
                      "unexpected end of file, expected " + what());
  tok = Tokens(line);
  std::string_view t;
  if (!tok.next(t) || !parse_int(t, index))
    return text_error(ErrorCode::kParse, file, scan.line() == 0 ? 1 : scan.line(),
                      "expected the index of " + what() + ", got " + quote(trim(line)));
  return {};
}

struct NodeFile {
  std::int64_t base = 0;
};

Status parse_node_file(std::string_view text, const std::string& file, TetMesh& mesh,
                       NodeFile& info) {
  LineScanner scan(text);
  const auto fail = [&](ErrorCode code, const std::string& message) {
    return text_error(code, file, scan.line() == 0 ? 1 : scan.line(), message);
  };
  std::string_view line;
  if (Status st = read_header(scan, file, "'<#points> <dim> <#attributes> <#markers>'", line); !st)
    return st;
  std::int64_t h[5] = {0, 3, 0, 0, 0};
  std::size_t count = 0;
  if (!header_values(line, h, 5, count) || count == 0)
    return fail(ErrorCode::kParse,
                "expected '<#points> <dim> <#attributes> <#markers>', got " + quote(trim(line)));
  const std::int64_t n = h[0], dim = h[1], nattr = h[2], nmark = h[3];
  if (dim != 3)
    return fail(ErrorCode::kUnsupported,
                "dimension " + std::to_string(dim) + " is not supported (expected 3)");
  if (nmark > 1)
    return fail(ErrorCode::kParse,
                "expected 0 or 1 boundary markers per point, got " + std::to_string(nmark));
  if (h[4] != 0)
    return fail(ErrorCode::kUnsupported, "points with uv parameters are not supported");
  // Shortest point line: "0 0 0 0\n" (+1: the last line may lack its '\n').
  if (n > kMaxCount || static_cast<std::uint64_t>(n) > (scan.remaining() + 1) / 8)
    return fail(ErrorCode::kParse, std::to_string(n) +
                                       " points announced, more than the remaining " +
                                       std::to_string(scan.remaining()) + " bytes can hold");
  // A count beyond any line's length cannot be honoured (and would overflow below).
  if (nattr > kMaxCount)
    return fail(ErrorCode::kParse, "expected at most " + std::to_string(kMaxCount) +
                                       " attributes per point, got " + std::to_string(nattr));
  const std::int64_t max_tokens = 4 + nattr + nmark;
  mesh.node_ids.resize(static_cast<std::size_t>(n));
  mesh.positions.resize(3, static_cast<Eigen::Index>(n));
  for (std::int64_t i = 0; i < n; ++i) {
    Tokens tok{std::string_view{}};
    std::int64_t index = 0;
    if (Status st = read_record_index(scan, file, "point", i, n, line, tok, index); !st) return st;
    std::string_view t;
    if (i == 0) {
      if (index != 0 && index != 1)
        return fail(ErrorCode::kParse,
                    "the first point index must be 0 or 1 (it sets the "
                    "numbering base), got " +
                        std::to_string(index));
      info.base = index;
    } else if (index != info.base + i) {
      return fail(ErrorCode::kParse, "expected point index " + std::to_string(info.base + i) +
                                         " (points are numbered consecutively), got " +
                                         std::to_string(index));
    }
    std::int64_t got = 1;
    double x[3] = {0.0, 0.0, 0.0};
    while (tok.next(t)) {
      if (got >= max_tokens)
        return fail(ErrorCode::kParse, "point " + std::to_string(index) + " has more than the " +
                                           std::to_string(max_tokens) +
                                           " values the header allows");
      double v = 0.0;
      if (!parse_double(t, v))
        return fail(ErrorCode::kParse,
                    "expected a number in point " + std::to_string(index) + ", got " + quote(t));
      if (got <= 3) x[got - 1] = v;
      ++got;
    }
    if (got < 4)
      return fail(ErrorCode::kParse, "expected 'index x y z' for point " + std::to_string(index) +
                                         ", got " + quote(trim(line)));
    if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
      return fail(ErrorCode::kInvalidMesh,
                  "point " + std::to_string(index) + " has a non-finite coordinate");
    mesh.node_ids[static_cast<std::size_t>(i)] = index;
    mesh.positions.col(static_cast<Eigen::Index>(i)) << x[0], x[1], x[2];
  }
  if (next_record(scan, line))
    return fail(ErrorCode::kParse, "unexpected line after the " + std::to_string(n) +
                                       " points announced: " + quote(trim(line)));
  return {};
}

Status parse_ele_file(std::string_view text, const std::string& file, const NodeFile& info,
                      TetMesh& mesh) {
  LineScanner scan(text);
  const auto fail = [&](ErrorCode code, const std::string& message) {
    return text_error(code, file, scan.line() == 0 ? 1 : scan.line(), message);
  };
  std::string_view line;
  if (Status st = read_header(scan, file, "'<#tets> <nodes per tet> <#attributes>'", line); !st)
    return st;
  std::int64_t h[3] = {0, 4, 0};
  std::size_t count = 0;
  if (!header_values(line, h, 3, count) || count == 0)
    return fail(ErrorCode::kParse,
                "expected '<#tets> <nodes per tet> <#attributes>', got " + quote(trim(line)));
  const std::int64_t m = h[0], corners = h[1], nattr = h[2];
  if (corners == 10)
    return fail(ErrorCode::kUnsupported,
                "10-node (second-order) tets are not supported (expected 4 nodes per tet; "
                "run tetgen without -o2)");
  if (corners != 4)
    return fail(ErrorCode::kParse, "expected 4 nodes per tet, got " + std::to_string(corners));
  // Shortest tet line: "0 0 0 0 0\n" (+1: the last line may lack its '\n').
  if (m > kMaxCount || static_cast<std::uint64_t>(m) > (scan.remaining() + 1) / 10)
    return fail(ErrorCode::kParse, std::to_string(m) + " tets announced, more than the remaining " +
                                       std::to_string(scan.remaining()) + " bytes can hold");
  const std::int64_t n = mesh.num_nodes();
  if (nattr > kMaxCount)
    return fail(ErrorCode::kParse, "expected at most " + std::to_string(kMaxCount) +
                                       " attributes per tet, got " + std::to_string(nattr));
  const std::int64_t max_tokens = 5 + nattr;
  mesh.tets.resize(static_cast<std::size_t>(m));
  for (std::int64_t i = 0; i < m; ++i) {
    Tokens tok{std::string_view{}};
    std::int64_t index = 0;
    if (Status st = read_record_index(scan, file, "tet", i, m, line, tok, index); !st) return st;
    std::string_view t;
    Tet& tet = mesh.tets[static_cast<std::size_t>(i)];
    std::int64_t got = 1;
    while (tok.next(t)) {
      if (got >= max_tokens)
        return fail(ErrorCode::kParse, "tet " + std::to_string(index) + " has more than the " +
                                           std::to_string(max_tokens) +
                                           " values the header allows");
      if (got <= 4) {
        std::int64_t node = 0;
        if (!parse_int(t, node))
          return fail(ErrorCode::kParse, "expected a point index in tet " + std::to_string(index) +
                                             ", got " + quote(t));
        if (node < info.base || node - info.base >= n)
          return fail(ErrorCode::kInvalidMesh, "tet " + std::to_string(index) +
                                                   " refers to point " + std::to_string(node) +
                                                   ", outside [" + std::to_string(info.base) +
                                                   ", " + std::to_string(info.base + n - 1) + "]");
        tet[static_cast<std::size_t>(got - 1)] = static_cast<Index>(node - info.base);
      } else {
        double attribute = 0.0;
        if (!parse_double(t, attribute))
          return fail(ErrorCode::kParse, "expected an attribute of tet " + std::to_string(index) +
                                             ", got " + quote(t));
      }
      ++got;
    }
    if (got < 5)
      return fail(ErrorCode::kParse, "expected 4 point indices for tet " + std::to_string(index) +
                                         ", got " + std::to_string(got - 1));
  }
  if (next_record(scan, line))
    return fail(ErrorCode::kParse, "unexpected line after the " + std::to_string(m) +
                                       " tets announced: " + quote(trim(line)));
  return {};
}

}  // namespace

Expected<TetMesh> read_tetgen_buffers(std::string_view node_text, std::string_view ele_text,
                                      const std::string& name) {
  TetMesh mesh;
  NodeFile info;
  if (Status st = parse_node_file(node_text, name + ".node", mesh, info); !st) return st.error();
  if (Status st = parse_ele_file(ele_text, name + ".ele", info, mesh); !st) return st.error();
  return mesh;
}

Expected<TetMesh> read_tetgen(const std::filesystem::path& path) {
  std::filesystem::path stem = path;
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".node" || ext == ".ele") stem.replace_extension();
  const std::string name = stem.string();
  auto node_text = io_detail::read_whole_file(name + ".node");
  if (!node_text) return node_text.error();
  auto ele_text = io_detail::read_whole_file(name + ".ele");
  if (!ele_text) return ele_text.error();
  return read_tetgen_buffers(*node_text, *ele_text, name);
}

}  // namespace tc
