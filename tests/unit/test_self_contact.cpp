// Self-contact (docs/DETECTION.md and docs/RESPONSE.md, "Self-contact"): the exact
// equivalence of two components of one object with two objects, no force on an object
// that does not touch itself, and a fold of one component pushed apart.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <vector>

#include "core/depth/boundary_bvh.hpp"
#include "core/detect/self_detect.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"
#include "core/pipeline/pipeline.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

/// `a` and `b` as one mesh: b's nodes and tets after a's.
TetMesh merged(const TetMesh& a, const TetMesh& b) {
  TetMesh m;
  m.positions.resize(3, a.num_nodes() + b.num_nodes());
  m.positions << a.positions, b.positions;
  for (Index i = 0; i < m.num_nodes(); ++i) m.node_ids.push_back(i + 1);
  m.tets = a.tets;
  for (Tet t : b.tets) {
    for (Index& v : t) v += a.num_nodes();
    m.tets.push_back(t);
  }
  return m;
}

TetMesh moved(TetMesh mesh, const Eigen::Matrix3d& turn, const Eigen::Vector3d& shift) {
  for (Index i = 0; i < mesh.num_nodes(); ++i)
    mesh.positions.col(i) = turn * mesh.positions.col(i) + shift;
  return mesh;
}

/// Only the tets whose centroid `keep` accepts, without the nodes no tet uses.
template <typename Keep>
TetMesh carved(const TetMesh& mesh, const Keep& keep) {
  std::vector<Tet> tets;
  for (const Tet& t : mesh.tets) {
    const Eigen::Vector3d c = 0.25 * (mesh.positions.col(t[0]) + mesh.positions.col(t[1]) +
                                      mesh.positions.col(t[2]) + mesh.positions.col(t[3]));
    if (keep(c)) tets.push_back(t);
  }
  std::vector<Index> map(static_cast<std::size_t>(mesh.num_nodes()), -1);
  TetMesh out;
  std::vector<Eigen::Vector3d> nodes;
  for (Tet& t : tets)
    for (Index& v : t) {
      Index& to = map[static_cast<std::size_t>(v)];
      if (to < 0) {
        to = static_cast<Index>(nodes.size());
        nodes.push_back(mesh.positions.col(v));
      }
      v = to;
    }
  out.positions.resize(3, static_cast<Index>(nodes.size()));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    out.positions.col(static_cast<Index>(i)) = nodes[i];
    out.node_ids.push_back(static_cast<std::int64_t>(i) + 1);
  }
  out.tets = std::move(tets);
  return out;
}

struct Equivalence {
  ResponseKind kind;
  const char* name;
};

class TwoComponentsAsTwoObjects : public ::testing::TestWithParam<Equivalence> {};

