// service/daemon/frame_assembler: completeness, the assembly wait, newest-wins, with a
// fake clock.
#include "frame_assembler.hpp"

#include <gtest/gtest.h>

namespace tc::daemon {
namespace {

using std::chrono::milliseconds;
const Clock::time_point t0{std::chrono::seconds(100)};

PendingState state(const std::string& object, std::int64_t frame, Clock::time_point at,
                   double value = 0.0) {
  PendingState s;
  s.object = object;
  s.version = 1;
  s.frame = frame;
  s.positions = Positions::Constant(3, 4, value);
  s.received = at;
  return s;
}

TEST(FrameAssembler, CompleteAsSoonAsEveryObjectSent) {
  FrameAssembler a(milliseconds(10));
  const std::vector<std::string> expected{"a", "b"};
  a.add(state("b", 5, t0));
  EXPECT_FALSE(a.poll(expected, t0));
  a.add(state("a", 5, t0 + milliseconds(1)));
  const auto f = a.poll(expected, t0 + milliseconds(1));
  ASSERT_TRUE(f);
  EXPECT_EQ(f->frame, 5);
  EXPECT_TRUE(f->complete);
  ASSERT_EQ(f->states.size(), 2u);
  EXPECT_EQ(f->states[0].object, "a");  // sorted by name
  EXPECT_EQ(f->states[1].object, "b");
  EXPECT_EQ(f->first_received, t0);
  EXPECT_TRUE(a.empty());
  EXPECT_FALSE(a.deadline());
}

TEST(FrameAssembler, WaitRunsFromTheFirstState) {
  FrameAssembler a(milliseconds(10));
  const std::vector<std::string> expected{"a", "b"};
  a.add(state("a", 1, t0));
  ASSERT_TRUE(a.deadline());
  EXPECT_EQ(*a.deadline(), t0 + milliseconds(10));
  EXPECT_FALSE(a.poll(expected, t0 + milliseconds(9)));
  a.add(state("a", 2, t0 + milliseconds(5)));  // newer frame of a: still waits from t0
  EXPECT_EQ(*a.deadline(), t0 + milliseconds(10));
  const auto f = a.poll(expected, t0 + milliseconds(10));
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->complete);
  EXPECT_EQ(f->frame, 2);
  ASSERT_EQ(f->states.size(), 1u);
  EXPECT_EQ(f->states[0].frame, 2);
}

TEST(FrameAssembler, NewestFrameWinsAndLaggardsWait) {
  FrameAssembler a(milliseconds(10));
  const std::vector<std::string> expected{"a", "b"};
  a.add(state("a", 7, t0));
  a.add(state("b", 6, t0));
  EXPECT_FALSE(a.poll(expected, t0));  // b is behind: frame 7 is not complete
  a.add(state("b", 7, t0 + milliseconds(1), 3.0));
  const auto f = a.poll(expected, t0 + milliseconds(1));
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->complete);
  EXPECT_EQ(f->frame, 7);
  EXPECT_EQ(f->states[1].positions(0, 0), 3.0);
}

TEST(FrameAssembler, TimedOutFrameCarriesOlderStates) {
  FrameAssembler a(milliseconds(4));
  const std::vector<std::string> expected{"a", "b"};
  a.add(state("a", 9, t0));
  a.add(state("b", 8, t0));
  const auto f = a.poll(expected, t0 + milliseconds(4));
  ASSERT_TRUE(f);
  EXPECT_EQ(f->frame, 9);
  EXPECT_FALSE(f->complete);
  ASSERT_EQ(f->states.size(), 2u);
  EXPECT_EQ(f->states[1].frame, 8);
}

TEST(FrameAssembler, NoExpectedObjectsDispatchesAtOnce) {
  FrameAssembler a(milliseconds(10));
  a.add(state("static_floor", 3, t0));
  const auto f = a.poll({}, t0);
  ASSERT_TRUE(f);
  EXPECT_TRUE(f->complete);
}

TEST(FrameAssembler, RemovedObjectNoLongerPending) {
  FrameAssembler a(milliseconds(10));
  a.add(state("a", 1, t0));
  a.remove("a");
  EXPECT_TRUE(a.empty());
  EXPECT_FALSE(a.poll({"a"}, t0 + milliseconds(100)));
}

TEST(FrameAssembler, FramesMayGoBackwards) {
  // A restarted simulation starts again at frame 0: the assembler has no memory of
  // answered frames, so it answers frame 0 again.
  FrameAssembler a(milliseconds(10));
  a.add(state("a", 500, t0));
  ASSERT_TRUE(a.poll({"a"}, t0));
  a.add(state("a", 0, t0 + milliseconds(1)));
  const auto f = a.poll({"a"}, t0 + milliseconds(1));
  ASSERT_TRUE(f);
  EXPECT_EQ(f->frame, 0);
}

TEST(FrameAssembler, TimeoutCanBeHeldBack) {
  FrameAssembler a(milliseconds(5));
  a.add(state("a", 1, t0));
  EXPECT_FALSE(a.poll({"a", "b"}, t0 + milliseconds(50), false));
  a.add(state("b", 1, t0 + milliseconds(51)));
  EXPECT_TRUE(a.poll({"a", "b"}, t0 + milliseconds(51), false));  // complete still goes
}

TEST(FrameAssembler, ZeroWaitDispatchesImmediately) {
  FrameAssembler a(milliseconds(0));
  a.add(state("a", 1, t0));
  const auto f = a.poll({"a", "b"}, t0);
  ASSERT_TRUE(f);
  EXPECT_FALSE(f->complete);
}

}  // namespace
}  // namespace tc::daemon
