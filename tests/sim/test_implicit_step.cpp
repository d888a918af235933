// Backward Euler with contact forces + stiffness blocks (ImplicitStepper): stable at time
// steps where symplectic Euler explodes, a body dropped on a stiff penalty floor (forces
// and blocks evaluated once per frame, as the service does) gains no energy and comes to
// rest, pinned nodes stay put, free fall is exact in velocity, and LDL^T and CG agree.
#include <gtest/gtest.h>

#include <random>

#include "body.hpp"
#include "implicit_step.hpp"
#include "sanitizer.hpp"
#include "sim_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc::sim {
namespace {

using test::kGravity;
using test::kNoGravity;
using test::make_body;

/// A penalty floor z = 0 as the service would send it: per node below the floor, the
/// force k (-z) e_z and the block df/dx = -k e_z e_z^T (k in N/m per node).
struct Floor {
  double k;
  Eigen::Matrix3Xd forces;
  Eigen::Matrix3Xd blocks;
  double max_depth = 0.0;
  void evaluate(const Eigen::Matrix3Xd& x) {
    forces = Eigen::Matrix3Xd::Zero(3, x.cols());
    blocks = Eigen::Matrix3Xd::Zero(3, 3 * x.cols());
    max_depth = 0.0;
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      if (x(2, i) >= 0.0) continue;
      forces(2, i) = -k * x(2, i);
      blocks(2, 3 * i + 2) = -k;
      max_depth = std::max(max_depth, -x(2, i));
    }
  }
};

TEST(ImplicitStep, StableAtATimeStepWhereExplicitBlowsUp) {
  const TetMesh box = test::structured_box(4, 4, 4, {0, 0, 0}, {0.2, 0.2, 0.2});
  const Material mat{.density = 1000.0, .young = 1e6, .poisson = 0.3};
  Body expl = make_body(box, mat);
  const double dt = 5e-3;
  ASSERT_GT(dt, 5.0 * expl.stable_dt()) << "the step must be far beyond the explicit limit";
  Eigen::Matrix3Xd x = expl.positions();
  x.row(0) *= 1.05;
  expl.set_positions(x);
  Body impl = expl;
  const double e0 = impl.energy(kNoGravity).total();
  ImplicitStepper stepper;
  double worst = 0.0;
  for (int f = 0; f < (test::kSanitized ? 30 : 100); ++f) {
    stepper.step(impl, dt, kNoGravity, {}, {});
    worst = std::max(worst, impl.energy(kNoGravity).total());
  }
  EXPECT_TRUE(impl.positions().allFinite());
  EXPECT_LE(worst, e0 * (1.0 + 1e-9)) << "backward Euler never gains energy here";
  EXPECT_EQ(impl.inverted_tets(), 0u);
  // Symplectic Euler, one substep per frame, at the same dt.
  bool exploded = false;
  for (int f = 0; f < 100 && !exploded; ++f) {
    expl.step(dt, 1, kNoGravity, {});
    const double e = expl.energy(kNoGravity).total();
    exploded = !std::isfinite(e) || e > 100.0 * e0;
  }
  EXPECT_TRUE(exploded) << "explicit integration was expected to blow up at this dt";
}

/// Dropped on a stiff floor: mechanical energy (kinetic + elastic + gravity) never rises
/// above its initial value, ends lower, the body comes to rest at the penalty depth.
class ImplicitFloor : public ::testing::TestWithParam<double> {};

TEST_P(ImplicitFloor, ABodyOnAStiffPenaltyFloorGainsNoEnergyAndComesToRest) {
  const double k = GetParam();  // N/m per node
  TetMesh box = test::structured_box(3, 3, 3, {-0.05, -0.05, 0.02}, {0.05, 0.05, 0.12});
  Body b = make_body(box, {.density = 1000.0, .young = 1e5, .poisson = 0.3});
  Eigen::Matrix3Xd v = Eigen::Matrix3Xd::Zero(3, b.node_count());
  v.row(2).setConstant(-0.5);
  b.set_velocities(v);
  const double m_node = b.masses().maxCoeff();
  const double dt = 1e-3;
  // The contact alone would be unstable for an explicit step: sqrt(k/m) dt > 2.
  if (k >= 1e6) {
    ASSERT_GT(std::sqrt(k / m_node) * dt, 2.0);
  }
  const double e0 = b.energy(kGravity).total();
  ImplicitStepper stepper;
  Floor floor{k, {}, {}};
  double e_max = e0;
  double ke_max = 0.0;
  // Under ASan+UBSan (clang -O1) a frame of this box costs ~60 ms: 150 frames cover the
  // landing (frame ~40) and the first rebound.
  const int frames = test::kSanitized ? 150 : 1500;
  for (int f = 0; f < frames; ++f) {
    floor.evaluate(b.positions());  // once per frame, like the service
    stepper.step(b, dt, kGravity, floor.forces, floor.blocks);
    const Energy e = b.energy(kGravity);
    e_max = std::max(e_max, e.total());
    ke_max = std::max(ke_max, e.kinetic);
    ASSERT_TRUE(b.positions().allFinite()) << "frame " << f;
    ASSERT_EQ(b.inverted_tets(), 0u) << "frame " << f;
  }
  const Energy end = b.energy(kGravity);
  EXPECT_GT(ke_max, 0.0);
  EXPECT_LE(e_max, e0 + 1e-6 * std::abs(e0)) << "gained " << e_max - e0 << " J";
  EXPECT_LT(end.total(), e0);
  // At rest on the floor: little kinetic energy left, and vertical equilibrium holds:
  // the bottom nodes' penalty forces carry the weight, so the depth is ~ m g / (k nodes).
  // Under a sanitizer the run is too short to come to rest: only the energy bounds above
  // are checked there.
  if (test::kSanitized) return;
  EXPECT_LT(end.kinetic, 0.01 * ke_max);
  floor.evaluate(b.positions());
  const double weight = b.masses().sum() * 9.81;
  EXPECT_NEAR(floor.forces.row(2).sum(), weight, 0.1 * weight);
  EXPECT_LT(floor.max_depth, 3.0 * weight / (16.0 * k));
}

