// Fuzz target: the Wavefront OBJ reader (v / f with every corner form, negative indices,
// fan-triangulated polygons, ignored statements). The input is the file's content.
// Every input must give a surface or an error naming the file; a surface that comes back
// has consistent sizes, in-range indices, finite coordinates and at least one triangle.
#include <cstdint>

#include "core/io/surface_io.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "fuzz_input.hpp"
#include "read_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = tc::fuzz::as_text(data, size);
  auto mesh = tc::read_obj_buffer(text, "fuzz.obj");
  if (!mesh) {
    TC_FUZZ_CHECK(mesh.error().message.rfind("fuzz.obj", 0) == 0);
    return 0;
  }
  const tc::SurfaceValidationReport report = tc::fuzz::check_read_surface(*mesh);
  if (!report.structurally_invalid()) {
    const tc::SurfaceEdges edges = tc::build_surface_edges(mesh->triangles);
    const tc::SurfaceStats stats = tc::compute_surface_stats(*mesh, edges, report);
    TC_FUZZ_CHECK(stats.edges >= 3);
    TC_FUZZ_CHECK(stats.components >= 1 && stats.components <= mesh->num_triangles());
  }
  return 0;
}
