// service/core/mesh/shape_check: the per-frame shape check that pays for what moved gives
// the full check's reports, and its motion radii are proven.
#include "core/mesh/shape_check.hpp"

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include <tbb/global_control.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "core/common/cpu_dispatch.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/topology.hpp"
#include "kernel_copies.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

ValidationOptions frame_options() {
  ValidationOptions o;
  o.compute_min_quality = false;
  return o;
}

void expect_same_list(const DefectList& a, const DefectList& b, const char* what) {
  EXPECT_EQ(a.count, b.count) << what;
  EXPECT_EQ(a.first, b.first) << what;
}

void expect_same_report(const ValidationReport& got, const ValidationReport& want) {
  expect_same_list(got.index_out_of_range, want.index_out_of_range, "index_out_of_range");
  expect_same_list(got.repeated_node, want.repeated_node, "repeated_node");
  expect_same_list(got.nonfinite_node, want.nonfinite_node, "nonfinite_node");
  expect_same_list(got.degenerate, want.degenerate, "degenerate");
  expect_same_list(got.inverted, want.inverted, "inverted");
  expect_same_list(got.sliver, want.sliver, "sliver");
  // NaN (not computed) after a shape check, 1 after a non-finite coordinate.
  if (!(std::isnan(got.min_quality) && std::isnan(want.min_quality))) {
    EXPECT_EQ(got.min_quality, want.min_quality);
  }
}

/// A mesh with its check order and topology, and a ShapeCheck on them.
struct Fixture {
  explicit Fixture(TetMesh m)
      : mesh(std::move(m)),
        order(make_tet_check_order(mesh.positions, mesh.tets)),
        topology(build_topology(mesh.tets, mesh.num_nodes())),
        check(order, topology.node_tets, mesh.num_nodes(), frame_options()) {}

  /// check() and validate_positions() agree on `x`; returns check()'s report.
  ValidationReport both(const Positions& x) {
    const ValidationReport got = check.check(x);
    expect_same_report(got, validate_positions(x, order, frame_options()));
    return got;
  }

  TetMesh mesh;
  TetCheckOrder order;
  Topology topology;
  ShapeCheck check;
};

Eigen::Vector3d random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Vector3d v(g(rng), g(rng), g(rng));
  return v.normalized();
}

// The radii with each copy of their kernel (AVX2, baseline).
class CertifiedMotionRadius : public test::BothKernels {};

TEST_P(CertifiedMotionRadius, ARegularTetMayMoveAFewPercentOfItsEdge) {
  const TetMesh m = test::regular_tet();
  const Tet t = m.tets[0];
  const double edge = std::sqrt(8.0);
  const double r = certified_motion_radius(m.positions, t, 0.01);
  EXPECT_GT(r, 0.05 * edge);  // useful: a good tet is not rechecked for small motions
  EXPECT_LT(r, 0.25 * edge);  // and sound: at 0.29 edge the tet can be flat
  // Scale-free: the same fraction at any size and offset.
  Positions far = m.positions * 1e-3;
  far.colwise() += Eigen::Vector3d(50, -20, 7);
  EXPECT_NEAR(certified_motion_radius(far, t, 0.01), 1e-3 * r, 1e-9 * r);
}

// Only for tets whose quality is computed without overflow or underflow: edges between
// about 1e-67 m and 1e66 m. At 1e-105 m, l2^1.5 is a subnormal number in tet_quality(),
// at 1e90 m the squared gradients here are infinite; the full check decides such tets.
TEST_P(CertifiedMotionRadius, OnlyForTetsOfAMeasurableSize) {
  const TetMesh m = test::regular_tet();
  const Tet t = m.tets[0];
  const double r = certified_motion_radius(m.positions, t, 0.01);
  for (const double scale : {1e-60, 1e-30, 1e30, 1e60}) {
    SCOPED_TRACE(scale);
    EXPECT_NEAR(certified_motion_radius(scale * m.positions, t, 0.01), scale * r, 1e-9 * scale * r);
  }
  for (const double scale : {1e-105, 1e-80, 1e70, 1e90, 1e200}) {
    SCOPED_TRACE(scale);
    EXPECT_EQ(certified_motion_radius(scale * m.positions, t, 0.01), -1.0);
  }
}

