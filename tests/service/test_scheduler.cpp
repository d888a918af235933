// service/daemon/scheduler: per-scene order, scenes in parallel, the newest-wins drop of
// waiting frames, closing scenes, shutdown.
#include "scheduler.hpp"

#include <gtest/gtest.h>

#include <thread>

#include "outbox_recorder.hpp"
#include "test_meshes.hpp"

namespace tc::daemon {
namespace {

TetMesh small_box() {
  return tc::test::structured_box(2, 2, 2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
}

FrameJob frame_job(std::int64_t f) {
  FrameJob j;
  j.frame = f;
  j.states.push_back(FrameObjectInput{"a", 1, small_box().positions});
  j.first_received = j.dispatched = Clock::now();
  j.complete = true;
  return j;
}

class SchedulerTest : public ::testing::TestWithParam<int> {
 protected:
  std::unique_ptr<Scheduler> make(int max_queued) {
    return std::make_unique<Scheduler>(GetParam(), max_queued, [this](const std::string& scene) {
      return std::make_unique<SceneRunner>(scene, PipelineConfig{}, outbox_, nullptr, 0.0);
    });
  }
  test::OutboxRecorder outbox_;
};

TEST_P(SchedulerTest, FramesOfEachSceneRunInOrder) {
  auto s = make(64);
  const std::vector<std::string> scenes{"s0", "s1", "s2", "s3"};
  for (const auto& scene : scenes)
    s->post(scene, TopologyJob{"a", 1, small_box(), ObjectParams{}, Clock::now()});
  for (std::int64_t f = 0; f < 30; ++f)
    for (const auto& scene : scenes) s->post(scene, frame_job(f));
  ASSERT_TRUE(outbox_.wait_stats(30 * scenes.size()));
  ASSERT_TRUE(s->shutdown(std::chrono::seconds(10)));
  for (const auto& scene : scenes) {
    std::vector<std::int64_t> order;
    for (const auto& st : outbox_.stats)
      if (st.scene == scene) order.push_back(st.frame);
    ASSERT_EQ(order.size(), 30u) << scene;
    for (std::size_t i = 0; i < order.size(); ++i)
      EXPECT_EQ(order[i], static_cast<std::int64_t>(i)) << scene;
  }
  EXPECT_EQ(s->dropped_frames(), 0u);
}

TEST_P(SchedulerTest, BusySceneDropsTheOldestWaitingFrames) {
  auto s = make(2);
  outbox_.close_gate();  // the registration's status publish blocks: the scene is busy
  s->post("s", TopologyJob{"a", 1, small_box(), ObjectParams{}, Clock::now()});
  for (std::int64_t f = 0; f < 10; ++f) s->post("s", frame_job(f));
  if (GetParam() > 1) {
    // Another scene is not held up by the busy one (its frame publishes no status).
    FrameJob empty;
    empty.frame = 0;
    empty.first_received = empty.dispatched = Clock::now();
    s->post("other", std::move(empty));
    EXPECT_TRUE(outbox_.wait_stats(1));
  }
  outbox_.open_gate();
  ASSERT_TRUE(outbox_.wait_stats(GetParam() > 1 ? 3 : 2));
  ASSERT_TRUE(s->shutdown(std::chrono::seconds(10)));
  std::vector<std::int64_t> answered;
  std::uint64_t dropped = 0;
  for (const auto& st : outbox_.stats)
    if (st.scene == "s") {
      answered.push_back(st.frame);
      dropped = st.dropped;
    }
  EXPECT_EQ(answered, (std::vector<std::int64_t>{8, 9}));  // newest win
  EXPECT_EQ(dropped, 8u);
  EXPECT_EQ(s->dropped_frames(), 8u);
}

TEST_P(SchedulerTest, ClosedSceneStartsAfresh) {
  auto s = make(4);
  s->post("s", TopologyJob{"a", 1, small_box(), ObjectParams{}, Clock::now()});
  s->post("s", frame_job(0));
  s->close_scene("s");
  ASSERT_TRUE(outbox_.wait_stats(1));
  const auto until = Clock::now() + std::chrono::seconds(10);
  while (s->active_scenes() != 0 && Clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(s->active_scenes(), 0u);
  // A new runner knows no object: a frame for "a" is answered as unknown.
  s->post("s", frame_job(1));
  ASSERT_TRUE(outbox_.wait_stats(2));
  ASSERT_TRUE(s->shutdown(std::chrono::seconds(10)));
  const auto answers = outbox_.forces_of("s", 1);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_NE(answers[0].status, 0);
  EXPECT_EQ(outbox_.forces_of("s", 0).size(), 1u);
  EXPECT_EQ(outbox_.forces_of("s", 0)[0].status, 0);
}

TEST_P(SchedulerTest, PostAfterCloseKeepsTheScene) {
  auto s = make(4);
  outbox_.close_gate();
  s->post("s", TopologyJob{"a", 1, small_box(), ObjectParams{}, Clock::now()});
  s->close_scene("s");         // still busy: the runner stays until its jobs are done ...
  s->post("s", frame_job(0));  // ... and a new job cancels the close
  outbox_.open_gate();
  ASSERT_TRUE(outbox_.wait_stats(1));
  ASSERT_TRUE(s->shutdown(std::chrono::seconds(10)));
  ASSERT_EQ(outbox_.forces_of("s", 0).size(), 1u);
  EXPECT_EQ(outbox_.forces_of("s", 0)[0].status, 0);
}

TEST_P(SchedulerTest, ShutdownDropsWaitingJobsAndIgnoresNewOnes) {
  auto s = make(64);
  outbox_.close_gate();
  s->post("s", TopologyJob{"a", 1, small_box(), ObjectParams{}, Clock::now()});
  for (std::int64_t f = 0; f < 5; ++f) s->post("s", frame_job(f));
  std::thread opener([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    outbox_.open_gate();
  });
  EXPECT_TRUE(s->shutdown(std::chrono::seconds(10)));
  opener.join();
  s->post("s", frame_job(99));
  EXPECT_TRUE(s->shutdown(std::chrono::seconds(1)));
  EXPECT_TRUE(outbox_.stats.empty());  // the waiting frames never ran
}

INSTANTIATE_TEST_SUITE_P(Threads, SchedulerTest, ::testing::Values(1, 2, 4),
                         [](const ::testing::TestParamInfo<int>& p) {
                           return "threads" + std::to_string(p.param);
                         });

}  // namespace
}  // namespace tc::daemon
