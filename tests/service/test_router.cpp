// service/daemon/router: every rule of the reader thread with a fake clock, a recording
// outbox and a recording job sink (no DDS, no pipeline).
#include "router.hpp"

#include <gtest/gtest.h>

#include <limits>

#include "test_meshes.hpp"

namespace tc::daemon {
namespace {

using std::chrono::milliseconds;

struct RecordedForces {
  std::string scene, object;
  std::int64_t frame;
  std::uint32_t version;
  std::int32_t status;
};

class RecordingOutbox final : public Outbox {
 public:
  void publish_forces(const ForcesMessage& m) override {
    forces.push_back(
        {std::string(m.scene), std::string(m.object), m.frame, m.topology_version, m.status});
  }
  void publish_stats(const StatsMessage&) override { ++stats; }
  void publish_status(const StatusMessage& m) override { status.push_back(m); }

  std::vector<RecordedForces> forces;
  int stats = 0;
  std::vector<StatusMessage> status;

  [[nodiscard]] std::vector<StatusMessage> errors() const {
    std::vector<StatusMessage> out;
    for (const auto& s : status)
      if (s.kind == StatusKind::kError) out.push_back(s);
    return out;
  }
};

class RecordingJobs final : public JobSink {
 public:
  void post(const std::string& scene, SceneJob job) override {
    jobs.emplace_back(scene, std::move(job));
  }
  void close_scene(const std::string& scene) override { closed.push_back(scene); }

  std::vector<std::pair<std::string, SceneJob>> jobs;
  std::vector<std::string> closed;

  [[nodiscard]] std::vector<FrameJob> frames() const {
    std::vector<FrameJob> out;
    for (const auto& [s, j] : jobs)
      if (const auto* f = std::get_if<FrameJob>(&j)) out.push_back(*f);
    return out;
  }
  [[nodiscard]] std::vector<TopologyJob> topologies() const {
    std::vector<TopologyJob> out;
    for (const auto& [s, j] : jobs)
      if (const auto* t = std::get_if<TopologyJob>(&j)) out.push_back(*t);
    return out;
  }
};

struct Topo {
  std::string scene, object;
  std::uint32_t version = 1;
  std::vector<std::int64_t> ids;
  std::vector<double> rest;
  std::vector<std::int32_t> tets;
  WireParams params{1e4, 0.0, 0.0, false, tetcollide_DEPTH_CPFM, tetcollide_RESPONSE_AUTO};
  Topo(std::string s, std::string o, const TetMesh& m) : scene(std::move(s)), object(std::move(o)) {
    ids = m.node_ids;
    rest.assign(m.positions.data(), m.positions.data() + m.positions.size());
    for (const Tet& t : m.tets) tets.insert(tets.end(), t.begin(), t.end());
  }
  [[nodiscard]] TopologyView view() const {
    return TopologyView{scene, object, version, ids, rest, tets, params};
  }
};

struct State {
  std::string scene, object;
  std::int64_t frame;
  std::uint32_t version;
  std::vector<double> positions;
  [[nodiscard]] StateView view() const {
    return StateView{scene, object, frame, version, positions, {}};
  }
};

class RouterTest : public ::testing::Test {
 protected:
  RouterTest() {
    config.assembly_wait_ms = 10;
    config.unknown_object_grace_ms = 50;
  }
  Router& router() {
    if (!router_) router_ = std::make_unique<Router>(config, outbox, jobs);
    return *router_;
  }
  void add_object(const std::string& scene, const std::string& object, std::uint32_t version = 1,
                  bool is_static = false) {
    Topo t(scene, object, test::single_tet());
    t.version = version;
    t.params.is_static = is_static;
    router().on_topology(t.view(), now);
  }
  void send(const std::string& scene, const std::string& object, std::int64_t frame,
            std::uint32_t version = 1, std::size_t values = 12, double value = 0.5) {
    State s{scene, object, frame, version, std::vector<double>(values, value)};
    router().on_state(s.view(), now);
  }

