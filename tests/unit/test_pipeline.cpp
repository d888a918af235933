// service/core/pipeline/pipeline: one scene's frame from states to forces.
#include "core/pipeline/pipeline.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <ostream>
#include <stdexcept>

#include "core/common/log.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/validate.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

// Box A = [0,1]^3; box B = [1-d, 2-d] x [0,1]^2 (overlap d along x); other boxes apart.
TetMesh box_at(double x0, int n = 4) {
  return test::structured_box(n, n, n, {x0, 0, 0}, {x0 + 1.0, 1.0, 1.0});
}

FrameObjectInput state_of(const std::string& name, const TetMesh& mesh, std::uint32_t version = 0) {
  return {name, version, mesh.positions, {}};
}

Eigen::Vector3d total(const FrameOutput& out, const std::string& name) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const ObjectForces& f : out.forces)
    if (f.object == name)
      for (const auto& v : f.forces) sum += v;
  return sum;
}

/// The same objects, nodes, forces and stiffness blocks, bit for bit.
void expect_same_forces(const FrameOutput& got, const FrameOutput& want) {
  ASSERT_EQ(got.forces.size(), want.forces.size());
  for (std::size_t o = 0; o < got.forces.size(); ++o) {
    EXPECT_EQ(got.forces[o].object, want.forces[o].object);
    EXPECT_EQ(got.forces[o].nodes, want.forces[o].nodes);
    EXPECT_EQ(got.forces[o].forces, want.forces[o].forces);
    EXPECT_EQ(got.forces[o].stiffness, want.forces[o].stiffness);
  }
}

const ObjectForces* forces_of(const FrameOutput& out, const std::string& name) {
  for (const ObjectForces& f : out.forces)
    if (f.object == name) return &f;
  return nullptr;
}

class PipelineResponse : public ::testing::TestWithParam<ResponseKind> {};

TEST_P(PipelineResponse, OverlappingBoxesPushApartAlongX) {
  double previous = 0.0;
  for (const double d : {0.05, 0.1, 0.2}) {
    Pipeline pipeline;
    ObjectParams params;
    params.response = GetParam();
    // B is narrower than A in y and z, so the overlap lies away from A's side faces and
    // the depth gradients on both sides point along x.
    const TetMesh a = box_at(0.0, 8);
    const TetMesh b = test::structured_box(8, 4, 4, {1.0 - d, 0.25, 0.25}, {2.0 - d, 0.75, 0.75});
    ASSERT_TRUE(pipeline.set_topology("a", 1, a, params).ok());
    ASSERT_TRUE(pipeline.set_topology("b", 1, b, params).ok());
    const std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
    const FrameOutput out = pipeline.run_frame(7, states);
    EXPECT_EQ(out.frame, 7);
    EXPECT_TRUE(out.errors.empty());
    ASSERT_EQ(out.forces.size(), 2u);
    const Eigen::Vector3d fa = total(out, "a"), fb = total(out, "b");
    EXPECT_LT(fa.x(), 0.0);
    EXPECT_GT(fb.x(), 0.0);
    EXPECT_NEAR((fa + fb).norm(), 0.0, 1e-9 * fa.norm());
    // Sideways remainder: the 6-tet split of the cubes is not mirror-symmetric, and CPFM
    // and the linear depth per tet follow it (measured: at most 3.4% at d = 0.2).
    EXPECT_LT(std::abs(fa.y()) + std::abs(fa.z()), 0.05 * std::abs(fa.x()))
        << "d=" << d << " fa=" << fa.transpose();
    EXPECT_GT(-fa.x(), previous);  // grows with the overlap
    previous = -fa.x();
    EXPECT_GT(out.stats.overlapping_pairs, 0u);
    EXPECT_GT(out.stats.contacts, 0u);
    EXPECT_GT(out.stats.settled_nodes, 0u);
    EXPECT_NEAR(out.stats.max_depth, d, 0.5 * d + 0.25);
  }
}

INSTANTIATE_TEST_SUITE_P(PointSegmentAuto, PipelineResponse,
                         ::testing::Values(ResponseKind::kPoint, ResponseKind::kSegment,
                                           ResponseKind::kAuto));

TEST(PairOptions, CombinesTheTwoObjectsParameters) {
  ObjectParams a, b;
  a.stiffness = 1e3;
  b.stiffness = 1e9;
  a.damping = 0.0;
  b.damping = 5.0;
  ResponseOptions o = pair_options(a, b);
  EXPECT_EQ(o.stiffness, 1e3);
  EXPECT_EQ(o.damping, 5.0);
  EXPECT_EQ(o.kind, ResponseKind::kAuto);
  a.response = ResponseKind::kPoint;
  EXPECT_EQ(pair_options(a, b).kind, ResponseKind::kPoint);
  b.response = ResponseKind::kSegment;
  EXPECT_EQ(pair_options(a, b).kind, ResponseKind::kSegment);
  EXPECT_EQ(pair_options(b, a).kind, ResponseKind::kSegment);
  // Friction: the geometric mean (a frictionless object makes the pair frictionless),
  // the larger threshold (0 = the default), lumped blocks when either asks.
  EXPECT_EQ(o.friction, 0.0);
  EXPECT_EQ(o.friction_velocity, kDefaultFrictionVelocity);
  EXPECT_EQ(o.stiffness_mode, StiffnessMode::kNone);
  a.friction = 0.4;
  EXPECT_EQ(pair_options(a, b).friction, 0.0);
  b.friction = 0.9;
  EXPECT_DOUBLE_EQ(pair_options(a, b).friction, 0.6);
  b.friction_velocity = 1e-2;
  EXPECT_EQ(pair_options(a, b).friction_velocity, 1e-2);
  a.friction_velocity = 1e-5;
  EXPECT_EQ(pair_options(a, b).friction_velocity, 1e-2);
  b.friction_velocity = 0.0;
  EXPECT_EQ(pair_options(a, b).friction_velocity, kDefaultFrictionVelocity);
  a.blocks = true;
  EXPECT_EQ(pair_options(a, b).stiffness_mode, StiffnessMode::kLumped);
  EXPECT_EQ(pair_options(b, a).stiffness_mode, StiffnessMode::kLumped);
}

// A sliver is registered, and said once through the log facade (the daemon's sink is
// spdlog); a clean mesh says nothing.
TEST(Pipeline, SliversAreKeptWithAWarning) {
  std::vector<std::pair<LogLevel, std::string>> logged;
  set_log_sink([&](LogLevel level, std::string_view message) {
    logged.emplace_back(level, std::string(message));
  });
  TetMesh sliver = test::single_tet();
  sliver.positions.col(3) = Eigen::Vector3d(0.3, 0.3, 0.004);
  const double q = tet_quality(sliver.positions, sliver.tets[0]);
  ASSERT_GT(q, 1e-6);
  ASSERT_LT(q, 1e-2);
  Pipeline pipeline;
  EXPECT_TRUE(pipeline.set_topology("clean", 1, box_at(0.0, 2), {}).ok());
  EXPECT_TRUE(logged.empty());
  EXPECT_TRUE(pipeline.set_topology("thin", 3, sliver, {}).ok());
  set_log_sink({});
  ASSERT_EQ(logged.size(), 1u);
  EXPECT_EQ(logged[0].first, LogLevel::kWarn);
  EXPECT_NE(logged[0].second.find("object 'thin' version 3: 1 sliver tets (first: 0)"),
            std::string::npos)
      << logged[0].second;
}

TEST(Pipeline, SeparatedObjectsCostOnlyTheBoxTest) {
  Pipeline pipeline;
  const TetMesh a = box_at(0.0), b = box_at(3.0);
  ASSERT_TRUE(pipeline.set_topology("a", 0, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 0, b, {}).ok());
  const std::vector<FrameObjectInput> states = {state_of("a", a), state_of("b", b)};
  const FrameOutput out = pipeline.run_frame(0, states);
  EXPECT_TRUE(out.forces.empty());
  EXPECT_EQ(out.stats.candidate_pairs, 0u);
  EXPECT_EQ(out.stats.settled_nodes, 0u);
}

TEST(Pipeline, TwoStaticObjectsAreNeverTested) {
  Pipeline pipeline;
  ObjectParams fixed;
  fixed.is_static = true;
  const TetMesh a = box_at(0.0), b = box_at(0.8);
  ASSERT_TRUE(pipeline.set_topology("a", 0, a, fixed).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 0, b, fixed).ok());
  const FrameOutput out = pipeline.run_frame(0, std::vector<FrameObjectInput>{});
  EXPECT_TRUE(out.forces.empty());
  EXPECT_EQ(out.stats.candidate_pairs, 0u);
}