TEST_P(CertifiedMotionRadius, NoMotionWithinItLeavesAGoodTet) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int tested = 0;
  double worst = std::numeric_limits<double>::infinity();
  while (tested < 400) {
    Positions p(3, 4);
    for (int j = 0; j < 4; ++j) p.col(j) << u(rng), u(rng), u(rng);
    Tet t{0, 1, 2, 3};
    if (signed_volume(p, t) < 0) std::swap(t[0], t[1]);
    const double q = tet_quality(p, t);
    const double r = certified_motion_radius(p, t, 0.01);
    if (q < 0.01001) {  // below the radii's margin (1.001 * 0.01 + 1e-6)
      EXPECT_LT(r, 0.0) << "quality " << q;
      continue;
    }
    if (r < 0.0) continue;  // just above the threshold: within the margin
    ++tested;
    // The motions that flatten the tet fastest move each node by r against the gradient
    // of its volume; then random directions, all at full length.
    const Eigen::Vector3d e1 = p.col(t[1]) - p.col(t[0]), e2 = p.col(t[2]) - p.col(t[0]),
                          e3 = p.col(t[3]) - p.col(t[0]);
    const Eigen::Vector3d g1 = e2.cross(e3), g2 = e3.cross(e1), g3 = e1.cross(e2);
    const Eigen::Vector3d g[4] = {-(g1 + g2 + g3), g1, g2, g3};
    for (int trial = 0; trial < 200; ++trial) {
      Positions moved = p;
      for (int j = 0; j < 4; ++j) {
        const Eigen::Vector3d dir =
            trial == 0 ? Eigen::Vector3d(-g[j].normalized()) : random_unit(rng);
        moved.col(t[static_cast<std::size_t>(j)]) += r * dir;
      }
      const double q2 = tet_quality(moved, t);
      worst = std::min(worst, q2);
      ASSERT_GE(q2, 0.01) << "quality " << q << " radius " << r << " trial " << trial;
    }
  }
  EXPECT_GT(worst, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Kernels, CertifiedMotionRadius, ::testing::Bool(), test::kernel_copy_name);

