// Fuzz target: the STL reader (ASCII and binary; binary detection by the 84 + 50 n size,
// even for a header that begins with "solid"). The input is the file's content. Every
// input must give a surface or an error naming the file; a surface that comes back has
// consistent sizes, in-range indices, finite coordinates, at least one triangle, and
// no two nodes at bit-identical coordinates (the corners are merged).
#include <cstdint>

#include "core/io/surface_io.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "fuzz_input.hpp"
#include "read_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = tc::fuzz::as_text(data, size);
  auto mesh = tc::read_stl_buffer(text, "fuzz.stl");
  if (!mesh) {
    TC_FUZZ_CHECK(mesh.error().message.rfind("fuzz.stl", 0) == 0);
    return 0;
  }
  // Every corner is used (nodes come from corners) and no two nodes coincide bit for bit.
  TC_FUZZ_CHECK(mesh->num_nodes() <= 3 * mesh->num_triangles());
  const tc::SurfaceValidationReport report = tc::fuzz::check_read_surface(*mesh);
  if (!report.structurally_invalid()) {
    const tc::SurfaceStats stats =
        tc::compute_surface_stats(*mesh, tc::build_surface_edges(mesh->triangles), report);
    TC_FUZZ_CHECK(stats.unused_nodes == 0);
    TC_FUZZ_CHECK(stats.components >= 1 && stats.components <= mesh->num_triangles());
  }
  return 0;
}
