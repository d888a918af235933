// service/daemon/scene_runner: a scene's jobs on the real pipeline turned into answers:
// one ContactForces per object per frame, rejected objects answered with their code,
// registrations and removals reported, stats per frame.
#include "scene_runner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "outbox_recorder.hpp"
#include "test_meshes.hpp"
#include "tetcollide.h"

namespace tc::daemon {
namespace {

TetMesh box_at(double x0) {
  return tc::test::structured_box(3, 3, 3, Eigen::Vector3d(x0, 0, 0),
                                  Eigen::Vector3d(x0 + 1, 1, 1));
}

class SceneRunnerTest : public ::testing::Test {
 protected:
  SceneRunnerTest()
      : runner_(
            "s", PipelineConfig{}, outbox_,
            [this](TopologyResult r) { results_.push_back(std::move(r)); }, 0.0) {}

  void add(const std::string& object, std::uint32_t version, TetMesh mesh) {
    SceneJob job = TopologyJob{object, version, std::move(mesh), ObjectParams{}, Clock::now()};
    runner_.run(job);
  }
  /// Registers a and b (version 1, b overlapping a by 0.2) and returns their rest meshes.
  std::pair<TetMesh, TetMesh> add_overlapping_pair() {
    add("a", 1, box_at(0.0));
    add("b", 1, box_at(0.8));
    return {box_at(0.0), box_at(0.8)};
  }
  void frame(std::int64_t f, std::vector<FrameObjectInput> states,
             std::vector<RejectedState> rejected = {}) {
    FrameJob j;
    j.frame = f;
    j.states = std::move(states);
    j.state_frames.assign(j.states.size(), f);
    j.rejected = std::move(rejected);
    j.first_received = j.dispatched = Clock::now();
    j.complete = true;
    SceneJob job = std::move(j);
    runner_.run(job);
  }

