// Frame assembly for one scene: collects the newest state of each object and decides
// when the scene's next frame is ready. DDS-free; time is passed in, so it is tested
// with a fake clock.
//
// Rule (docs/PROTOCOL.md, "Frames"): the frame to answer is the highest frame number
// among the states received since the last dispatch. It is dispatched as soon as every
// expected object's newest state carries that frame number, or `wait` after the first
// of those states arrived, with the newest state of every object that sent one (an
// object that sent none keeps its last positions in the pipeline).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc::daemon {

using Clock = std::chrono::steady_clock;

/// One object's newest state since the last dispatch. A state the daemon rejected still
/// counts as received (the object has answered for this frame) but carries its code.
struct PendingState {
  std::string object;
  std::uint32_t version = 0;
  std::int64_t frame = 0;
  Positions positions;   ///< 3 x n, metres; empty when rejected
  Positions velocities;  ///< 3 x n, m/s, or empty (the state sent none)
  Clock::time_point received{};
  std::int32_t rejected_code = 0;  ///< STATUS_* != 0 when rejected
  std::string rejected_message;
};

struct AssembledFrame {
  std::int64_t frame = 0;
  std::vector<PendingState> states;  ///< sorted by object name
  Clock::time_point first_received{};
  bool complete = false;  ///< every expected object sent this frame
};

class FrameAssembler {
 public:
  explicit FrameAssembler(Clock::duration wait) : wait_(wait) {}

  /// Adds (or replaces: newest wins) an object's pending state.
  void add(PendingState state);

  /// Drops an object's pending state (the object was removed).
  void remove(std::string_view object);

  /// The pending frame if it is complete for `expected` (sorted object names) or, when
  /// `may_time_out`, has waited long enough at `now`; the pending set is then empty.
  std::optional<AssembledFrame> poll(const std::vector<std::string>& expected,
                                     Clock::time_point now, bool may_time_out = true);

  /// When poll() will dispatch the pending frame at the latest; nullopt when empty.
  [[nodiscard]] std::optional<Clock::time_point> deadline() const;

  [[nodiscard]] bool empty() const { return pending_.empty(); }

 private:
  Clock::duration wait_;
  std::vector<PendingState> pending_;  ///< sorted by object name
};

}  // namespace tc::daemon