  DaemonConfig config;
  RecordingOutbox outbox;
  RecordingJobs jobs;
  Clock::time_point now{std::chrono::seconds(1000)};

 private:
  std::unique_ptr<Router> router_;
};

TEST_F(RouterTest, TopologyBecomesAJob) {
  add_object("s", "a");
  const auto topos = jobs.topologies();
  ASSERT_EQ(topos.size(), 1u);
  EXPECT_EQ(topos[0].object, "a");
  EXPECT_EQ(topos[0].version, 1u);
  EXPECT_EQ(std::get<TetMesh>(topos[0].mesh).num_tets(), 1);
  EXPECT_EQ(router().scene_count(), 1u);
  add_object("s", "a");  // re-delivered: not rebuilt, but answered
  EXPECT_EQ(jobs.topologies().size(), 1u);
  ASSERT_EQ(jobs.jobs.size(), 2u);
  const auto* verdict = std::get_if<VerdictJob>(&jobs.jobs[1].second);
  ASSERT_NE(verdict, nullptr);
  EXPECT_EQ(verdict->object, "a");
  EXPECT_EQ(verdict->version, 1u);
  EXPECT_TRUE(outbox.errors().empty());
}

// A sample with the registered version but another content is not a re-send: it is an
// error (a changed topology needs a new version) and the registered one stays.
TEST_F(RouterTest, TheSameVersionWithAnotherContentIsRejected) {
  Topo t("s", "a", test::single_tet());
  router().on_topology(t.view(), now);
  Topo stiffer = t;
  stiffer.params.stiffness = 2e4;
  router().on_topology(stiffer.view(), now);
  Topo moved = t;
  moved.rest[0] += 1e-12;
  router().on_topology(moved.view(), now);
  EXPECT_EQ(jobs.topologies().size(), 1u);
  EXPECT_EQ(jobs.jobs.size(), 1u);
  const auto errors = outbox.errors();
  ASSERT_EQ(errors.size(), 2u);
  for (const auto& e : errors) {
    EXPECT_EQ(e.code, tetcollide_STATUS_INVALID_ARGUMENT);
    EXPECT_EQ(e.frame, -1);
    EXPECT_EQ(e.topology_version, 1u);
    EXPECT_NE(e.message.find("different content"), std::string::npos) << e.message;
  }
  router().on_topology(t.view(), now);  // the original again: a verdict job
  EXPECT_NE(std::get_if<VerdictJob>(&jobs.jobs.back().second), nullptr);
}

TEST_F(RouterTest, FrameDispatchedWhenEveryObjectSent) {
  add_object("s", "a");
  add_object("s", "b");
  send("s", "a", 1);
  EXPECT_TRUE(jobs.frames().empty());
  send("s", "b", 1);
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, 1);
  EXPECT_TRUE(frames[0].complete);
  ASSERT_EQ(frames[0].states.size(), 2u);
  EXPECT_EQ(frames[0].states[0].positions.cols(), 4);
  EXPECT_TRUE(frames[0].rejected.empty());
}

TEST_F(RouterTest, VelocitiesTravelWithTheirState) {
  // The contact damping reads them (Pipeline); a state without them carries none.
  add_object("s", "a");
  add_object("s", "b");
  State with{"s", "a", 1, 1, std::vector<double>(12, 0.5)};
  const std::vector<double> v = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  StateView view = with.view();
  view.velocities = v;
  router().on_state(view, now);
  send("s", "b", 1);
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_EQ(frames[0].states.size(), 2u);
  ASSERT_EQ(frames[0].states[0].object, "a");
  ASSERT_EQ(frames[0].states[0].velocities.cols(), 4);
  EXPECT_EQ(frames[0].states[0].velocities(2, 3), 12.0);
  EXPECT_EQ(frames[0].states[1].velocities.size(), 0);
}

TEST_F(RouterTest, StaticObjectsAreNotWaitedFor) {
  add_object("s", "floor", 1, true);
  add_object("s", "a");
  send("s", "a", 4);
  ASSERT_EQ(jobs.frames().size(), 1u);
}

TEST_F(RouterTest, AssemblyWaitDispatchesPartialFrame) {
  add_object("s", "a");
  add_object("s", "b");
  send("s", "a", 2);
  ASSERT_TRUE(router().next_deadline());
  EXPECT_EQ(*router().next_deadline(), now + milliseconds(10));
  router().tick(now + milliseconds(9));
  EXPECT_TRUE(jobs.frames().empty());
  router().tick(now + milliseconds(10));
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_FALSE(frames[0].complete);
  EXPECT_EQ(frames[0].states.size(), 1u);
}

TEST_F(RouterTest, ScenesAreIndependent) {
  add_object("s1", "a");
  add_object("s2", "a");
  send("s1", "a", 1);
  send("s2", "a", 9);
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(jobs.jobs[2].first, "s1");
  EXPECT_EQ(jobs.jobs[3].first, "s2");
}

// The counts behind the daemon's systemd STATUS= line (objects, frames/s).
TEST_F(RouterTest, CountsObjectsAndDispatchedFrames) {
  EXPECT_EQ(router().object_count(), 0u);
  EXPECT_EQ(router().dispatched_frames(), 0u);
  add_object("s1", "a");
  add_object("s1", "floor", 1, true);
  add_object("s2", "a");
  EXPECT_EQ(router().object_count(), 3u);
  send("s1", "a", 1);
  send("s2", "a", 1);
  send("s2", "a", 2);
  EXPECT_EQ(router().dispatched_frames(), 3u);
  EXPECT_EQ(router().dispatched_frames(), jobs.frames().size());
  router().on_topology_gone("s2", "a");
  EXPECT_EQ(router().object_count(), 2u);
  EXPECT_EQ(router().dispatched_frames(), 3u);  // a count since the start, not a gauge
}

TEST_F(RouterTest, BadStateIsRejectedButAnswered) {
  add_object("s", "a");
  add_object("s", "b");
  send("s", "a", 3, 1, 9);  // 3 nodes for a 4-node topology
  send("s", "b", 3);
  const auto errors = outbox.errors();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, tetcollide_STATUS_INVALID_ARGUMENT);
  EXPECT_EQ(errors[0].object, "a");
  EXPECT_EQ(errors[0].frame, 3);
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);  // the bad state still completes the frame
  ASSERT_EQ(frames[0].rejected.size(), 1u);
  EXPECT_EQ(frames[0].rejected[0].object, "a");
  EXPECT_EQ(frames[0].rejected[0].code, tetcollide_STATUS_INVALID_ARGUMENT);
  ASSERT_EQ(frames[0].states.size(), 1u);
  EXPECT_EQ(frames[0].states[0].object, "b");
}

