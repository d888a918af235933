// The response of a surface object against a tet object (issue 19, paper Fig. 14):
// ResponseAccumulator::compute with a surface as either object. A flat square pressed
// into the box is pushed along the box's normal with the box's reactions balancing it
// (force and moment) and nothing when apart; the boundary surface of the tet ball gets
// the forces the tet ball's boundary nodes get from the ball-in-box direction alone;
// the kAuto rule measures triangles; bad input names what is wrong.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <map>

#include "core/detect/detect.hpp"
#include "core/detect/surface_detect.hpp"
#include "core/mesh/topology.hpp"
#include "core/response/response.hpp"
#include "response_fixtures.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

/// A surface as the response sees it: mesh, edges and their edge topology.
struct TestSurface {
  SurfaceMesh mesh;
  SurfaceEdges edges;
  Topology topology;
  explicit TestSurface(SurfaceMesh m) : mesh(std::move(m)) {
    edges = build_surface_edges(mesh.triangles);
    topology = build_edge_topology(edges.edges, mesh.num_nodes());
  }
  [[nodiscard]] ResponseObject view() const {
    ResponseObject o;
    o.positions = &mesh.positions;
    o.topology = &topology;
    o.triangles = mesh.triangles;
    return o;
  }
};

/// The box [0, 1]^3 (4 x 4 x 4 cubes) with its CPFM depth map.
test::TestObject unit_box() {
  test::TestObject box(test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1}));
  box.compute_depth_map();
  return box;
}

/// The square [0.2, 0.8]^2 in 6 x 6 cells at height z.
TestSurface plate_at(double z) {
  TestSurface s(test::square_surface(6, 0.6, z));
  for (Eigen::Index i = 0; i < s.mesh.positions.cols(); ++i)
    s.mesh.positions.col(i) += Vector3d(0.2, 0.2, 0.0);
  return s;
}

PairContacts surface_contacts(const TestSurface& s, const test::TestObject& t, bool surface_is_a) {
  return to_pair_contacts(detect_surface_tets(s.mesh.positions, s.mesh.triangles, s.edges,
                                              t.mesh.positions, t.mesh.tets),
                          surface_is_a);
}

struct Totals {
  Vector3d force = Vector3d::Zero();
  Vector3d moment = Vector3d::Zero();
  double magnitude = 0.0;
};

Totals totals(const ObjectForces& f, const Positions& x) {
  Totals t;
  for (std::size_t i = 0; i < f.nodes.size(); ++i) {
    t.force += f.forces[i];
    t.moment += Vector3d(x.col(f.nodes[i])).cross(f.forces[i]);
    t.magnitude += f.forces[i].norm();
  }
  return t;
}

ResponseOptions options_for(ResponseKind kind, StiffnessMode blocks = StiffnessMode::kNone) {
  ResponseOptions o;
  o.kind = kind;
  o.stiffness = 1e4;
  o.measure = ForceMeasure::kUnit;
  o.stiffness_mode = blocks;
  return o;
}

class PlateIntoBox : public ::testing::TestWithParam<ResponseKind> {};

