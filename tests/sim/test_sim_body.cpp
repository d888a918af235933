// The demo simulator's body: rest stays at rest, energy is conserved without damping and
// contact (free fall, free oscillation), the chosen time steps are stable, pinned nodes
// stay put, tearing removes over-stretched tets and compacts the mesh, and the local
// penetration probe measures depths it can be checked against.
#include <gtest/gtest.h>

#include <random>

#include "body.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "penetration.hpp"
#include "sanitizer.hpp"
#include "scene_file.hpp"
#include "sim_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc::sim {
namespace {

using test::kGravity;
using test::kNoGravity;
using test::make_body;

TEST(SimBody, LumpedMassesSumToDensityTimesVolume) {
  const TetMesh box = test::structured_box(3, 2, 2, {0, 0, 0}, {0.3, 0.2, 0.2});
  const Body b = make_body(box, {.density = 500.0});
  EXPECT_NEAR(b.masses().sum(), 500.0 * 0.3 * 0.2 * 0.2, 1e-12);
}

TEST(SimBody, RestStateStaysAtRest) {
  auto torus = read_mesh(test::mesh_path("torus.msh"));
  ASSERT_TRUE(torus);
  Body b = make_body(*torus, {.young = 3e5, .poisson = 0.35});
  EXPECT_LT(b.elastic_forces().cwiseAbs().maxCoeff(), 1e-9);
  const Eigen::Matrix3Xd x0 = b.positions();
  for (int i = 0; i < (test::kSanitized ? 10 : 50); ++i) b.step(1e-3, 8, kNoGravity, {});
  EXPECT_LT((b.positions() - x0).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(b.velocities().cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(b.energy(kNoGravity).elastic, 0.0, 1e-9);
}

TEST(SimBody, ElasticForcesHaveNoNetForce) {
  TetMesh box = test::structured_box(3, 3, 3, {0, 0, 0}, {1, 1, 1});
  Body b = make_body(box, {.young = 1e5});
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Eigen::Matrix3Xd x = b.positions();
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += u(rng);
  b.set_positions(x);
  const Eigen::Matrix3Xd f = b.elastic_forces();
  EXPECT_LT(f.rowwise().sum().norm(),
            1e-9 * f.cwiseAbs().maxCoeff() * static_cast<double>(f.cols()));
  EXPECT_GT(b.energy(kNoGravity).elastic, 0.0);
}

/// A stretched body oscillating freely (and falling): with no damping and no contact the
/// total energy of symplectic Euler stays within a small band.
class SimEnergy : public ::testing::TestWithParam<std::tuple<std::string, bool>> {};

TEST_P(SimEnergy, IsConservedWithoutDampingAndContact) {
  const auto& [mesh_name, gravity_on] = GetParam();
  auto mesh = read_mesh(test::mesh_path(mesh_name));
  ASSERT_TRUE(mesh);
  Body b = make_body(*mesh, {.density = 1000.0, .young = 3e5, .poisson = 0.35});
  // Initial deformation: 5 % stretch along x.
  Eigen::Matrix3Xd x = b.positions();
  x.row(0) *= 1.05;
  b.set_positions(x);
  const Eigen::Vector3d g = gravity_on ? kGravity : kNoGravity;
  const double dt = 1e-3;
  const int substeps = 8;
  ASSERT_LT(dt / substeps, b.stable_dt());
  const double e0 = b.energy(g).total();
  const double scale = b.energy(g).elastic;  // the energy that oscillates
  ASSERT_GT(scale, 0.0);
  double worst = 0.0;
  double ke_max = 0.0;
  // Under sanitizers (10-20x slower here) a quarter of the run: memory errors show in the
  // first steps; the 200-frame energy bound is checked in the Release pass.
  const int frames = test::kSanitized ? 50 : 200;
  for (int f = 0; f < frames; ++f) {
    b.step(dt, substeps, g, {});
    const Energy e = b.energy(g);
    worst = std::max(worst, std::abs(e.total() - e0));
    ke_max = std::max(ke_max, e.kinetic);
  }
  EXPECT_GT(ke_max, 0.1 * scale) << "the body must actually move";
  EXPECT_LT(worst, 0.05 * std::max(scale, ke_max)) << "energy drift " << worst << " J";
  EXPECT_EQ(b.dissipated(), 0.0);
  EXPECT_TRUE(b.positions().allFinite());
}

INSTANTIATE_TEST_SUITE_P(Meshes, SimEnergy,
                         ::testing::Combine(::testing::Values("ellipsoid.msh", "ball.msh"),
                                            ::testing::Bool()));

TEST(SimBody, FreeFallFollowsGravityExactly) {
  Body b = make_body(test::structured_box(2, 2, 2, {0, 0, 0}, {0.1, 0.1, 0.1}));
  const double dt = 1e-3;
  for (int f = 0; f < 100; ++f) b.step(dt, 4, kGravity, {});
  // Rigid free fall: every node has v = g t; symplectic Euler's position error is O(dt).
  EXPECT_NEAR(b.velocities()(2, 0), -9.81 * 0.1, 1e-9);
  EXPECT_NEAR(b.positions()(2, 0), -0.5 * 9.81 * 0.01, 9.81 * 0.1 * dt);
}

TEST(SimBody, DampingDissipatesAndIsAccounted) {
  Body b = make_body(test::structured_box(2, 2, 2, {0, 0, 0}, {0.1, 0.1, 0.1}), {.damping = 2.0});
  const double e0 = b.energy(kGravity).total();
  for (int f = 0; f < 100; ++f) b.step(1e-3, 4, kGravity, {});
  const double e1 = b.energy(kGravity).total();
  EXPECT_LT(e1, e0);
  EXPECT_GT(b.dissipated(), 0.0);
  // Balanced up to symplectic Euler's own O(dt) error in free fall (< 0.5 %).
  EXPECT_NEAR(e1 + b.dissipated(), e0, 5e-3 * e0);
}

TEST(SimBody, PinnedNodesStayPut) {
  auto slab = read_mesh(test::mesh_path("slab.msh"));
  ASSERT_TRUE(slab);
  Body b = make_body(*slab, {.young = 5e4});
  const auto border = b.border_nodes(0.49, 0.49);
  ASSERT_FALSE(border.empty());
  b.fix_nodes(border);
  const Eigen::Matrix3Xd x0 = b.positions();
  for (int f = 0; f < 20; ++f) b.step(5e-4, 8, kGravity, {});
  for (const Index n : border) EXPECT_EQ(b.positions().col(n), x0.col(n));
  // The middle sags.
  EXPECT_LT(b.positions().row(2).minCoeff(), x0.row(2).minCoeff() - 1e-5);
}

TEST(SimBody, ContactForcesPushNodes) {
  Body b = make_body(test::structured_box(1, 1, 1, {0, 0, 0}, {0.1, 0.1, 0.1}));
  Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, b.node_count());
  f.row(2).setConstant(1.0);  // 1 N up on every node
  b.step(1e-3, 1, kNoGravity, f);
  // Momentum gained = impulse: sum m v_z = n * 1 N * 1 ms.
  EXPECT_NEAR((b.velocities().row(2).transpose().array() * b.masses().array()).sum(),
              1e-3 * b.node_count(), 1e-12);
}

TEST(SimBody, ChosenSceneStepsAreStable) {
  for (const char* name : {"torus_on_box", "ellipsoid_rain", "tissue_tear"}) {
    SCOPED_TRACE(name);
    const auto spec = load_scene_file(
        std::filesystem::path(TC_SOURCE_DIR) / "config" / "scenes" / (std::string(name) + ".yaml"),
        {TC_SOURCE_DIR});
    ASSERT_TRUE(spec) << spec.error().message;
    std::set<std::string> meshes;
    for (const auto& o : spec->objects) {
      if (o.is_static || !meshes.insert(o.mesh.string()).second) continue;
      auto mesh = load_object_mesh(o);
      ASSERT_TRUE(mesh);
      Body b = make_body(*mesh, o.material);
      EXPECT_LT(spec->dt / spec->substeps, b.stable_dt()) << o.name;
      // A perturbed body under the scene's step neither explodes nor drifts up.
      Eigen::Matrix3Xd x = b.positions();
      x.row(2) *= 1.03;
      b.set_positions(x);
      const double e0 = b.energy(kNoGravity).total();
      for (int f = 0; f < 40; ++f) b.step(spec->dt, spec->substeps, kNoGravity, {});
      EXPECT_TRUE(b.positions().allFinite());
      EXPECT_LE(b.energy(kNoGravity).total(), e0 * 1.01) << o.name;
    }
  }
}

TEST(SimBody, TearRemovesOverStretchedTetsAndCompacts) {
  TetMesh box = test::structured_box(4, 1, 1, {0, 0, 0}, {0.4, 0.1, 0.1});
  Body b = make_body(box);
  const Index n0 = b.node_count();
  const std::size_t m0 = b.rest_mesh().tets.size();
  EXPECT_EQ(b.tear(0.3), 0u);  // at rest nothing tears
  // Pull the last column of cells far away: the tets of the last cell stretch.
  Eigen::Matrix3Xd x = b.positions();
  for (Index n = 0; n < n0; ++n)
    if (x(0, n) > 0.35) x(0, n) += 0.2;
  b.set_positions(x);
  EXPECT_GT(b.max_strain(), 0.3);
  const std::size_t removed = b.tear(0.3);
  EXPECT_GT(removed, 0u);
  EXPECT_EQ(b.rest_mesh().tets.size(), m0 - removed);
  EXPECT_LT(b.max_strain(), 0.3 + 1e-12);
  // Compacted: every node is used, every tet positive at rest, state sizes match.
  std::vector<bool> used(static_cast<std::size_t>(b.node_count()), false);
  for (const Tet& t : b.rest_mesh().tets) {
    for (const Index n : t) used[static_cast<std::size_t>(n)] = true;
    EXPECT_GT(signed_volume(b.rest_mesh().positions, t), 0.0);
  }
  EXPECT_TRUE(std::all_of(used.begin(), used.end(), [](bool u) { return u; }));
  EXPECT_LE(b.node_count(), n0);
  EXPECT_EQ(b.velocities().cols(), b.node_count());
  EXPECT_EQ(b.masses().size(), b.node_count());
  EXPECT_EQ(b.rest_mesh().node_ids.size(), static_cast<std::size_t>(b.node_count()));
}

TEST(SimBody, RejectsBadMaterialAndInvertedTets) {
  EXPECT_EQ(Body::create(test::single_tet(), {.density = 0.0}).error().code,
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(Body::create(test::single_tet(), {.poisson = 0.5}).error().code,
            ErrorCode::kInvalidArgument);
  TetMesh flipped = test::single_tet();
  std::swap(flipped.tets[0][0], flipped.tets[0][1]);
  const auto r = Body::create(flipped, {});
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidMesh);
  EXPECT_NE(r.error().message.find("tet 0"), std::string::npos);
}

TEST(PenetrationProbe, MeasuresDepthInsideAnotherObject) {
  // A: the cube [0, 1]^3; B: a small box with one node 0.2 inside A's bottom face and
  // the others outside.
  const TetMesh a = test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1});
  const TetMesh b = test::structured_box(1, 1, 1, {0.45, 0.45, -0.5}, {0.55, 0.55, 0.2});
  PenetrationProbe probe;
  probe.set_object(0, a.tets, a.num_nodes());
  probe.set_object(1, b.tets, b.num_nodes());
  std::vector<const Eigen::Matrix3Xd*> xs{&a.positions, &b.positions};
  const auto d = probe.measure(xs);
  ASSERT_EQ(d.size(), 2u);
  double deepest = 0.0;
  for (Index n = 0; n < b.num_nodes(); ++n) {
    const double z = b.positions(2, n);
    if (z > 0.0) {
      EXPECT_NEAR(d[1][static_cast<std::size_t>(n)], 0.2, 0.02) << n;
    } else {
      EXPECT_EQ(d[1][static_cast<std::size_t>(n)], 0.0) << n;
    }
    deepest = std::max(deepest, d[1][static_cast<std::size_t>(n)]);
  }
  EXPECT_GT(deepest, 0.18);
  // A's nodes are not inside B except none (B is thin): all zero.
  for (const double v : d[0]) EXPECT_EQ(v, 0.0);
  // Apart: nothing.
  TetMesh far = b;
  for (Index n = 0; n < far.num_nodes(); ++n) far.positions(2, n) -= 2.0;
  std::vector<const Eigen::Matrix3Xd*> apart{&a.positions, &far.positions};
  for (const auto& v : probe.measure(apart))
    for (const double x : v) EXPECT_EQ(x, 0.0);
}

}  // namespace
}  // namespace tc::sim
