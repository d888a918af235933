// service/daemon/samples: every kind of bad topic sample is rejected with the right code
// and a message naming the object and index; good samples convert exactly.
#include "samples.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

#include "protocol.hpp"
#include "test_meshes.hpp"

namespace tc::daemon {
namespace {

/// A topology sample's storage with a view over it.
struct TopologyData {
  std::string scene = "scene";
  std::string object = "box";
  std::uint32_t version = 1;
  std::vector<std::int64_t> node_ids;
  std::vector<double> rest;
  std::vector<std::int32_t> tets;
  std::vector<std::int32_t> triangles;
  WireParams params{1e4, 0.0, 0.0, false, tetcollide_DEPTH_CPFM, tetcollide_RESPONSE_AUTO};

  explicit TopologyData(const TetMesh& m) {
    node_ids = m.node_ids;
    rest.assign(m.positions.data(), m.positions.data() + m.positions.size());
    for (const Tet& t : m.tets) tets.insert(tets.end(), t.begin(), t.end());
  }
  explicit TopologyData(const SurfaceMesh& m) {
    node_ids = m.node_ids;
    rest.assign(m.positions.data(), m.positions.data() + m.positions.size());
    for (const Triangle& t : m.triangles) triangles.insert(triangles.end(), t.begin(), t.end());
  }
  [[nodiscard]] TopologyView view() const {
    return TopologyView{scene, object, version, node_ids, rest, tets, params, 0, triangles};
  }
};

struct StateData {
  std::string scene = "scene";
  std::string object = "box";
  std::int64_t frame = 7;
  std::uint32_t version = 1;
  std::vector<double> positions;
  std::vector<double> velocities;
  [[nodiscard]] StateView view() const {
    return StateView{scene, object, frame, version, positions, velocities};
  }
};

const double kNan = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

TEST(Samples, GoodTopologyConverts) {
  const TetMesh m =
      test::structured_box(2, 2, 2, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 2, 3));
  const TopologyData d(m);
  ASSERT_TRUE(validate_topology(d.view(), Limits{}));
  const TetMesh back = std::get<TetMesh>(to_mesh(d.view()));
  EXPECT_EQ(back.node_ids, m.node_ids);
  EXPECT_EQ(back.tets, m.tets);
  EXPECT_EQ(back.positions, m.positions);  // bit for bit
}

TEST(Samples, MissingNodeIdsBecomeOneBased) {
  TopologyData d(test::single_tet());
  d.node_ids.clear();
  ASSERT_TRUE(validate_topology(d.view(), Limits{}));
  EXPECT_EQ(std::get<TetMesh>(to_mesh(d.view())).node_ids, (std::vector<std::int64_t>{1, 2, 3, 4}));
}

TEST(Samples, ParamsConvert) {
  WireParams w{5.0, 0.5, 2.0, true, tetcollide_DEPTH_EXACT, tetcollide_RESPONSE_SEGMENT};
  const ObjectParams p = to_params(w);
  EXPECT_EQ(p.stiffness, 5.0);
  EXPECT_EQ(p.damping, 0.5);
  EXPECT_EQ(p.max_force, 2.0);
  EXPECT_TRUE(p.is_static);
  EXPECT_EQ(p.depth, DepthMethod::kExact);
  EXPECT_EQ(p.response, ResponseKind::kSegment);
  w.depth = tetcollide_DEPTH_CFFM;
  w.response = tetcollide_RESPONSE_POINT;
  EXPECT_EQ(to_params(w).depth, DepthMethod::kCffm);
  EXPECT_EQ(to_params(w).response, ResponseKind::kPoint);
  // Protocol 3's parameters; a version-2 sample has them at 0 / false.
  EXPECT_EQ(p.friction, 0.0);
  EXPECT_FALSE(p.blocks || p.contacts || p.self_contact);
  w.friction = 0.4;
  w.friction_velocity = 2e-3;
  w.blocks = true;
  w.contacts = true;
  w.self_contact = true;
  const ObjectParams q = to_params(w);
  EXPECT_EQ(q.friction, 0.4);
  EXPECT_EQ(q.friction_velocity, 2e-3);
  EXPECT_TRUE(q.blocks);
  EXPECT_TRUE(q.contacts);
  EXPECT_TRUE(q.self_contact);
}

struct TopologyCase {
  const char* name;
  std::function<void(TopologyData&, Limits&)> spoil;
  ErrorCode code;
  const char* mentions;
  bool surface = false;  ///< spoil the cube surface (8 nodes, 12 triangles), not 5 tets
};

class BadTopology : public ::testing::TestWithParam<TopologyCase> {};

TEST_P(BadTopology, IsRejected) {
  TopologyData d = GetParam().surface ? TopologyData(test::cube_surface())
                                      : TopologyData(test::cube_five_tets());
  Limits limits;
  GetParam().spoil(d, limits);
  const Status st = validate_topology(d.view(), limits);
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, GetParam().code) << st.error().message;
  EXPECT_NE(st.error().message.find(GetParam().mentions), std::string::npos) << st.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BadTopology,
    ::testing::Values(
        TopologyCase{"empty_scene", [](TopologyData& d, Limits&) { d.scene.clear(); },
                     ErrorCode::kInvalidArgument, "empty scene"},
        TopologyCase{"control_char", [](TopologyData& d, Limits&) { d.object = "a\nb"; },
                     ErrorCode::kInvalidArgument, "control character at byte 1"},
        TopologyCase{"long_object",
                     [](TopologyData& d, Limits&) { d.object = std::string(129, 'x'); },
                     ErrorCode::kInvalidArgument, "longer than 128"},
        TopologyCase{"version_zero", [](TopologyData& d, Limits&) { d.version = 0; },
                     ErrorCode::kInvalidArgument, "version must be > 0"},
        TopologyCase{"too_many_nodes", [](TopologyData&, Limits& l) { l.max_nodes = 7; },
                     ErrorCode::kOversized, "limits.max_nodes"},
        TopologyCase{"too_many_tets", [](TopologyData&, Limits& l) { l.max_tets = 4; },
                     ErrorCode::kOversized, "limits.max_tets"},
        TopologyCase{"coords_not_triple", [](TopologyData& d, Limits&) { d.rest.pop_back(); },
                     ErrorCode::kInvalidArgument, "not a multiple of 3"},
        TopologyCase{"tets_not_quad", [](TopologyData& d, Limits&) { d.tets.pop_back(); },
                     ErrorCode::kInvalidArgument, "not a multiple of 4"},
        TopologyCase{"no_tets", [](TopologyData& d, Limits&) { d.tets.clear(); },
                     ErrorCode::kInvalidArgument, "at least 4 nodes and 1 tet"},
        TopologyCase{"ids_length", [](TopologyData& d, Limits&) { d.node_ids.pop_back(); },
                     ErrorCode::kInvalidArgument, "node_ids has 7 entries for 8 nodes"},
        TopologyCase{"index_high", [](TopologyData& d, Limits&) { d.tets[9] = 8; },
                     ErrorCode::kInvalidMesh, "tet 2 has node index 8 outside [0, 8)"},
        TopologyCase{"index_negative", [](TopologyData& d, Limits&) { d.tets[0] = -1; },
                     ErrorCode::kInvalidMesh, "tet 0 has node index -1"},
        TopologyCase{"repeated", [](TopologyData& d, Limits&) { d.tets[5] = d.tets[4]; },
                     ErrorCode::kInvalidMesh, "tet 1 uses node"},
        TopologyCase{"nan_rest", [](TopologyData& d, Limits&) { d.rest[3 * 5 + 1] = kNan; },
                     ErrorCode::kInvalidMesh, "node 5 has a non-finite rest coordinate"},
        TopologyCase{"inf_rest", [](TopologyData& d, Limits&) { d.rest[0] = -kInf; },
                     ErrorCode::kInvalidMesh, "node 0"},
        TopologyCase{"stiffness_zero", [](TopologyData& d, Limits&) { d.params.stiffness = 0; },
                     ErrorCode::kInvalidArgument, "params.stiffness"},
        TopologyCase{"stiffness_nan", [](TopologyData& d, Limits&) { d.params.stiffness = kNan; },
                     ErrorCode::kInvalidArgument, "params.stiffness"},
        TopologyCase{"damping_neg", [](TopologyData& d, Limits&) { d.params.damping = -1; },
                     ErrorCode::kInvalidArgument, "params.damping"},
        TopologyCase{"max_force_inf", [](TopologyData& d, Limits&) { d.params.max_force = kInf; },
                     ErrorCode::kInvalidArgument, "params.max_force"},
        TopologyCase{"depth_enum", [](TopologyData& d, Limits&) { d.params.depth = 3; },
                     ErrorCode::kInvalidArgument, "params.depth 3"},
        TopologyCase{"response_enum", [](TopologyData& d, Limits&) { d.params.response = -1; },
                     ErrorCode::kInvalidArgument, "params.response -1"},
        TopologyCase{"friction_neg", [](TopologyData& d, Limits&) { d.params.friction = -0.1; },
                     ErrorCode::kInvalidArgument, "params.friction must be"},
        TopologyCase{"friction_nan", [](TopologyData& d, Limits&) { d.params.friction = kNan; },
                     ErrorCode::kInvalidArgument, "params.friction must be"},
        TopologyCase{"friction_velocity_inf",
                     [](TopologyData& d, Limits&) { d.params.friction_velocity = kInf; },
                     ErrorCode::kInvalidArgument, "params.friction_velocity"}),
    [](const ::testing::TestParamInfo<TopologyCase>& p) { return std::string(p.param.name); });

