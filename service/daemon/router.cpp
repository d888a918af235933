#include "router.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <span>

#include "protocol.hpp"
#include "tetcollide.h"

namespace tc::daemon {
namespace {

/// Held states across all scenes; one more is rejected at once (unknown_object).
constexpr std::size_t kMaxHeld = 1024;
/// One log line per (scene, object, code) per window; the rest are counted.
constexpr auto kReportWindow = std::chrono::seconds(1);
constexpr std::size_t kMaxThrottleEntries = 4096;

Clock::duration from_ms(double ms) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(ms));
}

/// FNV-1a over the bytes of a range of trivially copyable values, continuing from `h`.
template <typename T>
std::uint64_t hash_bytes(std::uint64_t h, std::span<const T> values) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
  for (std::size_t i = 0; i < values.size_bytes(); ++i) h = (h ^ bytes[i]) * 0x100000001b3ULL;
  return h;
}

/// What tells two MeshTopology samples of one version apart: every field but the keys
/// and the version (doubles by their bits, so a re-sent sample always matches itself).
std::uint64_t content_hash(const TopologyView& t) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  const std::array<std::uint64_t, 4> sizes{t.node_ids.size(), t.rest_positions.size(),
                                           t.tets.size(), t.triangles.size()};
  h = hash_bytes(h, std::span<const std::uint64_t>(sizes));
  h = hash_bytes(h, t.node_ids);
  h = hash_bytes(h, t.rest_positions);
  h = hash_bytes(h, t.tets);
  h = hash_bytes(h, t.triangles);
  const std::array<double, 5> numbers{t.params.stiffness, t.params.damping, t.params.max_force,
                                      t.params.friction, t.params.friction_velocity};
  h = hash_bytes(h, std::span<const double>(numbers));
  const std::array<std::int64_t, 6> choices{t.params.is_static ? 1 : 0,
                                            static_cast<std::int64_t>(t.params.depth),
                                            static_cast<std::int64_t>(t.params.response),
                                            t.params.blocks ? 1 : 0,
                                            t.params.contacts ? 1 : 0,
                                            t.params.self_contact ? 1 : 0};
  return hash_bytes(h, std::span<const std::int64_t>(choices));
}

/// Printable form of a name that may be invalid (control characters replaced).
std::string printable(std::string_view text) {
  std::string out(text.substr(0, 256));
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return out;
}

}  // namespace

Router::Router(const DaemonConfig& config, Outbox& outbox, JobSink& jobs)
    : config_(config),
      outbox_(outbox),
      jobs_(jobs),
      assembly_wait_(from_ms(config.assembly_wait_ms)),
      grace_(from_ms(config.unknown_object_grace_ms)) {}

const SceneRegistry* Router::registry(std::string_view scene) const {
  const auto it = scenes_.find(scene);
  return it == scenes_.end() ? nullptr : &it->second.registry;
}

std::size_t Router::object_count() const {
  std::size_t n = 0;
  for (const auto& [name, scene] : scenes_) n += scene.registry.size();
  return n;
}

void Router::report(std::int32_t code, std::string_view scene, std::string_view object,
                    std::uint32_t version, std::int64_t frame, const std::string& message,
                    Clock::time_point now, std::int64_t topology_timestamp) {
  // Every rejection goes to the status topic; the log gets one line per (scene, object,
  // code) per window so a client sending bad frames at 1 kHz cannot flood it.
  StatusMessage msg;
  msg.kind = StatusKind::kError;
  msg.code = code;
  msg.scene = printable(scene);
  msg.object = printable(object);
  msg.topology_version = version;
  msg.frame = frame;
  msg.message = message;
  msg.topology_timestamp = topology_timestamp;
  outbox_.publish_status(msg);

  if (throttle_.size() > kMaxThrottleEntries) throttle_.clear();
  Throttle& t = throttle_[{msg.scene, msg.object, code}];
  if (t.last != Clock::time_point{} && now - t.last < kReportWindow) {
    ++t.suppressed;
    return;
  }
  std::string suppressed;
  if (t.suppressed > 0)
    suppressed = " (" + std::to_string(t.suppressed) + " similar errors not logged)";
  t.last = now;
  t.suppressed = 0;
  spdlog::warn("{}/{}: rejected ({}): {}{}", msg.scene, msg.object, protocol::status_name(code),
               message, suppressed);
}

