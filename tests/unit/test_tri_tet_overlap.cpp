// service/core/detect/tri_tet_overlap: exact triangle-tet overlap. Checked against an
// independent brute-force oracle (the penetration depth is the distance from the origin to
// the boundary of the Minkowski difference tet - triangle, found here by enumerating the
// facets of the hull of the 12 corner differences), against sampled clearance, on touching,
// coplanar and degenerate contacts at several scales and offsets, and on non-finite input.
#include "core/detect/tri_tet_overlap.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <tuple>

#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kRel = 1e-9;  // relative tolerance, as detection uses by default

TetCorners unit_tet() {
  return {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0), Vector3d(0, 0, 1)};
}

bool overlap(const TriangleCorners& t, const TetCorners& k) {
  return triangle_tet_overlap(t, k, kRel * pair_scale(t, k));
}

// ------------------------------------------------------------------ independent oracle

/// Penetration depth from the hull of the differences k_j - t_i (the Minkowski difference
/// K - T, which holds the origin exactly when the two meet): the smallest support value
/// over its facets, positive when the origin is inside (then it is the depth), <= 0 when
/// outside or on the boundary. Facets are found by brute force: every plane through three
/// of the 12 points with all 12 on one side. A flat hull (coplanar contact) gives 0.
double hull_depth(const TriangleCorners& t, const TetCorners& k) {
  // Plain arrays: this runs 2,700 x 220 planes, also under ASan at -O1.
  double p[12][3];
  double size = 0.0;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 3; ++i)
      for (int d = 0; d < 3; ++d) {
        p[3 * j + i][d] = k[j][d] - t[i][d];
        size = std::max(size, std::abs(p[3 * j + i][d]));
      }
  const double eps = 1e-12 * size;
  double best = std::numeric_limits<double>::infinity();
  bool any = false;
  for (int a = 0; a < 12; ++a)
    for (int b = a + 1; b < 12; ++b)
      for (int c = b + 1; c < 12; ++c) {
        const double u[3] = {p[b][0] - p[a][0], p[b][1] - p[a][1], p[b][2] - p[a][2]};
        const double v[3] = {p[c][0] - p[a][0], p[c][1] - p[a][1], p[c][2] - p[a][2]};
        double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
        const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (len <= 1e-10 * size * size) continue;
        for (double& x : n) x /= len;
        double hi = -std::numeric_limits<double>::infinity();
        double lo = std::numeric_limits<double>::infinity();
        for (int q = 0; q < 12 && !(hi > eps && lo < -eps); ++q) {
          const double s =
              n[0] * (p[q][0] - p[a][0]) + n[1] * (p[q][1] - p[a][1]) + n[2] * (p[q][2] - p[a][2]);
          hi = std::max(hi, s);
          lo = std::min(lo, s);
        }
        const double offset = n[0] * p[a][0] + n[1] * p[a][1] + n[2] * p[a][2];
        // All on the negative side: outward normal n; on the positive side: -n.
        if (hi <= eps) {
          best = std::min(best, offset);
          any = true;
        }
        if (lo >= -eps) {
          best = std::min(best, -offset);
          any = true;
        }
      }
  return any ? best : 0.0;
}

/// Signed clearance of x inside tet k (min distance to its face planes, positive inside).
double clearance(const Vector3d& x, const TetCorners& k) {
  double best = std::numeric_limits<double>::infinity();
  for (int f = 0; f < 4; ++f) {
    const Vector3d& a = k[(f + 1) % 4];
    const Vector3d& b = k[(f + 2) % 4];
    const Vector3d& c = k[(f + 3) % 4];
    Vector3d n = (b - a).cross(c - a).normalized();
    if (n.dot(k[f] - a) < 0.0) n = -n;
    best = std::min(best, n.dot(x - a));
  }
  return best;
}

/// Largest clearance over a barycentric lattice of the triangle: a lower bound of the
/// penetration depth (the triangle must move at least that far to clear the tet).
double sampled_depth(const TriangleCorners& t, const TetCorners& k, int n = 16) {
  Vector3d normal[4], origin[4];
  for (int f = 0; f < 4; ++f) {
    origin[f] = k[(f + 1) % 4];
    normal[f] = (k[(f + 2) % 4] - origin[f]).cross(k[(f + 3) % 4] - origin[f]).normalized();
    if (normal[f].dot(k[f] - origin[f]) < 0.0) normal[f] = -normal[f];
  }
  double best = -std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const Vector3d x = (i * t[0] + j * t[1] + (n - i - j) * t[2]) / n;
      double c = std::numeric_limits<double>::infinity();
      for (int f = 0; f < 4; ++f) c = std::min(c, normal[f].dot(x - origin[f]));
      best = std::max(best, c);
    }
  return best;
}

