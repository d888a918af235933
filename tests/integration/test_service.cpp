// The real tetcollided over DDS: readiness, streaming, bad input, cuts, removal, scenes,
// signals. Each test runs its own daemon on a private domain.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <array>
#include <atomic>
#include <cmath>
#include <csignal>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <thread>

#include "daemon_test.hpp"
#include "protocol.hpp"
#include "scenes.hpp"
#include "tetcollide.h"
#include "tetcollide/client.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;
using client::Client;
using client::StatusCode;

const char* kConfig = R"(version: 1
dds:
  status_period_s: 0.2
frames:
  assembly_wait_ms: 50
  unknown_object_grace_ms: 100
limits:
  max_nodes: 5000
log:
  level: info
  timing_summary_period_s: 0
)";

class ServiceTest : public DaemonTest {
 protected:
  void SetUp() override { start_daemon("itest-service", kConfig); }
  /// Waits for a status event matching `pred` (events are consumed).
  template <typename Pred>
  std::optional<client::StatusEvent> wait_status(Client& c, Pred pred,
                                                 std::chrono::milliseconds timeout = 5s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      for (auto& e : c.take_status_events())
        if (pred(e)) return e;
      c.poll(20ms);
    }
    return std::nullopt;
  }
};

void expect_sane(const client::ObjectForces& f, std::size_t nodes) {
  EXPECT_EQ(f.status, 0) << f.object << " frame " << f.frame;
  ASSERT_EQ(f.forces.size(), 3 * f.nodes.size());
  for (std::size_t k = 0; k < f.nodes.size(); ++k) {
    EXPECT_GE(f.nodes[k], 0);
    EXPECT_LT(static_cast<std::size_t>(f.nodes[k]), nodes);
    if (k > 0) {
      EXPECT_LT(f.nodes[k - 1], f.nodes[k]);
    }
  }
  for (const double v : f.forces) EXPECT_TRUE(std::isfinite(v));
}

TEST_F(ServiceTest, AnnouncesReadyAndStopsCleanlyOnSigterm) {
  auto c = connect("ready");
  bool ready_seen = false;
  for (const auto& e : c->take_status_events())
    ready_seen = ready_seen || (e.state == client::StatusEvent::State::kReady);
  EXPECT_TRUE(ready_seen);
  const int status = daemon_->stop(SIGTERM);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const std::string log = daemon_->log_text();
  EXPECT_NE(log.find("received SIGTERM"), std::string::npos);
  EXPECT_NE(log.find("tetcollided stopped"), std::string::npos);
}

TEST_F(ServiceTest, StopsCleanlyOnSigint) {
  const int status = daemon_->stop(SIGINT);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 0);
}

TEST_F(ServiceTest, EveryStreamedFrameIsAnswered) {
  auto c = connect("stream");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  std::size_t with_forces = 0;
  for (std::int64_t f = 0; f < 200; ++f) {
    const auto pa = s.pos_a(f);
    const auto pb = s.pos_b(f);
    c->publish_states(f, {{"a", pa}, {"b", pb}});
    const auto forces = c->wait_forces(f, 5s);
    ASSERT_TRUE(forces) << "frame " << f << " not answered";
    ASSERT_EQ(forces->frame, f);
    ASSERT_EQ(forces->objects.size(), 2u);
    expect_sane(*forces->find("a"), s.a.rest_positions.size() / 3);
    expect_sane(*forces->find("b"), s.b.rest_positions.size() / 3);
    EXPECT_EQ(forces->find("a")->topology_version, 1u);
    with_forces += forces->find("a")->nodes.empty() ? 0 : 1;
  }
  EXPECT_GT(with_forces, 0u) << "overlapping boxes never produced a force";
}

TEST_F(ServiceTest, SameStatesGiveBitIdenticalForcesInAnotherScene) {
  TwoBoxes s;
  std::vector<std::vector<client::ObjectForces>> runs(2);
  for (int run = 0; run < 2; ++run) {
    auto c = connect("determinism-" + std::to_string(run));
    ASSERT_TRUE(s.register_with(*c));
    for (std::int64_t f = 0; f < 30; ++f) {
      const auto pa = s.pos_a(f);
      const auto pb = s.pos_b(f);
      c->publish_states(f, {{"a", pa}, {"b", pb}});
      const auto forces = c->wait_forces(f, 5s);
      ASSERT_TRUE(forces && forces->frame == f);
      for (const auto& o : forces->objects) runs[run].push_back(o);
    }
  }
  ASSERT_EQ(runs[0].size(), runs[1].size());
  for (std::size_t i = 0; i < runs[0].size(); ++i) {
    EXPECT_EQ(runs[0][i].nodes, runs[1][i].nodes);
    ASSERT_EQ(runs[0][i].forces.size(), runs[1][i].forces.size());
    EXPECT_EQ(0, std::memcmp(runs[0][i].forces.data(), runs[1][i].forces.data(),
                             runs[0][i].forces.size() * sizeof(double)));
  }
}

TEST_F(ServiceTest, ScenesRunInParallelAndIndependently) {
  TwoBoxes s;
  std::vector<std::thread> sims;
  std::vector<int> answered(3, 0);
  for (int k = 0; k < 3; ++k)
    sims.emplace_back([&, k] {
      auto c = connect("parallel-" + std::to_string(k));
      if (!s.register_with(*c)) return;
      for (std::int64_t f = 0; f < 50; ++f) {
        const auto pa = s.pos_a(f + k);
        const auto pb = s.pos_b(f);
        c->publish_states(f, {{"a", pa}, {"b", pb}});
        const auto forces = c->wait_forces(f, 5s);
        if (forces && forces->frame == f && forces->ok()) ++answered[static_cast<std::size_t>(k)];
      }
    });
  for (auto& t : sims) t.join();
  for (int k = 0; k < 3; ++k) EXPECT_EQ(answered[static_cast<std::size_t>(k)], 50) << "scene " << k;
}

