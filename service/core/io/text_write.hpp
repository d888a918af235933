// Internal to core/io: what the mesh writers share. Numbers in their shortest form that
// reads back to the same value (std::to_chars), and the check every writer makes before
// it writes a byte: one id per node, finite coordinates, cells naming existing nodes.
#pragma once

#include <array>
#include <charconv>
#include <cstdint>
#include <span>
#include <string>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc::io_detail {

inline void append_int(std::string& s, std::int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  s.append(buf, r.ptr);
}

/// The shortest decimal form that reads back to the same double.
inline void append_double(std::string& s, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  s.append(buf, r.ptr);
}

/// kInvalidArgument naming the first fault: node ids not one per node, a non-finite
/// coordinate, a tet (or one of `triangles`) naming a node outside [0, n).
Status check_mesh_for_writing(const TetMesh& mesh,
                              std::span<const std::array<Index, 3>> triangles = {});

}  // namespace tc::io_detail