void Router::answer_now(std::string_view scene, std::string_view object, std::int64_t frame,
                        std::int32_t code) {
  const SceneRegistry* reg = registry(scene);
  const VersionInfo* current = reg == nullptr ? nullptr : reg->current(object);
  outbox_.publish_forces(
      rejected_answer(scene, object, frame, current == nullptr ? 0 : current->version, code));
}

void Router::on_topology(const TopologyView& t, Clock::time_point now) {
  if (!scene_selected(config_.scenes, t.scene)) {
    spdlog::debug("{}/{}: topology ignored (scene not served here)", printable(t.scene),
                  printable(t.object));
    return;
  }
  if (Status st = validate_topology(t, config_.limits); !st) {
    report(status_code(st.error().code), t.scene, t.object, t.version, -1,
           "topology version " + std::to_string(t.version) + ": " + st.error().message, now,
           t.source_timestamp);
    return;
  }
  auto it = scenes_.find(t.scene);
  if (it == scenes_.end()) {
    if (static_cast<std::int64_t>(scenes_.size()) >= config_.limits.max_scenes) {
      report(tetcollide_STATUS_OVERSIZED, t.scene, t.object, t.version, -1,
             "limits.max_scenes = " + std::to_string(config_.limits.max_scenes) +
                 " scenes are served already",
             now, t.source_timestamp);
      return;
    }
    it = scenes_.emplace(std::string(t.scene), Scene(assembly_wait_)).first;
  }
  Scene& scene = it->second;
  const std::string object(t.object);
  if (scene.registry.current(object) == nullptr &&
      static_cast<std::int64_t>(scene.registry.size()) >= config_.limits.max_objects_per_scene) {
    report(tetcollide_STATUS_OVERSIZED, t.scene, t.object, t.version, -1,
           "limits.max_objects_per_scene = " +
               std::to_string(config_.limits.max_objects_per_scene) + " reached",
           now, t.source_timestamp);
    close_if_empty(it);
    return;
  }
  const VersionInfo info{t.version, static_cast<Index>(t.rest_positions.size() / 3),
                         t.params.is_static, content_hash(t)};
  if (const VersionInfo* current = scene.registry.current(object);
      current != nullptr && current->version == t.version) {
    // The version already submitted, sent again: not rebuilt, but answered, so a client
    // that waits for the verdict on this write gets one (docs/PROTOCOL.md, MeshTopology).
    if (current->content_hash != info.content_hash) {
      report(tetcollide_STATUS_INVALID_ARGUMENT, t.scene, t.object, t.version, -1,
             "topology version " + std::to_string(t.version) +
                 " is already registered with a different content (node ids, rest positions, "
                 "tets or parameters); a changed topology needs a new version, the registered "
                 "one stays",
             now, t.source_timestamp);
      return;
    }
    spdlog::debug("{}/{}: topology version {} received again, unchanged", it->first, object,
                  t.version);
    jobs_.post(it->first, VerdictJob{object, t.version, t.source_timestamp});
    return;
  }
  scene.registry.submit(object, info);
  TopologyJob job;
  job.object = object;
  job.version = t.version;
  job.mesh = to_mesh(t);
  job.params = to_params(t.params);
  job.received = now;
  job.source_timestamp = t.source_timestamp;
  if (t.triangles.empty())
    spdlog::info("{}/{}: topology version {} received ({} nodes, {} tets)", it->first, object,
                 t.version, info.nodes, t.tets.size() / 4);
  else
    spdlog::info("{}/{}: topology version {} received (a surface: {} nodes, {} triangles)",
                 it->first, object, t.version, info.nodes, t.triangles.size() / 3);
  jobs_.post(it->first, std::move(job));
  release_held(it->first, scene, object, now);
}

void Router::on_topology_gone(std::string_view scene_name, std::string_view object_name) {
  held_.erase(HeldKey{std::string(scene_name), std::string(object_name)});
  const auto it = scenes_.find(scene_name);
  if (it == scenes_.end()) return;
  const std::string object(object_name);
  Scene& scene = it->second;
  if (scene.registry.current(object) == nullptr) return;
  scene.registry.remove(object);
  scene.assembler.remove(object);
  spdlog::info("{}/{}: topology disposed or its writer is gone; removing the object", it->first,
               object);
  jobs_.post(it->first, RemoveJob{object});
  close_if_empty(it);
}

void Router::close_if_empty(std::map<std::string, Scene, std::less<>>::iterator it) {
  if (!it->second.registry.empty()) return;
  jobs_.close_scene(it->first);
  scenes_.erase(it);
}