TEST_F(ServiceTest, BadInputIsRejectedAndGoodObjectsKeepTheirForces) {
  auto c = connect("bad");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));

  // Topologies: an index out of range (sample validation) and an inverted tet (found
  // by the pipeline when it builds the object).
  client::Mesh out_of_range = box_mesh(1, {3, 3, 3}, {4, 4, 4});
  out_of_range.tets[5] = 1000;
  c->register_object("bad_index", out_of_range, {});
  const auto r1 = c->wait_registered("bad_index", 10s);
  ASSERT_TRUE(r1.done);
  EXPECT_FALSE(r1.ok);
  EXPECT_EQ(r1.code, static_cast<int>(StatusCode::kInvalidMesh)) << r1.message;
  client::Mesh inverted = box_mesh(1, {3, 3, 3}, {4, 4, 4});
  std::swap(inverted.tets[0], inverted.tets[1]);
  c->register_object("inverted", inverted, {});
  const auto r2 = c->wait_registered("inverted", 10s);
  ASSERT_TRUE(r2.done);
  EXPECT_FALSE(r2.ok);
  EXPECT_EQ(r2.code, static_cast<int>(StatusCode::kInvalidMesh)) << r2.message;
  client::ObjectParams bad_params;
  bad_params.stiffness = -1.0;
  c->register_object("bad_params", box_mesh(1, {3, 3, 3}, {4, 4, 4}), bad_params);
  const auto r3 = c->wait_registered("bad_params", 10s);
  ASSERT_TRUE(r3.done);
  EXPECT_EQ(r3.code, static_cast<int>(StatusCode::kInvalidArgument)) << r3.message;
  // Over limits.max_nodes (5000): 18^3 cells have 6859 nodes.
  c->register_object("huge", box_mesh(18, {5, 5, 5}, {6, 6, 6}), {});
  const auto r4 = c->wait_registered("huge", 10s);
  ASSERT_TRUE(r4.done);
  EXPECT_EQ(r4.code, static_cast<int>(StatusCode::kOversized)) << r4.message;

  struct BadState {
    const char* what;
    std::vector<double> positions;
    std::uint32_t version;
    StatusCode code;
  };
  auto nan_positions = s.pos_b(0);
  nan_positions[7] = std::nan("");
  auto inf_positions = s.pos_b(0);
  inf_positions[0] = INFINITY;
  auto short_positions = s.pos_b(0);
  short_positions.resize(short_positions.size() - 3);
  const std::vector<BadState> cases = {
      {"wrong length", short_positions, 0, StatusCode::kInvalidArgument},
      {"not a multiple of 3", std::vector<double>(10, 0.0), 0, StatusCode::kInvalidArgument},
      {"NaN", nan_positions, 0, StatusCode::kInvalidMesh},
      {"infinity", inf_positions, 0, StatusCode::kInvalidMesh},
      {"stale version", s.pos_b(0), 77, StatusCode::kStaleVersion},
      {"oversized", std::vector<double>(3 * 6000, 0.0), 0, StatusCode::kOversized},
  };
  std::int64_t frame = 0;
  for (const auto& bad : cases) {
    SCOPED_TRACE(bad.what);
    ++frame;
    const auto pa = s.pos_a(frame);
    client::ObjectState sa{"a", pa};
    client::ObjectState sb{"b", bad.positions};
    sb.topology_version = bad.version;
    const std::vector<client::ObjectState> states{sa, sb};
    c->publish_states(frame, states);
    const auto forces = c->wait_forces(frame, 5s);
    ASSERT_TRUE(forces);
    ASSERT_EQ(forces->frame, frame);
    ASSERT_NE(forces->find("a"), nullptr);
    expect_sane(*forces->find("a"), s.a.rest_positions.size() / 3);
    ASSERT_NE(forces->find("b"), nullptr);
    EXPECT_EQ(forces->find("b")->status, static_cast<int>(bad.code));
    EXPECT_TRUE(forces->find("b")->nodes.empty());
    const auto e = wait_status(*c, [&](const client::StatusEvent& ev) {
      return ev.kind == client::StatusEvent::Kind::kError && ev.object == "b" && ev.frame == frame;
    });
    ASSERT_TRUE(e) << "no status error for frame " << frame;
    EXPECT_EQ(e->code, static_cast<int>(bad.code)) << e->message;
    EXPECT_EQ(e->scene, "bad");
  }
  // A state for an object nobody registered: status error, and the scene goes on.
  {
    ++frame;
    const auto pa = s.pos_a(frame);
    const auto pb = s.pos_b(frame);
    const auto ghost = s.pos_b(frame);
    c->publish_states(frame, {{"a", pa}, {"b", pb}, {"ghost", ghost}});
    const auto forces = c->wait_forces(frame, 5s);
    ASSERT_TRUE(forces && forces->frame == frame);
    EXPECT_TRUE(forces->ok());
    const auto e = wait_status(*c, [&](const client::StatusEvent& ev) {
      return ev.kind == client::StatusEvent::Kind::kError && ev.object == "ghost";
    });
    ASSERT_TRUE(e);
    EXPECT_EQ(e->code, static_cast<int>(StatusCode::kUnknownObject));
  }
  // The daemon is still alive and serving.
  ++frame;
  const auto pa = s.pos_a(frame);
  const auto pb = s.pos_b(frame);
  c->publish_states(frame, {{"a", pa}, {"b", pb}});
  const auto forces = c->wait_forces(frame, 5s);
  ASSERT_TRUE(forces && forces->frame == frame && forces->ok());
  EXPECT_TRUE(daemon_->running());
  EXPECT_NE(daemon_->log_text().find("rejected"), std::string::npos);
}