TEST(ShapeCheck, TheSameReportsAsTheFullCheckForEveryKindOfMotion) {
  Fixture f(test::structured_box(6, 5, 4, {0, 0, 0}, {0.6, 0.5, 0.4}));
  const Positions rest = f.mesh.positions;
  const std::size_t m = f.mesh.tets.size();

  f.both(rest);  // the first state: every tet, and the reference
  EXPECT_TRUE(f.check.last().full);
  EXPECT_TRUE(f.check.last().rebuilt);

  f.both(rest);  // still: nothing moved, nothing checked
  EXPECT_FALSE(f.check.last().full);
  EXPECT_EQ(f.check.last().moved_nodes, 0u);
  EXPECT_EQ(f.check.last().checked_tets, 0u);

  Positions shifted = rest;
  shifted.colwise() += Eigen::Vector3d(3.0, -1.0, 0.25);  // a translation changes no shape
  f.both(shifted);
  EXPECT_EQ(f.check.last().checked_tets, 0u);

  // A local dent: the tets around one node only.
  Positions dent = shifted;
  const Index node = 60;
  dent(2, node) -= 0.02;
  f.both(dent);
  EXPECT_EQ(f.check.last().moved_nodes, 1u);
  EXPECT_EQ(f.check.last().checked_tets,
            static_cast<std::size_t>(f.topology.node_tets.row(node).size()));

  // The same node pushed through its neighbours: inverted tets, named as by the full check.
  Positions through = dent;
  through(2, node) -= 0.3;
  const ValidationReport bad = f.both(through);
  EXPECT_GT(bad.inverted.count, 0u);
  EXPECT_FALSE(f.check.last().full);
  // A rejected state does not become the reference: the dent is still compared with it.
  f.both(dent);
  EXPECT_EQ(f.check.last().moved_nodes, 0u);

  // A NaN anywhere, an infinite coordinate.
  Positions nan = dent;
  nan(1, 7) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(f.both(nan).nonfinite_node.count, 1u);
  Positions inf = dent;
  inf(0, 3) = std::numeric_limits<double>::infinity();
  inf(0, 9) = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(f.both(inf).nonfinite_node.count, 2u);

  // A node moved towards a face until its tets are slivers, then degenerate.
  for (const double depth : {0.05, 0.08, 0.0999, 0.1}) {
    Positions flat = dent;
    flat(2, 61) -= depth;
    f.both(flat);
  }

  // Back to the dent: node 61 (taken nearly flat) moved back, and its tets have radii
  // again.
  f.both(dent);

  // A rotation moves every node, but changes no shape: the nodes are compared after the
  // turn and shift that fit them best, and no tet is checked.
  const double a = 0.3;
  Eigen::Matrix3d rot;
  rot << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  const Positions turned = rot * dent;
  f.both(turned);
  EXPECT_FALSE(f.check.last().full);
  EXPECT_TRUE(f.check.last().rotated);
  EXPECT_TRUE(f.check.last().bounded);
  EXPECT_EQ(f.check.last().checked_tets, 0u);
  EXPECT_FALSE(f.check.last().rebuilt);
  // (Not the turn to rounding: the references of the nodes that moved before were taken
  // less that state's shift, the mean displacement, which their own motion pulled.)
  EXPECT_LT((f.check.last().rotation - rot).norm(), 1e-3);
  f.both(turned);
  EXPECT_EQ(f.check.last().checked_tets, 0u);
  EXPECT_TRUE(f.check.last().rotated);  // still turned from the reference

  // Turned further with a dent: the dent's tets only.
  Positions turned_dent =
      Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix() * turned;
  turned_dent(0, 80) += 0.03;
  f.both(turned_dent);
  EXPECT_FALSE(f.check.last().full);
  EXPECT_TRUE(f.check.last().rotated);
  EXPECT_EQ(f.check.last().moved_nodes, 1u);
  EXPECT_EQ(f.check.last().checked_tets,
            static_cast<std::size_t>(f.topology.node_tets.row(80).size()));
  // Turned further with the whole top layer raised (a fifth of the nodes): a least-squares
  // fit to every node would be pulled up by a fifth of the rise, and leave the other
  // nodes beyond their radii; fitted again to the nodes within, only the layer moved.
  Positions raised = turned_dent;
  std::size_t layer = 0;
  for (Index i = 0; i < raised.cols(); ++i)
    if (rest(2, i) == 0.4) {
      raised.col(i) += 0.06 * (rot * Eigen::Vector3d::UnitZ());
      ++layer;
    }
  raised = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix() * raised;
  ASSERT_TRUE(f.both(raised).clean());
  EXPECT_FALSE(f.check.last().full);
  EXPECT_EQ(f.check.last().moved_nodes, layer);
  f.both(turned_dent);  // and back

  // The dented node pushed through its neighbours while turning: rejected as the full
  // check rejects it, not taken as a rigid motion.
  Positions turned_through = turned_dent;
  turned_through(0, 80) += 0.4;
  EXPECT_GT(f.both(turned_through).inverted.count, 0u);
  // A mirror image is no rotation: every tet inverted, found by the full check.
  Positions mirrored = turned_dent;
  mirrored.row(0) *= -1.0;
  EXPECT_EQ(f.both(mirrored).inverted.count, m);
  EXPECT_TRUE(f.check.last().full);
  // A large deformation of every node (a shear) is no rigid motion either: every tet.
  Positions sheared = turned_dent;
  sheared.row(0) += 0.5 * sheared.row(2);
  f.both(sheared);
  EXPECT_TRUE(f.check.last().full);
  EXPECT_EQ(f.check.last().checked_tets, m);
}

