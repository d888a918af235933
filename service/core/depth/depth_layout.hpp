// The depth solver's layout of one topology (private to core/depth): the node and
// feature numbering the march reads, built once when an object registers or is cut.
// Every frame's march (depth_solver.cpp) only reads it; docs/DEPTH_MAPS.md,
// "Performance", says why it is laid out so:
//  - nodes are renumbered in breadth-first order from the boundary (boundary nodes
//    first, then layer after layer), so the front of the march and the closest points
//    it carries stay in a compact range of memory;
//  - boundary features are renumbered in the order of their smallest internal node,
//    and each records the one feature across each of its sides.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/depth/boundary_surface.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/mesh/topology.hpp"

namespace tc::detail {

template <int D>
struct DepthLayout {
  using Element = std::array<Index, D + 1>;

  DepthLayout(std::span<const Element> elems, const TopologyOf<D>& topo);

  /// The features across side j of feature s.
  [[nodiscard]] std::span<const Index> across_side(Index s, int j) const;

  Index n = 0;
  // Internal numbering: [0, num_boundary) boundary nodes, then breadth-first layers,
  // then used nodes no edge path reaches (none in a valid mesh): [0, num_used); then
  // orphans.
  Index num_boundary = 0;
  Index num_used = 0;
  std::vector<Index> perm;  ///< internal -> original
  std::vector<Index> inv;   ///< original -> internal
  Csr adjacency;            ///< internal indices
  std::vector<Element> elements;
  BoundarySurface<D> surface;                       ///< original node indices
  std::vector<std::array<Index, D>> simplices_int;  ///< internal node indices
  /// The one feature across side j of each feature (D = 3: edge j of a triangle;
  /// D = 2: endpoint j of a segment), or -1 when there is none or several (non-manifold:
  /// then the CSR lists are read).
  std::vector<std::array<Index, D>> across;
  /// The node of across[t][j] that is not on side j (the "far" node), internal index.
  std::vector<std::array<Index, D>> across_far;
  Csr vertex_simplices_int;               ///< num_boundary rows
  std::vector<Index> seed_simplex;        ///< num_boundary: one incident simplex
  std::vector<std::uint8_t> is_boundary;  ///< original
  std::vector<Index> used_original;       ///< sorted original used nodes
  std::vector<Index> all_boundary;        ///< 0 .. num_boundary - 1: the seeds of a whole run
};

extern template struct DepthLayout<2>;
extern template struct DepthLayout<3>;

}  // namespace tc::detail
