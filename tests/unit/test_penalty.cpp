// service/core/response/penalty: single point and segment contacts. Known answers,
// zero net force and moment, the segment transfer against a quadrature of the
// distributed load (and the paper's swapped weights failing it), finite differences of
// the stiffness blocks, the degenerate-gradient fallbacks, and extreme sweeps.
#include "core/response/penalty.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include <string>

#include "core/response/tet_frame.hpp"
#include "response_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

// Most tests here check the paper's interpolation formulas on depth fields written by
// hand: test::paper().
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using test::paper;
using test::TestObject;

/// One contact: an intruder tet X (node 0, or edge (0, 1) = edge index 0, is the
/// intruding feature) and a one-tet target Y.
struct Single {
  TestObject x;
  TestObject y;
};

Single make_single(const std::array<Vec3, 4>& intruder, const std::array<Vec3, 4>& target) {
  return {TestObject(test::mesh_from({intruder.begin(), intruder.end()}, {{0, 1, 2, 3}})),
          TestObject(test::mesh_from({target.begin(), target.end()}, {{0, 1, 2, 3}}))};
}

std::array<Vec3, 4> target_points(const Single& s) {
  return test::tet_points(s.y.mesh.positions, s.y.mesh.tets[0]);
}

ContactResult eval_point(const Single& s, const ResponseOptions& o,
                         const Vec3& pair_dir = Vec3::Zero()) {
  const Vec3 p = s.x.mesh.positions.col(0);
  const IntrudingNode c{0, 0, test::bary_by_volumes(target_points(s), p)};
  return point_contact(s.x.view(), s.y.view(), c, o, pair_dir);
}

ContactResult eval_segment(const Single& s, const ResponseOptions& o) {
  const auto clip =
      test::clip_segment(target_points(s), s.x.mesh.positions.col(0), s.x.mesh.positions.col(1));
  if (!clip) return {};
  return segment_contact(s.x.view(), s.y.view(), {0, 0, clip->first, clip->second}, o,
                         Vec3::Zero());
}

/// Position of result entry i: X's nodes first, then Y's.
Vec3 entry_position(const Single& s, const ContactResult& r, int i) {
  return i < r.intruder_nodes ? Vec3(s.x.mesh.positions.col(r.node[i]))
                              : Vec3(s.y.mesh.positions.col(r.node[i]));
}

int entries(const ContactResult& r) {
  return r.intruder_nodes + r.target_nodes;
}

/// A random well-shaped tet of size ~scale around centre.
std::array<Vec3, 4> random_tet(std::mt19937& rng, double scale, const Vec3& centre) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::array<Vec3, 4> x;
  for (;;) {
    for (auto& p : x) p = centre + scale * Vec3(u(rng), u(rng), u(rng));
    const TetFrame f = make_tet_frame(x[0], x[1], x[2], x[3]);
    if (f.quality > 0.2) return x;  // positively oriented, not a sliver
  }
}

Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

/// A random contact configuration with a linear depth d(x) = c + v.(x - centre) that is
/// positive on the target's nodes, |v| = 1 (a distance-like field).
struct RandomCase {
  Single s;
  Vec3 v;
  double c;
  Vec3 centre;
  [[nodiscard]] double depth_at(const Vec3& x) const { return c + v.dot(x - centre); }
};

RandomCase random_case(std::mt19937& rng, bool segment, double scale = 1.0,
                       const Vec3& centre = Vec3::Zero()) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (;;) {
    const auto target = random_tet(rng, scale, centre);
    Eigen::Vector4d w(u(rng) + 0.05, u(rng) + 0.05, u(rng) + 0.05, u(rng) + 0.05);
    w /= w.sum();
    const Vec3 q = w[0] * target[0] + w[1] * target[1] + w[2] * target[2] + w[3] * target[3];
    std::array<Vec3, 4> intruder;
    if (segment) {
      const Vec3 dir = random_unit(rng);
      intruder[0] = q - scale * (0.2 + 2.0 * u(rng)) * dir;
      intruder[1] = q + scale * (0.2 + 2.0 * u(rng)) * dir;
    } else {
      intruder[0] = q;
      intruder[1] = q + scale * Vec3(2.0, 0.3, 0.1);
    }
    intruder[2] = q + scale * Vec3(0.2, 2.1, 0.4);
    intruder[3] = q + scale * Vec3(0.3, 0.2, 2.2);
    RandomCase rc{make_single(intruder, target), random_unit(rng), 0.0, centre};
    double min_dot = 1e300;
    for (const Vec3& p : target) min_dot = std::min(min_dot, rc.v.dot(p - centre));
    rc.c = -min_dot + scale * (0.05 + 0.5 * u(rng));
    rc.s.y.set_depth([&](const Vec3& x) { return rc.depth_at(x); });
    return rc;
  }
}