// A node in no tet parked far away (1e39 m) drags the mean displacement and the fitted
// centroid there: the motion test then takes differences of numbers that size, whose
// rounding (about 1e22 m) hid a motion along that way, one that inverts the tet too. The
// test leaves room for its rounding now, so such a node cannot hide a motion, and the fit
// leaves it out. (Found by the fuzz target `mesh`: fuzz/regressions/mesh/far_orphan_*.)
TEST(ShapeCheck, ANodeFarAwayHidesNoMotionInItsRounding) {
  TetMesh mesh;
  mesh.positions.resize(3, 5);
  mesh.positions << 0, 1, 0, 0, 0,  //
      0, 0, 1, 0, -1e39,            //
      0, 0, 0, 1, 0;
  mesh.node_ids = {1, 2, 3, 4, 5};
  mesh.tets = {Tet{0, 1, 2, 3}};  // node 4 is in no tet
  Fixture f(std::move(mesh));
  const Positions rest = f.mesh.positions;
  ASSERT_TRUE(f.both(rest).clean());
  for (const double y : {0.5, -0.5, -1.0, 0.3}) {  // node 2 on the way through
    SCOPED_TRACE(y);
    Positions x = rest;
    x(1, 2) = y;
    f.both(x);
  }
  // Everything carried along too.
  Positions through = rest;
  through(1, 2) = -1.0;
  through.colwise() += Eigen::Vector3d(0.01, 0.02, -0.03);
  EXPECT_EQ(f.both(through).inverted.count, 1u);
  // The last clean state (node 2 at y = 0.3) turned while the parked node stays: the fit
  // leaves out nodes in no tet, so the tet is compared after its turn, and no tet is
  // checked.
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  Positions turned = rest;
  turned(1, 2) = 0.3;
  turned.leftCols(4) = (rot * turned.leftCols(4)).eval();
  ASSERT_TRUE(f.both(turned).clean());
  EXPECT_TRUE(f.check.last().rotated);
  EXPECT_FALSE(f.check.last().full);
  EXPECT_EQ(f.check.last().checked_tets, 0u);
  turned(1, 2) -= 2.0;  // and node 2 pushed through while turning
  EXPECT_EQ(f.both(turned).inverted.count, 1u);
  // The parked node moved a long way, the tet still: it pulls the mean shift, and the fit,
  // which leaves it out, finds that nothing else moved.
  for (const double to : {1e6, 1e30}) {
    Positions parked_moved = turned;
    parked_moved(1, 2) += 2.0;
    parked_moved(0, 4) = to;
    ASSERT_TRUE(f.both(parked_moved).clean());
    EXPECT_FALSE(f.check.last().full);
    EXPECT_EQ(f.check.last().checked_tets, 0u);
  }
}

// A tet carried 1e17 m away: every coordinate is then a multiple of 16 m, and its nodes
// fall on one point (degenerate). Each x - q rounds to the mean shift exactly, so a test
// after the shift found no motion; a shift that far is beyond the room kept for rounding,
// and the fit (about the centroids) finds the motion.
TEST(ShapeCheck, AShiftFarBeyondTheObjectsSizeHidesNoMotionInItsRounding) {
  TetMesh mesh;
  mesh.positions.resize(3, 4);
  mesh.positions << 0, 1, 0, 0,  //
      0, 0, 1, 0,                //
      0, 0, 0, 1;
  mesh.node_ids = {1, 2, 3, 4};
  mesh.tets = {Tet{0, 1, 2, 3}};
  Fixture f(std::move(mesh));
  const Positions rest = f.mesh.positions;
  ASSERT_TRUE(f.both(rest).clean());
  for (const double far : {1e3, 1e17, 1e30}) {
    SCOPED_TRACE(far);
    const Positions x = rest.array() + far;
    f.both(x);
  }
}