  test::OutboxRecorder outbox_;
  std::vector<TopologyResult> results_;
  SceneRunner runner_;
};

TEST_F(SceneRunnerTest, RegistrationIsReported) {
  add("a", 1, box_at(0.0));
  ASSERT_EQ(results_.size(), 1u);
  EXPECT_TRUE(results_[0].ok);
  ASSERT_EQ(outbox_.status.size(), 1u);
  EXPECT_EQ(outbox_.status[0].kind, StatusKind::kRegistered);
  EXPECT_EQ(outbox_.status[0].object, "a");
  EXPECT_EQ(outbox_.status[0].topology_version, 1u);
  EXPECT_NE(outbox_.status[0].message.find("64 nodes, 162 tets"), std::string::npos)
      << outbox_.status[0].message;
}

/// The pair rule (the smaller stiffness) is said once, with the registration of the later
/// object of a pair whose stiffnesses differ, in its status message (and the log).
TEST_F(SceneRunnerTest, AStiffnessThePairRuleCapsIsSaidWithTheRegistration) {
  ObjectParams box;
  box.is_static = true;  // the default 1e4
  ObjectParams ball;
  ball.stiffness = 1e7;
  SceneJob job = TopologyJob{"box", 1, box_at(0.0), box, Clock::now()};
  runner_.run(job);
  job = TopologyJob{"ball", 1, box_at(3.0), ball, Clock::now()};
  runner_.run(job);
  ObjectParams other_static = box;
  other_static.stiffness = 5e3;
  job = TopologyJob{"wall", 1, box_at(6.0), other_static, Clock::now()};
  runner_.run(job);
  ASSERT_EQ(outbox_.status.size(), 3u);
  EXPECT_EQ(outbox_.status[0].message.find("stiffness"), std::string::npos)
      << outbox_.status[0].message;  // alone in the scene: nothing to say
  const std::string& said = outbox_.status[1].message;
  EXPECT_EQ(outbox_.status[1].kind, StatusKind::kRegistered);
  EXPECT_NE(said.find("pairs with 'box' (10000) use that smaller stiffness, below this "
                      "object's 1e+07"),
            std::string::npos)
      << said;
  // A static wall never meets the static box: only its pair with the ball is named.
  const std::string& wall = outbox_.status[2].message;
  EXPECT_NE(wall.find("this object's stiffness 5000 caps its pairs with 'ball' (1e+07)"),
            std::string::npos)
      << wall;
  EXPECT_EQ(wall.find("'box'"), std::string::npos) << wall;
}

TEST_F(SceneRunnerTest, InvertedTopologyIsRejectedAndReported) {
  TetMesh m = box_at(0.0);
  std::swap(m.tets[3][0], m.tets[3][1]);
  add("a", 1, m);
  ASSERT_EQ(results_.size(), 1u);
  EXPECT_FALSE(results_[0].ok);
  ASSERT_EQ(outbox_.status.size(), 1u);
  EXPECT_EQ(outbox_.status[0].kind, StatusKind::kError);
  EXPECT_EQ(outbox_.status[0].code, tetcollide_STATUS_INVALID_MESH);
}

TEST_F(SceneRunnerTest, EveryObjectIsAnsweredEveryFrame) {
  add("a", 1, box_at(0.0));
  add("b", 1, box_at(0.8));  // overlaps a by 0.2
  add("far", 1, box_at(10.0));
  const TetMesh a = box_at(0.0);
  const TetMesh b = box_at(0.8);
  frame(0, {FrameObjectInput{"a", 1, a.positions}, FrameObjectInput{"b", 1, b.positions}});
  const auto answers = outbox_.forces_of("s", 0);
  ASSERT_EQ(answers.size(), 3u);  // far sent no state and is answered too
  EXPECT_EQ(answers[0].object, "a");
  EXPECT_EQ(answers[1].object, "b");
  EXPECT_EQ(answers[2].object, "far");
  for (const auto& f : answers) {
    EXPECT_EQ(f.status, 0);
    EXPECT_EQ(f.version, 1u);
    EXPECT_EQ(f.forces.size(), 3 * f.nodes.size());
    EXPECT_TRUE(std::is_sorted(f.nodes.begin(), f.nodes.end()));
    for (const double v : f.forces) EXPECT_TRUE(std::isfinite(v));
  }
  EXPECT_FALSE(answers[0].nodes.empty()) << "overlapping boxes, no force on a";
  EXPECT_FALSE(answers[1].nodes.empty()) << "overlapping boxes, no force on b";
  EXPECT_TRUE(answers[2].nodes.empty());
  ASSERT_EQ(outbox_.stats.size(), 1u);
  EXPECT_EQ(outbox_.stats[0].objects, 3u);
  EXPECT_EQ(outbox_.stats[0].states, 2u);
}

TEST_F(SceneRunnerTest, RejectedStatesAreAnsweredWithTheirCode) {
  add("a", 1, box_at(0.0));
  add("b", 1, box_at(0.8));
  const TetMesh a = box_at(0.0);
  frame(3, {FrameObjectInput{"a", 1, a.positions}},
        {RejectedState{"b", 1, tetcollide_STATUS_INVALID_MESH},
         RejectedState{"ghost", 0, tetcollide_STATUS_UNKNOWN_OBJECT}});
  const auto answers = outbox_.forces_of("s", 3);
  ASSERT_EQ(answers.size(), 3u);
  EXPECT_EQ(answers[0].object, "a");
  EXPECT_EQ(answers[0].status, 0);
  EXPECT_EQ(answers[1].object, "b");
  EXPECT_EQ(answers[1].status, tetcollide_STATUS_INVALID_MESH);
  EXPECT_TRUE(answers[1].nodes.empty());
  EXPECT_EQ(answers[2].object, "ghost");
  EXPECT_EQ(answers[2].status, tetcollide_STATUS_UNKNOWN_OBJECT);
  EXPECT_EQ(outbox_.stats[0].rejected, 2u);
}

// ContactForces.state_frame says which state each object's forces come from, so a client
// can tell the answer to its frame from one computed before its state arrived.
TEST_F(SceneRunnerTest, AnswersNameTheStateTheyWereComputedFrom) {
  const auto [a, b] = add_overlapping_pair();
  frame(4, {FrameObjectInput{"a", 1, a.positions}});  // b's state not in (yet)
  auto answers = outbox_.forces_of("s", 4);
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[0].state_frame, 4);
  EXPECT_EQ(answers[1].state_frame, -1);              // b still at rest
  frame(4, {FrameObjectInput{"b", 1, b.positions}});  // b's late state: frame 4 again
  answers = outbox_.forces_of("s", 4);
  ASSERT_EQ(answers.size(), 4u);
  EXPECT_EQ(answers[2].state_frame, 4);  // a kept its frame-4 positions
  EXPECT_EQ(answers[3].state_frame, 4);
  frame(5, {FrameObjectInput{"a", 1, a.positions}},
        {RejectedState{"b", 1, tetcollide_STATUS_INVALID_MESH}});
  answers = outbox_.forces_of("s", 5);
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[0].state_frame, 5);
  EXPECT_EQ(answers[1].state_frame, 5);  // rejected answers carry their frame
  add("b", 2, box_at(0.8));              // a cut: b starts again from rest
  frame(6, {FrameObjectInput{"a", 1, a.positions}});
  answers = outbox_.forces_of("s", 6);
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[1].state_frame, -1);
}

