// TetGen .node + .ele writer, the files tetgen_reader.cpp reads and TetGen writes:
//
//   stem.node: "<#points> 3 0 0", then "<index> <x> <y> <z>" per point;
//   stem.ele:  "<#tets> 4 0", then "<index> <n1> <n2> <n3> <n4>" per tet.
//
// TetGen numbers points consecutively from a base of 0 or 1 (the first point's index),
// and the .ele refers to them from that same base. The base is 0 when the mesh's node
// ids are exactly 0..n-1 (a 0-based TetGen file read back), else 1, so the ids of a
// TetGen file, and Gmsh tags 1..n, survive a round trip; other ids (Gmsh tags with gaps)
// cannot be written and become base..base+n-1 in node order. Coordinates use the
// shortest form that reads back to the same double (std::to_chars), so positions
// round-trip bit for bit; tets keep their node order (never flipped).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <string>

#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"

namespace tc {
namespace {

void append_int(std::string& s, std::int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  s.append(buf, r.ptr);
}

void append_double(std::string& s, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  s.append(buf, r.ptr);
}

/// Checks what a TetGen file can hold and what the reader would refuse: one id per
/// node, finite coordinates, tets referring to existing nodes.
Status check_writable(const TetMesh& mesh) {
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  if (mesh.node_ids.size() != n)
    return Error{ErrorCode::kInvalidArgument, "mesh has " + std::to_string(mesh.node_ids.size()) +
                                                  " node ids for " + std::to_string(n) + " nodes"};
  for (std::size_t i = 0; i < n; ++i)
    if (!mesh.positions.col(static_cast<Eigen::Index>(i)).allFinite())
      return Error{ErrorCode::kInvalidArgument,
                   "node " + std::to_string(i) + " has a non-finite coordinate"};
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (const Index v : mesh.tets[t])
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        return Error{ErrorCode::kInvalidArgument, "tet " + std::to_string(t) + " refers to node " +
                                                      std::to_string(v) + ", outside [0, " +
                                                      std::to_string(n) + ")"};
  return {};
}

}  // namespace

std::int64_t tetgen_base(const TetMesh& mesh) {
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    if (mesh.node_ids[i] != static_cast<std::int64_t>(i)) return 1;
  return 0;
}

Expected<TetGenText> format_tetgen(const TetMesh& mesh) {
  if (Status st = check_writable(mesh); !st) return st.error();
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  const std::size_t m = mesh.tets.size();
  const std::int64_t base = tetgen_base(mesh);
  TetGenText out;
  std::string& node = out.node;
  node.reserve(32 + n * 64);
  append_int(node, static_cast<std::int64_t>(n));
  node += " 3 0 0\n";
  for (std::size_t i = 0; i < n; ++i) {
    append_int(node, base + static_cast<std::int64_t>(i));
    for (int k = 0; k < 3; ++k) {
      node += ' ';
      append_double(node, mesh.positions(k, static_cast<Eigen::Index>(i)));
    }
    node += '\n';
  }
  std::string& ele = out.ele;
  ele.reserve(32 + m * 48);
  append_int(ele, static_cast<std::int64_t>(m));
  ele += " 4 0\n";
  for (std::size_t t = 0; t < m; ++t) {
    append_int(ele, base + static_cast<std::int64_t>(t));
    for (const Index v : mesh.tets[t]) {
      ele += ' ';
      append_int(ele, base + v);
    }
    ele += '\n';
  }
  return out;
}

std::filesystem::path tetgen_stem(const std::filesystem::path& path) {
  std::filesystem::path stem = path;
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".node" || ext == ".ele") stem.replace_extension();
  return stem;
}

Status write_tetgen(const std::filesystem::path& path, const TetMesh& mesh) {
  const std::string stem = tetgen_stem(path).string();
  auto text = format_tetgen(mesh);
  if (!text) return Error{text.error().code, stem + ".node: " + text.error().message};
  if (Status st = io_detail::write_whole_file(stem + ".node", text->node); !st) return st;
  return io_detail::write_whole_file(stem + ".ele", text->ele);
}

}  // namespace tc