TEST_F(ServiceTest, ACutReplacesTheTopologyBetweenFrames) {
  auto c = connect("cut");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  const auto pa0 = s.pos_a(0);
  const auto pb0 = s.pos_b(0);
  c->publish_states(0, {{"a", pa0}, {"b", pb0}});
  ASSERT_TRUE(c->wait_forces(0, 5s));
  // Cut b: a coarser mesh with a different node count, version 2.
  const client::Mesh b2 = box_mesh(2, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  EXPECT_EQ(c->register_object("b", b2, {}), 2u);
  // No waiting for the registration: a state that overtakes its topology is held.
  const auto pa1 = s.pos_a(1);
  const auto pb1 = translated(b2, {0, 0, 0});
  c->publish_states(1, {{"a", pa1}, {"b", pb1}});
  const auto forces = c->wait_forces(1, 5s);
  ASSERT_TRUE(forces && forces->frame == 1);
  ASSERT_TRUE(forces->ok());
  EXPECT_EQ(forces->find("b")->topology_version, 2u);
  expect_sane(*forces->find("b"), b2.rest_positions.size() / 3);
  // The old version is stale now.
  client::ObjectState old{"b", pb0};
  old.topology_version = 1;
  const std::vector<client::ObjectState> states{{"a", pa1}, old};
  c->publish_states(2, states);
  const auto f2 = c->wait_forces(2, 5s);
  ASSERT_TRUE(f2 && f2->frame == 2);
  EXPECT_EQ(f2->find("b")->status, static_cast<int>(StatusCode::kStaleVersion));
}

// A surface object (issue 19) through the service: a plate of triangles pressed into a
// static box is pushed up, the box takes the reactions (the sum of every force is zero),
// nothing when apart; a bad surface topology and a NaN state are rejected by name.
// A client written from the docs that got a QoS policy wrong is not matched by DDS and
// would hear nothing: the service names the topic and the policy in a ServiceStatus
// error (and its log) instead. Here: a ContactForces reader with the default SHARED
// ownership (the answer topics are EXCLUSIVE) and a MeshTopology writer with the default
// VOLATILE durability and infinite lease.
TEST_F(ServiceTest, AClientWithIncompatibleQosIsToldWhatIsWrong) {
  auto c = connect("qos");
  const dds_entity_t participant = dds_create_participant(domain_, nullptr, nullptr);
  ASSERT_GT(participant, 0);
  const auto make_topic = [&](protocol::Topic t) {
    return dds_create_topic(participant, protocol::topic_descriptor(t), protocol::topic_name(t),
                            nullptr, nullptr);
  };
  {
    auto qos = protocol::topic_qos(protocol::Topic::kForces);
    dds_qset_ownership(qos.get(), DDS_OWNERSHIP_SHARED);
    ASSERT_GT(
        dds_create_reader(participant, make_topic(protocol::Topic::kForces), qos.get(), nullptr),
        0);
  }
  const auto forces = wait_status(*c, [](const client::StatusEvent& e) {
    return e.kind == client::StatusEvent::Kind::kError &&
           e.message.find("tetcollide/ContactForces") != std::string::npos;
  });
  ASSERT_TRUE(forces.has_value()) << "no error names the SHARED ContactForces reader";
  EXPECT_EQ(forces->code, static_cast<std::int32_t>(StatusCode::kInvalidArgument));
  EXPECT_NE(forces->message.find("OWNERSHIP"), std::string::npos) << forces->message;
  EXPECT_NE(forces->message.find("EXCLUSIVE"), std::string::npos) << forces->message;

  ASSERT_GT(
      dds_create_writer(participant, make_topic(protocol::Topic::kTopology), nullptr, nullptr), 0);
  const auto topology = wait_status(*c, [](const client::StatusEvent& e) {
    return e.kind == client::StatusEvent::Kind::kError &&
           e.message.find("tetcollide/MeshTopology") != std::string::npos;
  });
  ASSERT_TRUE(topology.has_value()) << "no error names the default-QoS MeshTopology writer";
  EXPECT_TRUE(topology->message.find("DURABILITY") != std::string::npos ||
              topology->message.find("LIVELINESS") != std::string::npos)
      << topology->message;
  EXPECT_NE(daemon_->log_text().find("incompatible QoS not matched"), std::string::npos);
  std::printf("[ message ] %s\n[ message ] %s\n", forces->message.c_str(),
              topology->message.c_str());
  dds_delete(participant);
  // A well-configured client is served as before.
  c->register_object("box", box_mesh(1, {0, 0, 0}, {1, 1, 1}), {});
  EXPECT_TRUE(c->wait_registered("box", 10s).ok);
}

TEST_F(ServiceTest, ASurfaceObjectPressedIntoABoxIsPushedOut) {
  auto c = connect("surface");
  client::ObjectParams box_params;
  box_params.is_static = true;
  const client::Mesh box = box_mesh(3, {-1, -1, -1}, {1, 1, 0});
  const client::Mesh plate = plate_mesh(6, 0.6, {-0.3, -0.3, 0.0});
  c->register_object("box", box, box_params);
  c->register_object("plate", plate, {});
  ASSERT_TRUE(c->wait_registered("box", 10s).ok);
  const auto reg = c->wait_registered("plate", 10s);
  ASSERT_TRUE(reg.ok) << reg.message;
  const std::size_t n = plate.rest_positions.size() / 3;
  for (std::int64_t f = 0; f < 3; ++f) {
    const double sink = 0.01 * static_cast<double>(f);  // 0, 1 and 2 cm into the box
    const auto p = translated(plate, {0.0, 0.0, -sink + (f == 0 ? 0.05 : 0.0)});
    c->publish_states(f, {{"plate", p}});
    const auto forces = c->wait_forces(f, 5s);
    ASSERT_TRUE(forces && forces->frame == f) << "frame " << f;
    ASSERT_TRUE(forces->ok());
    const auto* on_plate = forces->find("plate");
    const auto* on_box = forces->find("box");
    ASSERT_NE(on_plate, nullptr);
    ASSERT_NE(on_box, nullptr);
    expect_sane(*on_plate, n);
    if (f == 0) {
      EXPECT_TRUE(on_plate->nodes.empty()) << "5 cm above the box";
      continue;
    }
    EXPECT_EQ(on_plate->nodes.size(), n) << "every vertex is in the box";
    Eigen::Vector3d sum = Eigen::Vector3d::Zero(), up = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < on_plate->nodes.size(); ++k) {
      const Eigen::Vector3d v(on_plate->forces[3 * k], on_plate->forces[3 * k + 1],
                              on_plate->forces[3 * k + 2]);
      EXPECT_GT(v.z(), 0.0);
      up += v;
    }
    sum += up;
    for (std::size_t k = 0; k < on_box->nodes.size(); ++k)
      sum += Eigen::Vector3d(on_box->forces[3 * k], on_box->forces[3 * k + 1],
                             on_box->forces[3 * k + 2]);
    EXPECT_LT(sum.norm(), 1e-9 * up.norm());
  }
  // A NaN in the plate's state: its answer carries invalid_mesh.
  auto bad = translated(plate, {0.0, 0.0, -0.01});
  bad[3 * 5 + 1] = std::nan("");
  c->publish_states(3, {{"plate", bad}});
  const auto rejected = c->wait_forces(3, 5s);
  ASSERT_TRUE(rejected && rejected->frame == 3);
  EXPECT_EQ(rejected->find("plate")->status, static_cast<int>(StatusCode::kInvalidMesh));
  // A surface whose triangle names a node that does not exist: KIND_ERROR, named.
  client::Mesh broken = plate;
  broken.triangles[4] = 999;
  c->register_object("broken", broken, {});
  const auto verdict = c->wait_registered("broken", 10s);
  EXPECT_FALSE(verdict.ok);
  EXPECT_NE(verdict.message.find("triangle 1 has node index 999"), std::string::npos)
      << verdict.message;
}

