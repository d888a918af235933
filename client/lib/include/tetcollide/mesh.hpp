// libtetcollide_client: mesh files read into tc::client::Mesh, the readers the service's
// tools and the Python module (`tetcollide.read_mesh`, `read_surface`) use.
//
//   #include <tetcollide/mesh.hpp>
//
//   try {
//     const tc::client::Mesh liver = tc::client::read_mesh("liver.msh");  // tets
//     const tc::client::Mesh tool = tc::client::read_surface("tool.stl");  // triangles
//     client->register_object("liver", liver, params);
//     client->register_object("tool", tool, tool_params);   // a surface object
//   } catch (const tc::client::MeshError& e) {
//     std::fprintf(stderr, "%s\n", e.what());   // "liver.msh:17: expected 4 node tags ..."
//   }
//
// Formats: read_mesh() takes Gmsh `.msh` (2.2 ASCII, 4.1 ASCII and binary; 4-node tets,
// other elements skipped) and TetGen `.node`/`.ele` (0- or 1-based; either file names
// the pair); read_surface() takes STL (ASCII and binary), Wavefront OBJ and a Gmsh `.msh`
// with triangles and no tets (docs/SURFACES.md, "Files"). Extensions are
// case-insensitive. The library holds the readers itself (privately compiled from the
// service's sources): a program needs nothing but this header, client.hpp and the
// library; no Eigen, no other header of the service.
//
// Errors throw MeshError, whose what() is the service's reader message exactly as the
// `tetcollide` CLI and the Python module print it: the file, the line (text) or byte
// (binary), and what is wrong ("box.msh: byte 7904: element 117 refers to unknown node
// tag 4000", "nowhere.msh: cannot open file"); code() tells a file that cannot be read
// (StatusCode::kIo, Python's OSError) from a malformed one (kParse, kUnsupported,
// kInvalidMesh: Python's ValueError). The readers do not judge shapes (inverted or
// degenerate tets): the service does when the object registers.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

#include "tetcollide/client.hpp"

namespace tc::client {

/// Thrown by read_mesh() and read_surface() when a file cannot be read or is malformed.
class TC_CLIENT_API MeshError : public std::runtime_error {
 public:
  MeshError(StatusCode code, const std::string& message);
  ~MeshError() override;
  MeshError(const MeshError&) = default;
  MeshError& operator=(const MeshError&) = default;

  /// kIo (cannot open or read the file), kParse (malformed or truncated), kUnsupported
  /// (a format version, flavour or extension this library does not read; a tet mesh
  /// given to read_surface()), kInvalidMesh (non-finite coordinate, duplicate node tag,
  /// an element referring to an unknown node).
  [[nodiscard]] StatusCode code() const noexcept { return code_; }

 private:
  StatusCode code_;
};

/// Reads a tetrahedral mesh by extension: `.msh` (Gmsh) or `.node`/`.ele` (TetGen, the
/// other file beside it with the same stem). Returns n nodes and m tets:
/// `node_ids` n ids as in the file (Gmsh node tags, TetGen point numbers),
/// `rest_positions` 3n doubles in metres (the file's numbers, x0 y0 z0 x1 ...), `tets` 4m
/// 0-based node indices as in the file (never flipped), `triangles` empty. Nodes no tet
/// uses are kept. Throws MeshError.
TC_CLIENT_API Mesh read_mesh(const std::filesystem::path& path);

/// Reads a triangle surface by extension: `.stl`, `.obj`, or `.msh` (triangles and no
/// tets; a file with tets is a kUnsupported MeshError, "a tet mesh, not a surface").
/// Returns n nodes and k triangles: `node_ids` n ids (Gmsh tags; 1..n for STL and OBJ),
/// `rest_positions` 3n doubles in metres, `triangles` 3k 0-based node indices, `tets`
/// empty: ready for Client::register_object as a surface object. Throws MeshError.
TC_CLIENT_API Mesh read_surface(const std::filesystem::path& path);

}  // namespace tc::client
