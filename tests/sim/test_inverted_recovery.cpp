// Issue 48, item 6: a simulation in which a few tets invert goes on with its contact
// forces and recovers. A soft block (the demo simulator's body) rests on a static floor
// under gravity, its contact forces from an in-process Pipeline each 1 ms frame. Once
// settled, a node one layer above the floor is kicked up through the face above it
// (a few inverted tets next to the contact, as a stiff contact's jitter does). With the
// degraded mode (the default limit) every state is accepted, no frame in which the block
// is in the floor goes without a force, the body's elasticity undoes the inversion and
// the block comes back to rest where it rested before. With the limit at 0 (the behaviour
// before) the same states are rejected and those frames have no force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "body.hpp"
#include "core/pipeline/pipeline.hpp"
#include "sim_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc::sim {
namespace {

using test::kGravity;

struct RunResult {
  int rejected = 0;  ///< frames whose block state was rejected
  int degraded = 0;  ///< frames whose block state was accepted without its inverted tets
  /// Frames in which a node of the block was under the floor's top and no force came.
  int in_floor_without_forces = 0;
  int last_degraded = -1;
  std::size_t inverted_at_end = 0;
  double final_lowest_z = 0.0;  ///< metres
  double final_speed = 0.0;     ///< largest node speed at the end, m/s
  bool finite = true;
};

constexpr int kFrames = 1200;
constexpr double kDt = 1e-3;
constexpr int kKickFrame = 300;

RunResult run(std::size_t max_inverted_tets, bool kick) {
  // The block: 0.2 m cube, 6^3 cells (1296 tets: the limit is min(16, 1% = 12) tets).
  const int n = 6;
  const double h = 0.2 / n;
  const TetMesh block = test::structured_box(n, n, n, {-0.1, -0.1, 0.0}, {0.1, 0.1, 0.2});
  const TetMesh floor = test::structured_box(6, 6, 2, {-0.3, -0.3, -0.1}, {0.3, 0.3, 0.0});
  Body body =
      test::make_body(block, {.density = 1000.0, .young = 1e5, .poisson = 0.3, .damping = 10.0});
  const int substeps = std::max(1, static_cast<int>(std::ceil(2.0 * kDt / body.stable_dt())));
  PipelineConfig config;
  config.max_inverted_tets = max_inverted_tets;
  Pipeline pipeline(config);
  ObjectParams contact;
  contact.stiffness = 3e4;
  contact.damping = 10.0;
  ObjectParams fixed = contact;
  fixed.is_static = true;
  EXPECT_TRUE(pipeline.set_topology("floor", 0, floor, fixed).ok());
  EXPECT_TRUE(pipeline.set_topology("block", 0, block, contact).ok());
  // The centre node of the layer one cell above the floor.
  const Index kicked = n / 2 + (n + 1) * (n / 2 + (n + 1) * 1);

  RunResult r;
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, body.node_count());
  for (int frame = 0; frame < kFrames; ++frame) {
    if (kick && frame == kKickFrame) {
      Eigen::Matrix3Xd x = body.positions();
      // (The bound check also tells GCC 12 the matrix is not empty: without it, -O3 warns
      // of a null pointer in the copy's data.)
      if (kicked < x.cols()) x(2, kicked) += 1.05 * h;
      body.set_positions(x);
    }
    const std::vector<FrameObjectInput> states = {
        {"block", 0, body.positions(), body.velocities()}};
    const FrameOutput out = pipeline.run_frame(frame, states);
    // The service answers a rejected state with its error and no forces (the pipeline still
    // computes the object's contact from the state it held before).
    const bool rejected = std::any_of(out.errors.begin(), out.errors.end(),
                                      [](const ObjectError& e) { return e.object == "block"; });
    if (rejected) ++r.rejected;
    if (!out.degraded.empty()) {
      ++r.degraded;
      r.last_degraded = frame;
    }
    forces.setZero();
    bool any = false;
    for (const ObjectForces& f : out.forces) {
      if (f.object != "block" || rejected) continue;
      for (std::size_t k = 0; k < f.nodes.size(); ++k) forces.col(f.nodes[k]) += f.forces[k];
      any = !f.nodes.empty();
    }
    if (!any && body.positions().row(2).minCoeff() < 0.0) ++r.in_floor_without_forces;
    body.step(kDt, substeps, kGravity, forces);
    r.finite = r.finite && body.positions().allFinite() && body.velocities().allFinite();
    if (!r.finite) break;
  }
  r.inverted_at_end = body.inverted_tets();
  r.final_lowest_z = body.positions().row(2).minCoeff();
  r.final_speed = body.velocities().colwise().norm().maxCoeff();
  std::printf(
      "max_inverted_tets %zu, kick %d: %d rejected, %d degraded (last %d), %d frames in the "
      "floor without forces; lowest node at the end %.3f mm, end speed %.4f m/s, %zu "
      "inverted\n",
      max_inverted_tets, kick ? 1 : 0, r.rejected, r.degraded, r.last_degraded,
      r.in_floor_without_forces, 1e3 * r.final_lowest_z, r.final_speed, r.inverted_at_end);
  return r;
}

TEST(InvertedRecovery, AFewInvertedTetsKeepTheForcesAndTheBlockRecovers) {
  const RunResult rest = run(PipelineConfig{}.max_inverted_tets, false);
  const RunResult r = run(PipelineConfig{}.max_inverted_tets, true);
  ASSERT_TRUE(r.finite);
  EXPECT_EQ(rest.degraded, 0);
  EXPECT_EQ(r.rejected, 0);
  EXPECT_GE(r.degraded, 1);  // at least the kicked frame
  EXPECT_EQ(r.in_floor_without_forces, 0);
  // Recovered: no inverted tet for the last half of the run, at rest where it rested.
  EXPECT_LT(r.last_degraded, kFrames / 2);
  EXPECT_EQ(r.inverted_at_end, 0u);
  EXPECT_LT(r.final_speed, 0.05);
  EXPECT_NEAR(r.final_lowest_z, rest.final_lowest_z, 1e-3);
}

TEST(InvertedRecovery, WithoutTheDegradedModeThoseFramesHaveNoForces) {
  const RunResult r = run(0, true);
  EXPECT_GE(r.rejected, 1);
  EXPECT_EQ(r.degraded, 0);
  EXPECT_GE(r.in_floor_without_forces, 1);
}

}  // namespace
}  // namespace tc::sim
