// What `tetcollide status` shows: every tetcollided on a domain and what its scenes are
// doing, from the ServiceStatus and FrameStats topics alone (docs/PROTOCOL.md), so it
// works against any service of the domain, on this host or another.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/result.hpp"

namespace tc::replay {

/// One service, from its newest ServiceStatus sample.
struct ServiceView {
  std::string id;
  std::string state;  ///< "starting", "ready" or "stopping"
  std::uint32_t protocol_version = 0;
  double uptime_s = 0.0;  ///< 0 from services before protocol 3
  std::int32_t ownership_strength = 0;
  std::string message;  ///< of that sample (a heartbeat: "N scenes")
  bool alive = true;    ///< false once its ServiceStatus instance lost its writer
};

/// One scene, from its FrameStats samples of the window and the errors about it.
struct SceneView {
  std::string scene;
  std::uint32_t objects = 0;  ///< registered objects (newest FrameStats)
  std::size_t frames = 0;     ///< FrameStats samples (answered frames) in the window
  double frames_per_s = 0.0;
  double compute_ms_p50 = 0.0;  ///< pipeline time per frame, nearest rank
  double compute_ms_p99 = 0.0;
  std::uint64_t contacts = 0;        ///< newest frame
  std::uint64_t rejected = 0;        ///< objects rejected, summed over the window's frames
  std::uint64_t dropped_frames = 0;  ///< newest FrameStats (since the scene started)
  std::vector<std::string> errors;   ///< the newest error messages about it, newest last
};

struct StatusSnapshot {
  double window_s = 0.0;
  std::vector<ServiceView> services;  ///< by id
  std::vector<SceneView> scenes;      ///< by name
};

/// Listens on `domain` (and `partition`) for `window`, or until `stop`: the services
/// heard (their transient-local status history arrives at once) and the scenes that
/// answered frames or had errors in that time. kIo for DDS errors.
class StatusWatcher {
 public:
  static Expected<StatusWatcher> create(std::uint32_t domain, const std::string& partition);
  StatusWatcher(StatusWatcher&&) noexcept;
  StatusWatcher& operator=(StatusWatcher&&) noexcept;
  ~StatusWatcher();
  Expected<StatusSnapshot> listen(std::chrono::milliseconds window, const std::atomic<bool>& stop);

 private:
  StatusWatcher() = default;
  struct Impl;
  Impl* impl_ = nullptr;
};

}  // namespace tc::replay
