// The boundary of an object as the depth maps see it, built once per topology:
// the boundary features (triangles of a tet mesh, segments of a 2D triangle mesh) and
// their adjacency on the surface, which CFFM's local descent walks.
//
// The 2D case's mesh and topology (the paper's triangle meshes in the plane) are in
// core/mesh/mesh2d.hpp.
#pragma once

#include <array>
#include <span>
#include <utility>
#include <vector>

#include "core/mesh/mesh2d.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// The boundary surface of dimension D - 1 of a D-dimensional mesh: triangles for D = 3,
/// segments for D = 2, with the adjacency a local descent needs.
template <int D>
struct BoundarySurface {
  Index num_nodes = 0;
  /// k boundary features, D node indices each (into the mesh's nodes). For D = 3 these
  /// are Topology::boundary_faces in the same order; for D = 2 the boundary segments.
  std::vector<std::array<Index, D>> simplices;
  /// n rows: the features using node i (empty for nodes not on the boundary).
  Csr vertex_simplices;
  /// D = 3 only: 3k rows; row 3t + j lists the other triangles that share edge j of
  /// triangle t (edge j joins local vertices j and (j + 1) % 3). One entry on a closed
  /// manifold surface, more on a non-manifold edge. Empty for D = 2.
  Csr edge_simplices;

  [[nodiscard]] Index size() const { return static_cast<Index>(simplices.size()); }
};

/// Boundary surface made of the given features (any order; the feature index is the
/// position in this list).
///
/// @param[in] num_nodes  n, the mesh's node count.
/// @param[in] simplices  k features, D node indices each in [0, n).
template <int D>
BoundarySurface<D> build_boundary_surface(Index num_nodes,
                                          std::vector<std::array<Index, D>> simplices);

/// Boundary surface of a tet mesh (triangles, in Topology::boundary_faces order).
BoundarySurface<3> build_boundary_surface(const Topology& topo);
/// Boundary curve of a 2D triangle mesh (segments, in Topology2 order).
BoundarySurface<2> build_boundary_surface(const Topology2& topo);

}  // namespace tc
