#include "frame_assembler.hpp"

#include <algorithm>

namespace tc::daemon {
namespace {

auto find_object(std::vector<PendingState>& pending, std::string_view object) {
  return std::lower_bound(
      pending.begin(), pending.end(), object,
      [](const PendingState& s, std::string_view name) { return s.object < name; });
}

}  // namespace

void FrameAssembler::add(PendingState state) {
  auto it = find_object(pending_, state.object);
  if (it != pending_.end() && it->object == state.object) {
    // Keep the first arrival time of the pending set: the wait runs from the frame's
    // first state, not from this object's latest.
    const Clock::time_point first = std::min(it->received, state.received);
    *it = std::move(state);
    it->received = first;
  } else {
    pending_.insert(it, std::move(state));
  }
}

void FrameAssembler::remove(std::string_view object) {
  auto it = find_object(pending_, object);
  if (it != pending_.end() && it->object == object) pending_.erase(it);
}

std::optional<Clock::time_point> FrameAssembler::deadline() const {
  if (pending_.empty()) return std::nullopt;
  Clock::time_point first = pending_.front().received;
  for (const auto& s : pending_) first = std::min(first, s.received);
  return first + wait_;
}

std::optional<AssembledFrame> FrameAssembler::poll(const std::vector<std::string>& expected,
                                                   Clock::time_point now, bool may_time_out) {
  if (pending_.empty()) return std::nullopt;
  std::int64_t target = pending_.front().frame;
  Clock::time_point first = pending_.front().received;
  for (const auto& s : pending_) {
    target = std::max(target, s.frame);
    first = std::min(first, s.received);
  }
  bool complete = true;
  for (const auto& name : expected) {
    const auto it = find_object(pending_, name);
    if (it == pending_.end() || it->object != name || it->frame != target) {
      complete = false;
      break;
    }
  }
  if (!complete && (!may_time_out || now < first + wait_)) return std::nullopt;
  AssembledFrame out;
  out.frame = target;
  out.states = std::move(pending_);
  out.first_received = first;
  out.complete = complete;
  pending_.clear();
  return out;
}

}  // namespace tc::daemon