TEST(Pipeline, BadStatesAreRejectedAndTheRestRuns) {
  Pipeline pipeline;
  const TetMesh a = box_at(0.0), b = box_at(0.9), c = box_at(5.0);
  ASSERT_TRUE(pipeline.set_topology("a", 2, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 2, b, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("c", 2, c, {}).ok());
  FrameObjectInput nan_state = state_of("c", c, 2);
  nan_state.positions(0, 3) = std::numeric_limits<double>::quiet_NaN();
  FrameObjectInput short_state = state_of("c", c, 2);
  short_state.positions.conservativeResize(3, 5);
  FrameObjectInput inverted = state_of("c", c, 2);
  inverted.positions.row(0) *= -1.0;  // mirror: every tet inverted
  const std::vector<FrameObjectInput> states = {state_of("a", a, 2),
                                                state_of("b", b, 2),
                                                state_of("ghost", a, 2),
                                                state_of("c", c, 1),
                                                nan_state,
                                                short_state,
                                                inverted};
  const FrameOutput out = pipeline.run_frame(3, states);
  ASSERT_EQ(out.errors.size(), 5u);
  EXPECT_EQ(out.errors[0].error.code, ErrorCode::kUnknownObject);
  EXPECT_EQ(out.errors[0].object, "ghost");
  EXPECT_EQ(out.errors[1].error.code, ErrorCode::kStaleVersion);
  EXPECT_EQ(out.errors[2].error.code, ErrorCode::kInvalidMesh);
  EXPECT_NE(out.errors[2].error.message.find("non-finite"), std::string::npos);
  EXPECT_EQ(out.errors[3].error.code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(out.errors[4].error.code, ErrorCode::kInvalidMesh);
  EXPECT_NE(out.errors[4].error.message.find("inverted"), std::string::npos);
  for (const auto& e : out.errors) EXPECT_EQ(e.object == "a" || e.object == "b", false);
  EXPECT_NE(forces_of(out, "a"), nullptr);
  EXPECT_NE(forces_of(out, "b"), nullptr);
  EXPECT_EQ(forces_of(out, "c"), nullptr);
}

TEST(Pipeline, LaterStatesAreCheckedAsStrictlyAsTheFirst) {
  // After accepted states the shape check only recomputes the tets of the nodes that
  // moved: a still object, a translated one, a small dent pass; a node pushed through its
  // neighbours is rejected with the message of the full check, and the next good state runs.
  Pipeline pipeline;
  const TetMesh a = box_at(0.0);
  ASSERT_TRUE(pipeline.set_topology("a", 1, a, {}).ok());
  FrameObjectInput state = state_of("a", a, 1);
  const auto run = [&](std::int64_t frame, const Positions& x) {
    state.positions = x;
    return pipeline.run_frame(frame, std::vector<FrameObjectInput>{state});
  };
  Positions x = a.positions;
  EXPECT_TRUE(run(0, x).errors.empty());
  EXPECT_TRUE(run(1, x).errors.empty());
  x.colwise() += Eigen::Vector3d(0.5, 0.25, -2.0);
  EXPECT_TRUE(run(2, x).errors.empty());
  const Index node = 31;  // an interior node of the 4 x 4 x 4 box
  x(2, node) -= 0.01;
  EXPECT_TRUE(run(3, x).errors.empty());
  Positions through = x;
  through(2, node) -= 0.6;
  const FrameOutput bad = run(4, through);
  ASSERT_EQ(bad.errors.size(), 1u);
  EXPECT_EQ(bad.errors[0].error.code, ErrorCode::kInvalidMesh);
  ValidationOptions frame_options;
  frame_options.compute_min_quality = false;
  ValidationReport full = validate_positions(through, a.tets, frame_options);
  full.sliver = {};  // slivers pass: not named in the rejection
  const std::string expected = full.summary();
  EXPECT_NE(expected.find("inverted"), std::string::npos) << expected;
  EXPECT_EQ(bad.errors[0].error.message, "object 'a' frame 4: " + expected);
  EXPECT_TRUE(run(5, x).errors.empty());
}

// Issue 48, item 6: the degraded mode. The inverted and degenerate tets of `x`, sorted,
// every one listed (the reference the pipeline's list is checked against).
std::vector<Index> bad_tets(const Positions& x, const std::vector<Tet>& tets) {
  ValidationOptions options;
  options.max_listed = tets.size();
  const ValidationReport r = validate_positions(x, tets, options);
  std::vector<Index> out = r.inverted.first;
  out.insert(out.end(), r.degenerate.first.begin(), r.degenerate.first.end());
  std::sort(out.begin(), out.end());
  return out;
}

/// Node (i, j, k) of test::structured_box(n, n, n, ...).
Index grid_node(int n, int i, int j, int k) {
  return i + (n + 1) * (j + (n + 1) * k);
}

// A state with a few inverted tets far from the contact is accepted (the default limit:
// 16 tets and 1 % of the object's), its objects get the forces a clean state gets, bit for
// bit, and FrameOutput::degraded names the object and every tet left out. The same state
// is rejected as before when the limit is 0. The next clean state is answered in full.
TEST(PipelineDegraded, AFewInvertedTetsFarFromContactKeepTheForces) {
  const TetMesh a = box_at(0.0, 8), b = box_at(0.9, 4);  // overlap: x in [0.9, 1]
  Positions dented = a.positions;
  // A node (at x = 0.25) pushed past its neighbour below: 6 tets inverted.
  dented.col(grid_node(8, 2, 4, 4)) += Eigen::Vector3d(0.0, 0.0, -0.14);
  const std::vector<Index> bad = bad_tets(dented, a.tets);
  ASSERT_GE(bad.size(), 1u);
  ASSERT_LE(bad.size(), 16u);
  const std::vector<FrameObjectInput> clean = {state_of("a", a), state_of("b", b)};
  std::vector<FrameObjectInput> degraded = clean;
  degraded[0].positions = dented;

  Pipeline reference;
  ASSERT_TRUE(reference.set_topology("a", 0, a, {}).ok());
  ASSERT_TRUE(reference.set_topology("b", 0, b, {}).ok());
  const FrameOutput want = reference.run_frame(0, clean);
  ASSERT_TRUE(want.errors.empty());
  ASSERT_EQ(want.forces.size(), 2u);

  Pipeline pipeline;
  ASSERT_TRUE(pipeline.set_topology("a", 0, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 0, b, {}).ok());
  EXPECT_TRUE(pipeline.run_frame(0, clean).degraded.empty());
  const FrameOutput got = pipeline.run_frame(1, degraded);
  EXPECT_TRUE(got.errors.empty());
  ASSERT_EQ(got.degraded.size(), 1u);
  const DegradedState& d = got.degraded[0];
  EXPECT_EQ(d.object, "a");
  EXPECT_EQ(d.tets, bad);
  EXPECT_EQ(d.inverted + d.degenerate, bad.size());
  EXPECT_EQ(d.allowed, 16u);  // min(16, 1 % of 3072 tets)
  expect_same_forces(got, want);
  // Clean again: nothing left out, the same forces.
  const FrameOutput after = pipeline.run_frame(2, clean);
  EXPECT_TRUE(after.errors.empty());
  EXPECT_TRUE(after.degraded.empty());
  expect_same_forces(after, want);

  // max_inverted_tets = 0: the state is rejected as before (a gets no forces, b's come
  // from a's last state).
  PipelineConfig strict_config;
  strict_config.max_inverted_tets = 0;
  Pipeline strict(strict_config);
  ASSERT_TRUE(strict.set_topology("a", 0, a, {}).ok());
  ASSERT_TRUE(strict.set_topology("b", 0, b, {}).ok());
  ASSERT_TRUE(strict.run_frame(0, clean).errors.empty());
  const FrameOutput rejected = strict.run_frame(1, degraded);
  ASSERT_EQ(rejected.errors.size(), 1u);
  EXPECT_EQ(rejected.errors[0].object, "a");
  EXPECT_EQ(rejected.errors[0].error.code, ErrorCode::kInvalidMesh);
  EXPECT_NE(rejected.errors[0].error.message.find("inverted"), std::string::npos);
  EXPECT_TRUE(rejected.degraded.empty());
}

// Inverted tets inside the contact, in both objects: they take part in nothing (no
// point contact has its node in one of them), every force is finite, the objects are
// still pushed apart, and the forces are the same bits whatever the thread count.
TEST(PipelineDegraded, InvertedTetsAtTheContactTakePartInNothing) {
  const TetMesh a = box_at(0.0, 8), b = box_at(0.9, 8);
  Positions xa = a.positions, xb = b.positions;
  // A node of each pushed past its neighbour towards the other object, into the overlap.
  xa.col(grid_node(8, 7, 4, 4)) += Eigen::Vector3d(0.14, 0.0, 0.0);   // x: 0.875 -> 1.015
  xb.col(grid_node(8, 1, 4, 4)) += Eigen::Vector3d(-0.14, 0.0, 0.0);  // x: 1.025 -> 0.885
  const std::vector<Index> bad_a = bad_tets(xa, a.tets), bad_b = bad_tets(xb, b.tets);
  ASSERT_GE(bad_a.size(), 1u);
  ASSERT_LE(bad_a.size(), 16u);
  ASSERT_GE(bad_b.size(), 1u);
  ASSERT_LE(bad_b.size(), 16u);
  const std::vector<FrameObjectInput> states = {{"a", 0, xa, {}}, {"b", 0, xb, {}}};
  std::vector<FrameOutput> outputs;
  for (const int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              static_cast<std::size_t>(threads));
    PipelineConfig config;
    config.record_contacts = true;
    config.compute_stiffness = true;
    Pipeline pipeline(config);
    ASSERT_TRUE(pipeline.set_topology("a", 0, a, {}).ok());
    ASSERT_TRUE(pipeline.set_topology("b", 0, b, {}).ok());
    outputs.push_back(pipeline.run_frame(0, states));
  }
  const FrameOutput& out = outputs[0];
  EXPECT_TRUE(out.errors.empty());
  ASSERT_EQ(out.degraded.size(), 2u);
  EXPECT_EQ(out.degraded[0].tets, bad_a);
  EXPECT_EQ(out.degraded[1].tets, bad_b);
  ASSERT_EQ(out.forces.size(), 2u);
  for (const ObjectForces& f : out.forces)
    for (const Eigen::Vector3d& v : f.forces) EXPECT_TRUE(v.allFinite()) << f.object;
  EXPECT_LT(total(out, "a").x(), 0.0);
  EXPECT_GT(total(out, "b").x(), 0.0);
  EXPECT_TRUE(std::isfinite(out.stats.max_depth));
  ASSERT_FALSE(out.point_contacts.empty());
  for (const FramePointContact& c : out.point_contacts) {
    const std::vector<Index>& left_out = c.penetrated == "a" ? bad_a : bad_b;
    EXPECT_FALSE(std::binary_search(left_out.begin(), left_out.end(), c.tet))
        << c.object << " node " << c.node << " in " << c.penetrated << " tet " << c.tet;
    EXPECT_TRUE(std::isfinite(c.depth));
  }
  for (std::size_t k = 1; k < outputs.size(); ++k) expect_same_forces(outputs[k], out);
}

// The limit: inverted and degenerate tets count together, against both the count and the
// fraction; a rejection names at most 8 tets of a kind however many the check lists.
TEST(PipelineDegraded, TheLimitIsACountAndAFraction) {
  const TetMesh a = box_at(0.0, 8);
  Positions dented = a.positions;
  dented.col(grid_node(8, 2, 4, 4)) += Eigen::Vector3d(0.0, 0.0, -0.14);
  const std::size_t bad = bad_tets(dented, a.tets).size();
  ASSERT_GE(bad, 2u);
  const auto errors = [&](std::size_t count, double fraction, const Positions& x) {
    PipelineConfig config;
    config.max_inverted_tets = count;
    config.max_inverted_fraction = fraction;
    Pipeline pipeline(config);
    EXPECT_TRUE(pipeline.set_topology("a", 0, a, {}).ok());
    return pipeline.run_frame(0, std::vector<FrameObjectInput>{{"a", 0, x, {}}}).errors;
  };
  const double m = static_cast<double>(a.tets.size());
  EXPECT_TRUE(errors(bad, 1.0, dented).empty());
  EXPECT_EQ(errors(bad - 1, 1.0, dented).size(), 1u);
  EXPECT_TRUE(errors(1000, (static_cast<double>(bad) + 0.5) / m, dented).empty());
  EXPECT_EQ(errors(1000, (static_cast<double>(bad) - 0.5) / m, dented).size(), 1u);
  // A mirror inverts every tet: rejected with the message of the registration's check.
  Positions mirror = a.positions;
  mirror.row(0) *= -1.0;
  const auto rejected = errors(5000, 1.0 / 3.0, mirror);
  ASSERT_EQ(rejected.size(), 1u);
  ValidationOptions frame_options;
  frame_options.compute_min_quality = false;
  EXPECT_EQ(rejected[0].error.message,
            "object 'a' frame 0: " + validate_positions(mirror, a.tets, frame_options).summary());
  PipelineConfig bad_config;
  bad_config.max_inverted_fraction = 1.5;
  EXPECT_THROW(Pipeline{bad_config}, std::invalid_argument);
  bad_config.max_inverted_fraction = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(Pipeline{bad_config}, std::invalid_argument);
}

TEST(Pipeline, InvalidTopologyKeepsThePreviousVersion) {
  Pipeline pipeline;
  const TetMesh a = box_at(0.0), b = box_at(0.9);
  ASSERT_TRUE(pipeline.set_topology("a", 1, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 1, b, {}).ok());
  TetMesh broken = a;
  broken.tets[4][2] = 100000;
  const Status st = pipeline.set_topology("a", 2, broken, {});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("object 'a'"), std::string::npos);
  const std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
  EXPECT_TRUE(pipeline.run_frame(0, states).errors.empty());
}