TetCorners random_tet(std::mt19937& rng, double min_quality) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (;;) {
    TetCorners k;
    for (auto& p : k) p = Vector3d(u(rng), u(rng), u(rng));
    if (signed_volume(k[0], k[1], k[2], k[3]) < 0) std::swap(k[2], k[3]);
    Positions p(3, 4);
    for (int i = 0; i < 4; ++i) p.col(i) = k[i];
    if (tet_quality(p, Tet{0, 1, 2, 3}) >= min_quality) return k;
  }
}

/// A random triangle around the centroid of `k`, shifted by up to 0.35 per axis.
TriangleCorners random_triangle(std::mt19937& rng, const TetCorners& k) {
  std::uniform_real_distribution<double> u(-0.35, 0.35), size(0.1, 1.0);
  const Vector3d c = 0.25 * (k[0] + k[1] + k[2] + k[3]) + Vector3d(u(rng), u(rng), u(rng));
  const double s = size(rng);
  std::uniform_real_distribution<double> d(-1.0, 1.0);
  return {c + s * Vector3d(d(rng), d(rng), d(rng)), c + s * Vector3d(d(rng), d(rng), d(rng)),
          c + s * Vector3d(d(rng), d(rng), d(rng))};
}

// ------------------------------------------------------------------- random vs oracles

TEST(TriTetOverlap, RandomPairsAgreeWithTheHullOracle) {
  std::mt19937 rng(19);
  int overlapping = 0, disjoint = 0;
  for (int iter = 0; iter < 1000; ++iter) {
    const TetCorners k = random_tet(rng, 0.05);
    const TriangleCorners t = random_triangle(rng, k);
    const double depth = hull_depth(t, k);
    const double pen = triangle_tet_penetration(t, k);
    const double scale = pair_scale(t, k);
    // Never below what sampling proves, and the exact depth when they overlap.
    const double sampled = sampled_depth(t, k);
    if (sampled > 0.0) {
      EXPECT_GE(pen, sampled - 1e-12) << "iteration " << iter;
    }
    if (depth > 1e-9) {
      ++overlapping;
      EXPECT_NEAR(pen, depth, 1e-9 * scale) << "iteration " << iter;
      EXPECT_TRUE(overlap(t, k)) << "iteration " << iter;
    } else if (depth < -1e-9) {
      ++disjoint;
      EXPECT_LE(pen, 0.0) << "iteration " << iter;
      EXPECT_FALSE(overlap(t, k)) << "iteration " << iter;
    }
    for (const double tol : {0.0, 1e-9 * scale, 1e-3 * scale})
      EXPECT_EQ(triangle_tet_overlap(t, k, tol), pen > tol) << "iteration " << iter;
  }
  EXPECT_GT(overlapping, 250);
  EXPECT_GT(disjoint, 500);
}