TEST(Samples, GoodSurfaceConverts) {
  const SurfaceMesh m = test::cube_surface(0.5, Eigen::Vector3d(1, 2, 3));
  const TopologyData d(m);
  const Status st = validate_topology(d.view(), Limits{});
  ASSERT_TRUE(st) << st.error().message;
  const ObjectMesh back = to_mesh(d.view());
  ASSERT_TRUE(std::holds_alternative<SurfaceMesh>(back));
  const SurfaceMesh& s = std::get<SurfaceMesh>(back);
  EXPECT_EQ(s.triangles, m.triangles);
  EXPECT_EQ(s.positions, m.positions);  // bit for bit
  EXPECT_EQ(s.node_ids, (std::vector<std::int64_t>{1, 2, 3, 4, 5, 6, 7, 8}));
}

INSTANTIATE_TEST_SUITE_P(
    Surfaces, BadTopology,
    ::testing::Values(
        TopologyCase{"too_many_triangles", [](TopologyData&, Limits& l) { l.max_tets = 11; },
                     ErrorCode::kOversized, "12 triangles exceed limits.max_tets = 11", true},
        TopologyCase{"not_triple", [](TopologyData& d, Limits&) { d.triangles.pop_back(); },
                     ErrorCode::kInvalidArgument, "triangles has 35 indices, not a multiple of 3",
                     true},
        TopologyCase{"tets_and_triangles",
                     [](TopologyData& d, Limits&) {
                       d.tets = {0, 1, 2, 4};
                     },
                     ErrorCode::kInvalidArgument, "tets or triangles (a surface), not both", true},
        TopologyCase{"two_nodes",
                     [](TopologyData& d, Limits&) {
                       d.rest.resize(6);
                       d.node_ids.resize(2);
                       d.triangles = {0, 1, 0};
                     },
                     ErrorCode::kInvalidArgument, "a surface needs at least 3 nodes, got 2", true},
        TopologyCase{"index_high", [](TopologyData& d, Limits&) { d.triangles[7] = 8; },
                     ErrorCode::kInvalidMesh, "triangle 2 has node index 8 outside [0, 8)", true},
        TopologyCase{"index_negative", [](TopologyData& d, Limits&) { d.triangles[0] = -3; },
                     ErrorCode::kInvalidMesh, "triangle 0 has node index -3", true},
        TopologyCase{"repeated", [](TopologyData& d, Limits&) { d.triangles[5] = d.triangles[4]; },
                     ErrorCode::kInvalidMesh, "triangle 1 uses node", true},
        TopologyCase{"nan_rest", [](TopologyData& d, Limits&) { d.rest[3 * 6 + 2] = kNan; },
                     ErrorCode::kInvalidMesh, "node 6 has a non-finite rest coordinate", true}),
    [](const ::testing::TestParamInfo<TopologyCase>& p) { return std::string(p.param.name); });

