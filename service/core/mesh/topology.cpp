#include "core/mesh/topology.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>

#include "core/common/parallel_chunks.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {

Csr csr_from_pairs(Index rows, std::vector<std::pair<Index, Index>>& pairs) {
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  Csr csr;
  csr.offsets.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (const auto& p : pairs) ++csr.offsets[static_cast<std::size_t>(p.first) + 1];
  std::partial_sum(csr.offsets.begin(), csr.offsets.end(), csr.offsets.begin());
  csr.indices.resize(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) csr.indices[i] = pairs[i].second;
  return csr;
}
namespace {

struct FaceRecord {
  std::array<Index, 3> key;  // sorted node indices
  Index tet;
  std::int8_t local;  // local index of the opposite node
};

Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

/// Boundary faces, their tets, edges and nodes from the (tet, local) pairs of the
/// boundary faces, sorted.
void add_boundary(Topology& topo, std::span<const Tet> tets,
                  const std::vector<std::pair<Index, Index>>& boundary) {
  topo.boundary_faces.reserve(boundary.size());
  topo.boundary_face_tet.reserve(boundary.size());
  for (const auto& [t, local] : boundary) {
    const auto& f = kTetFaces[local];
    topo.boundary_faces.push_back({tets[t][f[0]], tets[t][f[1]], tets[t][f[2]]});
    topo.boundary_face_tet.push_back(t);
  }
  topo.is_boundary_node.assign(static_cast<std::size_t>(topo.num_nodes), 0);
  topo.boundary_edges.reserve(3 * topo.boundary_faces.size());
  for (const auto& f : topo.boundary_faces) {
    for (int k = 0; k < 3; ++k) {
      topo.is_boundary_node[f[k]] = 1;
      const Index a = f[k], b = f[(k + 1) % 3];
      topo.boundary_edges.push_back({std::min(a, b), std::max(a, b)});
    }
  }
  std::sort(topo.boundary_edges.begin(), topo.boundary_edges.end());
  topo.boundary_edges.erase(std::unique(topo.boundary_edges.begin(), topo.boundary_edges.end()),
                            topo.boundary_edges.end());
  for (Index i = 0; i < topo.num_nodes; ++i)
    if (topo.is_boundary_node[i]) topo.boundary_nodes.push_back(i);
  // Node -> incident boundary faces, by a counting sort (faces ascending in each row).
  Csr& rows = topo.node_boundary_faces;
  rows.offsets.assign(static_cast<std::size_t>(topo.num_nodes) + 1, 0);
  for (const auto& f : topo.boundary_faces)
    for (const Index v : f) ++rows.offsets[static_cast<std::size_t>(v) + 1];
  for (std::size_t i = 0; i + 1 < rows.offsets.size(); ++i) rows.offsets[i + 1] += rows.offsets[i];
  rows.indices.resize(static_cast<std::size_t>(rows.offsets.back()));
  std::vector<Index> next(rows.offsets.begin(), rows.offsets.end() - 1);
  for (std::size_t k = 0; k < topo.boundary_faces.size(); ++k)
    for (const Index v : topo.boundary_faces[k]) rows.indices[next[v]++] = static_cast<Index>(k);
}

/// Orphan nodes (from node_tets) and face-connected components (from tet_neighbors),
/// numbered by their smallest tet.
void add_orphans_and_components(Topology& topo) {
  for (Index i = 0; i < topo.num_nodes; ++i)
    if (topo.node_tets.offsets[i] == topo.node_tets.offsets[i + 1]) topo.orphan_nodes.push_back(i);
  const auto m = static_cast<std::size_t>(topo.num_tets);
  std::vector<Index> parent(m);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t t = 0; t < m; ++t) {
    for (const Index n : topo.tet_neighbors[t]) {
      if (n < 0) continue;
      const Index a = find_root(parent, static_cast<Index>(t)), b = find_root(parent, n);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  topo.tet_component.assign(m, -1);
  std::vector<Index> label(m, -1);
  for (std::size_t t = 0; t < m; ++t) {
    const Index r = find_root(parent, static_cast<Index>(t));
    if (label[r] < 0) label[r] = topo.num_components++;
    topo.tet_component[t] = label[r];
  }
}

}  // namespace

Topology build_topology_reference(std::span<const Tet> tets, Index num_nodes) {
  Topology topo;
  topo.num_nodes = num_nodes;
  topo.num_tets = static_cast<Index>(tets.size());
  const auto m = tets.size();

  // Faces: sort the 4m sorted-key faces; singletons are boundary, pairs neighbours.
  std::vector<FaceRecord> faces;
  faces.reserve(4 * m);
  for (std::size_t t = 0; t < m; ++t) {
    for (int j = 0; j < 4; ++j) {
      const auto& f = kTetFaces[j];
      std::array<Index, 3> key = {tets[t][f[0]], tets[t][f[1]], tets[t][f[2]]};
      std::sort(key.begin(), key.end());
      faces.push_back({key, static_cast<Index>(t), static_cast<std::int8_t>(j)});
    }
  }
  std::sort(faces.begin(), faces.end(), [](const FaceRecord& a, const FaceRecord& b) {
    return a.key != b.key ? a.key < b.key : (a.tet != b.tet ? a.tet < b.tet : a.local < b.local);
  });

  topo.tet_neighbors.assign(m, {-1, -1, -1, -1});
  std::vector<std::pair<Index, Index>> boundary;  // (tet, local) of boundary faces
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    const std::size_t count = j - i;
    if (count == 1) {
      boundary.emplace_back(faces[i].tet, faces[i].local);
    } else if (count == 2) {
      topo.tet_neighbors[faces[i].tet][faces[i].local] = faces[i + 1].tet;
      topo.tet_neighbors[faces[i + 1].tet][faces[i + 1].local] = faces[i].tet;
    } else {
      ++topo.nonmanifold_faces;
    }
    i = j;
  }
  std::sort(boundary.begin(), boundary.end());
  add_boundary(topo, tets, boundary);