TEST_F(RouterTest, NonFiniteStateRejected) {
  add_object("s", "a");
  send("s", "a", 1, 1, 12, std::numeric_limits<double>::quiet_NaN());
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_INVALID_MESH);
  ASSERT_EQ(jobs.frames().size(), 1u);
  EXPECT_EQ(jobs.frames()[0].rejected.size(), 1u);
}

TEST_F(RouterTest, OversizedStateRejectedBeforeLookup) {
  config.limits.max_nodes = 4;
  add_object("s", "a");
  send("s", "a", 1, 1, 15);
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_OVERSIZED);
}

TEST_F(RouterTest, BadTopologyReportedAndNotRegistered) {
  Topo t("s", "a", test::single_tet());
  t.tets[3] = 17;
  router().on_topology(t.view(), now);
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_INVALID_MESH);
  EXPECT_TRUE(jobs.jobs.empty());
  EXPECT_EQ(router().scene_count(), 0u);
}

TEST_F(RouterTest, UnknownObjectHeldThenAnsweredWithError) {
  add_object("s", "a");
  send("s", "ghost", 5);
  EXPECT_EQ(router().held_states(), 1u);
  EXPECT_TRUE(outbox.errors().empty());
  router().tick(now + milliseconds(49));
  EXPECT_TRUE(outbox.errors().empty());
  router().tick(now + milliseconds(50));
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_UNKNOWN_OBJECT);
  EXPECT_EQ(outbox.errors()[0].object, "ghost");
  ASSERT_EQ(outbox.forces.size(), 1u);  // answered so its client does not wait
  EXPECT_EQ(outbox.forces[0].status, tetcollide_STATUS_UNKNOWN_OBJECT);
  EXPECT_EQ(outbox.forces[0].frame, 5);
  EXPECT_EQ(router().held_states(), 0u);
}

