// Shared by the simulator's tests (test_sim_body, test_implicit_step): gravity vectors and
// a Body built from a test mesh (the test fails, not crashes, on a bad mesh).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <utility>

#include "body.hpp"

namespace tc::test {

inline const Eigen::Vector3d kNoGravity = Eigen::Vector3d::Zero();
inline const Eigen::Vector3d kGravity{0.0, 0.0, -9.81};

inline sim::Body make_body(TetMesh mesh, sim::Material m = {}) {
  auto b = sim::Body::create(std::move(mesh), m);
  EXPECT_TRUE(b) << b.error().message;
  return std::move(*b);
}

}  // namespace tc::test
