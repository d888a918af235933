// service/core/response/response: pair responses on brute-force contacts. Two boxes
// overlapping along z, the paper's Fig. 11 edge-only overlap, point and segment agreeing
// as quadratures of one integral, the kAuto rule, deep penetration, scale and offset
// invariance, determinism across thread counts, the sparse merge and the force cap,
// input validation, and a stiff sweep with a backward-Euler integrator.
#include "core/response/response.hpp"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <Eigen/LU>
#include <cstdio>
#include <cstring>
#include <random>

#include "response_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

// The tests of the paper's formulas use depth fields written by hand (half-spaces,
// linear fields): test::paper().
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using test::paper;
using test::TestObject;

Vec3 total_force(const ObjectForces& f) {
  Vec3 sum = Vec3::Zero();
  for (const Vec3& v : f.forces) sum += v;
  return sum;
}

PairResponse respond(const TestObject& a, const TestObject& b, const PairContacts& c,
                     const ResponseOptions& o) {
  auto r = compute_pair_response(a.view(), b.view(), c, o);
  EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
  return r ? std::move(*r) : PairResponse{};
}

/// B: the box [0, 1]^2 x [0, 0.5] (8 x 8 x 4 cells); A: a box of half-width hw centred
/// over it, its bottom d below B's top. Depths: the exact box distance, or (half_space)
/// the distance to the contact face only (B's top, A's bottom), as for large bodies.
/// Then x -> s x + o.
struct BoxPair {
  TestObject a;
  TestObject b;
};

enum class Depth { kBox, kHalfSpace };

BoxPair box_pair(double d, double hw, int cells_a = 3, Depth depth = Depth::kHalfSpace,
                 double scale = 1.0, const Vec3& offset = Vec3::Zero()) {
  const Vec3 lo_b(0, 0, 0), hi_b(1, 1, 0.5);
  const Vec3 lo_a(0.5 - hw, 0.5 - hw, 0.5 - d), hi_a(0.5 + hw, 0.5 + hw, 0.75 - d);
  BoxPair p{TestObject(test::structured_box(cells_a, cells_a, 2, lo_a, hi_a)),
            TestObject(test::structured_box(8, 8, 4, lo_b, hi_b))};
  if (depth == Depth::kBox) {
    p.a.set_depth([&](const Vec3& x) { return scale * test::box_depth(x, lo_a, hi_a); });
    p.b.set_depth([&](const Vec3& x) { return scale * test::box_depth(x, lo_b, hi_b); });
  } else {
    p.a.set_depth([&](const Vec3& x) { return scale * (x.z() - lo_a.z()); });
    p.b.set_depth([&](const Vec3& x) { return scale * (hi_b.z() - x.z()); });
  }
  test::transform(p.a.mesh, scale, offset);
  test::transform(p.b.mesh, scale, offset);
  return p;
}

void expect_pair_balanced(const PairResponse& r) {
  const Vec3 fa = total_force(r.a), fb = total_force(r.b);
  double fmax = 0.0;
  for (const Vec3& f : r.a.forces) fmax = std::max(fmax, f.norm());
  EXPECT_LE((fa + fb).norm(), 1e-12 * std::max(1.0, static_cast<double>(r.a.nodes.size())) * fmax);
}

// ---- Two boxes ----------------------------------------------------------------------

class TwoBoxes : public ::testing::TestWithParam<ResponseKind> {};

TEST_P(TwoBoxes, ForcesAlongTheAxisGrowingWithOverlapDepth) {
  ResponseOptions o = paper();
  o.kind = GetParam();
  o.stiffness = 1e4;
  double previous = 0.0;
  for (const double d : {0.03, 0.06, 0.09}) {
    const BoxPair p = box_pair(d, 0.21);
    const PairContacts c = test::brute_force_contacts(p.a, p.b);
    ASSERT_FALSE(c.nodes_a_in_b.empty());
    const PairResponse r = respond(p.a, p.b, c, o);
    EXPECT_EQ(r.used_a_in_b, GetParam());
    const Vec3 fa = total_force(r.a);
    EXPECT_GT(fa.z(), 0.0);  // A pushed up, out of B
    EXPECT_LE(std::hypot(fa.x(), fa.y()), 1e-12 * fa.z()) << d;
    for (const Vec3& f : r.a.forces) EXPECT_LE(std::hypot(f.x(), f.y()), 1e-12 * fa.z());
    EXPECT_GT(fa.z(), previous * 1.2) << d;
    previous = fa.z();
    expect_pair_balanced(r);
    EXPECT_EQ(r.stats.skipped, 0u);
    EXPECT_GT(r.stats.max_depth, 0.8 * d);
    EXPECT_LE(r.stats.max_depth, d + 1e-12);
  }
}

