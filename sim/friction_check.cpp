#include "friction_check.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>

namespace tc::sim {
namespace {

const ObjectSpec* find_object(const SceneSpec& scene, const std::string& name) {
  for (const auto& o : scene.objects)
    if (o.name == name) return &o;
  return nullptr;
}

std::string text(const char* format, double a, double b) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b);
  return buf;
}

}  // namespace

FrictionCheckResult evaluate_friction_check(const SceneSpec& scene, const FrictionCheck& check,
                                            const Eigen::Vector3d& com_start,
                                            const std::vector<Eigen::Vector3d>& com) {
  FrictionCheckResult r;
  r.kind = check.kind;
  const ObjectSpec* object = find_object(scene, check.object);
  const ObjectSpec* support = find_object(scene, check.support);
  const double g = scene.gravity.norm();
  if (object == nullptr || support == nullptr || !(g > 0.0) || com.empty()) {
    r.failure = "the check needs its object, its support, gravity and at least one frame";
    return r;
  }
  // The support's face it rests on is its +z side; the slope is that face's tilt.
  const Eigen::Vector3d up = object_rotation(*support) * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d down = scene.gravity / g;
  const double cos_t = std::clamp(-up.dot(down), -1.0, 1.0);
  const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
  r.slope_deg = std::atan2(sin_t, cos_t) * 180.0 / 3.14159265358979323846;
  r.mu = std::sqrt(object->contact.friction * support->contact.friction);
  Eigen::Vector3d downhill = down - down.dot(up) * up;  // gravity's part along the face
  if (downhill.norm() > 1e-12) downhill.normalize();
  const double dt = scene.dt;
  // Drift over the last window_s (or the whole run when shorter).
  const auto window = static_cast<std::size_t>(std::llround(check.window_s / dt));
  const Eigen::Vector3d& before = window < com.size() ? com[com.size() - 1 - window] : com_start;
  r.drift_m = (com.back() - before).norm();

  if (check.kind == "stick") {
    r.quantity = "drift_m";
    r.expected = check.max_drift_m;
    r.measured = r.drift_m;
    if (!(sin_t < r.mu * cos_t)) {
      r.failure = text("the slope (%.3g deg) is steeper than atan(mu) = %.3g deg: it cannot stick",
                       r.slope_deg, std::atan(r.mu) * 180.0 / 3.14159265358979323846);
      return r;
    }
    r.passed = r.drift_m <= check.max_drift_m;
    if (!r.passed)
      r.failure = text("the block moved %.4g m in the last window, more than %.4g m", r.drift_m,
                       check.max_drift_m);
    return r;
  }
  if (check.kind == "slide") {
    r.quantity = "acceleration_m_s2";
    r.expected = g * (sin_t - r.mu * cos_t);
    if (!(r.expected > 0.0)) {
      r.failure = text("the slope (%.3g deg) is not steeper than atan(mu) = %.3g deg: no slide",
                       r.slope_deg, std::atan(r.mu) * 180.0 / 3.14159265358979323846);
      return r;
    }
    // Least squares s(t) = c0 + c1 t + c2 t^2 of the centre's path along the slope, frame
    // k at t = (k + 1) dt, from from_s on.
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    std::size_t used = 0;
    for (std::size_t k = 0; k < com.size(); ++k) {
      const double t = static_cast<double>(k + 1) * dt;
      if (t < check.from_s) continue;
      const Eigen::Vector3d basis(1.0, t, t * t);
      normal += basis * basis.transpose();
      rhs += basis * (com[k] - com_start).dot(downhill);
      ++used;
    }
    if (used < 10) {
      r.failure = "fewer than 10 frames after from_s: no fit";
      return r;
    }
    r.measured = 2.0 * normal.ldlt().solve(rhs)[2];
    r.passed = std::abs(r.measured - r.expected) <= check.tolerance * r.expected;
    if (!r.passed)
      r.failure = text("the block slid at %.4g m/s^2 along the slope, not g (sin - mu cos) = %.4g",
                       r.measured, r.expected);
    return r;
  }
  // skid
  r.quantity = "distance_m";
  const Eigen::Vector3d v0 = object->velocity - object->velocity.dot(up) * up;
  const double speed = v0.norm();
  const double decel = g * (r.mu * cos_t - sin_t * (speed > 0.0 ? v0.dot(downhill) / speed : 0.0));
  if (!(speed > 0.0) || !(decel > 0.0)) {
    r.failure = "a skid needs a launch velocity along the support and friction that stops it";
    return r;
  }
  r.expected = speed * speed / (2.0 * decel);
  r.measured = (com.back() - com_start).dot(v0 / speed);
  const bool distance_ok = std::abs(r.measured - r.expected) <= check.tolerance * r.expected;
  const bool stays = r.drift_m <= check.max_drift_m;
  r.passed = distance_ok && stays;
  if (!distance_ok)
    r.failure =
        text("the block skidded %.4g m, not v0^2 / (2 mu g) = %.4g m", r.measured, r.expected);
  else if (!stays)
    r.failure = text("the block moved %.4g m in the last window after stopping, more than %.4g m",
                     r.drift_m, check.max_drift_m);
  return r;
}

}  // namespace tc::sim