// A large object (sampled: over 8,192 nodes) turning a little every frame, as a tool or an
// organ carried along does, with a dent pressed into it on the way: after the first turn,
// no state is a full check, only the dent's tets are checked, and the reports are the full
// check's. Then it stops turning and is translated: still no full check.
TEST(ShapeCheck, ALargeObjectTurningIsComparedAfterItsTurn) {
  Fixture f(test::structured_box(22, 22, 22, {0, 0, 0}, {0.2, 0.2, 0.2}));  // 12,167 nodes
  const Positions rest = f.mesh.positions;
  const Index n = f.mesh.num_nodes();
  ASSERT_GT(n, 8192);
  f.both(rest);
  Index top = 0;  // the top node nearest the middle of the top face
  for (Index i = 0; i < n; ++i)
    if ((rest.col(i) - Eigen::Vector3d(0.1, 0.1, 0.2)).norm() <
        (rest.col(top) - Eigen::Vector3d(0.1, 0.1, 0.2)).norm())
      top = i;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  int full = 0, rotated = 0;
  std::size_t checked = 0;
  for (int frame = 1; frame <= 24; ++frame) {
    SCOPED_TRACE(frame);
    Positions x = rest;
    const double press = 0.004 * std::sin(0.3 * frame);  // the dent in and out
    for (Index i = 0; i < n; ++i) {
      const double d = (rest.col(i) - rest.col(top)).norm() / 0.03;
      if (d < 1.0) x(2, i) -= std::max(press, 0.0) * (1.0 - d);
    }
    const double angle = frame <= 16 ? 0.02 * frame : 0.32;
    const Eigen::Vector3d shift(0.01 * frame, -0.3, 0.002 * frame * frame);
    x = (Eigen::AngleAxisd(angle, axis).toRotationMatrix() * x).colwise() + shift;
    ASSERT_TRUE(f.both(x).clean());
    full += f.check.last().full ? 1 : 0;
    rotated += f.check.last().rotated ? 1 : 0;
    if (frame > 1) checked += f.check.last().checked_tets;
    EXPECT_TRUE(f.check.last().bounded);
  }
  EXPECT_EQ(full, 0);
  EXPECT_EQ(rotated, 24);
  // The tets of the dent's nodes (under 1% of the nodes, as it goes in and as it comes
  // back), far from all 63,888 tets a frame.
  EXPECT_LT(checked, 23u * static_cast<std::size_t>(f.mesh.tets.size()) / 10);
}

// An object turning slowly, a thousandth of a radian a frame: the shift alone leaves only
// a few nodes a frame beyond their radii, never a quarter. Before a turn was tried for
// those few, each was made its own reference after the shift alone, frame after frame; with
// references turned by different amounts no fit then held, and the pawn turning 0.05
// degrees a frame made a large share of its nodes their own references again every frame.
// Now, once a few nodes are beyond, the check fits the turn and compares after it: no full
// check, and the tets of a few nodes checked once at most. A large object (sampled) and a
// small one (its pass tells).
TEST(ShapeCheck, AnObjectTurningSlowlyIsComparedAfterItsTurn) {
  for (const int cells : {22, 9}) {
    SCOPED_TRACE(cells);
    Fixture f(test::structured_box(cells, cells, cells, {0, 0, 0}, {0.2, 0.2, 0.2}));
    const Positions rest = f.mesh.positions;
    f.both(rest);
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
    const Eigen::Vector3d middle(0.1, 0.1, 0.1);
    int full = 0, rotated = 0;
    std::size_t checked = 0, moved = 0;
    for (int frame = 1; frame <= 120; ++frame) {
      SCOPED_TRACE(frame);
      const Positions x =
          (Eigen::AngleAxisd(0.001 * frame, axis).toRotationMatrix() * (rest.colwise() - middle))
              .colwise() +
          (middle + Eigen::Vector3d(0.0002 * frame, 0.0, 0.0));
      ASSERT_TRUE(f.both(x).clean());
      full += f.check.last().full ? 1 : 0;
      rotated += f.check.last().rotated ? 1 : 0;
      checked += f.check.last().checked_tets;
      moved += f.check.last().moved_nodes;
    }
    EXPECT_EQ(full, 0);
    EXPECT_GT(rotated, 100);
    // Fewer than one tet in a thousand a frame, on average.
    EXPECT_LT(checked, 120u * f.mesh.tets.size() / 1000) << moved << " nodes moved";
  }
}

