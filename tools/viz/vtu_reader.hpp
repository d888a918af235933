// Reads back the VTK XML UnstructuredGrid files this project writes (core/io
// write_vtu(): ASCII DataArrays, tetrahedra), so `tetcollide render` can draw a frame
// the pipeline wrote, coloured by one of its point fields.
//
// Scope: one <Piece>, format="ascii" arrays (binary and appended data are reported as
// kUnsupported), Points with 3 components, Cells with connectivity/offsets/types. Cells
// other than VTK_TETRA (10) are skipped. Point fields with 1 component are kept as is,
// 3-component fields as their Euclidean norm (e.g. |force|).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/io/mesh_io.hpp"

namespace tc::viz {

struct VtuMesh {
  TetMesh mesh;                        ///< node ids from a "node_id" field, else 0..n-1
  std::vector<VtuField> point_fields;  ///< one value per node each (components == 1)
};

/// Reads an ASCII .vtu written by write_vtu(). Errors name the file and what is wrong
/// (kIo, kParse, kUnsupported, kInvalidMesh for indices out of range or non-finite
/// coordinates).
Expected<VtuMesh> read_vtu(const std::filesystem::path& path);
/// Same, from memory; `name` is used in error messages.
Expected<VtuMesh> read_vtu_buffer(std::string_view data, const std::string& name);

}  // namespace tc::viz