// ContactForces.answer_id ties the answers of one computation together: a frame computed
// without b's late state and again with it gives two sets a client must not mix (the
// first set's answer for a was computed without b). Rejected answers carry 0.
TEST_F(SceneRunnerTest, AnswersOfOneComputationShareAnId) {
  const auto [a, b] = add_overlapping_pair();
  frame(4, {FrameObjectInput{"a", 1, a.positions}});  // b's state not in (yet)
  frame(4, {FrameObjectInput{"b", 1, b.positions}});  // b's late state: frame 4 again
  frame(5, {FrameObjectInput{"a", 1, a.positions}},
        {RejectedState{"c", 1, tetcollide_STATUS_UNKNOWN_OBJECT}});
  const auto four = outbox_.forces_of("s", 4);
  const auto five = outbox_.forces_of("s", 5);
  ASSERT_EQ(four.size(), 4u);
  ASSERT_EQ(five.size(), 3u);  // a, b and the rejected c
  EXPECT_NE(four[0].answer_id, 0u);
  EXPECT_EQ(four[1].answer_id, four[0].answer_id);
  EXPECT_EQ(four[3].answer_id, four[2].answer_id);
  EXPECT_NE(four[2].answer_id, four[0].answer_id);
  EXPECT_EQ(five[1].answer_id, five[0].answer_id);
  EXPECT_EQ(five[2].object, "c");
  EXPECT_EQ(five[2].answer_id, 0u);
  EXPECT_NE(five[0].answer_id, four[2].answer_id);
}