  // Unique edges, adjacency and incidence.
  topo.edges.reserve(6 * m);
  std::vector<std::pair<Index, Index>> incidence;
  incidence.reserve(4 * m);
  for (std::size_t t = 0; t < m; ++t) {
    for (const auto& e : kTetEdges) {
      const Index a = tets[t][e[0]], b = tets[t][e[1]];
      topo.edges.push_back({std::min(a, b), std::max(a, b)});
    }
    for (int k = 0; k < 4; ++k) incidence.emplace_back(tets[t][k], static_cast<Index>(t));
  }
  std::sort(topo.edges.begin(), topo.edges.end());
  topo.edges.erase(std::unique(topo.edges.begin(), topo.edges.end()), topo.edges.end());
  std::vector<std::pair<Index, Index>> adjacency;
  adjacency.reserve(2 * topo.edges.size());
  for (const auto& e : topo.edges) {
    if (e[0] == e[1]) continue;  // a repeated node in a broken tet
    adjacency.emplace_back(e[0], e[1]);
    adjacency.emplace_back(e[1], e[0]);
  }
  topo.node_adjacency = csr_from_pairs(num_nodes, adjacency);
  topo.node_tets = csr_from_pairs(num_nodes, incidence);

  add_orphans_and_components(topo);
  return topo;
}

namespace {

/// The fast path needs tets of 4 distinct nodes in [0, n) (no self-shared faces or
/// degenerate edges), face keys packed in 64 bits (n^3 < 2^63) and 4m < 2^32.
bool fast_path_applies(std::span<const Tet> tets, Index num_nodes) {
  if (num_nodes <= 0 || num_nodes > (Index{1} << 21)) return false;
  if (tets.size() >= (std::size_t{1} << 30)) return false;
  for (const Tet& t : tets) {
    for (const Index v : t)
      if (v < 0 || v >= num_nodes) return false;
    if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] ||
        t[2] == t[3])
      return false;
  }
  return true;
}

