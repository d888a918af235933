// service/core/response/tet_frame: barycentric coordinates and linear gradients, checked
// against the signed-volume formula and analytic linear fields; the paper's printed
// formulas are shown to be wrong on the same inputs.
#include "core/response/tet_frame.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <random>

#include "response_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Vec3 = Eigen::Vector3d;

std::array<Vec3, 4> random_tet(std::mt19937& rng, double scale, const Vec3& offset) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::array<Vec3, 4> x;
  do {
    for (auto& p : x) p = offset + scale * Vec3(u(rng), u(rng), u(rng));
  } while (std::abs(signed_volume(x[0], x[1], x[2], x[3])) < 0.01 * scale * scale * scale);
  return x;
}

TEST(TetFrame, UnitTetKnownAnswer) {
  const TetFrame f = make_tet_frame({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  ASSERT_TRUE(f.regular);
  EXPECT_NEAR(f.volume6,
              6.0 * signed_volume(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)),
              1e-15);
  EXPECT_GT(f.volume6, 0.0);
  const Eigen::Vector4d b = barycentric(f, {0.1, 0.2, 0.3});
  EXPECT_NEAR(b[0], 0.4, 1e-15);
  EXPECT_NEAR(b[1], 0.1, 1e-15);
  EXPECT_NEAR(b[2], 0.2, 1e-15);
  EXPECT_NEAR(b[3], 0.3, 1e-15);
  // d = x + 2y + 3z at the nodes: (0, 1, 2, 3).
  const Vec3 g = linear_gradient(f, {0.0, 1.0, 2.0, 3.0});
  EXPECT_NEAR((g - Vec3(1, 2, 3)).norm(), 0.0, 1e-14);
}

struct FrameCase {
  double scale;
  double offset;
};

class TetFrameSweep : public ::testing::TestWithParam<FrameCase> {};

TEST_P(TetFrameSweep, BarycentricMatchesVolumesAndReconstructsThePoint) {
  const auto [scale, offset] = GetParam();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const auto x = random_tet(rng, scale, Vec3::Constant(offset));
    const TetFrame f = make_tet_frame(x[0], x[1], x[2], x[3]);
    ASSERT_TRUE(f.regular);
    Eigen::Vector4d w(u(rng), u(rng), u(rng), u(rng));
    w /= w.sum();
    const Vec3 p = w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
    const Eigen::Vector4d b = barycentric(f, p);
    // Offsets of 1e6 leave ~1e-10 of relative precision on the differences.
    const double tol = 1e-9 * (1.0 + std::abs(offset) / scale);
    EXPECT_NEAR((b - w).norm(), 0.0, tol);
    EXPECT_NEAR((b - test::bary_by_volumes(x, p)).norm(), 0.0, tol);
    EXPECT_NEAR(b.sum(), 1.0, 1e-12);
  }
}

TEST_P(TetFrameSweep, GradientOfSampledLinearFieldIsExact) {
  const auto [scale, offset] = GetParam();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    auto x = random_tet(rng, scale, Vec3::Constant(offset));
    if (trial % 2) std::swap(x[0], x[1]);  // inverted orientation works the same
    const Vec3 v(u(rng), u(rng), u(rng));
    const double c = u(rng) * scale;
    Eigen::Vector4d d;
    // Sample relative to the centroid so the values do not lose precision to the offset.
    const Vec3 centre = 0.25 * (x[0] + x[1] + x[2] + x[3]);
    for (int k = 0; k < 4; ++k) d[k] = c + v.dot(x[k] - centre);
    const TetFrame f = make_tet_frame(x[0], x[1], x[2], x[3]);
    ASSERT_TRUE(f.regular);
    EXPECT_NEAR((linear_gradient(f, d) - v).norm(), 0.0, 1e-8 * (1.0 + v.norm()));
    // The barycentric gradients are the dual basis of the edges: grad b_k . (x_j - x_m)
    // = delta_kj - delta_km.
    const auto grads = barycentric_gradients(f);
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 4; ++j) EXPECT_NEAR(grads[k].dot(x[j] - x[3]), (k == j) - (k == 3), 1e-8);
  }
}

INSTANTIATE_TEST_SUITE_P(ScalesAndOffsets, TetFrameSweep,
                         ::testing::Values(FrameCase{1.0, 0.0}, FrameCase{1e-6, 0.0},
                                           FrameCase{1.0, 1e6}, FrameCase{1e-3, 1e3},
                                           FrameCase{1e3, -5.0}));