/// Protocol 3 through the daemon: a box sliding over a static one with friction gets the
/// pair's Coulomb force (sqrt(0.4 x 0.9) = 0.6 times the push, against the slip), the
/// reaction balances it, the blocks (df/dx and df/dv) go to the object that asked for
/// them only, a state without velocities is at rest (no friction), and a bad coefficient
/// is rejected naming the parameter.
TEST_F(ServiceTest, FrictionAndPerObjectBlocks) {
  auto c = connect("friction");
  const client::Mesh floor = box_mesh(3, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh block = box_mesh(3, {-0.3, -0.3, 0.48}, {0.3, 0.3, 1.08});  // 2 cm in
  // Both objects publish (the floor at rest, no velocities), so wait_forces waits for
  // both answers.
  client::ObjectParams pf;
  pf.friction = 0.4;
  pf.response = client::ResponseKind::kPoint;
  client::ObjectParams pb = pf;
  pb.friction = 0.9;
  pb.blocks = true;
  c->register_object("floor", floor, pf);
  c->register_object("block", block, pb);
  ASSERT_TRUE(c->wait_registered("floor", 10s).ok);
  ASSERT_TRUE(c->wait_registered("block", 10s).ok);
  const std::size_t n = block.rest_positions.size() / 3;
  std::vector<double> sliding(3 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i) sliding[3 * i] = 0.5;  // +x at 0.5 m/s
  const auto total = [](const client::ObjectForces& f) {
    std::array<double, 3> sum{0.0, 0.0, 0.0};
    for (std::size_t k = 0; k < f.forces.size(); ++k) sum[k % 3] += f.forces[k];
    return sum;
  };
  for (const bool moving : {true, false}) {
    SCOPED_TRACE(moving ? "sliding" : "no velocities");
    const std::int64_t frame = moving ? 0 : 1;
    c->publish_states(frame,
                      {{"floor", floor.rest_positions},
                       {"block", block.rest_positions,
                        moving ? std::span<const double>(sliding) : std::span<const double>()}});
    const auto answer = c->wait_forces(frame, 10s);
    ASSERT_TRUE(answer);
    const client::ObjectForces* fb = answer->find("block");
    const client::ObjectForces* ff = answer->find("floor");
    ASSERT_TRUE(fb != nullptr && ff != nullptr);
    expect_sane(*fb, n);
    const auto on_block = total(*fb), on_floor = total(*ff);
    ASSERT_GT(on_block[2], 0.0);
    EXPECT_NEAR(on_block[0], moving ? -0.6 * on_block[2] : 0.0, 1e-9 * on_block[2]);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(on_block[k] + on_floor[k], 0.0, 1e-9 * on_block[2]);
    EXPECT_EQ(fb->stiffness.size(), 9 * fb->nodes.size());
    EXPECT_EQ(fb->damping.size(), 9 * fb->nodes.size());
    EXPECT_TRUE(ff->stiffness.empty() && ff->damping.empty());  // the floor did not ask
    double slip = 0.0;  // sliding along x: friction's secant acts across the tangent plane
    for (std::size_t k = 0; k < fb->nodes.size(); ++k) slip += fb->damping[9 * k + 4];
    if (moving) {
      EXPECT_LT(slip, 0.0);
    }
  }
  client::ObjectParams bad = pb;
  bad.friction = -0.1;
  c->register_object("bad", block, bad);
  const auto r = c->wait_registered("bad", 10s);
  ASSERT_TRUE(r.done);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.code, static_cast<int>(StatusCode::kInvalidArgument)) << r.message;
  EXPECT_NE(r.message.find("params.friction"), std::string::npos) << r.message;
}

/// ObjectParams.contacts through the daemon: the block that asked gets the contact points
/// behind its forces (its nodes in the floor and the floor's nodes in it), each point of the
/// intruder at its barycentric place in the penetrated tet, 2 cm deep along +-z; the floor,
/// which did not ask, gets none.
TEST_F(ServiceTest, ContactsForTheObjectsThatAskForThem) {
  auto c = connect("contacts");
  const client::Mesh floor = box_mesh(3, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh block = box_mesh(3, {-0.3, -0.3, 0.48}, {0.3, 0.3, 1.08});  // 2 cm in
  client::ObjectParams pf;  // both publish: wait_forces waits for both answers
  pf.response = client::ResponseKind::kPoint;
  client::ObjectParams pb = pf;
  pb.contacts = true;
  c->register_object("floor", floor, pf);
  c->register_object("block", block, pb);
  ASSERT_TRUE(c->wait_registered("floor", 10s).ok);
  ASSERT_TRUE(c->wait_registered("block", 10s).ok);
  c->publish_states(0, {{"floor", floor.rest_positions}, {"block", block.rest_positions}});
  const auto answer = c->wait_forces(0, 10s);
  ASSERT_TRUE(answer);
  const client::ObjectForces* fb = answer->find("block");
  const client::ObjectForces* ff = answer->find("floor");
  ASSERT_TRUE(fb != nullptr && ff != nullptr);
  EXPECT_TRUE(ff->contacts.empty());
  ASSERT_FALSE(fb->contacts.empty());
  const auto point = [](const client::Mesh& m, std::int32_t node) {
    return Eigen::Vector3d(m.rest_positions[3 * static_cast<std::size_t>(node)],
                           m.rest_positions[3 * static_cast<std::size_t>(node) + 1],
                           m.rest_positions[3 * static_cast<std::size_t>(node) + 2]);
  };
  std::size_t intruding = 0;
  for (const client::Contact& k : fb->contacts) {
    EXPECT_EQ(k.other, "floor");
    const client::Mesh& x = k.intrudes ? block : floor;
    const client::Mesh& y = k.intrudes ? floor : block;
    intruding += k.intrudes ? 1 : 0;
    EXPECT_EQ(k.nodes[1], -1);  // point response: one node per row
    ASSERT_GE(k.tet, 0);
    ASSERT_LT(static_cast<std::size_t>(k.tet), y.tets.size() / 4);
    Eigen::Vector3d in_y = Eigen::Vector3d::Zero();
    for (std::size_t j = 0; j < 4; ++j)
      in_y += k.barycentric[j] * point(y, y.tets[4 * static_cast<std::size_t>(k.tet) + j]);
    EXPECT_LT((point(x, k.nodes[0]) - in_y).norm(), 1e-9);
    EXPECT_NEAR(k.depth, 0.02, 1e-9);
    EXPECT_NEAR(std::abs(k.normal[2]), 1.0, 1e-9);  // out through the floor's top or the
    EXPECT_EQ(k.normal[2] > 0.0, k.intrudes);       // block's bottom
  }
  EXPECT_GT(intruding, 0u);
  EXPECT_LT(intruding, fb->contacts.size());
}

/// `tetcollide status --json` while a simulator streams frames: the service (ready,
/// protocol 3, its uptime), the scene with its two objects, its frame rate and compute
/// times, and the error of a state it rejected.
TEST_F(ServiceTest, StatusShowsTheServiceAndItsScenes) {
  auto c = connect("watched");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  std::atomic<bool> done{false};
  std::thread simulator([&] {
    for (std::int64_t f = 0; !done.load() && f < 20000; ++f) {
      const auto pa = s.pos_a(f);
      const auto pb = s.pos_b(f);
      const std::vector<double> bad(6, 0.0);  // frame 5: a state of the wrong length
      c->publish_states(f, {{"a", f == 5 ? std::span<const double>(bad) : pa}, {"b", pb}});
      c->wait_forces(f, 2s);
      std::this_thread::sleep_for(2ms);
    }
  });
  const auto r = run_program({program_from_env("TC_CLI"), "status", "--domain",
                              std::to_string(domain_), "--duration", "1.5", "--json"},
                             30s);
  done.store(true);
  simulator.join();
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["services"].size(), 1u) << j.dump(2);
  const auto& service = j["services"][0];
  EXPECT_EQ(service["state"], "ready");
  EXPECT_EQ(service["protocol_version"].get<int>(), 3);
  EXPECT_GT(service["uptime_s"].get<double>(), 0.0);
  const nlohmann::json* scene = nullptr;
  for (const auto& sc : j["scenes"])
    if (sc["scene"] == "watched") scene = &sc;
  ASSERT_NE(scene, nullptr) << j.dump(2);
  EXPECT_EQ((*scene)["objects"].get<int>(), 2);
  EXPECT_GT((*scene)["frames_per_s"].get<double>(), 10.0) << scene->dump();
  EXPECT_GT((*scene)["compute_ms_p50"].get<double>(), 0.0);
  EXPECT_GE((*scene)["compute_ms_p99"].get<double>(), (*scene)["compute_ms_p50"].get<double>());
  for (const char* key : {"contacts", "rejected", "dropped_frames", "errors"})
    EXPECT_TRUE(scene->contains(key)) << key;
  // No service on another domain: exit 1, said.
  const auto none = run_program({program_from_env("TC_CLI"), "status", "--domain",
                                 std::to_string((domain_ + 1) % 233), "--duration", "0.5"},
                                30s);
  EXPECT_EQ(none.exit_code, 1) << none.out << none.err;
  EXPECT_NE(none.err.find("no tetcollided heard"), std::string::npos) << none.err;
}