TEST(Pipeline, CutReplacesTheTopologyBetweenFrames) {
  Pipeline pipeline;
  const TetMesh a = box_at(0.0), b = box_at(0.9);
  ASSERT_TRUE(pipeline.set_topology("a", 1, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 1, b, {}).ok());
  // "Cut" b: drop the tets of its first layer in z, a new topology version.
  TetMesh cut = b;
  cut.tets.erase(cut.tets.begin(), cut.tets.begin() + 6 * 16);
  ASSERT_TRUE(pipeline.set_topology("b", 2, cut, {}).ok());
  std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
  FrameOutput out = pipeline.run_frame(1, states);
  ASSERT_EQ(out.errors.size(), 1u);
  EXPECT_EQ(out.errors[0].error.code, ErrorCode::kStaleVersion);
  states[1].topology_version = 2;
  out = pipeline.run_frame(2, states);
  EXPECT_TRUE(out.errors.empty());
  EXPECT_NE(forces_of(out, "b"), nullptr);
}

// Issue 14: after a cut, until a state of the new version is used, the object's positions
// are its rest positions, which the client never sent for this frame: no pair with it is
// tested (the object is listed in left_out), the others get no force from it.
TEST(Pipeline, AMovingObjectWithoutAStateOfItsVersionIsLeftOut) {
  Pipeline pipeline;
  const TetMesh a = box_at(0.0), b = box_at(0.9), far = box_at(5.0);
  ASSERT_TRUE(pipeline.set_topology("a", 1, a, {}).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 1, far, {}).ok());
  // b was never sent a state: a overlaps b's rest positions (box_at(0.9) is the cut's rest
  // shape below) but that is not where b is.
  FrameOutput out = pipeline.run_frame(0, std::vector<FrameObjectInput>{state_of("a", a, 1)});
  EXPECT_TRUE(out.errors.empty());
  EXPECT_EQ(out.left_out, std::vector<std::string>{"b"});
  // b's state (far away), then a cut whose rest positions overlap a.
  out = pipeline.run_frame(
      1, std::vector<FrameObjectInput>{state_of("a", a, 1), state_of("b", far, 1)});
  EXPECT_TRUE(out.left_out.empty());
  EXPECT_TRUE(out.forces.empty());
  ASSERT_TRUE(pipeline.set_topology("b", 2, b, {}).ok());
  // A stale state of b (rejected) and a's new one: b is left out, a gets no force.
  out = pipeline.run_frame(
      2, std::vector<FrameObjectInput>{state_of("a", a, 1), state_of("b", far, 1)});
  ASSERT_EQ(out.errors.size(), 1u);
  EXPECT_EQ(out.errors[0].error.code, ErrorCode::kStaleVersion);
  EXPECT_EQ(out.left_out, std::vector<std::string>{"b"});
  EXPECT_TRUE(out.forces.empty());
  EXPECT_EQ(out.stats.candidate_pairs, 0u);
  // No state of b at all this frame: still left out.
  out = pipeline.run_frame(3, std::vector<FrameObjectInput>{state_of("a", a, 1)});
  EXPECT_EQ(out.left_out, std::vector<std::string>{"b"});
  EXPECT_TRUE(out.forces.empty());
  // b's first version-2 state (at the rest shape, overlapping a): both take part.
  out = pipeline.run_frame(4, std::vector<FrameObjectInput>{state_of("b", b, 2)});
  EXPECT_TRUE(out.left_out.empty());
  EXPECT_NE(forces_of(out, "a"), nullptr);
  EXPECT_NE(forces_of(out, "b"), nullptr);
}

