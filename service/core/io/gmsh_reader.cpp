// Gmsh .msh reader: format 2.2 ASCII and 4.1 ASCII/binary (little-endian, size_t of
// 8 bytes). Keeps every node (orphans included) and the elements of one wanted type.
//
// Hostile input: every count is checked against the bytes that remain before anything
// is reserved or read, every binary read is bounds-checked, and the loops are bounded
// by the data, so a truncated or forged file ends in an Error, never in a crash, a hang
// or an absurd allocation.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"
#include "core/io/surface_io.hpp"

namespace tc {

int gmsh_element_node_count(int type) noexcept {
  // Node counts of the element types in Gmsh's GmshDefines.h (MElement::getInfoMSH);
  // 0 marks an unused number or a type of variable size (polygons, polyhedra).
  static constexpr std::array<std::uint16_t, 141> kCounts = {
      0,                                                  // 0: unused
      2,   3,   4,   4,   8,   6,   5,   3,    6,   9,    // 1-10
      10,  27,  18,  14,  1,   8,   20,  15,   13,  9,    // 11-20
      10,  12,  15,  15,  21,  4,   5,   6,    20,  35,   // 21-30
      56,  22,  28,  0,   0,   16,  25,  36,   12,  16,   // 31-40
      20,  28,  36,  45,  55,  66,  49,  64,   81,  100,  // 41-50
      121, 18,  21,  24,  27,  30,  24,  28,   32,  36,   // 51-60
      40,  7,   8,   9,   10,  11,  2,   3,    0,   2,    // 61-70
      84,  120, 165, 220, 286, 0,   0,   0,    34,  40,   // 71-80
      46,  52,  58,  1,   1,   1,   1,   1,    1,   40,   // 81-90
      75,  64,  125, 216, 343, 512, 729, 1000, 32,  44,   // 91-100
      56,  68,  80,  92,  104, 126, 196, 288,  405, 550,  // 101-110
      24,  33,  42,  51,  60,  69,  78,  30,   55,  91,   // 111-120
      140, 204, 285, 385, 21,  29,  37,  45,   53,  61,   // 121-130
      69,  1,   1,   2,   3,   4,   16,  0,    0,   4};   // 131-140
  if (type < 0 || type >= static_cast<int>(kCounts.size())) return 0;
  return kCounts[static_cast<std::size_t>(type)];
}

namespace {

// The readers' shared scanning and error helpers (core/io/scan.hpp).
using namespace io_detail;

constexpr std::uint64_t kMaxCount = static_cast<std::uint64_t>(std::numeric_limits<Index>::max());

/// Bounds-checked reads from the binary part of a file.
class BinaryCursor {
 public:
  BinaryCursor(std::string_view data, std::size_t pos) : data_(data), pos_(pos) {}
  [[nodiscard]] std::size_t pos() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }
  [[nodiscard]] bool has(std::uint64_t n) const { return n <= remaining(); }
  [[nodiscard]] const char* here() const { return data_.data() + pos_; }
  /// Callers check has() first.
  template <typename T>
  T take() {
    const T v = load_le<T>(data_.data() + pos_);
    pos_ += sizeof(T);
    return v;
  }
  void skip(std::uint64_t n) { pos_ += static_cast<std::size_t>(n); }

 private:
  std::string_view data_;
  std::size_t pos_;
};

/// Nodes and wanted elements as parsed, before they become a TetMesh or TriMesh2.
struct GmshData {
  std::vector<std::int64_t> ids;
  std::vector<double> xyz;      ///< 3 per node
  std::vector<Index> conn;      ///< `wanted_nodes` per element
  std::uint64_t tets_seen = 0;  ///< 4-node tets (type 4) in the file, wanted or not
};

class GmshParser {
 public:
  GmshParser(std::string_view data, const std::string& name, int wanted_type, int wanted_nodes)
      : scan_(data), name_(name), wanted_type_(wanted_type), wanted_nodes_(wanted_nodes) {}

  Status parse();
  GmshData& result() { return out_; }

 private:
  // Errors located at the current line (text), or at its first byte (binary files).
  Error fail(ErrorCode code, const std::string& message) const {
    if (binary_) return binary_error(code, name_, scan_.line_start(), message);
    return text_error(code, name_, scan_.line() == 0 ? 1 : scan_.line(), message);
  }
  // Errors located at a byte offset of binary data.
  Error fail_at(std::size_t offset, ErrorCode code, const std::string& message) const {
    return binary_error(code, name_, offset, message);
  }
  // Errors located at an earlier line of a text file.
  Error fail_at_line(std::size_t line, ErrorCode code, const std::string& message) const {
    return text_error(code, name_, line, message);
  }
  // Binary data ending before `what`, located where it was expected.
  Error truncated(const BinaryCursor& c, const std::string& what) const {
    return fail_at(c.pos(), ErrorCode::kParse,
                   "unexpected end of file, expected " + what + " (" +
                       std::to_string(c.remaining()) + " bytes left)");
  }
  // A section's header announcing another count of `noun` than its blocks hold.
  static std::string blocks_hold(std::string_view section, std::uint64_t announced,
                                 std::uint64_t total, std::string_view noun) {
    return std::string(section) + " header announces " + std::to_string(announced) + " " +
           std::string(noun) + ", its blocks hold " + std::to_string(total);
  }
  Error end_of_file(const std::string& expected) const {
    if (binary_)
      return fail_at(scan_.data().size(), ErrorCode::kParse,
                     "unexpected end of file, expected " + expected);
    return text_error(ErrorCode::kParse, name_, scan_.line() + 1,
                      "unexpected end of file, expected " + expected);
  }