TEST_F(ServiceTest, RemovedAndDisconnectedObjectsLeaveTheScene) {
  auto c = connect("remove");
  TwoBoxes s;
  ASSERT_TRUE(s.register_with(*c));
  c->remove_object("b");
  const auto e = wait_status(*c, [](const client::StatusEvent& ev) {
    return ev.kind == client::StatusEvent::Kind::kRemoved && ev.object == "b";
  });
  ASSERT_TRUE(e);
  // Frames no longer wait for b.
  const auto pa = s.pos_a(0);
  c->publish_states(0, {{"a", pa}});
  const auto forces = c->wait_forces(0, 5s);
  ASSERT_TRUE(forces && forces->frame == 0);
  EXPECT_EQ(forces->objects.size(), 1u);
  // A client that goes away takes its objects with it.
  {
    auto other = Client::connect(domain_, "remove");
    ASSERT_TRUE(other->wait_for_service(10s));
    other->register_object("c", box_mesh(1, {4, 4, 4}, {5, 5, 5}), {});
    ASSERT_TRUE(other->wait_registered("c", 10s).ok);
  }
  EXPECT_TRUE(daemon_->wait_for_log("remove/c: removed", 10s));
}

TEST_F(ServiceTest, AVerdictIsMatchedToItsOwnWrite) {
  // Client 1 registers "x" version 1 (accepted) and leaves; the status history keeps
  // that verdict. Client 2 registers "x" version 1 with an inverted mesh: it must get
  // the rejection of its own write, not the old acceptance.
  {
    auto first = connect("verdict");
    first->register_object("x", box_mesh(1, {0, 0, 0}, {1, 1, 1}), {});
    ASSERT_TRUE(first->wait_registered("x", 10s).ok);
  }
  ASSERT_TRUE(daemon_->wait_for_log("verdict/x: removed", 10s));
  auto second = connect("verdict");
  client::Mesh inverted = box_mesh(1, {0, 0, 0}, {1, 1, 1});
  std::swap(inverted.tets[0], inverted.tets[1]);
  EXPECT_EQ(second->register_object("x", inverted, {}, 1), 1u);
  const auto r = second->wait_registered("x", 10s);
  ASSERT_TRUE(r.done);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.code, static_cast<int>(StatusCode::kInvalidMesh)) << r.message;
}

TEST_F(ServiceTest, StaticObjectsAreNotWaitedFor) {
  // A daemon whose assembly wait (2 s) dwarfs any compute time, even under sanitizers:
  // an answer well within it was not held back waiting for the static object's state.
  std::string config = kConfig;
  config.replace(config.find("assembly_wait_ms: 50"), 20, "assembly_wait_ms: 2000");
  restart_daemon(config);
  auto c = connect("static");
  TwoBoxes s;
  client::ObjectParams floor;
  floor.is_static = true;
  c->register_object("floor", s.b, floor);
  c->register_object("a", s.a, {});
  ASSERT_TRUE(c->wait_registered("floor", 10s).ok);
  ASSERT_TRUE(c->wait_registered("a", 10s).ok);
  for (std::int64_t f = 0; f < 20; ++f) {
    const auto pa = s.pos_a(f);
    c->publish_states(f, {{"a", pa}});
    const auto t0 = std::chrono::steady_clock::now();
    const auto forces = c->wait_forces(f, 5s);
    ASSERT_TRUE(forces && forces->frame == f);
    // Answered without the 2 s assembly wait.
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 1000ms) << "frame " << f;
  }
}

/// A ContactForces sample as a plain reader of the topic sees it (no client filtering).
struct RawForces {
  std::string scene;
  std::string object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::int32_t status = 0;
  std::size_t nodes = 0;
  std::int64_t state_frame = 0;
  std::uint64_t answer_id = 0;
  std::size_t left_out = 0;
};

/// A bare DDS reader of every ContactForces sample of a domain, with the protocol's QoS:
/// what a client written from the IDL and PROTOCOL.md alone receives.
class RawForcesReader {
 public:
  explicit RawForcesReader(std::uint32_t domain) {
    participant_ = dds_create_participant(domain, nullptr, nullptr);
    EXPECT_GT(participant_, 0) << protocol::dds_error(participant_);
    const auto qos = protocol::topic_qos(protocol::Topic::kForces);
    const dds_entity_t topic =
        dds_create_topic(participant_, protocol::topic_descriptor(protocol::Topic::kForces),
                         protocol::topic_name(protocol::Topic::kForces), qos.get(), nullptr);
    EXPECT_GT(topic, 0) << protocol::dds_error(topic);
    reader_ = dds_create_reader(participant_, topic, qos.get(), nullptr);
    EXPECT_GT(reader_, 0) << protocol::dds_error(reader_);
  }
  ~RawForcesReader() { dds_delete(participant_); }
  RawForcesReader(const RawForcesReader&) = delete;
  RawForcesReader& operator=(const RawForcesReader&) = delete;

  /// Takes samples until one matches `pred` (all taken are kept in `seen`).
  template <typename Pred>
  std::optional<RawForces> wait(Pred pred, std::chrono::milliseconds timeout = 5s) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      for (const auto& f : seen)
        if (pred(f)) return f;
      if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
      take();
      std::this_thread::sleep_for(10ms);
    }
  }
  std::vector<RawForces> seen;

 private:
  void take() {
    std::array<void*, 64> samples{};
    std::array<dds_sample_info_t, 64> infos{};
    const dds_return_t n = dds_take(reader_, samples.data(), infos.data(), 64, 64);
    ASSERT_GE(n, 0) << protocol::dds_error(n);
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[static_cast<std::size_t>(i)].valid_data) continue;
      const auto* s =
          static_cast<const tetcollide_ContactForces*>(samples[static_cast<std::size_t>(i)]);
      seen.push_back({std::string(protocol::bounded_view(s->scene)),
                      std::string(protocol::bounded_view(s->object)), s->frame, s->topology_version,
                      s->status, s->nodes._length, s->state_frame, s->answer_id,
                      s->left_out._length});
    }
    if (n > 0) dds_return_loan(reader_, samples.data(), n);
  }
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
};

