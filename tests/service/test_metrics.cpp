// service/daemon/metrics: the exposition text of the per-scene series a SceneRunner feeds,
// the rejections CountingOutbox counts, ownership changes, the process figures, and the
// series leaving with their scene. No HTTP here (tests/integration/test_metrics.cpp
// scrapes a running daemon).
#include "metrics.hpp"

#include <gtest/gtest.h>

#include <utility>

#include "outbox_recorder.hpp"
#include "scene_runner.hpp"
#include "test_meshes.hpp"
#include "tetcollide.h"

namespace tc::daemon {
namespace {

/// The value of the sample line `series` (name and labels exactly as printed), or -1.
double sample(const std::string& text, const std::string& series) {
  const std::string prefix = series + " ";
  std::size_t at = 0;
  while ((at = text.find(prefix, at)) != std::string::npos) {
    if (at == 0 || text[at - 1] == '\n') return std::stod(text.substr(at + prefix.size()));
    at += prefix.size();
  }
  return -1.0;
}

TetMesh box_at(double x0) {
  return tc::test::structured_box(3, 3, 3, Eigen::Vector3d(x0, 0, 0),
                                  Eigen::Vector3d(x0 + 1, 1, 1));
}

TEST(Metrics, ProcessFiguresAreExported) {
  Metrics m;
  const std::string text = m.text();
  for (const char* name :
       {"process_cpu_seconds_total", "process_resident_memory_bytes", "process_open_fds",
        "process_start_time_seconds", "process_max_fds", "process_virtual_memory_bytes",
        "process_threads", "tetcollide_heap_in_use_bytes", "tetcollide_heap_held_bytes",
        "tetcollide_dds_write_errors_total"})
    EXPECT_GT(sample(text, name), -1.0) << name << " missing in:\n" << text;
  EXPECT_GT(sample(text, "process_resident_memory_bytes"), 1e6);
  EXPECT_GT(sample(text, "process_open_fds"), 2.0);  // stdin, stdout, stderr at least
  EXPECT_GT(sample(text, "process_start_time_seconds"), 1.5e9);
  EXPECT_GT(sample(text, "tetcollide_heap_in_use_bytes"), 0.0);
  m.set_write_errors([] { return std::uint64_t{7}; });
  EXPECT_EQ(sample(m.text(), "tetcollide_dds_write_errors_total"), 7.0);
}

TEST(Metrics, HeapInUseSeesABlockKeptAndFreed) {
  const std::uint64_t before = heap_in_use_bytes();
  auto block = std::make_unique<char[]>(4 << 20);
  block[0] = 1;
  EXPECT_GE(heap_in_use_bytes(), before + (4u << 20));
  block.reset();
  EXPECT_LT(heap_in_use_bytes(), before + (1u << 20));
}

TEST(Metrics, ASceneRunnerCountsItsFramesObjectsAndContacts) {
  Metrics m;
  test::OutboxRecorder recorder;
  CountingOutbox outbox(recorder, m);
  SceneRunner runner("ward", PipelineConfig{}, outbox, nullptr, 0.0, m.scene("ward"));
  const auto add = [&](const std::string& object, double x0) {
    SceneJob job = TopologyJob{object, 1, box_at(x0), ObjectParams{}, Clock::now()};
    runner.run(job);
  };
  add("a", 0.0);
  EXPECT_EQ(sample(m.text(), R"(tetcollide_objects{scene="ward"})"), 1.0);
  add("b", 0.8);  // overlaps a by 0.2
  const auto frame = [&](std::int64_t f, std::uint64_t dropped_so_far,
                         std::vector<RejectedState> rejected) {
    FrameJob j;
    j.frame = f;
    j.states = {FrameObjectInput{"a", 1, box_at(0.0).positions}};
    if (rejected.empty()) j.states.push_back(FrameObjectInput{"b", 1, box_at(0.8).positions});
    j.state_frames.assign(j.states.size(), f);
    j.rejected = std::move(rejected);
    j.first_received = j.dispatched = Clock::now();
    j.complete = true;
    j.dropped_frames = dropped_so_far;
    SceneJob job = std::move(j);
    runner.run(job);
  };
  frame(0, 0, {});
  frame(1, 2, {});
  frame(2, 3, {});
  const std::string text = m.text();
  EXPECT_EQ(sample(text, R"(tetcollide_frames_total{scene="ward"})"), 3.0);
  EXPECT_EQ(sample(text, R"(tetcollide_frame_compute_seconds_count{scene="ward"})"), 3.0);
  EXPECT_EQ(sample(text, R"(tetcollide_frame_latency_seconds_count{scene="ward"})"), 3.0);
  EXPECT_EQ(sample(text, R"(tetcollide_frame_compute_seconds_bucket{scene="ward",le="+Inf"})"),
            3.0);
  EXPECT_GT(sample(text, R"(tetcollide_frame_compute_seconds_sum{scene="ward"})"), 0.0);
  EXPECT_GT(sample(text, R"(tetcollide_frame_compute_seconds_bucket{scene="ward",le="0.0001"})"),
            -1.0);
  EXPECT_EQ(sample(text, R"(tetcollide_objects{scene="ward"})"), 2.0);
  EXPECT_EQ(recorder.stats.size(), 3u);
  EXPECT_GT(sample(text, R"(tetcollide_contacts{scene="ward"})"), 0.0);  // the boxes overlap
  EXPECT_EQ(sample(text, R"(tetcollide_dropped_frames_total{scene="ward"})"), 3.0);
  SceneJob remove = RemoveJob{"b"};
  runner.run(remove);
  EXPECT_EQ(sample(m.text(), R"(tetcollide_objects{scene="ward"})"), 1.0);
}

TEST(Metrics, RejectionsAreCountedBySceneAndCode) {
  Metrics m;
  test::OutboxRecorder recorder;
  CountingOutbox outbox(recorder, m);
  const auto scene = m.scene("ward");
  StatusMessage state_error;
  state_error.kind = StatusKind::kError;
  state_error.code = tetcollide_STATUS_UNKNOWN_OBJECT;
  state_error.scene = "ward";
  state_error.object = "ghost";
  state_error.frame = 4;
  outbox.publish_status(state_error);
  outbox.publish_status(state_error);
  state_error.code = tetcollide_STATUS_STALE_VERSION;
  outbox.publish_status(state_error);
  StatusMessage topology_error = state_error;
  topology_error.code = tetcollide_STATUS_INVALID_MESH;
  topology_error.frame = -1;
  outbox.publish_status(topology_error);
  StatusMessage registered;
  registered.kind = StatusKind::kRegistered;
  registered.scene = "ward";
  registered.object = "a";
  outbox.publish_status(registered);
  EXPECT_EQ(recorder.status.size(), 5u);  // everything forwarded
  const std::string text = m.text();
  EXPECT_EQ(sample(text, R"(tetcollide_rejected_states_total{code="unknown_object",scene="ward"})"),
            2.0)
      << text;
  EXPECT_EQ(sample(text, R"(tetcollide_rejected_states_total{code="stale_version",scene="ward"})"),
            1.0);
  EXPECT_EQ(
      sample(text, R"(tetcollide_rejected_topologies_total{code="invalid_mesh",scene="ward"})"),
      1.0);
}

TEST(Metrics, OwnershipChangesAreCountedForServedScenesOnly) {
  Metrics m;
  const auto scene = m.scene("ward");
  m.answer_owner("ward", 11, true);  // the first owner seen: not a change
  m.answer_owner("ward", 11, true);
  std::string text = m.text();
  EXPECT_EQ(sample(text, R"(tetcollide_answer_owner{scene="ward"})"), 1.0);
  EXPECT_EQ(sample(text, R"(tetcollide_ownership_changes_total{scene="ward"})"), 0.0);
  m.answer_owner("ward", 22, false);  // a stronger daemon took over
  m.answer_owner("ward", 11, true);   // and went away
  m.answer_owner("elsewhere", 33, false);
  text = m.text();
  EXPECT_EQ(sample(text, R"(tetcollide_answer_owner{scene="ward"})"), 1.0);
  EXPECT_EQ(sample(text, R"(tetcollide_ownership_changes_total{scene="ward"})"), 2.0);
  EXPECT_EQ(text.find("elsewhere"), std::string::npos);
}

TEST(Metrics, ASceneSeriesLeaveWithTheLastHolder) {
  Metrics m;
  auto first = m.scene("cycle");
  auto second = m.scene("cycle");
  EXPECT_EQ(first, second);
  first->set_objects(2);
  m.rejected_state("cycle", tetcollide_STATUS_STALE_VERSION);
  first.reset();
  EXPECT_EQ(sample(m.text(), R"(tetcollide_objects{scene="cycle"})"), 2.0);
  second.reset();
  const std::string text = m.text();
  EXPECT_EQ(text.find(R"(scene="cycle")"), std::string::npos) << text;
  // A scene opened again starts from zero.
  auto again = m.scene("cycle");
  again->frame_done(0.001, 0.002, 1, 0, 0);
  EXPECT_EQ(sample(m.text(), R"(tetcollide_frames_total{scene="cycle"})"), 1.0);
}

TEST(Metrics, RejectionsForScenesWithoutARunnerAreBounded) {
  Metrics m;
  for (int i = 0; i < 100; ++i)
    m.rejected_state("nobody" + std::to_string(i), tetcollide_STATUS_UNKNOWN_OBJECT);
  const std::string text = m.text();
  EXPECT_EQ(
      sample(text, R"(tetcollide_rejected_states_total{code="unknown_object",scene="nobody0"})"),
      1.0);
  EXPECT_EQ(
      sample(text, R"x(tetcollide_rejected_states_total{code="unknown_object",scene="(other)"})x"),
      36.0);
}

}  // namespace
}  // namespace tc::daemon
