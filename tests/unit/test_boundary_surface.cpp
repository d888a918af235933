// service/core/depth/boundary_surface: surface adjacency of tet meshes and the 2D
// topology, counted by hand and checked against brute force.
#include "core/depth/boundary_surface.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "test_meshes.hpp"

namespace tc {
namespace {

TEST(BoundarySurface, CubeHasTwelveTrianglesEachWithThreeEdgeNeighbours) {
  const TetMesh m = test::cube_six_tets();
  const Topology topo = build_topology(m.tets, m.num_nodes());
  const BoundarySurface<3> s = build_boundary_surface(topo);
  ASSERT_EQ(s.size(), 12);
  EXPECT_EQ(s.edge_simplices.rows(), 36);
  for (Index t = 0; t < s.size(); ++t)
    for (int j = 0; j < 3; ++j) {
      const auto row = s.edge_simplices.row(3 * t + j);
      ASSERT_EQ(row.size(), 1u);  // closed manifold surface
      // The neighbour really shares edge j.
      const Index a = s.simplices[t][j], b = s.simplices[t][(j + 1) % 3];
      const auto& n = s.simplices[row[0]];
      EXPECT_TRUE(std::count(n.begin(), n.end(), a) == 1 && std::count(n.begin(), n.end(), b) == 1);
    }
  // Vertex rings: every triangle appears in the rings of its three vertices.
  std::size_t total = 0;
  for (Index v = 0; v < m.num_nodes(); ++v) total += s.vertex_simplices.row(v).size();
  EXPECT_EQ(total, 36u);
}

TEST(BoundarySurface, NonManifoldEdgeListsEveryOtherTriangle) {
  // Two cubes sharing one edge: that edge has four boundary triangles around it.
  TetMesh a = test::cube_six_tets();
  TetMesh b = test::cube_six_tets();
  b.positions.row(0).array() += 1.0;
  b.positions.row(1).array() += 1.0;
  // Cube b's corner (0,0,z) lands on cube a's corner (1,1,z): nodes 0 and 4 of b are
  // nodes 3 and 7 of a.
  TetMesh m = a;
  std::vector<Index> map(8);
  Index next = a.num_nodes();
  for (Index i = 0; i < 8; ++i) map[i] = i == 0 ? 3 : (i == 4 ? 7 : next++);
  m.positions.conservativeResize(3, next);
  for (Index i = 0; i < 8; ++i) m.positions.col(map[i]) = b.positions.col(i);
  for (Tet t : b.tets) {
    for (Index& v : t) v = map[v];
    m.tets.push_back(t);
  }
  const Topology topo = build_topology(m.tets, next);
  const BoundarySurface<3> s = build_boundary_surface(topo);
  std::size_t rows_with_three = 0;
  for (Index r = 0; r < s.edge_simplices.rows(); ++r)
    if (s.edge_simplices.row(r).size() == 3) ++rows_with_three;
  EXPECT_EQ(rows_with_three, 4u);  // the four triangles at the shared edge
}

TEST(Topology2d, RectangleCountsAndAdjacency) {
  const TriMesh2 m = test::rect_mesh_2d(3, 2, 3.0, 2.0);
  const Topology2 t = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  EXPECT_EQ(t.num_triangles, 12);
  EXPECT_EQ(t.boundary_segments.size(), 10u);
  EXPECT_EQ(t.boundary_nodes.size(), 10u);
  EXPECT_TRUE(t.orphan_nodes.empty());
  // Node 5 (interior, (1,1)) has the 6 neighbours of the two-triangle split.
  EXPECT_EQ(t.node_adjacency.row(5).size(), 6u);
  const BoundarySurface<2> s = build_boundary_surface(t);
  for (const Index b : t.boundary_nodes) EXPECT_EQ(s.vertex_simplices.row(b).size(), 2u);
}

TEST(Topology2d, OrphansAndTwoComponents) {
  TriMesh2 m = test::rect_mesh_2d(1, 1, 1.0, 1.0);
  m.positions.conservativeResize(2, 8);
  m.positions.col(4) = Eigen::Vector2d(5, 5);
  m.positions.col(5) = Eigen::Vector2d(6, 5);
  m.positions.col(6) = Eigen::Vector2d(5, 6);
  m.positions.col(7) = Eigen::Vector2d(9, 9);  // orphan
  m.triangles.push_back({4, 5, 6});
  const Topology2 t = build_topology_2d(m.triangles, 8);
  EXPECT_EQ(t.orphan_nodes, std::vector<Index>{7});
  EXPECT_EQ(t.boundary_segments.size(), 7u);
  EXPECT_EQ(t.is_boundary_node[7], 0);
}

}  // namespace
}  // namespace tc