// Issue 14, point 1, the sequence an independent client found: after a cut of "box"
// (version 2, whose rest shape overlaps "body"), in a frame where box's state is stale
// (version 1, rejected) and body's is new, body used to get forces against box's rest
// positions. Now box is left out of contact until its first version-2 state, and every
// OK answer names it in left_out.
TEST_F(ServiceTest, ACutObjectIsLeftOutUntilItsFirstStateOfTheNewVersion) {
  RawForcesReader raw(domain_);  // box's answers in frames it sent no state in
  auto c = connect("left-out");
  const client::Mesh body = box_mesh(3, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  const client::Mesh box1 = box_mesh(2, {-0.3, -0.3, -0.3}, {0.7, 0.7, 0.7});
  c->register_object("body", body, {});
  c->register_object("box", box1, {});
  ASSERT_TRUE(c->wait_registered("body", 10s).ok);
  ASSERT_TRUE(c->wait_registered("box", 10s).ok);
  const auto body_pos = translated(body, {0, 0, 0});
  const auto box1_far = translated(box1, {5, 0, 0});
  const auto frame = [&](std::int64_t f, const std::vector<client::ObjectState>& states) {
    c->publish_states(f, states);
    auto forces = c->wait_forces(f, 5s);
    EXPECT_TRUE(forces && forces->frame == f) << "frame " << f;
    return forces;
  };
  // Frame 0: box far from body; nobody has contact, nobody is left out.
  auto f0 = frame(0, {{"body", body_pos}, {"box", box1_far}});
  ASSERT_TRUE(f0 && f0->ok());
  EXPECT_TRUE(f0->find("body")->nodes.empty());
  EXPECT_TRUE(f0->find("body")->left_out.empty());

  // The cut: version 2 of box, its rest shape right inside body.
  const client::Mesh box2 = box_mesh(1, {-0.3, -0.3, -0.3}, {0.3, 0.3, 0.3});
  ASSERT_EQ(c->register_object("box", box2, {}), 2u);
  ASSERT_TRUE(c->wait_registered("box", 10s).ok);

  // Frame 1: box's state is stale (version 1), body's is new.
  client::ObjectState stale{"box", box1_far};
  stale.topology_version = 1;
  auto f1 = frame(1, {{"body", body_pos}, stale});
  ASSERT_TRUE(f1);
  const auto* box_answer = f1->find("box");
  ASSERT_NE(box_answer, nullptr);
  EXPECT_EQ(box_answer->status, static_cast<int>(StatusCode::kStaleVersion));
  EXPECT_EQ(box_answer->topology_version, 2u) << "a rejected answer names the held version";
  EXPECT_EQ(box_answer->answer_id, 0u);
  EXPECT_EQ(box_answer->state_frame, 1);
  EXPECT_TRUE(box_answer->left_out.empty());
  const auto* body_answer = f1->find("body");
  ASSERT_NE(body_answer, nullptr);
  EXPECT_EQ(body_answer->status, 0);
  EXPECT_TRUE(body_answer->nodes.empty())
      << "body got forces on " << body_answer->nodes.size()
      << " nodes against box's rest positions, which the client never sent";
  EXPECT_EQ(body_answer->left_out, std::vector<std::string>{"box"});
  EXPECT_NE(body_answer->answer_id, 0u);

  // Frame 2: no state of box at all (the frame runs after the assembly wait): still out.
  auto f2 = frame(2, {{"body", body_pos}});
  ASSERT_TRUE(f2 && f2->ok());
  EXPECT_TRUE(f2->find("body")->nodes.empty());
  EXPECT_EQ(f2->find("body")->left_out, std::vector<std::string>{"box"});
  // The client waits only for the objects it sent states for: box's answer comes apart.
  const auto box2_answer = raw.wait([](const RawForces& f) {
    return f.scene == "left-out" && f.object == "box" && f.frame == 2;
  });
  ASSERT_TRUE(box2_answer);
  EXPECT_EQ(box2_answer->status, 0);
  EXPECT_EQ(box2_answer->state_frame, -1);
  EXPECT_EQ(box2_answer->topology_version, 2u);
  EXPECT_EQ(box2_answer->nodes, 0u);
  EXPECT_EQ(box2_answer->left_out, 1u);
  EXPECT_EQ(box2_answer->answer_id, f2->find("body")->answer_id);

  // Frame 3: box's first version-2 state, far away: it is back, and far.
  const auto box2_far = translated(box2, {5, 0, 0});
  auto f3 = frame(3, {{"body", body_pos}, {"box", box2_far}});
  ASSERT_TRUE(f3 && f3->ok());
  EXPECT_TRUE(f3->find("body")->left_out.empty());
  EXPECT_TRUE(f3->find("body")->nodes.empty());
  EXPECT_EQ(f3->find("box")->state_frame, 3);

  // Frame 4: box where its rest shape is, inside body: now both get forces.
  const auto box2_in = translated(box2, {0, 0, 0});
  auto f4 = frame(4, {{"body", body_pos}, {"box", box2_in}});
  ASSERT_TRUE(f4 && f4->ok());
  EXPECT_FALSE(f4->find("body")->nodes.empty());
  EXPECT_FALSE(f4->find("box")->nodes.empty());
  EXPECT_TRUE(f4->find("body")->left_out.empty());
}

// Issue 14, point 4: what PROTOCOL.md now says a second implementation had to guess.
// Rejected answers look alike whatever the rejection (topology_version = the version the
// service holds, 0 when none; answer_id 0; state_frame = frame; no arrays); a plain
// ContactForces reader gets every scene's answers (a client filters by scene); a
// zero-initialized parameter set is rejected (stiffness 0); node indices are indices
// into the topology's arrays, whatever the node ids.
TEST_F(ServiceTest, RejectedAnswersAreAlikeAndEveryReaderSeesEveryScene) {
  RawForcesReader raw(domain_);
  auto c = connect("rejects");
  TwoBoxes s;
  client::Mesh a = s.a;
  a.node_ids.clear();
  for (std::size_t i = 0; i < a.rest_positions.size() / 3; ++i)
    a.node_ids.push_back(1'000'000 + 7 * static_cast<std::int64_t>(i));
  c->register_object("a", a, {});
  c->register_object("b", s.b, {});
  ASSERT_TRUE(c->wait_registered("a", 10s).ok);
  ASSERT_TRUE(c->wait_registered("b", 10s).ok);
  client::ObjectParams zero;
  zero.stiffness = 0.0;
  zero.response = client::ResponseKind::kPoint;
  c->register_object("zero", box_mesh(1, {5, 5, 5}, {6, 6, 6}), zero);
  const auto z = c->wait_registered("zero", 10s);
  ASSERT_TRUE(z.done);
  EXPECT_EQ(z.code, static_cast<int>(StatusCode::kInvalidArgument)) << z.message;

  auto nan_positions = s.pos_b(0);
  nan_positions[7] = std::nan("");
  auto short_positions = s.pos_b(0);
  short_positions.resize(short_positions.size() - 3);
  struct Case {
    const char* what;
    std::vector<double> positions;
    std::uint32_t version;
    StatusCode code;
  };
  const std::vector<Case> cases = {
      {"stale version", s.pos_b(0), 77, StatusCode::kStaleVersion},
      {"NaN", nan_positions, 0, StatusCode::kInvalidMesh},
      {"wrong length", short_positions, 0, StatusCode::kInvalidArgument}};
  std::int64_t frame = 0;
  for (const auto& bad : cases) {
    SCOPED_TRACE(bad.what);
    ++frame;
    const auto pa = s.pos_a(frame);
    client::ObjectState sb{"b", bad.positions};
    sb.topology_version = bad.version;
    c->publish_states(frame, {{"a", pa}, sb});
    ASSERT_TRUE(c->wait_forces(frame, 5s));
    const auto rb = raw.wait([&](const RawForces& f) {
      return f.scene == "rejects" && f.object == "b" && f.frame == frame;
    });
    ASSERT_TRUE(rb);
    EXPECT_EQ(rb->status, static_cast<int>(bad.code));
    EXPECT_EQ(rb->topology_version, 1u);
    EXPECT_EQ(rb->answer_id, 0u);
    EXPECT_EQ(rb->state_frame, frame);
    EXPECT_EQ(rb->nodes, 0u);
    EXPECT_EQ(rb->left_out, 0u);
    const auto ra = raw.wait([&](const RawForces& f) {
      return f.scene == "rejects" && f.object == "a" && f.frame == frame;
    });
    ASSERT_TRUE(ra);
    EXPECT_EQ(ra->status, 0);
    EXPECT_NE(ra->answer_id, 0u);
  }
  // A state for an object the service does not hold: answered after the grace, outside
  // any computation, alike.
  ++frame;
  const auto pa = s.pos_a(frame);
  const auto pb = s.pos_b(frame);
  c->publish_states(frame, {{"a", pa}, {"b", pb}, {"ghost", pb}});
  const auto answered = c->wait_forces(frame, 5s);
  ASSERT_TRUE(answered && answered->ok());
  const auto ghost = raw.wait([&](const RawForces& f) { return f.object == "ghost"; });
  ASSERT_TRUE(ghost);
  EXPECT_EQ(ghost->status, static_cast<int>(StatusCode::kUnknownObject));
  EXPECT_EQ(ghost->topology_version, 0u);
  EXPECT_EQ(ghost->answer_id, 0u);
  EXPECT_EQ(ghost->state_frame, frame);
  // Node indices: 0-based into the arrays, whatever the ids.
  bool any = false;
  for (const auto& o : answered->objects) {
    any = any || !o.nodes.empty();
    for (const auto n : o.nodes) {
      EXPECT_GE(n, 0);
      EXPECT_LT(static_cast<std::size_t>(n), a.rest_positions.size() / 3);
    }
  }
  EXPECT_TRUE(any) << "the overlapping boxes got no force";

  // Another simulator's scene: its answers reach this plain reader too.
  auto other = connect("someone-else");
  other->register_object("x", s.a, {});
  ASSERT_TRUE(other->wait_registered("x", 10s).ok);
  const auto px = s.pos_a(0);
  other->publish_states(0, {{"x", px}});
  ASSERT_TRUE(other->wait_forces(0, 5s));
  EXPECT_TRUE(raw.wait([](const RawForces& f) { return f.scene == "someone-else"; }));
}

// Issue 14, point 3: every MeshTopology write gets a verdict matched to it, a re-sent
// version too ("Life of a client", step 3, waits for it).
TEST_F(ServiceTest, ReSendingTheSameVersionGetsAVerdict) {
  auto c = connect("resend");
  const client::Mesh x = box_mesh(1, {0, 0, 0}, {1, 1, 1});
  ASSERT_EQ(c->register_object("x", x, {}), 1u);
  ASSERT_TRUE(c->wait_registered("x", 10s).ok);
  // The same version and content again: REGISTERED again, not rebuilt.
  ASSERT_EQ(c->register_object("x", x, {}, 1), 1u);
  const auto again = c->wait_registered("x", 10s);
  ASSERT_TRUE(again.done) << "no verdict on a re-sent version";
  EXPECT_TRUE(again.ok) << again.message;
  EXPECT_NE(again.message.find("unchanged"), std::string::npos) << again.message;
  // Sent right after the first write (verdict still pending): both get their verdict.
  const client::Mesh y = box_mesh(2, {3, 0, 0}, {4, 1, 1});
  ASSERT_EQ(c->register_object("y", y, {}), 1u);
  ASSERT_EQ(c->register_object("y", y, {}, 1), 1u);
  const auto y_again = c->wait_registered("y", 10s);
  ASSERT_TRUE(y_again.done);
  EXPECT_TRUE(y_again.ok) << y_again.message;
  // The same version with another content: an error, the registered version stays.
  client::ObjectParams stiffer;
  stiffer.stiffness = 2e4;
  ASSERT_EQ(c->register_object("x", x, stiffer, 1), 1u);
  const auto changed = c->wait_registered("x", 10s);
  ASSERT_TRUE(changed.done);
  EXPECT_FALSE(changed.ok);
  EXPECT_EQ(changed.code, static_cast<int>(StatusCode::kInvalidArgument)) << changed.message;
  EXPECT_NE(changed.message.find("different content"), std::string::npos) << changed.message;
  // A rejected version re-sent unchanged is rejected again, with its reason (whether the
  // re-send arrives while the first build runs or after it failed).
  client::Mesh inverted = box_mesh(1, {6, 0, 0}, {7, 1, 1});
  std::swap(inverted.tets[0], inverted.tets[1]);
  ASSERT_EQ(c->register_object("z", inverted, {}), 1u);
  ASSERT_EQ(c->register_object("z", inverted, {}, 1), 1u);
  const auto bad = c->wait_registered("z", 10s);
  ASSERT_TRUE(bad.done);
  EXPECT_FALSE(bad.ok);
  EXPECT_EQ(bad.code, static_cast<int>(StatusCode::kInvalidMesh)) << bad.message;
  // x's version 1 is still what the scene holds.
  const auto px = translated(x, {0, 0, 0});
  const auto py = translated(y, {0, 0, 0});
  c->publish_states(0, {{"x", px}, {"y", py}});
  const auto forces = c->wait_forces(0, 5s);
  ASSERT_TRUE(forces && forces->frame == 0);
  ASSERT_NE(forces->find("x"), nullptr);
  EXPECT_EQ(forces->find("x")->status, 0);
  EXPECT_EQ(forces->find("x")->topology_version, 1u);
}

// Issue 14, point 2: PROTOCOL.md promises a late ServiceStatus reader the service's
// newest 32 samples (transient-local, KEEP_LAST 32); a writer without a matching
// durability_service depth gave it only the newest one.
TEST_F(ServiceTest, ALateStatusReaderGetsTheNewest32Samples) {
  // Heartbeats every hour: the samples written during the test are the test's own.
  std::string config = kConfig;
  config.replace(config.find("status_period_s: 0.2"), 20, "status_period_s: 3600");
  restart_daemon(config);
  const auto late_reader = [&](std::size_t expect) {
    auto late = connect("history-reader");
    std::vector<client::StatusEvent> events;
    const auto deadline = std::chrono::steady_clock::now() + 5s;
    while (events.size() < expect && std::chrono::steady_clock::now() < deadline) {
      for (auto& e : late->take_status_events()) events.push_back(std::move(e));
      late->poll(20ms);
    }
    late->poll(300ms);  // nothing beyond the history arrives
    for (auto& e : late->take_status_events()) events.push_back(std::move(e));
    return events;
  };
  {
    auto c = connect("history");
    for (const char* o : {"a", "b", "c"}) {
      c->register_object(o, box_mesh(1, {0, 0, 0}, {1, 1, 1}), {});
      ASSERT_TRUE(c->wait_registered(o, 10s).ok) << o;
    }
    client::Mesh inverted = box_mesh(1, {0, 0, 0}, {1, 1, 1});
    std::swap(inverted.tets[0], inverted.tets[1]);
    c->register_object("bad", inverted, {});
    ASSERT_FALSE(c->wait_registered("bad", 10s).ok);
    // Keep c (and its objects) until the late reader looked: no removals yet.
    const auto events = late_reader(6);
    // STARTING, READY, 3 registrations, 1 error: everything the service wrote.
    ASSERT_EQ(events.size(), 6u);
    for (std::size_t i = 1; i < events.size(); ++i)
      EXPECT_EQ(events[i].sequence_number, events[i - 1].sequence_number + 1);
    EXPECT_EQ(events[1].kind, client::StatusEvent::Kind::kStateChange);
    EXPECT_EQ(events[1].state, client::StatusEvent::State::kReady);
    std::set<std::string> registered;
    for (const auto& e : events)
      if (e.kind == client::StatusEvent::Kind::kRegistered) registered.insert(e.object);
    EXPECT_EQ(registered, (std::set<std::string>{"a", "b", "c"}));
    EXPECT_EQ(events.back().kind, client::StatusEvent::Kind::kError);
    EXPECT_EQ(events.back().object, "bad");
  }
  // c's objects leave with it (3 REMOVED samples would otherwise interleave below).
  for (const std::string line : {"history/a: removed", "history/b: removed", "history/c: removed"})
    ASSERT_TRUE(daemon_->wait_for_log(line, 10s)) << line;
  // More than 32 samples: a late reader gets exactly the newest 32, in order.
  auto c = connect("history-2");
  const client::Mesh m = box_mesh(1, {0, 0, 0}, {1, 1, 1});
  for (int i = 0; i < 40; ++i) {
    const std::string o = std::string("o").append(std::to_string(i));
    c->register_object(o, m, {});
    ASSERT_TRUE(c->wait_registered(o, 10s).ok) << o;
  }
  const auto events = late_reader(32);
  ASSERT_EQ(events.size(), 32u);
  for (std::size_t i = 1; i < events.size(); ++i)
    EXPECT_EQ(events[i].sequence_number, events[i - 1].sequence_number + 1);
  EXPECT_EQ(events.back().kind, client::StatusEvent::Kind::kRegistered);
  EXPECT_EQ(events.back().object, "o39");
  EXPECT_EQ(events.back().state, client::StatusEvent::State::kReady);
}

}  // namespace
}  // namespace tc::itest