TEST_P(TwoBoxes, SegmentForceGrowsWithTheOverlapArea) {
  ResponseOptions o = paper();
  o.kind = GetParam();
  // Same cell count, so more area means longer edges and more of B's nodes inside A.
  // The segment response integrates over the overlap and tracks the area; the point
  // response counts nodes and only has to not decrease.
  const bool segment = GetParam() == ResponseKind::kSegment;
  double previous = 0.0, first = 0.0;
  for (const double hw : {0.15, 0.21, 0.27, 0.33}) {
    const BoxPair p = box_pair(0.05, hw);
    const PairResponse r = respond(p.a, p.b, test::brute_force_contacts(p.a, p.b), o);
    const double fz = total_force(r.a).z();
    EXPECT_GT(fz, previous * (segment ? 1.1 : 1.0)) << hw;
    if (first == 0.0) first = fz;
    previous = fz;
  }
  EXPECT_GT(previous, 2.0 * first);  // the area grew 4.8 times
}

TEST_P(TwoBoxes, ExactBoxDepthsStillPushAlongTheAxis) {
  // With the box distance, A's depth is poorly resolved near its side walls (one cell
  // of 0.14 m against 0.03 m of overlap): some reactions lean sideways, the total not.
  ResponseOptions o = paper();
  o.kind = GetParam();
  for (const double d : {0.03, 0.06, 0.09}) {
    const BoxPair p = box_pair(d, 0.21, 3, Depth::kBox);
    const PairResponse r = respond(p.a, p.b, test::brute_force_contacts(p.a, p.b), o);
    const Vec3 fa = total_force(r.a);
    EXPECT_GT(fa.z(), 0.0);
    EXPECT_LE(std::hypot(fa.x(), fa.y()), 0.15 * fa.z()) << d;
    expect_pair_balanced(r);
  }
}

INSTANTIATE_TEST_SUITE_P(PointAndSegment, TwoBoxes,
                         ::testing::Values(ResponseKind::kPoint, ResponseKind::kSegment));

TEST(TwoBoxes, ScaleAndOffsetInvariance) {
  // Force = k * depth * length: x -> s x + o scales every force by s^2.
  for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
    ResponseOptions o = paper();
    o.kind = kind;
    o.stiffness = 1e9;
    const BoxPair ref = box_pair(0.05, 0.21, 3, Depth::kBox);
    const PairContacts cref = test::brute_force_contacts(ref.a, ref.b);
    const PairResponse rref = respond(ref.a, ref.b, cref, o);
    const Vec3 fref = total_force(rref.a);
    for (const auto& [s, off] : std::vector<std::pair<double, double>>{
             {1e-6, 0.0}, {1.0, 1e6}, {1e3, -1e6}, {1e-3, 1e3}}) {
      const BoxPair p = box_pair(0.05, 0.21, 3, Depth::kBox, s, Vec3(off, -off, 0.5 * off));
      const PairContacts c = test::brute_force_contacts(p.a, p.b);
      EXPECT_EQ(c.nodes_a_in_b.size(), cref.nodes_a_in_b.size());
      EXPECT_EQ(c.edges_a_in_b.size(), cref.edges_a_in_b.size());
      const PairResponse r = respond(p.a, p.b, c, o);
      ASSERT_EQ(r.a.nodes, rref.a.nodes);
      const double tol = 1e-9 * (1.0 + std::abs(off) / s);
      EXPECT_NEAR((total_force(r.a) / (s * s) - fref).norm(), 0.0, tol * fref.norm()) << s << off;
      for (std::size_t i = 0; i < r.a.forces.size(); ++i) EXPECT_TRUE(r.a.forces[i].allFinite());
    }
  }
}

// ---- Fig. 11 ------------------------------------------------------------------------