TEST(PointContact, KnownAnswer) {
  // Target: the unit tet with depth 0.5 - 0.2 x + 0.1 y - 0.3 z; intruding node p.
  const Vec3 p(0.2, 0.15, 0.25);
  Single s = make_single({p, Vec3(2, 0.1, 0.1), Vec3(0.1, 2, 0.2), Vec3(0.3, 0.2, 2)},
                         {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  const Vec3 v(-0.2, 0.1, -0.3);
  s.y.set_depth([&](const Vec3& x) { return 0.5 + v.dot(x); });
  ResponseOptions o = paper();
  o.stiffness = 1e3;
  for (const ForceMeasure m : {ForceMeasure::kEdgeLength, ForceMeasure::kUnit}) {
    o.measure = m;
    const ContactResult r = eval_point(s, o);
    ASSERT_TRUE(r.active);
    EXPECT_EQ(r.fallback, Fallback::kNone);
    double w = 1.0;
    if (m == ForceMeasure::kEdgeLength) {
      w = 0.0;
      for (int k = 1; k < 4; ++k) w += 0.5 * (s.x.mesh.positions.col(k) - p).norm();
    }
    const Vec3 n = -v.normalized();
    const Vec3 expected = 1e3 * w * (0.5 + v.dot(p)) * n;
    EXPECT_NEAR((r.force[0] - expected).norm(), 0.0, 1e-12 * expected.norm());
    EXPECT_NEAR((r.normal - n).norm(), 0.0, 1e-14);
    const Eigen::Vector4d b(1 - p.sum(), p.x(), p.y(), p.z());
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR((r.force[1 + k] + b[k] * expected).norm(), 0.0, 1e-12 * expected.norm());
  }
  EXPECT_NEAR(
      node_length_weight(s.x.view(), 0),
      0.5 * ((s.x.mesh.positions.col(1) - p).norm() + (s.x.mesh.positions.col(2) - p).norm() +
             (s.x.mesh.positions.col(3) - p).norm()),
      1e-15);
}

class ContactBalance : public ::testing::TestWithParam<std::tuple<bool, double, double>> {};

TEST_P(ContactBalance, ZeroNetForceAndMoment) {
  const auto [segment, scale, offset] = GetParam();
  std::mt19937 rng(1234);
  int active = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const RandomCase rc = random_case(rng, segment, scale, Vec3::Constant(offset));
    ResponseOptions o = paper();
    o.stiffness = 1e5;
    const ContactResult r = segment ? eval_segment(rc.s, o) : eval_point(rc.s, o);
    if (!r.active) continue;
    ++active;
    Vec3 total = Vec3::Zero(), moment = Vec3::Zero();
    double fmax = 0.0;
    const Vec3 origin = Vec3::Constant(offset) + scale * Vec3(0.3, -0.7, 0.2);
    for (int i = 0; i < entries(r); ++i) {
      total += r.force[i];
      moment += (entry_position(rc.s, r, i) - origin).cross(r.force[i]);
      fmax = std::max(fmax, r.force[i].norm());
    }
    EXPECT_LE(total.norm(), 1e-12 * fmax) << trial;
    // Offsets cost precision on the lever arms: positions carry ~1e-16 * offset.
    EXPECT_LE(moment.norm(), 1e-11 * fmax * (scale + 1e-4 * offset)) << trial;
  }
  EXPECT_GT(active, 50);
}

INSTANTIATE_TEST_SUITE_P(PointAndSegment, ContactBalance,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(1.0, 1e-6),
                                            ::testing::Values(0.0, 1e6)));

TEST(SegmentContact, TransferIsTheShapeFunctionIntegralAndBalancesMoments) {
  // Three-point Gauss-Legendre on [l1, l2] integrates the quadratic and cubic
  // integrands below exactly.
  const double gx[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
  std::mt19937 rng(99);
  int asymmetric = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const RandomCase rc = random_case(rng, true);
    ResponseOptions o = paper();
    o.stiffness = 1e4;
    const Vec3 a = rc.s.x.mesh.positions.col(0), b = rc.s.x.mesh.positions.col(1);
    const auto tp = target_points(rc.s);
    const auto clip = test::clip_segment(tp, a, b);
    if (!clip) continue;
    const ContactResult r = eval_segment(rc.s, o);
    ASSERT_TRUE(r.active);
    const auto [l1, l2] = *clip;
    const Vec3 n = -rc.v;  // |v| = 1
    const double ell = (b - a).norm();
    Vec3 fa = Vec3::Zero(), fb = Vec3::Zero(), moment = Vec3::Zero();
    std::array<Vec3, 4> reaction;
    reaction.fill(Vec3::Zero());
    const Vec3 origin(0.4, 0.1, -0.3);
    for (int q = 0; q < 3; ++q) {
      const double lambda = 0.5 * (l1 + l2) + 0.5 * (l2 - l1) * gx[q];
      const double weight = 0.5 * (l2 - l1) * gw[q];
      const Vec3 x = a + lambda * (b - a);
      const Vec3 load = o.stiffness * ell * rc.depth_at(x) * n;  // N per unit lambda
      fa += weight * (1.0 - lambda) * load;
      fb += weight * lambda * load;
      moment += weight * (x - origin).cross(load);
      const Eigen::Vector4d beta = test::bary_by_volumes(tp, x);
      for (int k = 0; k < 4; ++k) reaction[k] -= weight * beta[k] * load;
    }
    const double scale = fa.norm() + fb.norm();
    EXPECT_NEAR((r.force[0] - fa).norm(), 0.0, 1e-10 * scale);
    EXPECT_NEAR((r.force[1] - fb).norm(), 0.0, 1e-10 * scale);
    for (int k = 0; k < 4; ++k)
      EXPECT_NEAR((r.force[2 + k] - reaction[k]).norm(), 0.0, 1e-10 * scale);
    // Moment balance about any point: (f_a at a, f_b at b) has the load's moment.
    const Vec3 transferred = (a - origin).cross(r.force[0]) + (b - origin).cross(r.force[1]);
    EXPECT_NEAR((transferred - moment).norm(), 0.0, 1e-10 * scale * (a - origin).norm());
    // The paper's printed weights give f_b to a and f_a to b: same resultant, wrong moment.
    const Vec3 paper = (a - origin).cross(r.force[1]) + (b - origin).cross(r.force[0]);
    const double sin_theta = (b - a).normalized().cross(n).norm();
    if (std::abs(0.5 * (l1 + l2) - 0.5) > 0.1 && sin_theta > 0.2) {
      ++asymmetric;
      EXPECT_GT((paper - moment).norm(), 1e-3 * scale * ell) << trial;
    }
  }
  EXPECT_GT(asymmetric, 20);
}

// ---- Stiffness blocks -------------------------------------------------------------