TEST(TriTetOverlap, DegenerateTrianglesAndFlatTetsAgreeWithTheHullOracle) {
  std::mt19937 rng(2004);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int overlapping = 0, disjoint = 0;
  for (int iter = 0; iter < 1200; ++iter) {
    TetCorners k = random_tet(rng, 0.05);
    TriangleCorners t = random_triangle(rng, k);
    const int kind = iter % 6;
    if (kind == 0) t[2] = t[0] + u(rng) * (t[1] - t[0]);  // collinear: a segment
    if (kind == 1) t[1] = t[2] = t[0];                    // a point
    if (kind == 2) t[2] = t[0] + 0.5 * (t[1] - t[0]) + 1e-10 * Vector3d(u(rng), u(rng), u(rng));
    if (kind == 3) k[3] = k[0] + u(rng) * (k[1] - k[0]) + u(rng) * (k[2] - k[0]);  // flat tet
    if (kind == 4) {  // flat tet and a segment
      k[3] = k[0] + 0.3 * (k[1] - k[0]) + 0.4 * (k[2] - k[0]);
      t[2] = t[1];
    }
    if (kind == 5) k[1] = k[0] + 1e-9 * (k[1] - k[0]);  // a sliver with a tiny edge
    const double depth = hull_depth(t, k);
    const double pen = triangle_tet_penetration(t, k);
    const double scale = pair_scale(t, k);
    ASSERT_FALSE(std::isnan(pen)) << "iteration " << iter;
    if (depth > 1e-6 * scale) {
      ++overlapping;
      EXPECT_TRUE(overlap(t, k)) << "iteration " << iter << " kind " << kind;
      EXPECT_NEAR(pen, depth, 1e-7 * scale) << "iteration " << iter << " kind " << kind;
    } else if (depth < -1e-6 * scale) {
      ++disjoint;
      EXPECT_FALSE(overlap(t, k)) << "iteration " << iter << " kind " << kind;
    }
    // A point inside a tet must move by its clearance (the nearest face plane) to get out.
    if (kind == 1) {
      const double c = clearance(t[0], k);
      if (c > 0.0) {
        EXPECT_NEAR(pen, c, 1e-12 * scale) << "iteration " << iter;
      } else {
        EXPECT_LE(pen, 1e-12 * scale) << "iteration " << iter;
      }
    }
  }
  EXPECT_GT(overlapping, 100);
  EXPECT_GT(disjoint, 300);
}

// ------------------------------------------------------------- contacts, frame by frame

/// (scale, offset) frames with exact dyadic arithmetic, as in test_tet_overlap.
using Frame = std::tuple<double, double>;

class TriTetContacts : public ::testing::TestWithParam<Frame> {
 protected:
  [[nodiscard]] Vector3d at(double x, double y, double z) const {
    const auto [scale, offset] = GetParam();
    return Vector3d(x, y, z) * scale + Vector3d::Constant(offset);
  }
  [[nodiscard]] TetCorners tet() const {
    return {at(0, 0, 0), at(1, 0, 0), at(0, 1, 0), at(0, 0, 1)};
  }
  [[nodiscard]] TriangleCorners tri(const Vector3d& a, const Vector3d& b, const Vector3d& c,
                                    const Vector3d& push = Vector3d::Zero()) const {
    return {at(a.x() + push.x(), a.y() + push.y(), a.z() + push.z()),
            at(b.x() + push.x(), b.y() + push.y(), b.z() + push.z()),
            at(c.x() + push.x(), c.y() + push.y(), c.z() + push.z())};
  }
};

constexpr double kPush = 1.0 / 1024;  // far above the tolerance, exact in binary

TEST_P(TriTetContacts, InAFaceTouchesAndPushedInOverlaps) {
  const Vector3d a(0.125, 0.125, 0), b(0.5, 0.125, 0), c(0.125, 0.5, 0);
  EXPECT_FALSE(overlap(tri(a, b, c), tet()));
  EXPECT_TRUE(overlap(tri(a, b, c, {0, 0, kPush}), tet()));
  EXPECT_FALSE(overlap(tri(a, b, c, {0, 0, -kPush}), tet()));
  // Coplanar with the face but sticking out of it: still touching only.
  const Vector3d d(-0.5, 0.25, 0), e(0.75, 0.25, 0), f(0.25, -0.5, 0);
  EXPECT_FALSE(overlap(tri(d, e, f), tet()));
  EXPECT_TRUE(overlap(tri(d, e, f, {0, 0, kPush}), tet()));
  // The same on the slanted face x + y + z = 1, pushed along -(1, 1, 1).
  const Vector3d g(0.5, 0.25, 0.25), h(0.25, 0.5, 0.25), i(0.25, 0.25, 0.5);
  EXPECT_FALSE(overlap(tri(g, h, i), tet()));
  EXPECT_TRUE(overlap(tri(g, h, i, Vector3d::Constant(-kPush)), tet()));
}

TEST_P(TriTetContacts, AlongAnEdgeTouchesAndPushedInOverlaps) {
  // In the plane y + z = 0, which meets the tet only along its edge on the x axis.
  const Vector3d a(0.5, 1, -1), b(0.5, -1, 1), c(-1, 0, 0);
  EXPECT_FALSE(overlap(tri(a, b, c), tet()));
  EXPECT_TRUE(overlap(tri(a, b, c, {0, kPush, kPush}), tet()));
  EXPECT_FALSE(overlap(tri(a, b, c, {0, -kPush, -kPush}), tet()));
  // Crossing the edge (0,0,0)-(0,0,1) at one point from outside: edge-edge touching.
  const Vector3d d(-1, 1, 0.5), e(1, -1, 0.5), f(-1, -1, 0.5);
  EXPECT_FALSE(overlap(tri(d, e, f), tet()));
  EXPECT_TRUE(overlap(tri(d, e, f, {kPush, kPush, 0}), tet()));
}

