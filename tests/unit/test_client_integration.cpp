// client/lib/include/tetcollide/integration.hpp: the penalty's node weights against
// hand-computed ones, and the explicit stability bound against the steps of the system it
// describes (a node on a penalty spring and dashpot, symplectic Euler): stable just below
// the bound, growing just above it.
#include "tetcollide/integration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace tc::client {
namespace {

/// The unit right-angle tet (0,0,0), (1,0,0), (0,1,0), (0,0,1).
Mesh unit_tet() {
  Mesh m;
  m.rest_positions = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.tets = {0, 1, 2, 3};
  return m;
}

TEST(ClientIntegration, NodeWeightsAreHalfTheEdgeLengths) {
  const std::vector<double> w = node_weights(unit_tet());
  ASSERT_EQ(w.size(), 4u);
  EXPECT_DOUBLE_EQ(w[0], 1.5);                                 // three unit edges
  EXPECT_DOUBLE_EQ(w[1], 0.5 * (1.0 + 2.0 * std::sqrt(2.0)));  // one unit, two diagonals
  // Two tets sharing a face: the shared edges count once.
  Mesh two = unit_tet();
  two.rest_positions.insert(two.rest_positions.end(), {1, 1, 1});
  two.tets.insert(two.tets.end(), {1, 2, 3, 4});
  const std::vector<double> w2 = node_weights(two);
  EXPECT_DOUBLE_EQ(w2[0], 1.5);
  EXPECT_DOUBLE_EQ(w2[4], 1.5 * std::sqrt(2.0));
  EXPECT_DOUBLE_EQ(w2[1], 0.5 * (1.0 + 3.0 * std::sqrt(2.0)));
  // A surface: the triangle's edges; an unused node weighs 0.
  Mesh tri;
  tri.rest_positions = {0, 0, 0, 3, 0, 0, 0, 4, 0, 9, 9, 9};
  tri.triangles = {0, 1, 2};
  const std::vector<double> wt = node_weights(tri);
  EXPECT_DOUBLE_EQ(wt[0], 3.5);
  EXPECT_DOUBLE_EQ(wt[1], 4.0);
  EXPECT_DOUBLE_EQ(wt[2], 4.5);
  EXPECT_EQ(wt[3], 0.0);
}

/// Largest |x| over the last 100 of `steps` symplectic Euler steps of m x'' = -k w x - c w x'
/// from x = 1, v = 0 (infinity once it is no longer finite).
double late_amplitude(double m, double k, double c, double w, double dt, int steps) {
  double x = 1.0, v = 0.0, late = 0.0;
  for (int i = 0; i < steps; ++i) {
    v += dt * (-k * w * x - c * w * v) / m;
    x += dt * v;
    if (!std::isfinite(x)) return HUGE_VAL;
    if (i >= steps - 100) late = std::max(late, std::abs(x));
  }
  return late;
}

TEST(ClientIntegration, TheBoundSeparatesStableFromGrowingSteps) {
  const Mesh mesh = unit_tet();
  const std::vector<double> w = node_weights(mesh);
  const std::vector<double> mass = {0.02, 0.05, 0.05, 0.05};
  const double dt = 1e-3;
  for (const double c : {0.0, 1.0, 10.0}) {
    SCOPED_TRACE(c);
    const double k = max_explicit_stiffness(mesh, mass, dt, c);
    ASSERT_GT(k, 0.0);
    // The bound is set by the node with the smallest m / w: node 0 here.
    EXPECT_NEAR(k, (4.0 * mass[0] - 2.0 * c * w[0] * dt) / (w[0] * dt * dt), 1e-9 * k);
    // Below it every node stays bounded (symplectic Euler's undamped amplitude near the
    // limit exceeds the start: 1 / sqrt(1 - 0.9) = 3.2 at 90 % of it); above it the
    // limiting node grows without bound.
    for (std::size_t i = 0; i < 4; ++i)
      EXPECT_LE(late_amplitude(mass[i], 0.9 * k, c, w[i], dt, 20000), 3.3) << i;
    EXPECT_GT(late_amplitude(mass[0], 1.1 * k, c, w[0], dt, 20000), 1e6);
  }
  // Damping alone over its own limit: no stiffness is stable.
  EXPECT_EQ(max_explicit_stiffness(mesh, mass, dt, 2.0 * mass[0] / (w[0] * dt)), 0.0);
}

TEST(ClientIntegration, BadArgumentsAreNamed) {
  const Mesh mesh = unit_tet();
  const std::vector<double> mass = {1, 1, 1, 1};
  const auto message = [&](auto&& call) {
    try {
      call();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([&] {
              max_explicit_stiffness(mesh, std::vector<double>{1, 1}, 1e-3);
            }).find("2 node masses for 4 nodes"),
            std::string::npos);
  EXPECT_NE(message([&] {
              max_explicit_stiffness(mesh, std::vector<double>{1, 1, -1, 1}, 1e-3);
            }).find("node 2 has mass"),
            std::string::npos);
  EXPECT_NE(message([&] { max_explicit_stiffness(mesh, mass, 0.0); }).find("dt"),
            std::string::npos);
  EXPECT_NE(message([&] { max_explicit_stiffness(mesh, mass, 1e-3, NAN); }).find("damping"),
            std::string::npos);
  Mesh bad = mesh;
  bad.tets[3] = 7;
  EXPECT_NE(message([&] { node_weights(bad); }).find("node 7"), std::string::npos);
}

}  // namespace
}  // namespace tc::client
