// The sessions the replay tests record and replay (and that made the committed
// recordings in tests/data/recordings, see its README): small meshes, a few dozen
// frames, lock-step (each frame waits for its answer).
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "scenes.hpp"

namespace tc::itest {

/// Names of the scenarios; each runs in the scene of the same name.
inline const std::vector<std::string>& scenario_names() {
  static const std::vector<std::string> names{"two_boxes", "cut_and_errors", "surface_tool"};
  return names;
}

/// What a recording of a scenario holds: its objects and its frames 0 .. frames - 1.
struct ScenarioShape {
  std::size_t objects = 0;
  std::int64_t frames = 0;
};

inline ScenarioShape scenario_shape(const std::string& name) {
  if (name == "two_boxes") return {2, 40};
  if (name == "cut_and_errors") return {3, 30};
  if (name == "surface_tool") return {2, 24};
  ADD_FAILURE() << "unknown scenario " << name;
  return {};
}

/// Streams scenario `name` through `c` (connected to scene `name`, service ready).
/// `registered` runs once every object is registered, before the first frame.
inline void run_scenario(client::Client& c, const std::string& name,
                         const std::function<void()>& registered = {}) {
  using namespace std::chrono_literals;
  const client::Mesh a = box_mesh(2, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh b = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  const auto step = [&](std::int64_t f, const std::vector<client::ObjectState>& states) {
    c.publish_states(f, states);
    const auto forces = c.wait_forces(f, 10s);
    ASSERT_TRUE(forces && forces->frame == f) << name << " frame " << f;
  };
  if (name == "two_boxes") {
    c.register_object("a", a, {});
    c.register_object("b", b, {});
    ASSERT_TRUE(c.wait_registered("a", 10s).ok);
    ASSERT_TRUE(c.wait_registered("b", 10s).ok);
    if (registered) registered();
    for (std::int64_t f = 0; f < 40; ++f) {
      const double s = std::sin(0.15 * static_cast<double>(f));
      const auto pa = translated(a, {0.05 * s, 0.01 * s, 0.0});
      const auto pb = translated(b, {-0.003 * static_cast<double>(f), 0.0, 0.02 * s});
      step(f, {{"a", pa}, {"b", pb}});
    }
    return;
  }
  if (name == "cut_and_errors") {
    client::ObjectParams floor_params;
    floor_params.is_static = true;
    floor_params.stiffness = 5e4;
    c.register_object("floor", box_mesh(2, {-2, -2, -1.2}, {2, 2, -0.45}), floor_params);
    c.register_object("a", a, {});
    c.register_object("b", b, {});
    for (const char* o : {"floor", "a", "b"}) ASSERT_TRUE(c.wait_registered(o, 10s).ok) << o;
    if (registered) registered();
    const client::Mesh b2 = box_mesh(1, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
    for (std::int64_t f = 0; f < 30; ++f) {
      if (f == 15) {
        ASSERT_EQ(c.register_object("b", b2, {}), 2u);  // the cut
        ASSERT_TRUE(c.wait_registered("b", 10s).ok);
      }
      const double s = std::sin(0.2 * static_cast<double>(f));
      auto pa = translated(a, {0.0, 0.0, -0.02 * static_cast<double>(f % 10)});
      if (f == 20) pa[4] = std::nan("");  // a bad state: rejected, a's answer has the error
      const auto pb = translated(f < 15 ? b : b2, {-0.1 * s, 0.0, 0.0});
      step(f, {{"a", pa}, {"b", pb}});
    }
    return;
  }
  if (name == "surface_tool") {
    // A surface object (issue 19): a plate of triangles pressed into a static box and
    // dragged across it, cut (a finer plate, version 2) at frame 12, a NaN at frame 16.
    client::ObjectParams box_params;
    box_params.is_static = true;
    c.register_object("box", box_mesh(3, {-1, -1, -1}, {1, 1, 0}), box_params);
    const client::Mesh plate = plate_mesh(4, 0.6, {-0.3, -0.3, 0.0});
    const client::Mesh plate2 = plate_mesh(6, 0.6, {-0.3, -0.3, 0.0});
    client::ObjectParams tool;
    tool.response = client::ResponseKind::kPoint;
    c.register_object("tool", plate, tool);
    for (const char* o : {"box", "tool"}) ASSERT_TRUE(c.wait_registered(o, 10s).ok) << o;
    if (registered) registered();
    for (std::int64_t f = 0; f < 24; ++f) {
      if (f == 12) {
        ASSERT_EQ(c.register_object("tool", plate2, tool), 2u);  // the cut
        ASSERT_TRUE(c.wait_registered("tool", 10s).ok);
      }
      const double t = static_cast<double>(f);
      auto p = translated(f < 12 ? plate : plate2, {0.02 * t, 0.01 * t, 0.02 - 0.004 * t});
      if (f == 16) p[7] = std::nan("");  // rejected: the tool's answer has the error
      step(f, {{"tool", p}});
    }
    return;
  }
  FAIL() << "unknown scenario " << name;
}

}  // namespace tc::itest
