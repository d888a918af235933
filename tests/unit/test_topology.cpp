// Known answers for service/core/mesh/topology.
#include "core/mesh/topology.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <random>
#include <string>

#include "core/io/mesh_io.hpp"

#include "core/mesh/geometry.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

Topology topo_of(const TetMesh& m) {
  return build_topology(m.tets, m.num_nodes());
}

TEST(Topology, SingleTet) {
  const TetMesh m = test::single_tet();
  const Topology t = topo_of(m);
  EXPECT_EQ(t.boundary_faces.size(), 4u);
  EXPECT_EQ(t.boundary_edges.size(), 6u);
  EXPECT_EQ(t.boundary_nodes.size(), 4u);
  EXPECT_EQ(t.edges.size(), 6u);
  EXPECT_EQ(t.num_components, 1);
  EXPECT_TRUE(t.orphan_nodes.empty());
  EXPECT_EQ(boundary_euler_characteristic(t), 2);
  for (Index i = 0; i < 4; ++i) EXPECT_EQ(t.node_adjacency.row(i).size(), 3u);
  for (const auto& n : t.tet_neighbors[0]) EXPECT_EQ(n, -1);
}

TEST(Topology, TwoTetsSharingAFace) {
  const Topology t = topo_of(test::two_tets_sharing_face());
  EXPECT_EQ(t.boundary_faces.size(), 6u);
  EXPECT_EQ(t.edges.size(), 9u);
  EXPECT_EQ(t.boundary_edges.size(), 9u);
  EXPECT_EQ(t.num_components, 1);
  EXPECT_EQ(boundary_euler_characteristic(t), 2);
  EXPECT_EQ(t.tet_neighbors[0][0], 1);  // face opposite node 0 of tet 0 is shared
  int shared = 0;
  for (const Index n : t.tet_neighbors[1]) shared += n == 0;
  EXPECT_EQ(shared, 1);
}

TEST(Topology, NodeBoundaryFacesListEveryIncidentFaceOnce) {
  const Topology t = topo_of(test::two_tets_sharing_face());
  ASSERT_EQ(t.node_boundary_faces.rows(), t.num_nodes);
  std::size_t total = 0;
  for (Index v = 0; v < t.num_nodes; ++v) {
    const auto row = t.node_boundary_faces.row(v);
    total += row.size();
    EXPECT_TRUE(std::is_sorted(row.begin(), row.end()));
    EXPECT_EQ(row.empty(), t.is_boundary_node[v] == 0);
    for (std::size_t k = 0; k < t.boundary_faces.size(); ++k) {
      const auto& f = t.boundary_faces[k];
      const bool uses = f[0] == v || f[1] == v || f[2] == v;
      const bool listed = std::find(row.begin(), row.end(), static_cast<Index>(k)) != row.end();
      EXPECT_EQ(uses, listed) << "node " << v << " face " << k;
    }
  }
  EXPECT_EQ(total, 3 * t.boundary_faces.size());
}

class CubeSplit : public ::testing::TestWithParam<int> {};