void Router::on_topology_result(const TopologyResult& r, Clock::time_point now) {
  const auto it = scenes_.find(r.scene);
  if (it == scenes_.end()) return;
  it->second.registry.confirm(r.object, r.version, r.ok);
  if (r.ok) return;
  if (it->second.registry.current(r.object) == nullptr) it->second.assembler.remove(r.object);
  if (it->second.registry.empty()) {
    close_if_empty(it);
    return;
  }
  try_dispatch(it->first, it->second, now);
}

void Router::on_state(const StateView& s, Clock::time_point now) {
  if (!scene_selected(config_.scenes, s.scene)) return;
  if (Status st = validate_state_header(s, config_.limits); !st) {
    const auto code = status_code(st.error().code);
    report(code, s.scene, s.object, s.topology_version, s.frame, st.error().message, now);
    const auto it = scenes_.find(s.scene);
    if (it != scenes_.end() && it->second.registry.current(s.object) != nullptr) {
      add_rejected(it->second, s, code, st.error().message, now);
      try_dispatch(it->first, it->second, now);
    } else if (validate_name(s.scene, tetcollide_MAX_SCENE_NAME, "scene") &&
               validate_name(s.object, tetcollide_MAX_OBJECT_NAME, "object")) {
      answer_now(s.scene, s.object, s.frame, code);
    }
    return;
  }
  const auto it = scenes_.find(s.scene);
  const auto match = it == scenes_.end() ? SceneRegistry::Match::kUnknown
                                         : it->second.registry.match(s.object, s.topology_version);
  if (match == SceneRegistry::Match::kUnknown) {
    hold(s, now);
    return;
  }
  admit(it->first, it->second, s, now, now);
  try_dispatch(it->first, it->second, now);
}

void Router::admit(const std::string& scene_name, Scene& scene, const StateView& s,
                   Clock::time_point received, Clock::time_point now) {
  const VersionInfo* current = scene.registry.current(s.object);
  if (scene.registry.match(s.object, s.topology_version) == SceneRegistry::Match::kStale) {
    const std::string message = "frame " + std::to_string(s.frame) + ": topology version " +
                                std::to_string(s.topology_version) + " is stale (current is " +
                                std::to_string(current->version) + ")";
    report(tetcollide_STATUS_STALE_VERSION, scene_name, s.object, s.topology_version, s.frame,
           message, now);
    add_rejected(scene, s, tetcollide_STATUS_STALE_VERSION, message, received);
    return;
  }
  if (Status st = validate_state(s, config_.limits, current->nodes); !st) {
    const auto code = status_code(st.error().code);
    report(code, scene_name, s.object, s.topology_version, s.frame, st.error().message, now);
    add_rejected(scene, s, code, st.error().message, received);
    return;
  }
  PendingState p;
  p.object = std::string(s.object);
  p.version = s.topology_version;
  p.frame = s.frame;
  p.positions = to_positions(s.positions);
  if (!s.velocities.empty()) p.velocities = to_positions(s.velocities);
  p.received = received;
  scene.assembler.add(std::move(p));
}

void Router::add_rejected(Scene& scene, const StateView& s, std::int32_t code,
                          const std::string& message, Clock::time_point received) {
  PendingState p;
  p.object = std::string(s.object);
  p.version = s.topology_version;
  p.frame = s.frame;
  p.received = received;
  p.rejected_code = code;
  p.rejected_message = message;
  scene.assembler.add(std::move(p));
}

bool Router::holds_state(const std::string& scene_name) const {
  const auto it = held_.lower_bound(HeldKey{scene_name, std::string()});
  return it != held_.end() && it->first.first == scene_name;
}