/// Two disphenoids crossing by edges only: B has a bottom edge along x at z = 0 and a top
/// edge along y at z = 1; A is B turned 90 degrees about z and lifted by 0.5. No vertex
/// of either is inside the other; A's bottom edge crosses B, B's top edge crosses A.
BoxPair fig11() {
  const auto oriented = [](std::vector<Vec3> pts) {
    Tet t{0, 1, 2, 3};
    if (signed_volume(pts[0], pts[1], pts[2], pts[3]) < 0) std::swap(t[2], t[3]);
    return test::mesh_from(pts, {t});
  };
  return {
      TestObject(oriented({Vec3(0, -1, 0.5), Vec3(0, 1, 0.5), Vec3(-1, 0, 1.5), Vec3(1, 0, 1.5)})),
      TestObject(oriented({Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 1), Vec3(0, 1, 1)}))};
}

TEST(Fig11, EdgeOnlyOverlapHasNoPointResponseAndASegmentResponse) {
  BoxPair p = fig11();
  const PairContacts c = test::brute_force_contacts(p.a, p.b);
  ASSERT_FALSE(c.overlapping.empty());
  EXPECT_TRUE(c.nodes_a_in_b.empty());
  EXPECT_TRUE(c.nodes_b_in_a.empty());
  ASSERT_EQ(c.edges_a_in_b.size(), 1u);
  ASSERT_EQ(c.edges_b_in_a.size(), 1u);

  // Depths as if each tet were the surface layer of a thick body: B's grows downwards
  // from its top, A's upwards from its bottom.
  p.b.set_depth([](const Vec3& x) { return 1.0 - x.z(); });
  p.a.set_depth([](const Vec3& x) { return x.z() - 0.5; });
  ResponseOptions o = paper();
  o.kind = ResponseKind::kPoint;
  PairResponse r = respond(p.a, p.b, c, o);
  EXPECT_TRUE(r.a.nodes.empty());
  EXPECT_TRUE(r.b.nodes.empty());
  EXPECT_EQ(r.stats.point_contacts, 0u);

  o.kind = ResponseKind::kSegment;
  r = respond(p.a, p.b, c, o);
  EXPECT_EQ(r.stats.segment_contacts, 2u);
  const Vec3 fa = total_force(r.a);
  EXPECT_GT(fa.z(), 0.0);
  EXPECT_LE(std::hypot(fa.x(), fa.y()), 1e-12 * fa.z());
  expect_pair_balanced(r);

  // kAuto: one tet against one tet is as coarse as it gets.
  o.kind = ResponseKind::kAuto;
  r = respond(p.a, p.b, c, o);
  EXPECT_EQ(r.used_a_in_b, ResponseKind::kSegment);
  EXPECT_EQ(r.used_b_in_a, ResponseKind::kSegment);

  // With the exact depth of a lone tet (0 at all four nodes, paper 6.2) the nearest
  // boundary face still separates them.
  std::fill(p.a.depth.begin(), p.a.depth.end(), 0.0);
  std::fill(p.b.depth.begin(), p.b.depth.end(), 0.0);
  r = respond(p.a, p.b, c, o);
  EXPECT_EQ(r.stats.segment_contacts, 2u);
  EXPECT_EQ(r.stats.fallback_nearest_face, 2u);
  EXPECT_GT(total_force(r.a).norm(), 0.0);
  expect_pair_balanced(r);
}

// ---- Point and segment: two quadratures of one integral ------------------------------