  Status parse_header();
  Status parse_nodes_v2();
  Status parse_nodes_v4_text();
  Status parse_nodes_v4_binary();
  Status parse_elements_v2();
  Status parse_elements_v4_text();
  Status parse_elements_v4_binary();
  Status parse_entities_binary();
  Status skip_section(std::string_view section);
  Status expect_line(std::string_view expected);

  /// Reads `n` integers (n <= 8) from one line that must hold exactly them.
  Status read_counts(std::string_view what, std::size_t n, std::int64_t* values);
  /// A data line inside a section; `what` names the expected record.
  /// `what()` builds the description only when there is an error to report.
  template <typename What>
  Status data_line(std::string_view& line, const What& what);

  Status add_node(std::int64_t tag, double x, double y, double z);
  /// The node tags that end an element's text line (after its number, and its tags in
  /// 2.2): for the wanted type each one becomes a node index appended to the connectivity;
  /// for another type of fixed size they are only counted.
  Status element_nodes_text(Tokens& tok, std::int64_t num, std::int64_t type);
  /// The index of node `tag`, -1 for a tag no node has (text tags are signed, binary
  /// ones unsigned).
  template <typename Tag>
  Index node_index(Tag tag) const;
  template <typename Tag>
  static std::string unknown_node(Tag num, Tag tag) {
    return "element " + std::to_string(num) + " refers to unknown node tag " + std::to_string(tag);
  }
  Status check_node_total(std::uint64_t more);
  Status check_fits(std::uint64_t count, std::uint64_t min_bytes, std::string_view what);