namespace tc::itest {
namespace {

// The daemon's command line: usage errors exit 2, bad configuration exits 3 with the
// file, line and column; neither starts DDS.
TEST(DaemonCommandLine, UsageAndConfigurationErrors) {
  using namespace std::chrono_literals;
  const std::string daemon = program_from_env("TC_DAEMON");
  const auto dir = make_temp_dir("itest-cli");
  const auto bad = dir / "bad.yaml";
  std::ofstream(bad) << "version: 1\nframes:\n  assembly_wait_ms: -5\n";
  auto r = run_program({daemon, "--config", bad.string()}, 20s);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("bad.yaml:3:21: 'frames.assembly_wait_ms' must be in"), std::string::npos)
      << r.err;
  const auto unknown = dir / "unknown.yaml";
  std::ofstream(unknown) << "version: 1\nlog:\n  colour: red\n";
  r = run_program({daemon, "--config", unknown.string()}, 20s);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("unknown.yaml:3:3: unknown key 'log.colour'"), std::string::npos) << r.err;
  r = run_program({daemon, "--domain", "999"}, 20s);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_program({daemon, "--config", (dir / "missing.yaml").string()}, 20s);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_program({daemon, "--log-level", "loud"}, 20s);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  r = run_program({daemon, "--version"}, 20s);
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("tetcollided " TC_VERSION), std::string::npos) << r.out;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest

namespace tc::itest {
namespace {

// Several daemons share one domain: scene patterns split the scenes between them and a
// partition separates a third; each scene is served by exactly one daemon.
TEST(SharedLoad, ScenePatternsAndPartitionsSplitTheScenes) {
  using namespace std::chrono_literals;
  const std::uint32_t domain = private_domain();
  const auto dir = make_temp_dir("itest-shared");
  const auto make_dir = [&](const char* name) {
    std::filesystem::create_directories(dir / name);
    return dir / name;
  };
  DaemonProcess a(make_dir("a"), domain,
                  "version: 1\ndds:\n  service_id: svc-a\n  scenes: [\"a-*\"]\n");
  DaemonProcess b(make_dir("b"), domain,
                  "version: 1\ndds:\n  service_id: svc-b\n  scenes: [\"b-*\"]\n");
  DaemonProcess lab(make_dir("lab"), domain,
                    "version: 1\ndds:\n  service_id: svc-lab\n  partition: lab\n");
  ASSERT_TRUE(a.start()) << a.log_text();
  ASSERT_TRUE(b.start()) << b.log_text();
  ASSERT_TRUE(lab.start()) << lab.log_text();

  const auto serve = [&](const std::string& scene, const std::string& partition) {
    client::Options o;
    o.domain = domain;
    o.scene = scene;
    o.partition = partition;
    auto c = client::Client::connect(o);
    EXPECT_TRUE(c->wait_for_service(10s));
    c->register_object("box", box_mesh(1, {0, 0, 0}, {1, 1, 1}), {});
    const auto r = c->wait_registered("box", partition.empty() && scene[0] == 'c' ? 1s : 10s);
    std::set<std::string> registrars;
    for (const auto& e : c->take_status_events())
      if (e.kind == client::StatusEvent::Kind::kRegistered && e.scene == scene)
        registrars.insert(e.service_id);
    return std::make_pair(r.ok, registrars);
  };
  const auto [a_ok, a_by] = serve("a-1", "");
  EXPECT_TRUE(a_ok);
  EXPECT_EQ(a_by, (std::set<std::string>{"svc-a"}));
  const auto [b_ok, b_by] = serve("b-7", "");
  EXPECT_TRUE(b_ok);
  EXPECT_EQ(b_by, (std::set<std::string>{"svc-b"}));
  const auto [lab_ok, lab_by] = serve("c-1", "lab");
  EXPECT_TRUE(lab_ok);
  EXPECT_EQ(lab_by, (std::set<std::string>{"svc-lab"}));
  const auto [c_ok, c_by] = serve("c-1", "");  // no daemon serves c-* in the default partition
  EXPECT_FALSE(c_ok);
  EXPECT_TRUE(c_by.empty());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace tc::itest
