// What every mesh or surface a reader returns must hold, whatever the input: consistent
// sizes, indices in range and finite coordinates (the readers reject the rest).
#pragma once

#include <cstddef>

#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/validate.hpp"
#include "fuzz_input.hpp"

namespace tc::fuzz {

inline void check_read_mesh(const TetMesh& mesh) {
  TC_FUZZ_CHECK(mesh.node_ids.size() == static_cast<std::size_t>(mesh.num_nodes()));
  const ValidationReport report = validate_mesh(mesh);
  TC_FUZZ_CHECK(report.index_out_of_range.count == 0);
  TC_FUZZ_CHECK(report.nonfinite_node.count == 0);
}

/// The same for a surface, which also has at least one triangle; returns its report.
inline SurfaceValidationReport check_read_surface(const SurfaceMesh& mesh) {
  TC_FUZZ_CHECK(mesh.node_ids.size() == static_cast<std::size_t>(mesh.num_nodes()));
  TC_FUZZ_CHECK(mesh.num_triangles() > 0);
  const SurfaceValidationReport report = validate_surface(mesh);
  TC_FUZZ_CHECK(report.index_out_of_range.count == 0);
  TC_FUZZ_CHECK(report.nonfinite_node.count == 0);
  return report;
}

}  // namespace tc::fuzz
