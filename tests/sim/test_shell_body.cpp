// The triangle-based body of the demo (sim/shell_body.hpp): rest equilibrium,
// forces that are the energy's gradient, the gas's restoring pressure, free fall, and
// stability against a stiff penalty floor with and without its stiffness blocks.
#include "shell_body.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "core/io/surface_io.hpp"

namespace tc::sim {
namespace {

SurfaceMesh sphere() {
  auto s = read_surface(std::filesystem::path(TC_SOURCE_DIR) / "data/meshes/sphere_shell.obj");
  EXPECT_TRUE(s.has_value()) << (s ? "" : s.error().message);
  return *s;
}

ShellBody make(const ShellMaterial& m = {.mass = 4.0, .stretch = 2e3, .pressure = 1e4}) {
  auto b = ShellBody::create(sphere(), m);
  EXPECT_TRUE(b.has_value()) << (b ? "" : b.error().message);
  return std::move(*b);
}

TEST(ShellBody, RestShapeIsAnEquilibriumWithTheSphereVolume) {
  ShellBody b = make();
  EXPECT_NEAR(b.rest_volume(), 4.0 / 3.0 * M_PI * 0.2 * 0.2 * 0.2, 1.5e-3);  // icosphere < ball
  EXPECT_NEAR(b.masses().sum(), 4.0, 1e-12);
  EXPECT_LT(b.internal_forces().colwise().norm().maxCoeff(), 1e-9);
  EXPECT_NEAR(b.internal_energy(), 0.0, 1e-12);
}

TEST(ShellBody, ForcesAreMinusTheGradientOfTheEnergy) {
  ShellBody b = make();
  // A deformed state: squeezed along z, sheared, with a little noise.
  Eigen::Matrix3Xd x = b.positions();
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    x(2, i) *= 0.8;
    x(0, i) += 0.1 * x(2, i) + 1e-3 * std::sin(7.0 * static_cast<double>(i));
  }
  b.set_positions(x);
  const Eigen::Matrix3Xd f = b.internal_forces();
  const double h = 1e-7;
  for (const Eigen::Index i : {0, 17, 311, 641})
    for (int k = 0; k < 3; ++k) {
      Eigen::Matrix3Xd xp = x;
      Eigen::Matrix3Xd xm = x;
      xp(k, i) += h;
      xm(k, i) -= h;
      b.set_positions(xp);
      const double ep = b.internal_energy();
      b.set_positions(xm);
      const double em = b.internal_energy();
      EXPECT_NEAR(f(k, i), -(ep - em) / (2 * h), 1e-5 * (1.0 + std::abs(f(k, i))))
          << "node " << i << " axis " << k;
    }
}

TEST(ShellBody, SqueezedGasPushesOutwardWithNoNetForceOrTorque) {
  ShellBody b = make({.mass = 4.0, .stretch = 1e-3, .pressure = 1e4});  // nearly gas only
  b.set_positions(0.9 * b.positions());
  EXPECT_NEAR(b.volume(), 0.729 * b.rest_volume(), 1e-12);
  const Eigen::Matrix3Xd f = b.internal_forces();
  Eigen::Vector3d net = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  double along = 0.0;
  for (Eigen::Index i = 0; i < f.cols(); ++i) {
    net += f.col(i);
    torque += b.positions().col(i).cross(f.col(i));
    along += f.col(i).dot(b.positions().col(i).normalized());
  }
  // Overpressure p0 (V0/V - 1) over the area: sum of outward forces = p A.
  const double p = 1e4 * (1.0 / 0.729 - 1.0);
  const double area = 0.81 * 0.500259709;  // sphere_shell.obj's area, scaled
  EXPECT_NEAR(along, p * area, 0.01 * p * area);
  EXPECT_LT(net.norm(), 1e-9 * along);
  EXPECT_LT(torque.norm(), 1e-9 * along);
}

TEST(ShellBody, FallsFreelyUnderGravity) {
  ShellBody b = make();
  const Eigen::Vector3d g(0, 0, -9.81);
  const Eigen::Matrix3Xd x0 = b.positions();
  const auto r = b.step(1e-3, g, {}, {});
  EXPECT_FALSE(r.linear_solver_failed || r.line_search_failed);
  for (Eigen::Index i = 0; i < x0.cols(); ++i) {
    EXPECT_NEAR(b.velocities()(2, i), -9.81e-3, 1e-12);
    EXPECT_NEAR(b.positions()(2, i) - x0(2, i), -9.81e-6, 1e-14);
  }
}

/// Drops the shell on a penalty floor z = 0 (force k * depth up on every vertex below it,
/// block -k ez ez^T when `blocks`) and returns the largest rise of its mechanical energy
/// (kinetic + elastic + gravity, as the demo books it) over the initial value, relative;
/// `lowest` is the lowest vertex height seen.
double drop_on_floor(double k, bool blocks, double* lowest) {
  ShellBody b = make({.mass = 4.0, .stretch = 2e3, .pressure = 1e4, .damping = 0.0});
  Eigen::Matrix3Xd x = b.positions();
  x.row(2).array() += 0.21;
  b.set_positions(x);
  b.set_velocities(Eigen::Matrix3Xd::Zero(3, x.cols()).colwise() + Eigen::Vector3d(0, 0, -1));
  const Eigen::Vector3d g(0, 0, -9.81);
  const double e0 = b.energy(g).total();
  double emax = e0;
  *lowest = 1.0;
  const Index n = b.node_count();
  for (int step = 0; step < 200; ++step) {  // 0.1 s: lands at 10 ms, bounces
    Eigen::Matrix3Xd f = Eigen::Matrix3Xd::Zero(3, n);
    Eigen::Matrix3Xd kb = blocks ? Eigen::Matrix3Xd::Zero(3, 3 * n) : Eigen::Matrix3Xd(3, 0);
    for (Index i = 0; i < n; ++i) {
      const double z = b.positions()(2, i);
      *lowest = std::min(*lowest, z);
      if (z >= 0.0) continue;
      f(2, i) = -k * z;
      if (blocks) kb(2, 3 * i + 2) = -k;
    }
    b.step(5e-4, g, f, kb, 1);
    const double e = b.energy(g).total();
    if (!std::isfinite(e)) return INFINITY;
    emax = std::max(emax, e);
  }
  return (emax - e0) / std::abs(e0);
}

TEST(ShellBody, StiffPenaltyContactIsStableWithTheStiffnessBlocks) {
  double lowest = 0.0;
  // 1e7 N/m per vertex: one frame of 0.5 ms is beyond the explicit limit of a vertex
  // of ~6 g (sqrt(m/k) ~ 25 us).
  const double rise = drop_on_floor(1e7, true, &lowest);
  EXPECT_LE(rise, 0.01) << "energy rose with the blocks";
  EXPECT_GT(lowest, -2e-3) << "the floor let the shell through";
  EXPECT_LT(lowest, 0.0) << "the shell never reached the floor";
  // The same forces without their derivative gain energy: the blocks are what helps.
  double lowest_no = 0.0;
  EXPECT_GT(drop_on_floor(1e7, false, &lowest_no), 0.05);
}

TEST(ShellBody, BadSurfacesAndMaterialsAreClearErrors) {
  SurfaceMesh open = sphere();
  open.triangles.pop_back();
  auto r = ShellBody::create(open, {});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("not closed (3 boundary edges"), std::string::npos)
      << r.error().message;
  SurfaceMesh flipped = sphere();
  std::swap(flipped.triangles[5][1], flipped.triangles[5][2]);
  r = ShellBody::create(flipped, {});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("opposite orientation"), std::string::npos) << r.error().message;
  r = ShellBody::create(sphere(), {.mass = 0.0});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("shell mass must be > 0"), std::string::npos);
  r = ShellBody::create(sphere(), {.mass = 1.0, .stretch = NAN});
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("stretch"), std::string::npos);
  // Inward-facing triangles are turned outward: the same volume.
  SurfaceMesh inward = sphere();
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  auto in = ShellBody::create(inward, {});
  ASSERT_TRUE(in.has_value());
  EXPECT_NEAR(in->rest_volume(), make().rest_volume(), 1e-15);
}

}  // namespace
}  // namespace tc::sim
