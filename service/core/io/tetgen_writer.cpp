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
#include "core/io/text_write.hpp"

namespace tc {

using io_detail::append_double;
using io_detail::append_int;

std::int64_t tetgen_base(const TetMesh& mesh) {
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i)
    if (mesh.node_ids[i] != static_cast<std::int64_t>(i)) return 1;
  return 0;
}

Expected<TetGenText> format_tetgen(const TetMesh& mesh) {
  if (Status st = io_detail::check_mesh_for_writing(mesh); !st) return st.error();
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
