// What the daemon publishes, as plain C++ messages, and the interface that sends them
// (DDS writers in the daemon, a recorder in the tests). Publishing may be called from
// several threads at once.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh/tet_mesh.hpp"
#include "core/pipeline/pipeline.hpp"

namespace tc::daemon {

/// Contact forces on one object for one answered frame (ContactForces topic).
struct ForcesMessage {
  std::string_view scene;
  std::string_view object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::int32_t status = 0;            ///< STATUS_*
  std::span<const Index> nodes;       ///< k sorted node indices
  std::span<const double> forces;     ///< 3k, newtons
  std::span<const double> stiffness;  ///< 9k row-major df/dx blocks, or empty
  std::span<const double> damping;    ///< 9k row-major df/dv blocks, with stiffness
  /// The contacts behind the forces (the object asked: ObjectParams::contacts), or null.
  const ObjectContacts* contacts = nullptr;
  /// Frame of the object's state the forces were computed from (-1: rest positions).
  std::int64_t state_frame = -1;
  /// The computation that produced this answer, shared by every answer of one frame
  /// computation with status OK (ContactForces.answer_id); 0 for rejected answers.
  std::uint64_t answer_id = 0;
  /// Moving objects of the scene the computation left out (no state of their current
  /// topology version), sorted by name; empty in rejected answers.
  std::span<const std::string> left_out;
};

/// A rejected answer (docs/PROTOCOL.md, ContactForces): `code` for the object's state of
/// `frame`, the version the service holds for it (0: none), answer_id 0, no arrays.
inline ForcesMessage rejected_answer(std::string_view scene, std::string_view object,
                                     std::int64_t frame, std::uint32_t topology_version,
                                     std::int32_t code) {
  ForcesMessage f;
  f.scene = scene;
  f.object = object;
  f.frame = frame;
  f.topology_version = topology_version;
  f.status = code;
  f.state_frame = frame;
  return f;
}

/// One scene's frame timings and counts (FrameStats topic).
struct StatsMessage {
  std::string_view scene;
  std::int64_t frame = 0;
  double assembly_ms = 0.0;
  double queue_ms = 0.0;
  FrameStats core;  ///< the pipeline's stage timings and counts
  double publish_ms = 0.0;
  std::uint32_t objects = 0;
  std::uint32_t states = 0;
  std::uint32_t rejected = 0;
  std::uint64_t dropped_frames = 0;
};

enum class StatusKind { kHeartbeat, kStateChange, kRegistered, kRemoved, kError };
enum class ServiceState { kStarting, kReady, kStopping };

/// A life-cycle event, a registration or an error (ServiceStatus topic).
struct StatusMessage {
  StatusKind kind = StatusKind::kError;
  std::int32_t code = 0;  ///< STATUS_*
  std::string scene;
  std::string object;
  std::uint32_t topology_version = 0;
  std::int64_t frame = -1;
  std::string message;
  std::int64_t topology_timestamp = 0;  ///< verdicts on a topology: its source timestamp
};

class Outbox {
 public:
  virtual ~Outbox() = default;
  virtual void publish_forces(const ForcesMessage& message) = 0;
  virtual void publish_stats(const StatsMessage& message) = 0;
  virtual void publish_status(const StatusMessage& message) = 0;
};

}  // namespace tc::daemon
