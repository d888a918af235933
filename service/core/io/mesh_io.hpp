// Mesh files: Gmsh .msh (2.2 ASCII, 4.1 ASCII and binary), TetGen .node/.ele, VTK .vtu.
//
// Readers never crash or hang on hostile input: every count is checked against the
// bytes that remain, and an error names the file, the line (text) or byte offset
// (binary), and what was expected.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// A triangle mesh in the plane (the paper's 2D test case): n x 2 positions, k x 3
/// triangles, node ids as in the file.
struct TriMesh2 {
  std::vector<std::int64_t> node_ids;
  Eigen::Matrix<double, 2, Eigen::Dynamic> positions;
  std::vector<std::array<Index, 3>> triangles;
};

/// Reads a mesh by extension: `.msh` (Gmsh), `.node` or `.ele` (TetGen, the other file
/// beside it with the same stem).
Expected<TetMesh> read_mesh(const std::filesystem::path& path);

/// Reads the 4-node tetrahedra (element type 4) of a Gmsh file, format 2.2 ASCII or
/// 4.1 ASCII/binary. Other element types are skipped. Node tags become node ids
/// (non-contiguous tags allowed); nodes no tet uses are kept (orphans).
Expected<TetMesh> read_gmsh(const std::filesystem::path& path);
/// Same, from memory; `name` is used in error messages.
Expected<TetMesh> read_gmsh_buffer(std::string_view data, const std::string& name);

/// Reads the 3-node triangles (element type 2) of a Gmsh file as a 2D mesh (z dropped).
Expected<TriMesh2> read_gmsh_triangles(const std::filesystem::path& path);
Expected<TriMesh2> read_gmsh_triangles_buffer(std::string_view data, const std::string& name);

/// Reads a TetGen pair `stem.node` + `stem.ele`; `path` may name either file or the
/// stem. Numbering may start at 0 or 1 (taken from the .node file, as TetGen does).
Expected<TetMesh> read_tetgen(const std::filesystem::path& path);
Expected<TetMesh> read_tetgen_buffers(std::string_view node_text, std::string_view ele_text,
                                      const std::string& name);

/// Gmsh output flavours of write_gmsh().
enum class GmshFormat { kMsh22Ascii, kMsh41Ascii, kMsh41Binary };

/// The mesh as the text (or bytes) of a Gmsh file: node ids as node tags (they must be
/// positive and unique), one tet element (type 4) per tet, element tags 1..m. 4.1 files
/// hold one node block and one element block on volume entity 1 and no $Entities.
Expected<std::string> format_gmsh(const TetMesh& mesh, GmshFormat format);
/// Writes format_gmsh() to a file.
Status write_gmsh(const std::filesystem::path& path, const TetMesh& mesh, GmshFormat format);

/// Number of nodes of a Gmsh element type (1 for points, 4 for 4-node tets, 10 for
/// type 11, ...), or 0 for unknown types and types of variable size (polygons).
int gmsh_element_node_count(int type) noexcept;

/// A per-node (point data) or per-tet (cell data) field for the VTU writer.
struct VtuField {
  std::string name;
  int components = 1;          ///< 1 (scalar) or 3 (vector)
  std::vector<double> values;  ///< n * components (point) or m * components (cell)
};

/// Writes a VTK XML UnstructuredGrid (.vtu, ASCII) that ParaView opens, with a
/// `node_id` point field and the given point and cell fields.
Status write_vtu(const std::filesystem::path& path, const TetMesh& mesh,
                 std::span<const VtuField> point_fields = {},
                 std::span<const VtuField> cell_fields = {});

}  // namespace tc