// A static object's rest positions are where it is (it never moves): it is never left out.
TEST(Pipeline, AStaticObjectNeedsNoState) {
  Pipeline pipeline;
  ObjectParams fixed;
  fixed.is_static = true;
  const TetMesh floor = box_at(0.0), body = box_at(0.9);
  ASSERT_TRUE(pipeline.set_topology("floor", 1, floor, fixed).ok());
  ASSERT_TRUE(pipeline.set_topology("body", 1, body, {}).ok());
  const FrameOutput out =
      pipeline.run_frame(0, std::vector<FrameObjectInput>{state_of("body", body, 1)});
  EXPECT_TRUE(out.left_out.empty());
  EXPECT_NE(forces_of(out, "body"), nullptr);
}

TEST(Pipeline, BitIdenticalAcrossThreadCounts) {
  const TetMesh a = box_at(0.0, 6),
                b = test::structured_box(5, 5, 5, {0.83, 0.1, 0.05}, {1.71, 0.93, 1.2});
  ObjectParams params;
  params.response = ResponseKind::kSegment;
  const auto run = [&](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(threads));
    PipelineConfig config;
    config.compute_stiffness = true;
    Pipeline pipeline(config);
    EXPECT_TRUE(pipeline.set_topology("a", 0, a, params).ok());
    EXPECT_TRUE(pipeline.set_topology("b", 0, b, params).ok());
    const std::vector<FrameObjectInput> states = {state_of("a", a), state_of("b", b)};
    return pipeline.run_frame(0, states);
  };
  const FrameOutput one = run(1), two = run(2), four = run(4);
  for (const FrameOutput* other : {&two, &four}) {
    ASSERT_EQ(one.forces.size(), other->forces.size());
    for (std::size_t o = 0; o < one.forces.size(); ++o) {
      EXPECT_EQ(one.forces[o].nodes, other->forces[o].nodes);
      ASSERT_EQ(one.forces[o].forces.size(), other->forces[o].forces.size());
      for (std::size_t i = 0; i < one.forces[o].forces.size(); ++i) {
        EXPECT_EQ(one.forces[o].forces[i], other->forces[o].forces[i]);
        EXPECT_EQ(one.forces[o].stiffness[i], other->forces[o].stiffness[i]);
      }
    }
  }
}

TEST(Pipeline, StaticObjectsReuseTheirDepthMap) {
  Pipeline pipeline;
  ObjectParams fixed;
  fixed.is_static = true;
  const TetMesh floor = box_at(0.0), body = box_at(0.9);
  ASSERT_TRUE(pipeline.set_topology("floor", 0, floor, fixed).ok());
  ASSERT_TRUE(pipeline.set_topology("body", 0, body, {}).ok());
  const std::vector<FrameObjectInput> states = {state_of("body", body)};
  const FrameOutput first = pipeline.run_frame(0, states);
  const FrameOutput second = pipeline.run_frame(1, states);
  EXPECT_GT(first.stats.settled_nodes, second.stats.settled_nodes);
  ASSERT_EQ(first.forces.size(), second.forces.size());
  for (std::size_t o = 0; o < first.forces.size(); ++o)
    EXPECT_EQ(first.forces[o].forces, second.forces[o].forces);
}

TEST(Pipeline, ObjectsAtRestGiveWhatFreshStatesGive) {
  // A static floor (never sent a state) and a block that sends one state and then none
  // keep their detection bounds and trees across frames (CollisionBody::reuse_positions);
  // a ball moves through both. Every frame's forces are those of a new pipeline given
  // every object's current positions.
  ObjectParams fixed;
  fixed.is_static = true;
  const TetMesh floor = box_at(0.0, 5);
  const TetMesh block = test::structured_box(3, 3, 3, {0.1, 0.1, 0.95}, {0.6, 0.6, 1.4});
  const TetMesh ball0 = test::ball_mesh(3, 0.15);
  const auto ball_at = [&](int frame) {
    TetMesh ball = ball0;
    ball.positions.colwise() += Eigen::Vector3d(0.4 + 0.05 * frame, 0.5, 1.05 - 0.01 * frame);
    return ball;
  };
  Pipeline kept;
  ASSERT_TRUE(kept.set_topology("floor", 0, floor, fixed).ok());
  ASSERT_TRUE(kept.set_topology("block", 0, block, {}).ok());
  ASSERT_TRUE(kept.set_topology("ball", 0, ball0, {}).ok());
  for (int frame = 0; frame < 5; ++frame) {
    SCOPED_TRACE(frame);
    const TetMesh ball = ball_at(frame);
    std::vector<FrameObjectInput> states = {state_of("ball", ball)};
    if (frame == 0) states.push_back(state_of("block", block));
    const FrameOutput got = kept.run_frame(frame, states);
    Pipeline fresh;
    ASSERT_TRUE(fresh.set_topology("floor", 0, floor, fixed).ok());
    ASSERT_TRUE(fresh.set_topology("block", 0, block, {}).ok());
    ASSERT_TRUE(fresh.set_topology("ball", 0, ball0, {}).ok());
    const FrameOutput want = fresh.run_frame(
        frame, std::vector<FrameObjectInput>{state_of("ball", ball), state_of("block", block)});
    EXPECT_TRUE(got.errors.empty());
    EXPECT_GT(got.stats.overlapping_pairs, 0u);
    EXPECT_EQ(got.stats.candidate_pairs, want.stats.candidate_pairs);
    expect_same_forces(got, want);
  }
}

// A deforming object: the pipeline hands the detection the shape check's bound of each
// state (CollisionBody's group boxes without a pass over the nodes). Over frames that
// lift a corner of it 15 cm under the tool (a hundredth of its nodes: the rest stay within
// their radii, so the check's bound holds with new references for the corner) and walk a
// bulge along it, and a frame that bends its whole end (every tet checked), every frame's
// forces are those of a new pipeline given the same positions. With `turn` the whole
// scene also turns by `turn` rad a frame about a tilted axis through the slab's middle:
// the check compares the slab after its fitted turn, and the bound's turned group boxes
// must give the same forces.
void deforming_slab_frames(double turn) {
  // 24 detection groups: the ball meets few of them, so the group boxes are used.
  const TetMesh slab = test::structured_box(32, 32, 4, {0, 0, 0}, {1.0, 1.0, 0.25});
  const TetMesh ball0 = test::ball_mesh(3, 0.05);
  const auto register_both = [&](Pipeline& p) {
    ASSERT_TRUE(p.set_topology("slab", 0, slab, {}).ok());
    ASSERT_TRUE(p.set_topology("ball", 0, ball0, {}).ok());
  };
  Pipeline kept;
  register_both(kept);
  int contact = 0;
  for (int frame = 0; frame < 12; ++frame) {
    SCOPED_TRACE(frame);
    const bool lifted = frame % 3 == 1;
    const bool bent = frame == 9;
    const Eigen::Vector3d middle(0.5, 0.5, 0.125);
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(turn * frame, Eigen::Vector3d(0.3, -0.2, 1.0).normalized())
            .toRotationMatrix();
    const auto place = [&](auto&& positions) {
      positions = (rotation * (positions.colwise() - middle)).colwise() + middle;
    };
    TetMesh state = slab;
    for (Eigen::Index i = 0; i < state.positions.cols(); ++i) {
      auto x = state.positions.col(i);
      const bool corner = x.x() > 0.94 && x.y() > 0.94;
      if (lifted && corner) x.z() += 0.15;
      const double past = std::max(0.0, x.x() - 0.8);
      if (bent) x.z() += 6.0 * past * past;
      const double d = std::hypot(x.x() - 0.3, x.y() - 0.1 - 0.07 * frame);
      if (d < 0.15) x.z() += 0.02 * (1.0 - d / 0.15);
    }
    TetMesh ball = ball0;
    const Eigen::Vector3d at = lifted ? Eigen::Vector3d(0.97, 0.97, 0.25 + 0.15)
                               : bent ? Eigen::Vector3d(0.93, 0.5, 0.25 + 6.0 * 0.13 * 0.13)
                                      : Eigen::Vector3d(0.3, 0.1 + 0.07 * frame, 0.27);
    ball.positions.colwise() += at + Eigen::Vector3d(0.0, 0.0, 0.05 - 0.01);
    if (turn != 0.0) {
      place(state.positions);
      place(ball.positions);
    }
    const std::vector<FrameObjectInput> states = {state_of("slab", state), state_of("ball", ball)};
    const FrameOutput got = kept.run_frame(frame, states);
    Pipeline fresh;
    register_both(fresh);
    const FrameOutput want = fresh.run_frame(frame, states);
    EXPECT_TRUE(got.errors.empty());
    EXPECT_EQ(got.stats.candidate_pairs, want.stats.candidate_pairs);
    contact += got.stats.overlapping_pairs > 0 ? 1 : 0;
    expect_same_forces(got, want);
  }
  EXPECT_EQ(contact, 12);
}