  LineScanner scan_;
  const std::string& name_;
  const int wanted_type_;
  const int wanted_nodes_;
  bool binary_ = false;
  int version_ = 0;  // 2 or 4
  bool seen_nodes_ = false;
  bool seen_elements_ = false;
  TagMap tags_;
  GmshData out_;
};

Status GmshParser::parse() {
  if (Status st = parse_header(); !st) return st;
  std::string_view line;
  while (scan_.next(line)) {
    const std::string_view t = trim(line);
    // Gmsh ignores anything between sections; so do we.
    if (t.empty() || t.front() != '$') continue;
    const std::string_view section = t.substr(1);
    Status st;
    if (section == "Nodes") {
      seen_nodes_ = true;
      st = version_ == 2 ? parse_nodes_v2()
                         : (binary_ ? parse_nodes_v4_binary() : parse_nodes_v4_text());
    } else if (section == "Elements") {
      seen_elements_ = true;
      st = version_ == 2 ? parse_elements_v2()
                         : (binary_ ? parse_elements_v4_binary() : parse_elements_v4_text());
    } else if (section == "Entities" && binary_) {
      st = parse_entities_binary();
    } else if (section.substr(0, 3) == "End") {
      return fail(ErrorCode::kParse, "unexpected " + quote(t) + " outside its section");
    } else {
      st = skip_section(section);
    }
    if (!st) return st;
  }
  if (!seen_nodes_) return end_of_file("a $Nodes section");
  if (!seen_elements_) return end_of_file("an $Elements section");
  return {};
}

Status GmshParser::parse_header() {
  std::string_view line;
  if (!scan_.next_nonblank(line)) return end_of_file("$MeshFormat (empty file)");
  const std::string_view first = trim(line);
  if (first == "$NOD" || first == "$NOE")
    return fail(ErrorCode::kUnsupported, "MSH version 1 is not supported (expected 2.2 or 4.1)");
  if (first != "$MeshFormat")
    return fail(ErrorCode::kParse, "expected $MeshFormat, got " + quote(first));
  if (!scan_.next_nonblank(line)) return end_of_file("'version file-type data-size'");
  Tokens tok(line);
  std::string_view version_token, type_token, size_token;
  if (!tok.next(version_token) || !tok.next(type_token) || !tok.next(size_token) || !tok.at_end())
    return fail(ErrorCode::kParse,
                "expected 'version file-type data-size', got " + quote(trim(line)));
  double version = 0.0;
  std::int64_t file_type = 0;
  std::int64_t data_size = 0;
  if (!parse_double(version_token, version))
    return fail(ErrorCode::kParse, "expected a format version, got " + quote(version_token));
  if (!parse_int(type_token, file_type) || (file_type != 0 && file_type != 1))
    return fail(ErrorCode::kParse,
                "expected file-type 0 (ASCII) or 1 (binary), got " + quote(type_token));
  if (!parse_int(size_token, data_size))
    return fail(ErrorCode::kParse, "expected a data-size, got " + quote(size_token));
  if (version >= 2.0 && version < 3.0) {
    version_ = 2;
  } else if (version == 4.1) {
    version_ = 4;
  } else {
    return fail(ErrorCode::kUnsupported, "MSH version " + std::string(version_token) +
                                             " is not supported (expected 2.2 or 4.1; "
                                             "re-export with gmsh -format msh41)");
  }
  binary_ = file_type == 1;
  if (binary_ && version_ == 2)
    return fail(ErrorCode::kUnsupported,
                "binary MSH 2.2 is not supported (expected ASCII 2.2 or 4.1 ASCII/binary)");
  if (binary_) {
    if (data_size != 8)
      return fail(ErrorCode::kUnsupported,
                  "data-size " + std::to_string(data_size) +
                      " is not supported (expected 8, the size of size_t on 64-bit systems)");
    const std::size_t at = scan_.offset();
    if (scan_.remaining() < 4)
      return fail_at(at, ErrorCode::kParse,
                     "unexpected end of file, expected the endianness "
                     "marker (int 1)");
    const auto marker = load_le<std::int32_t>(scan_.data().data() + at);
    if (marker == 0x01000000)
      return fail_at(at, ErrorCode::kUnsupported,
                     "big-endian binary file (only little-endian is supported)");
    if (marker != 1)
      return fail_at(at, ErrorCode::kParse,
                     "bad endianness marker " + std::to_string(marker) + " (expected int 1)");
    scan_.seek(at + 4);
  }
  return expect_line("$EndMeshFormat");
}

Status GmshParser::expect_line(std::string_view expected) {
  std::string_view line;
  if (!scan_.next_nonblank(line)) return end_of_file(std::string(expected));
  if (trim(line) != expected)
    return fail(ErrorCode::kParse,
                "expected " + std::string(expected) + ", got " + quote(trim(line)));
  return {};
}

Status GmshParser::skip_section(std::string_view section) {
  const std::string end = "$End" + std::string(section);
  const std::size_t start_line = scan_.line();
  const std::size_t start_offset = scan_.line_start();
  std::string_view line;
  while (scan_.next(line))
    if (trim(line) == end) return {};
  const std::string where =
      binary_ ? "at byte " + std::to_string(start_offset) : "at line " + std::to_string(start_line);
  return end_of_file(end + " to close the section $" + std::string(section) + " " + where);
}

Status GmshParser::read_counts(std::string_view what, std::size_t n, std::int64_t* values) {
  std::string_view line;
  if (!scan_.next_nonblank(line)) return end_of_file(std::string(what));
  Tokens tok(line);
  std::string_view t;
  for (std::size_t i = 0; i < n; ++i) {
    if (!tok.next(t) || !parse_int(t, values[i]) || values[i] < 0)
      return fail(ErrorCode::kParse,
                  "expected " + std::string(what) + ", got " + quote(trim(line)));
  }
  if (!tok.at_end())
    return fail(ErrorCode::kParse, "expected " + std::string(what) + ", got " + quote(trim(line)));
  return {};
}

template <typename What>
Status GmshParser::data_line(std::string_view& line, const What& what) {
  if (!scan_.next_nonblank(line)) return end_of_file(what());
  const std::string_view t = trim(line);
  if (t.front() == '$')
    return fail(ErrorCode::kParse, "expected " + what() + ", got " + quote(t) +
                                       " (the section holds fewer records than announced)");
  return {};
}

Status GmshParser::check_fits(std::uint64_t count, std::uint64_t min_bytes, std::string_view what) {
  // +1: the last line of a file may lack its '\n'.
  if (count > (scan_.remaining() + 1) / min_bytes)
    return fail(ErrorCode::kParse, std::to_string(count) + " " + std::string(what) +
                                       " announced, more than the remaining " +
                                       std::to_string(scan_.remaining()) + " bytes can hold");
  return {};
}

Status GmshParser::check_node_total(std::uint64_t more) {
  if (out_.ids.size() + more > kMaxCount)
    return fail(ErrorCode::kUnsupported, "more than 2^31-1 nodes");
  return {};
}

Status GmshParser::add_node(std::int64_t tag, double x, double y, double z) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
    return Error{ErrorCode::kInvalidMesh,
                 "node tag " + std::to_string(tag) + " has a non-finite coordinate"};
  if (out_.ids.size() >= kMaxCount) return Error{ErrorCode::kUnsupported, "more than 2^31-1 nodes"};
  if (!tags_.insert(tag, static_cast<Index>(out_.ids.size())))
    return Error{ErrorCode::kInvalidMesh, "duplicate node tag " + std::to_string(tag)};
  out_.ids.push_back(tag);
  out_.xyz.push_back(x);
  out_.xyz.push_back(y);
  out_.xyz.push_back(z);
  return {};
}

