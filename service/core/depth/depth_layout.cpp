// The depth solver's per-topology layout (depth_layout.hpp).
#include "core/depth/depth_layout.hpp"

#include <algorithm>
#include <utility>

namespace tc::detail {
namespace {

Csr csr_from_rows(const std::vector<std::vector<Index>>& rows) {
  Csr csr;
  csr.offsets.reserve(rows.size() + 1);
  csr.offsets.push_back(0);
  for (const auto& r : rows) {
    csr.indices.insert(csr.indices.end(), r.begin(), r.end());
    csr.offsets.push_back(static_cast<Index>(csr.indices.size()));
  }
  return csr;
}

}  // namespace

template <int D>
DepthLayout<D>::DepthLayout(std::span<const Element> elems, const TopologyOf<D>& topo) {
  n = topo.num_nodes;
  const auto nn = static_cast<std::size_t>(n);
  elements.assign(elems.begin(), elems.end());
  is_boundary = topo.is_boundary_node;
  std::vector<std::uint8_t> used(nn, 0);
  for (const Element& e : elements)
    for (const Index v : e) used[v] = 1;
  for (Index v = 0; v < n; ++v)
    if (used[v]) used_original.push_back(v);

  // Boundary nodes in breadth-first order over the boundary surface (so that nodes
  // near each other on the surface are near each other in memory), each component
  // started from its smallest node.
  const BoundarySurface<D> original = build_boundary_surface(topo);
  inv.assign(nn, -1);
  perm.reserve(nn);
  for (const Index seed : topo.boundary_nodes) {
    if (inv[seed] >= 0) continue;
    std::size_t head = perm.size();
    inv[seed] = static_cast<Index>(perm.size());
    perm.push_back(seed);
    for (; head < perm.size(); ++head)
      for (const Index t : original.vertex_simplices.row(perm[head]))
        for (const Index v : original.simplices[t])
          if (inv[v] < 0) {
            inv[v] = static_cast<Index>(perm.size());
            perm.push_back(v);
          }
  }
  num_boundary = static_cast<Index>(perm.size());
  for (std::size_t head = 0; head < perm.size(); ++head)
    for (const Index v : topo.node_adjacency.row(perm[head]))
      if (inv[v] < 0) {
        inv[v] = static_cast<Index>(perm.size());
        perm.push_back(v);
      }
  for (const Index v : used_original)
    if (inv[v] < 0) {
      inv[v] = static_cast<Index>(perm.size());
      perm.push_back(v);
    }
  num_used = static_cast<Index>(perm.size());
  for (Index v = 0; v < n; ++v)
    if (inv[v] < 0) {
      inv[v] = static_cast<Index>(perm.size());
      perm.push_back(v);
    }

  // Adjacency in internal numbering, written straight into CSR (no per-node vectors).
  adjacency.offsets.assign(nn + 1, 0);
  for (Index i = 0; i < n; ++i)
    adjacency.offsets[i + 1] =
        adjacency.offsets[i] + static_cast<Index>(topo.node_adjacency.row(perm[i]).size());
  adjacency.indices.resize(static_cast<std::size_t>(adjacency.offsets[nn]));
  for (Index i = 0; i < n; ++i) {
    Index* row = adjacency.indices.data() + adjacency.offsets[i];
    Index k = 0;
    for (const Index v : topo.node_adjacency.row(perm[i])) row[k++] = inv[v];
    std::sort(row, row + k);
  }

  // Features renumbered in the order of their smallest internal node, so features
  // near each other on the surface are near each other in memory.
  std::vector<std::pair<std::array<Index, D>, Index>> keyed;
  keyed.reserve(original.simplices.size());
  for (std::size_t t = 0; t < original.simplices.size(); ++t) {
    std::array<Index, D> key;
    for (int k = 0; k < D; ++k) key[k] = inv[original.simplices[t][k]];
    std::sort(key.begin(), key.end());
    keyed.emplace_back(key, static_cast<Index>(t));
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::array<Index, D>> ordered;
  ordered.reserve(keyed.size());
  for (const auto& kt : keyed) ordered.push_back(original.simplices[kt.second]);
  surface = build_boundary_surface<D>(n, std::move(ordered));
  simplices_int.resize(surface.simplices.size());
  for (std::size_t t = 0; t < surface.simplices.size(); ++t)
    for (int k = 0; k < D; ++k) simplices_int[t][k] = inv[surface.simplices[t][k]];
  across.assign(surface.simplices.size(), {});
  across_far.assign(surface.simplices.size(), {});
  for (std::size_t t = 0; t < surface.simplices.size(); ++t)
    for (int j = 0; j < D; ++j) {
      across[t][j] = -1;
      across_far[t][j] = -1;
      std::vector<Index> others;
      if constexpr (D == 3) {
        const auto row = surface.edge_simplices.row(static_cast<Index>(3 * t + j));
        others.assign(row.begin(), row.end());
      } else {
        for (const Index o : surface.vertex_simplices.row(surface.simplices[t][j]))
          if (o != static_cast<Index>(t)) others.push_back(o);
      }
      if (others.size() != 1) continue;
      across[t][j] = others[0];
      // Side j of t: nodes j and j + 1 (3D edge) or node j (2D endpoint).
      for (const Index v : surface.simplices[others[0]]) {
        const bool on_side =
            v == surface.simplices[t][j] || (D == 3 && v == surface.simplices[t][(j + 1) % D]);
        if (!on_side) across_far[t][j] = inv[v];
      }
    }
  std::vector<std::vector<Index>> ring(static_cast<std::size_t>(num_boundary));
  seed_simplex.assign(static_cast<std::size_t>(num_boundary), -1);
  for (Index b = 0; b < num_boundary; ++b) {
    const auto row = surface.vertex_simplices.row(perm[b]);
    ring[b].assign(row.begin(), row.end());
    if (!row.empty()) seed_simplex[b] = row[0];
  }
  vertex_simplices_int = csr_from_rows(ring);
  all_boundary.resize(static_cast<std::size_t>(num_boundary));
  for (Index b = 0; b < num_boundary; ++b) all_boundary[b] = b;
}

template <int D>
std::span<const Index> DepthLayout<D>::across_side(Index s, int j) const {
  if (across[s][j] >= 0) return {&across[s][j], 1};
  if constexpr (D == 3) {
    return surface.edge_simplices.row(3 * s + j);
  } else {
    return vertex_simplices_int.row(simplices_int[s][j]);
  }
}

template struct DepthLayout<2>;
template struct DepthLayout<3>;

}  // namespace tc::detail