/// Stable LSD radix sort of (keys, values) by key, one byte per pass, skipping bytes
/// above max_key and passes whose byte is the same for every key.
void radix_sort(std::vector<std::uint64_t>& keys, std::vector<std::uint32_t>& values,
                std::uint64_t max_key) {
  const std::size_t n = keys.size();
  int bytes = 0;
  while (bytes < 8 && (max_key >> (8 * bytes)) != 0) ++bytes;
  std::vector<std::array<std::size_t, 256>> hist(static_cast<std::size_t>(bytes));
  for (auto& h : hist) h.fill(0);
  for (const std::uint64_t k : keys)
    for (int b = 0; b < bytes; ++b) ++hist[b][(k >> (8 * b)) & 0xff];
  std::vector<std::uint64_t> keys2(n);
  std::vector<std::uint32_t> values2(n);
  for (int b = 0; b < bytes; ++b) {
    auto& h = hist[b];
    if (std::find(h.begin(), h.end(), n) != h.end()) continue;  // one bucket: no-op
    std::size_t sum = 0;
    for (auto& c : h) {
      const std::size_t count = c;
      c = sum;
      sum += count;
    }
    const int shift = 8 * b;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t to = h[(keys[i] >> shift) & 0xff]++;
      keys2[to] = keys[i];
      values2[to] = values[i];
    }
    keys.swap(keys2);
    values.swap(values2);
  }
}

