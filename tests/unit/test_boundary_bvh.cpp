// service/core/depth/boundary_bvh: nearest feature == brute force over all features
// (2D and 3D, points inside, outside and on the surface), bounds, range queries.
#include "core/depth/boundary_bvh.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "core/depth/boundary_surface.hpp"
#include "core/depth/point_simplex_distance.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

class BvhRandom : public ::testing::TestWithParam<unsigned> {};

TEST_P(BvhRandom, NearestTriangleEqualsBruteForce) {
  const TetMesh m = test::torus_mesh(20, 4, 2.0, 0.7);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  BoundaryBvh<3> bvh;
  bvh.build(topo.boundary_faces, m.positions);
  EXPECT_EQ(bvh.size(), static_cast<Index>(topo.boundary_faces.size()));
  std::mt19937 rng(GetParam());
  std::uniform_real_distribution<double> u(-3.5, 3.5);
  for (int trial = 0; trial < 300; ++trial) {
    // Random points, and points exactly at vertices of the surface.
    Eigen::Vector3d p(u(rng), u(rng), u(rng) * 0.4);
    if (trial % 10 == 0)
      p = m.positions.col(topo.boundary_nodes[rng() % topo.boundary_nodes.size()]);
    const double best = test::brute_force_sq_distance_to_boundary(m, topo, p);
    const auto hit = bvh.nearest(p);
    EXPECT_EQ(hit.sq_dist, best);
    ASSERT_GE(hit.simplex, 0);
    const auto& f = topo.boundary_faces[hit.simplex];
    EXPECT_EQ(point_triangle_distance(p, Eigen::Vector3d(m.positions.col(f[0])),
                                      Eigen::Vector3d(m.positions.col(f[1])),
                                      Eigen::Vector3d(m.positions.col(f[2])))
                  .sq_dist,
              best);
    // A bound at or below the answer finds nothing; a bound above finds the answer.
    EXPECT_EQ(bvh.nearest(p, best).simplex, -1);
    EXPECT_EQ(bvh.nearest(p, best * 1.0001 + 1e-300).sq_dist, best);
  }
}

TEST_P(BvhRandom, NearestSegmentEqualsBruteForce2d) {
  const TriMesh2 m = test::disc_mesh_2d(10, 1.0);
  const Topology2 topo = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  BoundaryBvh<2> bvh;
  bvh.build(topo.boundary_segments, m.positions);
  std::mt19937 rng(GetParam());
  std::uniform_real_distribution<double> u(-1.5, 1.5);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector2d p(u(rng), u(rng));
    double best = INFINITY;
    for (const auto& s : topo.boundary_segments)
      best = std::min(best, point_segment_distance(p, Eigen::Vector2d(m.positions.col(s[0])),
                                                   Eigen::Vector2d(m.positions.col(s[1])))
                                .sq_dist);
    EXPECT_EQ(bvh.nearest(p).sq_dist, best);
  }
}

TEST_P(BvhRandom, ForEachNearVisitsEveryFeatureWithinTheRadius) {
  const TetMesh m = test::ball_mesh(5, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  BoundaryBvh<3> bvh;
  bvh.build(topo.boundary_faces, m.positions);
  std::mt19937 rng(GetParam());
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const double r = 0.3;
    std::set<Index> seen;
    bvh.for_each_near(p, r, [&](Index s) { seen.insert(s); });
    for (std::size_t s = 0; s < topo.boundary_faces.size(); ++s) {
      const auto& f = topo.boundary_faces[s];
      const double d = point_triangle_distance(p, Eigen::Vector3d(m.positions.col(f[0])),
                                               Eigen::Vector3d(m.positions.col(f[1])),
                                               Eigen::Vector3d(m.positions.col(f[2])))
                           .sq_dist;
      if (d <= r * r) {
        EXPECT_TRUE(seen.count(static_cast<Index>(s))) << s;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, BvhRandom, ::testing::Values(11u, 12u, 13u));

TEST(Bvh, EmptyAndSingleFeature) {
  BoundaryBvh<3> bvh;
  Positions p(3, 3);
  p << 0, 1, 0, 0, 0, 1, 0, 0, 0;
  bvh.build({}, p);
  EXPECT_EQ(bvh.nearest(Eigen::Vector3d(1, 1, 1)).simplex, -1);
  const std::vector<std::array<Index, 3>> one = {{0, 1, 2}};
  bvh.build(one, p);
  const auto hit = bvh.nearest(Eigen::Vector3d(0.2, 0.2, 2.0));
  EXPECT_EQ(hit.simplex, 0);
  EXPECT_DOUBLE_EQ(hit.sq_dist, 4.0);
}

}  // namespace
}  // namespace tc
