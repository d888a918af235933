// The analytic checks of the friction scenes (docs/DEMO.md, "Friction scenes"): what a
// block's mass-weighted centre must do on a static support under Coulomb friction, from
// the scene's own gravity, the support's tilt and the pair's coefficient, against what
// the run recorded (RunBooks::com).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "scene_file.hpp"

namespace tc::sim {

struct FrictionCheckResult {
  std::string kind;      ///< stick | slide | skid
  std::string quantity;  ///< what `expected` and `measured` are, with its unit
  double expected = 0.0;
  double measured = 0.0;
  double slope_deg = 0.0;  ///< the support's tilt against gravity
  double mu = 0.0;         ///< the pair's coefficient, sqrt(mu_object mu_support)
  double drift_m = 0.0;    ///< stick, skid: how far the centre moved in the last window_s
  bool passed = false;
  std::string failure;  ///< why it failed (empty when it passed)
};

/// Evaluates `check` on a run of `scene`: com holds the object's centre after each frame
/// (metres, one per frame of dt seconds), com_start before the first. A scene whose
/// parameters contradict the kind (a "stick" slope steeper than atan(mu), a "slide"
/// flatter) fails with that reason.
FrictionCheckResult evaluate_friction_check(const SceneSpec& scene, const FrictionCheck& check,
                                            const Eigen::Vector3d& com_start,
                                            const std::vector<Eigen::Vector3d>& com);

}  // namespace tc::sim