TEST(PointVsSegment, AgreeForAnObjectInsideALinearDepthField) {
  // A inside one cell of B, B's depth linear (B as the top of a thick body): the
  // segment response integrates k d exactly over every edge, the point response lumps
  // the same integral on the nodes; with one gradient everywhere the totals agree.
  TestObject b(test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1}));
  b.set_depth([](const Vec3& x) { return 2.0 - 0.6 * x.z() + 0.8 * x.x(); });
  TestObject a(test::structured_box(2, 2, 2, {0.27, 0.28, 0.26}, {0.47, 0.48, 0.46}));
  PairContacts c = test::brute_force_contacts(a, b);
  ASSERT_EQ(c.nodes_a_in_b.size(), 27u);
  c.nodes_b_in_a.clear();  // compare the A-in-B direction only
  c.edges_b_in_a.clear();
  ResponseOptions o = paper();
  o.kind = ResponseKind::kPoint;
  const PairResponse point = respond(a, b, c, o);
  o.kind = ResponseKind::kSegment;
  const PairResponse segment = respond(a, b, c, o);
  EXPECT_EQ(segment.stats.segment_contacts, c.edges_a_in_b.size());
  const Vec3 fp = total_force(point.a), fs = total_force(segment.a);
  EXPECT_NEAR((fp - fs).norm(), 0.0, 1e-12 * fp.norm());
  EXPECT_NEAR((fp.normalized() - Vec3(-0.8, 0, 0.6)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((total_force(point.b) - total_force(segment.b)).norm(), 0.0, 1e-12 * fp.norm());
}

// ---- kAuto --------------------------------------------------------------------------

TEST(AutoRule, ThresholdOnEdgeLengthOverContactExtent) {
  EXPECT_EQ(choose_response_kind(ResponseKind::kAuto, {0.3, 1.0}, 0.25), ResponseKind::kSegment);
  EXPECT_EQ(choose_response_kind(ResponseKind::kAuto, {0.2, 1.0}, 0.25), ResponseKind::kPoint);
  EXPECT_EQ(choose_response_kind(ResponseKind::kAuto, {0.2, 0.0}, 0.25), ResponseKind::kSegment);
  EXPECT_EQ(choose_response_kind(ResponseKind::kAuto, {0.0, 0.0}, 0.25), ResponseKind::kPoint);
  EXPECT_EQ(choose_response_kind(ResponseKind::kPoint, {9.0, 1.0}, 0.25), ResponseKind::kPoint);
  EXPECT_EQ(choose_response_kind(ResponseKind::kSegment, {0.0, 1.0}, 0.25), ResponseKind::kSegment);
}

TEST(AutoRule, CoarseBoxOnFineBoxUsesSegmentsFineBoxUsesPoints) {
  ResponseOptions o;  // kAuto
  // The contact density of box_pair(0.05, 0.21, cells_a) and the kind the response used.
  const auto density_and_kind = [&](int cells_a) {
    const BoxPair p = box_pair(0.05, 0.21, cells_a);
    const PairContacts c = test::brute_force_contacts(p.a, p.b);
    const ContactDensity d =
        measure_contact_density(p.a.view(), c.marked_a, p.b.view(), c.marked_b);
    return std::make_pair(d, respond(p.a, p.b, c, o).used_a_in_b);
  };
  const auto [dc, coarse_kind] = density_and_kind(1);
  EXPECT_GT(dc.rms_edge, o.auto_threshold * dc.contact_extent);
  EXPECT_EQ(coarse_kind, ResponseKind::kSegment);
  const auto [df, fine_kind] = density_and_kind(7);
  EXPECT_LT(df.rms_edge, o.auto_threshold * df.contact_extent);
  EXPECT_EQ(fine_kind, ResponseKind::kPoint);
  // The measured extent is the contact patch, not the objects: about the diagonal of
  // A's footprint.
  EXPECT_NEAR(df.contact_extent, std::sqrt(2.0) * 0.42, 0.1);
}

TEST(AutoRule, ResponseKindsAreTheKindsTheResponseUses) {
  // The pipeline asks response_kinds() before the intrusion scans to skip the edges of
  // point directions: it must be the response's own choice, direction by direction.
  for (const int cells : {1, 2, 7}) {
    const BoxPair pair = box_pair(0.05, 0.21, cells);
    const PairContacts c = test::brute_force_contacts(pair.a, pair.b);
    for (const ResponseKind kind :
         {ResponseKind::kPoint, ResponseKind::kSegment, ResponseKind::kAuto}) {
      ResponseOptions o;
      o.kind = kind;
      const PairResponse r = respond(pair.a, pair.b, c, o);
      const std::array<ResponseKind, 2> kinds =
          response_kinds(pair.a.view(), c.marked_a, pair.b.view(), c.marked_b, o);
      EXPECT_EQ(kinds[0], r.used_a_in_b) << cells << " cells";
      EXPECT_EQ(kinds[1], r.used_b_in_a) << cells << " cells";
      if (kind != ResponseKind::kAuto) {
        EXPECT_EQ(kinds[0], kind);
      }
    }
  }
}

TEST(AutoRule, DecidedKindsAreUsedAsGivenAndChecked) {
  // The pipeline hands the response the kinds it decided before detection's edge scans:
  // the response takes them without measuring again, and refuses kAuto among them.
  const BoxPair pair = box_pair(0.05, 0.21, 2);
  const PairContacts c = test::brute_force_contacts(pair.a, pair.b);
  ResponseOptions o;  // kAuto, not read
  o.decided_kinds = std::array<ResponseKind, 2>{ResponseKind::kSegment, ResponseKind::kPoint};
  const PairResponse r = respond(pair.a, pair.b, c, o);
  EXPECT_EQ(r.used_a_in_b, ResponseKind::kSegment);
  EXPECT_EQ(r.used_b_in_a, ResponseKind::kPoint);
  o.decided_kinds = std::array<ResponseKind, 2>{ResponseKind::kPoint, ResponseKind::kAuto};
  const auto bad = compute_pair_response(pair.a.view(), pair.b.view(), c, o);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("decided_kinds"), std::string::npos) << bad.error().message;
}