// Issue 14: an object with no state of its current version (registered, or cut, and no
// state used since) is left out of contact, and every OK answer names it; its rest
// positions are not a state. Rejected answers name the version the scene holds (0 for
// an object it does not hold), carry answer_id 0 and no left-out list.
TEST_F(SceneRunnerTest, AnObjectWithoutAStateOfItsVersionIsLeftOut) {
  const auto [a, b] = add_overlapping_pair();
  frame(1, {FrameObjectInput{"a", 1, a.positions}});  // b never sent a state
  auto answers = outbox_.forces_of("s", 1);
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_TRUE(answers[0].nodes.empty()) << "a got forces against b's rest positions";
  EXPECT_EQ(answers[0].left_out, std::vector<std::string>{"b"});
  EXPECT_EQ(answers[1].left_out, std::vector<std::string>{"b"});
  EXPECT_EQ(answers[1].state_frame, -1);
  frame(2, {FrameObjectInput{"a", 1, a.positions}, FrameObjectInput{"b", 1, b.positions}});
  answers = outbox_.forces_of("s", 2);
  EXPECT_FALSE(answers[0].nodes.empty());
  EXPECT_TRUE(answers[0].left_out.empty());
  add("b", 2, box_at(0.8));  // the cut: b is out again until its first version-2 state
  frame(3, {FrameObjectInput{"a", 1, a.positions}},
        {RejectedState{"b", 1, tetcollide_STATUS_STALE_VERSION},
         RejectedState{"ghost", 4, tetcollide_STATUS_UNKNOWN_OBJECT}});
  answers = outbox_.forces_of("s", 3);
  ASSERT_EQ(answers.size(), 3u);
  EXPECT_EQ(answers[0].status, 0);
  EXPECT_TRUE(answers[0].nodes.empty());
  EXPECT_EQ(answers[0].left_out, std::vector<std::string>{"b"});
  EXPECT_EQ(answers[1].status, tetcollide_STATUS_STALE_VERSION);
  EXPECT_EQ(answers[1].version, 2u);  // the version held, not the stale one sent
  EXPECT_EQ(answers[1].answer_id, 0u);
  EXPECT_TRUE(answers[1].left_out.empty());
  EXPECT_EQ(answers[2].object, "ghost");
  EXPECT_EQ(answers[2].version, 0u);  // not held
  EXPECT_EQ(answers[2].answer_id, 0u);
  frame(4, {FrameObjectInput{"a", 1, a.positions}, FrameObjectInput{"b", 2, b.positions}});
  answers = outbox_.forces_of("s", 4);
  EXPECT_FALSE(answers[0].nodes.empty());
  EXPECT_TRUE(answers[0].left_out.empty());
}

// A re-sent topology version gets a verdict of its own, after the version's build.
TEST_F(SceneRunnerTest, AReSentVersionGetsAVerdict) {
  add("a", 1, box_at(0.0));
  TetMesh inverted = box_at(3.0);
  std::swap(inverted.tets[3][0], inverted.tets[3][1]);
  add("a", 2, inverted);  // rejected; version 1 stays
  const auto verdict = [&](std::uint32_t version, std::int64_t timestamp) {
    SceneJob job = VerdictJob{"a", version, timestamp};
    runner_.run(job);
    return outbox_.status.back();
  };
  const StatusMessage v1 = verdict(1, 111);
  EXPECT_EQ(v1.kind, StatusKind::kRegistered);
  EXPECT_EQ(v1.topology_version, 1u);
  EXPECT_EQ(v1.topology_timestamp, 111);
  EXPECT_NE(v1.message.find("unchanged"), std::string::npos) << v1.message;
  const StatusMessage v2 = verdict(2, 222);
  EXPECT_EQ(v2.kind, StatusKind::kError);
  EXPECT_EQ(v2.code, tetcollide_STATUS_INVALID_MESH);
  EXPECT_EQ(v2.topology_timestamp, 222);
  SceneJob remove = RemoveJob{"a"};
  runner_.run(remove);
  const StatusMessage gone = verdict(1, 333);
  EXPECT_EQ(gone.kind, StatusKind::kError);
  EXPECT_EQ(gone.code, tetcollide_STATUS_UNKNOWN_OBJECT);
}

TEST_F(SceneRunnerTest, PipelineRejectionsAreAnsweredAndReported) {
  add("a", 1, box_at(0.0));
  // An inverted state: the pipeline rejects a's frame; a is answered with the code.
  TetMesh inverted = box_at(0.0);
  inverted.positions.row(0) *= -1.0;  // mirror: every tet inverted
  frame(1, {FrameObjectInput{"a", 1, inverted.positions}});
  const auto answers = outbox_.forces_of("s", 1);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_NE(answers[0].status, 0);
  bool reported = false;
  for (const auto& s : outbox_.status)
    reported = reported || (s.kind == StatusKind::kError && s.object == "a" && s.frame == 1);
  EXPECT_TRUE(reported);
}

