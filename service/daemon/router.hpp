// The reader thread's side of the daemon: every topic sample goes through here. It
// validates the sample, keeps the per-scene registries, assembles frames, holds states
// that arrive before their topology, reports bad input (log + ServiceStatus, answered
// frames carry the error code) and posts jobs to the scenes' runners. DDS-free and
// single-threaded: time is passed in, so every rule is unit-tested with a fake clock.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "config.hpp"
#include "frame_assembler.hpp"
#include "outbox.hpp"
#include "registry.hpp"
#include "samples.hpp"
#include "scheduler.hpp"

namespace tc::daemon {

class Router {
 public:
  Router(const DaemonConfig& config, Outbox& outbox, JobSink& jobs);

  /// A MeshTopology sample (valid data).
  void on_topology(const TopologyView& topology, Clock::time_point now);

  /// A MeshTopology instance was disposed or lost all its writers: remove the object.
  void on_topology_gone(std::string_view scene, std::string_view object);

  /// A MeshState sample.
  void on_state(const StateView& state, Clock::time_point now);

  /// The pipeline's verdict on a topology job.
  void on_topology_result(const TopologyResult& result, Clock::time_point now);

  /// Dispatches frames that waited long enough and rejects held states that expired.
  void tick(Clock::time_point now);

  /// When tick() has something to do at the latest; nullopt when nothing is pending.
  [[nodiscard]] std::optional<Clock::time_point> next_deadline() const;

  [[nodiscard]] std::size_t scene_count() const { return scenes_.size(); }
  /// Objects registered across every scene (static ones too).
  [[nodiscard]] std::size_t object_count() const;
  /// Frames handed to the scenes' pipelines since the start (complete or not).
  [[nodiscard]] std::uint64_t dispatched_frames() const { return dispatched_frames_; }
  /// The registry of a scene, or null (tests and diagnostics).
  [[nodiscard]] const SceneRegistry* registry(std::string_view scene) const;
  /// States held for a topology that has not arrived.
  [[nodiscard]] std::size_t held_states() const { return held_.size(); }

 private:
  struct Scene {
    explicit Scene(Clock::duration wait) : assembler(wait) {}
    SceneRegistry registry;
    FrameAssembler assembler;
  };
  /// A state whose (object, version) is not registered yet.
  struct Held {
    std::int64_t frame = 0;
    std::uint32_t version = 0;
    std::vector<double> positions;
    std::vector<double> velocities;
    Clock::time_point received{};
  };
  using HeldKey = std::pair<std::string, std::string>;  // scene, object

  void admit(const std::string& scene_name, Scene& scene, const StateView& state,
             Clock::time_point received, Clock::time_point now);
  void add_rejected(Scene& scene, const StateView& state, std::int32_t code,
                    const std::string& message, Clock::time_point received);
  void try_dispatch(const std::string& scene_name, Scene& scene, Clock::time_point now);
  void release_held(const std::string& scene_name, Scene& scene, const std::string& object,
                    Clock::time_point now);
  void hold(const StateView& state, Clock::time_point now);
  /// True while a state of the scene waits for its topology (within the grace).
  [[nodiscard]] bool holds_state(const std::string& scene_name) const;
  /// A rejected answer outside any computation (the scene does not hold the state).
  void answer_now(std::string_view scene, std::string_view object, std::int64_t frame,
                  std::int32_t code);
  void report(std::int32_t code, std::string_view scene, std::string_view object,
              std::uint32_t version, std::int64_t frame, const std::string& message,
              Clock::time_point now, std::int64_t topology_timestamp = 0);
  void close_if_empty(std::map<std::string, Scene, std::less<>>::iterator it);

  const DaemonConfig& config_;
  Outbox& outbox_;
  JobSink& jobs_;
  Clock::duration assembly_wait_;
  Clock::duration grace_;
  std::map<std::string, Scene, std::less<>> scenes_;
  std::map<HeldKey, Held> held_;
  std::uint64_t dispatched_frames_ = 0;

  // Log rate limit per (scene, object, code): one line per window.
  struct Throttle {
    Clock::time_point last{};
    std::uint64_t suppressed = 0;
  };
  std::map<std::tuple<std::string, std::string, std::int32_t>, Throttle> throttle_;
};

}  // namespace tc::daemon
