// Replaying a committed recording against a test's daemon, checking every answer.
#pragma once

#include <chrono>
#include <cstdint>

#include "replayer.hpp"

namespace tc::itest {

/// Replay as fast as the answers come (rate 0), every frame checked bit for bit against
/// the recording, 30 s for a frame's answer and an unanswered frame sent again after
/// 300 ms (the daemon may be killed and restarted during the replay).
inline replay::ReplayOptions checked_replay_options(std::uint32_t domain) {
  using namespace std::chrono_literals;
  replay::ReplayOptions o;
  o.domain = domain;
  o.rate = 0.0;
  o.check = true;
  o.frame_timeout = 30s;
  o.resend_after = 300ms;
  return o;
}

}  // namespace tc::itest
