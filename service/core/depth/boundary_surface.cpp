#include "core/depth/boundary_surface.hpp"

#include <algorithm>
#include <numeric>
#include <utility>

namespace tc {
namespace {

template <int D>
Csr vertex_simplex_csr(Index num_nodes, const std::vector<std::array<Index, D>>& simplices) {
  std::vector<std::pair<Index, Index>> pairs;
  pairs.reserve(simplices.size() * D);
  for (std::size_t s = 0; s < simplices.size(); ++s)
    for (int k = 0; k < D; ++k) pairs.emplace_back(simplices[s][k], static_cast<Index>(s));
  return csr_from_pairs(num_nodes, pairs);
}

}  // namespace

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