TEST(Samples, MessagesNameSceneAndObject) {
  TopologyData d(test::single_tet());
  d.scene = "s1";
  d.object = "liver";
  d.tets[2] = 9;
  const Status st = validate_topology(d.view(), Limits{});
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().message.rfind("s1/liver: ", 0), 0u) << st.error().message;
}

TEST(Samples, SizeIsCheckedBeforeContent) {
  // An oversized sample full of garbage is reported as oversized: the limit check comes
  // before any scan of its content.
  TopologyData d(test::cube_six_tets());
  d.rest.assign(3 * 100, kNan);
  d.tets.assign(4 * 3, -5);
  Limits l;
  l.max_nodes = 50;
  const Status st = validate_topology(d.view(), l);
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, ErrorCode::kOversized);
}

StateData good_state(Index nodes) {
  StateData s;
  s.positions.assign(3 * static_cast<std::size_t>(nodes), 0.25);
  return s;
}

TEST(Samples, GoodStateConverts) {
  StateData s = good_state(4);
  for (std::size_t i = 0; i < s.positions.size(); ++i)
    s.positions[i] = 0.1 * static_cast<double>(i);
  ASSERT_TRUE(validate_state(s.view(), Limits{}, 4));
  const Positions p = to_positions(s.positions);
  ASSERT_EQ(p.cols(), 4);
  EXPECT_EQ(p(0, 1), s.positions[3]);
  EXPECT_EQ(p(2, 3), s.positions[11]);
  s.velocities.assign(12, 1.0);
  EXPECT_TRUE(validate_state(s.view(), Limits{}, 4));
}

