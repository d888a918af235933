// The paper's 2D test case (its Figs. 8-10): triangle meshes in the plane, read by the
// Gmsh reader (core/io/mesh_io.hpp) and marched by the 2D depth maps (core/depth).
// Not to be confused with SurfaceMesh (core/mesh/surface_mesh.hpp), a triangle surface
// in 3D.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// A triangle mesh in the plane (the paper's 2D test case): n x 2 positions, k x 3
/// triangles, node ids as in the file.
struct TriMesh2 {
  std::vector<std::int64_t> node_ids;
  Eigen::Matrix<double, 2, Eigen::Dynamic> positions;
  std::vector<std::array<Index, 3>> triangles;
};

/// Topology of a 2D triangle mesh (the paper's Fig. 9 and 10 case), the counterpart of
/// Topology for the depth maps. All lists are sorted.
struct Topology2 {
  Index num_nodes = 0;
  Index num_triangles = 0;
  /// Boundary segments (triangle edges used by exactly one triangle), (a, b) with a < b.
  std::vector<std::array<Index, 2>> boundary_segments;
  /// Nodes of the boundary segments.
  std::vector<Index> boundary_nodes;
  /// n flags: 1 for a boundary node.
  std::vector<std::uint8_t> is_boundary_node;
  /// n rows: the nodes sharing a triangle edge with node i.
  Csr node_adjacency;
  /// Nodes used by no triangle.
  std::vector<Index> orphan_nodes;
};

/// Builds the topology of k triangles over n nodes.
///
/// @param[in] triangles  k x 3 node indices, each in [0, num_nodes).
/// @param[in] num_nodes  n.
Topology2 build_topology_2d(std::span<const std::array<Index, 3>> triangles, Index num_nodes);

}  // namespace tc
