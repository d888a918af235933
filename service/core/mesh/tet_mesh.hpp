// The one mesh model every stage shares.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace tc {

/// Node indices of one tetrahedron, 0-based into TetMesh::positions.
using Tet = std::array<std::int32_t, 4>;
using Index = std::int32_t;

/// Positions of n nodes, stored as a 3 x n column-major matrix: the same memory
/// layout as an n x 3 row-major array (x0 y0 z0 x1 y1 z1 ...). Units: metres.
using Positions = Eigen::Matrix<double, 3, Eigen::Dynamic>;

/// A tetrahedral mesh as read from a file.
///
/// Tets are expected positively oriented (signed volume > 0, the Gmsh and TetGen
/// convention); validate_mesh() reports the ones that are not, it never flips them.
struct TetMesh {
  /// n node ids as in the file (Gmsh node tags, TetGen node numbers). Any order, may
  /// be non-contiguous; used for output only.
  std::vector<std::int64_t> node_ids;
  /// n node positions (3 x n), metres.
  Positions positions;
  /// m tets, 0-based indices into positions.
  std::vector<Tet> tets;

  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(positions.cols()); }
  [[nodiscard]] Index num_tets() const { return static_cast<Index>(tets.size()); }
};

}  // namespace tc
