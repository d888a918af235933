// A thread-safe Outbox that keeps every message (copies), for the runner and scheduler
// tests. `gate_status` makes publish_status block until open() — a way to hold a scene's
// runner busy at a known point.
#pragma once

#include <condition_variable>
#include <mutex>
#include <string>
#include <vector>

#include "outbox.hpp"

namespace tc::daemon::test {

struct Forces {
  std::string scene, object;
  std::int64_t frame = 0;
  std::uint32_t version = 0;
  std::int32_t status = 0;
  std::vector<Index> nodes;
  std::vector<double> forces;
  std::vector<double> stiffness;
  std::int64_t state_frame = -1;
  std::uint64_t answer_id = 0;
  std::vector<std::string> left_out;
};

struct Stats {
  std::string scene;
  std::int64_t frame = 0;
  std::uint32_t objects = 0, states = 0, rejected = 0;
  std::uint64_t dropped = 0;
  double compute_ms = 0.0;
};

class OutboxRecorder final : public Outbox {
 public:
  void publish_forces(const ForcesMessage& m) override {
    std::lock_guard lock(mutex_);
    forces.push_back({std::string(m.scene),
                      std::string(m.object),
                      m.frame,
                      m.topology_version,
                      m.status,
                      {m.nodes.begin(), m.nodes.end()},
                      {m.forces.begin(), m.forces.end()},
                      {m.stiffness.begin(), m.stiffness.end()},
                      m.state_frame,
                      m.answer_id,
                      {m.left_out.begin(), m.left_out.end()}});
  }
  void publish_stats(const StatsMessage& m) override {
    std::lock_guard lock(mutex_);
    stats.push_back({std::string(m.scene), m.frame, m.objects, m.states, m.rejected,
                     m.dropped_frames, m.core.total_ms});
    changed_.notify_all();
  }
  void publish_status(const StatusMessage& m) override {
    std::unique_lock lock(mutex_);
    gate_cv_.wait(lock, [&] { return !gated_; });
    status.push_back(m);
    changed_.notify_all();
  }
  void close_gate() {
    std::lock_guard lock(mutex_);
    gated_ = true;
  }
  void open_gate() {
    {
      std::lock_guard lock(mutex_);
      gated_ = false;
    }
    gate_cv_.notify_all();
  }
  /// Waits until `n` stats samples are in (bounded).
  bool wait_stats(std::size_t n, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return stats.size() >= n; });
  }
  std::vector<Forces> forces_of(const std::string& scene, std::int64_t frame) {
    std::lock_guard lock(mutex_);
    std::vector<Forces> out;
    for (const auto& f : forces)
      if (f.scene == scene && f.frame == frame) out.push_back(f);
    return out;
  }

  std::vector<Forces> forces;
  std::vector<Stats> stats;
  std::vector<StatusMessage> status;

 private:
  std::mutex mutex_;
  std::condition_variable gate_cv_;
  std::condition_variable changed_;
  bool gated_ = false;
};

}  // namespace tc::daemon::test