TEST(TetFrame, PaperPrintedFormulasAreNotTheFrame) {
  // Section 5.1 prints G = [p - x1, p - x2, p - x3] and grad d = G^-1 (u1 - u4, ...).
  // On a generic tet, the first does not give coordinates that reconstruct p, the second
  // does not give the gradient of the interpolated depth.
  const std::array<Vec3, 4> x = {Vec3(0.1, 0, 0), Vec3(1.2, 0.1, 0), Vec3(0.3, 1.1, 0.2),
                                 Vec3(0.2, 0.3, 0.9)};
  const Vec3 p = 0.1 * x[0] + 0.2 * x[1] + 0.3 * x[2] + 0.4 * x[3];
  Eigen::Matrix3d paper_g;
  paper_g << p - x[0], p - x[1], p - x[2];
  const Vec3 u_paper = paper_g.inverse() * (p - x[3]);
  const Vec3 rebuilt =
      x[3] + u_paper[0] * (x[0] - x[3]) + u_paper[1] * (x[1] - x[3]) + u_paper[2] * (x[2] - x[3]);
  EXPECT_GT((rebuilt - p).norm(), 1e-3);

  const TetFrame f = make_tet_frame(x[0], x[1], x[2], x[3]);
  const Eigen::Vector4d b = barycentric(f, p);
  const Vec3 rebuilt_ok = b[0] * x[0] + b[1] * x[1] + b[2] * x[2] + b[3] * x[3];
  EXPECT_NEAR((rebuilt_ok - p).norm(), 0.0, 1e-14);

  const Vec3 v(0.3, -0.5, 0.8);
  Eigen::Vector4d d;
  for (int k = 0; k < 4; ++k) d[k] = v.dot(x[k]);
  // The untransposed inverse applied to the node-value differences:
  const Vec3 delta(d[0] - d[3], d[1] - d[3], d[2] - d[3]);
  EXPECT_GT((f.inverse * delta - v).norm(), 1e-3);
  EXPECT_NEAR((linear_gradient(f, d) - v).norm(), 0.0, 1e-13);
}

TEST(TetFrame, FlatCollapsedAndNonFiniteTetsAreNotRegular) {
  const Vec3 o(0, 0, 0), ex(1, 0, 0), ey(0, 1, 0);
  // Coplanar.
  TetFrame f = make_tet_frame(o, ex, ey, Vec3(0.3, 0.3, 0.0));
  EXPECT_FALSE(f.regular);
  EXPECT_TRUE(f.inverse.isZero());
  // A hair off the plane, below the quality threshold.
  f = make_tet_frame(o, ex, ey, Vec3(0.3, 0.3, 1e-12));
  EXPECT_FALSE(f.regular);
  // Just above it: regular, and exact on a linear field.
  f = make_tet_frame(o, ex, ey, Vec3(0.3, 0.3, 1e-8));
  EXPECT_TRUE(f.regular);
  // All nodes equal.
  f = make_tet_frame(o, o, o, o);
  EXPECT_FALSE(f.regular);
  EXPECT_EQ(f.quality, 0.0);
  // NaN.
  f = make_tet_frame(o, ex, ey, Vec3(0, 0, std::nan("")));
  EXPECT_FALSE(f.regular);
  EXPECT_TRUE(f.inverse.allFinite());
}

TEST(TetFrame, QualityIsScaleAndOffsetFree) {
  const auto x = test::tet_points(test::single_tet().positions, {0, 1, 2, 3});
  const TetFrame ref = make_tet_frame(x[0], x[1], x[2], x[3]);
  const std::array<std::pair<double, double>, 6> cases = {
      {{1e-6, 0.0}, {1e-3, 0.0}, {1e3, 0.0}, {1.0, 1e6}, {1e3, 1e6}, {1e-6, 1.0}}};
  for (const auto& [s, off] : cases) {
    const Vec3 o = Vec3::Constant(off);
    const TetFrame f = make_tet_frame(s * x[0] + o, s * x[1] + o, s * x[2] + o, s * x[3] + o);
    EXPECT_TRUE(f.regular);
    EXPECT_NEAR(f.quality, ref.quality, 1e-12 * (1.0 + off / s)) << s << " " << off;
  }
}

}  // namespace
}  // namespace tc