TEST(Pipeline, ADeformingObjectGivesWhatAFreshPipelineGives) {
  deforming_slab_frames(0.0);
}

TEST(Pipeline, ATurningDeformingObjectGivesWhatAFreshPipelineGives) {
  deforming_slab_frames(0.03);
}

// run_frame_taking swaps the states' matrices in rather than copying them: over frames
// with moving objects, velocities, a static object, an object without a state and a
// rejected state, it gives what run_frame gives, bit for bit; each accepted state then
// holds the matrices its object had, and a rejected one keeps its own.
TEST(Pipeline, TakingTheStatesGivesWhatCopyingGives) {
  ObjectParams fixed, moving;
  fixed.is_static = true;
  moving.damping = 1e3;
  const TetMesh floor = box_at(0.0, 5);
  const TetMesh block = test::structured_box(3, 3, 3, {0.1, 0.1, 0.95}, {0.6, 0.6, 1.4});
  const TetMesh ball0 = test::ball_mesh(3, 0.15);
  Pipeline copying, taking;
  for (Pipeline* p : {&copying, &taking}) {
    ASSERT_TRUE(p->set_topology("floor", 0, floor, fixed).ok());
    ASSERT_TRUE(p->set_topology("block", 0, block, moving).ok());
    ASSERT_TRUE(p->set_topology("ball", 0, ball0, moving).ok());
  }
  Positions last_ball;  // the ball's last accepted positions
  for (int frame = 0; frame < 6; ++frame) {
    SCOPED_TRACE(frame);
    TetMesh ball = ball0;
    ball.positions.colwise() += Eigen::Vector3d(0.4 + 0.05 * frame, 0.5, 1.05 - 0.01 * frame);
    std::vector<FrameObjectInput> states = {state_of("ball", ball)};
    states[0].velocities = Positions::Constant(3, ball.num_nodes(), -0.1 * frame);
    if (frame % 2 == 0) states.push_back(state_of("block", block));  // else at rest
    if (frame == 3) {  // the ball's state is rejected (a NaN): last frame's stays
      states[0].positions(1, 4) = std::numeric_limits<double>::quiet_NaN();
      states[0].velocities.resize(3, 0);
    }
    const std::vector<FrameObjectInput> sent = states;
    const FrameOutput want = copying.run_frame(frame, states);
    const FrameOutput got = taking.run_frame_taking(frame, states);
    ASSERT_EQ(got.errors.size(), want.errors.size());
    EXPECT_EQ(got.errors.size(), frame == 3 ? 1u : 0u);
    EXPECT_GT(want.stats.overlapping_pairs, 0u);
    EXPECT_EQ(got.stats.candidate_pairs, want.stats.candidate_pairs);
    expect_same_forces(got, want);
    // A rejected state keeps its matrices; an accepted one got its object's old ones.
    if (frame == 3) {
      EXPECT_TRUE(states[0].positions.hasNaN());
    } else {
      if (frame > 0) {
        EXPECT_EQ(states[0].positions, last_ball);
      }
      last_ball = sent[0].positions;
    }
  }
}

TEST(Pipeline, UnknownObjectsCanBeRemoved) {
  Pipeline pipeline;
  ASSERT_TRUE(pipeline.set_topology("a", 0, box_at(0.0), {}).ok());
  EXPECT_TRUE(pipeline.has_object("a"));
  pipeline.remove_object("a");
  pipeline.remove_object("never");
  EXPECT_FALSE(pipeline.has_object("a"));
}

// ---- Contact depths against the exact reference ---------------------------------------
// Each case is a pose nobody tuned the response for; every point contact's depth is
// compared with the exact distance of its node to the other object's boundary
// (Pipeline::exact_depths, a BVH over the boundary triangles).

struct ContactCase {
  const char* name;
  const char* mesh_a;
  const char* mesh_b;
  Eigen::Vector3d scale_a;  ///< per-axis scale of A (then B's transform)
  Eigen::Vector3d scale_b;
  double rotate_b_deg;  ///< about x
  Eigen::Vector3d move_b;
  ResponseKind response;
};

void PrintTo(const ContactCase& c, std::ostream* os) {
  *os << c.name;
}

TetMesh load_scaled(const char* name, const Eigen::Vector3d& scale) {
  auto mesh = read_mesh(test::mesh_path(name));
  if (!mesh) throw std::runtime_error(mesh.error().message);
  mesh->positions = scale.asDiagonal() * mesh->positions;
  return std::move(*mesh);
}

struct ContactAudit {
  std::size_t contacts = 0;
  std::size_t within = 0;      ///< within 10% + 1e-3 of the penetrated bbox diagonal
  std::size_t beyond_1_5 = 0;  ///< over 1.5x or under 1/1.5x exact (+- the same tolerance)
  double max_ratio = 0.0;
  Eigen::Vector3d force_a = Eigen::Vector3d::Zero();
};

ContactAudit audit_pair(const TetMesh& a, const TetMesh& b, ResponseKind kind,
                        DepthEvaluation evaluation = DepthEvaluation::kNearestFace) {
  PipelineConfig config;
  config.record_contacts = true;
  config.evaluation = evaluation;
  Pipeline pipeline(config);
  ObjectParams params;
  params.response = kind;
  EXPECT_TRUE(pipeline.set_topology("a", 1, a, params).ok());
  EXPECT_TRUE(pipeline.set_topology("b", 1, b, params).ok());
  const std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
  const FrameOutput out = pipeline.run_frame(0, states);
  EXPECT_TRUE(out.errors.empty());
  const auto exact = pipeline.exact_depths(out.point_contacts);
  EXPECT_TRUE(exact.has_value());
  const auto diagonal = [](const TetMesh& m) {
    return (m.positions.rowwise().maxCoeff() - m.positions.rowwise().minCoeff()).norm();
  };
  ContactAudit audit;
  audit.force_a = total(out, "a");
  for (std::size_t i = 0; exact && i < exact->size(); ++i) {
    const FramePointContact& c = out.point_contacts[i];
    const double e = (*exact)[i];
    const double tol = 1e-3 * diagonal(c.penetrated == "a" ? a : b);
    if (evaluation == DepthEvaluation::kNearestFace) {  // an upper bound, never below
      EXPECT_GE(c.depth, e - 1e-12 * (1.0 + e)) << c.object << " node " << c.node;
    }
    ++audit.contacts;
    audit.within += std::abs(c.depth - e) <= 0.1 * e + tol;
    audit.beyond_1_5 += c.depth > 1.5 * e + tol || c.depth < e / 1.5 - tol;
    if (e > tol) audit.max_ratio = std::max(audit.max_ratio, c.depth / e);
  }
  return audit;
}

class ContactDepth : public ::testing::TestWithParam<ContactCase> {};

TEST_P(ContactDepth, PointContactsMatchTheExactDepth) {
  const ContactCase& cc = GetParam();
  const TetMesh a = load_scaled(cc.mesh_a, cc.scale_a);
  TetMesh b = load_scaled(cc.mesh_b, cc.scale_b);
  const Eigen::Matrix3d rot =
      Eigen::AngleAxisd(cc.rotate_b_deg * 3.14159265358979323846 / 180.0, Eigen::Vector3d::UnitX())
          .toRotationMatrix();
  b.positions = (rot * b.positions).colwise() + cc.move_b;
  const ContactAudit audit = audit_pair(a, b, cc.response);
  ASSERT_GT(audit.contacts, 0u);
  std::printf("  %-22s %4zu point contacts, %5.1f%% within 10%%, %zu beyond 1.5x, max ratio %.3f\n",
              cc.name, audit.contacts,
              100.0 * static_cast<double>(audit.within) / static_cast<double>(audit.contacts),
              audit.beyond_1_5, audit.max_ratio);
  EXPECT_GE(static_cast<double>(audit.within), 0.99 * static_cast<double>(audit.contacts));
  EXPECT_EQ(audit.beyond_1_5, 0u);
  // The paper's interpolation on the same pose, for the record (docs/RESPONSE.md).
  const ContactAudit paper = audit_pair(a, b, cc.response, DepthEvaluation::kInterpolate);
  std::printf("  %-22s interpolated: %5.1f%% within 10%%, %zu beyond 1.5x, max ratio %.3f\n", "",
              100.0 * static_cast<double>(paper.within) / static_cast<double>(paper.contacts),
              paper.beyond_1_5, paper.max_ratio);
}

const Eigen::Vector3d kOne = Eigen::Vector3d::Ones();
// The plate: data/meshes/box.msh (1 x 1 x 0.3 m) made 3 x 3 m and 2 cm thick (about 0.28 m
// edges in the plane); the ball (radius 0.2 m) halved to 0.1 m, pressed 5 mm in.
const Eigen::Vector3d kPlate(3.0, 3.0, 0.02 / 0.3);
const Eigen::Vector3d kHalf = 0.5 * kOne;