// A state with a few inverted tets (issue 48, item 6) is answered with its forces and
// status ok, and said on the status topic: KIND_ERROR with code 0 naming the object, the
// frame and the count. The first degraded state after a clean one is always said.
TEST(SceneRunner, AFewInvertedTetsAreAnsweredAndSaid) {
  test::OutboxRecorder outbox;
  PipelineConfig config;
  config.max_inverted_fraction = 1.0;  // box_at's 162 tets: the limit is the count, 16
  SceneRunner runner("s", config, outbox, {}, 0.0);
  const TetMesh a = box_at(0.0), b = box_at(0.8);
  for (const auto& [name, mesh] : {std::pair{"a", a}, std::pair{"b", b}}) {
    SceneJob job = TopologyJob{name, 1, mesh, ObjectParams{}, Clock::now()};
    runner.run(job);
  }
  Positions dented = a.positions;
  dented(2, 21) -= 0.4;  // node (1, 1, 1) past its neighbour below: 6 inverted tets
  const auto run_frame = [&](std::int64_t f, const Positions& xa) {
    FrameJob j;
    j.frame = f;
    j.states = {FrameObjectInput{"a", 1, xa, {}}, FrameObjectInput{"b", 1, b.positions, {}}};
    j.state_frames.assign(j.states.size(), f);
    j.first_received = j.dispatched = Clock::now();
    j.complete = true;
    SceneJob job = std::move(j);
    runner.run(job);
  };
  const auto notices = [&](std::int64_t f) {
    std::vector<StatusMessage> out;
    for (const StatusMessage& s : outbox.status)
      if (s.frame == f) out.push_back(s);
    return out;
  };
  run_frame(1, dented);
  const auto answers = outbox.forces_of("s", 1);
  ASSERT_EQ(answers.size(), 2u);
  for (const auto& answer : answers) {
    EXPECT_EQ(answer.status, tetcollide_STATUS_OK) << answer.object;
    EXPECT_FALSE(answer.nodes.empty()) << answer.object;
  }
  const auto said = notices(1);
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0].kind, StatusKind::kError);
  EXPECT_EQ(said[0].code, tetcollide_STATUS_OK);
  EXPECT_EQ(said[0].object, "a");
  EXPECT_EQ(said[0].topology_version, 1u);
  EXPECT_NE(said[0].message.find("state accepted with 6 inverted and 0 degenerate tets"),
            std::string::npos)
      << said[0].message;
  run_frame(2, a.positions);  // clean: nothing said
  EXPECT_TRUE(notices(2).empty());
  run_frame(3, dented);  // a new run: said again
  EXPECT_EQ(notices(3).size(), 1u);
  EXPECT_EQ(outbox.stats.back().rejected, 0u);
}

TEST_F(SceneRunnerTest, CutAndRemove) {
  add("a", 1, box_at(0.0));
  add("a", 2,
      tc::test::structured_box(2, 2, 2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1)));
  const TetMesh a2 =
      tc::test::structured_box(2, 2, 2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 1));
  frame(5, {FrameObjectInput{"a", 2, a2.positions}});
  auto answers = outbox_.forces_of("s", 5);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers[0].version, 2u);
  EXPECT_EQ(answers[0].status, 0);
  SceneJob remove = RemoveJob{"a"};
  runner_.run(remove);
  EXPECT_EQ(outbox_.status.back().kind, StatusKind::kRemoved);
  frame(6, {});
  EXPECT_TRUE(outbox_.forces_of("s", 6).empty());
}

TEST_F(SceneRunnerTest, SameInputSameBits) {
  const auto [a, b] = add_overlapping_pair();
  for (int f = 0; f < 2; ++f)
    frame(f, {FrameObjectInput{"a", 1, a.positions}, FrameObjectInput{"b", 1, b.positions}});
  const auto f0 = outbox_.forces_of("s", 0);
  const auto f1 = outbox_.forces_of("s", 1);
  ASSERT_EQ(f0.size(), f1.size());
  for (std::size_t i = 0; i < f0.size(); ++i) {
    EXPECT_EQ(f0[i].nodes, f1[i].nodes);
    EXPECT_EQ(f0[i].forces, f1[i].forces);
  }
}

}  // namespace
}  // namespace tc::daemon