// ---- Deep penetration ----------------------------------------------------------------

TEST(DeepPenetration, ABoxWhollyInsideIsPushedTowardTheNearestFace) {
  const Vec3 lo_b(-1, -1, -1), hi_b(1, 1, 1);
  TestObject b(test::structured_box(6, 6, 6, lo_b, hi_b));
  b.set_depth([&](const Vec3& x) { return test::box_depth(x, lo_b, hi_b); });
  const Vec3 lo_a(0.35, -0.08, -0.07), hi_a(0.55, 0.12, 0.13);
  TestObject a(test::structured_box(2, 2, 2, lo_a, hi_a));
  a.set_depth([&](const Vec3& x) { return test::box_depth(x, lo_a, hi_a); });
  const PairContacts c = test::brute_force_contacts(a, b);
  ASSERT_EQ(c.nodes_a_in_b.size(), 27u);
  for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
    ResponseOptions o = paper();
    o.kind = kind;
    const PairResponse r = respond(a, b, c, o);
    const Vec3 f = total_force(r.a);
    EXPECT_GT(f.x(), 2.0 * (std::abs(f.y()) + std::abs(f.z())));
    EXPECT_GT(r.stats.max_depth, 0.4);
    expect_pair_balanced(r);
  }
}

TEST(DeepPenetration, EqualDepthsFarFromTheBoundaryFallBackToThePairDirection) {
  // A plateau of equal depths (as an approximate depth map can give deep inside): no
  // gradient, no boundary face within a ring of tets. The push goes from B's contact
  // centre towards A's.
  TestObject b(test::structured_box(7, 7, 7, {-1, -1, -1}, {1, 1, 1}));
  std::fill(b.depth.begin(), b.depth.end(), 1.0);
  TestObject a(test::structured_box(1, 1, 1, {0.02, -0.05, -0.05}, {0.12, 0.05, 0.05}));
  const PairContacts c = test::brute_force_contacts(a, b);
  ASSERT_EQ(c.nodes_a_in_b.size(), 8u);
  ASSERT_TRUE(c.nodes_b_in_a.empty());
  ResponseOptions o = paper();
  o.kind = ResponseKind::kPoint;
  const PairResponse r = respond(a, b, c, o);
  EXPECT_EQ(r.stats.fallback_pair, 8u);
  EXPECT_EQ(r.stats.fallback_axis, 0u);
  const Vec3 f = total_force(r.a);
  EXPECT_GT(f.x(), 0.7 * f.norm());
  expect_pair_balanced(r);
}

// ---- Determinism ---------------------------------------------------------------------

