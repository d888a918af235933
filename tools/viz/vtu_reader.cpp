// A small reader for the project's own ASCII .vtu output (see vtu_reader.hpp).
#include "vtu_reader.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace tc::viz {
namespace {

Error parse_error(const std::string& name, const std::string& message) {
  return Error{ErrorCode::kParse, name + ": " + message};
}

/// Value of attribute `key` inside a tag's text, or empty.
std::string attribute(std::string_view tag, std::string_view key) {
  std::size_t pos = 0;
  while ((pos = tag.find(key, pos)) != std::string_view::npos) {
    const bool word_start = pos == 0 || tag[pos - 1] == ' ' || tag[pos - 1] == '\t' ||
                            tag[pos - 1] == '\n' || tag[pos - 1] == '\r';
    const std::size_t eq = pos + key.size();
    if (word_start && eq + 1 < tag.size() && tag[eq] == '=' && tag[eq + 1] == '"') {
      const std::size_t end = tag.find('"', eq + 2);
      if (end == std::string_view::npos) return {};
      return std::string(tag.substr(eq + 2, end - eq - 2));
    }
    pos = eq;
  }
  return {};
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

struct Array {
  std::string section;  // PointData, CellData, Points, Cells
  std::string name;
  int components = 1;
  std::vector<double> values;
};

bool parse_count(const std::string& s, long long& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  out = std::strtoll(s.c_str(), &end, 10);
  return *end == '\0' && out >= 0;
}

}  // namespace

Expected<VtuMesh> read_vtu_buffer(std::string_view data, const std::string& name) {
  if (data.find("<VTKFile") == std::string_view::npos ||
      data.find("UnstructuredGrid") == std::string_view::npos)
    return parse_error(name, "not a VTK XML UnstructuredGrid file");
  const std::size_t piece = data.find("<Piece");
  if (piece == std::string_view::npos) return parse_error(name, "no <Piece> element");
  const std::size_t piece_end = data.find('>', piece);
  if (piece_end == std::string_view::npos) return parse_error(name, "unterminated <Piece> tag");
  const std::string_view piece_tag = data.substr(piece, piece_end - piece);
  long long n = 0, m = 0;
  if (!parse_count(attribute(piece_tag, "NumberOfPoints"), n) ||
      !parse_count(attribute(piece_tag, "NumberOfCells"), m))
    return parse_error(name, "<Piece> lacks NumberOfPoints/NumberOfCells");
  if (n > (1LL << 31) - 1 || m > (1LL << 31) - 1)
    return Error{ErrorCode::kOversized, name + ": too many points or cells"};

  // Walk the tags in order; the enclosing section is the last one opened.
  std::vector<Array> arrays;
  std::string section;
  std::size_t pos = piece_end;
  while (true) {
    const std::size_t lt = data.find('<', pos);
    if (lt == std::string_view::npos) break;
    const std::size_t gt = data.find('>', lt);
    if (gt == std::string_view::npos) return parse_error(name, "unterminated tag");
    const std::string_view tag = data.substr(lt + 1, gt - lt - 1);
    pos = gt + 1;
    for (const char* s : {"PointData", "CellData", "Points", "Cells"}) {
      const std::string_view sv(s);
      if (tag.substr(0, sv.size()) == sv &&
          (tag.size() == sv.size() || tag[sv.size()] == ' ' || tag[sv.size()] == '/'))
        section = s;
      if (tag.size() == sv.size() + 1 && tag[0] == '/' && tag.substr(1) == sv) section.clear();
    }
    if (tag.substr(0, 4) == "/Pie") break;
    if (tag.substr(0, 9) != "DataArray") continue;
    Array a;
    a.section = section;
    a.name = attribute(tag, "Name");
    const std::string format = attribute(tag, "format");
    if (format != "ascii")
      return Error{ErrorCode::kUnsupported, name + ": DataArray '" + a.name + "' has format '" +
                                                format + "' (only ascii is read)"};
    const std::string comps = attribute(tag, "NumberOfComponents");
    long long c = 1;
    if (!comps.empty() && (!parse_count(comps, c) || c < 1 || c > 9))
      return parse_error(name, "DataArray '" + a.name + "': bad NumberOfComponents");
    a.components = static_cast<int>(c);
    const std::size_t close = data.find("</DataArray>", pos);
    if (close == std::string_view::npos)
      return parse_error(name, "DataArray '" + a.name + "' is not closed");
    const std::string text(data.substr(pos, close - pos));
    const char* p = text.c_str();
    while (true) {
      while (*p == ' ' || *p == '\n' || *p == '\r' || *p == '\t') ++p;
      if (*p == '\0') break;
      char* end = nullptr;
      const double v = std::strtod(p, &end);
      if (end == p)
        return parse_error(name, "DataArray '" + a.name + "': bad number after value " +
                                     std::to_string(a.values.size()));
      a.values.push_back(v);
      p = end;
    }
    pos = close + 12;
    arrays.push_back(std::move(a));
  }

  const Array* points = nullptr;
  const Array* conn = nullptr;
  const Array* offsets = nullptr;
  const Array* types = nullptr;
  for (const Array& a : arrays) {
    if (a.section == "Points") points = &a;
    if (a.section == "Cells" && a.name == "connectivity") conn = &a;
    if (a.section == "Cells" && a.name == "offsets") offsets = &a;
    if (a.section == "Cells" && a.name == "types") types = &a;
  }
  if (points == nullptr || points->components != 3 ||
      points->values.size() != static_cast<std::size_t>(n) * 3)
    return parse_error(name, "expected a Points array of " + std::to_string(n) + " x 3 values");
  if (m > 0 && (conn == nullptr || offsets == nullptr || types == nullptr))
    return parse_error(name, "Cells needs connectivity, offsets and types");
  if (m > 0 && (offsets->values.size() != static_cast<std::size_t>(m) ||
                types->values.size() != static_cast<std::size_t>(m)))
    return parse_error(name, "expected " + std::to_string(m) + " cell offsets and types");

  VtuMesh out;
  out.mesh.positions.resize(3, static_cast<Eigen::Index>(n));
  for (long long i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      const double v = points->values[static_cast<std::size_t>(i * 3 + k)];
      if (!std::isfinite(v))
        return Error{ErrorCode::kInvalidMesh,
                     name + ": point " + std::to_string(i) + " has a non-finite coordinate"};
      out.mesh.positions(k, static_cast<Eigen::Index>(i)) = v;
    }
  double start = 0;
  for (long long c = 0; c < m; ++c) {
    const double end = offsets->values[static_cast<std::size_t>(c)];
    if (!(end >= start) || end > static_cast<double>(conn->values.size()))
      return parse_error(name, "cell " + std::to_string(c) + ": bad offset");
    const auto b = static_cast<std::size_t>(start), e = static_cast<std::size_t>(end);
    start = end;
    if (types->values[static_cast<std::size_t>(c)] != 10) continue;  // not a tetrahedron
    if (e - b != 4)
      return parse_error(
          name, "tetrahedron " + std::to_string(c) + " has " + std::to_string(e - b) + " nodes");
    Tet t{};
    for (int k = 0; k < 4; ++k) {
      const double v = conn->values[b + static_cast<std::size_t>(k)];
      if (!(v >= 0 && v < static_cast<double>(n)) || v != std::floor(v))
        return Error{ErrorCode::kInvalidMesh, name + ": cell " + std::to_string(c) +
                                                  " refers to point " + number(v) + " of " +
                                                  std::to_string(n)};
      t[static_cast<std::size_t>(k)] = static_cast<Index>(v);
    }
    out.mesh.tets.push_back(t);
  }
  out.mesh.node_ids.resize(static_cast<std::size_t>(n));
  for (long long i = 0; i < n; ++i) out.mesh.node_ids[static_cast<std::size_t>(i)] = i;
  for (const Array& a : arrays) {
    if (a.section != "PointData") continue;
    if (a.values.size() != static_cast<std::size_t>(n) * static_cast<std::size_t>(a.components))
      return parse_error(name, "point field '" + a.name + "' has " +
                                   std::to_string(a.values.size()) + " values for " +
                                   std::to_string(n) + " points");
    if (a.name == "node_id" && a.components == 1) {
      for (long long i = 0; i < n; ++i)
        out.mesh.node_ids[static_cast<std::size_t>(i)] =
            static_cast<std::int64_t>(a.values[static_cast<std::size_t>(i)]);
    }
    VtuField f;
    f.name = a.name;
    f.components = 1;
    f.values.resize(static_cast<std::size_t>(n));
    for (long long i = 0; i < n; ++i) {
      double s = 0;
      for (int k = 0; k < a.components; ++k) {
        const double v = a.values[static_cast<std::size_t>(i * a.components + k)];
        s += a.components == 1 ? v : v * v;
      }
      f.values[static_cast<std::size_t>(i)] = a.components == 1 ? s : std::sqrt(s);
    }
    out.point_fields.push_back(std::move(f));
  }
  return out;
}

Expected<VtuMesh> read_vtu(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{ErrorCode::kIo, path.string() + ": cannot open file"};
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return Error{ErrorCode::kIo, path.string() + ": read failed"};
  return read_vtu_buffer(ss.str(), path.string());
}

}  // namespace tc::viz
