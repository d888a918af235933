#include "core/depth/self_depth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/depth/point_simplex_distance.hpp"

namespace tc {

std::vector<Index> nodes_within_rings(const Topology& topology, std::span<const Index> seeds,
                                      int rings) {
  std::vector<Index> near(seeds.begin(), seeds.end());
  std::size_t begin = 0;
  for (int ring = 0; ring < rings; ++ring) {
    const std::size_t end = near.size();
    for (std::size_t i = begin; i < end; ++i)
      for (const Index w : topology.node_adjacency.row(near[i])) near.push_back(w);
    begin = end;
  }
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());
  return near;
}

double exact_self_depth(const BoundaryBvh<3>& faces, const Topology& topology,
                        std::span<const Index> node_component, const Positions& x, Index node,
                        Index tet) {
  const Index part = topology.tet_component[static_cast<std::size_t>(tet)];
  const bool same = node_component[static_cast<std::size_t>(node)] == part;
  const Index seed[1] = {node};
  const std::vector<Index> near =
      same ? nodes_within_rings(topology, seed, kSelfContactRings) : std::vector<Index>{};
  const Eigen::Vector3d p = x.col(node);
  double radius = 0.0;
  for (const Index w : topology.node_adjacency.row(node))
    radius = std::max(radius, (x.col(w) - p).norm());
  if (!(radius > 0.0)) radius = 1e-9;
  // Doubling radii: the nearest valid face within a radius is the nearest of all.
  for (int round = 0; round < 64; ++round, radius *= 2.0) {
    double best = std::numeric_limits<double>::infinity();
    std::size_t visited = 0;
    faces.for_each_near(p, radius, [&](Index f) {
      ++visited;
      const auto& tri = topology.boundary_faces[static_cast<std::size_t>(f)];
      if (topology.tet_component[static_cast<std::size_t>(
              topology.boundary_face_tet[static_cast<std::size_t>(f)])] != part)
        return;
      for (const Index w : tri)
        if (std::binary_search(near.begin(), near.end(), w)) return;
      const auto cp =
          closest_point_triangle(p, Eigen::Vector3d(x.col(tri[0])), Eigen::Vector3d(x.col(tri[1])),
                                 Eigen::Vector3d(x.col(tri[2])));
      best = std::min(best, (cp.point - p).norm());
    });
    if (best <= radius) return best;
    if (visited == static_cast<std::size_t>(faces.size())) return best;  // every face seen
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace tc