// The same slow turn with a dent pressed in and out every other frame (0.4% of the nodes,
// 4 mm deep): the nodes the dent moves are beyond after any motion, so the turn is kept only
// if it leaves clearly fewer beyond than the shift. It does: no full check, and the dent's
// tets checked a frame (about 320). The check before this rule checked 12,900 tets a frame
// here and fitted no turn.
TEST(ShapeCheck, ADentPressedWhileTurningSlowlyChecksTheDentOnly) {
  Fixture f(test::structured_box(22, 22, 22, {0, 0, 0}, {0.2, 0.2, 0.2}));
  const Positions rest = f.mesh.positions;
  const Index n = f.mesh.num_nodes();
  f.both(rest);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  const Eigen::Vector3d middle(0.1, 0.1, 0.1), top(0.1, 0.1, 0.2);
  Positions dented = rest;
  for (Index i = 0; i < n; ++i) {
    const double d = (rest.col(i) - top).norm() / 0.03;
    if (d < 1.0) dented(2, i) -= 0.004 * (1.0 - d);
  }
  int full = 0, rotated = 0;
  std::size_t checked = 0;
  for (int frame = 1; frame <= 120; ++frame) {
    SCOPED_TRACE(frame);
    const Positions& shape = frame % 2 == 1 ? dented : rest;
    const Positions x =
        (Eigen::AngleAxisd(0.001 * frame, axis).toRotationMatrix() * (shape.colwise() - middle))
            .colwise() +
        middle;
    ASSERT_TRUE(f.both(x).clean());
    full += f.check.last().full ? 1 : 0;
    rotated += f.check.last().rotated ? 1 : 0;
    checked += f.check.last().checked_tets;
  }
  EXPECT_EQ(full, 0);
  EXPECT_GT(rotated, 100);
  EXPECT_LT(checked, 120u * 1000u);
}

