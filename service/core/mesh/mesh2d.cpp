#include "core/mesh/mesh2d.hpp"

#include <algorithm>
#include <utility>

namespace tc {

Topology2 build_topology_2d(std::span<const std::array<Index, 3>> triangles, Index num_nodes) {
  Topology2 topo;
  topo.num_nodes = num_nodes;
  topo.num_triangles = static_cast<Index>(triangles.size());
  std::vector<std::array<Index, 2>> edges;
  edges.reserve(3 * triangles.size());
  std::vector<std::uint8_t> used(static_cast<std::size_t>(num_nodes), 0);
  for (const auto& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      const Index a = t[k], b = t[(k + 1) % 3];
      used[a] = 1;
      if (a != b) edges.push_back({std::min(a, b), std::max(a, b)});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::vector<std::pair<Index, Index>> adjacency;
  adjacency.reserve(2 * edges.size());
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i == 1) topo.boundary_segments.push_back(edges[i]);
    adjacency.emplace_back(edges[i][0], edges[i][1]);
    adjacency.emplace_back(edges[i][1], edges[i][0]);
    i = j;
  }
  topo.node_adjacency = csr_from_pairs(num_nodes, adjacency);
  topo.is_boundary_node.assign(static_cast<std::size_t>(num_nodes), 0);
  for (const auto& s : topo.boundary_segments)
    topo.is_boundary_node[s[0]] = topo.is_boundary_node[s[1]] = 1;
  for (Index i = 0; i < num_nodes; ++i) {
    if (topo.is_boundary_node[i]) topo.boundary_nodes.push_back(i);
    if (!used[i]) topo.orphan_nodes.push_back(i);
  }
  return topo;
}

}  // namespace tc
