// read_mesh(): picks the reader from the file extension.
#include "core/io/mesh_io.hpp"

#include <algorithm>
#include <cctype>

namespace tc {

Expected<TetMesh> read_mesh(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".msh") return read_gmsh(path);
  if (ext == ".node" || ext == ".ele") return read_tetgen(path);
  return Error{ErrorCode::kUnsupported,
               path.string() + ": unknown mesh file extension " +
                   (ext.empty() ? std::string("(none)") : "'" + ext + "'") +
                   " (expected .msh, .node or .ele)"};
}

}  // namespace tc
