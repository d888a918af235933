// Fuzz target: the TetGen reader. The input is the .node file's content, a NUL byte,
// then the .ele file's content (no NUL: the .ele file is empty). Every input must give
// a mesh with in-range indices and finite coordinates, or an error with a message.
#include <cstdint>

#include "core/io/mesh_io.hpp"
#include "core/mesh/validate.hpp"
#include "fuzz_input.hpp"
#include "read_checks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = tc::fuzz::as_text(data, size);
  const std::size_t split = text.find('\0');
  const std::string_view node_text = text.substr(0, split);
  const std::string_view ele_text =
      split == std::string_view::npos ? std::string_view() : text.substr(split + 1);
  if (auto mesh = tc::read_tetgen_buffers(node_text, ele_text, "fuzz")) {
    tc::fuzz::check_read_mesh(*mesh);
  } else {
    TC_FUZZ_CHECK(!mesh.error().message.empty());
  }
  return 0;
}
