// sim/friction_check: the analytic answers of the friction scenes, against made-up
// paths of the block's centre that meet them, miss them, or come from a scene whose
// parameters contradict the kind asked for.
#include "friction_check.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace tc::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A ramp tilted `deg` about x (downhill is -y) and a block on it, frictions mu_ramp and
/// mu_block, dt 1 ms.
SceneSpec ramp_scene(double deg, double mu_ramp, double mu_block) {
  SceneSpec s;
  s.dt = 1e-3;
  ObjectSpec ramp;
  ramp.name = "ramp";
  ramp.is_static = true;
  ramp.rotate_deg = {deg, 0.0, 0.0};
  ramp.contact.friction = mu_ramp;
  ObjectSpec block;
  block.name = "block";
  block.contact.friction = mu_block;
  s.objects = {ramp, block};
  return s;
}

FrictionCheck check_of(const std::string& kind) {
  FrictionCheck c;
  c.kind = kind;
  c.object = "block";
  c.support = "ramp";
  return c;
}

/// The centre after each of `frames` frames: p(t) = v0 t + a t^2 / 2 along `dir`, stopped
/// (held) once its speed along dir reaches zero when `stops`.
std::vector<Eigen::Vector3d> path(int frames, double dt, const Eigen::Vector3d& dir, double v0,
                                  double a, bool stops) {
  std::vector<Eigen::Vector3d> out;
  for (int k = 1; k <= frames; ++k) {
    double t = k * dt;
    if (stops && a < 0.0) t = std::min(t, -v0 / a);
    out.push_back((v0 * t + 0.5 * a * t * t) * dir);
  }
  return out;
}

TEST(FrictionCheck, SlideMeasuresTheAccelerationAlongTheSlope) {
  const SceneSpec s = ramp_scene(25.0, 0.3, 0.3);
  const double a = 9.81 * (std::sin(25.0 * kPi / 180.0) - 0.3 * std::cos(25.0 * kPi / 180.0));
  const Eigen::Vector3d down =
      Eigen::Vector3d(0.0, -std::cos(25.0 * kPi / 180.0), -std::sin(25.0 * kPi / 180.0));
  FrictionCheck c = check_of("slide");
  c.from_s = 0.1;
  auto r =
      evaluate_friction_check(s, c, Eigen::Vector3d::Zero(), path(700, s.dt, down, 0.0, a, false));
  EXPECT_TRUE(r.passed) << r.failure;
  EXPECT_NEAR(r.expected, a, 1e-12);
  EXPECT_NEAR(r.measured, a, 1e-6 * a);
  EXPECT_NEAR(r.slope_deg, 25.0, 1e-9);
  EXPECT_NEAR(r.mu, 0.3, 1e-15);
  r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(),
                              path(700, s.dt, down, 0.0, 0.9 * a, false));
  EXPECT_FALSE(r.passed);
  EXPECT_NE(r.failure.find("slid at"), std::string::npos) << r.failure;
  // Flatter than atan(mu): nothing to slide.
  r = evaluate_friction_check(ramp_scene(10.0, 0.3, 0.3), c, Eigen::Vector3d::Zero(),
                              path(700, s.dt, down, 0.0, a, false));
  EXPECT_FALSE(r.passed);
  EXPECT_NE(r.failure.find("no slide"), std::string::npos) << r.failure;
}

TEST(FrictionCheck, StickBoundsTheDriftOfTheLastWindow) {
  const SceneSpec s = ramp_scene(20.0, 0.6, 0.6);
  const Eigen::Vector3d down(0.0, -1.0, 0.0);
  const FrictionCheck c = check_of("stick");  // window 1 s, 1 mm
  // Creeping at 0.5 mm/s over 1.5 s: 0.5 mm in the last second.
  auto r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(),
                                   path(1500, s.dt, down, 5e-4, 0.0, false));
  EXPECT_TRUE(r.passed) << r.failure;
  EXPECT_NEAR(r.drift_m, 5e-4, 1e-12);
  r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(),
                              path(1500, s.dt, down, 2e-3, 0.0, false));
  EXPECT_FALSE(r.passed);
  // The geometric mean of the coefficients: 0.6 and 0.1 give 0.245 < tan(20 deg).
  r = evaluate_friction_check(ramp_scene(20.0, 0.6, 0.1), c, Eigen::Vector3d::Zero(),
                              path(1500, s.dt, down, 0.0, 0.0, false));
  EXPECT_FALSE(r.passed);
  EXPECT_NE(r.failure.find("cannot stick"), std::string::npos) << r.failure;
}

TEST(FrictionCheck, SkidComparesTheStoppingDistanceAndTheRest) {
  SceneSpec s = ramp_scene(0.0, 0.5, 0.5);
  s.objects[1].velocity = {1.0, 0.0, 0.0};
  FrictionCheck c = check_of("skid");
  c.window_s = 0.5;
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  const double a = -0.5 * 9.81;
  auto r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(), path(800, s.dt, x, 1.0, a, true));
  EXPECT_TRUE(r.passed) << r.failure;
  EXPECT_NEAR(r.expected, 1.0 / (2.0 * 0.5 * 9.81), 1e-12);
  EXPECT_NEAR(r.measured, r.expected, 1e-6);
  // Too much friction: stops at 80 % of the distance.
  r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(),
                              path(800, s.dt, x, 1.0, a / 0.8, true));
  EXPECT_FALSE(r.passed);
  EXPECT_NE(r.failure.find("skidded"), std::string::npos) << r.failure;
  // The right distance, but still moving at the end.
  auto moving = path(800, s.dt, x, 1.0, a, true);
  for (std::size_t k = 500; k < moving.size(); ++k)
    moving[k] += static_cast<double>(k - 500) * 1e-5 * x;
  r = evaluate_friction_check(s, c, Eigen::Vector3d::Zero(), moving);
  EXPECT_FALSE(r.passed);
  EXPECT_NE(r.failure.find("after stopping"), std::string::npos) << r.failure;
}

}  // namespace
}  // namespace tc::sim