INSTANTIATE_TEST_SUITE_P(Poses, ContactDepth,
                         ::testing::Values(ContactCase{"box_on_box",
                                                       "box.msh",
                                                       "box.msh",
                                                       kOne,
                                                       kOne,
                                                       0.0,
                                                       {0, 0, 0.295},
                                                       ResponseKind::kPoint},
                                           ContactCase{"box_on_box_offset",
                                                       "box.msh",
                                                       "box.msh",
                                                       kOne,
                                                       kOne,
                                                       0.0,
                                                       {0.05, 0.03, 0.295},
                                                       ResponseKind::kPoint},
                                           ContactCase{"box_on_box_segment",
                                                       "box.msh",
                                                       "box.msh",
                                                       kOne,
                                                       kOne,
                                                       0.0,
                                                       {0.05, 0.03, 0.29},
                                                       ResponseKind::kSegment},
                                           ContactCase{"torus_on_box",
                                                       "box.msh",
                                                       "torus.msh",
                                                       kOne,
                                                       kOne,
                                                       20.0,
                                                       {0.02, -0.01, 0.23},
                                                       ResponseKind::kPoint},
                                           ContactCase{"ball_in_thin_plate",
                                                       "box.msh",
                                                       "ball.msh",
                                                       kPlate,
                                                       kHalf,
                                                       0.0,
                                                       {0.013, -0.021, 0.01 + 0.1 - 0.005},
                                                       ResponseKind::kPoint},
                                           ContactCase{"coarse_ellipsoids",
                                                       "ellipsoid.msh",
                                                       "ellipsoid.msh",
                                                       kOne,
                                                       kOne,
                                                       35.0,
                                                       {0.012, 0.004, 0.052},
                                                       ResponseKind::kPoint}),
                         [](const ::testing::TestParamInfo<ContactCase>& p) {
                           return std::string(p.param.name);
                         });

// Two copies of one mesh at one place: every node's push out of the other copy is undone
// by the reaction of its twin, so the depth directions alone give zero force everywhere.
TEST(SymmetricOverlap, CoincidentCopiesAreSeparated) {
  for (const char* name : {"box.msh", "ellipsoid.msh"}) {
    for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
      const TetMesh a = load_scaled(name, kOne);
      Pipeline pipeline;
      ObjectParams params;
      params.response = kind;
      ASSERT_TRUE(pipeline.set_topology("a", 1, a, params).ok());
      ASSERT_TRUE(pipeline.set_topology("b", 1, a, params).ok());
      const std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", a, 1)};
      const FrameOutput out = pipeline.run_frame(0, states);
      EXPECT_EQ(out.stats.symmetric_pairs, 1u) << name;
      const Eigen::Vector3d fa = total(out, "a"), fb = total(out, "b");
      // The centres coincide: the axis the overlap is thinnest in (z for the flat box).
      Eigen::Index axis = 0;
      (a.positions.rowwise().maxCoeff() - a.positions.rowwise().minCoeff()).minCoeff(&axis);
      EXPECT_GT(fa[axis], 0.0) << name;
      EXPECT_NEAR((fa + fb).norm(), 0.0, 1e-9 * fa.norm());
      EXPECT_LT(fa.norm() - std::abs(fa[axis]), 1e-9 * fa.norm()) << name;
      // The same pair run again gives the same forces (the choice is deterministic).
      const FrameOutput again = pipeline.run_frame(1, states);
      EXPECT_EQ(total(again, "a"), fa);
    }
  }
}

/// One frame of objects "a" and "b" at their given positions, default parameters.
FrameOutput one_frame(const TetMesh& a, const TetMesh& b) {
  Pipeline pipeline;
  EXPECT_TRUE(pipeline.set_topology("a", 1, a, {}).ok());
  EXPECT_TRUE(pipeline.set_topology("b", 1, b, {}).ok());
  return pipeline.run_frame(
      0, std::vector<FrameObjectInput>{state_of("a", a, 1), state_of("b", b, 1)});
}

TEST(SymmetricOverlap, ANearlyCoincidentCopyIsPushedAwayFromTheOther) {
  // 2 mm apart along x the pushes no longer cancel (the check does not fire, measured
  // ratio above 0.1) and the depth directions push the copies apart along x.
  const TetMesh a = load_scaled("box.msh", kOne);
  TetMesh b = a;
  b.positions.colwise() += Eigen::Vector3d(0.002, 0.0, 0.0);
  const Eigen::Vector3d fa = total(one_frame(a, b), "a");
  EXPECT_LT(fa.x(), 0.0) << fa.transpose();
  EXPECT_GT(std::abs(fa.x()), std::hypot(fa.y(), fa.z())) << fa.transpose();
}

TEST(SymmetricOverlap, OrdinaryContactsAreNotTakenForSymmetric) {
  TetMesh b = load_scaled("box.msh", kOne);
  b.positions.colwise() += Eigen::Vector3d(0.05, 0.03, 0.295);
  const FrameOutput out = one_frame(load_scaled("box.msh", kOne), b);
  EXPECT_GT(out.stats.contacts, 0u);
  EXPECT_EQ(out.stats.symmetric_pairs, 0u);
}

// Contact damping (ObjectParams::damping) reads the states' velocities: approaching
// stiffens the push, separating softens it, no velocities is the undamped force.
TEST(Pipeline, DampingReadsTheStatesVelocities) {
  TetMesh b = load_scaled("box.msh", kOne);
  b.positions.colwise() += Eigen::Vector3d(0.05, 0.03, 0.295);
  const TetMesh a = load_scaled("box.msh", kOne);
  ObjectParams params;
  params.response = ResponseKind::kPoint;
  params.damping = 2e3;
  Pipeline pipeline;
  ASSERT_TRUE(pipeline.set_topology("a", 1, a, params).ok());
  ASSERT_TRUE(pipeline.set_topology("b", 1, b, params).ok());
  const auto push_on_b = [&](double vz) {  // b moving along z at vz, a at rest
    std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
    if (vz != 0.0) states[1].velocities = Positions::Constant(3, b.num_nodes(), 0.0);
    if (vz != 0.0) states[1].velocities.row(2).setConstant(vz);
    const FrameOutput out = pipeline.run_frame(0, states);
    EXPECT_TRUE(out.errors.empty());
    return total(out, "b").z();
  };
  const double still = push_on_b(0.0), down = push_on_b(-0.1), up = push_on_b(0.1);
  EXPECT_GT(still, 0.0);
  EXPECT_GT(down, still * 1.01);  // b sinking into a: more push
  EXPECT_LT(up, still * 0.99);    // b leaving: less
  EXPECT_GE(up, 0.0);             // never a pull
  // Velocities of the wrong size or non-finite reject that state only.
  std::vector<FrameObjectInput> bad = {state_of("a", a, 1), state_of("b", b, 1)};
  bad[1].velocities = Positions::Zero(3, 2);
  const FrameOutput out = pipeline.run_frame(1, bad);
  ASSERT_EQ(out.errors.size(), 1u);
  EXPECT_EQ(out.errors[0].object, "b");
  EXPECT_NE(out.errors[0].error.message.find("velocities"), std::string::npos);
}

/// Box b sliding along +x over box a (its bottom 5 mm into a's top), with friction mu on
/// both; a at rest.
FrameOutput sliding_frame(double mu, bool blocks_b, double vx = 0.5) {
  TetMesh b = load_scaled("box.msh", kOne);
  b.positions.colwise() += Eigen::Vector3d(0.05, 0.03, 0.295);
  const TetMesh a = load_scaled("box.msh", kOne);
  ObjectParams params;
  params.response = ResponseKind::kPoint;
  params.friction = mu;
  ObjectParams params_b = params;
  params_b.blocks = blocks_b;
  Pipeline pipeline;
  EXPECT_TRUE(pipeline.set_topology("a", 1, a, params).ok());
  EXPECT_TRUE(pipeline.set_topology("b", 1, b, params_b).ok());
  std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
  states[1].velocities = Positions::Zero(3, b.num_nodes());
  states[1].velocities.row(0).setConstant(vx);
  FrameOutput out = pipeline.run_frame(0, states);
  EXPECT_TRUE(out.errors.empty());
  return out;
}

