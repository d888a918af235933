// Spatial orders of a mesh's tets: neighbours in space become neighbours in memory order.
#pragma once

#include <Eigen/Core>
#include <span>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// Tet indices sorted along a Morton (Z-order) curve of their centroids, on a grid of
/// 2^21 cells per axis over the cube [lo, lo + extent]^3 (clamped); tets with a non-finite
/// corner last; ties by tet index, so the order depends on the positions only. Consecutive
/// tets in this order mostly share nodes: loops over tets in it read the positions with
/// far fewer cache misses than a mesher's element order.
std::vector<Index> tets_in_morton_order(const Positions& positions, std::span<const Tet> tets,
                                        const Eigen::Vector3d& lo, double extent);

/// The same over the bounding cube of the finite positions.
std::vector<Index> tets_in_morton_order(const Positions& positions, std::span<const Tet> tets);

}  // namespace tc
