// The exact depth of a self-contact (docs/RESPONSE.md, "Self-contact"): the reference the
// response's nearest-face depth is checked against, and the demo's probe.
#pragma once

#include <span>
#include <vector>

#include "core/depth/boundary_bvh.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// Mesh edges around a self-contact's intruding node within which the faces of its own
/// component are its neighbourhood, never the part it is pushed out of.
inline constexpr int kSelfContactRings = 2;

/// The nodes within `rings` mesh edges of `seeds` (the seeds included), sorted.
std::vector<Index> nodes_within_rings(const Topology& topology, std::span<const Index> seeds,
                                      int rings);

/// The exact depth of node `node` (at x.col(node)) inside tet `tet` of its own object: its
/// distance to the nearest boundary face of tet's component that is not of the node's
/// neighbourhood (a face of the node's own component with a corner within
/// kSelfContactRings edges of it), metres; +infinity when there is no such face.
///
/// @param[in] faces           BoundaryBvh over topology.boundary_faces at positions x
/// @param[in] node_component  n: component of each node (node_components())
double exact_self_depth(const BoundaryBvh<3>& faces, const Topology& topology,
                        std::span<const Index> node_component, const Positions& x, Index node,
                        Index tet);

}  // namespace tc