TEST(Pipeline, FrictionOpposesTheSlipAndTheReactionBalancesIt) {
  const FrameOutput bare = sliding_frame(0.0, false);
  const FrameOutput rubbed = sliding_frame(0.5, false);
  const Eigen::Vector3d push = total(bare, "b"), on_b = total(rubbed, "b");
  ASSERT_GT(push.z(), 0.0);
  // Face on face: every push is along +z and every slip along +x, so the friction on b is
  // -mu times the summed push, along -x; the normal part is unchanged.
  EXPECT_NEAR(on_b.x() - push.x(), -0.5 * push.z(), 1e-9 * push.z());
  EXPECT_NEAR(on_b.z(), push.z(), 1e-9 * push.z());
  EXPECT_LE((on_b + total(rubbed, "a")).norm(), 1e-9 * push.z());  // action = reaction
  // mu = 0 is frictionless to the bit, with or without velocities.
  expect_same_forces(sliding_frame(0.0, false, 0.0), bare);
  // The blocks go to the object that asked only: df/dx and df/dv for b, none for a.
  const FrameOutput asked = sliding_frame(0.5, true);
  const ObjectForces* fa = forces_of(asked, "a");
  const ObjectForces* fb = forces_of(asked, "b");
  ASSERT_TRUE(fa != nullptr && fb != nullptr);
  EXPECT_TRUE(fa->stiffness.empty() && fa->damping.empty());
  ASSERT_EQ(fb->stiffness.size(), fb->nodes.size());
  ASSERT_EQ(fb->damping.size(), fb->nodes.size());
  const ObjectForces* fb_unasked = forces_of(rubbed, "b");
  ASSERT_TRUE(fb_unasked != nullptr);
  EXPECT_EQ(fb->forces, fb_unasked->forces);  // asking changes no force
  double slip_damping = 0.0;  // sliding: friction's df/dv is across the slip, not along it
  for (const auto& d : fb->damping) slip_damping += d(1, 1);
  EXPECT_LT(slip_damping, 0.0);
}

/// The contacts behind the forces (ObjectParams::contacts), point and segment response:
/// every row's point of the intruder is its point in the penetrated tet, the point
/// contacts' depths and directions are those of the audit, asking changes no force, and
/// only the object that asked gets rows.
TEST(Pipeline, ContactRowsAreThePointsBehindTheForces) {
  for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
    SCOPED_TRACE(response_kind_name(kind));
    TetMesh b = load_scaled("box.msh", kOne);
    b.positions.colwise() += Eigen::Vector3d(0.05, 0.03, 0.295);
    const TetMesh a = load_scaled("box.msh", kOne);
    const auto run = [&](bool contacts) {
      ObjectParams pa, pb;
      pa.response = pb.response = kind;
      pb.contacts = contacts;
      PipelineConfig config;
      config.record_contacts = true;
      Pipeline pipeline(config);
      EXPECT_TRUE(pipeline.set_topology("a", 1, a, pa).ok());
      EXPECT_TRUE(pipeline.set_topology("b", 1, b, pb).ok());
      std::vector<FrameObjectInput> states = {state_of("a", a, 1), state_of("b", b, 1)};
      return pipeline.run_frame(0, states);
    };
    const FrameOutput plain = run(false), asked = run(true);
    EXPECT_TRUE(plain.contacts.empty());
    expect_same_forces(asked, plain);
    ASSERT_EQ(asked.contacts.size(), 1u);
    const ObjectContacts& oc = asked.contacts[0];
    EXPECT_EQ(oc.object, "b");
    ASSERT_EQ(oc.others, std::vector<std::string>{"a"});
    ASSERT_FALSE(oc.rows.empty());
    std::size_t intruding = 0, penetrated = 0;
    for (const ObjectContacts::Row& row : oc.rows) {
      const ContactRow& c = row.contact;
      const TetMesh& x = row.intrudes ? b : a;  // the intruder
      const TetMesh& y = row.intrudes ? a : b;  // the penetrated object
      ++(row.intrudes ? intruding : penetrated);
      ASSERT_GE(c.tet, 0);
      ASSERT_LT(static_cast<std::size_t>(c.tet), y.tets.size());
      Eigen::Vector3d in_x = c.weights[0] * x.positions.col(c.nodes[0]);
      if (c.nodes[1] >= 0) in_x += c.weights[1] * x.positions.col(c.nodes[1]);
      Eigen::Vector3d in_y = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) in_y += c.bary[k] * y.positions.col(y.tets[c.tet][k]);
      EXPECT_LT((in_x - in_y).norm(), 1e-9);
      EXPECT_NEAR(c.bary.sum(), 1.0, 1e-12);
      EXPECT_GE(c.bary.minCoeff(), 0.0);
      EXPECT_GE(c.depth, 0.0);
      EXPECT_NEAR(c.normal.norm(), 1.0, 1e-12);
      if (kind == ResponseKind::kPoint) {
        EXPECT_EQ(c.nodes[1], -1);
        // The audit of the same node: the same depth and direction, bit for bit.
        const std::string intruder = row.intrudes ? "b" : "a";
        const auto audit = std::find_if(asked.point_contacts.begin(), asked.point_contacts.end(),
                                        [&](const FramePointContact& p) {
                                          return p.object == intruder && p.node == c.nodes[0];
                                        });
        ASSERT_NE(audit, asked.point_contacts.end());
        EXPECT_EQ(audit->depth, c.depth);
        EXPECT_EQ(audit->normal, c.normal);
      } else {
        EXPECT_GE(c.nodes[1], 0);  // a piece of an edge: both ends, weights summing to 1
        EXPECT_NEAR(c.weights[0] + c.weights[1], 1.0, 1e-15);
      }
    }
    EXPECT_GT(intruding, 0u);  // b's features in a, and a's in b
    EXPECT_GT(penetrated, 0u);
    if (kind == ResponseKind::kPoint)
      EXPECT_EQ(oc.rows.size(), asked.point_contacts.size());
    else
      EXPECT_EQ(oc.rows.size() % 2, 0u);  // two rows per piece
  }
}

TEST(ContactDepth, FaceOnFaceWithALateralOffsetPushesAlongTheNormal) {
  // Issue 12's case: two copies of box.msh, the second 5 mm into the first's top and
  // offset sideways by (5, 3) cm. The interpolated depths gave a net sideways force of
  // 10% of the normal force and twice the true depth on 17 of 95 fallback contacts.
  TetMesh b = load_scaled("box.msh", kOne);
  b.positions.colwise() += Eigen::Vector3d(0.05, 0.03, 0.295);
  const ContactAudit audit = audit_pair(load_scaled("box.msh", kOne), b, ResponseKind::kPoint);
  ASSERT_GT(audit.contacts, 0u);
  EXPECT_LT(audit.force_a.z(), 0.0);  // a (below) pushed down
  EXPECT_LE(std::hypot(audit.force_a.x(), audit.force_a.y()), 0.02 * std::abs(audit.force_a.z()));
  EXPECT_LE(audit.max_ratio, 1.5);
}

// A small tool pressed into a large object (issue 13): the local lazy depth map settles a
// few per cent of the large object's nodes, and the forces are those of the march from
// the whole boundary (within 1% in total, node by node on the tool) and those of the same
// press into a piece cut from the large object with the same mesh around the contact.
TEST(Pipeline, ASmallToolInALargeObjectCostsWhatTheContactCosts) {
  const int n = 24;  // cells per metre (the same under the sanitizers: the 5% bound depends on it)
  const double h = 1.0 / n;
  const TetMesh large = test::structured_box(n, n, n / 4, {0, 0, 0}, {1.0, 1.0, 0.25});
  // The piece: the 12 x 12 columns of cells around the press, the same cells as the large
  // object's (an even cell offset keeps the tets' split pattern).
  const int off = n / 2 - 6 - (n / 2 - 6) % 2;
  const TetMesh piece = test::structured_box(12, 12, n / 4, {off * h, off * h, 0},
                                             {(off + 12) * h, (off + 12) * h, 0.25});
  const TetMesh tool0 = test::ball_mesh(4, 0.06);
  const auto run = [&](const TetMesh& target, LazyRegion lazy, int frame, std::size_t* settled) {
    PipelineConfig config;
    config.lazy_region = lazy;
    config.compute_stiffness = true;
    Pipeline pipeline(config);
    EXPECT_TRUE(pipeline.set_topology("organ", 0, target, {}).ok());
    EXPECT_TRUE(pipeline.set_topology("tool", 0, tool0, {}).ok());
    TetMesh tool = tool0;
    // Pressed 1.5 cm into the top face, a little further along x every frame.
    const Eigen::Vector3d at((off + 6) * h + 0.01 * frame, (off + 6) * h - 0.004 * frame,
                             0.25 + 0.06 - 0.015);
    tool.positions.colwise() += at;
    const FrameOutput out = pipeline.run_frame(
        frame, std::vector<FrameObjectInput>{state_of("organ", target), state_of("tool", tool)});
    EXPECT_TRUE(out.errors.empty());
    for (const auto& [name, count] : out.settled_by_object)
      if (name == "organ") *settled = count;
    return out;
  };
  for (int frame = 0; frame < 3; ++frame) {
    SCOPED_TRACE(frame);
    std::size_t local_settled = 0, whole_settled = 0, piece_settled = 0;
    const FrameOutput local = run(large, LazyRegion::kLocal, frame, &local_settled);
    const FrameOutput whole = run(large, LazyRegion::kWholeBoundary, frame, &whole_settled);
    const FrameOutput cut = run(piece, LazyRegion::kLocal, frame, &piece_settled);
    EXPECT_LT(local_settled * 20, static_cast<std::size_t>(large.num_nodes())) << local_settled;
    EXPECT_LT(local_settled * 4, whole_settled);
    const Eigen::Vector3d fl = total(local, "tool"), fw = total(whole, "tool"),
                          fc = total(cut, "tool");
    ASSERT_GT(fw.norm(), 0.0);
    EXPECT_LE((fl - fw).norm(), 0.01 * fw.norm()) << fl.transpose() << " / " << fw.transpose();
    EXPECT_LE((fc - fl).norm(), 0.01 * fl.norm()) << fc.transpose() << " / " << fl.transpose();
    const ObjectForces* tl = forces_of(local, "tool");
    const ObjectForces* tw = forces_of(whole, "tool");
    ASSERT_TRUE(tl && tw);
    EXPECT_EQ(tl->nodes, tw->nodes);
  }
}

}  // namespace
}  // namespace tc