/// What ShapeCheck::bound() promises of a state `x` checked with the reference and radii
/// `reference`, `radius2` (version `version`): when bounded, every node that did not move
/// is within its radius of its reference moved by the shift, computed as check() computes
/// it, and keeps its reference; every node that moved gets x less the shift; the versions
/// follow on, and change exactly when something changed.
void expect_bound_holds(const MotionBound& b, std::uint64_t version, const Positions& reference,
                        const std::vector<double>& radius2, const Positions& x,
                        const ValidationReport& report) {
  EXPECT_EQ(b.version_before, version);
  if (!b.bounded) {
    EXPECT_EQ(b.version_after, b.version_before);
    EXPECT_TRUE(std::isinf(b.motion));
    return;
  }
  EXPECT_TRUE(report.clean());
  const Positions& q = *b.reference;
  if (b.rebuilt) {
    EXPECT_EQ(q, x);
    EXPECT_EQ(b.shift, Eigen::Vector3d::Zero());
    EXPECT_EQ(b.version_after, b.version_before + 1);
    EXPECT_EQ(b.motion, 0.0);
    return;
  }
  EXPECT_EQ(b.version_after, b.version_before + (b.moved.empty() ? 0 : 1));
  std::vector<bool> moved(static_cast<std::size_t>(x.cols()), false);
  for (const Index v : b.moved) moved[static_cast<std::size_t>(v)] = true;
  std::vector<bool> changed(moved.size(), false);
  for (const Index v : b.changed) changed[static_cast<std::size_t>(v)] = true;
  if (!b.rotated) {
    EXPECT_EQ(b.rotation, Eigen::Matrix3d::Identity());
  }
  // A proper rotation, to rounding.
  EXPECT_LT((b.rotation.transpose() * b.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_GT(b.rotation.determinant(), 0.0);
  if (!b.rotated) {
    EXPECT_EQ(b.pivot, Eigen::Vector3d::Zero());
  }
  const Eigen::Matrix3d& m = b.rotation;
  const Eigen::Vector3d& p = b.pivot;
  double most = 0.0;  // the largest d2 of a node that did not move: b.motion^2
  for (Index i = 0; i < x.cols(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (moved[k]) {
      EXPECT_TRUE(changed[k]) << i;
      // Turned back about the pivot: m^T u + p, the sums in this order.
      const Eigen::Vector3d u = x.col(i) - b.shift;
      for (int c = 0; c < 3; ++c) {
        const double want =
            b.rotated ? (m(0, c) * u[0] + m(1, c) * u[1] + m(2, c) * u[2]) + p[c] : u[c];
        EXPECT_EQ(q(c, i), want) << i;
      }
      continue;
    }
    EXPECT_EQ(q.col(i), reference.col(i)) << i;
    const Eigen::Vector3d r = reference.col(i) - p;  // after a turn: (x - s) - m (q - p)
    double d2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double d =
          b.rotated ? (x(c, i) - b.shift[c]) - (m(c, 0) * r[0] + m(c, 1) * r[1] + m(c, 2) * r[2])
                    : x(c, i) - reference(c, i) - b.shift[c];
      d2 += d * d;
    }
    EXPECT_LE(d2, radius2[k]) << i;
    most = std::max(most, d2);
    if (!changed[k]) {
      EXPECT_EQ(b.radius2[k], radius2[k]) << i;
    }
  }
  EXPECT_EQ(b.motion, std::sqrt(most));
}

using test::BothKernels;

TEST_P(BothKernels, ARandomWalkOfDeformationsGivesTheFullChecksReports) {
  // Each step moves a random patch of nodes by a random amount, from a hair to far beyond
  // an edge; some steps are rejected, others rotate or translate the whole object.
  Fixture f(test::ball_mesh(4, 0.2));
  std::mt19937_64 rng(2026);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Positions x = f.mesh.positions;
  f.both(x);
  const Index n = f.mesh.num_nodes();
  std::size_t incremental = 0, rejected = 0, bounded = 0, turned = 0;
  for (int step = 0; step < 400; ++step) {
    // The reference and radii before this check, which its bound speaks of.
    const MotionBound before = f.check.bound();
    const Positions reference = *before.reference;
    const std::vector<double> radius2(before.radius2.begin(), before.radius2.end());
    Positions next = x;
    const double kind = u(rng);
    if (kind < 0.05) {
      const double a = 0.05 * u(rng);
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(a, random_unit(rng)).toRotationMatrix();
      next = rot * x;
    } else if (kind < 0.1) {
      next.colwise() += 0.1 * random_unit(rng);
    } else {
      const Index centre = static_cast<Index>(u(rng) * n) % n;
      const double radius = 0.02 + 0.08 * u(rng);
      const double amount = 0.05 * std::pow(10.0, -4.0 * u(rng));  // 5e-6 .. 5e-2
      const Eigen::Vector3d dir = random_unit(rng);
      for (Index i = 0; i < n; ++i) {
        const double d = (x.col(i) - x.col(centre)).norm();
        if (d < radius) next.col(i) += amount * (1.0 - d / radius) * dir;
      }
      if (u(rng) < 0.05) next(static_cast<Index>(u(rng) * 3) % 3, centre) = std::nan("");
    }
    const ValidationReport r = f.both(next);
    if (!f.check.last().full) ++incremental;
    turned += f.check.last().rotated ? 1 : 0;
    expect_bound_holds(f.check.bound(), before.version_after, reference, radius2, next, r);
    bounded += f.check.bound().bounded ? 1 : 0;
    if (r.clean()) {
      x = next;
    } else {
      ++rejected;
    }
  }
  EXPECT_GT(incremental, 200u);  // the walk did exercise the incremental path
  EXPECT_GT(rejected, 5u);       // and states that must be rejected
  EXPECT_GT(bounded, 300u);      // and bounds
  EXPECT_GT(turned, 100u);       // turned ones among them
}

INSTANTIATE_TEST_SUITE_P(ShapeCheck, BothKernels, ::testing::Bool(), test::kernel_copy_name);

// The box the motion pass makes on the way (Stats::box_lo, box_hi) is the box an Aabb
// extended node by node gets, bit for bit: the detection takes it instead of reading the
// nodes again. Over small moves (the incremental path) of a box whose extreme
// coordinates are zeros of both signs, in an order that changes from state to state: the
// pass keeps four boxes a chunk, one per node position in its steps of four nodes, and must
// find the first zero when they disagree. Also on an object of several chunks of the
// parallel pass (10,626 nodes: four chunks), where each chunk's box is joined to the
// others': the signs of the zeros at the extremes are drawn anew every state, so the first
// zero of each extreme moves between chunks. 210 and 10,626 nodes leave two nodes past the
// last step of four (the pass takes them one by one).
class MotionPassBox : public ::testing::TestWithParam<std::tuple<int, int, bool>> {
 protected:
  void TearDown() override { detail::use_baseline_kernels(false); }
};

TEST_P(MotionPassBox, IsTheNodeByNodeBoxBitForBit) {
  const auto [cells, threads, baseline] = GetParam();
  detail::use_baseline_kernels(baseline);
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                            static_cast<std::size_t>(threads));
  Fixture f(test::structured_box(cells + 1, cells, cells - 1, Eigen::Vector3d(-1, 0, -1),
                                 Eigen::Vector3d(0, 1, 0)));
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Positions rest = f.mesh.positions;
  Positions x = rest;
  f.check.check(x);
  const Index n = f.mesh.num_nodes();
  std::vector<Index> top;  // the nodes of the face y = 1
  for (Index i = 0; i < n; ++i)
    if (rest(1, i) == 1.0) top.push_back(i);
  Index pushed = n - 1;  // (on that face too)
  int boxes = 0;
  for (int step = 0; step < 40; ++step) {
    // A hair of motion, and the zero coordinates' signs drawn anew; some of them a hair
    // inside, so that the first zero of an extreme is not always the first node's.
    for (Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        if (rest(c, i) == 0.0) {
          const double draw = u(rng);
          x(c, i) = draw < 0.4 ? -0.0 : draw < 0.8 ? 0.0 : (c == 1 ? 1e-9 : -1e-9);
        } else if (step % 5 == 4) {
          x(c, i) += 1e-6 * (u(rng) - 0.5);
        }
      }
    // One node of the face y = 1 a hair outside, alone at the extreme: half of the time
    // the last node (past the last step of four when n is not a multiple of 4).
    x(1, pushed) = 1.0;
    pushed = u(rng) < 0.5 ? n - 1 : top[static_cast<std::size_t>(u(rng) * top.size())];
    x(1, pushed) = 1.0 + 1e-7 * (1.0 + u(rng));
    ASSERT_TRUE(f.both(x).clean());
    if (!f.check.last().has_box) continue;
    ++boxes;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (Index i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], x(c, i));
        hi[c] = std::max(hi[c], x(c, i));
      }
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(std::signbit(f.check.last().box_lo[c]), std::signbit(lo[c])) << step << " " << c;
      EXPECT_EQ(std::signbit(f.check.last().box_hi[c]), std::signbit(hi[c])) << step << " " << c;
    }
    EXPECT_EQ(f.check.last().box_lo, lo);
    EXPECT_EQ(f.check.last().box_hi, hi);
  }
  EXPECT_GT(boxes, 30);
}