TEST_F(RouterTest, StateBeforeTopologyIsUsedWhenTopologyArrives) {
  send("s", "a", 1);
  EXPECT_EQ(router().held_states(), 1u);
  add_object("s", "a");
  EXPECT_EQ(router().held_states(), 0u);
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].states.size(), 1u);
  // Job order: the topology before the frame that uses it.
  ASSERT_EQ(jobs.jobs.size(), 2u);
  EXPECT_TRUE(std::holds_alternative<TopologyJob>(jobs.jobs[0].second));
  EXPECT_TRUE(outbox.errors().empty());
}

// After a service restart the topologies come back one by one: a frame whose other
// object's topology is still on the wire waits for it (within the grace) instead of being
// computed without that object.
TEST_F(RouterTest, FrameWaitsForAStateWhoseTopologyIsOnTheWire) {
  add_object("s", "a");
  send("s", "b", 7);  // b's topology not in yet: held
  send("s", "a", 7);  // a is the only registered object: complete, but b is held
  router().tick(now + milliseconds(20));  // past the assembly wait, within the grace
  EXPECT_TRUE(jobs.frames().empty());
  add_object("s", "b");  // b's topology arrives: frame 7 runs with both states
  const auto frames = jobs.frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].frame, 7);
  EXPECT_EQ(frames[0].states.size(), 2u);
  EXPECT_EQ(frames[0].state_frames, (std::vector<std::int64_t>{7, 7}));
}

// A state for an object that never comes delays its scene's frame by the grace at most.
TEST_F(RouterTest, AHeldStateDelaysTheFrameByTheGraceAtMost) {
  add_object("s", "a");
  send("s", "ghost", 3);
  send("s", "a", 3);
  router().tick(now + milliseconds(49));
  EXPECT_TRUE(jobs.frames().empty());
  router().tick(now + milliseconds(50));  // ghost rejected; frame 3 goes
  ASSERT_EQ(jobs.frames().size(), 1u);
  EXPECT_EQ(jobs.frames()[0].states.size(), 1u);
}

TEST_F(RouterTest, StaleVersionRejected) {
  add_object("s", "a", 1);
  add_object("s", "a", 2);  // a cut
  send("s", "a", 8, 1);
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_STALE_VERSION);
  ASSERT_EQ(jobs.frames().size(), 1u);
  EXPECT_EQ(jobs.frames()[0].rejected.size(), 1u);
}

TEST_F(RouterTest, NewerVersionHeldUntilItsTopology) {
  add_object("s", "a", 1);
  send("s", "a", 8, 2);  // the cut's state overtook the cut's topology
  EXPECT_EQ(router().held_states(), 1u);
  EXPECT_TRUE(jobs.frames().empty());
  add_object("s", "a", 2);
  ASSERT_EQ(jobs.frames().size(), 1u);
  EXPECT_EQ(jobs.frames()[0].states.size(), 1u);
  EXPECT_EQ(jobs.frames()[0].states[0].topology_version, 2u);
}

TEST_F(RouterTest, NeverRegisteredVersionExpiresAsStale) {
  add_object("s", "a", 1);
  add_object("s", "b", 1);
  send("s", "b", 8, 1);
  send("s", "a", 8, 7);
  router().tick(now + milliseconds(20));  // past the assembly wait, inside the grace
  EXPECT_TRUE(jobs.frames().empty()) << "frame dispatched while a's state was unresolved";
  router().tick(now + milliseconds(60));
  ASSERT_EQ(outbox.errors().size(), 1u);
  EXPECT_EQ(outbox.errors()[0].code, tetcollide_STATUS_STALE_VERSION);
  ASSERT_EQ(jobs.frames().size(), 1u);  // answered through the scene's frame
  EXPECT_TRUE(jobs.frames()[0].complete);
  EXPECT_EQ(jobs.frames()[0].rejected.size(), 1u);
  EXPECT_EQ(jobs.frames()[0].states.size(), 1u);
}