TEST_P(CubeSplit, TwelveBoundaryTrianglesAndClosedSurface) {
  const TetMesh m = GetParam() == 5 ? test::cube_five_tets(2.0) : test::cube_six_tets(2.0);
  const Topology t = topo_of(m);
  EXPECT_EQ(m.num_tets(), GetParam());
  EXPECT_EQ(t.boundary_faces.size(), 12u);
  EXPECT_EQ(t.boundary_nodes.size(), 8u);
  EXPECT_EQ(t.boundary_edges.size(), 18u);  // 12 cube edges + 6 face diagonals
  EXPECT_EQ(boundary_euler_characteristic(t), 2);
  EXPECT_EQ(t.num_components, 1);
  // Outward orientation: the signed volume of the boundary equals the tet volume.
  double surface_volume = 0.0;
  for (const auto& f : t.boundary_faces)
    surface_volume +=
        m.positions.col(f[0]).dot(m.positions.col(f[1]).cross(m.positions.col(f[2]))) / 6.0;
  EXPECT_NEAR(surface_volume, 8.0, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(FiveAndSix, CubeSplit, ::testing::Values(5, 6));

TEST(Topology, StructuredBoxCountsAndAdjacencySymmetry) {
  const TetMesh m = test::structured_box(3, 2, 4, {0, 0, 0}, {3, 2, 4});
  const Topology t = topo_of(m);
  EXPECT_EQ(m.num_tets(), 6 * 24);
  EXPECT_EQ(t.boundary_faces.size(), static_cast<std::size_t>(2 * 2 * (3 * 2 + 2 * 4 + 3 * 4)));
  EXPECT_EQ(boundary_euler_characteristic(t), 2);
  EXPECT_EQ(t.num_components, 1);
  for (Index i = 0; i < t.num_nodes; ++i)
    for (const Index j : t.node_adjacency.row(i)) {
      const auto row = t.node_adjacency.row(j);
      EXPECT_TRUE(std::find(row.begin(), row.end(), i) != row.end());
    }
  // Every tet lists each of its nodes' incidences exactly once.
  std::size_t incidences = 0;
  for (Index i = 0; i < t.num_nodes; ++i) incidences += t.node_tets.row(i).size();
  EXPECT_EQ(incidences, 4u * m.tets.size());
}

TEST(Topology, ComponentsAndOrphans) {
  TetMesh a = test::single_tet();
  // A second tet far away, plus an orphan node between them.
  a.positions.conservativeResize(3, 9);
  a.positions.col(4) << 10, 0, 0;
  a.positions.col(5) << 11, 0, 0;
  a.positions.col(6) << 10, 1, 0;
  a.positions.col(7) << 10, 0, 1;
  a.positions.col(8) << 5, 5, 5;
  a.tets.push_back({4, 5, 6, 7});
  const Topology t = topo_of(a);
  EXPECT_EQ(t.num_components, 2);
  EXPECT_EQ(t.tet_component[0], 0);
  EXPECT_EQ(t.tet_component[1], 1);
  ASSERT_EQ(t.orphan_nodes.size(), 1u);
  EXPECT_EQ(t.orphan_nodes[0], 8);
  EXPECT_EQ(t.is_boundary_node[8], 0);
  EXPECT_EQ(boundary_euler_characteristic(t), 4);
}

TEST(Topology, NonManifoldFaceIsCountedNotUsed) {
  TetMesh m = test::single_tet();
  m.positions.conservativeResize(3, 6);
  m.positions.col(4) << 0.3, 0.3, -1;
  m.positions.col(5) << 0.3, 0.3, -2;
  m.tets.push_back({0, 2, 1, 4});
  m.tets.push_back({0, 2, 1, 5});
  const Topology t = topo_of(m);
  EXPECT_EQ(t.nonmanifold_faces, 1);
}

TEST(Topology, DeterministicAcrossBuilds) {
  const TetMesh m = test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1});
  const Topology a = topo_of(m), b = topo_of(m);
  EXPECT_EQ(a.boundary_faces, b.boundary_faces);
  EXPECT_EQ(a.node_adjacency.indices, b.node_adjacency.indices);
  EXPECT_EQ(a.tet_neighbors, b.tet_neighbors);
}

void expect_same_topology(const Topology& a, const Topology& b) {
  EXPECT_EQ(a.num_nodes, b.num_nodes);
  EXPECT_EQ(a.num_tets, b.num_tets);
  EXPECT_EQ(a.boundary_faces, b.boundary_faces);
  EXPECT_EQ(a.boundary_face_tet, b.boundary_face_tet);
  EXPECT_EQ(a.boundary_edges, b.boundary_edges);
  EXPECT_EQ(a.boundary_nodes, b.boundary_nodes);
  EXPECT_EQ(a.node_boundary_faces.offsets, b.node_boundary_faces.offsets);
  EXPECT_EQ(a.node_boundary_faces.indices, b.node_boundary_faces.indices);
  EXPECT_EQ(a.is_boundary_node, b.is_boundary_node);
  EXPECT_EQ(a.edges, b.edges);
  EXPECT_EQ(a.node_adjacency.offsets, b.node_adjacency.offsets);
  EXPECT_EQ(a.node_adjacency.indices, b.node_adjacency.indices);
  EXPECT_EQ(a.node_tets.offsets, b.node_tets.offsets);
  EXPECT_EQ(a.node_tets.indices, b.node_tets.indices);
  EXPECT_EQ(a.tet_neighbors, b.tet_neighbors);
  EXPECT_EQ(a.tet_component, b.tet_component);
  EXPECT_EQ(a.num_components, b.num_components);
  EXPECT_EQ(a.orphan_nodes, b.orphan_nodes);
  EXPECT_EQ(a.nonmanifold_faces, b.nonmanifold_faces);
}

// build_topology (fast path: radix-sorted face keys, per-node adjacency rows, TBB) gives
// exactly what the plain comparison-sort reference gives, on shuffled structured boxes
// with random tets dropped (boundaries, holes, several components, orphan nodes), with
// extra tets sharing a face three ways (non-manifold), and on broken tets (repeated
// nodes: the reference path).
class TopologyAgainstReference : public ::testing::TestWithParam<int> {};