template <typename Tag>
Index GmshParser::node_index(Tag tag) const {
  if constexpr (std::is_unsigned_v<Tag>) {
    if (tag > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return -1;
  }
  return tags_.find(static_cast<std::int64_t>(tag));
}

Status GmshParser::element_nodes_text(Tokens& tok, std::int64_t num, std::int64_t type) {
  if (type != wanted_type_) {
    const int expected =
        gmsh_element_node_count(static_cast<int>(type < 0 || type > 1000 ? 0 : type));
    if (expected <= 0) return {};
    const std::size_t got = tok.count_rest();
    if (got != static_cast<std::size_t>(expected))
      return fail(ErrorCode::kParse, "expected " + std::to_string(expected) +
                                         " node tags for element " + std::to_string(num) +
                                         " (type " + std::to_string(type) + "), got " +
                                         std::to_string(got));
    return {};
  }
  const auto k = static_cast<std::size_t>(wanted_nodes_);
  Index conn[8];
  std::size_t got = 0;
  std::string_view t;
  while (tok.next(t)) {
    std::int64_t node = 0;
    if (!parse_int(t, node))
      return fail(ErrorCode::kParse,
                  "expected a node tag in element " + std::to_string(num) + ", got " + quote(t));
    if (got < k) {
      const Index index = node_index(node);
      if (index < 0) return fail(ErrorCode::kInvalidMesh, unknown_node(num, node));
      conn[got] = index;
    }
    ++got;
  }
  if (got != k)
    return fail(ErrorCode::kParse, "expected " + std::to_string(k) + " node tags for element " +
                                       std::to_string(num) + ", got " + std::to_string(got));
  if (out_.conn.size() / k >= kMaxCount)
    return fail(ErrorCode::kUnsupported, "more than 2^31-1 elements");
  out_.conn.insert(out_.conn.end(), conn, conn + k);
  return {};
}

// ---- MSH 2.2 ----------------------------------------------------------------------

Status GmshParser::parse_nodes_v2() {
  std::int64_t n = 0;
  if (Status st = read_counts("the number of nodes", 1, &n); !st) return st;
  // Shortest node line: "1 0 0 0\n".
  if (Status st = check_fits(static_cast<std::uint64_t>(n), 8, "nodes"); !st) return st;
  if (Status st = check_node_total(static_cast<std::uint64_t>(n)); !st) return st;
  out_.ids.reserve(out_.ids.size() + static_cast<std::size_t>(n));
  out_.xyz.reserve(out_.xyz.size() + 3 * static_cast<std::size_t>(n));
  std::string_view line;
  for (std::int64_t i = 0; i < n; ++i) {
    const auto what = [&] { return "node " + std::to_string(i + 1) + " of " + std::to_string(n); };
    if (Status st = data_line(line, what); !st) return st;
    Tokens tok(line);
    std::string_view t[4];
    std::size_t count = 0;
    while (count < 4 && tok.next(t[count])) ++count;
    if (count < 4 || !tok.at_end())
      return fail(ErrorCode::kParse,
                  "expected 'tag x y z' for " + what() + ", got " + quote(trim(line)));
    std::int64_t tag = 0;
    double x[3];
    if (!parse_int(t[0], tag) || tag < 0)
      return fail(ErrorCode::kParse, "expected a non-negative node tag, got " + quote(t[0]));
    for (int k = 0; k < 3; ++k)
      if (!parse_double(t[k + 1], x[k]))
        return fail(ErrorCode::kParse, "expected a coordinate of node tag " + std::to_string(tag) +
                                           ", got " + quote(t[k + 1]));
    if (Status st = add_node(tag, x[0], x[1], x[2]); !st)
      return fail(st.error().code, st.error().message);
  }
  return expect_line("$EndNodes");
}

Status GmshParser::parse_elements_v2() {
  std::int64_t m = 0;
  if (Status st = read_counts("the number of elements", 1, &m); !st) return st;
  // Shortest element line: "1 15 0 1\n".
  if (Status st = check_fits(static_cast<std::uint64_t>(m), 9, "elements"); !st) return st;
  std::string_view line;
  for (std::int64_t i = 0; i < m; ++i) {
    const auto what = [&] {
      return "element " + std::to_string(i + 1) + " of " + std::to_string(m);
    };
    if (Status st = data_line(line, what); !st) return st;
    Tokens tok(line);
    std::string_view t_num, t_type, t_ntags;
    std::int64_t num = 0, type = 0, ntags = 0;
    if (!tok.next(t_num) || !tok.next(t_type) || !tok.next(t_ntags) || !parse_int(t_num, num) ||
        !parse_int(t_type, type) || !parse_int(t_ntags, ntags) || ntags < 0)
      return fail(ErrorCode::kParse, "expected 'number type number-of-tags tags... nodes...' for " +
                                         what() + ", got " + quote(trim(line)));
    std::string_view t;
    for (std::int64_t j = 0; j < ntags; ++j)
      if (!tok.next(t))
        return fail(ErrorCode::kParse, "expected " + std::to_string(ntags) + " tags for element " +
                                           std::to_string(num));
    if (type == 4) ++out_.tets_seen;
    if (Status st = element_nodes_text(tok, num, type); !st) return st;
  }
  return expect_line("$EndElements");
}

// ---- MSH 4.1 ASCII ----------------------------------------------------------------

Status GmshParser::parse_nodes_v4_text() {
  std::int64_t h[4];
  if (Status st = read_counts("'numEntityBlocks numNodes minNodeTag maxNodeTag'", 4, h); !st)
    return st;
  const std::int64_t blocks = h[0], num_nodes = h[1], min_tag = h[2], max_tag = h[3];
  const std::size_t header_line = scan_.line();
  // Shortest block header "0 1 0 0\n"; shortest node: "1\n" + "0 0 0\n".
  if (Status st = check_fits(static_cast<std::uint64_t>(blocks), 8, "node blocks"); !st) return st;
  if (Status st = check_fits(static_cast<std::uint64_t>(num_nodes), 8, "nodes"); !st) return st;
  if (Status st = check_node_total(static_cast<std::uint64_t>(num_nodes)); !st) return st;
  out_.ids.reserve(out_.ids.size() + static_cast<std::size_t>(num_nodes));
  out_.xyz.reserve(out_.xyz.size() + 3 * static_cast<std::size_t>(num_nodes));
  std::int64_t total = 0;
  std::vector<std::int64_t> block_tags;
  std::string_view line;
  for (std::int64_t b = 0; b < blocks; ++b) {
    std::int64_t bh[4];
    if (Status st = read_counts("'entityDim entityTag parametric numNodesInBlock'", 4, bh); !st)
      return st;
    const std::int64_t dim = bh[0], parametric = bh[2], count = bh[3];
    if (dim > 3 || parametric > 1)
      return fail(ErrorCode::kParse, "bad node block header: entityDim " + std::to_string(dim) +
                                         ", parametric " + std::to_string(parametric));
    if (count > num_nodes - total)
      return fail(ErrorCode::kParse, "node blocks hold more than the " + std::to_string(num_nodes) +
                                         " nodes announced");
    total += count;
    const std::size_t ncoords = 3 + static_cast<std::size_t>(parametric != 0 ? dim : 0);
    block_tags.clear();
    for (std::int64_t i = 0; i < count; ++i) {
      const auto what = [&] {
        return "node tag " + std::to_string(i + 1) + " of block " + std::to_string(b + 1);
      };
      if (Status st = data_line(line, what); !st) return st;
      std::int64_t tag = 0;
      if (!parse_int(trim(line), tag) || tag < 0)
        return fail(ErrorCode::kParse, "expected " + what() + ", got " + quote(trim(line)));
      if (num_nodes > 0 && (tag < min_tag || tag > max_tag))
        return fail(ErrorCode::kParse, "node tag " + std::to_string(tag) + " outside the range [" +
                                           std::to_string(min_tag) + ", " +
                                           std::to_string(max_tag) +
                                           "] announced in the $Nodes header");
      block_tags.push_back(tag);
    }
    for (std::int64_t i = 0; i < count; ++i) {
      const std::int64_t tag = block_tags[static_cast<std::size_t>(i)];
      const auto what = [&] { return "coordinates of node tag " + std::to_string(tag); };
      if (Status st = data_line(line, what); !st) return st;
      Tokens tok(line);
      std::string_view t;
      double x[3];
      std::size_t got = 0;
      while (tok.next(t)) {
        if (got < 3 && !parse_double(t, x[got]))
          return fail(ErrorCode::kParse, "expected a coordinate of node tag " +
                                             std::to_string(tag) + ", got " + quote(t));
        ++got;
      }
      if (got != ncoords)
        return fail(ErrorCode::kParse, "expected " + std::to_string(ncoords) +
                                           " coordinates for node tag " + std::to_string(tag) +
                                           ", got " + std::to_string(got));
      if (Status st = add_node(tag, x[0], x[1], x[2]); !st)
        return fail(st.error().code, st.error().message);
    }
  }
  if (total != num_nodes)
    return fail_at_line(header_line, ErrorCode::kParse,
                        blocks_hold("$Nodes", static_cast<std::uint64_t>(num_nodes),
                                    static_cast<std::uint64_t>(total), "nodes"));
  return expect_line("$EndNodes");
}

Status GmshParser::parse_elements_v4_text() {
  std::int64_t h[4];
  if (Status st = read_counts("'numEntityBlocks numElements minElementTag maxElementTag'", 4, h);
      !st)
    return st;
  const std::int64_t blocks = h[0], num_elements = h[1];
  const std::size_t header_line = scan_.line();
  // Shortest block header "0 1 15 0\n"; shortest element: "1 1\n".
  if (Status st = check_fits(static_cast<std::uint64_t>(blocks), 9, "element blocks"); !st)
    return st;
  if (Status st = check_fits(static_cast<std::uint64_t>(num_elements), 4, "elements"); !st)
    return st;
  const auto k = static_cast<std::size_t>(wanted_nodes_);
  std::int64_t total = 0;
  std::string_view line;
  for (std::int64_t b = 0; b < blocks; ++b) {
    std::int64_t bh[4];
    if (Status st = read_counts("'entityDim entityTag elementType numElementsInBlock'", 4, bh); !st)
      return st;
    const std::int64_t type = bh[2], count = bh[3];
    if (count > num_elements - total)
      return fail(ErrorCode::kParse, "element blocks hold more than the " +
                                         std::to_string(num_elements) + " elements announced");
    total += count;
    if (type == 4) out_.tets_seen += static_cast<std::uint64_t>(count);
    if (type == wanted_type_)
      out_.conn.reserve(out_.conn.size() + k * static_cast<std::size_t>(count));
    for (std::int64_t i = 0; i < count; ++i) {
      const auto what = [&] {
        return "element " + std::to_string(i + 1) + " of block " + std::to_string(b + 1);
      };
      if (Status st = data_line(line, what); !st) return st;
      Tokens tok(line);
      std::string_view t;
      std::int64_t num = 0;
      if (!tok.next(t) || !parse_int(t, num))
        return fail(ErrorCode::kParse, "expected an element tag, got " + quote(trim(line)));
      if (Status st = element_nodes_text(tok, num, type); !st) return st;
    }
  }
  if (total != num_elements)
    return fail_at_line(header_line, ErrorCode::kParse,
                        blocks_hold("$Elements", static_cast<std::uint64_t>(num_elements),
                                    static_cast<std::uint64_t>(total), "elements"));
  return expect_line("$EndElements");
}

// ---- MSH 4.1 binary ---------------------------------------------------------------

Status GmshParser::parse_nodes_v4_binary() {
  BinaryCursor c(scan_.data(), scan_.offset());
  if (!c.has(32)) return truncated(c, "the $Nodes header (4 x size_t)");
  const std::size_t header_at = c.pos();
  const auto blocks = c.take<std::uint64_t>();
  const auto num_nodes = c.take<std::uint64_t>();
  const auto min_tag = c.take<std::uint64_t>();
  const auto max_tag = c.take<std::uint64_t>();
  // Block header: 3 int + size_t; node: size_t tag + 3 doubles.
  if (blocks > c.remaining() / 20 || num_nodes > c.remaining() / 32)
    return fail_at(header_at, ErrorCode::kParse,
                   "$Nodes header announces " + std::to_string(blocks) + " blocks and " +
                       std::to_string(num_nodes) + " nodes, more than the remaining " +
                       std::to_string(c.remaining()) + " bytes can hold");
  if (Status st = check_node_total(num_nodes); !st) return st;
  out_.ids.reserve(out_.ids.size() + static_cast<std::size_t>(num_nodes));
  out_.xyz.reserve(out_.xyz.size() + 3 * static_cast<std::size_t>(num_nodes));
  std::uint64_t total = 0;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::size_t block_at = c.pos();
    if (!c.has(20)) return truncated(c, "the header of node block " + std::to_string(b + 1));
    const auto dim = c.take<std::int32_t>();
    c.take<std::int32_t>();  // entity tag
    const auto parametric = c.take<std::int32_t>();
    const auto count = c.take<std::uint64_t>();
    if (dim < 0 || dim > 3 || parametric < 0 || parametric > 1)
      return fail_at(block_at, ErrorCode::kParse,
                     "bad node block header: entityDim " + std::to_string(dim) + ", parametric " +
                         std::to_string(parametric));
    const std::uint64_t ncoords = 3 + static_cast<std::uint64_t>(parametric != 0 ? dim : 0);
    const std::uint64_t per_node = 8 + 8 * ncoords;
    if (count > num_nodes - total)
      return fail_at(
          block_at, ErrorCode::kParse,
          "node blocks hold more than the " + std::to_string(num_nodes) + " nodes announced");
    if (count > c.remaining() / per_node)
      return truncated(c, std::to_string(count) + " nodes in block " + std::to_string(b + 1));
    total += count;
    const char* tags = c.here();
    const char* coords = tags + 8 * count;
    for (std::uint64_t i = 0; i < count; ++i) {
      const auto tag = load_le<std::uint64_t>(tags + 8 * i);
      const std::size_t tag_at = c.pos() + static_cast<std::size_t>(8 * i);
      if (tag > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
        return fail_at(tag_at, ErrorCode::kParse,
                       "node tag " + std::to_string(tag) + " is too large");
      if (num_nodes > 0 && (tag < min_tag || tag > max_tag))
        return fail_at(tag_at, ErrorCode::kParse,
                       "node tag " + std::to_string(tag) + " outside the range [" +
                           std::to_string(min_tag) + ", " + std::to_string(max_tag) +
                           "] announced in the $Nodes header");
      const char* x = coords + 8 * ncoords * i;
      if (Status st = add_node(static_cast<std::int64_t>(tag), load_le<double>(x),
                               load_le<double>(x + 8), load_le<double>(x + 16));
          !st)
        return fail_at(static_cast<std::size_t>(x - scan_.data().data()), st.error().code,
                       st.error().message);
    }
    c.skip(per_node * count);
  }
  if (total != num_nodes)
    return fail_at(header_at, ErrorCode::kParse, blocks_hold("$Nodes", num_nodes, total, "nodes"));
  scan_.seek(c.pos());
  return expect_line("$EndNodes");
}

Status GmshParser::parse_elements_v4_binary() {
  BinaryCursor c(scan_.data(), scan_.offset());
  if (!c.has(32)) return truncated(c, "the $Elements header (4 x size_t)");
  const std::size_t header_at = c.pos();
  const auto blocks = c.take<std::uint64_t>();
  const auto num_elements = c.take<std::uint64_t>();
  c.skip(16);  // min and max element tags
  // Block header: 3 int + size_t; element: at least 2 size_t.
  if (blocks > c.remaining() / 20 || num_elements > c.remaining() / 16)
    return fail_at(header_at, ErrorCode::kParse,
                   "$Elements header announces " + std::to_string(blocks) + " blocks and " +
                       std::to_string(num_elements) + " elements, more than the remaining " +
                       std::to_string(c.remaining()) + " bytes can hold");
  const auto k = static_cast<std::size_t>(wanted_nodes_);
  std::uint64_t total = 0;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    const std::size_t block_at = c.pos();
    if (!c.has(20)) return truncated(c, "the header of element block " + std::to_string(b + 1));
    c.take<std::int32_t>();  // entity dim
    c.take<std::int32_t>();  // entity tag
    const auto type = c.take<std::int32_t>();
    const auto count = c.take<std::uint64_t>();
    const int nodes = gmsh_element_node_count(type);
    if (nodes == 0)
      return fail_at(block_at, ErrorCode::kUnsupported,
                     "element type " + std::to_string(type) +
                         " has no known fixed node count, so its block cannot be skipped");
    if (count > num_elements - total)
      return fail_at(block_at, ErrorCode::kParse,
                     "element blocks hold more than the " + std::to_string(num_elements) +
                         " elements announced");
    const std::uint64_t per_element = 8 * (1 + static_cast<std::uint64_t>(nodes));
    if (count > c.remaining() / per_element)
      return truncated(c, std::to_string(count) + " elements of type " + std::to_string(type) +
                              " in block " + std::to_string(b + 1));
    total += count;
    if (type == 4) out_.tets_seen += count;
    if (type == wanted_type_) {
      if (out_.conn.size() / k + count > kMaxCount)
        return fail_at(block_at, ErrorCode::kUnsupported, "more than 2^31-1 elements");
      out_.conn.reserve(out_.conn.size() + k * static_cast<std::size_t>(count));
      const char* p = c.here();
      for (std::uint64_t i = 0; i < count; ++i, p += per_element) {
        const auto num = load_le<std::uint64_t>(p);
        for (std::size_t j = 0; j < k; ++j) {
          const auto node = load_le<std::uint64_t>(p + 8 * (1 + j));
          const Index index = node_index(node);
          if (index < 0)
            return fail_at(static_cast<std::size_t>(p - scan_.data().data()) + 8 * (1 + j),
                           ErrorCode::kInvalidMesh, unknown_node(num, node));
          out_.conn.push_back(index);
        }
      }
    }
    c.skip(per_element * count);
  }
  if (total != num_elements)
    return fail_at(header_at, ErrorCode::kParse,
                   blocks_hold("$Elements", num_elements, total, "elements"));
  scan_.seek(c.pos());
  return expect_line("$EndElements");
}