TEST_P(PlateIntoBox, PushedAlongTheNormalAndBalancedByTheBoxsReactions) {
  const test::TestObject box = unit_box();
  const double sink = 0.02;
  const TestSurface plate = plate_at(1.0 - sink);
  for (const bool surface_is_a : {true, false}) {
    SCOPED_TRACE(surface_is_a ? "surface is A" : "surface is B");
    const PairContacts contacts = surface_contacts(plate, box, surface_is_a);
    ASSERT_FALSE(contacts.empty());
    const ResponseObject s = plate.view(), t = box.view();
    const auto got = compute_pair_response(surface_is_a ? s : t, surface_is_a ? t : s, contacts,
                                           options_for(GetParam(), StiffnessMode::kLumped));
    ASSERT_TRUE(got.has_value()) << got.error().message;
    const ObjectForces& on_surface = surface_is_a ? got->a : got->b;
    const ObjectForces& on_box = surface_is_a ? got->b : got->a;
    // Every plate node is inside the box, 2 cm below its top and >= 0.2 m from the sides.
    ASSERT_EQ(on_surface.nodes.size(), 49u);
    for (std::size_t i = 0; i < on_surface.nodes.size(); ++i) {
      const Vector3d& f = on_surface.forces[i];
      EXPECT_GT(f.z(), 0.0) << "node " << on_surface.nodes[i];
      EXPECT_LT(std::hypot(f.x(), f.y()), 1e-9 * f.norm()) << "node " << on_surface.nodes[i];
    }
    const Totals ts = totals(on_surface, plate.mesh.positions);
    const Totals tb = totals(on_box, box.mesh.positions);
    EXPECT_LT((ts.force + tb.force).norm(), 1e-12 * ts.magnitude);
    EXPECT_LT((ts.moment + tb.moment).norm(), 1e-12 * ts.magnitude);
    if (GetParam() == ResponseKind::kPoint) {
      // The plain spring per node (kUnit): k d with d = 0.02 m.
      for (const Vector3d& f : on_surface.forces) EXPECT_NEAR(f.z(), 1e4 * sink, 1e-9);
      EXPECT_EQ(got->stats.point_contacts, 49u);
    } else {
      // The segment response integrates k d over every edge's parameter: the same sum
      // k d per edge, spread over its two ends.
      EXPECT_NEAR(ts.force.z(), 1e4 * sink * static_cast<double>(plate.edges.edges.size()), 1e-6);
      EXPECT_GT(got->stats.segment_contacts, 0u);
    }
    // Lumped blocks: symmetric and negative semi-definite.
    ASSERT_EQ(on_surface.stiffness.size(), on_surface.nodes.size());
    for (const Eigen::Matrix3d& k : on_surface.stiffness) {
      EXPECT_LT((k - k.transpose()).norm(), 1e-9 * (1.0 + k.norm()));
      EXPECT_LE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(k).eigenvalues().maxCoeff(),
                1e-9 * k.norm());
      EXPECT_LT(k(2, 2), 0.0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Kinds, PlateIntoBox,
                         ::testing::Values(ResponseKind::kPoint, ResponseKind::kSegment));

TEST(SurfaceResponse, NothingWhenApart) {
  const test::TestObject box = unit_box();
  const TestSurface plate = plate_at(1.01);
  const PairContacts contacts = surface_contacts(plate, box, true);
  EXPECT_TRUE(contacts.empty());
  const auto got =
      compute_pair_response(plate.view(), box.view(), contacts, options_for(ResponseKind::kAuto));
  ASSERT_TRUE(got.has_value()) << got.error().message;
  EXPECT_TRUE(got->a.nodes.empty());
  EXPECT_TRUE(got->b.nodes.empty());
}

// The boundary surface of the tet ball is pushed out of the box as the tet ball's
// boundary nodes are by the ball-in-box direction: same depths and directions, the same
// plain springs (kUnit; with kEdgeLength the weights differ, the surface's nodes have
// only surface edges).
TEST(SurfaceResponse, BallSurfaceGetsTheForcesOfTheTetBallsBoundaryNodes) {
  const test::TestObject box = unit_box();
  test::TestObject ball(test::ball_mesh(3, 0.35));
  for (Eigen::Index i = 0; i < ball.mesh.positions.cols(); ++i)
    ball.mesh.positions.col(i) += Vector3d(0.47, 0.52, 1.2);
  ball.compute_depth_map();
  const TestSurface shell(test::boundary_surface_of(ball.mesh));

  PairContacts tet_contacts = detect_pair(ball.mesh.positions, ball.mesh.tets, ball.topology,
                                          box.mesh.positions, box.mesh.tets, box.topology);
  tet_contacts.nodes_b_in_a.clear();  // the ball-in-box direction alone
  tet_contacts.edges_b_in_a.clear();
  const ResponseOptions options = options_for(ResponseKind::kPoint);
  const auto tet_ball = compute_pair_response(ball.view(), box.view(), tet_contacts, options);
  ASSERT_TRUE(tet_ball.has_value()) << tet_ball.error().message;
  const auto surface =
      compute_pair_response(shell.view(), box.view(), surface_contacts(shell, box, true), options);
  ASSERT_TRUE(surface.has_value()) << surface.error().message;

  std::map<Index, Vector3d> expected;
  for (std::size_t i = 0; i < tet_ball->a.nodes.size(); ++i)
    if (ball.topology.is_boundary_node[static_cast<std::size_t>(tet_ball->a.nodes[i])] != 0)
      expected[tet_ball->a.nodes[i]] = tet_ball->a.forces[i];
  ASSERT_GT(expected.size(), 10u);
  ASSERT_EQ(surface->a.nodes.size(), expected.size());
  for (std::size_t i = 0; i < surface->a.nodes.size(); ++i) {
    const Index node = surface->a.nodes[i];
    ASSERT_TRUE(expected.count(node)) << "node " << node;
    EXPECT_LT((surface->a.forces[i] - expected[node]).norm(), 1e-9 * expected[node].norm())
        << "node " << node;
  }
}

// kAuto measures the surface's contact triangles: three edges each.
TEST(SurfaceResponse, AutoRuleMeasuresTriangles) {
  const test::TestObject box = unit_box();
  const TestSurface coarse = plate_at(0.98);  // 0.1 m cells: edges 0.1, 0.1, 0.1 sqrt(2)
  const PairContacts contacts = surface_contacts(coarse, box, true);
  const ContactDensity d =
      measure_contact_density(coarse.view(), contacts.marked_a, box.view(), contacts.marked_b);
  EXPECT_NEAR(d.rms_edge, 0.1 * std::sqrt(4.0 / 3.0), 1e-12);
  EXPECT_GT(d.contact_extent, 0.5);
}

TEST(SurfaceResponse, BadInputNamesWhatIsWrong) {
  const test::TestObject box = unit_box();
  const TestSurface plate = plate_at(0.98);
  const PairContacts contacts = surface_contacts(plate, box, true);
  const ResponseOptions options = options_for(ResponseKind::kPoint);
  const auto message = [&](const ResponseObject& a, const ResponseObject& b,
                           const PairContacts& c) {
    const auto got = compute_pair_response(a, b, c, options);
    return got.has_value() ? std::string("accepted") : got.error().message;
  };
  // A surface has no depth map.
  std::vector<double> depth(static_cast<std::size_t>(plate.mesh.num_nodes()), 0.0);
  ResponseObject with_depth = plate.view();
  with_depth.depth = depth;
  EXPECT_NE(message(with_depth, box.view(), contacts).find("a surface has no depth map"),
            std::string::npos);
  // Nothing is pushed out of a surface.
  PairContacts swapped = contacts;
  swapped.nodes_b_in_a = swapped.nodes_a_in_b;
  EXPECT_NE(message(plate.view(), box.view(), swapped).find("A is a surface"), std::string::npos);
  // Two surfaces.
  EXPECT_NE(message(plate.view(), plate.view(), contacts).find("both surfaces"), std::string::npos);
  // A marked triangle out of range.
  PairContacts bad = contacts;
  bad.marked_a.push_back(static_cast<Index>(plate.mesh.triangles.size()));
  EXPECT_NE(message(plate.view(), box.view(), bad)
                .find("marked_a[" + std::to_string(bad.marked_a.size() - 1) +
                      "]: triangle 72 out of range"),
            std::string::npos);
  // A surface topology with tets.
  ResponseObject wrong_topology = plate.view();
  wrong_topology.topology = &box.topology;
  EXPECT_NE(message(wrong_topology, box.view(), contacts).find("topology"), std::string::npos);
}

}  // namespace
}  // namespace tc