TEST(Determinism, BitIdenticalAcrossThreadCountsAndRuns) {
  const BoxPair p = box_pair(0.07, 0.27, 6);
  const PairContacts c = test::brute_force_contacts(p.a, p.b);
  ASSERT_GT(c.edges_a_in_b.size(), 200u);
  const auto same = [](const ObjectForces& x, const ObjectForces& y) {
    return x.nodes == y.nodes && x.forces.size() == y.forces.size() &&
           std::memcmp(x.forces.data(), y.forces.data(), x.forces.size() * sizeof(Vec3)) == 0 &&
           x.stiffness.size() == y.stiffness.size() &&
           std::memcmp(x.stiffness.data(), y.stiffness.data(), x.stiffness.size() * sizeof(Mat3)) ==
               0;
  };
  for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
    ResponseOptions o;
    o.kind = kind;
    o.stiffness_mode = StiffnessMode::kExact;
    o.parallel_threshold = std::size_t(-1);  // serial reference
    const PairResponse serial = respond(p.a, p.b, c, o);
    ASSERT_FALSE(serial.a.nodes.empty());
    o.parallel_threshold = 1;
    ResponseAccumulator reused;
    PairResponse r;  // reused too: cleared, not reallocated
    for (const int threads : {1, 2}) {
      tbb::task_arena arena(threads);
      for (int run = 0; run < 2; ++run) {
        arena.execute([&] { ASSERT_TRUE(reused.compute(p.a.view(), p.b.view(), c, o, r)); });
        EXPECT_TRUE(same(r.a, serial.a)) << threads;
        EXPECT_TRUE(same(r.b, serial.b)) << threads;
      }
    }
  }
}

// ---- Merge, cap, validation, options --------------------------------------------------

TEST(Accumulation, SortedMergeEqualsADenseSum) {
  std::mt19937 rng(4);
  std::uniform_int_distribution<Index> node(0, 49);
  std::normal_distribution<double> val(0.0, 1.0);
  std::vector<Vec3> dense(50, Vec3::Zero());
  std::vector<Mat3> dense_k(50, Mat3::Zero());
  ObjectForces total;
  for (int part = 0; part < 6; ++part) {
    ObjectForces f;
    for (Index i = 0; i < 50; ++i)
      if (node(rng) < 15) {
        f.nodes.push_back(i);
        f.forces.emplace_back(val(rng), val(rng), val(rng));
        f.stiffness.push_back(Mat3::Random());
        dense[i] += f.forces.back();
        dense_k[i] += f.stiffness.back();
      }
    add_object_forces(total, f);
  }
  ASSERT_TRUE(std::is_sorted(total.nodes.begin(), total.nodes.end()));
  ASSERT_EQ(total.stiffness.size(), total.nodes.size());
  for (std::size_t j = 0; j < total.nodes.size(); ++j) {
    EXPECT_NEAR((total.forces[j] - dense[total.nodes[j]]).norm(), 0.0, 1e-12);
    EXPECT_NEAR((total.stiffness[j] - dense_k[total.nodes[j]]).norm(), 0.0, 1e-12);
  }
  for (Index i = 0; i < 50; ++i)
    if (!std::binary_search(total.nodes.begin(), total.nodes.end(), i)) {
      EXPECT_TRUE(dense[i].isZero());
    }
}

TEST(Accumulation, CapLimitsMagnitudesAndDifferentiatesTheCappedForce) {
  ObjectForces f;
  f.nodes = {1, 4, 9};
  f.forces = {Vec3(3, 4, 0), Vec3(0.1, 0, 0), Vec3(0, 0, -20)};
  const Mat3 k = (Mat3() << -5, 1, 0, 1, -3, 0.5, 0, 0.5, -2).finished();
  f.stiffness = {k, k, k};
  ObjectForces capped = f;
  EXPECT_EQ(cap_object_forces(capped, 2.0), 2u);
  EXPECT_NEAR(capped.forces[0].norm(), 2.0, 1e-15);
  EXPECT_EQ(capped.forces[1], f.forces[1]);
  EXPECT_NEAR((capped.forces[2] - Vec3(0, 0, -2)).norm(), 0.0, 1e-15);
  // Capped block = derivative of cap(f0 + K dx) at dx = 0.
  const auto cap = [](const Vec3& v) { return v.norm() > 2.0 ? Vec3(2.0 * v.normalized()) : v; };
  const double h = 1e-7;
  Mat3 fd;
  for (int c = 0; c < 3; ++c)
    fd.col(c) = (cap(f.forces[0] + h * k.col(c)) - cap(f.forces[0] - h * k.col(c))) / (2 * h);
  EXPECT_NEAR((fd - capped.stiffness[0]).norm(), 0.0, 1e-6);
  EXPECT_EQ(cap_object_forces(capped, 0.0), 0u);  // 0 = no cap
}