// Two meshes registered as two objects, and the same two meshes as one object with
// self-contact: the same contacts, and the same force on every node to 1e-9 of the
// largest force. Poses not tuned: a ball pressed into a box off-centre and turned, with
// damping and friction and random velocities.
TEST_P(TwoComponentsAsTwoObjects, GetTheSameContactsAndForces) {
  const TetMesh box = test::structured_box(6, 6, 3, {-0.5, -0.5, -0.3}, {0.5, 0.5, 0.0});
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.37, Eigen::Vector3d(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const TetMesh ball = moved(test::ball_mesh(5, 0.2), turn, {0.07, -0.11, 0.14});
  const TetMesh one = merged(box, ball);

  ObjectParams params;
  params.response = GetParam().kind;
  params.stiffness = 2e4;
  params.damping = 30.0;
  params.friction = 0.4;
  params.blocks = true;
  PipelineConfig config;
  config.record_contacts = true;
  Pipeline two(config), single(config);
  ASSERT_TRUE(two.set_topology("box", 1, box, params).ok());
  ASSERT_TRUE(two.set_topology("ball", 1, ball, params).ok());
  ObjectParams self = params;
  self.self_contact = true;
  ASSERT_TRUE(single.set_topology("one", 1, one, self).ok());

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> speed(-0.3, 0.3);
  Positions v(3, one.num_nodes());
  for (Index i = 0; i < v.cols(); ++i) v.col(i) << speed(rng), speed(rng), speed(rng);
  const Positions v_box = v.leftCols(box.num_nodes());
  const Positions v_ball = v.rightCols(ball.num_nodes());
  const std::vector<FrameObjectInput> states2{{"ball", 1, ball.positions, v_ball},
                                              {"box", 1, box.positions, v_box}};
  const std::vector<FrameObjectInput> states1{{"one", 1, one.positions, v}};
  const FrameOutput a = two.run_frame(1, states2);
  const FrameOutput b = single.run_frame(1, states1);
  ASSERT_TRUE(a.errors.empty());
  ASSERT_TRUE(b.errors.empty()) << b.errors.front().error.message;
  ASSERT_GT(a.stats.contacts, 10u);
  EXPECT_EQ(a.stats.contacts, b.stats.contacts);
  EXPECT_EQ(a.stats.overlapping_pairs, b.stats.overlapping_pairs);

  // Forces, node by node, in the merged numbering.
  std::map<Index, Eigen::Vector3d> expected;
  std::map<Index, Eigen::Matrix3d> expected_k;
  double largest = 0.0;
  for (const ObjectForces& f : a.forces) {
    const Index offset = f.object == "ball" ? box.num_nodes() : 0;
    for (std::size_t i = 0; i < f.nodes.size(); ++i) {
      expected[f.nodes[i] + offset] = f.forces[i];
      expected_k[f.nodes[i] + offset] = f.stiffness[i];
      largest = std::max(largest, f.forces[i].norm());
    }
  }
  ASSERT_EQ(b.forces.size(), 1u);
  const ObjectForces& got = b.forces.front();
  ASSERT_EQ(got.nodes.size(), expected.size());
  ASSERT_EQ(got.stiffness.size(), got.nodes.size());
  for (std::size_t i = 0; i < got.nodes.size(); ++i) {
    const auto it = expected.find(got.nodes[i]);
    ASSERT_NE(it, expected.end()) << "node " << got.nodes[i];
    EXPECT_LE((got.forces[i] - it->second).norm(), 1e-9 * largest) << "node " << got.nodes[i];
    EXPECT_LE((got.stiffness[i] - expected_k[got.nodes[i]]).norm(),
              1e-9 * expected_k[got.nodes[i]].norm() + 1e-12)
        << "node " << got.nodes[i];
  }
  // The contacts: the same nodes at the same depths along the same directions.
  ASSERT_EQ(a.point_contacts.size(), b.point_contacts.size());
  std::map<Index, std::pair<double, Eigen::Vector3d>> points;
  for (const FramePointContact& c : a.point_contacts)
    points[c.node + (c.object == "ball" ? box.num_nodes() : 0)] = {c.depth, c.normal};
  for (const FramePointContact& c : b.point_contacts) {
    EXPECT_EQ(c.object, "one");
    EXPECT_EQ(c.penetrated, "one");
    const auto it = points.find(c.node);
    ASSERT_NE(it, points.end()) << "node " << c.node;
    EXPECT_NEAR(c.depth, it->second.first, 1e-12);
    EXPECT_LE((c.normal - it->second.second).norm(), 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(Responses, TwoComponentsAsTwoObjects,
                         ::testing::Values(Equivalence{ResponseKind::kPoint, "point"},
                                           Equivalence{ResponseKind::kSegment, "segment"}),
                         [](const ::testing::TestParamInfo<Equivalence>& param) {
                           return std::string(param.param.name);
                         });

// An object that does not touch itself gets no force, and its detection stops at the
// surface gate with no crossing; a deformed (twisted) one as well.
TEST(SelfContact, AnObjectThatDoesNotTouchItselfGetsNothing) {
  for (const TetMesh& mesh : {test::torus_mesh(24, 4, 0.3, 0.1), test::ball_mesh(6, 0.2)}) {
    const Topology topo = build_topology(mesh.tets, mesh.num_nodes());
    SelfCollider collider(mesh.tets, topo, mesh.positions);
    Positions x = mesh.positions;
    for (Index i = 0; i < x.cols(); ++i) {  // twist about z: no tet inverts
      const double angle = 2.0 * x(2, i);
      const double c = std::cos(angle), s = std::sin(angle);
      const double px = x(0, i), py = x(1, i);
      x(0, i) = c * px - s * py;
      x(1, i) = s * px + c * py;
    }
    for (const Positions* p : std::array<const Positions*, 2>{&mesh.positions, &x}) {
      SelfContacts out;
      SelfDetectStats st;
      collider.detect(*p, kDefaultRelativeTolerance, out, &st);
      EXPECT_TRUE(out.empty());
      EXPECT_EQ(st.crossing_pairs, 0u);
      EXPECT_EQ(st.overlapping, 0u);
    }
    ObjectParams params;
    params.self_contact = true;
    Pipeline pipeline;
    ASSERT_TRUE(pipeline.set_topology("o", 1, mesh, params).ok());
    const std::vector<FrameObjectInput> states{{"o", 1, x, {}}};
    const FrameOutput out = pipeline.run_frame(1, states);
    EXPECT_TRUE(out.errors.empty());
    EXPECT_TRUE(out.forces.empty());
    EXPECT_EQ(out.stats.contacts, 0u);
  }
}

/// A U of one component: a base and two prongs with a slot between them; the left prong
/// bent (sheared, no tet inverted) past the slot into the right one by `reach` metres at
/// its tip, and 3 mm sideways and 4 mm down there (no face of one prong in the plane of a
/// face of the other).
struct BentU {
  TetMesh mesh;
  Positions bent;
};

BentU bent_u(double reach) {
  const TetMesh block = test::structured_box(6, 2, 6, {0.0, 0.0, 0.0}, {0.06, 0.02, 0.06});
  BentU u;
  u.mesh = carved(block, [](const Eigen::Vector3d& c) {
    return !(c.x() > 0.02 && c.x() < 0.04 && c.z() > 0.02);
  });
  u.bent = u.mesh.positions;
  for (Index i = 0; i < u.bent.cols(); ++i) {
    const double x = u.bent(0, i), z = u.bent(2, i);
    if (x <= 0.02 + 1e-12 && z > 0.02) {  // sheared towards +x, a little down and sideways
      const double s = (z - 0.02) / 0.04;
      u.bent(0, i) += s * reach;
      u.bent(1, i) += s * 0.003;
      u.bent(2, i) -= s * 0.004;
    }
  }
  return u;
}

// A fold of one component: the left prong's tip inside the right prong is pushed back
// (towards -x), the right prong's face away (+x), the forces sum to zero, and each
// point contact's depth is its node's exact distance to the right prong's boundary.
TEST(SelfContact, AFoldOfOneComponentIsPushedApart) {
  const BentU u = bent_u(0.025);  // 5 mm past the 2 cm slot at the tip
  const Topology topo = build_topology(u.mesh.tets, u.mesh.num_nodes());
  ASSERT_EQ(topo.num_components, 1);
  for (const ResponseKind kind : {ResponseKind::kPoint, ResponseKind::kSegment}) {
    ObjectParams params;
    params.self_contact = true;
    params.response = kind;
    PipelineConfig config;
    config.record_contacts = true;
    Pipeline pipeline(config);
    ASSERT_TRUE(pipeline.set_topology("u", 1, u.mesh, params).ok());
    const std::vector<FrameObjectInput> states{{"u", 1, u.bent, {}}};
    const FrameOutput out = pipeline.run_frame(1, states);
    ASSERT_TRUE(out.errors.empty()) << out.errors.front().error.message;
    ASSERT_EQ(out.forces.size(), 1u);
    Eigen::Vector3d left = Eigen::Vector3d::Zero(), right = Eigen::Vector3d::Zero();
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    const ObjectForces& f = out.forces.front();
    for (std::size_t i = 0; i < f.nodes.size(); ++i) {
      total += f.forces[i];
      (u.mesh.positions(0, f.nodes[i]) <= 0.02 + 1e-12 ? left : right) += f.forces[i];
    }
    EXPECT_LT(left.x(), 0.0);
    EXPECT_GT(right.x(), 0.0);
    EXPECT_LE(total.norm(), 1e-9 * left.norm());
    EXPECT_GT(out.stats.max_depth, 0.002);
    EXPECT_LT(out.stats.max_depth, 0.0052);
  }
  // Point contacts: nodes of the left prong inside the right one and nodes of the right
  // one inside the left, each at its exact distance to the other prong's boundary faces
  // (the faces whose corners all lay on that prong's side of the slot at rest), and its
  // normal leads it there.
  PipelineConfig config;
  config.record_contacts = true;
  Pipeline pipeline(config);
  ObjectParams params;
  params.self_contact = true;
  params.response = ResponseKind::kPoint;
  ASSERT_TRUE(pipeline.set_topology("u", 1, u.mesh, params).ok());
  const std::vector<FrameObjectInput> states{{"u", 1, u.bent, {}}};
  const FrameOutput out = pipeline.run_frame(1, states);
  ASSERT_FALSE(out.point_contacts.empty());
  const auto side_faces = [&](bool left) {
    std::vector<std::array<Index, 3>> faces;
    for (const auto& tri : topo.boundary_faces) {
      bool all = true;
      for (const Index v : tri) {
        const double x = u.mesh.positions(0, v);
        all = all && (left ? x <= 0.02 + 1e-12 : x >= 0.04 - 1e-12);
      }
      if (all) faces.push_back(tri);
    }
    return faces;
  };
  BoundaryBvh<3> left_bvh, right_bvh;
  left_bvh.build(side_faces(true), u.bent);
  right_bvh.build(side_faces(false), u.bent);
  std::size_t from_left = 0, from_right = 0;
  for (const FramePointContact& c : out.point_contacts) {
    const bool left = u.mesh.positions(0, c.node) <= 0.02 + 1e-12;
    (left ? from_left : from_right) += 1;
    const BoundaryBvh<3>& other = left ? right_bvh : left_bvh;
    const double exact = std::sqrt(other.nearest(u.bent.col(c.node)).sq_dist);
    EXPECT_NEAR(c.depth, exact, 1e-9) << "node " << c.node;
    // Pushed by its depth along its normal, the node lands on that boundary.
    const Eigen::Vector3d out_point = u.bent.col(c.node) + c.depth * c.normal;
    EXPECT_LE(std::sqrt(other.nearest(out_point).sq_dist), 1e-9) << "node " << c.node;
  }
  EXPECT_GT(from_left, 0u);
  EXPECT_GT(from_right, 0u);
  // The pipeline's own exact reference for self-contacts says the same.
  const auto exact = pipeline.exact_depths(out.point_contacts);
  ASSERT_TRUE(exact.has_value());
  for (std::size_t i = 0; i < exact->size(); ++i)
    EXPECT_NEAR(out.point_contacts[i].depth, (*exact)[i], 1e-9);
}

// Off by default: the same bent U without self_contact gets nothing.
// The gate's certificate told by the shape check's bound (SelfCollider::detect given a
// MotionBound, as the pipeline does) gives the contacts the gate gives without it, frame
// by frame, while the U closes on itself and opens again, jitters and shifts; jitter and
// shifts alone are certified without a pass over the boundary nodes.
TEST(SelfContact, TheShapeChecksBoundGivesTheSameContacts) {
  const BentU u = bent_u(0.0);
  const TetMesh& mesh = u.mesh;
  const Topology topo = build_topology(mesh.tets, mesh.num_nodes());
  const TetCheckOrder order = make_tet_check_order(mesh.positions, mesh.tets);
  ValidationOptions options;
  options.compute_min_quality = false;
  ShapeCheck check(order, topo.node_tets, mesh.num_nodes(), options);
  SelfCollider with_bound(mesh.tets, topo, mesh.positions);
  SelfCollider without(mesh.tets, topo, mesh.positions);
  std::mt19937_64 rng(45);
  std::uniform_real_distribution<double> jitter(-1e-6, 1e-6);
  std::size_t by_bound = 0, in_contact = 0, frames = 0;
  for (int frame = 0; frame < 240; ++frame) {
    // Still for 40 frames, then closing to 6 mm past the slot and opening again, with
    // every node jittered and the whole U shifted 0.1 mm a frame.
    const double phase = frame < 40 ? 0.0 : std::sin(std::numbers::pi * (frame - 40) / 200.0);
    const double reach = 0.026 * phase;
    Positions x = u.mesh.positions;
    for (Index i = 0; i < x.cols(); ++i) {
      const double px = x(0, i), pz = x(2, i);
      if (px <= 0.02 + 1e-12 && pz > 0.02) x(0, i) += (pz - 0.02) / 0.04 * reach;
      for (int c = 0; c < 3; ++c) x(c, i) += jitter(rng) + (c == 1 ? 1e-4 * frame : 0.0);
    }
    const ValidationReport report = check.check(x);
    ASSERT_TRUE(report.clean()) << frame;
    const MotionBound bound = check.bound();
    SelfContacts a, b;
    SelfDetectStats sa, sb;
    with_bound.detect(x, kDefaultRelativeTolerance, a, &sa, &bound);
    without.detect(x, kDefaultRelativeTolerance, b, &sb);
    ASSERT_EQ(a.parts.size(), b.parts.size()) << frame;
    EXPECT_EQ(a.marked, b.marked) << frame;
    for (std::size_t k = 0; k < a.parts.size(); ++k) {
      const PairContacts& pa = a.parts[k].contacts;
      const PairContacts& pb = b.parts[k].contacts;
      EXPECT_EQ(pa.overlapping, pb.overlapping) << frame;
      EXPECT_EQ(pa.nodes_a_in_b.size(), pb.nodes_a_in_b.size()) << frame;
      EXPECT_EQ(pa.edges_a_in_b.size(), pb.edges_a_in_b.size()) << frame;
    }
    by_bound += sa.certified_by_bound ? 1 : 0;
    in_contact += a.empty() ? 0 : 1;
    ++frames;
    EXPECT_FALSE(sb.certified_by_bound);
    if (sa.certified_by_bound) {
      EXPECT_TRUE(a.empty()) << frame;
    }
  }
  std::printf("by bound %zu, in contact %zu of %zu frames\n", by_bound, in_contact, frames);
  EXPECT_EQ(frames, 240u);
  EXPECT_GT(in_contact, 40u);  // the U did close on itself
  EXPECT_GT(by_bound, 30u);    // and the still frames were told by the bound
}

TEST(SelfContact, OffByDefault) {
  const BentU u = bent_u(0.025);
  Pipeline pipeline;
  ASSERT_TRUE(pipeline.set_topology("u", 1, u.mesh, {}).ok());
  const std::vector<FrameObjectInput> states{{"u", 1, u.bent, {}}};
  const FrameOutput out = pipeline.run_frame(1, states);
  EXPECT_TRUE(out.errors.empty());
  EXPECT_TRUE(out.forces.empty());
}

// A surface object cannot ask for self-contact: refused, naming the field.
TEST(SelfContact, ASurfaceObjectIsRefused) {
  ObjectParams params;
  params.self_contact = true;
  Pipeline pipeline;
  const Status st = pipeline.set_surface("s", 1, test::cube_surface(), params);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(st.error().message.find("params.self_contact"), std::string::npos);
}

// Bit-identical whatever the thread count is checked for the whole pipeline elsewhere;
// here the self-contacts themselves with one thread and with all.
TEST(SelfContact, TheSameContactsWhateverTheThreadCount) {
  const BentU u = bent_u(0.03);
  const Topology topo = build_topology(u.mesh.tets, u.mesh.num_nodes());
  SelfCollider collider(u.mesh.tets, topo, u.mesh.positions);
  SelfContacts all, one;
  collider.detect(u.bent, kDefaultRelativeTolerance, all);
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    collider.detect(u.bent, kDefaultRelativeTolerance, one);
  }
  ASSERT_EQ(all.parts.size(), 1u);
  ASSERT_EQ(one.parts.size(), 1u);
  const PairContacts& a = all.parts[0].contacts;
  const PairContacts& b = one.parts[0].contacts;
  EXPECT_EQ(a.overlapping, b.overlapping);
  ASSERT_EQ(a.nodes_a_in_b.size(), b.nodes_a_in_b.size());
  for (std::size_t i = 0; i < a.nodes_a_in_b.size(); ++i) {
    EXPECT_EQ(a.nodes_a_in_b[i].node, b.nodes_a_in_b[i].node);
    EXPECT_EQ(a.nodes_a_in_b[i].tet, b.nodes_a_in_b[i].tet);
    EXPECT_EQ(a.nodes_a_in_b[i].bary, b.nodes_a_in_b[i].bary);
  }
  ASSERT_EQ(a.edges_a_in_b.size(), b.edges_a_in_b.size());
  EXPECT_FALSE(a.nodes_a_in_b.empty());
}

}  // namespace
}  // namespace tc