struct StateCase {
  const char* name;
  std::function<void(StateData&, Limits&)> spoil;
  ErrorCode code;
  const char* mentions;
};

class BadState : public ::testing::TestWithParam<StateCase> {};

TEST_P(BadState, IsRejected) {
  StateData s = good_state(8);
  Limits limits;
  GetParam().spoil(s, limits);
  const Status st = validate_state(s.view(), limits, 8);
  ASSERT_FALSE(st);
  EXPECT_EQ(st.error().code, GetParam().code) << st.error().message;
  EXPECT_NE(st.error().message.find(GetParam().mentions), std::string::npos) << st.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BadState,
    ::testing::Values(StateCase{"empty_object", [](StateData& s, Limits&) { s.object.clear(); },
                                ErrorCode::kInvalidArgument, "empty object"},
                      StateCase{"negative_frame", [](StateData& s, Limits&) { s.frame = -3; },
                                ErrorCode::kInvalidArgument, "frame -3"},
                      StateCase{"oversized", [](StateData&, Limits& l) { l.max_nodes = 5; },
                                ErrorCode::kOversized, "limits.max_nodes"},
                      StateCase{"short", [](StateData& s, Limits&) { s.positions.resize(21); },
                                ErrorCode::kInvalidArgument, "positions has 21 values"},
                      StateCase{"not_triple", [](StateData& s, Limits&) { s.positions.resize(23); },
                                ErrorCode::kInvalidArgument, "not a multiple of 3"},
                      StateCase{"long", [](StateData& s, Limits&) { s.positions.resize(27, 0.0); },
                                ErrorCode::kInvalidArgument, "has 8 nodes (24 values)"},
                      StateCase{"velocity_length",
                                [](StateData& s, Limits&) { s.velocities.assign(3, 0.0); },
                                ErrorCode::kInvalidArgument, "velocities has 3 values"},
                      StateCase{"nan", [](StateData& s, Limits&) { s.positions[3 * 6 + 2] = kNan; },
                                ErrorCode::kInvalidMesh, "node 6 has a non-finite position"},
                      StateCase{"inf", [](StateData& s, Limits&) { s.positions[0] = kInf; },
                                ErrorCode::kInvalidMesh, "node 0 has a non-finite position"},
                      StateCase{"nan_velocity",
                                [](StateData& s, Limits&) {
                                  s.velocities.assign(24, 0.0);
                                  s.velocities[13] = kNan;
                                },
                                ErrorCode::kInvalidMesh, "node 4 has a non-finite velocity"}),
    [](const ::testing::TestParamInfo<StateCase>& p) { return std::string(p.param.name); });