/// Finite-difference check of the diagonal blocks of every node entry.
void expect_blocks_match_fd(const Single& base, bool segment, const ResponseOptions& o, double tol,
                            const std::string& what) {
  const auto eval = [&](const Single& s) {
    return segment ? eval_segment(s, o) : eval_point(s, o);
  };
  const ContactResult r = eval(base);
  ASSERT_TRUE(r.active) << what;
  ASSERT_EQ(r.fallback, Fallback::kNone) << what;
  double kmax = 0.0;
  for (int i = 0; i < entries(r); ++i) kmax = std::max(kmax, r.stiffness[i].cwiseAbs().maxCoeff());
  const double h = 1e-6;
  for (int i = 0; i < entries(r); ++i) {
    Mat3 fd;
    for (int c = 0; c < 3; ++c) {
      Single plus = base, minus = base;
      Positions& pp = i < r.intruder_nodes ? plus.x.mesh.positions : plus.y.mesh.positions;
      Positions& pm = i < r.intruder_nodes ? minus.x.mesh.positions : minus.y.mesh.positions;
      pp(c, r.node[i]) += h;
      pm(c, r.node[i]) -= h;
      const ContactResult rp = eval(plus), rm = eval(minus);
      ASSERT_TRUE(rp.active && rm.active) << what;
      fd.col(c) = (rp.force[i] - rm.force[i]) / (2.0 * h);
    }
    EXPECT_LE((fd - r.stiffness[i]).cwiseAbs().maxCoeff(), tol * kmax)
        << what << " entry " << i << "\nfd\n"
        << fd << "\nblock\n"
        << r.stiffness[i];
  }
}

TEST(Stiffness, ExactBlocksMatchFiniteDifferences) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 30; ++trial)
    for (const bool segment : {false, true})
      for (const ForceMeasure m : {ForceMeasure::kEdgeLength, ForceMeasure::kUnit}) {
        const RandomCase rc = random_case(rng, segment);
        ResponseOptions o = paper();
        o.stiffness = 1e3;
        o.measure = m;
        o.stiffness_mode = StiffnessMode::kExact;
        const ContactResult r = segment ? eval_segment(rc.s, o) : eval_point(rc.s, o);
        if (!r.active) continue;
        expect_blocks_match_fd(rc.s, segment, o, 2e-5,
                               "trial " + std::to_string(trial) +
                                   (segment ? " segment" : " point") +
                                   (m == ForceMeasure::kUnit ? " unit" : " length"));
      }
}

TEST(Stiffness, ExactSegmentBlocksWithOneEndInside) {
  // a inside the tet (lambda_in = 0): no clip term at that end.
  Single s = make_single({Vec3(0.2, 0.2, 0.2), Vec3(1.5, 0.9, 0.7), Vec3(0, 3, 0), Vec3(0, 0, 3)},
                         {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  s.y.set_depth([](const Vec3& x) { return 0.6 - 0.3 * x.x() - 0.2 * x.y() - 0.9 * x.z(); });
  ResponseOptions o = paper();
  o.stiffness_mode = StiffnessMode::kExact;
  const auto clip =
      test::clip_segment(target_points(s), s.x.mesh.positions.col(0), s.x.mesh.positions.col(1));
  ASSERT_TRUE(clip);
  EXPECT_EQ(clip->first, 0.0);
  EXPECT_LT(clip->second, 1.0);
  expect_blocks_match_fd(s, true, o, 2e-5, "one end inside");
}

TEST(Stiffness, LumpedBlocksAreSymmetricNegativeAndRowSumsOfTheDominantTerm) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 50; ++trial)
    for (const bool segment : {false, true}) {
      const RandomCase rc = random_case(rng, segment);
      ResponseOptions o = paper();
      o.stiffness = 2e3;
      o.stiffness_mode = StiffnessMode::kLumped;
      const ContactResult r = segment ? eval_segment(rc.s, o) : eval_point(rc.s, o);
      if (!r.active) continue;
      Mat3 intruder = Mat3::Zero(), target = Mat3::Zero();
      for (int i = 0; i < entries(r); ++i) {
        const Mat3& k = r.stiffness[i];
        EXPECT_NEAR((k - k.transpose()).norm(), 0.0, 1e-12 * k.norm());
        const Eigen::SelfAdjointEigenSolver<Mat3> eig(k);
        EXPECT_LE(eig.eigenvalues().maxCoeff(), 1e-9 * k.norm());
        (i < r.intruder_nodes ? intruder : target) += k;
      }
      // Both objects carry the same total: -k L |grad d| n n^T (L = w, or the clipped
      // measure).
      EXPECT_NEAR((intruder - target).norm(), 0.0, 1e-12 * intruder.norm());
    }
}

TEST(Stiffness, LumpedEqualsExactForThePointOfAUnitSpring) {
  std::mt19937 rng(23);
  const RandomCase rc = random_case(rng, false);
  ResponseOptions o = paper();
  o.measure = ForceMeasure::kUnit;
  o.stiffness_mode = StiffnessMode::kLumped;
  const ContactResult lumped = eval_point(rc.s, o);
  o.stiffness_mode = StiffnessMode::kExact;
  const ContactResult exact = eval_point(rc.s, o);
  ASSERT_TRUE(lumped.active);
  EXPECT_NEAR((lumped.stiffness[0] - exact.stiffness[0]).norm(), 0.0,
              1e-12 * exact.stiffness[0].norm());
}

