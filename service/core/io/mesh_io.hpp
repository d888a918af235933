// Mesh files: Gmsh .msh (2.2 ASCII, 4.1 ASCII and binary), TetGen .node/.ele, VTK .vtu.
//
// Readers never crash or hang on hostile input: every count is checked against the
// bytes that remain, and an error names the file, the line (text) or byte offset
// (binary), and what was expected: "box.msh:17: expected 4 node tags for element 12,
// got 3", "box.msh: byte 7904: element 117 refers to unknown node tag 4000".
// Error codes: kIo (cannot open/read), kParse (malformed or truncated, wrong counts),
// kUnsupported (MSH 1/4.0, binary 2.2, big-endian, data-size other than 8, 10-node
// TetGen tets, binary blocks of polygons), kInvalidMesh (non-finite coordinate,
// duplicate node tag, element referring to an unknown node).
//
// Decisions:
// - Gmsh: records are read line by line as Gmsh writes them; anything between sections
//   is ignored and unknown sections are skipped up to their $End line, as Gmsh does.
//   Sections may repeat (nodes accumulate). Nodes must come before the elements that
//   use them (the format says so). Node tags may be any value in [0, 2^63) (Gmsh
//   reserves 0; we accept it); they are not required to be sorted or contiguous.
//   4.1 headers are checked: numNodes/numElements must equal the blocks' sum and every
//   node tag must lie in [minNodeTag, maxNodeTag]. In ASCII, elements of unknown type
//   are skipped line by line; in binary their size must be known (GmshDefines.h table).
//   Binary $Entities is parsed (not searched for its end marker).
// - TetGen: the first point's index (0 or 1) sets the numbering base, as in TetGen;
//   later indices must follow consecutively (a skipped index is an error, since TetGen
//   itself would ignore it and refer to points by position). Missing attributes and
//   markers read as 0 (TetGen does the same); extra values and extra lines are errors.
// - Readers never reorder nodes or flip tets; validate_mesh() judges orientation.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/mesh2d.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

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

/// The two texts of a TetGen pair, as format_tetgen() makes them.
struct TetGenText {
  std::string node;  ///< the .node file: "<n> 3 0 0", then "<index> x y z" per node
  std::string ele;   ///< the .ele file: "<m> 4 0", then "<index> n1 n2 n3 n4" per tet
};

/// Numbering base of a written TetGen pair: 0 when the node ids are exactly 0..n-1 (a
/// 0-based TetGen file read back), else 1. TetGen numbers points consecutively from the
/// base, so other ids than base..base+n-1 are not kept.
std::int64_t tetgen_base(const TetMesh& mesh);

/// The mesh as the texts of a TetGen pair (no attributes, no markers), numbered from
/// tetgen_base(mesh); coordinates in the shortest form that reads back to the same
/// double, so read_tetgen_buffers() gives the same positions bit for bit and the same
/// tets (and the same node ids when they are base..base+n-1). Errors (kInvalidArgument)
/// when node_ids does not hold n ids, a coordinate is not finite, or a tet refers to a
/// node outside [0, n).
Expected<TetGenText> format_tetgen(const TetMesh& mesh);
/// `path` without a `.node` or `.ele` extension (case-insensitive), else `path` itself:
/// the stem the TetGen reader and writer append `.node` and `.ele` to.
std::filesystem::path tetgen_stem(const std::filesystem::path& path);
/// Writes format_tetgen() to `stem.node` and `stem.ele`; `path` may name either file or
/// the stem (tetgen_stem()). Errors name the file.
Status write_tetgen(const std::filesystem::path& path, const TetMesh& mesh);

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
/// The same with triangles (VTK_TRIANGLE cells, after the tets) for the surface objects
/// of a mixed grid; cell fields then hold tets + triangles values.
Status write_vtu(const std::filesystem::path& path, const TetMesh& mesh,
                 std::span<const std::array<Index, 3>> triangles,
                 std::span<const VtuField> point_fields, std::span<const VtuField> cell_fields);

}  // namespace tc