TEST_F(RouterTest, FailedTopologyFallsBackAndUnblocksFrames) {
  add_object("s", "a");
  add_object("s", "b");
  router().on_topology_result({"s", "a", 1, true}, now);
  router().on_topology_result({"s", "b", 1, false}, now);  // b's mesh was inverted
  EXPECT_EQ(router().registry("s")->current("b"), nullptr);
  send("s", "a", 1);
  EXPECT_EQ(jobs.frames().size(), 1u);  // no longer waits for b
}

TEST_F(RouterTest, RemovalClosesEmptyScene) {
  add_object("s", "a");
  add_object("s", "b");
  router().on_topology_gone("s", "a");
  EXPECT_EQ(router().scene_count(), 1u);
  router().on_topology_gone("s", "b");
  EXPECT_EQ(router().scene_count(), 0u);
  ASSERT_EQ(jobs.closed.size(), 1u);
  EXPECT_EQ(jobs.closed[0], "s");
  int removes = 0;
  for (const auto& [s, j] : jobs.jobs) removes += std::holds_alternative<RemoveJob>(j) ? 1 : 0;
  EXPECT_EQ(removes, 2);
}

TEST_F(RouterTest, RemovalCompletesAWaitingFrame) {
  add_object("s", "a");
  add_object("s", "b");
  send("s", "a", 1);
  router().on_topology_gone("s", "b");
  router().tick(now);
  EXPECT_EQ(jobs.frames().size(), 1u);
}

TEST_F(RouterTest, SceneFilter) {
  config.scenes = {"mine*"};
  add_object("other", "a");
  EXPECT_EQ(router().scene_count(), 0u);
  add_object("mine-1", "a");
  EXPECT_EQ(router().scene_count(), 1u);
  send("other", "a", 1);
  EXPECT_EQ(router().held_states(), 0u);
  EXPECT_TRUE(outbox.errors().empty());
}

TEST_F(RouterTest, ObjectAndSceneLimits) {
  config.limits.max_objects_per_scene = 1;
  config.limits.max_scenes = 1;
  add_object("s", "a");
  add_object("s", "b");
  add_object("t", "a");
  const auto errors = outbox.errors();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0].code, tetcollide_STATUS_OVERSIZED);
  EXPECT_EQ(errors[0].object, "b");
  EXPECT_EQ(errors[1].code, tetcollide_STATUS_OVERSIZED);
  EXPECT_EQ(errors[1].scene, "t");
  EXPECT_EQ(router().scene_count(), 1u);
  add_object("s", "a", 2);  // a cut of a registered object is still fine
  EXPECT_EQ(outbox.errors().size(), 2u);
}

TEST_F(RouterTest, EveryRejectionIsReported) {
  // The log is rate-limited, the status topic is not: each bad frame has its sample.
  add_object("s", "a");
  for (int f = 0; f < 5; ++f) send("s", "a", f, 1, 3);
  ASSERT_EQ(outbox.errors().size(), 5u);
  for (int f = 0; f < 5; ++f) EXPECT_EQ(outbox.errors()[static_cast<std::size_t>(f)].frame, f);
  EXPECT_EQ(jobs.frames().size(), 5u);  // every frame is still answered
}

TEST_F(RouterTest, InvalidNamesNeverCrash) {
  send("", "a", 1);
  send("s", std::string("a\0b", 3), 1);
  send("s", std::string(300, 'x'), 1);
  EXPECT_EQ(outbox.errors().size(), 3u);
  EXPECT_EQ(router().held_states(), 0u);
}

}  // namespace
}  // namespace tc::daemon