Status GmshParser::parse_entities_binary() {
  BinaryCursor c(scan_.data(), scan_.offset());
  if (!c.has(32)) return truncated(c, "the $Entities header (4 x size_t)");
  std::uint64_t counts[4];
  for (auto& n : counts) n = c.take<std::uint64_t>();
  static constexpr const char* kKinds[4] = {"point", "curve", "surface", "volume"};
  for (int kind = 0; kind < 4; ++kind) {
    // Point: int tag, 3 doubles, size_t; others: int tag, 6 doubles, 2 size_t.
    const std::uint64_t min_bytes = kind == 0 ? 36 : 68;
    if (counts[kind] > c.remaining() / min_bytes)
      return truncated(c, std::to_string(counts[kind]) + " " + kKinds[kind] + " entities");
    for (std::uint64_t e = 0; e < counts[kind]; ++e) {
      const auto what = [&] {
        return std::string(kKinds[kind]) + " entity " + std::to_string(e + 1);
      };
      if (!c.has(min_bytes - (kind == 0 ? 0 : 8))) return truncated(c, what());
      c.skip(kind == 0 ? 4 + 24 : 4 + 48);
      const auto physicals = c.take<std::uint64_t>();
      if (physicals > c.remaining() / 4) return truncated(c, "physical tags of " + what());
      c.skip(4 * physicals);
      if (kind > 0) {
        if (!c.has(8)) return truncated(c, "bounding entity count of " + what());
        const auto bounding = c.take<std::uint64_t>();
        if (bounding > c.remaining() / 4) return truncated(c, "bounding entities of " + what());
        c.skip(4 * bounding);
      }
    }
  }
  scan_.seek(c.pos());
  return expect_line("$EndEntities");
}

}  // namespace

