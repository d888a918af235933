// Known answers for service/core/mesh/topology.
#include "core/mesh/topology.hpp"

#include <gtest/gtest.h>

#include <map>

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
