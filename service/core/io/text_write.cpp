#include "core/io/text_write.hpp"

namespace tc::io_detail {
namespace {

/// kInvalidArgument for cell `c` (a "tet" or a "triangle") naming node `v` outside [0, n).
template <typename Cells>
Status check_cells(const Cells& cells, std::size_t n, const char* what) {
  for (std::size_t c = 0; c < cells.size(); ++c)
    for (const Index v : cells[c])
      if (v < 0 || static_cast<std::size_t>(v) >= n)
        return Error{ErrorCode::kInvalidArgument, std::string(what) + " " + std::to_string(c) +
                                                      " refers to node " + std::to_string(v) +
                                                      ", outside [0, " + std::to_string(n) + ")"};
  return {};
}

}  // namespace

Status check_mesh_for_writing(const TetMesh& mesh,
                              std::span<const std::array<Index, 3>> triangles) {
  const auto n = static_cast<std::size_t>(mesh.positions.cols());
  if (mesh.node_ids.size() != n)
    return Error{ErrorCode::kInvalidArgument, "mesh has " + std::to_string(mesh.node_ids.size()) +
                                                  " node ids for " + std::to_string(n) + " nodes"};
  for (std::size_t i = 0; i < n; ++i)
    if (!mesh.positions.col(static_cast<Eigen::Index>(i)).allFinite())
      return Error{ErrorCode::kInvalidArgument,
                   "node " + std::to_string(i) + " has a non-finite coordinate"};
  if (Status st = check_cells(mesh.tets, n, "tet"); !st) return st;
  return check_cells(triangles, n, "triangle");
}

}  // namespace tc::io_detail
