// The work of one scene: its tc::Pipeline and the jobs the reader thread sends it
// (register or replace a topology, remove an object, run a frame), turned into
// ContactForces, FrameStats and ServiceStatus messages. A SceneRunner runs one job at a
// time (the Scheduler guarantees it); different scenes run in parallel. DDS-free.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "core/pipeline/pipeline.hpp"
#include "frame_assembler.hpp"
#include "metrics.hpp"
#include "outbox.hpp"

namespace tc::daemon {

struct TopologyJob {
  std::string object;
  std::uint32_t version = 0;
  ObjectMesh mesh;  ///< tets, or a surface object's triangles
  ObjectParams params;
  Clock::time_point received{};
  std::int64_t source_timestamp = 0;  ///< of the MeshTopology sample, echoed in the verdict
};

struct RemoveJob {
  std::string object;
};

/// A MeshTopology sample that re-sent the version already submitted (same content): no
/// rebuild, but a verdict of its own once that version's build is done (jobs of a scene
/// run in order), so a client waiting for the verdict on its write gets one.
struct VerdictJob {
  std::string object;
  std::uint32_t version = 0;
  std::int64_t source_timestamp = 0;  ///< of the re-sent sample, echoed in the verdict
};

/// An object whose state the reader thread rejected in this frame.
struct RejectedState {
  std::string object;
  std::uint32_t version = 0;
  std::int32_t code = 0;  ///< STATUS_*
};

struct FrameJob {
  std::int64_t frame = 0;
  std::vector<FrameObjectInput> states;
  std::vector<std::int64_t> state_frames;  ///< frame number of each of `states`
  std::vector<RejectedState> rejected;
  Clock::time_point first_received{};
  Clock::time_point dispatched{};
  bool complete = false;
  std::uint64_t dropped_frames = 0;  ///< set by the Scheduler when the job starts
};

using SceneJob = std::variant<TopologyJob, RemoveJob, FrameJob, VerdictJob>;

/// The pipeline's verdict on a topology, sent back to the reader thread's registry.
struct TopologyResult {
  std::string scene;
  std::string object;
  std::uint32_t version = 0;
  bool ok = false;
};
using TopologyResultSink = std::function<void(TopologyResult)>;

/// Test-only (docs/RELIABILITY.md "Soak"): the value of the environment variable
/// TETCOLLIDED_TEST_LEAK_BYTES_PER_REMOVAL, read once; 0 when unset. When set, every
/// object removal keeps that many bytes for the life of the process, on purpose: the leak
/// the soak must catch. Never set it in production (the daemon warns at the start).
std::size_t test_leak_bytes_per_removal();

class SceneRunner {
 public:
  /// `metrics`: the scene's Prometheus series (metrics.listen), or null.
  SceneRunner(std::string scene, const PipelineConfig& config, Outbox& outbox,
              TopologyResultSink on_topology, double timing_summary_period_s,
              std::shared_ptr<SceneMetrics> metrics = nullptr);

  void run(SceneJob& job);

  [[nodiscard]] const std::string& scene() const { return scene_; }

 private:
  void run_topology(TopologyJob& job);
  void run_remove(const RemoveJob& job);
  void run_verdict(const VerdictJob& job);
  void run_frame(FrameJob& job);
  void publish_answers(const FrameJob& job, const FrameOutput& output, std::uint64_t answer_id);
  void report_timing(double compute_ms, double latency_ms);
  /// The degraded states of a frame (a few inverted tets left out of contact,
  /// FrameOutput::degraded) on the status topic and in the log: the first of a run of an
  /// object's degraded states always, then at most once per kDegradedWindow with the
  /// count since; the run ends (said in the log) with the object's next clean state.
  void report_degraded(const FrameJob& job, const FrameOutput& output);

  std::string scene_;
  Pipeline pipeline_;
  Outbox& outbox_;
  TopologyResultSink on_topology_;
  std::map<std::string, std::uint32_t, std::less<>> active_;  ///< object -> version held
  /// The last rejected topology build of each object (its version, code and message),
  /// until a build of that object succeeds: the verdict repeated for a re-sent version.
  struct FailedBuild {
    std::uint32_t version = 0;
    std::int32_t code = 0;
    std::string message;
  };
  std::map<std::string, FailedBuild, std::less<>> failed_;
  /// object -> frame of the newest state the pipeline used (absent: rest positions)
  std::map<std::string, std::int64_t, std::less<>> state_frame_;
  /// Objects whose last accepted state was degraded: when that was last said, the
  /// degraded states since (not said), and the run's length.
  struct DegradedRun {
    Clock::time_point said{};
    std::uint64_t unsaid = 0;
    std::uint64_t states = 0;
  };
  std::map<std::string, DegradedRun, std::less<>> degraded_;
  std::vector<double> stiffness_rows_;  ///< reused per object
  std::vector<double> damping_rows_;    ///< reused per object
  std::shared_ptr<SceneMetrics> metrics_;

  // Periodic timing summary.
  std::chrono::duration<double> summary_period_;
  Clock::time_point summary_start_ = Clock::now();
  std::vector<double> compute_ms_;
  std::vector<double> latency_ms_;
};

}  // namespace tc::daemon
