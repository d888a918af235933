#include "core/mesh/topology.hpp"

#include <algorithm>
#include <numeric>

#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

struct FaceRecord {
  std::array<Index, 3> key;  // sorted node indices
  Index tet;
  std::int8_t local;  // local index of the opposite node
};

Csr build_csr(Index rows, std::vector<std::pair<Index, Index>>& entries) {
  std::sort(entries.begin(), entries.end());
  entries.erase(std::unique(entries.begin(), entries.end()), entries.end());
  Csr csr;
  csr.offsets.assign(static_cast<std::size_t>(rows) + 1, 0);
  for (const auto& e : entries) ++csr.offsets[static_cast<std::size_t>(e.first) + 1];
  std::partial_sum(csr.offsets.begin(), csr.offsets.end(), csr.offsets.begin());
  csr.indices.resize(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) csr.indices[i] = entries[i].second;
  return csr;
}

Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

Topology build_topology(std::span<const Tet> tets, Index num_nodes) {
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
  topo.boundary_faces.reserve(boundary.size());
  topo.boundary_face_tet.reserve(boundary.size());
  for (const auto& [t, local] : boundary) {
    const auto& f = kTetFaces[local];
    topo.boundary_faces.push_back({tets[t][f[0]], tets[t][f[1]], tets[t][f[2]]});
    topo.boundary_face_tet.push_back(t);
  }

  // Boundary nodes and edges.
  topo.is_boundary_node.assign(static_cast<std::size_t>(num_nodes), 0);
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
  for (Index i = 0; i < num_nodes; ++i)
    if (topo.is_boundary_node[i]) topo.boundary_nodes.push_back(i);

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
  topo.node_adjacency = build_csr(num_nodes, adjacency);
  topo.node_tets = build_csr(num_nodes, incidence);

  for (Index i = 0; i < num_nodes; ++i)
    if (topo.node_tets.offsets[i] == topo.node_tets.offsets[i + 1]) topo.orphan_nodes.push_back(i);

  // Face-connected components, numbered by their smallest tet.
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
  return topo;
}

Index boundary_euler_characteristic(const Topology& topo) {
  return static_cast<Index>(topo.boundary_nodes.size()) -
         static_cast<Index>(topo.boundary_edges.size()) +
         static_cast<Index>(topo.boundary_faces.size());
}

}  // namespace tc