TEST(Stiffness, LumpedIsNeverSofterThanTheCoupledTargetStiffness) {
  // A shallow point contact (depth 1e-4 of the tet size: the terms left out of the
  // lumped block are O(depth / size)): the 4x4 normal-normal Jacobian S of the reactions against
  // all four tet nodes (every node coupling, by finite differences) is dominated by the
  // lumped diagonal L: S_sym - L is positive semi-definite (both negative, L stiffer).
  // Along a rigid translation both give exactly -k w |grad d|.
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const auto target = random_tet(rng, 1.0, Vec3::Zero());
    Eigen::Vector4d w(0.15 + 0.2 * u(rng), 0.15 + 0.2 * u(rng), 0.15 + 0.2 * u(rng), 0.0);
    w[3] = 1.0 - w[0] - w[1] - w[2];
    const Vec3 p = w[0] * target[0] + w[1] * target[1] + w[2] * target[2] + w[3] * target[3];
    Single s = make_single({p, p + Vec3(2, 0, 0), p + Vec3(0, 2, 0), p + Vec3(0, 0, 2)}, target);
    const Vec3 v = random_unit(rng);
    s.y.set_depth([&](const Vec3& x) { return 1e-4 + v.dot(x - p); });
    ResponseOptions o = paper();
    o.stiffness_mode = StiffnessMode::kLumped;
    const ContactResult r = eval_point(s, o);
    ASSERT_TRUE(r.active);
    ASSERT_EQ(r.fallback, Fallback::kNone);
    const Vec3 n = r.normal;
    Eigen::Matrix4d s_nn;
    const double h = 1e-7;
    for (int j = 0; j < 4; ++j) {
      Single plus = s, minus = s;
      plus.y.mesh.positions.col(j) += h * n;
      minus.y.mesh.positions.col(j) -= h * n;
      const ContactResult rp = eval_point(plus, o), rm = eval_point(minus, o);
      for (int k = 0; k < 4; ++k) s_nn(k, j) = n.dot(rp.force[1 + k] - rm.force[1 + k]) / (2 * h);
    }
    Eigen::Matrix4d lumped = Eigen::Matrix4d::Zero();
    for (int k = 0; k < 4; ++k) lumped(k, k) = n.dot(r.stiffness[1 + k] * n);
    const Eigen::Matrix4d diff = 0.5 * (s_nn + s_nn.transpose()) - lumped;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(diff);
    const double scale = lumped.cwiseAbs().maxCoeff();
    EXPECT_GE(eig.eigenvalues().minCoeff(), -1e-5 * scale) << trial;
    EXPECT_NEAR(s_nn.sum(), lumped.sum(), 1e-5 * scale) << trial;
  }
}

// ---- Fallbacks --------------------------------------------------------------------