TEST_P(TriTetContacts, CornerOnACornerTouchesAndPokedInOverlaps) {
  const Vector3d a(1, 0, 0), b(3, 1, -1), c(3, -1, 1);
  EXPECT_FALSE(overlap(tri(a, b, c), tet()));
  const Vector3d in(1 - kPush, kPush / 4, kPush / 4);
  EXPECT_TRUE(overlap(tri(in, b, c), tet()));
  EXPECT_GE(triangle_tet_penetration(tri(in, b, c), tet()),
            std::get<0>(GetParam()) * kPush / 4 * (1 - 1e-6));
}

TEST_P(TriTetContacts, SlicingTheTetOverlapsByItsDepth) {
  // The plane z = 1/4 cuts the tet; the triangle covers the whole cut. To clear the tet it
  // must move up by 3/4 or down by 1/4, or sideways out of the cut: min = 1/4.
  const Vector3d a(-2, -2, 0.25), b(4, -2, 0.25), c(-2, 4, 0.25);
  EXPECT_TRUE(overlap(tri(a, b, c), tet()));
  EXPECT_NEAR(triangle_tet_penetration(tri(a, b, c), tet()), 0.25 * std::get<0>(GetParam()),
              1e-9 * std::get<0>(GetParam()));
}

TEST_P(TriTetContacts, DegenerateTrianglesInsideOverlapOnTheBoundaryDoNot) {
  const Vector3d p(0.125, 0.125, 0.125), q(0.25, 0.25, 0.25);
  EXPECT_TRUE(overlap(tri(p, p, p), tet()));              // a point inside
  EXPECT_TRUE(overlap(tri(p, q, 0.5 * (p + q)), tet()));  // a segment inside
  const Vector3d f0(0.25, 0.25, 0), f1(0.5, 0.25, 0), e0(0.25, 0, 0), e1(0.75, 0, 0);
  EXPECT_FALSE(overlap(tri(f0, f0, f0), tet()));  // a point on a face
  EXPECT_FALSE(overlap(tri(f0, f1, f1), tet()));  // a segment in a face
  EXPECT_FALSE(overlap(tri(e0, e1, e1), tet()));  // a segment along an edge
  EXPECT_FALSE(overlap(tri(e0, e0, e0, {0, -kPush, 0}), tet()));
  // A segment through the tet from outside to outside.
  const Vector3d s0(-1, 0.25, 0.25), s1(2, 0.25, 0.25);
  EXPECT_TRUE(overlap(tri(s0, s1, s1), tet()));
}

INSTANTIATE_TEST_SUITE_P(TriTetOverlap, TriTetContacts,
                         ::testing::Values(Frame{1.0, 0.0}, Frame{1.0 / 1048576, 0.0},
                                           Frame{1.0, 1048576.0}, Frame{1.0 / 1048576, 1.0 / 64}));

TEST(TriTetOverlap, NonFiniteCornersNeverOverlapAndNeverNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const TriangleCorners inside = {Vector3d(0.1, 0.1, 0.1), Vector3d(0.2, 0.1, 0.1),
                                  Vector3d(0.1, 0.2, 0.1)};
  ASSERT_TRUE(overlap(inside, unit_tet()));
  for (const double bad : {nan, inf, -inf}) {
    for (int c = 0; c < 3; ++c) {
      TriangleCorners t = inside;
      t[c].y() = bad;
      EXPECT_FALSE(triangle_tet_overlap(t, unit_tet(), 0.0));
      EXPECT_FALSE(std::isnan(triangle_tet_penetration(t, unit_tet())));
    }
    for (int c = 0; c < 4; ++c) {
      TetCorners k = unit_tet();
      k[c].z() = bad;
      EXPECT_FALSE(triangle_tet_overlap(inside, k, 0.0));
      EXPECT_FALSE(std::isnan(triangle_tet_penetration(inside, k)));
    }
  }
}

}  // namespace
}  // namespace tc