void Router::try_dispatch(const std::string& scene_name, Scene& scene, Clock::time_point now) {
  // A state that waits for its topology (a cut in flight, or an object whose topology is
  // still on the wire, e.g. right after a service restart) is resolved first, within the
  // grace: admitted or rejected, it then takes part in the frame. Without this wait the
  // frame would be computed without that object and its answer would differ from the
  // one computed with every state (found by the restart test in tests/reliability).
  if (holds_state(scene_name)) return;
  auto frame = scene.assembler.poll(scene.registry.expected(), now);
  if (!frame) return;
  FrameJob job;
  job.frame = frame->frame;
  job.first_received = frame->first_received;
  job.dispatched = now;
  job.complete = frame->complete;
  for (auto& s : frame->states) {
    if (s.rejected_code != 0) {
      job.rejected.push_back(RejectedState{std::move(s.object), s.version, s.rejected_code});
    } else {
      FrameObjectInput in;
      in.object = std::move(s.object);
      in.topology_version = s.version;
      in.positions = std::move(s.positions);
      in.velocities = std::move(s.velocities);
      job.states.push_back(std::move(in));
      job.state_frames.push_back(s.frame);
    }
  }
  if (!frame->complete && spdlog::should_log(spdlog::level::debug)) {
    std::string missing;
    for (const auto& name : scene.registry.expected()) {
      const auto has = [&](const auto& s) { return s.object == name; };
      if (std::none_of(job.states.begin(), job.states.end(), has) &&
          std::none_of(job.rejected.begin(), job.rejected.end(), has))
        missing += (missing.empty() ? "" : ", ") + name;
    }
    spdlog::debug(
        "{}: frame {} dispatched after the assembly wait with {} of {} states (none from {})",
        scene_name, job.frame, job.states.size() + job.rejected.size(), scene.registry.size(),
        missing);
  }
  jobs_.post(scene_name, std::move(job));
  ++dispatched_frames_;
}

void Router::hold(const StateView& s, Clock::time_point now) {
  HeldKey key{std::string(s.scene), std::string(s.object)};
  auto it = held_.find(key);
  if (it == held_.end() && held_.size() >= kMaxHeld) {
    const std::string message = "frame " + std::to_string(s.frame) +
                                ": no topology for this object (and too many states held)";
    report(tetcollide_STATUS_UNKNOWN_OBJECT, s.scene, s.object, s.topology_version, s.frame,
           message, now);
    answer_now(s.scene, s.object, s.frame, tetcollide_STATUS_UNKNOWN_OBJECT);
    return;
  }
  Held& h = held_[key];
  h.frame = s.frame;
  h.version = s.topology_version;
  h.positions.assign(s.positions.begin(), s.positions.end());
  h.velocities.assign(s.velocities.begin(), s.velocities.end());
  if (it == held_.end()) h.received = now;  // the grace runs from the first held state
}

void Router::release_held(const std::string& scene_name, Scene& scene, const std::string& object,
                          Clock::time_point now) {
  const auto it = held_.find(HeldKey{scene_name, object});
  if (it == held_.end()) return;
  if (scene.registry.match(object, it->second.version) == SceneRegistry::Match::kUnknown) return;
  const Held h = std::move(it->second);
  held_.erase(it);
  StateView view;
  view.scene = scene_name;
  view.object = object;
  view.frame = h.frame;
  view.topology_version = h.version;
  view.positions = h.positions;
  view.velocities = h.velocities;
  admit(scene_name, scene, view, h.received, now);
  try_dispatch(scene_name, scene, now);
}

void Router::tick(Clock::time_point now) {
  for (auto it = held_.begin(); it != held_.end();) {
    if (now - it->second.received < grace_) {
      ++it;
      continue;
    }
    const auto& [scene_name, object] = it->first;
    const auto scene = scenes_.find(scene_name);
    const bool known = scene != scenes_.end() && scene->second.registry.current(object) != nullptr;
    const std::int32_t code =
        known ? tetcollide_STATUS_STALE_VERSION : tetcollide_STATUS_UNKNOWN_OBJECT;
    const std::string message =
        known ? "frame " + std::to_string(it->second.frame) + ": topology version " +
                    std::to_string(it->second.version) + " was never registered (current is " +
                    std::to_string(scene->second.registry.current(object)->version) + ")"
              : "frame " + std::to_string(it->second.frame) +
                    ": no topology registered for this object";
    report(code, scene_name, object, it->second.version, it->second.frame, message, now);
    if (known) {
      StateView view;
      view.scene = scene_name;
      view.object = object;
      view.frame = it->second.frame;
      view.topology_version = it->second.version;
      add_rejected(scene->second, view, code, message, it->second.received);
    } else {
      answer_now(scene_name, object, it->second.frame, code);
    }
    it = held_.erase(it);
  }
  for (auto& [name, scene] : scenes_) try_dispatch(name, scene, now);
}

std::optional<Clock::time_point> Router::next_deadline() const {
  std::optional<Clock::time_point> out;
  const auto consider = [&](Clock::time_point t) {
    if (!out || t < *out) out = t;
  };
  for (const auto& [name, scene] : scenes_)
    if (const auto d = scene.assembler.deadline()) consider(*d);
  for (const auto& [key, h] : held_) consider(h.received + grace_);
  return out;
}

}  // namespace tc::daemon