TEST(Fallback, FourBoundaryNodesUseTheNearestFace) {
  // Paper 6.2: a tet with its four nodes on the boundary has depth 0 everywhere; the
  // nearest boundary face gives the direction and the depth, by default and as the
  // interpolation's fallback alike.
  const Vec3 p(0.3, 0.25, 0.05);
  const Single s = make_single({p, Vec3(2, 0, 0), Vec3(0, 2, 0), Vec3(0, 0, 2)},
                               {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  ResponseOptions o;
  o.measure = ForceMeasure::kUnit;
  o.stiffness = 100.0;
  o.stiffness_mode = StiffnessMode::kExact;
  ContactResult r = eval_point(s, o);
  ASSERT_TRUE(r.active);
  EXPECT_EQ(r.fallback, Fallback::kNone);
  o.evaluation = DepthEvaluation::kInterpolate;
  r = eval_point(s, o);
  ASSERT_TRUE(r.active);
  EXPECT_EQ(r.fallback, Fallback::kNearestFace);
  EXPECT_NEAR((r.normal - Vec3(0, 0, -1)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(r.depth, 0.05, 1e-15);
  EXPECT_NEAR((r.force[0] - Vec3(0, 0, -5.0)).norm(), 0.0, 1e-12);
  // Unit-gradient blocks: -k n n^T on the node.
  EXPECT_NEAR((r.stiffness[0] + 100.0 * Vec3(0, 0, 1) * Vec3(0, 0, 1).transpose()).norm(), 0.0,
              1e-12);
  // Same for a segment through the tet near its x = 0 face.
  const Single seg =
      make_single({Vec3(0.02, -0.5, 0.2), Vec3(0.02, 1.5, 0.2), Vec3(3, 0, 0), Vec3(0, 0, 3)},
                  {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  const ContactResult rs = eval_segment(seg, o);
  ASSERT_TRUE(rs.active);
  EXPECT_EQ(rs.fallback, Fallback::kNearestFace);
  EXPECT_NEAR((rs.normal - Vec3(-1, 0, 0)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(rs.depth, 0.02, 1e-15);
}

TEST(Fallback, EqualDepthsInAnInteriorTetUseTheNearestFaceOfTheAnchors) {
  // A box thin in z: the centre cell's tets have no boundary face and no boundary node;
  // with equal depths the interpolation has no gradient, and the nearest face around
  // the nodes' anchors (the depth map's closest boundary nodes) is on z = 0 or z = 1.2.
  TestObject y(test::structured_box(3, 3, 3, {0, 0, 0}, {3, 3, 1.2}));
  y.compute_depth_map();
  std::fill(y.depth.begin(), y.depth.end(), 0.4);
  const Index centre_tet = 6 * 13;  // first tet of cell (1, 1, 1)
  for (int j = 0; j < 4; ++j) ASSERT_NE(y.topology.tet_neighbors[centre_tet][j], -1);
  const auto tp = test::tet_points(y.mesh.positions, y.mesh.tets[centre_tet]);
  const Vec3 p = 0.25 * (tp[0] + tp[1] + tp[2] + tp[3]);
  TestObject x(test::mesh_from({p, p + Vec3(5, 0, 0), p + Vec3(0, 5, 0), p + Vec3(0, 0, 5)},
                               {{0, 1, 2, 3}}));
  ResponseOptions o;
  o.evaluation = DepthEvaluation::kInterpolate;
  ContactResult r = point_contact(
      x.view(), y.view(), {0, centre_tet, Eigen::Vector4d::Constant(0.25)}, o, Vec3::Zero());
  ASSERT_TRUE(r.active);
  EXPECT_EQ(r.fallback, Fallback::kNearestFace);
  const bool low = p.z() < 1.2 - p.z();
  EXPECT_NEAR((r.normal - Vec3(0, 0, low ? -1 : 1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(r.depth, std::min(p.z(), 1.2 - p.z()), 1e-12);
  // The default evaluation reaches the same face directly; without anchors an interior
  // tet has no candidate face and falls back to the (gradient-less) interpolation.
  o.evaluation = DepthEvaluation::kNearestFace;
  r = point_contact(x.view(), y.view(), {0, centre_tet, Eigen::Vector4d::Constant(0.25)}, o,
                    Vec3::Zero());
  EXPECT_EQ(r.fallback, Fallback::kNone);
  EXPECT_NEAR(r.depth, std::min(p.z(), 1.2 - p.z()), 1e-12);
  y.anchor.clear();
  r = point_contact(x.view(), y.view(), {0, centre_tet, Eigen::Vector4d::Constant(0.25)}, o,
                    Vec3::Zero());
  EXPECT_EQ(r.fallback, Fallback::kAxis);
}

TEST(Fallback, WithoutTopologyThePairDirectionThenTheAxis) {
  Single s = make_single({Vec3(0.2, 0.2, 0.2), Vec3(2, 0, 0), Vec3(0, 2, 0), Vec3(0, 0, 2)},
                         {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)});
  std::fill(s.y.depth.begin(), s.y.depth.end(), 0.3);
  ResponseObject target = s.y.view();
  target.topology = nullptr;
  const IntrudingNode c{0, 0, Eigen::Vector4d(0.4, 0.2, 0.2, 0.2)};
  ResponseOptions o;
  ContactResult r = point_contact(s.x.view(), target, c, o, Vec3(1, 0, 0));
  EXPECT_EQ(r.fallback, Fallback::kPairDirection);
  EXPECT_NEAR((r.normal - Vec3(1, 0, 0)).norm(), 0.0, 0.0);
  EXPECT_NEAR(r.depth, 0.3, 1e-15);
  r = point_contact(s.x.view(), target, c, o, Vec3::Zero());
  EXPECT_EQ(r.fallback, Fallback::kAxis);
  EXPECT_EQ(r.normal, Vec3(0, 0, 1));
}

// ---- Damping and options ------------------------------------------------------------

TEST(Damping, ApproachStiffensSeparationSoftensNeverPulls) {
  for (const bool segment : {false, true}) {
    std::mt19937 rng(3);
    RandomCase rc = random_case(rng, segment);
    ResponseOptions o = paper();
    o.stiffness = 1e3;
    const ContactResult still = segment ? eval_segment(rc.s, o) : eval_point(rc.s, o);
    ASSERT_TRUE(still.active);
    const Vec3 n = still.normal;
    o.damping = 50.0;
    const auto with_velocity = [&](double speed) {
      rc.s.x.velocities = Positions::Zero(3, 4);
      for (int i = 0; i < 4; ++i) rc.s.x.velocities->col(i) = speed * n;
      return segment ? eval_segment(rc.s, o) : eval_point(rc.s, o);
    };
    const ContactResult in = with_velocity(-1.0);  // moving deeper
    const ContactResult out = with_velocity(+0.1);
    const ContactResult away = with_velocity(+1e6);
    const double f0 = (still.force[0] + still.force[segment ? 1 : 0]).norm();
    EXPECT_GT((in.force[0] + in.force[segment ? 1 : 0]).norm(), f0 * (1 + 1e-6));
    ASSERT_TRUE(out.active);
    EXPECT_LT((out.force[0] + out.force[segment ? 1 : 0]).norm(), f0);
    EXPECT_GT(n.dot(out.force[0]), 0.0);  // still a push
    EXPECT_FALSE(away.active);            // clamped at zero: no pull
    // A moving target with the same velocity is no relative motion at all.
    rc.s.y.velocities = Positions::Zero(3, 4);
    for (int i = 0; i < 4; ++i) rc.s.y.velocities->col(i) = -1.0 * n;
    const ContactResult same = with_velocity(-1.0);
    EXPECT_NEAR((same.force[0] - still.force[0]).norm(), 0.0, 1e-12 * still.force[0].norm());
  }
}

// ---- Friction -----------------------------------------------------------------------

/// Every node of X (the intruder) moves at vx, every node of Y at vy.
void set_velocities(Single& s, const Vec3& vx, const Vec3& vy) {
  s.x.velocities = vx.replicate(1, s.x.mesh.num_nodes());
  s.y.velocities = vy.replicate(1, s.y.mesh.num_nodes());
}

ContactResult eval(const Single& s, bool segment, const ResponseOptions& o) {
  return segment ? eval_segment(s, o) : eval_point(s, o);
}

/// The sum of the forces on the intruder's nodes (the contact's force on X).
Vec3 on_intruder(const ContactResult& r) {
  Vec3 f = Vec3::Zero();
  for (int i = 0; i < r.intruder_nodes; ++i) f += r.force[i];
  return f;
}

TEST(Friction, SlidingOpposesTheTangentialVelocityWithMuTimesThePush) {
  for (const bool segment : {false, true}) {
    std::mt19937 rng(segment ? 41 : 42);
    int active = 0;
    for (int trial = 0; trial < 40; ++trial) {
      RandomCase rc = random_case(rng, segment);
      ResponseOptions o = paper();
      o.stiffness = 1e3;
      const ContactResult bare = eval(rc.s, segment, o);
      if (!bare.active) continue;
      ++active;
      const Vec3 n = bare.normal;
      // Sliding well above the threshold, with a normal part that friction ignores.
      const Vec3 t = n.unitOrthogonal();
      const Vec3 v = 2.0 * t + 0.3 * n;
      set_velocities(rc.s, v, Vec3::Zero());
      o.friction = 0.4;
      o.friction_velocity = 1e-3;
      const ContactResult r = eval(rc.s, segment, o);
      ASSERT_TRUE(r.active);
      // Without damping the push is the frictionless force; friction adds -mu |push| t
      // at each point (the segment's two clip points move together here).
      const Vec3 push = on_intruder(bare);
      double push_sum = 0.0;
      for (int i = 0; i < r.intruder_nodes; ++i) push_sum += r.push[i];
      EXPECT_NEAR(push_sum, push.norm(), 1e-12 * push.norm()) << trial;
      const Vec3 friction = on_intruder(r) - push;
      EXPECT_NEAR((friction + 0.4 * push.norm() * t).norm(), 0.0, 1e-9 * push.norm()) << trial;
      // The reaction: every contact still sums to zero.
      Vec3 total = Vec3::Zero();
      for (int i = 0; i < entries(r); ++i) total += r.force[i];
      EXPECT_LE(total.norm(), 1e-12 * push.norm()) << trial;
      // A target moving with the intruder: no relative motion, no friction.
      set_velocities(rc.s, v, v);
      const ContactResult same = eval(rc.s, segment, o);
      EXPECT_LE((on_intruder(same) - push).norm(), 1e-12 * push.norm()) << trial;
    }
    EXPECT_GT(active, 20);
  }
}

TEST(Friction, BelowTheThresholdItSticksViscouslyAndIsContinuous) {
  std::mt19937 rng(43);
  const RandomCase base = random_case(rng, false);
  ResponseOptions o = paper();
  o.stiffness = 1e3;
  const ContactResult bare = eval_point(base.s, o);
  ASSERT_TRUE(bare.active);
  const Vec3 n = bare.normal, t = n.unitOrthogonal();
  const double push = bare.force[0].norm();
  o.friction = 0.5;
  o.friction_velocity = 1e-3;
  const auto magnitude = [&](double speed) {
    RandomCase rc = base;
    set_velocities(rc.s, speed * t, Vec3::Zero());
    const ContactResult r = eval_point(rc.s, o);
    const Vec3 f = r.force[0] - bare.force[0];
    EXPECT_LE(f.dot(t), 0.0) << speed;  // opposes the motion
    return f.norm();
  };
  EXPECT_EQ(magnitude(0.0), 0.0);
  // f1(y) = 2y - y^2 below eps: a viscous stick of slope 2 mu push / eps at rest.
  for (const double y : {1e-3, 0.1, 0.5, 0.9})
    EXPECT_NEAR(magnitude(y * 1e-3), 0.5 * push * (2.0 * y - y * y), 1e-9 * push) << y;
  EXPECT_NEAR(magnitude(1e-3), 0.5 * push, 1e-12 * push);
  EXPECT_NEAR(magnitude(1e-3 * (1.0 - 1e-7)), 0.5 * push, 1e-9 * push);  // continuous at eps
  EXPECT_NEAR(magnitude(10.0), 0.5 * push, 1e-12 * push);                // Coulomb's bound
}

TEST(Friction, NeverAddsEnergy) {
  // The contact's power sum_i f_i . v_i over its nodes is at most the frictionless one:
  // friction only takes energy out, in sliding and sticking, point and segment.
  for (const bool segment : {false, true}) {
    std::mt19937 rng(segment ? 44 : 45);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int trial = 0; trial < 60; ++trial) {
      RandomCase rc = random_case(rng, segment);
      rc.s.x.velocities = Positions(3, 4);
      rc.s.y.velocities = Positions(3, 4);
      const double scale = trial % 2 == 0 ? 1e-3 : 1.0;  // sticking, then sliding
      for (int i = 0; i < 4; ++i) {
        rc.s.x.velocities->col(i) = scale * Vec3(u(rng), u(rng), u(rng));
        rc.s.y.velocities->col(i) = scale * Vec3(u(rng), u(rng), u(rng));
      }
      ResponseOptions o = paper();
      o.stiffness = 1e3;
      o.damping = trial % 3 == 0 ? 5.0 : 0.0;
      const auto power = [&](const ContactResult& r) {
        double p = 0.0;
        for (int i = 0; i < entries(r); ++i) {
          const auto& v = i < r.intruder_nodes ? *rc.s.x.velocities : *rc.s.y.velocities;
          p += r.force[i].dot(v.col(r.node[i]));
        }
        return p;
      };
      const ContactResult bare = eval(rc.s, segment, o);
      o.friction = 0.8;
      o.friction_velocity = 1e-3;
      const ContactResult r = eval(rc.s, segment, o);
      if (!r.active) continue;
      EXPECT_LE(power(r), power(bare) + 1e-12 * std::abs(power(bare))) << trial;
    }
  }
}

/// Finite differences of the forces under a velocity change shared by all nodes of X
/// (or of Y) against the df/dv blocks: each entry's block is its row sum over its own
/// object (the lumping of the stiffness blocks). Exact for the damping, whose force is
/// affine in the velocity.
void expect_damping_blocks_match_fd(Single s, bool segment, const ResponseOptions& o,
                                    const std::string& what, double h = 1e-7) {
  const ContactResult r = eval(s, segment, o);
  ASSERT_TRUE(r.active) << what;
  double scale = 0.0;
  for (int i = 0; i < entries(r); ++i) scale = std::max(scale, r.damping[i].norm());
  ASSERT_GT(scale, 0.0) << what;
  for (const bool move_x : {true, false}) {
    Single moved = s;
    for (int c = 0; c < 3; ++c) {
      Positions& v = move_x ? *moved.x.velocities : *moved.y.velocities;
      const Positions& v0 = move_x ? *s.x.velocities : *s.y.velocities;
      v = v0;
      v.row(c).array() += h;
      const ContactResult plus = eval(moved, segment, o);
      v = v0;
      v.row(c).array() -= h;
      const ContactResult minus = eval(moved, segment, o);
      for (int i = 0; i < entries(r); ++i) {
        const bool on_x = i < r.intruder_nodes;
        if (on_x != move_x) continue;  // a block is the row sum over its own object
        const Vec3 fd = (plus.force[i] - minus.force[i]) / (2.0 * h);
        EXPECT_NEAR((fd - r.damping[i].col(c)).norm(), 0.0, 1e-5 * scale)
            << what << " entry " << i << " column " << c;
      }
    }
  }
}

/// The blocks of a contact are symmetric and negative semi-definite.
void expect_symmetric_negative(const ContactResult& r, const std::string& what) {
  for (int i = 0; i < entries(r); ++i) {
    const Mat3& d = r.damping[i];
    EXPECT_NEAR((d - d.transpose()).norm(), 0.0, 1e-12 * d.norm()) << what;
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(d);
    EXPECT_LE(eig.eigenvalues().maxCoeff(), 1e-9 * d.norm()) << what;
  }
}

TEST(Friction, DampingBlocksAreTheSecantOfFrictionAndTheDerivativeOfDamping) {
  // Friction's df/dv is the secant (lagged viscous) matrix D = -mu p g(|v_t|) P: with the
  // intruder's nodes all at v and the target at rest, each entry's friction is D v (its
  // reaction -D v); at rest it is the derivative. The damping's block is its derivative
  // (finite differences). Sliding and sticking, point and segment.
  std::mt19937 rng(46);
  int checked = 0;
  for (int trial = 0; trial < 12; ++trial)
    for (const bool segment : {false, true}) {
      RandomCase rc = random_case(rng, segment);
      ResponseOptions o = paper();
      o.stiffness = 1e3;
      o.stiffness_mode = StiffnessMode::kLumped;
      const ContactResult bare = eval(rc.s, segment, o);
      if (!bare.active) continue;
      ++checked;
      const Vec3 n = bare.normal, t = n.unitOrthogonal(), b = n.cross(t);
      const double speed = trial % 2 == 0 ? 4e-4 : 0.3;  // below and above eps = 1e-3
      const Vec3 v = speed * (0.8 * t + 0.6 * b) + 0.2 * speed * n;
      set_velocities(rc.s, v, Vec3::Zero());
      o.friction = 0.6;
      o.friction_velocity = 1e-3;
      const std::string what = "trial " + std::to_string(trial) + (segment ? " segment" : " point");
      const ContactResult r = eval(rc.s, segment, o);
      ASSERT_TRUE(r.active) << what;
      double fmax = 0.0;
      for (int i = 0; i < entries(r); ++i) fmax = std::max(fmax, r.force[i].norm());
      for (int i = 0; i < entries(r); ++i) {
        const Vec3 friction = r.force[i] - bare.force[i];
        const Vec3 secant = (i < r.intruder_nodes ? 1.0 : -1.0) * r.damping[i] * v;
        EXPECT_NEAR((friction - secant).norm(), 0.0, 1e-12 * fmax) << what << " entry " << i;
      }
      expect_symmetric_negative(r, what + " friction");
      // At rest the secant is the derivative: -2 mu p / eps on the tangent plane (a step
      // of 1e-9 m/s: f1's curvature costs h / (2 eps) of relative error).
      set_velocities(rc.s, Vec3::Zero(), Vec3::Zero());
      expect_damping_blocks_match_fd(rc.s, segment, o, what + " friction at rest", 1e-9);
      o.friction = 0.0;
      o.damping = 3.0;
      set_velocities(rc.s, -0.01 * n + speed * t, Vec3::Zero());  // approaching: damping on
      expect_damping_blocks_match_fd(rc.s, segment, o, what + " damping");
      expect_symmetric_negative(eval(rc.s, segment, o), what + " damping");
    }
  EXPECT_GT(checked, 12);
}

TEST(Friction, NoFrictionWithoutVelocitiesOrWithMuZero) {
  std::mt19937 rng(47);
  RandomCase rc = random_case(rng, false);
  ResponseOptions o = paper();
  o.friction = 0.7;
  const ContactResult still = eval_point(rc.s, o);  // no velocities: at rest
  o.friction = 0.0;
  const ContactResult bare = eval_point(rc.s, o);
  EXPECT_EQ(still.force[0], bare.force[0]);
  set_velocities(rc.s, Vec3(1, 2, 3), Vec3::Zero());
  const ContactResult moving = eval_point(rc.s, o);  // mu = 0: the same bits
  EXPECT_EQ(moving.force[0], bare.force[0]);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(moving.force[1 + k], bare.force[1 + k]);
}

TEST(Options, PushPointOnlyLeavesTheTargetAlone) {
  std::mt19937 rng(8);
  const RandomCase rc = random_case(rng, false);
  ResponseOptions o = paper();
  const ContactResult both = eval_point(rc.s, o);
  o.push_point_only = true;
  o.stiffness_mode = StiffnessMode::kLumped;
  const ContactResult only = eval_point(rc.s, o);
  ASSERT_TRUE(only.active);
  EXPECT_EQ(only.target_nodes, 0);
  EXPECT_EQ(both.target_nodes, 4);
  EXPECT_EQ(only.force[0], both.force[0]);
}

// ---- Degenerate and extreme sweep -------------------------------------------------

enum class Shape { kRegular, kEqualDepths, kZeroDepths, kSliver, kFlat, kInverted, kNeedle };

struct ExtremeCase {
  Shape shape;
  double scale;
  double offset;
  double stiffness;
  bool segment;
  StiffnessMode mode;
};

class Extreme : public ::testing::TestWithParam<ExtremeCase> {};

TEST_P(Extreme, FiniteAndBounded) {
  const ExtremeCase ec = GetParam();
  std::array<Vec3, 4> t = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  switch (ec.shape) {
    case Shape::kSliver:
      t[3] = Vec3(0.3, 0.3, 1e-9);
      break;
    case Shape::kFlat:
      t[3] = Vec3(0.3, 0.3, 0.0);
      break;
    case Shape::kInverted:
      std::swap(t[2], t[3]);
      break;
    case Shape::kNeedle:
      t[1] = Vec3(1e-7, 0, 0), t[2] = Vec3(0, 1e-7, 0);
      break;
    default:
      break;
  }
  for (Vec3& p : t) p = ec.scale * p + Vec3::Constant(ec.offset);
  const Eigen::Vector4d beta(0.25, 0.25, 0.25, 0.25);
  const Vec3 q = 0.25 * (t[0] + t[1] + t[2] + t[3]);
  const Vec3 dir = Vec3(0.3, -0.4, 0.87).normalized();
  const std::array<Vec3, 4> x = {ec.segment ? Vec3(q - ec.scale * dir) : q, q + ec.scale * dir,
                                 q + ec.scale * Vec3(2, 0, 0), q + ec.scale * Vec3(0, 0, 2)};
  Single s = make_single(x, t);
  Eigen::Vector4d d = Eigen::Vector4d(0.1, 0.5, 0.2, 0.4) * ec.scale;
  if (ec.shape == Shape::kEqualDepths) d.setConstant(0.3 * ec.scale);
  if (ec.shape == Shape::kZeroDepths) d.setZero();
  for (int k = 0; k < 4; ++k) s.y.depth[k] = d[k];
  ResponseOptions o = paper();
  o.stiffness = ec.stiffness;
  o.stiffness_mode = ec.mode;
  const ContactResult r =
      ec.segment ? segment_contact(s.x.view(), s.y.view(), {0, 0, 0.45, 0.55}, o, Vec3::Zero())
                 : point_contact(s.x.view(), s.y.view(), {0, 0, beta}, o, Vec3::Zero());
  EXPECT_FALSE(r.skipped);
  EXPECT_TRUE(r.active);
  EXPECT_TRUE(r.normal.allFinite());
  EXPECT_NEAR(r.normal.norm(), 1.0, 1e-12);
  // Depth never exceeds the node depths or the tet's size; the force never exceeds
  // k * weight * that depth.
  const double diameter = 2.0 * ec.scale;
  const double max_depth = std::max(d.maxCoeff(), diameter);
  EXPECT_LE(r.depth, max_depth * (1 + 1e-9));
  double weight = ec.segment ? 0.1 * (x[1] - x[0]).norm() : node_length_weight(s.x.view(), 0);
  Vec3 total = Vec3::Zero();
  for (int i = 0; i < entries(r); ++i) {
    EXPECT_TRUE(r.force[i].allFinite()) << i;
    EXPECT_TRUE(r.stiffness[i].allFinite()) << i;
    EXPECT_LE(r.force[i].norm(), ec.stiffness * weight * max_depth * (1 + 1e-9)) << i;
    total += r.force[i];
  }
  EXPECT_LE(total.norm(), 1e-12 * ec.stiffness * weight * max_depth + 1e-300);
  if (ec.mode == StiffnessMode::kLumped) {
    for (int i = 0; i < entries(r); ++i) {
      EXPECT_LE(r.stiffness[i].norm(),
                ec.stiffness * weight * o.max_gradient * (1 + 1e-9) + 1e-300);
    }
  }
  // The default nearest-face evaluation on the same lone tet: finite, never deeper than
  // the tet, balanced. (It may be inactive: a flat or needle tet has no inside.)
  o.evaluation = DepthEvaluation::kNearestFace;
  const ContactResult nf =
      ec.segment ? segment_contact(s.x.view(), s.y.view(), {0, 0, 0.45, 0.55}, o, Vec3::Zero())
                 : point_contact(s.x.view(), s.y.view(), {0, 0, beta}, o, Vec3::Zero());
  EXPECT_FALSE(nf.skipped);
  EXPECT_TRUE(nf.normal.allFinite());
  EXPECT_NEAR(nf.normal.norm(), 1.0, 1e-12);
  EXPECT_LE(nf.depth, diameter * (1 + 1e-9));
  Vec3 nf_total = Vec3::Zero();
  for (int i = 0; i < entries(nf); ++i) {
    EXPECT_TRUE(nf.force[i].allFinite()) << i;
    EXPECT_TRUE(nf.stiffness[i].allFinite()) << i;
    EXPECT_LE(nf.force[i].norm(), ec.stiffness * weight * diameter * (1 + 1e-9)) << i;
    nf_total += nf.force[i];
  }
  EXPECT_LE(nf_total.norm(), 1e-12 * ec.stiffness * weight * diameter + 1e-300);
}

std::vector<ExtremeCase> extreme_cases() {
  std::vector<ExtremeCase> out;
  for (const Shape shape : {Shape::kRegular, Shape::kEqualDepths, Shape::kZeroDepths,
                            Shape::kSliver, Shape::kFlat, Shape::kInverted, Shape::kNeedle})
    for (const auto& [scale, offset] :
         std::vector<std::pair<double, double>>{{1.0, 0.0}, {1e-6, 0.0}, {1.0, 1e6}})
      for (const double k : {1.0, 1e4, 1e9})
        for (const bool segment : {false, true})
          for (const StiffnessMode mode : {StiffnessMode::kLumped, StiffnessMode::kExact})
            out.push_back({shape, scale, offset, k, segment, mode});
  return out;
}

INSTANTIATE_TEST_SUITE_P(DegenerateShapesScalesStiffnesses, Extreme,
                         ::testing::ValuesIn(extreme_cases()));

TEST(Extreme, NonFiniteInputIsSkipped) {
  std::mt19937 rng(2);
  RandomCase rc = random_case(rng, false);
  ResponseOptions o = paper();
  rc.s.y.depth[2] = std::nan("");
  EXPECT_TRUE(eval_point(rc.s, o).skipped);
  rc.s.y.depth[2] = 0.1;
  rc.s.x.mesh.positions(0, 0) = std::numeric_limits<double>::infinity();
  const ContactResult r = point_contact(rc.s.x.view(), rc.s.y.view(),
                                        {0, 0, Eigen::Vector4d::Constant(0.25)}, o, Vec3::Zero());
  EXPECT_TRUE(r.skipped);
  EXPECT_FALSE(r.active);
  const ContactResult bad_bary = point_contact(
      rc.s.x.view(), rc.s.y.view(), {0, 0, Eigen::Vector4d(-1, -1, -1, -1)}, o, Vec3::Zero());
  EXPECT_TRUE(bad_bary.skipped);
}

}  // namespace
}  // namespace tc
