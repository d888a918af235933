// Triangle-surface files: STL (ASCII and binary), Wavefront OBJ, and Gmsh .msh files
// with triangles and no tets (docs/SURFACES.md, "Files").
//
// Like the tet readers (mesh_io.hpp), these never crash, hang or allocate more than the
// file's size calls for on hostile input: binary counts are checked against the file
// size before anything is reserved, text grows with the lines actually read. An error
// names the file and the line (text) or byte offset (binary) and what was expected:
// "tool.stl:12: expected 'vertex x y z', got 'vertex 1 2'", "tool.stl: byte 80: the
// header announces 1000 triangles (50084 bytes), the file has 584".
// Error codes: kIo (cannot open/read), kParse (malformed or truncated),
// kUnsupported (unknown extension, a .msh that holds tets or no triangles, more than
// 2^31-1 nodes), kInvalidMesh (non-finite coordinate, index out of range).
//
// Readers do not validate the shapes: validate_surface() (core/mesh/surface_mesh.hpp)
// judges degenerate triangles and the rest, as validate_mesh() does for tets. Units are
// the file's numbers read as metres (STL and OBJ carry no unit).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/common/result.hpp"
#include "core/mesh/surface_mesh.hpp"

namespace tc {

/// Reads a surface by extension (case-insensitive): `.stl`, `.obj`, `.msh`.
Expected<SurfaceMesh> read_surface(const std::filesystem::path& path);

/// True for the extensions only surfaces use (`.stl`, `.obj`); `.msh` may hold either.
bool is_surface_extension(const std::filesystem::path& path);

/// STL, ASCII or binary. Binary when the file has at least 84 bytes and its size is
/// exactly 84 + 50 n for the count n stored at byte 80 (a binary file may begin with
/// "solid"); else ASCII when it begins with "solid"; else an error. Vertices with
/// bit-identical coordinates (after -0 -> +0) become one node, numbered in order of
/// first appearance (node ids 1..n); facet normals and attribute bytes are ignored.
/// ASCII keywords are case-insensitive; several solids in one file are read as one.
Expected<SurfaceMesh> read_stl(const std::filesystem::path& path);
/// Same, from memory; `name` is used in error messages.
Expected<SurfaceMesh> read_stl_buffer(std::string_view data, const std::string& name);

/// Wavefront OBJ: `v x y z` (an optional w, or r g b colours, are ignored) and `f` with
/// `v`, `v/vt`, `v//vn`, `v/vt/vn` corners, 1-based or negative (relative to the
/// vertices read so far) indices; polygons of k >= 3 corners become k - 2 triangles
/// (fan from the first corner). Other statements (vt, vn, g, o, s, usemtl, mtllib, l,
/// ...) and `#` comments are ignored; line continuations (`\`) are not supported.
/// Every vertex is a node (ids 1..n in `v` order); none is merged.
Expected<SurfaceMesh> read_obj(const std::filesystem::path& path);
Expected<SurfaceMesh> read_obj_buffer(std::string_view data, const std::string& name);

/// The 3-node triangles (element type 2) of a Gmsh file (2.2 ASCII, 4.1 ASCII/binary,
/// the tet reader's parser) in 3D, every node kept. Errors (kUnsupported) when the file
/// holds 4-node tets (it is a tet mesh: read_mesh()) or no 3-node triangle.
Expected<SurfaceMesh> read_gmsh_surface(const std::filesystem::path& path);
Expected<SurfaceMesh> read_gmsh_surface_buffer(std::string_view data, const std::string& name);

/// A tet mesh or a surface, as `tetcollide respond` and `mesh info` take either: `.stl`
/// and `.obj` are surfaces; other files go to read_mesh() (core/io/mesh_io.hpp), and a
/// `.msh` that holds 3-node triangles and no tets is read as a surface.
Expected<ObjectMesh> read_object_mesh(const std::filesystem::path& path);

}  // namespace tc
