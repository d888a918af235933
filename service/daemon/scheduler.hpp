// Runs scene jobs on a TBB arena: jobs of one scene run one at a time and in order,
// scenes run in parallel. Each scene keeps at most `max_queued_frames` frame jobs
// waiting; one more drops the oldest waiting frame (newest wins, counted per scene).
// Topology and remove jobs are never dropped.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "scene_runner.hpp"

namespace tc::daemon {

/// Where the reader thread sends scene jobs (the Scheduler, or a test double).
class JobSink {
 public:
  virtual ~JobSink() = default;
  virtual void post(const std::string& scene, SceneJob job) = 0;
  /// The scene has no objects left: its runner (and pipeline memory) goes once its
  /// queued jobs are done. A later post() starts a new runner.
  virtual void close_scene(const std::string& scene) = 0;
};

class Scheduler final : public JobSink {
 public:
  using RunnerFactory = std::function<std::unique_ptr<SceneRunner>(const std::string& scene)>;

  /// threads: 0 = one per core.
  Scheduler(int threads, int max_queued_frames, RunnerFactory factory);
  ~Scheduler() override;
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  void post(const std::string& scene, SceneJob job) override;
  void close_scene(const std::string& scene) override;

  /// Drops every waiting job, lets running ones finish and waits for them at most
  /// `timeout`. Returns false on timeout. Later posts are ignored.
  bool shutdown(std::chrono::milliseconds timeout);

  /// Scenes with a runner or queued jobs (a closed scene leaves once its jobs are done).
  [[nodiscard]] std::size_t active_scenes() const;

  /// Frame jobs dropped so far across all scenes.
  [[nodiscard]] std::uint64_t dropped_frames() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tc::daemon
