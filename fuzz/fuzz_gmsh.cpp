// Fuzz target: the Gmsh reader (MSH 2.2 ASCII, 4.1 ASCII and binary), read as tets, as 2D
// triangles and as a 3D surface. The input is the file's content. Every input must give a
// mesh or an error with a message; a mesh that comes back has consistent sizes and
// in-range indices unless validation says so.
#include <cstdint>

#include "core/io/mesh_io.hpp"
#include "core/io/surface_io.hpp"
#include "core/mesh/validate.hpp"
#include "fuzz_input.hpp"
#include "read_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = tc::fuzz::as_text(data, size);
  if (auto mesh = tc::read_gmsh_buffer(text, "fuzz.msh")) {
    // The reader rejects unknown node tags and non-finite coordinates.
    tc::fuzz::check_read_mesh(*mesh);
  } else {
    TC_FUZZ_CHECK(!mesh.error().message.empty());
  }
  if (auto tris = tc::read_gmsh_triangles_buffer(text, "fuzz.msh")) {
    TC_FUZZ_CHECK(tris->node_ids.size() == static_cast<std::size_t>(tris->positions.cols()));
    for (const auto& t : tris->triangles)
      for (const tc::Index i : t) TC_FUZZ_CHECK(i >= 0 && i < tris->positions.cols());
  } else {
    TC_FUZZ_CHECK(!tris.error().message.empty());
  }
  // The same file as a 3D surface (triangles and no tets).
  if (auto surface = tc::read_gmsh_surface_buffer(text, "fuzz.msh")) {
    tc::fuzz::check_read_surface(*surface);
  } else {
    TC_FUZZ_CHECK(surface.error().message.rfind("fuzz.msh", 0) == 0);
  }
  return 0;
}