TEST_P(TopologyAgainstReference, IdenticalOnShuffledMeshes) {
  std::mt19937 rng(static_cast<unsigned>(GetParam()));
  const int nx = 2 + GetParam() % 5, ny = 1 + GetParam() % 4, nz = 3 + GetParam() % 3;
  const TetMesh box = test::structured_box(nx, ny, nz, {0, 0, 0}, {1, 1, 1});
  const Index n = box.num_nodes() + 3;  // 3 extra nodes: orphans unless used below
  std::vector<Index> perm(static_cast<std::size_t>(n));
  std::iota(perm.begin(), perm.end(), 0);
  std::shuffle(perm.begin(), perm.end(), rng);
  std::vector<Tet> tets;
  std::bernoulli_distribution keep(GetParam() % 2 == 0 ? 1.0 : 0.7);
  for (const Tet& t : box.tets) {
    if (!keep(rng)) continue;
    Tet u{perm[t[0]], perm[t[1]], perm[t[2]], perm[t[3]]};
    if (rng() % 3 == 0) std::swap(u[0], u[1]);  // orientation does not matter here
    tets.push_back(u);
  }
  std::shuffle(tets.begin(), tets.end(), rng);
  if (GetParam() % 3 == 0 && !tets.empty()) {
    // Two more tets on a face of the first one, with the extra nodes: non-manifold.
    const Tet& t = tets.front();
    tets.push_back({t[0], t[1], t[2], perm[static_cast<std::size_t>(n - 1)]});
    tets.push_back({t[2], t[1], t[0], perm[static_cast<std::size_t>(n - 2)]});
  }
  SCOPED_TRACE("seed " + std::to_string(GetParam()) + ", " + std::to_string(tets.size()) + " tets");
  const Topology fast = build_topology(tets, n);
  const Topology reference = build_topology_reference(tets, n);
  expect_same_topology(fast, reference);
  EXPECT_EQ(fast.orphan_nodes.empty(), false);
  if (GetParam() % 3 == 0) {
    EXPECT_GT(fast.nonmanifold_faces, 0);
  }

  // Broken tets (a repeated node) go through the reference path: still identical.
  tets.push_back({perm[0], perm[0], perm[1], perm[2]});
  expect_same_topology(build_topology(tets, n), build_topology_reference(tets, n));
}

INSTANTIATE_TEST_SUITE_P(Seeds, TopologyAgainstReference, ::testing::Range(0, 12));

TEST(TopologyAgainstReference, IdenticalOnTheBundledMeshes) {
  for (const char* file : {"torus.msh", "ball.msh", "box.msh"}) {
    auto mesh = read_mesh(test::mesh_path(file));
    ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
    SCOPED_TRACE(file);
    expect_same_topology(build_topology(mesh->tets, mesh->num_nodes()),
                         build_topology_reference(mesh->tets, mesh->num_nodes()));
  }
}

TEST(TopologyAgainstReference, IdenticalWithOneThread) {
  const TetMesh m = test::structured_box(9, 7, 8, {0, 0, 0}, {1, 1, 1});
  const Topology many = build_topology(m.tets, m.num_nodes());
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  expect_same_topology(build_topology(m.tets, m.num_nodes()), many);
  expect_same_topology(many, build_topology_reference(m.tets, m.num_nodes()));
}

}  // namespace
}  // namespace tc

namespace tc {
namespace {

// The bundled Gmsh meshes: closed boundaries with the Euler characteristic of their shape.
struct BundledMesh {
  const char* file;
  Index euler;
};

class BundledTopology : public ::testing::TestWithParam<BundledMesh> {};

TEST_P(BundledTopology, ClosedBoundaryWithTheRightEulerCharacteristic) {
  auto mesh = read_mesh(test::mesh_path(GetParam().file));
  ASSERT_TRUE(mesh.has_value()) << mesh.error().message;
  const Topology t = build_topology(mesh->tets, mesh->num_nodes());
  EXPECT_EQ(boundary_euler_characteristic(t), GetParam().euler);
  EXPECT_EQ(t.num_components, 1);
  EXPECT_EQ(t.nonmanifold_faces, 0);
  EXPECT_TRUE(t.orphan_nodes.empty());
  // Closed: every boundary edge is shared by exactly two boundary faces.
  std::map<std::array<Index, 2>, int> uses;
  for (const auto& f : t.boundary_faces)
    for (int k = 0; k < 3; ++k)
      ++uses[{std::min(f[k], f[(k + 1) % 3]), std::max(f[k], f[(k + 1) % 3])}];
  for (const auto& [edge, count] : uses) EXPECT_EQ(count, 2);
  // Outward: the boundary encloses the tets' volume with a positive sign.
  double tets_volume = 0.0, surface_volume = 0.0;
  for (const Tet& tet : mesh->tets) tets_volume += signed_volume(mesh->positions, tet);
  for (const auto& f : t.boundary_faces)
    surface_volume +=
        mesh->positions.col(f[0]).dot(mesh->positions.col(f[1]).cross(mesh->positions.col(f[2]))) /
        6.0;
  EXPECT_NEAR(surface_volume, tets_volume, 1e-9 * tets_volume);
  EXPECT_GT(tets_volume, 0.0);
}

INSTANTIATE_TEST_SUITE_P(DataMeshes, BundledTopology,
                         ::testing::Values(BundledMesh{"torus.msh", 0}, BundledMesh{"ball.msh", 2},
                                           BundledMesh{"box.msh", 2},
                                           BundledMesh{"ellipsoid.msh", 2},
                                           BundledMesh{"slab.msh", 2}));

}  // namespace
}  // namespace tc
