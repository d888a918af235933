// Replays a recording against a running service (`tetcollide replay`): topologies and
// states go out through the client library frame by frame, each frame waits for its
// answer, and with `check` the answer is compared bit for bit with the recorded forces.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "recording.hpp"

namespace tc::replay {

struct ReplayOptions {
  std::uint32_t domain = 0;
  std::string partition;
  /// Pace frames at the recorded rate times `rate` (2 = twice as fast); 0 = no pacing.
  /// Frames are always sent one at a time, each after the previous one's answer.
  double rate = 1.0;
  bool check = false;
  std::chrono::milliseconds service_timeout{10000};  ///< wait for a READY service
  /// Before the first frame, also wait (service_timeout) until this many services read
  /// the states: a shard's primary and standbys all compute from the first frame on.
  std::size_t services = 1;
  std::chrono::milliseconds frame_timeout{10000};  ///< per frame, re-sends included
  std::chrono::milliseconds resend_after{500};     ///< re-publish an unanswered frame
  /// Called before each frame is published (index from 0; tests kill the service here).
  std::function<void(std::size_t index, const std::string& scene, std::int64_t frame)> before_frame;
};

struct ReplayReport {
  std::size_t frames = 0;             ///< frames replayed
  std::size_t unanswered = 0;         ///< frames with no answer within frame_timeout
  std::size_t mismatched_frames = 0;  ///< frames whose forces differ (or are missing)
  double max_force_deviation = 0.0;   ///< max |f_replayed - f_recorded| over components, N
  double latency_ms_p50 = 0.0;        ///< states published -> all forces received
  double latency_ms_p99 = 0.0;
  std::vector<std::string> mismatches;  ///< first few differences, human-readable
};

/// Replays `records`. DDS failures and a missing service are errors (kIo); forces that
/// differ are not (they are in the report).
Expected<ReplayReport> replay(const std::vector<Record>& records, const ReplayOptions& options);

/// Nearest-rank percentile q in [0, 1] of `values` (copied); 0 for an empty list.
double percentile(std::vector<double> values, double q);

}  // namespace tc::replay