INSTANTIATE_TEST_SUITE_P(Stiffness, ImplicitFloor, ::testing::Values(1e3, 1e6, 1e8));

TEST(ImplicitStep, ExplicitGainsEnergyOnTheSameStiffFloor) {
  // The same floor with the forces held over a frame of symplectic Euler substeps (the
  // demo's former integrator): the test above would fail for it.
  TetMesh box = test::structured_box(3, 3, 3, {-0.05, -0.05, 0.02}, {0.05, 0.05, 0.12});
  Body b = make_body(box, {.density = 1000.0, .young = 1e5, .poisson = 0.3});
  Eigen::Matrix3Xd v = Eigen::Matrix3Xd::Zero(3, b.node_count());
  v.row(2).setConstant(-0.5);
  b.set_velocities(v);
  const double e0 = b.energy(kGravity).total();
  Floor floor{1e5, {}, {}};
  double e_max = e0;
  for (int f = 0; f < 300; ++f) {
    floor.evaluate(b.positions());
    b.step(1e-3, 8, kGravity, floor.forces);
    const double e = b.energy(kGravity).total();
    if (!std::isfinite(e)) {
      e_max = std::numeric_limits<double>::infinity();
      break;
    }
    e_max = std::max(e_max, e);
  }
  EXPECT_GT(e_max, 1.01 * e0);
}

TEST(ImplicitStep, FreeFallVelocityIsExact) {
  Body b = make_body(test::structured_box(2, 2, 2, {0, 0, 0}, {0.1, 0.1, 0.1}));
  ImplicitStepper stepper;
  for (int f = 0; f < 100; ++f) stepper.step(b, 1e-3, kGravity, {}, {});
  for (Index i = 0; i < b.node_count(); ++i) EXPECT_NEAR(b.velocities()(2, i), -0.981, 1e-9);
  EXPECT_LT(b.velocities().topRows(2).cwiseAbs().maxCoeff(), 1e-9);
  // Backward Euler: x_N = sum_k h v_k = -g h^2 N (N + 1) / 2.
  EXPECT_NEAR(b.positions()(2, 0), -9.81 * 1e-6 * 100 * 101 / 2, 1e-9);
}

TEST(ImplicitStep, PinnedNodesStayPutAndTheRestSags) {
  TetMesh slab = test::structured_box(6, 6, 1, {-0.5, -0.5, 0.0}, {0.5, 0.5, 0.05});
  Body b = make_body(slab, {.young = 5e4, .damping = 2.0});
  const auto border = b.border_nodes(0.49, 0.49);
  ASSERT_FALSE(border.empty());
  b.fix_nodes(border);
  const Eigen::Matrix3Xd x0 = b.positions();
  ImplicitStepper stepper;
  for (int f = 0; f < 50; ++f) stepper.step(b, 5e-3, kGravity, {}, {});
  for (const Index n : border) {
    EXPECT_EQ(b.positions().col(n), x0.col(n));
    EXPECT_EQ(b.velocities().col(n), Eigen::Vector3d::Zero());
  }
  EXPECT_LT(b.positions().row(2).minCoeff(), x0.row(2).minCoeff() - 1e-3);
  EXPECT_GT(b.dissipated(), 0.0);
}

TEST(ImplicitStep, LdltAndCgAgree) {
  TetMesh box = test::structured_box(3, 3, 3, {0, 0, 0}, {0.1, 0.1, 0.1});
  Body a = make_body(box, {.young = 1e5, .damping = 1.0});
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-0.005, 0.005);
  Eigen::Matrix3Xd x = a.positions();
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += u(rng);
  a.set_positions(x);
  Body c = a;
  ImplicitStepper ldlt({.max_newton = 8, .velocity_tolerance = 1e-9});
  ImplicitStepper cg({.max_newton = 8,
                      .velocity_tolerance = 1e-9,
                      .solver = LinearSolver::kCg,
                      .cg_tolerance = 1e-12});
  Floor floor{1e4, {}, {}};
  for (int f = 0; f < 20; ++f) {
    floor.evaluate(a.positions());
    ldlt.step(a, 2e-3, kGravity, floor.forces, floor.blocks);
    floor.evaluate(c.positions());
    cg.step(c, 2e-3, kGravity, floor.forces, floor.blocks);
  }
  EXPECT_LT((a.positions() - c.positions()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((a.velocities() - c.velocities()).cwiseAbs().maxCoeff(), 1e-6);
}

}  // namespace
}  // namespace tc::sim