INSTANTIATE_TEST_SUITE_P(ShapeCheck, MotionPassBox,
                         ::testing::Values(std::tuple(5, 1, false), std::tuple(8, 1, false),
                                           std::tuple(21, 1, false), std::tuple(21, 2, false),
                                           std::tuple(5, 1, true), std::tuple(21, 2, true)));

TEST(ShapeCheck, ThreadCountChangesNothing) {
  const TetMesh mesh = test::ball_mesh(6, 1.0);
  std::vector<std::vector<std::size_t>> stats;
  for (const int threads : {1, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(threads));
    Fixture f(mesh);
    std::vector<std::size_t> s;
    Positions x = f.mesh.positions;
    for (int step = 0; step < 30; ++step) {
      for (Index i = 0; i < x.cols(); i += 7) x(step % 3, i) += 1e-3 * std::sin(i + step);
      const ValidationReport r = f.both(x);
      s.push_back(r.sliver.count);
      s.push_back(f.check.last().moved_nodes);
      s.push_back(f.check.last().checked_tets);
    }
    stats.push_back(s);
  }
  EXPECT_EQ(stats[0], stats[1]);
}

TEST(ShapeCheck, BadArgumentsAreNamed) {
  const TetMesh mesh = test::cube_six_tets();
  const TetCheckOrder order = make_tet_check_order(mesh.positions, mesh.tets);
  const Topology topo = build_topology(mesh.tets, mesh.num_nodes());
  EXPECT_THROW(ShapeCheck(order, topo.node_tets, mesh.num_nodes() + 1, frame_options()),
               std::invalid_argument);
  EXPECT_THROW(ShapeCheck(order, topo.node_tets, mesh.num_nodes(), ValidationOptions{}),
               std::invalid_argument);
  ShapeCheck check(order, topo.node_tets, mesh.num_nodes(), frame_options());
  try {
    check.check(Positions::Zero(3, 3));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("3 positions for 8 nodes"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tc
