// Topology-derived data, built once per topology version and cached by its owner:
// per-frame work touches positions only.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// Compressed sparse rows: the entries of row i are indices[offsets[i] .. offsets[i+1]).
struct Csr {
  std::vector<Index> offsets;  ///< rows + 1 entries, offsets[0] == 0
  std::vector<Index> indices;  ///< offsets.back() entries

  [[nodiscard]] Index rows() const {
    return offsets.empty() ? 0 : static_cast<Index>(offsets.size() - 1);
  }
  [[nodiscard]] std::span<const Index> row(Index i) const {
    return {indices.data() + offsets[i], static_cast<std::size_t>(offsets[i + 1] - offsets[i])};
  }
};

/// CSR of (row, value) pairs: rows sorted, values within a row sorted and unique. The
/// pairs are sorted and deduplicated in place.
/// @param[in] rows   number of rows; every pair's row in [0, rows)
/// @param[in,out] pairs  (row, value) pairs
Csr csr_from_pairs(Index rows, std::vector<std::pair<Index, Index>>& pairs);

/// Everything the pipeline derives from the tets alone (no positions).
///
/// All lists are sorted, so two builds of the same topology are identical.
struct Topology {
  Index num_nodes = 0;
  Index num_tets = 0;

  /// Boundary triangles (faces owned by exactly one tet), k x 3 node indices, ordered
  /// so that the right-hand normal points outward for positively oriented tets.
  std::vector<std::array<Index, 3>> boundary_faces;
  /// k: the tet owning each boundary face.
  std::vector<Index> boundary_face_tet;
  /// Unique edges of the boundary faces, (a, b) with a < b, sorted.
  std::vector<std::array<Index, 2>> boundary_edges;
  /// Nodes of the boundary faces, sorted.
  std::vector<Index> boundary_nodes;
  /// n flags: 1 for a boundary node.
  std::vector<std::uint8_t> is_boundary_node;
  /// n rows: the boundary faces (indices into boundary_faces) using node i, ascending;
  /// empty for interior nodes. The response's nearest-face queries read it.
  Csr node_boundary_faces;
  /// Unique tet edges, (a, b) with a < b, sorted.
  std::vector<std::array<Index, 2>> edges;
  /// n rows: the nodes sharing a tet edge with node i, sorted.
  Csr node_adjacency;
  /// n rows: the tets using node i, sorted.
  Csr node_tets;
  /// m x 4: the tet across the face opposite local node j, or -1 on the boundary (and
  /// on non-manifold faces shared by more than two tets).
  std::vector<std::array<Index, 4>> tet_neighbors;
  /// m: face-connected component of each tet, numbered in order of the smallest tet.
  std::vector<Index> tet_component;
  Index num_components = 0;
  /// Nodes used by no tet, sorted.
  std::vector<Index> orphan_nodes;
  /// Faces shared by three or more tets (a broken mesh); counted, never used.
  Index nonmanifold_faces = 0;
};

/// The topology of an object with edges and no tets (a triangle surface: the edges of
/// build_surface_edges()): num_nodes, `edges` as given and `node_adjacency`; every
/// tet-derived list is empty and num_tets is 0. The response reads nothing else of an
/// intruding object (node weights, segment ends).
/// @param[in] edges      unique edges (a, b), a < b, sorted; indices in [0, num_nodes)
/// @param[in] num_nodes  n.
Topology build_edge_topology(std::span<const std::array<Index, 2>> edges, Index num_nodes);

/// Builds the topology of m tets over n nodes.
///
/// @param[in] tets       m tets; every index must be in [0, num_nodes) (validate first).
/// @param[in] num_nodes  n.
/// Meshes whose tets have 4 distinct nodes (any valid mesh) take a fast path:
/// counting sorts, a radix sort of packed face keys and per-node adjacency rows, TBB
/// over fixed chunks; the result is identical to build_topology_reference().
Topology build_topology(std::span<const Tet> tets, Index num_nodes);

/// The plain implementation (comparison sorts of every face, edge and incidence), used
/// by build_topology() for other input (repeated nodes) and as the tests' reference.
Topology build_topology_reference(std::span<const Tet> tets, Index num_nodes);

/// Euler characteristic V - E + F of the boundary surface (2 for a ball, 0 for a torus,
/// summed over components).
Index boundary_euler_characteristic(const Topology& topo);

}  // namespace tc