Expected<TetMesh> read_gmsh_buffer(std::string_view data, const std::string& name) {
  GmshParser parser(data, name, 4, 4);
  if (Status st = parser.parse(); !st) return st.error();
  GmshData& d = parser.result();
  TetMesh mesh;
  mesh.node_ids = std::move(d.ids);
  mesh.positions =
      Eigen::Map<const Positions>(d.xyz.data(), 3, static_cast<Eigen::Index>(mesh.node_ids.size()));
  mesh.tets.resize(d.conn.size() / 4);
  for (std::size_t i = 0; i < mesh.tets.size(); ++i)
    for (std::size_t j = 0; j < 4; ++j) mesh.tets[i][j] = d.conn[4 * i + j];
  return mesh;
}

Expected<TriMesh2> read_gmsh_triangles_buffer(std::string_view data, const std::string& name) {
  GmshParser parser(data, name, 2, 3);
  if (Status st = parser.parse(); !st) return st.error();
  GmshData& d = parser.result();
  TriMesh2 mesh;
  mesh.node_ids = std::move(d.ids);
  const auto n = static_cast<Eigen::Index>(mesh.node_ids.size());
  mesh.positions.resize(2, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    mesh.positions(0, i) = d.xyz[static_cast<std::size_t>(3 * i)];
    mesh.positions(1, i) = d.xyz[static_cast<std::size_t>(3 * i + 1)];
  }
  mesh.triangles.resize(d.conn.size() / 3);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (std::size_t j = 0; j < 3; ++j) mesh.triangles[i][j] = d.conn[3 * i + j];
  return mesh;
}