TEST(Validation, BadInputIsRejectedWithTheIndexAtFault) {
  const BoxPair p = box_pair(0.05, 0.21);
  const PairContacts good = test::brute_force_contacts(p.a, p.b);
  ResponseOptions o;
  o.kind = ResponseKind::kPoint;
  const auto error_of = [&](const PairContacts& c, const ResponseOptions& opt,
                            const ResponseObject& a) {
    const auto r = compute_pair_response(a, p.b.view(), c, opt);
    return r ? std::string() : r.error().message;
  };
  PairContacts c = good;
  c.nodes_a_in_b[3].tet = 100000;
  EXPECT_NE(error_of(c, o, p.a.view()).find("nodes_a_in_b[3]: tet 100000"), std::string::npos);
  c = good;
  c.nodes_b_in_a[0].node = -1;
  EXPECT_NE(error_of(c, o, p.a.view()).find("nodes_b_in_a[0]: node -1"), std::string::npos);
  ResponseOptions seg = o;
  seg.kind = ResponseKind::kSegment;
  c = good;
  c.edges_a_in_b[2].edge = 1 << 30;
  EXPECT_NE(error_of(c, seg, p.a.view()).find("edges_a_in_b[2]: edge"), std::string::npos);
  c = good;
  c.edges_a_in_b[1].lambda_out = 1.5;
  EXPECT_NE(error_of(c, seg, p.a.view()).find("edges_a_in_b[1]"), std::string::npos);
  c = good;
  c.marked_b.push_back(-3);
  EXPECT_NE(error_of(c, o, p.a.view()).find("marked_b"), std::string::npos);
  ResponseObject short_depth = p.a.view();
  short_depth.depth = short_depth.depth.subspan(1);
  EXPECT_NE(error_of(good, o, short_depth).find("depth"), std::string::npos);
  ResponseOptions negative = o;
  negative.stiffness = -1.0;
  EXPECT_NE(error_of(good, negative, p.a.view()).find("stiffness"), std::string::npos);
  // A NaN lambda is not an error: that contact is skipped and counted.
  c = good;
  c.edges_a_in_b[0].lambda_in = std::nan("");
  const auto r = compute_pair_response(p.a.view(), p.b.view(), c, seg);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->stats.skipped, 1u);
}

TEST(Validation, NoOverlapCostsNothing) {
  const BoxPair p = box_pair(-0.1, 0.21);  // A above B, apart
  const PairContacts c = test::brute_force_contacts(p.a, p.b);
  EXPECT_TRUE(c.empty());
  const PairResponse r = respond(p.a, p.b, c, {});
  EXPECT_TRUE(r.a.nodes.empty());
  EXPECT_TRUE(r.b.nodes.empty());
  EXPECT_EQ(r.stats.point_contacts + r.stats.segment_contacts + r.stats.inactive, 0u);
}

// ---- Stiff sweep ------------------------------------------------------------------------

/// A rigid box A (1 kg, 0.6 m, one cell) dropped from rest onto a static box B under
/// gravity, integrated by backward Euler with Newton iterations on the velocity; the
/// Jacobian uses the returned lumped stiffness blocks. Returns the mean penetration over
/// the last `average` seconds.
struct DropResult {
  double mean_penetration = 0.0;
  double max_speed = 0.0;
  double final_speed = 0.0;
  int unconverged_steps = 0;
  bool finite = true;
};

