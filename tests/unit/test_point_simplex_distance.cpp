// service/core/depth/point_simplex_distance: closest points on segments and
// triangles against dense sampling, known answers, locations, degenerate features,
// float against double.
#include "core/depth/point_simplex_distance.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>

namespace tc {
namespace {

using V3 = Eigen::Vector3d;
using V2 = Eigen::Vector2d;

// Smallest squared distance to a triangle sampled on a fine barycentric grid (an upper
// bound of the true distance, within the grid spacing).
double sampled_triangle_sq(const V3& p, const V3& a, const V3& b, const V3& c, int n) {
  double best = INFINITY;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const double u = double(i) / n, v = double(j) / n;
      best = std::min(best, (p - (a + u * (b - a) + v * (c - a))).squaredNorm());
    }
  return best;
}

TEST(PointTriangle, KnownRegions) {
  const V3 a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  struct Case {
    V3 p;
    double dist;
    FeatureLoc loc;
  };
  const Case cases[] = {
      {V3(0.5, 0.5, 3.0), 3.0, FeatureLoc::kInterior},
      {V3(0.5, 0.5, -1.5), 1.5, FeatureLoc::kInterior},
      {V3(-1, -1, 0), std::sqrt(2.0), FeatureLoc::kV0},
      {V3(3, -1, 0), std::sqrt(2.0), FeatureLoc::kV1},
      {V3(-1, 3, 1), std::sqrt(3.0), FeatureLoc::kV2},
      {V3(1, -2, 0), 2.0, FeatureLoc::kE01},
      {V3(2, 2, 0), std::sqrt(2.0), FeatureLoc::kE12},
      {V3(-3, 1, 4), 5.0, FeatureLoc::kE20},
      {V3(1, 0, 0), 0.0, FeatureLoc::kE01},  // exactly on an edge
      {V3(0, 0, 0), 0.0, FeatureLoc::kV0},   // exactly on a vertex
  };
  for (const Case& k : cases) {
    const FeatureDistance d = point_triangle_distance(k.p, a, b, c);
    EXPECT_NEAR(std::sqrt(d.sq_dist), k.dist, 1e-12) << k.p.transpose();
    EXPECT_EQ(d.loc, k.loc) << k.p.transpose();
  }
}

class PointTriangleRandom : public ::testing::TestWithParam<unsigned> {};

TEST_P(PointTriangleRandom, MatchesDenseSamplingAndClosestPointLiesOnTheTriangle) {
  std::mt19937 rng(GetParam());
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const V3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    const V3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const auto q = closest_point_triangle(p, a, b, c);
    const double d = (p - q.point).squaredNorm();
    EXPECT_EQ(d, point_triangle_distance(p, a, b, c).sq_dist);
    const double sampled = sampled_triangle_sq(p, a, b, c, 200);
    // Sampled points lie on the triangle: never nearer than the true distance.
    EXPECT_LE(d, sampled + 1e-12);
    EXPECT_NEAR(std::sqrt(d), std::sqrt(sampled), 0.02);
    // The closest point lies in the triangle's plane, inside it.
    const V3 n = (b - a).cross(c - a);
    EXPECT_NEAR(n.dot(q.point - a), 0.0, 1e-9 * n.norm());
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, PointTriangleRandom, ::testing::Values(1u, 2u, 3u, 4u));

TEST(PointTriangle, DegenerateTrianglesGiveTheSegmentOrPointDistance) {
  const V3 p(0.3, 1.0, 0.5);
  // Collinear: the distance to the segment it spans.
  const V3 a(0, 0, 0), b(1, 0, 0), c(2, 0, 0);
  EXPECT_NEAR(point_triangle_distance(p, a, b, c).sq_dist, point_segment_distance(p, a, c).sq_dist,
              1e-15);
  // Two coincident vertices, and all three coincident.
  EXPECT_NEAR(point_triangle_distance(p, a, a, c).sq_dist, point_segment_distance(p, a, c).sq_dist,
              1e-15);
  EXPECT_NEAR(point_triangle_distance(p, b, b, b).sq_dist, (p - b).squaredNorm(), 1e-15);
  // A hair away from degenerate: still finite and close to the segment distance.
  const V3 c_eps(2, 1e-12, 0);
  const double d = point_triangle_distance(p, a, b, c_eps).sq_dist;
  EXPECT_TRUE(std::isfinite(d));
  EXPECT_NEAR(d, point_segment_distance(p, a, c).sq_dist, 1e-9);
}

TEST(PointTriangle, FloatAgreesWithDouble) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Vector3f a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)),
        c(u(rng), u(rng), u(rng)), p(u(rng), u(rng), u(rng));
    const float f = point_triangle_distance(p, a, b, c).sq_dist;
    const double d = point_triangle_distance(V3(p.cast<double>()), V3(a.cast<double>()),
                                             V3(b.cast<double>()), V3(c.cast<double>()))
                         .sq_dist;
    EXPECT_NEAR(std::sqrt(f), std::sqrt(d), 1e-5);
  }
}

TEST(PointSegment, KnownAnswersIn2dAnd3d) {
  const V2 a(0, 0), b(4, 0);
  EXPECT_EQ(point_segment_distance(V2(2, 3), a, b).sq_dist, 9.0);
  EXPECT_EQ(point_segment_distance(V2(2, 3), a, b).loc, FeatureLoc::kE01);
  EXPECT_EQ(point_segment_distance(V2(-3, 4), a, b).sq_dist, 25.0);
  EXPECT_EQ(point_segment_distance(V2(-3, 4), a, b).loc, FeatureLoc::kV0);
  EXPECT_EQ(point_segment_distance(V2(7, 4), a, b).loc, FeatureLoc::kV1);
  // Zero-length segment: the point distance, no NaN.
  const auto z = point_segment_distance(V3(1, 2, 2), V3(0, 0, 0), V3(0, 0, 0));
  EXPECT_EQ(z.sq_dist, 9.0);
  EXPECT_EQ(closest_point_segment(V2(2, 3), a, b).point, V2(2, 0));
}

}  // namespace
}  // namespace tc