Expected<SurfaceMesh> read_gmsh_surface_buffer(std::string_view data, const std::string& name) {
  GmshParser parser(data, name, 2, 3);
  if (Status st = parser.parse(); !st) return st.error();
  GmshData& d = parser.result();
  if (d.tets_seen > 0)
    return Error{ErrorCode::kUnsupported,
                 name + ": holds " + std::to_string(d.tets_seen) +
                     " tetrahedra: a tet mesh, not a surface (a surface file has 3-node "
                     "triangles and no tets)"};
  if (d.conn.empty())
    return Error{ErrorCode::kUnsupported,
                 name + ": no 3-node triangles (element type 2): not a surface"};
  SurfaceMesh mesh;
  mesh.node_ids = std::move(d.ids);
  mesh.positions =
      Eigen::Map<const Positions>(d.xyz.data(), 3, static_cast<Eigen::Index>(mesh.node_ids.size()));
  mesh.triangles.resize(d.conn.size() / 3);
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (std::size_t j = 0; j < 3; ++j) mesh.triangles[i][j] = d.conn[3 * i + j];
  return mesh;
}

Expected<SurfaceMesh> read_gmsh_surface(const std::filesystem::path& path) {
  auto data = io_detail::read_whole_file(path);
  if (!data) return data.error();
  return read_gmsh_surface_buffer(*data, path.string());
}

Expected<TetMesh> read_gmsh(const std::filesystem::path& path) {
  auto data = io_detail::read_whole_file(path);
  if (!data) return data.error();
  return read_gmsh_buffer(*data, path.string());
}

Expected<TriMesh2> read_gmsh_triangles(const std::filesystem::path& path) {
  auto data = io_detail::read_whole_file(path);
  if (!data) return data.error();
  return read_gmsh_triangles_buffer(*data, path.string());
}

}  // namespace tc