DropResult drop(double k, ResponseKind kind, double duration = 0.6, double average = 0.3) {
  const Vec3 lo_b(-1, -1, -1), hi_b(1, 1, 0);
  TestObject b(test::structured_box(4, 4, 2, lo_b, hi_b));
  b.set_depth([&](const Vec3& x) { return test::box_depth(x, lo_b, hi_b); });
  const Vec3 lo_a(-0.3, -0.3, 0.0), hi_a(0.3, 0.3, 0.6);
  TestObject a(test::structured_box(1, 1, 1, lo_a, hi_a));
  a.set_depth([&](const Vec3& x) { return test::box_depth(x, lo_a, hi_a); });
  const Positions rest = a.mesh.positions;
  ResponseOptions o;
  o.kind = kind;
  o.stiffness = k;
  o.stiffness_mode = StiffnessMode::kLumped;
  ResponseAccumulator acc;
  PairResponse r;
  const double mass = 1.0, h = 1e-3;
  const Vec3 gravity(0, 0, -9.81);
  Vec3 t(0, 0, 1e-9), v = Vec3::Zero();
  DropResult out;
  double sum = 0.0;
  int samples = 0;
  const int steps = static_cast<int>(duration / h + 0.5);
  for (int step = 0; step < steps; ++step) {
    Vec3 v_new = v;
    bool converged = false;
    for (int iter = 0; iter < 30 && !converged; ++iter) {
      const Vec3 x = t + h * v_new;
      a.mesh.positions = rest.colwise() + x;
      const PairContacts c = test::brute_force_contacts(a, b);
      EXPECT_TRUE(acc.compute(a.view(), b.view(), c, o, r));
      Vec3 force = mass * gravity;
      Mat3 stiffness = Mat3::Zero();
      for (std::size_t j = 0; j < r.a.nodes.size(); ++j) {
        force += r.a.forces[j];
        stiffness += r.a.stiffness[j];
      }
      const Vec3 residual = mass * (v_new - v) - h * force;
      const Mat3 jacobian = mass * Mat3::Identity() - h * h * stiffness;
      const Vec3 dv = jacobian.partialPivLu().solve(-residual);
      v_new += dv;
      converged = dv.norm() <= 1e-10 * (1.0 + v_new.norm());
    }
    out.unconverged_steps += !converged;
    v = v_new;
    t += h * v;
    out.finite = out.finite && t.allFinite() && v.allFinite();
    if (!out.finite) break;
    out.max_speed = std::max(out.max_speed, v.norm());
    if (step * h >= duration - average) {
      sum += std::max(0.0, -t.z());
      ++samples;
    }
  }
  out.mean_penetration = samples ? sum / samples : 0.0;
  out.final_speed = v.norm();
  return out;
}

class StiffSweep : public ::testing::TestWithParam<ResponseKind> {};

TEST_P(StiffSweep, BackwardEulerRestsWithPenetrationShrinkingAsStiffnessGrows) {
  double previous = std::numeric_limits<double>::infinity();
  std::vector<double> depth_times_k;
  for (const double k : {1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8}) {
    const DropResult d = drop(k, GetParam());
    ASSERT_TRUE(d.finite) << k;
    EXPECT_LT(d.max_speed, 1.0) << k;  // dropped from rest: no blow-up, no launch
    EXPECT_LE(d.unconverged_steps, 6) << k;
    EXPECT_GT(d.mean_penetration, 0.0) << k;
    EXPECT_LT(d.mean_penetration, previous) << k;
    if (k >= 1e4) {
      EXPECT_LT(d.final_speed, 1e-3) << k;  // at rest
    }
    previous = d.mean_penetration;
    depth_times_k.push_back(d.mean_penetration * k);
    std::printf("  k %8.0e  mean penetration %.3e m  k*pen %.3f  max speed %.3f m/s\n", k,
                d.mean_penetration, d.mean_penetration * k, d.max_speed);
  }
  EXPECT_LT(previous, 1e-6);
  // Equilibrium k * (sum of weights) * depth = m g: depth ~ 1/k over six decades.
  const auto [lo, hi] = std::minmax_element(depth_times_k.begin(), depth_times_k.end());
  EXPECT_LT(*hi / *lo, 2.0);
}

INSTANTIATE_TEST_SUITE_P(PointAndSegment, StiffSweep,
                         ::testing::Values(ResponseKind::kPoint, ResponseKind::kSegment));

TEST(ResponseKindNames, ParseIsTheInverseOfTheName) {
  for (const ResponseKind k : {ResponseKind::kPoint, ResponseKind::kSegment, ResponseKind::kAuto})
    EXPECT_EQ(parse_response_kind(response_kind_name(k)), k);
  EXPECT_EQ(parse_response_kind("segment"), ResponseKind::kSegment);
  EXPECT_FALSE(parse_response_kind("Point").has_value());
  EXPECT_FALSE(parse_response_kind("").has_value());
}

}  // namespace
}  // namespace tc