// Surface objects (issue 19): a plate of triangles pressed into the box, through the
// pipeline with its validation, pairing and response.
namespace tc {
namespace {

SurfaceMesh plate(double z) {
  SurfaceMesh s = test::square_surface(6, 0.6, z);
  for (Eigen::Index i = 0; i < s.positions.cols(); ++i)
    s.positions.col(i) += Eigen::Vector3d(0.2, 0.2, 0);
  return s;
}

FrameObjectInput surface_state(const std::string& name, const SurfaceMesh& s) {
  return {name, 0, s.positions, {}};
}

TEST(PipelineSurface, APlateInTheBoxIsPushedOutAndTheBoxTakesTheReactions) {
  for (const ResponseKind kind :
       {ResponseKind::kPoint, ResponseKind::kSegment, ResponseKind::kAuto}) {
    PipelineConfig config;
    config.compute_stiffness = true;
    Pipeline pipeline(config);
    ObjectParams params;
    params.response = kind;
    const TetMesh box = box_at(0.0);
    const SurfaceMesh tool = plate(0.98);
    ASSERT_TRUE(pipeline.set_topology("box", 0, box, params).ok());
    const Status st = pipeline.set_surface("tool", 0, tool, params);
    ASSERT_TRUE(st.ok()) << st.error().message;
    EXPECT_TRUE(pipeline.is_surface("tool"));
    EXPECT_FALSE(pipeline.is_surface("box"));
    const std::vector<FrameObjectInput> states = {state_of("box", box),
                                                  surface_state("tool", tool)};
    const FrameOutput out = pipeline.run_frame(1, states);
    ASSERT_TRUE(out.errors.empty()) << out.errors[0].error.message;
    const ObjectForces* on_tool = forces_of(out, "tool");
    ASSERT_NE(on_tool, nullptr);
    ASSERT_NE(forces_of(out, "box"), nullptr);
    EXPECT_EQ(on_tool->stiffness.size(), on_tool->nodes.size());
    const Eigen::Vector3d f_tool = total(out, "tool"), f_box = total(out, "box");
    EXPECT_GT(f_tool.z(), 0.0);
    EXPECT_LT(std::hypot(f_tool.x(), f_tool.y()), 1e-9 * f_tool.z());
    EXPECT_LT((f_tool + f_box).norm(), 1e-12 * f_tool.norm());
    EXPECT_GT(out.stats.overlapping_pairs, 0u);
    // Only the box has a depth map.
    ASSERT_EQ(out.settled_by_object.size(), 1u);
    EXPECT_EQ(out.settled_by_object[0].first, "box");

    // Lifted clear of the box: nothing.
    const SurfaceMesh lifted = plate(1.01);
    const std::vector<FrameObjectInput> apart = {surface_state("tool", lifted)};
    const FrameOutput none = pipeline.run_frame(2, apart);
    EXPECT_TRUE(none.errors.empty());
    EXPECT_TRUE(none.forces.empty());
  }
}

TEST(PipelineSurface, BadSurfacesAndStatesAreRejectedWithTheirNames) {
  Pipeline pipeline;
  const TetMesh box = box_at(0.0);
  ASSERT_TRUE(pipeline.set_topology("box", 0, box, {}).ok());
  SurfaceMesh broken = plate(0.98);
  broken.triangles[3] = {0, 0, 1};
  Status st = pipeline.set_surface("tool", 0, broken, {});
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("object 'tool'"), std::string::npos) << st.error().message;
  EXPECT_NE(st.error().message.find("repeated node"), std::string::npos) << st.error().message;
  EXPECT_FALSE(pipeline.has_object("tool"));
  EXPECT_FALSE(pipeline.set_surface("tool", 0, SurfaceMesh{}, {}).ok());

  const SurfaceMesh tool = plate(0.98);
  ASSERT_TRUE(pipeline.set_surface("tool", 0, tool, {}).ok());
  // NaN, a collapsed triangle, a wrong node count: that state is rejected, the box runs.
  FrameObjectInput nan = surface_state("tool", tool);
  nan.positions(1, 5) = std::numeric_limits<double>::quiet_NaN();
  FrameObjectInput flat = surface_state("tool", tool);
  flat.positions.col(1) = flat.positions.col(0);
  FrameObjectInput short_state = surface_state("tool", tool);
  short_state.positions.conservativeResize(3, 10);
  for (const auto& [state, text] : {std::pair{nan, "non-finite"}, std::pair{flat, "degenerate"},
                                    std::pair{short_state, "10 positions for 49 nodes"}}) {
    const std::vector<FrameObjectInput> states = {state_of("box", box), state};
    const FrameOutput out = pipeline.run_frame(1, states);
    ASSERT_EQ(out.errors.size(), 1u);
    EXPECT_EQ(out.errors[0].object, "tool");
    EXPECT_NE(out.errors[0].error.message.find(text), std::string::npos)
        << out.errors[0].error.message;
    // The tool never had a valid state: left out, no pair.
    EXPECT_EQ(out.left_out, std::vector<std::string>{"tool"});
    EXPECT_TRUE(out.forces.empty());
  }
}

TEST(PipelineSurface, TwoSurfacesAreNeverTested) {
  Pipeline pipeline;
  const SurfaceMesh s = plate(0.5);
  ASSERT_TRUE(pipeline.set_surface("s1", 0, s, {}).ok());
  ASSERT_TRUE(pipeline.set_surface("s2", 0, s, {}).ok());
  const std::vector<FrameObjectInput> states = {surface_state("s1", s), surface_state("s2", s)};
  const FrameOutput out = pipeline.run_frame(1, states);
  EXPECT_TRUE(out.errors.empty());
  EXPECT_TRUE(out.forces.empty());
  EXPECT_EQ(out.stats.candidate_pairs, 0u);
}

TEST(PipelineSurface, BitIdenticalAcrossThreadCounts) {
  const TetMesh box = box_at(0.0, 6);
  SurfaceMesh tool = test::boundary_surface_of(test::ball_mesh(3, 0.3));
  for (Eigen::Index i = 0; i < tool.positions.cols(); ++i)
    tool.positions.col(i) += Eigen::Vector3d(0.5, 0.45, 1.1);
  std::vector<ObjectForces> reference;
  for (const int threads : {1, 2, 3, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    PipelineConfig config;
    config.compute_stiffness = true;
    Pipeline pipeline(config);
    ASSERT_TRUE(pipeline.set_topology("box", 0, box, {}).ok());
    ASSERT_TRUE(pipeline.set_surface("ball", 0, tool, {}).ok());
    const std::vector<FrameObjectInput> states = {state_of("box", box),
                                                  surface_state("ball", tool)};
    const FrameOutput out = pipeline.run_frame(1, states);
    ASSERT_TRUE(out.errors.empty());
    ASSERT_EQ(out.forces.size(), 2u);
    if (threads == 1) {
      reference = out.forces;
      continue;
    }
    for (std::size_t o = 0; o < 2; ++o) {
      EXPECT_EQ(out.forces[o].nodes, reference[o].nodes);
      for (std::size_t i = 0; i < reference[o].nodes.size(); ++i) {
        EXPECT_EQ(out.forces[o].forces[i], reference[o].forces[i]);
        EXPECT_EQ(out.forces[o].stiffness[i], reference[o].stiffness[i]);
      }
    }
  }
}

}  // namespace
}  // namespace tc