TEST(Samples, StatusCodesAreTheProtocolTable) {
  EXPECT_EQ(status_code(ErrorCode::kIo), 1);
  EXPECT_EQ(status_code(ErrorCode::kParse), 2);
  EXPECT_EQ(status_code(ErrorCode::kUnsupported), 3);
  EXPECT_EQ(status_code(ErrorCode::kInvalidMesh), 4);
  EXPECT_EQ(status_code(ErrorCode::kInvalidArgument), 5);
  EXPECT_EQ(status_code(ErrorCode::kUnknownObject), 6);
  EXPECT_EQ(status_code(ErrorCode::kStaleVersion), 7);
  EXPECT_EQ(status_code(ErrorCode::kOversized), 8);
  // Names match the core's names for the same codes.
  for (ErrorCode c : {ErrorCode::kIo, ErrorCode::kParse, ErrorCode::kUnsupported,
                      ErrorCode::kInvalidMesh, ErrorCode::kInvalidArgument,
                      ErrorCode::kUnknownObject, ErrorCode::kStaleVersion, ErrorCode::kOversized})
    EXPECT_EQ(protocol::status_name(status_code(c)), error_code_name(c));
  EXPECT_EQ(protocol::status_name(0), "ok");
  EXPECT_EQ(protocol::status_name(9), "internal");
  EXPECT_EQ(protocol::status_name(99), "unknown");
}

TEST(Samples, BoundedStrings) {
  char field[5];
  EXPECT_TRUE(protocol::copy_bounded(field, "abcd"));
  EXPECT_EQ(protocol::bounded_view(field), "abcd");
  EXPECT_FALSE(protocol::copy_bounded(field, "abcde"));
  EXPECT_EQ(protocol::bounded_view(field), "");
  EXPECT_FALSE(protocol::copy_bounded(field, std::string_view("a\0b", 3)));
  const char unterminated[4] = {'w', 'x', 'y', 'z'};
  EXPECT_EQ(protocol::bounded_view(unterminated), "wxyz");
}

TEST(Samples, ViewOfGeneratedSample) {
  tetcollide_MeshState s{};
  ASSERT_TRUE(protocol::copy_bounded(s.scene, "sc"));
  ASSERT_TRUE(protocol::copy_bounded(s.object, "ob"));
  double xyz[6] = {1, 2, 3, 4, 5, 6};
  protocol::borrow(s.positions, xyz, 6);
  s.frame = 11;
  s.topology_version = 2;
  const StateView v = view_of(s);
  EXPECT_EQ(v.scene, "sc");
  EXPECT_EQ(v.object, "ob");
  EXPECT_EQ(v.frame, 11);
  EXPECT_EQ(v.topology_version, 2u);
  ASSERT_EQ(v.positions.size(), 6u);
  EXPECT_EQ(v.positions[5], 6.0);
  EXPECT_TRUE(v.velocities.empty());
}

}  // namespace
}  // namespace tc::daemon
