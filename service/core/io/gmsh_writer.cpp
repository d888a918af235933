// Gmsh .msh writer (2.2 ASCII, 4.1 ASCII and 4.1 binary): tets only, so that meshes
// built in code can be handed to Gmsh, and so the readers can be checked on round trips
// and timed on large files.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <string>

#include "core/io/mesh_io.hpp"
#include "core/io/scan.hpp"
#include "core/io/text_write.hpp"

namespace tc {
namespace {

using io_detail::append_double;
using io_detail::append_int;

template <typename T>
void append_binary(std::string& s, T v) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
  s.append(bytes, sizeof(T));
}

/// The writers' common check, then what Gmsh needs of the ids: positive and distinct tags.
Status check_writable(const TetMesh& mesh) {
  if (Status st = io_detail::check_mesh_for_writing(mesh); !st) return st;
  io_detail::TagMap seen;
  for (std::size_t i = 0; i < mesh.node_ids.size(); ++i) {
    const std::int64_t id = mesh.node_ids[i];
    if (id <= 0)
      return Error{ErrorCode::kInvalidArgument,
                   "node " + std::to_string(i) + " has id " + std::to_string(id) +
                       ", not a valid Gmsh node tag (tags are positive)"};
    if (!seen.insert(id, static_cast<Index>(i)))
      return Error{ErrorCode::kInvalidArgument, "duplicate node id " + std::to_string(id)};
  }
  return {};
}

}  // namespace

Expected<std::string> format_gmsh(const TetMesh& mesh, GmshFormat format) {
  if (Status st = check_writable(mesh); !st) return st.error();
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  const std::size_t m = mesh.tets.size();
  std::string s;
  s.reserve(64 + n * 64 + m * 48);
  const auto id = [&](Index v) { return mesh.node_ids[static_cast<std::size_t>(v)]; };
  const auto coord = [&](std::size_t i, int k) {
    return mesh.positions(k, static_cast<Eigen::Index>(i));
  };

  if (format == GmshFormat::kMsh22Ascii) {
    s += "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n";
    append_int(s, static_cast<std::int64_t>(n));
    s += '\n';
    for (std::size_t i = 0; i < n; ++i) {
      append_int(s, mesh.node_ids[i]);
      for (int k = 0; k < 3; ++k) {
        s += ' ';
        append_double(s, coord(i, k));
      }
      s += '\n';
    }
    s += "$EndNodes\n$Elements\n";
    append_int(s, static_cast<std::int64_t>(m));
    s += '\n';
    for (std::size_t t = 0; t < m; ++t) {
      append_int(s, static_cast<std::int64_t>(t + 1));
      s += " 4 2 0 1";  // type 4, two tags: physical 0, elementary 1
      for (const Index v : mesh.tets[t]) {
        s += ' ';
        append_int(s, id(v));
      }
      s += '\n';
    }
    s += "$EndElements\n";
    return s;
  }

  std::int64_t min_tag = 0;
  std::int64_t max_tag = 0;
  if (n > 0) {
    min_tag = *std::min_element(mesh.node_ids.begin(), mesh.node_ids.end());
    max_tag = *std::max_element(mesh.node_ids.begin(), mesh.node_ids.end());
  }
  const std::int64_t node_blocks = n > 0 ? 1 : 0;
  const std::int64_t element_blocks = m > 0 ? 1 : 0;

  if (format == GmshFormat::kMsh41Ascii) {
    s += "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n";
    for (const std::int64_t v : {node_blocks, static_cast<std::int64_t>(n), min_tag, max_tag}) {
      append_int(s, v);
      s += ' ';
    }
    s.back() = '\n';
    if (n > 0) {
      s += "3 1 0 ";
      append_int(s, static_cast<std::int64_t>(n));
      s += '\n';
      for (std::size_t i = 0; i < n; ++i) {
        append_int(s, mesh.node_ids[i]);
        s += '\n';
      }
      for (std::size_t i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) {
          append_double(s, coord(i, k));
          s += k < 2 ? ' ' : '\n';
        }
      }
    }
    s += "$EndNodes\n$Elements\n";
    for (const std::int64_t v : {element_blocks, static_cast<std::int64_t>(m),
                                 std::int64_t{m > 0 ? 1 : 0}, static_cast<std::int64_t>(m)}) {
      append_int(s, v);
      s += ' ';
    }
    s.back() = '\n';
    if (m > 0) {
      s += "3 1 4 ";
      append_int(s, static_cast<std::int64_t>(m));
      s += '\n';
      for (std::size_t t = 0; t < m; ++t) {
        append_int(s, static_cast<std::int64_t>(t + 1));
        for (const Index v : mesh.tets[t]) {
          s += ' ';
          append_int(s, id(v));
        }
        s += '\n';
      }
    }
    s += "$EndElements\n";
    return s;
  }

  // 4.1 binary, little-endian, size_t of 8 bytes.
  s += "$MeshFormat\n4.1 1 8\n";
  append_binary<std::int32_t>(s, 1);
  s += "\n$EndMeshFormat\n$Nodes\n";
  for (const std::int64_t v : {node_blocks, static_cast<std::int64_t>(n), min_tag, max_tag})
    append_binary<std::uint64_t>(s, static_cast<std::uint64_t>(v));
  if (n > 0) {
    for (const std::int32_t v : {3, 1, 0}) append_binary<std::int32_t>(s, v);
    append_binary<std::uint64_t>(s, n);
    for (std::size_t i = 0; i < n; ++i)
      append_binary<std::uint64_t>(s, static_cast<std::uint64_t>(mesh.node_ids[i]));
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) append_binary<double>(s, coord(i, k));
  }
  s += "\n$EndNodes\n$Elements\n";
  for (const std::uint64_t v :
       {static_cast<std::uint64_t>(element_blocks), static_cast<std::uint64_t>(m),
        std::uint64_t{m > 0 ? 1u : 0u}, static_cast<std::uint64_t>(m)})
    append_binary<std::uint64_t>(s, v);
  if (m > 0) {
    for (const std::int32_t v : {3, 1, 4}) append_binary<std::int32_t>(s, v);
    append_binary<std::uint64_t>(s, m);
    for (std::size_t t = 0; t < m; ++t) {
      append_binary<std::uint64_t>(s, t + 1);
      for (const Index v : mesh.tets[t])
        append_binary<std::uint64_t>(s, static_cast<std::uint64_t>(id(v)));
    }
  }
  s += "\n$EndElements\n";
  return s;
}

Status write_gmsh(const std::filesystem::path& path, const TetMesh& mesh, GmshFormat format) {
  auto text = format_gmsh(mesh, format);
  if (!text) return Error{text.error().code, path.string() + ": " + text.error().message};
  return io_detail::write_whole_file(path, *text);
}

}  // namespace tc
