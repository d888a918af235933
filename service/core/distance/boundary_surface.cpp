#include "core/distance/boundary_surface.hpp"

#include <algorithm>
#include <numeric>
#include <utility>

namespace tc {
namespace {

// CSR from (row, value) pairs; rows sorted, values within a row sorted and unique.
Csr csr_from_pairs(Index rows, std::vector<std::pair<Index, Index>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  Csr csr;
  csr.offsets.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (const auto& p : pairs) ++csr.offsets[static_cast<std::size_t>(p.first) + 1];
  std::partial_sum(csr.offsets.begin(), csr.offsets.end(), csr.offsets.begin());
  csr.indices.reserve(pairs.size());
  for (const auto& p : pairs) csr.indices.push_back(p.second);
  return csr;
}

template <int D>
Csr vertex_simplex_csr(Index num_nodes, const std::vector<std::array<Index, D>>& simplices) {
  std::vector<std::pair<Index, Index>> pairs;
  pairs.reserve(simplices.size() * D);
  for (std::size_t s = 0; s < simplices.size(); ++s)
    for (int k = 0; k < D; ++k) pairs.emplace_back(simplices[s][k], static_cast<Index>(s));
  return csr_from_pairs(num_nodes, pairs);
}

}  // namespace

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

template <int D>
BoundarySurface<D> build_boundary_surface(Index num_nodes,
                                          std::vector<std::array<Index, D>> simplices) {
  BoundarySurface<D> s;
  s.num_nodes = num_nodes;
  s.simplices = std::move(simplices);
  s.vertex_simplices = vertex_simplex_csr<D>(num_nodes, s.simplices);
  if constexpr (D == 2) {
    s.edge_simplices.offsets.assign(1, 0);
    return s;
  } else {
    // Edge records (sorted node pair, triangle, local edge); triangles sharing a pair
    // are neighbours across that edge.
    struct EdgeRecord {
      std::array<Index, 2> key;
      Index tri;
      Index local;
    };
    const auto k = s.simplices.size();
    std::vector<EdgeRecord> records;
    records.reserve(3 * k);
    for (std::size_t t = 0; t < k; ++t)
      for (int j = 0; j < 3; ++j) {
        const Index a = s.simplices[t][j], b = s.simplices[t][(j + 1) % 3];
        records.push_back({{std::min(a, b), std::max(a, b)}, static_cast<Index>(t), j});
      }
    std::sort(records.begin(), records.end(), [](const EdgeRecord& x, const EdgeRecord& y) {
      return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.local < y.local);
    });
    std::vector<std::pair<Index, Index>> pairs;
    pairs.reserve(3 * k);
    for (std::size_t i = 0; i < records.size();) {
      std::size_t j = i + 1;
      while (j < records.size() && records[j].key == records[i].key) ++j;
      for (std::size_t x = i; x < j; ++x)
        for (std::size_t y = i; y < j; ++y)
          if (records[x].tri != records[y].tri)
            pairs.emplace_back(3 * records[x].tri + records[x].local, records[y].tri);
      i = j;
    }
    s.edge_simplices = csr_from_pairs(static_cast<Index>(3 * k), pairs);
    return s;
  }
}

template BoundarySurface<2> build_boundary_surface<2>(Index, std::vector<std::array<Index, 2>>);
template BoundarySurface<3> build_boundary_surface<3>(Index, std::vector<std::array<Index, 3>>);

BoundarySurface<3> build_boundary_surface(const Topology& topo) {
  return build_boundary_surface<3>(topo.num_nodes, topo.boundary_faces);
}

BoundarySurface<2> build_boundary_surface(const Topology2& topo) {
  return build_boundary_surface<2>(topo.num_nodes, topo.boundary_segments);
}

}  // namespace tc