Topology build_topology_fast(std::span<const Tet> tets, Index num_nodes) {
  Topology topo;
  topo.num_nodes = num_nodes;
  topo.num_tets = static_cast<Index>(tets.size());
  const std::size_t m = tets.size();
  const auto n = static_cast<std::size_t>(num_nodes);
  constexpr std::size_t kChunk = 4096;

  // Node -> tets by counting sort: tets are visited in order, so rows come out sorted.
  Csr& node_tets = topo.node_tets;
  node_tets.offsets.assign(n + 1, 0);
  for (const Tet& t : tets)
    for (const Index v : t) ++node_tets.offsets[static_cast<std::size_t>(v) + 1];
  std::partial_sum(node_tets.offsets.begin(), node_tets.offsets.end(), node_tets.offsets.begin());
  node_tets.indices.resize(4 * m);
  {
    std::vector<Index> fill(node_tets.offsets.begin(), node_tets.offsets.end() - 1);
    for (std::size_t t = 0; t < m; ++t)
      for (const Index v : tets[t]) node_tets.indices[fill[v]++] = static_cast<Index>(t);
  }

  // Faces: packed sorted-node keys, radix-sorted (stable, so equal keys stay in (tet,
  // local) order as in the reference's comparison sort).
  std::vector<std::uint64_t> keys(4 * m);
  std::vector<std::uint32_t> owner(4 * m);  // 4 tet + local
  const auto nn = static_cast<std::uint64_t>(n);
  detail::for_chunks(m, kChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t t = begin; t < end; ++t)
      for (int j = 0; j < 4; ++j) {
        const auto& f = kTetFaces[j];
        auto a = static_cast<std::uint64_t>(tets[t][f[0]]);
        auto b = static_cast<std::uint64_t>(tets[t][f[1]]);
        auto c = static_cast<std::uint64_t>(tets[t][f[2]]);
        if (a > b) std::swap(a, b);
        if (b > c) std::swap(b, c);
        if (a > b) std::swap(a, b);
        keys[4 * t + j] = (a * nn + b) * nn + c;
        owner[4 * t + j] = static_cast<std::uint32_t>(4 * t + j);
      }
  });
  radix_sort(keys, owner, nn * nn * nn - 1);
  topo.tet_neighbors.assign(m, {-1, -1, -1, -1});
  std::vector<std::pair<Index, Index>> boundary;  // (tet, local) of boundary faces
  for (std::size_t i = 0; i < keys.size();) {
    std::size_t j = i + 1;
    while (j < keys.size() && keys[j] == keys[i]) ++j;
    const std::size_t count = j - i;
    const auto t0 = static_cast<Index>(owner[i] >> 2);
    const auto l0 = static_cast<int>(owner[i] & 3);
    if (count == 1) {
      boundary.emplace_back(t0, l0);
    } else if (count == 2) {
      const auto t1 = static_cast<Index>(owner[i + 1] >> 2);
      const auto l1 = static_cast<int>(owner[i + 1] & 3);
      topo.tet_neighbors[t0][l0] = t1;
      topo.tet_neighbors[t1][l1] = t0;
    } else {
      ++topo.nonmanifold_faces;
    }
    i = j;
  }
  std::vector<std::uint64_t>().swap(keys);
  std::vector<std::uint32_t>().swap(owner);
  std::sort(boundary.begin(), boundary.end());
  add_boundary(topo, tets, boundary);

  // Node adjacency: per node, the other nodes of its tets, sorted and unique; each row
  // is written into its own slice of a scratch array sized by 3 x (tets of the node).
  std::vector<Index> scratch(3 * 4 * m);
  std::vector<Index> count(n, 0);
  detail::for_chunks(n, kChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t v = begin; v < end; ++v) {
      Index* row = scratch.data() + 3 * static_cast<std::size_t>(node_tets.offsets[v]);
      Index k = 0;
      for (const Index t : node_tets.row(static_cast<Index>(v)))
        for (const Index u : tets[t])
          if (u != static_cast<Index>(v)) row[k++] = u;
      std::sort(row, row + k);
      count[v] = static_cast<Index>(std::unique(row, row + k) - row);
    }
  });
  Csr& adjacency = topo.node_adjacency;
  adjacency.offsets.assign(n + 1, 0);
  std::vector<Index> edge_offsets(n + 1, 0);
  for (std::size_t v = 0; v < n; ++v) {
    adjacency.offsets[v + 1] = adjacency.offsets[v] + count[v];
    // Edges (v, u), u > v: the tail of v's sorted row.
    const Index* row = scratch.data() + 3 * static_cast<std::size_t>(node_tets.offsets[v]);
    const Index above = static_cast<Index>(
        row + count[v] - std::upper_bound(row, row + count[v], static_cast<Index>(v)));
    edge_offsets[v + 1] = edge_offsets[v] + above;
  }
  adjacency.indices.resize(static_cast<std::size_t>(adjacency.offsets[n]));
  topo.edges.resize(static_cast<std::size_t>(edge_offsets[n]));
  detail::for_chunks(n, kChunk, [&](std::size_t begin, std::size_t end, std::size_t) {
    for (std::size_t v = begin; v < end; ++v) {
      const Index* row = scratch.data() + 3 * static_cast<std::size_t>(node_tets.offsets[v]);
      std::copy(row, row + count[v], adjacency.indices.begin() + adjacency.offsets[v]);
      const Index above = edge_offsets[v + 1] - edge_offsets[v];
      for (Index k = 0; k < above; ++k)
        topo.edges[static_cast<std::size_t>(edge_offsets[v] + k)] = {static_cast<Index>(v),
                                                                     row[count[v] - above + k]};
    }
  });

  add_orphans_and_components(topo);
  return topo;
}

}  // namespace

Topology build_topology(std::span<const Tet> tets, Index num_nodes) {
  return fast_path_applies(tets, num_nodes) ? build_topology_fast(tets, num_nodes)
                                            : build_topology_reference(tets, num_nodes);
}

Index boundary_euler_characteristic(const Topology& topo) {
  return static_cast<Index>(topo.boundary_nodes.size()) -
         static_cast<Index>(topo.boundary_edges.size()) +
         static_cast<Index>(topo.boundary_faces.size());
}

Topology build_edge_topology(std::span<const std::array<Index, 2>> edges, Index num_nodes) {
  Topology topo;
  topo.num_nodes = num_nodes;
  topo.edges.assign(edges.begin(), edges.end());
  std::vector<std::pair<Index, Index>> adjacency;
  adjacency.reserve(2 * edges.size());
  for (const auto& e : edges) {
    adjacency.emplace_back(e[0], e[1]);
    adjacency.emplace_back(e[1], e[0]);
  }
  topo.node_adjacency = csr_from_pairs(num_nodes, adjacency);
  return topo;
}

}  // namespace tc
