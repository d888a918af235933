// VTK XML UnstructuredGrid writer (.vtu, ASCII), as specified in "VTK File Formats"
// (XML formats): <VTKFile type="UnstructuredGrid"> / <UnstructuredGrid> / one <Piece>
// with <PointData>, <CellData>, <Points> (Float64 x 3) and <Cells> (connectivity and
// offsets as Int64, types as UInt8; 10 = VTK_TETRA, 5 = VTK_TRIANGLE after the tets for the
// surface objects of a mixed grid). Offsets are the end position of
// each cell in the connectivity array (4, 8, 12, ...). Numbers use the shortest form
// that reads back to the same double, so a file round-trips exactly.
#include <charconv>
#include <cmath>
#include <set>
#include <string>

#include "core/common/xml.hpp"
#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"
#include "core/io/text_write.hpp"

namespace tc {
namespace {

constexpr int kVtkTetra = 10;
constexpr int kVtkTriangle = 5;

void append_number(std::string& s, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  s.append(buf, r.ptr);
}

void append_number(std::string& s, std::int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  s.append(buf, r.ptr);
}

/// Values are written 6 per line (x y z of two points, or 6 scalars).
template <typename Range>
void append_values(std::string& s, const Range& values, std::size_t per_line) {
  std::size_t i = 0;
  for (const auto v : values) {
    s += i % per_line == 0 ? "          " : " ";
    append_number(s, v);
    if (++i % per_line == 0) s += '\n';
  }
  if (i % per_line != 0) s += '\n';
}

void open_array(std::string& s, std::string_view type, std::string_view name, int components) {
  s += "        <DataArray type=\"";
  s += type;
  s += "\" Name=\"";
  s += xml_escape(name);
  s += '"';
  if (components != 1) {
    s += " NumberOfComponents=\"";
    s += std::to_string(components);
    s += '"';
  }
  s += " format=\"ascii\">\n";
}

void close_array(std::string& s) {
  s += "        </DataArray>\n";
}

Status check_fields(std::span<const VtuField> fields, std::size_t count, const char* kind,
                    std::set<std::string>& names) {
  for (const VtuField& f : fields) {
    if (f.name.empty())
      return Error{ErrorCode::kInvalidArgument, std::string(kind) + " field with an empty name"};
    if (!names.insert(f.name).second)
      return Error{ErrorCode::kInvalidArgument,
                   std::string(kind) + " field name '" + f.name + "' used twice"};
    if (f.components != 1 && f.components != 3)
      return Error{ErrorCode::kInvalidArgument, std::string(kind) + " field '" + f.name + "' has " +
                                                    std::to_string(f.components) +
                                                    " components (expected 1 or 3)"};
    const std::size_t expected = count * static_cast<std::size_t>(f.components);
    if (f.values.size() != expected)
      return Error{ErrorCode::kInvalidArgument,
                   std::string(kind) + " field '" + f.name + "' has " +
                       std::to_string(f.values.size()) + " values, expected " +
                       std::to_string(expected) + " (" + std::to_string(count) + " x " +
                       std::to_string(f.components) + ")"};
    for (std::size_t i = 0; i < f.values.size(); ++i)
      if (!std::isfinite(f.values[i]))
        return Error{ErrorCode::kInvalidArgument,
                     std::string(kind) + " field '" + f.name + "' value " + std::to_string(i) +
                         " is not finite (VTK's ASCII reader cannot read it)"};
  }
  return {};
}

void append_fields(std::string& s, std::span<const VtuField> fields) {
  for (const VtuField& f : fields) {
    open_array(s, "Float64", f.name, f.components);
    append_values(s, f.values, 6);
    close_array(s);
  }
}

Expected<std::string> format_vtu(const TetMesh& mesh,
                                 std::span<const std::array<Index, 3>> triangles,
                                 std::span<const VtuField> point_fields,
                                 std::span<const VtuField> cell_fields) {
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  const std::size_t tets = mesh.tets.size();
  const std::size_t m = tets + triangles.size();
  if (Status st = io_detail::check_mesh_for_writing(mesh, triangles); !st) return st.error();
  std::set<std::string> point_names = {"node_id"};
  if (Status st = check_fields(point_fields, n, "point", point_names); !st) return st.error();
  std::set<std::string> cell_names;
  if (Status st = check_fields(cell_fields, m, "cell", cell_names); !st) return st.error();

  std::string s;
  s.reserve(512 + n * 80 + m * 40);
  s += "<?xml version=\"1.0\"?>\n";
  s += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
       "header_type=\"UInt64\">\n";
  s += "  <UnstructuredGrid>\n";
  s += "    <Piece NumberOfPoints=\"" + std::to_string(n) + "\" NumberOfCells=\"" +
       std::to_string(m) + "\">\n";

  s += "      <PointData>\n";
  open_array(s, "Int64", "node_id", 1);
  append_values(s, mesh.node_ids, 6);
  close_array(s);
  append_fields(s, point_fields);
  s += "      </PointData>\n";

  s += "      <CellData>\n";
  append_fields(s, cell_fields);
  s += "      </CellData>\n";

  s += "      <Points>\n";
  open_array(s, "Float64", "Points", 3);
  append_values(s, std::span<const double>(mesh.positions.data(), 3 * n), 6);
  close_array(s);
  s += "      </Points>\n";

  s += "      <Cells>\n";
  open_array(s, "Int64", "connectivity", 1);
  std::vector<std::int64_t> ints;
  ints.reserve(4 * m);
  for (const Tet& t : mesh.tets)
    for (const Index v : t) ints.push_back(v);
  for (const auto& t : triangles)
    for (const Index v : t) ints.push_back(v);
  append_values(s, ints, 8);
  close_array(s);
  open_array(s, "Int64", "offsets", 1);
  ints.clear();
  for (std::size_t t = 0; t < tets; ++t) ints.push_back(static_cast<std::int64_t>(4 * (t + 1)));
  for (std::size_t t = 0; t < triangles.size(); ++t)
    ints.push_back(static_cast<std::int64_t>(4 * tets + 3 * (t + 1)));
  append_values(s, ints, 8);
  close_array(s);
  open_array(s, "UInt8", "types", 1);
  ints.assign(tets, kVtkTetra);
  ints.insert(ints.end(), triangles.size(), kVtkTriangle);
  append_values(s, ints, 16);
  close_array(s);
  s += "      </Cells>\n";

  s += "    </Piece>\n";
  s += "  </UnstructuredGrid>\n";
  s += "</VTKFile>\n";
  return s;
}

}  // namespace

Status write_vtu(const std::filesystem::path& path, const TetMesh& mesh,
                 std::span<const VtuField> point_fields, std::span<const VtuField> cell_fields) {
  return write_vtu(path, mesh, {}, point_fields, cell_fields);
}

Status write_vtu(const std::filesystem::path& path, const TetMesh& mesh,
                 std::span<const std::array<Index, 3>> triangles,
                 std::span<const VtuField> point_fields, std::span<const VtuField> cell_fields) {
  auto text = format_vtu(mesh, triangles, point_fields, cell_fields);
  if (!text) return Error{text.error().code, path.string() + ": " + text.error().message};
  return io_detail::write_whole_file(path, *text);
}

}  // namespace tc
