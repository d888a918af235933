// service/core/detect/detect: the whole stage against brute force over all tet pairs,
// every broad phase, touching and nested objects, thread-count independence, offsets
// and scales, and the reusable Detector across frames.
#include "core/detect/detect.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <set>
#include <tuple>

#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/validate.hpp"
#include "kernel_copies.hpp"
#include "sanitizer.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kRel = kDefaultRelativeTolerance;

TetMesh moved(TetMesh m, const Eigen::Matrix3d& rotation, const Vector3d& offset,
              double scale = 1.0) {
  for (Eigen::Index i = 0; i < m.positions.cols(); ++i)
    m.positions.col(i) = scale * (rotation * m.positions.col(i)) + offset;
  return m;
}

/// Three draws in order (see random_rotation).
template <class Dist>
Eigen::Vector3d draw3(Dist& d, std::mt19937& rng) {
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = d(rng);
  return v;
}

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  // One draw per statement: the order in which function arguments are evaluated is
  // unspecified (gcc and clang differ), and every compiler must see the same rotation.
  std::array<double, 4> c{};
  for (double& v : c) v = n(rng);
  Eigen::Quaterniond q(c[0], c[1], c[2], c[3]);
  return q.normalized().toRotationMatrix();
}

struct Object {
  TetMesh mesh;
  Topology topo;
  explicit Object(TetMesh m)
      : mesh(std::move(m)), topo(build_topology(mesh.tets, mesh.num_nodes())) {}
};

/// A 4^3-cell unit box and a 3^3-cell one overlapping its corner: nodes and edges of each
/// inside the other, and a few hundred overlapping pairs.
struct CornerBoxes {
  Object a{test::structured_box(4, 4, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 1))};
  Object b{test::structured_box(3, 3, 3, Vector3d(0.5, 0.4, 0.3), Vector3d(1.5, 1.4, 1.3))};
  /// A body of `o` (a or b, which it reads: the boxes must outlive it) at its positions.
  static CollisionBody body(const Object& o) {
    CollisionBody x(o.mesh.tets, o.topo);
    x.set_positions(o.mesh.positions);
    return x;
  }
};

PairContacts run(const Object& a, const Object& b, DetectOptions opt = {},
                 DetectStats* stats = nullptr) {
  return detect_pair(a.mesh.positions, a.mesh.tets, a.topo, b.mesh.positions, b.mesh.tets, b.topo,
                     opt, stats);
}

// ------------------------------------------------------------------ brute-force reference

/// The contract of PairContacts, computed the slow way: all pairs, every node, every edge.
PairContacts brute_force(const Object& a, const Object& b) {
  PairContacts out;
  const auto& ma = a.mesh;
  const auto& mb = b.mesh;
  std::set<std::pair<Index, Index>> ov;
  for (Index ta = 0; ta < ma.num_tets(); ++ta)
    for (Index tb = 0; tb < mb.num_tets(); ++tb) {
      const TetCorners ca = tet_corners(ma.positions, ma.tets[ta]);
      const TetCorners cb = tet_corners(mb.positions, mb.tets[tb]);
      if (tets_overlap(ca, cb, kRel * pair_scale(ca, cb))) {
        out.overlapping.push_back({ta, tb});
        ov.insert({ta, tb});
      }
    }
  std::set<Index> sa, sb;
  for (const auto& p : out.overlapping) {
    sa.insert(p.tet_a);
    sb.insert(p.tet_b);
  }
  out.marked_a.assign(sa.begin(), sa.end());
  out.marked_b.assign(sb.begin(), sb.end());

  // Tets of the other object overlapping each tet (rows ascending: `ov` is sorted by
  // (ta, tb)). A node or edge is tested only against tets overlapping one of its own
  // tets, in ascending tet order, as the contract says.
  std::vector<std::vector<Index>> near_ab(static_cast<std::size_t>(ma.num_tets()));
  std::vector<std::vector<Index>> near_ba(static_cast<std::size_t>(mb.num_tets()));
  for (const auto& [ta, tb] : ov) {
    near_ab[static_cast<std::size_t>(ta)].push_back(tb);
    near_ba[static_cast<std::size_t>(tb)].push_back(ta);
  }
  for (int side = 0; side < 2; ++side) {
    const Object& x = side == 0 ? a : b;
    const Object& y = side == 0 ? b : a;
    const auto& near_of = side == 0 ? near_ab : near_ba;
    const auto candidates = [&](const auto& own_tets) {
      std::set<Index> c;
      for (const Index tx : own_tets) {
        const auto& row = near_of[static_cast<std::size_t>(tx)];
        c.insert(row.begin(), row.end());
      }
      return c;
    };
    auto& nodes = side == 0 ? out.nodes_a_in_b : out.nodes_b_in_a;
    for (Index n = 0; n < x.mesh.num_nodes(); ++n)
      for (const Index ty : candidates(x.topo.node_tets.row(n))) {
        const TetCorners ct = tet_corners(y.mesh.positions, y.mesh.tets[ty]);
        const PointInTet r = point_in_tet(x.mesh.positions.col(n), ct, kRel * tet_scale(ct));
        if (r.inside) {
          nodes.push_back({n, ty, r.bary});
          break;
        }
      }
    auto& edges = side == 0 ? out.edges_a_in_b : out.edges_b_in_a;
    for (Index e = 0; e < static_cast<Index>(x.topo.edges.size()); ++e) {
      const auto [u, v] = x.topo.edges[e];
      const Vector3d p0 = x.mesh.positions.col(u), p1 = x.mesh.positions.col(v);
      const double len = (p1 - p0).norm();
      const std::size_t first = edges.size();
      std::vector<Index> edge_tets;  // the tets holding both ends
      for (const Index tx : x.topo.node_tets.row(u)) {
        const Tet& t = x.mesh.tets[tx];
        if (std::count(t.begin(), t.end(), v)) edge_tets.push_back(tx);
      }
      for (const Index ty : candidates(edge_tets)) {
        const TetCorners ct = tet_corners(y.mesh.positions, y.mesh.tets[ty]);
        const double tol = kRel * std::max(tet_scale(ct), len);
        const SegmentClip c = clip_segment_tet(p0, p1, ct, tol);
        if (!c.hit) continue;
        bool repeated = false;
        for (std::size_t k = first; k < edges.size(); ++k)
          repeated = repeated || (std::abs(edges[k].lambda_in - c.lambda_in) <= tol / len &&
                                  std::abs(edges[k].lambda_out - c.lambda_out) <= tol / len);
        if (!repeated) edges.push_back({e, ty, c.lambda_in, c.lambda_out});
      }
    }
  }
  return out;
}

void expect_same_nodes(const std::vector<IntrudingNode>& got,
                       const std::vector<IntrudingNode>& want, const char* what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].node, want[i].node) << what << " " << i;
    EXPECT_EQ(got[i].tet, want[i].tet) << what << " " << i;
    EXPECT_EQ(got[i].bary, want[i].bary) << what << " " << i;
  }
}

void expect_same_edges(const std::vector<IntrudingEdge>& got,
                       const std::vector<IntrudingEdge>& want, const char* what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].edge, want[i].edge) << what << " " << i;
    EXPECT_EQ(got[i].tet, want[i].tet) << what << " " << i;
    EXPECT_EQ(got[i].lambda_in, want[i].lambda_in) << what << " " << i;
    EXPECT_EQ(got[i].lambda_out, want[i].lambda_out) << what << " " << i;
  }
}

/// Bit-for-bit equality of two results.
void expect_identical(const PairContacts& got, const PairContacts& want) {
  EXPECT_EQ(got.overlapping, want.overlapping);
  EXPECT_EQ(got.marked_a, want.marked_a);
  EXPECT_EQ(got.marked_b, want.marked_b);
  expect_same_nodes(got.nodes_a_in_b, want.nodes_a_in_b, "nodes_a_in_b");
  expect_same_nodes(got.nodes_b_in_a, want.nodes_b_in_a, "nodes_b_in_a");
  expect_same_edges(got.edges_a_in_b, want.edges_a_in_b, "edges_a_in_b");
  expect_same_edges(got.edges_b_in_a, want.edges_b_in_a, "edges_b_in_a");
}

/// Runs two detectors whose options differ only in cost (cluster cull, kept pairs) on
/// (a, b): the contacts are not empty, and the candidates and contacts are the same.
void expect_same_detection(Detector& with, Detector& without, CollisionBody& a, CollisionBody& b,
                           DetectStats& st_with, DetectStats& st_without) {
  PairContacts got, want;
  with.detect(a, b, got, &st_with);
  without.detect(a, b, want, &st_without);
  EXPECT_FALSE(want.overlapping.empty());
  EXPECT_TRUE(std::ranges::equal(with.candidates(), without.candidates()));
  expect_identical(got, want);
}

/// Sorted, duplicate-free and within the documented ranges.
void expect_well_formed(const PairContacts& c) {
  EXPECT_TRUE(std::is_sorted(c.overlapping.begin(), c.overlapping.end()));
  EXPECT_TRUE(std::adjacent_find(c.overlapping.begin(), c.overlapping.end()) ==
              c.overlapping.end());
  for (const auto* nodes : {&c.nodes_a_in_b, &c.nodes_b_in_a})
    for (std::size_t i = 0; i < nodes->size(); ++i) {
      const auto& n = (*nodes)[i];
      if (i > 0) {
        EXPECT_LT((*nodes)[i - 1].node, n.node);
      }
      EXPECT_FALSE(n.bary.hasNaN());
      EXPECT_NEAR(n.bary.sum(), 1.0, 1e-9);
      EXPECT_GE(n.bary.minCoeff(), -1e-6);
    }
  for (const auto* edges : {&c.edges_a_in_b, &c.edges_b_in_a})
    for (std::size_t i = 0; i < edges->size(); ++i) {
      const auto& e = (*edges)[i];
      if (i > 0) {
        const auto& p = (*edges)[i - 1];
        EXPECT_TRUE(p.edge < e.edge || (p.edge == e.edge && p.tet < e.tet));
      }
      EXPECT_LE(0.0, e.lambda_in);
      EXPECT_LT(e.lambda_in, e.lambda_out);
      EXPECT_LE(e.lambda_out, 1.0);
    }
}

const auto kAllKinds = ::testing::Values(BroadPhaseKind::kGrid, BroadPhaseKind::kHash,
                                         BroadPhaseKind::kSap, BroadPhaseKind::kBvh);

std::string kind_name(const ::testing::TestParamInfo<BroadPhaseKind>& info) {
  return std::string(broad_phase_name(info.param));
}

// ------------------------------------------------------------------------------- tests

class DetectEachBroadPhase : public ::testing::TestWithParam<BroadPhaseKind> {};

TEST_P(DetectEachBroadPhase, RandomPosesMatchBruteForce) {
  std::mt19937 rng(2004);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  // Boxes centred on the origin, rotated about their centres.
  const TetMesh box =
      test::structured_box(4, 3, 3, Vector3d(-0.5, -0.4, -0.35), Vector3d(0.5, 0.4, 0.35));
  const TetMesh other =
      test::structured_box(3, 3, 2, Vector3d(-0.3, -0.3, -0.25), Vector3d(0.3, 0.3, 0.25));
  DetectOptions opt;
  opt.broad_phase = GetParam();
  int with_contacts = 0;
  for (int pose = 0; pose < 8; ++pose) {
    const Matrix3d ra = random_rotation(rng);
    const Vector3d ta = draw3(u, rng);
    const Object a(moved(box, ra, ta));
    const Matrix3d rb = random_rotation(rng);
    const Vector3d tb = Vector3d(0.3, 0, 0) + draw3(u, rng);
    const Object b(moved(other, rb, tb));
    DetectStats st;
    const PairContacts got = run(a, b, opt, &st);
    const PairContacts want = brute_force(a, b);
    expect_identical(got, want);
    expect_well_formed(got);
    EXPECT_EQ(st.overlapping, got.overlapping.size());
    EXPECT_GE(st.candidates, st.overlapping);
    with_contacts += !got.empty();
  }
  EXPECT_GE(with_contacts, 6);
}

TEST_P(DetectEachBroadPhase, AlignedGridsMatchBruteForce) {
  // Same spacing, offset by whole cells: faces, edges and nodes of A lie exactly on
  // those of B (shared planes everywhere). Once in grid order, once with both meshes'
  // tets shuffled: a node of A on a face, edge or corner of B lies in several tets of B,
  // and the one reported is the first in tet order, whatever order the tets around the
  // node reach them in (in grid order they come in ascending order, so only the shuffled
  // meshes check that).
  std::mt19937 rng(2026);
  for (const bool shuffle : {false, true}) {
    SCOPED_TRACE(shuffle ? "tets shuffled" : "tets in grid order");
    const auto mesh = [&](const Vector3d& lo, const Vector3d& hi) {
      TetMesh m = test::structured_box(4, 4, 4, lo, hi);
      if (shuffle) std::shuffle(m.tets.begin(), m.tets.end(), rng);
      return m;
    };
    const Object a(mesh(Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
    const Object b(mesh(Vector3d(0.5, 0.25, 0.5), Vector3d(1.5, 1.25, 1.5)));
    DetectOptions opt;
    opt.broad_phase = GetParam();
    const PairContacts got = run(a, b, opt);
    expect_identical(got, brute_force(a, b));
    expect_well_formed(got);
    EXPECT_FALSE(got.edges_a_in_b.empty());
    EXPECT_FALSE(got.nodes_a_in_b.empty());
    EXPECT_FALSE(got.nodes_b_in_a.empty());
  }
}

// Meshes nobody here shaped (tests/data/meshes/foreign: a Gmsh HXT cylinder with two
// orphan nodes, a TetGen genus-1 tube, 1-based), posed so that the cylinder passes
// through the tube's hole and its wall: every broad phase against brute force (all
// 1.57 M tet pairs), once per pose; under sanitizers (15x slower) on one pose.
TEST(Detect, ForeignMeshesMatchBruteForceWithEveryBroadPhase) {
  auto cylinder = read_mesh(test::data_path("meshes/foreign/cylinder_hxt.msh"));
  auto tube = read_mesh(test::data_path("meshes/foreign/tube.1.node"));
  ASSERT_TRUE(cylinder) << cylinder.error().message;
  ASSERT_TRUE(tube) << tube.error().message;
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> u(-0.06, 0.06);
  const Object a(*tube);
  const int poses = test::kSanitized ? 1 : 3;
  for (int pose = 0; pose < poses; ++pose) {
    SCOPED_TRACE(pose);
    const Matrix3d r = random_rotation(rng);
    const Vector3d t = draw3(u, rng) + Vector3d(0, 0, 0.05);
    const Object b(moved(*cylinder, r, t));
    const PairContacts want = brute_force(a, b);
    EXPECT_FALSE(want.overlapping.empty());
    for (const BroadPhaseKind kind : {BroadPhaseKind::kGrid, BroadPhaseKind::kHash,
                                      BroadPhaseKind::kSap, BroadPhaseKind::kBvh}) {
      SCOPED_TRACE(broad_phase_name(kind));
      DetectOptions opt;
      opt.broad_phase = kind;
      const PairContacts got = run(a, b, opt);
      expect_identical(got, want);
      expect_well_formed(got);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Detect, DetectEachBroadPhase, kAllKinds, kind_name);

TEST(Detect, EveryBroadPhaseGivesTheSameContacts) {
  std::mt19937 rng(11);
  const Vector3d h(0.5, 0.5, 0.5);
  const Object a(
      moved(test::structured_box(6, 6, 6, -h, h), random_rotation(rng), Vector3d::Zero()));
  const Object b(
      moved(test::structured_box(5, 5, 5, -h, h), random_rotation(rng), Vector3d(0.5, 0.4, 0.3)));
  DetectOptions opt;
  opt.broad_phase = BroadPhaseKind::kGrid;
  const PairContacts ref = run(a, b, opt);
  EXPECT_GT(ref.overlapping.size(), 100u);
  for (const auto k : {BroadPhaseKind::kHash, BroadPhaseKind::kSap, BroadPhaseKind::kBvh}) {
    opt.broad_phase = k;
    expect_identical(run(a, b, opt), ref);
  }
}

TEST(Detect, StackedBoxesTouchWithoutOverlap) {
  // B sits exactly on A's top face (z = 1), grids aligned and not.
  const Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  for (const int n : {3, 4}) {
    const Object b(test::structured_box(n, n, 2, Vector3d(0, 0, 1), Vector3d(1, 1, 2)));
    DetectStats st;
    const PairContacts c = run(a, b, {}, &st);
    EXPECT_TRUE(st.boxes_overlap);
    EXPECT_GT(st.candidates, 0u);
    EXPECT_TRUE(c.empty()) << c.overlapping.size() << " overlaps for n = " << n;
    EXPECT_TRUE(c.nodes_a_in_b.empty());
    EXPECT_TRUE(c.edges_b_in_a.empty());
  }
}

TEST(Detect, PushedAcrossTheToleranceOverlap) {
  const Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  for (const double push : {1e-12, 1e-6, 1e-3}) {
    const Object b(
        test::structured_box(3, 3, 2, Vector3d(0, 0, 1 - push), Vector3d(1, 1, 2 - push)));
    const PairContacts c = run(a, b);
    if (push < kRel) {
      EXPECT_TRUE(c.empty()) << push;
    } else {
      EXPECT_FALSE(c.empty()) << push;
      // Every bottom node of B is in A, on the shared top face of A's tets.
      EXPECT_EQ(c.nodes_b_in_a.size(), 16u) << push;
      EXPECT_EQ(c.nodes_a_in_b.size(), 16u) << push;  // and every top node of A in B
    }
  }
}

TEST(Detect, NestedBoxIsEntirelyInside) {
  for (const bool aligned : {true, false}) {
    const Object outer(test::structured_box(4, 4, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
    const Vector3d lo = aligned ? Vector3d(0.25, 0.25, 0.25) : Vector3d(0.21, 0.33, 0.27);
    const Object inner(test::structured_box(3, 2, 2, lo, lo + Vector3d(0.5, 0.5, 0.5)));
    const PairContacts c = run(inner, outer);
    expect_well_formed(c);
    EXPECT_EQ(c.marked_a.size(), static_cast<std::size_t>(inner.mesh.num_tets()));
    EXPECT_EQ(c.nodes_a_in_b.size(), static_cast<std::size_t>(inner.mesh.num_nodes()));
    // Nodes of the outer box inside the closed inner one, and only those.
    std::size_t inside = 0;
    for (Index n = 0; n < outer.mesh.num_nodes(); ++n) {
      const Vector3d p = outer.mesh.positions.col(n);
      inside += ((p - lo).array() >= -1e-12).all() &&
                ((lo + Vector3d::Constant(0.5) - p).array() >= -1e-12).all();
    }
    EXPECT_EQ(c.nodes_b_in_a.size(), inside);
    EXPECT_GT(inside, 0u);
    for (const auto& n : c.nodes_a_in_b) {
      const TetCorners t = tet_corners(outer.mesh.positions, outer.mesh.tets[n.tet]);
      const Vector3d p = n.bary[0] * t[0] + n.bary[1] * t[1] + n.bary[2] * t[2] + n.bary[3] * t[3];
      EXPECT_LT((p - inner.mesh.positions.col(n.node)).norm(), 1e-12);
    }
    // Every edge of the inner box is inside the outer one: its intervals cover [0, 1]
    // exactly once (edges lying on shared faces are not counted twice).
    std::vector<double> covered(inner.topo.edges.size(), 0.0);
    for (const auto& e : c.edges_a_in_b) covered[e.edge] += e.lambda_out - e.lambda_in;
    for (std::size_t e = 0; e < covered.size(); ++e)
      EXPECT_NEAR(covered[e], 1.0, 1e-9) << "edge " << e << (aligned ? " aligned" : "");
  }
}

TEST(Detect, DisjointBoxesCostOnlyTheBoxTest) {
  const Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  const Object b(test::structured_box(3, 3, 3, Vector3d(1.01, 0, 0), Vector3d(2, 1, 1)));
  DetectStats st;
  const PairContacts c = run(a, b, {}, &st);
  EXPECT_FALSE(st.boxes_overlap);
  EXPECT_EQ(st.candidates, 0u);
  EXPECT_EQ(st.tets_a_in_box, 0u);
  EXPECT_TRUE(c.empty());
}

TEST(Detect, OptionsSwitchOffNodesAndEdges) {
  const Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  const Object b(test::structured_box(3, 3, 3, Vector3d(0.5, 0.4, 0.3), Vector3d(1.5, 1.4, 1.3)));
  DetectOptions opt;
  const PairContacts full = run(a, b, opt);
  ASSERT_FALSE(full.nodes_a_in_b.empty());
  ASSERT_FALSE(full.edges_a_in_b.empty());
  opt.intruding_nodes = false;
  PairContacts c = run(a, b, opt);
  EXPECT_EQ(c.overlapping, full.overlapping);
  EXPECT_TRUE(c.nodes_a_in_b.empty() && c.nodes_b_in_a.empty());
  EXPECT_EQ(c.edges_a_in_b.size(), full.edges_a_in_b.size());
  opt.intruding_edges = false;
  c = run(a, b, opt);
  EXPECT_TRUE(c.edges_a_in_b.empty() && c.edges_b_in_a.empty());
}

TEST(Detect, EdgeNeedLeavesOutTheDirectionsItDeclines) {
  // The pipeline asks, once the overlaps are known, which directions the response will
  // answer with segments; the other directions' edges are not computed, the rest is the same.
  const CornerBoxes boxes;
  const Object& a = boxes.a;
  const Object& b = boxes.b;
  CollisionBody ba = CornerBoxes::body(a), bb = CornerBoxes::body(b);
  Detector detector;
  PairContacts full;
  detector.detect(ba, bb, full);
  ASSERT_FALSE(full.edges_a_in_b.empty());
  ASSERT_FALSE(full.edges_b_in_a.empty());
  for (const std::array<bool, 2> need :
       {std::array<bool, 2>{true, false}, std::array<bool, 2>{false, true},
        std::array<bool, 2>{false, false}}) {
    PairContacts c;
    int asked = 0;
    detector.detect(ba, bb, c, nullptr, [&](const PairContacts& so_far) {
      ++asked;
      EXPECT_EQ(so_far.overlapping, full.overlapping);  // what the choice reads is complete
      EXPECT_EQ(so_far.marked_a, full.marked_a);
      EXPECT_EQ(so_far.marked_b, full.marked_b);
      return need;
    });
    EXPECT_EQ(asked, 1);
    EXPECT_EQ(c.overlapping, full.overlapping);
    expect_same_nodes(c.nodes_a_in_b, full.nodes_a_in_b, "nodes_a_in_b");
    expect_same_nodes(c.nodes_b_in_a, full.nodes_b_in_a, "nodes_b_in_a");
    expect_same_edges(c.edges_a_in_b, need[0] ? full.edges_a_in_b : std::vector<IntrudingEdge>{},
                      "edges_a_in_b");
    expect_same_edges(c.edges_b_in_a, need[1] ? full.edges_b_in_a : std::vector<IntrudingEdge>{},
                      "edges_b_in_a");
  }
  // Without overlap nothing is asked.
  const Object far(test::structured_box(2, 2, 2, Vector3d(5, 0, 0), Vector3d(6, 1, 1)));
  CollisionBody bf(far.mesh.tets, far.topo);
  bf.set_positions(far.mesh.positions);
  PairContacts none;
  detector.detect(ba, bf, none, nullptr, [](const PairContacts&) -> std::array<bool, 2> {
    ADD_FAILURE() << "asked without overlap";
    return {true, true};
  });
  EXPECT_TRUE(none.empty());
}

class ThreadCount : public ::testing::TestWithParam<BroadPhaseKind> {};

TEST_P(ThreadCount, OutputIsBitIdenticalWith1To4Threads) {
  std::mt19937 rng(42);
  // Unit cubes rotated about their centres, centres 0.88 apart: each holds a ball of
  // radius 0.5, so they overlap whatever the rotations.
  const Vector3d lo = Vector3d::Constant(-0.5), hi = Vector3d::Constant(0.5);
  const Matrix3d ra = random_rotation(rng);
  const Object a(moved(test::structured_box(12, 12, 12, lo, hi), ra, Vector3d::Zero()));
  const Matrix3d rb = random_rotation(rng);
  const Object b(moved(test::structured_box(10, 10, 10, lo, hi), rb, Vector3d(0.6, 0.5, 0.4)));
  DetectOptions opt;
  opt.broad_phase = GetParam();
  std::vector<PairContacts> results;
  for (const int threads : {1, 2, 3, 4}) {
    tbb::task_arena arena(threads);
    arena.execute([&] { results.push_back(run(a, b, opt)); });
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    results.push_back(run(a, b, opt));
  }
  ASSERT_GT(results[0].overlapping.size(), 1000u);
  for (std::size_t i = 1; i < results.size(); ++i) expect_identical(results[i], results[0]);
}

INSTANTIATE_TEST_SUITE_P(Detect, ThreadCount, kAllKinds, kind_name);

// Each thread keeps its own copy of the tet geometry from call to call (built when it first
// needs a tet in a call; all of it up front when one thread runs the call). One Detector over
// frames that move the bodies, each frame on another number of threads, must give what a
// fresh one-thread detection gives: no geometry of an earlier frame or of another thread used.
TEST(Detect, AReusedDetectorOnChangingThreadCountsGivesWhatAFreshOneGives) {
  std::mt19937 rng(7);
  const Vector3d lo = Vector3d::Constant(-0.5), hi = Vector3d::Constant(0.5);
  const Object a(
      moved(test::structured_box(9, 9, 9, lo, hi), random_rotation(rng), Vector3d::Zero()));
  Object b(
      moved(test::structured_box(8, 8, 8, lo, hi), random_rotation(rng), Vector3d(0.75, 0.2, 0.1)));
  const Positions rest_b = b.mesh.positions;
  CollisionBody ba(a.mesh.tets, a.topo), bb(b.mesh.tets, b.topo);
  Detector detector;
  const std::array<int, 7> threads = {2, 1, 3, 0, 2, 4, 1};  // 0: TBB's global limit of 1
  for (std::size_t frame = 0; frame < threads.size(); ++frame) {
    // B slides in, then a bulge on part of it, then back out (the set of tets changes).
    const double depth = 0.06 * static_cast<double>(frame < 4 ? frame : 7 - frame);
    b.mesh.positions = rest_b;
    for (Eigen::Index i = 0; i < b.mesh.positions.cols(); ++i) {
      b.mesh.positions(0, i) -= depth;
      if (frame == 3 && b.mesh.positions(1, i) > 0.2) b.mesh.positions(0, i) -= 0.05;
    }
    ba.set_positions(a.mesh.positions);
    bb.set_positions(b.mesh.positions);
    PairContacts got;
    const auto detect = [&] { detector.detect(ba, bb, got); };
    if (threads[frame] == 0) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      detect();
    } else {
      tbb::task_arena arena(threads[frame]);
      arena.execute(detect);
    }
    PairContacts want;
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      want = run(a, b);
    }
    ASSERT_GT(want.overlapping.size(), frame == 0 ? 0u : 100u) << "frame " << frame;
    SCOPED_TRACE("frame " + std::to_string(frame) + ", threads " + std::to_string(threads[frame]));
    expect_identical(got, want);
  }
}

using Frame = std::tuple<double, double>;  // scale, offset

class OffsetsAndScales : public ::testing::TestWithParam<Frame> {};

TEST_P(OffsetsAndScales, SameContactsAsAtTheOrigin) {
  const auto [scale, offset] = GetParam();
  std::mt19937 rng(31);
  const TetMesh ma = moved(test::structured_box(5, 4, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 1)),
                           random_rotation(rng), Vector3d::Zero());
  const TetMesh mb = moved(test::structured_box(4, 4, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 1)),
                           random_rotation(rng), Vector3d(0.55, 0.45, 0.35));
  const Object a0(ma), b0(mb);
  const PairContacts ref = run(a0, b0);
  ASSERT_GT(ref.overlapping.size(), 50u);
  const Vector3d o = Vector3d(1.0, -0.6, 0.8) * offset;
  const Object a(moved(ma, Eigen::Matrix3d::Identity(), o, scale));
  const Object b(moved(mb, Eigen::Matrix3d::Identity(), o, scale));
  const PairContacts c = run(a, b);
  expect_well_formed(c);
  EXPECT_EQ(c.overlapping, ref.overlapping);
  EXPECT_EQ(c.marked_a, ref.marked_a);
  EXPECT_EQ(c.marked_b, ref.marked_b);
  ASSERT_EQ(c.nodes_a_in_b.size(), ref.nodes_a_in_b.size());
  for (std::size_t i = 0; i < c.nodes_a_in_b.size(); ++i) {
    EXPECT_EQ(c.nodes_a_in_b[i].node, ref.nodes_a_in_b[i].node);
    EXPECT_LT((c.nodes_a_in_b[i].bary - ref.nodes_a_in_b[i].bary).cwiseAbs().maxCoeff(), 1e-5);
  }
  ASSERT_EQ(c.edges_a_in_b.size(), ref.edges_a_in_b.size());
  for (std::size_t i = 0; i < c.edges_a_in_b.size(); ++i) {
    EXPECT_EQ(c.edges_a_in_b[i].edge, ref.edges_a_in_b[i].edge);
    EXPECT_NEAR(c.edges_a_in_b[i].lambda_in, ref.edges_a_in_b[i].lambda_in, 1e-5);
    EXPECT_NEAR(c.edges_a_in_b[i].lambda_out, ref.edges_a_in_b[i].lambda_out, 1e-5);
  }
}

INSTANTIATE_TEST_SUITE_P(Detect, OffsetsAndScales,
                         ::testing::Values(Frame{1e-6, 0.0}, Frame{1e-3, 0.0}, Frame{1e4, 0.0},
                                           Frame{1.0, 1e6}, Frame{1e3, 1e6}, Frame{1e-3, 1e3}));

TEST(Detector, ReusedAcrossFramesMatchesOneOffs) {
  const Object a(test::structured_box(6, 6, 6, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  const Object b0(test::structured_box(5, 5, 5, Vector3d(0, 0, 0), Vector3d(0.8, 0.8, 0.8)));
  for (const auto kind : {BroadPhaseKind::kBvh, BroadPhaseKind::kSap}) {
    DetectOptions opt;
    opt.broad_phase = kind;
    CollisionBody ba(a.mesh.tets, a.topo), bb(b0.mesh.tets, b0.topo);
    Detector detector(opt);
    ba.set_positions(a.mesh.positions);
    for (int frame = 0; frame < 6; ++frame) {
      if (frame > 0) ba.reuse_positions();  // A at rest
      // B slides in and twists: the tree built on frame 0 is only refitted.
      const Eigen::Matrix3d r =
          Eigen::AngleAxisd(0.3 * frame, Vector3d(0.2, 0.5, 1).normalized()).toRotationMatrix();
      Object b(moved(b0.mesh, r, Vector3d(1.2 - 0.2 * frame, 0.1, 0.15)));
      Positions pb = b.mesh.positions;
      bb.set_positions(pb);
      PairContacts got;
      DetectStats st;
      detector.detect(ba, bb, got, &st);
      expect_identical(got, run(a, b, opt));
      if (frame >= 2) {
        EXPECT_FALSE(got.empty()) << frame;
      }
      EXPECT_EQ(detector.candidates().size(), st.candidates);
    }
  }
}

// A small tool pressed into a large object (issue 13): with the cluster cull only the
// tets near the tool get bounds, and the contacts are exactly those of the full pass,
// for every broad phase, with the large object as A or as B (kBvh: B's few tets in a
// tree of their own, or B's persistent tree), over frames that move the tool.
TEST(Detect, ClusterCullGivesTheFullPassContactsAndLooksAtFewTets) {
  // The same mesh under the sanitizers: a coarser one puts a tenth of its tets near the
  // tool (clusters of 64 tets are then as wide as the tool).
  const int n = 24;
  const Object large(test::structured_box(n, n, n / 3, Vector3d(0, 0, 0), Vector3d(1, 1, 0.3)));
  const TetMesh tool0 = test::ball_mesh(3, 0.06);
  for (const BroadPhaseKind kind :
       {BroadPhaseKind::kGrid, BroadPhaseKind::kHash, BroadPhaseKind::kSap, BroadPhaseKind::kBvh}) {
    for (const bool large_is_a : {true, false}) {
      SCOPED_TRACE(std::string(broad_phase_name(kind)) + (large_is_a ? " large=a" : " large=b"));
      DetectOptions on, off;
      on.broad_phase = off.broad_phase = kind;
      off.cluster_cull = false;
      CollisionBody body_large(large.mesh.tets, large.topo);
      const Object tool_rest(tool0);
      CollisionBody body_tool(tool_rest.mesh.tets, tool_rest.topo);
      Detector with(on), without(off);
      body_large.set_positions(large.mesh.positions);
      for (int frame = 0; frame < 4; ++frame) {
        SCOPED_TRACE(frame);
        // The large object is at rest: its box, cluster boxes, bounds and tree are kept.
        if (frame > 0) body_large.reuse_positions();
        // Pressed 2 cm into the top face, sliding across it.
        const Object tool(moved(tool0, Matrix3d::Identity(),
                                Vector3d(0.3 + 0.1 * frame, 0.45, 0.3 + 0.06 - 0.02)));
        body_tool.set_positions(tool.mesh.positions);
        CollisionBody& a = large_is_a ? body_large : body_tool;
        CollisionBody& b = large_is_a ? body_tool : body_large;
        DetectStats st_on, st_off;
        expect_same_detection(with, without, a, b, st_on, st_off);
        const std::size_t large_near = large_is_a ? st_on.tets_a_near : st_on.tets_b_near;
        EXPECT_EQ(large_is_a ? st_off.tets_a_near : st_off.tets_b_near, large.mesh.tets.size());
        EXPECT_LT(large_near * 10, large.mesh.tets.size()) << large_near;
      }
    }
  }
}

// The cluster boxes are refitted only inside the groups of clusters that meet the region,
// or all of them when last frame's contact met most groups. Over frames that deform the
// large object, alternate a small press (few groups) with a wide one (most groups: the
// next frame refits every cluster) and put a NaN node far from the tool, the near tets
// are those a new body (first frame: groups) gives, and the contacts those of the full
// pass.
// (With each copy of the kernels: the body's comparison of its nodes with their references
// runs in AVX2 and baseline copies.)
using test::BothKernels;

TEST_P(BothKernels, ClusterGroupsGiveTheNearTetsOfEveryClusterWhateverLastFrameDid) {
  const Object large(test::structured_box(24, 24, 8, Vector3d(0, 0, 0), Vector3d(1, 1, 0.3)));
  const TetMesh small_tool = test::ball_mesh(3, 0.06);
  const TetMesh wide_tool = test::ball_mesh(3, 0.9);
  DetectOptions on, off;
  off.cluster_cull = false;
  CollisionBody body_large(large.mesh.tets, large.topo);
  Detector with(on), without(off);
  std::mt19937 rng(77);
  std::normal_distribution<double> jitter(0.0, 1e-3);
  std::size_t fewest = large.mesh.tets.size(), most = 0;
  for (int frame = 0; frame < 8; ++frame) {
    SCOPED_TRACE(frame);
    Positions p = large.mesh.positions;
    // Jittered, and the whole object moved 3 cm a frame (stale cluster boxes would miss).
    const Vector3d shift(0.03 * frame, -0.02 * frame, 0.0);
    for (Eigen::Index i = 0; frame > 0 && i < p.cols(); ++i)
      for (int c = 0; c < 3; ++c) p(c, i) += jitter(rng) + shift[c];
    if (frame == 5) p(0, 0) = std::numeric_limits<double>::quiet_NaN();  // a far corner
    body_large.set_positions(p);
    const bool wide = frame % 3 == 1;
    const Object tool(wide
                          ? moved(wide_tool, Matrix3d::Identity(), Vector3d(0.5, 0.5, 1.02) + shift)
                          : moved(small_tool, Matrix3d::Identity(),
                                  Vector3d(0.3 + 0.05 * frame, 0.45, 0.34) + shift));
    CollisionBody body_tool(tool.mesh.tets, tool.topo);
    body_tool.set_positions(tool.mesh.positions);
    PairContacts got, want;
    DetectStats st;
    with.detect(body_large, body_tool, got, &st);
    without.detect(body_large, body_tool, want);
    EXPECT_FALSE(want.overlapping.empty());
    expect_identical(got, want);
    // The same near tets as a body with the same clusters (made from the first frame's
    // positions) that was not asked before, so refits its groups first.
    const Aabb region = body_large.box().intersection(body_tool.box());
    std::vector<Index> near, fresh_near;
    body_large.tets_near(region, near);
    CollisionBody fresh(large.mesh.tets, large.topo);
    fresh.set_positions(large.mesh.positions);  // the same clusters as body_large's
    fresh.set_positions(p);
    fresh.tets_near(region, fresh_near);
    EXPECT_EQ(near, fresh_near);
    EXPECT_EQ(near.size(), st.tets_a_near);
    fewest = std::min(fewest, near.size());
    most = std::max(most, near.size());
  }
  // Both kinds of frame happened: a press that looks at a tenth of the object at most,
  // and one that looks at more than half.
  EXPECT_LT(fewest * 10, large.mesh.tets.size()) << fewest;
  EXPECT_GT(most * 2, large.mesh.tets.size()) << most;
}

INSTANTIATE_TEST_SUITE_P(Detect, BothKernels, ::testing::Bool(), test::kernel_copy_name);

// tets_near()'s promise, checked tet by tet: every tet whose box meets the region is
// near. With node numbers in no spatial order (a mesher's, shuffled), frames that do not
// ask (the tool away), frames at rest, a NaN and an infinite coordinate, regions of the
// tool, small boxes and points anywhere (the corners of the object among them), asked of
// bodies that used groups last frame or were never asked; and the contacts are those of
// the full pass.
TEST(Detect, ClusterCullKeepsEveryTetThatMeetsTheRegion) {
  TetMesh shuffled = test::structured_box(28, 28, 8, Vector3d(0, 0, 0), Vector3d(1, 1, 0.3));
  {
    std::mt19937 rng(5);
    std::vector<Index> perm(static_cast<std::size_t>(shuffled.num_nodes()));
    std::iota(perm.begin(), perm.end(), Index{0});
    std::shuffle(perm.begin(), perm.end(), rng);  // old node -> new node
    Positions p(3, shuffled.num_nodes());
    for (Index i = 0; i < shuffled.num_nodes(); ++i)
      p.col(perm[static_cast<std::size_t>(i)]) = shuffled.positions.col(i);
    shuffled.positions = p;
    for (Tet& t : shuffled.tets)
      for (Index& v : t) v = perm[static_cast<std::size_t>(v)];
  }
  const Object large(shuffled);
  const TetMesh tool0 = test::ball_mesh(3, 0.07);
  DetectOptions on, off;
  off.cluster_cull = false;
  CollisionBody body(large.mesh.tets, large.topo);
  Detector with(on), without(off);
  std::mt19937 rng(9);
  std::normal_distribution<double> jitter(0.0, 5e-4);  // a seventieth of an edge
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Positions p = large.mesh.positions, prev = p;
  Vector3d shift = Vector3d::Zero();  // of the large object's positions, and the tool with it
  int asked = 0;
  // This frame's box of each tet (empty for a tet with a non-finite corner).
  std::vector<Aabb> tet_boxes;
  const auto make_tet_boxes = [&] {
    tet_boxes.assign(large.mesh.tets.size(), Aabb{});
    for (std::size_t t = 0; t < tet_boxes.size(); ++t) {
      bool finite = true;
      for (const Index v : large.mesh.tets[t]) {
        finite = finite && p.col(v).allFinite();
        tet_boxes[t].extend(Vector3d(p.col(v)));
      }
      if (!finite) tet_boxes[t] = Aabb{};
    }
  };
  // Every tet whose box meets `region` is near `of`.
  const auto check_near = [&](CollisionBody& of, const Aabb& region) {
    std::vector<Index> near;
    of.tets_near(region, near);
    std::size_t meeting = 0;
    for (std::size_t t = 0; t < tet_boxes.size(); ++t) {
      if (!tet_boxes[t].overlaps(region)) continue;
      ++meeting;
      if (!std::binary_search(near.begin(), near.end(), static_cast<Index>(t)))
        ADD_FAILURE() << "tet " << t << " meets the region but is not near";
    }
    return std::pair(meeting, near.size());
  };
  for (int frame = 0; frame < 12; ++frame) {
    SCOPED_TRACE(frame);
    const bool rest = frame % 4 == 3;  // the large object keeps last frame's positions
    if (rest) {
      body.reuse_positions();
    } else {
      // Moved by 30 cm at frames 4 and 8 (every node far from where it was); between,
      // jittered by less than the reach of a reference and bulged 3 cm out in a moving
      // spot (a few nodes far from where they were, outside their group's last box).
      shift = Vector3d(0.3, -0.2, 0.1) * static_cast<double>(frame / 4);
      prev = p;
      p = large.mesh.positions;
      const Vector3d bulge(0.8 - 0.02 * frame, 0.15 + 0.02 * frame, 0.0);  // away from the tool
      for (Eigen::Index i = 0; frame > 0 && i < p.cols(); ++i) {
        const double d = (p.col(i) - bulge).head<2>().norm();
        if (d < 0.12) p(2, i) += 0.03 * (1.0 - d / 0.12);
        for (int c = 0; c < 3; ++c) p(c, i) += jitter(rng) + shift[c];
      }
      if (frame == 6) p(1, 7) = std::numeric_limits<double>::quiet_NaN();
      if (frame == 9) p(2, 11) = std::numeric_limits<double>::infinity();
      body.set_positions(p);
    }
    make_tet_boxes();
    // Away from the object every third frame: that frame does not ask for near tets.
    const double lift = frame % 3 == 2 ? 1.0 : 0.0;
    const Object tool(moved(tool0, Matrix3d::Identity(),
                            Vector3d(0.2 + 0.06 * frame, 0.7 - 0.05 * frame, 0.35 + lift) + shift));
    CollisionBody body_tool(tool.mesh.tets, tool.topo);
    body_tool.set_positions(tool.mesh.positions);
    PairContacts got, want;
    with.detect(body, body_tool, got);
    without.detect(body, body_tool, want);
    expect_identical(got, want);
    if (lift > 0.0) {
      EXPECT_TRUE(want.overlapping.empty());
      continue;
    }
    ++asked;
    EXPECT_FALSE(want.overlapping.empty());
    const auto [meeting, near] = check_near(body, body.box().intersection(body_tool.box()));
    EXPECT_GT(meeting, 0u);
    EXPECT_LT(near * 8, large.mesh.tets.size()) << near;
    // And small regions anywhere in the object (one falls between two groups' nodes),
    // asked of two more bodies (the regions would make `body` refit every cluster next
    // frame): one never asked before, one asked last frame for a small region.
    CollisionBody fresh_body(large.mesh.tets, large.topo), asked_body(large.mesh.tets, large.topo);
    fresh_body.set_positions(large.mesh.positions);  // the clusters of `body`
    fresh_body.set_positions(p);
    asked_body.set_positions(prev);  // last frame's positions: few nodes moved since
    std::vector<Index> unused;
    asked_body.tets_near(Aabb{Vector3d::Zero(), Vector3d::Constant(0.01)}, unused);
    asked_body.set_positions(p);
    // Points too: the corners of the object (a node no other group's box holds) and
    // nodes at random.
    std::vector<Eigen::Index> points;
    for (const Vector3d& dir :
         {Vector3d(1, 1, 1), Vector3d(-1, 1, 1), Vector3d(1, -1, 1), Vector3d(-1, -1, 1),
          Vector3d(1, 1, -1), Vector3d(-1, 1, -1), Vector3d(1, -1, -1), Vector3d(-1, -1, -1)}) {
      Eigen::Index best = 0;
      (dir.transpose() * p.array().isFinite().select(p, 0.0).matrix()).maxCoeff(&best);
      points.push_back(best);
    }
    for (int k = 0; k < 16; ++k)
      points.push_back(static_cast<Eigen::Index>(unit(rng) * static_cast<double>(p.cols() - 1)));
    // And the 32 nodes that moved most since last frame.
    std::vector<std::pair<double, Eigen::Index>> moved;
    for (Eigen::Index i = 0; i < p.cols(); ++i)
      if (p.col(i).allFinite() && prev.col(i).allFinite())
        moved.emplace_back((p.col(i) - prev.col(i)).norm(), i);
    std::partial_sort(moved.begin(), moved.begin() + 32, moved.end(), std::greater<>());
    for (int k = 0; k < 32; ++k) points.push_back(moved[static_cast<std::size_t>(k)].second);
    for (CollisionBody* probe : {&fresh_body, &asked_body}) {
      for (int k = 0; k < 32; ++k) {
        const Vector3d size = Vector3d(0.02, 0.02, 0.01) * (1.0 + 4.0 * unit(rng));
        const Vector3d at = shift + Vector3d(unit(rng), unit(rng), 0.3 * unit(rng));
        check_near(*probe, Aabb{at, at + size});
      }
      for (const Eigen::Index v : points)
        if (p.col(v).allFinite()) check_near(*probe, Aabb{p.col(v), p.col(v)});
      // Every node as a point (every other frame; every 5th node under the sanitizers):
      // the finite tets around it are near (a node left out of a group's box is missed
      // there when it is that box's extreme).
      std::vector<Index> around;
      const Index stride = test::kSanitized ? 5 : 1;
      for (Index v = 0; frame % 2 == 0 && v < large.mesh.num_nodes(); v += stride) {
        if (!p.col(v).allFinite()) continue;
        probe->tets_near(Aabb{p.col(v), p.col(v)}, around);
        for (const Index t : large.topo.node_tets.row(v)) {
          if (tet_boxes[static_cast<std::size_t>(t)].empty()) continue;
          if (!std::binary_search(around.begin(), around.end(), t))
            ADD_FAILURE() << "tet " << t << " around node " << v << " is not near it";
        }
      }
    }
  }
  EXPECT_EQ(asked, 8);
}

/// Detection of the tool `tool_mesh` against two bodies of one object, `got` and `want`:
/// the same contacts. Returns want's, with both calls' stats.
PairContacts detect_alike(Detector& got_detector, CollisionBody& got, Detector& want_detector,
                          CollisionBody& want, const TetMesh& tool_mesh, DetectStats* got_stats,
                          DetectStats* want_stats, Aabb* tool_box = nullptr) {
  const Object tool(tool_mesh);
  CollisionBody tool_body(tool.mesh.tets, tool.topo);
  tool_body.set_positions(tool.mesh.positions);
  PairContacts got_contacts, want_contacts;
  got_detector.detect(got, tool_body, got_contacts, got_stats);
  want_detector.detect(want, tool_body, want_contacts, want_stats);
  expect_identical(got_contacts, want_contacts);
  if (tool_box != nullptr) *tool_box = tool_body.box();
  return want_contacts;
}

/// A body given its object's shape-check bounds (as the pipeline gives them) and one that
/// compares its nodes itself, over the same states; checks both against each other and
/// against the tets' boxes.
struct BoundAndOwn {
  explicit BoundAndOwn(const Object& object)
      : large(object),
        order(make_tet_check_order(object.mesh.positions, object.mesh.tets)),
        check(order, object.topo.node_tets, object.mesh.num_nodes(), options()),
        bound(object.mesh.tets, object.topo),
        own(object.mesh.tets, object.topo) {}
  static ValidationOptions options() {
    ValidationOptions o;
    o.compute_min_quality = false;
    return o;
  }
  /// A new state of the large object: checked; when clean, both bodies take it (the bound
  /// body with the check's bound unless `pass_bound` is false), else both keep the last.
  /// Returns whether the state was taken.
  bool take(const Positions& x, bool pass_bound = true) {
    if (!check.check(x).clean()) {
      bound.reuse_positions();
      own.reuse_positions();
      return false;
    }
    p = x;
    if (!check.last().has_box) {  // every tet checked: no pass over the nodes, no box
      if (pass_bound)
        bound.set_positions(p, check.bound(), nullptr);
      else
        bound.set_positions(p);
      own.set_positions(p);
      return true;
    }
    const Aabb box{check.last().box_lo, check.last().box_hi};
    if (pass_bound)
      bound.set_positions(p, check.bound(), &box);
    else
      bound.set_positions(p, box);
    own.set_positions(p, box);
    return true;
  }
  void rest() {
    bound.reuse_positions();
    own.reuse_positions();
  }
  /// Detection against `tool` with both bodies: the same contacts and near tets, and every
  /// tet whose box meets the overlap box of the two objects near. Returns whether they
  /// overlap.
  bool detect(const TetMesh& tool_mesh) {
    DetectStats got_stats, want_stats;
    Aabb tool_box;
    const PairContacts want = detect_alike(bound_detector, bound, own_detector, own, tool_mesh,
                                           &got_stats, &want_stats, &tool_box);
    EXPECT_EQ(got_stats.tets_a_near, want_stats.tets_a_near);
    EXPECT_EQ(got_stats.candidates, want_stats.candidates);
    if (!got_stats.boxes_overlap) return false;
    // Asked of copies: a second call would count the groups met twice, and the bodies
    // would leave the group boxes next frame.
    const Aabb region = bound.box().intersection(tool_box);
    std::vector<Index> near_bound, near_own;
    CollisionBody bound_copy = bound, own_copy = own;
    bound_copy.tets_near(region, near_bound);
    own_copy.tets_near(region, near_own);
    EXPECT_EQ(near_bound, near_own);
    for (std::size_t t = 0; t < large.mesh.tets.size(); ++t) {
      Aabb b;
      for (const Index v : large.mesh.tets[t]) b.extend(Vector3d(p.col(v)));
      if (b.overlaps(region) &&
          !std::binary_search(near_bound.begin(), near_bound.end(), static_cast<Index>(t)))
        ADD_FAILURE() << "tet " << t << " meets the region but is not near";
    }
    return !want.overlapping.empty();
  }

  const Object& large;
  TetCheckOrder order;
  ShapeCheck check;
  CollisionBody bound, own;
  Detector bound_detector, own_detector;
  Positions p;
};

// The group boxes from the shape check's bound (no pass over the nodes) give the near tets
// and contacts of the body's own comparison, over frames of a bulge moving under the tool,
// a corner lifted 15 cm with the tool on it (its references move, the rest's do not),
// translations of the whole object (the check's shift), frames at rest, shears (every tet
// checked; the reference rebuilt, then not), turns (the check's turned references), an
// inverted state (rejected), and a frame whose bound is not passed on (the next bound is
// taken anew, and used from the one after).
TEST(Detect, AShapeChecksBoundGivesTheNearTetsOfTheBodysOwnComparison) {
  // 31 groups: the tool's region meets few of them, so the group boxes are used.
  const Object large(test::structured_box(36, 36, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25)));
  const TetMesh tool0 = test::ball_mesh(3, 0.05);
  BoundAndOwn bodies(large);
  std::mt19937 rng(13);
  std::normal_distribution<double> jitter(0.0, 2e-4);
  int from_bound = 0, moved_from_bound = 0, lifted_contact = 0, contact = 0, rejected = 0;
  int rebuilt = 0, busy_not_rebuilt = 0, turned_from_bound = 0;
  for (int frame = 0; frame < 28; ++frame) {
    SCOPED_TRACE(frame);
    const bool lifted = frame % 3 == 1;
    const double shear = frame >= 10 && frame <= 12 ? 0.1 * (frame - 9) : 0.0;
    const double turn = frame >= 13 && frame <= 22 ? 0.05 * (frame - 12) : 0.0;
    const Vector3d shift = Vector3d(0.2, 0.1, 0.05) * static_cast<double>(frame / 7);
    const Eigen::Matrix3d rotation =
        Eigen::AngleAxisd(turn, Vector3d(0.2, 0.1, 1.0).normalized()).toRotationMatrix();
    const Vector3d centre(0.5, 0.5, 0.0);
    const auto place = [&](const Vector3d& x) -> Vector3d {
      return rotation * (x - centre + Vector3d(shear * (x.y() - 0.5), 0.0, 0.0)) + centre + shift;
    };
    // The corner beyond x, y = 0.94 lifted 15 cm (a hundredth of the nodes: the shift
    // of the rest stays within their radii); a 2 cm bulge.
    const auto lift = [&](const Vector3d& x) {
      return lifted && x.x() > 0.94 && x.y() > 0.94 ? 0.15 : 0.0;
    };
    if (frame % 5 == 4) {
      bodies.rest();
    } else {
      Positions x = large.mesh.positions;
      const Eigen::Vector2d bulge(0.2 + 0.025 * frame, 0.5);
      for (Eigen::Index i = 0; i < x.cols(); ++i) {
        Vector3d v = x.col(i);
        const double d = (v.head<2>() - bulge).norm();
        if (d < 0.1) v.z() += 0.02 * (1.0 - d / 0.1);
        v.z() += lift(v);
        for (int c = 0; c < 3; ++c) v[c] += jitter(rng);
        x.col(i) = place(v);
      }
      if (frame == 7) x.col(200) = x.col(201) + Vector3d(0.0, 0.0, -0.5);  // inverts its tets
      const bool taken = bodies.take(x, frame != 17);
      EXPECT_EQ(taken, frame != 7);
      rejected += taken ? 0 : 1;
      const MotionBound b = bodies.check.bound();
      rebuilt += taken && b.rebuilt ? 1 : 0;
      busy_not_rebuilt += taken && !b.bounded ? 1 : 0;
      if (frame == 17 || frame == 18) {
        EXPECT_FALSE(bodies.bound.groups_from_bound());  // not passed on, taken anew
      }
      if (taken && b.bounded && !b.rebuilt && frame != 17 && frame != 18) {
        EXPECT_TRUE(bodies.bound.groups_from_bound());
        moved_from_bound += b.moved.empty() ? 0 : 1;
        turned_from_bound += b.rotated ? 1 : 0;
      }
    }
    from_bound += bodies.bound.groups_from_bound() ? 1 : 0;
    const Vector3d target =
        lifted ? Vector3d(0.97, 0.97, 0.25 + 0.15) : Vector3d(0.25 + 0.025 * frame, 0.5, 0.25);
    const bool touch =
        bodies.detect(moved(tool0, rotation, place(target + Vector3d(0.0, 0.0, 0.05 - 0.01))));
    contact += touch ? 1 : 0;
    lifted_contact += touch && lifted && bodies.bound.groups_from_bound() ? 1 : 0;
  }
  EXPECT_EQ(rejected, 1);
  EXPECT_GE(rebuilt, 3);
  EXPECT_GE(busy_not_rebuilt, 1);
  EXPECT_GE(moved_from_bound, 8);
  EXPECT_GE(lifted_contact, 3);
  EXPECT_GE(turned_from_bound, 6);
  EXPECT_GE(from_bound, 20);
  EXPECT_GE(contact, 23);  // not on the rest frames where the tool went on to the corner
}

// The bound covers nodes that moved within their radius: a top node raised by 0.9 of its
// radius (the check does not count it as moved, so its reference stays), and the tool
// touching only what it raised.
TEST(Detect, AShapeChecksBoundCoversNodesThatMovedWithinTheirRadius) {
  const Object large(test::structured_box(12, 12, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25)));
  BoundAndOwn bodies(large);
  ASSERT_TRUE(bodies.take(large.mesh.positions));  // the reference
  // The radius of a node as the check certifies it at the reference.
  const ValidationOptions o = BoundAndOwn::options();
  const double quality = std::max(o.sliver_quality, o.degenerate_quality);
  const auto radius = [&](Index v) {
    double r = std::numeric_limits<double>::infinity();
    for (const Index t : large.topo.node_tets.row(v))
      r = std::min(r, certified_motion_radius(large.mesh.positions, large.mesh.tets[t], quality));
    return r;
  };
  int frames = 0;
  for (const Vector3d& spot : {Vector3d(0.5, 0.5, 0.25), Vector3d(0.25, 0.75, 0.25),
                               Vector3d(0.75, 0.25, 0.25), Vector3d(0.5, 0.5, 0.25)}) {
    SCOPED_TRACE(frames);
    Index apex = 0;
    for (Index v = 0; v < large.mesh.num_nodes(); ++v)
      if ((large.mesh.positions.col(v) - spot).norm() <
          (large.mesh.positions.col(apex) - spot).norm())
        apex = v;
    const double r = radius(apex);
    ASSERT_GT(r, 1e-4);
    Positions x = large.mesh.positions;
    const double up = (frames % 2 == 0 ? 0.9 : 0.8) * r;
    x(2, apex) += up;
    ASSERT_TRUE(bodies.take(x));
    EXPECT_TRUE(bodies.bound.groups_from_bound());
    EXPECT_EQ(bodies.check.last().moved_nodes, 0u);  // within its radius: not moved
    // A ball 0.1 r wide, its lowest point half way up the raised apex.
    const Vector3d at = x.col(apex) - Vector3d(0.0, 0.0, 0.5 * up - 0.1 * r);
    EXPECT_TRUE(bodies.detect(moved(test::ball_mesh(3, 0.1 * r), Matrix3d::Identity(), at)));
    ++frames;
  }
}

// The bound's contract on its own (a MotionBound made by hand, no shape check): a radius
// that grows in a check raises its groups' boxes from the next frame on, when the node may
// use it; a translation is the shift; a bound whose versions do not follow the last is
// taken anew and not used that frame.
TEST(Detect, AMotionBoundsGrownRadiusAndShiftMoveTheGroupBoxes) {
  // 14 groups, of which the tool meets one or two: the group boxes are used.
  const Object large(test::structured_box(24, 24, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25)));
  const auto n = static_cast<std::size_t>(large.mesh.num_nodes());
  Index apex = 0;  // the top node nearest the middle
  for (Index v = 0; v < large.mesh.num_nodes(); ++v)
    if ((large.mesh.positions.col(v) - Vector3d(0.5, 0.5, 0.25)).norm() <
        (large.mesh.positions.col(apex) - Vector3d(0.5, 0.5, 0.25)).norm())
      apex = v;
  const Positions reference = large.mesh.positions;
  std::vector<double> radius2(n, 1e-6);  // 1 mm
  MotionBound b;
  b.bounded = b.rebuilt = true;
  b.version_before = 0;
  b.version_after = 1;
  b.reference = &reference;
  b.radius2 = radius2;
  CollisionBody bound(large.mesh.tets, large.topo), own(large.mesh.tets, large.topo);
  Detector bound_detector, own_detector;
  Positions p = reference;
  const auto frame = [&](const Vector3d& tool_at) {
    bound.set_positions(p, b, nullptr);
    own.set_positions(p);
    return !detect_alike(bound_detector, bound, own_detector, own,
                         moved(test::ball_mesh(3, 0.01), Matrix3d::Identity(), tool_at), nullptr,
                         nullptr)
                .overlapping.empty();
  };
  const Vector3d above = reference.col(apex) + Vector3d(0.0, 0.0, 0.01 + 0.02);
  EXPECT_FALSE(frame(above));  // the reference; the tool 2 cm above the top
  EXPECT_TRUE(bound.groups_from_bound());
  // A check gives the apex a radius of 5 cm (its tets grew, say); the apex stays.
  b.rebuilt = false;
  b.version_before = 1;
  b.version_after = 2;
  radius2[static_cast<std::size_t>(apex)] = 0.05 * 0.05;
  const std::vector<Index> changed = {apex};
  b.changed = changed;
  EXPECT_FALSE(frame(above));
  EXPECT_TRUE(bound.groups_from_bound());
  // The next check: nothing changed, the apex is 4 cm up, within its new radius, into the
  // tool.
  b.version_before = b.version_after = 2;
  b.changed = {};
  p(2, apex) += 0.04;
  EXPECT_TRUE(frame(above));
  EXPECT_TRUE(bound.groups_from_bound());
  // The whole object 2 m along x (off its old place), the shift of the check.
  p.row(0).array() += 2.0;
  b.shift = Vector3d(2.0, 0.0, 0.0);
  EXPECT_TRUE(frame(above + Vector3d(2.0, 0.0, 0.0)));
  EXPECT_TRUE(bound.groups_from_bound());
  // A check missed (versions 3 to 4 given after 2): taken anew, not used this frame.
  b.version_before = 3;
  b.version_after = 4;
  EXPECT_TRUE(frame(above + Vector3d(2.0, 0.0, 0.0)));
  EXPECT_FALSE(bound.groups_from_bound());
  b.version_before = 4;
  EXPECT_TRUE(frame(above + Vector3d(2.0, 0.0, 0.0)));
  EXPECT_TRUE(bound.groups_from_bound());
}

/// A ball tool (radius 6 cm) and a slab (1 x 1 x 0.25 m, 16 x 16 x 4 cells), each with a
/// body: the scene of the tool-on-slab tests below.
struct ToolOnSlab {
  const Object large{test::structured_box(16, 16, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25))};
  const TetMesh tool0 = test::ball_mesh(3, 0.06);
  const Object tool_rest{tool0};
  CollisionBody body_tool{tool_rest.mesh.tets, tool_rest.topo};
  CollisionBody body_large{large.mesh.tets, large.topo};
};

// A tool creeping across a large object (1 kHz motion): the tree over the large object's
// few tets near the contact is refitted while those tets stay the same, and rebuilt when
// they change or after 32 refits; the contacts are every frame those of a one-off.
TEST(Detector, ARefittedLocalTreeGivesTheOneOffContacts) {
  ToolOnSlab scene;
  auto& [large, tool0, tool_rest, body_tool, body_large] = scene;
  DetectOptions no_kept_pairs;  // (kept pairs would serve most of these frames without a tree)
  no_kept_pairs.keep_pairs = false;
  Detector detector(no_kept_pairs);
  body_large.set_positions(large.mesh.positions);
  int refitted = 0, built = 0;
  for (int frame = 0; frame < 80; ++frame) {
    SCOPED_TRACE(frame);
    if (frame > 0) body_large.reuse_positions();
    // Pressed 2 cm into the top face and 0.1 mm deeper and further along x every frame
    // (the large object's tets near the tool change rarely, their clipped boxes every
    // frame); every 10th frame a jump.
    const double x = 0.4 + 1e-4 * frame + (frame % 10 == 9 ? 0.05 : 0.0);
    const double z = 0.25 + 0.06 - 0.02 - 1e-4 * frame;
    const Object tool(moved(tool0, Matrix3d::Identity(), Vector3d(x, 0.45, z)));
    body_tool.set_positions(tool.mesh.positions);
    PairContacts got;
    DetectStats st;
    detector.detect(body_tool, body_large, got, &st);
    EXPECT_FALSE(got.overlapping.empty());
    expect_identical(got, run(tool, large));
    (st.local_tree_refitted ? refitted : built) += 1;
  }
  EXPECT_GT(refitted, 20);
  EXPECT_GT(built, 8);
}

// Kept pairs (DetectOptions::keep_pairs, kBvh): the candidates, and so the contacts, are
// those a tree gives, bit for bit, over frames in which both objects move a little (the
// large one deformed node by node), with a jump every 25th frame, with the large object as
// A (B's tree over all of the small tool) and as B (a tree over B's few tets).
TEST(Detector, KeptPairsGiveTheTreesCandidatesOverSlowMotionAndJumps) {
  for (const bool large_is_a : {true, false}) {
    SCOPED_TRACE(large_is_a ? "large=a" : "large=b");
    ToolOnSlab scene;
    auto& [large, tool0, tool_rest, body_tool, body_large] = scene;
    DetectOptions off;
    off.keep_pairs = false;
    Detector with, without(off);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-2e-5, 2e-5);
    int kept = 0, rebuilt = 0;
    std::size_t hinted = 0, kept_candidates = 0;
    for (int frame = 0; frame < 120; ++frame) {
      SCOPED_TRACE(frame);
      Positions pl = large.mesh.positions;
      for (Eigen::Index i = 0; i < pl.cols(); ++i) pl.col(i) += draw3(jitter, rng);
      body_large.set_positions(pl);
      // 0.1 mm a frame along x, 0.05 mm down, 1 mrad about z (a hand at 0.1 m/s at 1 kHz);
      // 5 cm further along x on frames 20-24 of each 25.
      const double x = 0.4 + 1e-4 * frame + (frame % 25 >= 20 ? 0.05 : 0.0);
      const double z = 0.25 + 0.06 - 0.02 - 5e-5 * (frame % 25);
      const Object tool(moved(tool0, Eigen::AngleAxisd(0.001 * frame, Vector3d::UnitZ()).matrix(),
                              Vector3d(x, 0.45, z)));
      body_tool.set_positions(tool.mesh.positions);
      DetectStats st_with, st_without;
      expect_same_detection(with, without, large_is_a ? body_large : body_tool,
                            large_is_a ? body_tool : body_large, st_with, st_without);
      EXPECT_FALSE(st_without.pairs_kept);
      if (frame == 0) {
        EXPECT_FALSE(st_with.pairs_kept) << "a new pair's first call is served by the tree";
      }
      kept += st_with.pairs_kept ? 1 : 0;
      rebuilt += st_with.pairs_rebuilt ? 1 : 0;
      EXPECT_EQ(st_without.hinted, 0U);  // hints come with kept pairs only
      if (st_with.pairs_kept) {
        hinted += st_with.hinted;
        kept_candidates += st_with.candidates;
      }
    }
    EXPECT_GT(kept, 90) << kept;       // kept pairs served most frames
    EXPECT_GE(rebuilt, 5) << rebuilt;  // and were made again after each jump at least
    // The overlap hints decided most of their candidates (83% here; the tool turns and
    // sinks a little every frame, so some go stale), with the tree's answers throughout.
    EXPECT_GT(hinted, kept_candidates * 3 / 4) << hinted << " of " << kept_candidates;
  }
}

/// ToolOnSlab with the large object at rest, and two detectors: kept pairs on (`with`) and
/// off (`without`, every call served by a tree).
struct KeptAgainstTree {
  ToolOnSlab objects;
  std::array<Detector, 2> detectors{Detector(), Detector([] {
                                      DetectOptions off;
                                      off.keep_pairs = false;
                                      return off;
                                    }())};
  KeptAgainstTree() { objects.body_large.set_positions(objects.large.mesh.positions); }
};

// Contact that moves too fast for kept pairs: they sit out (the tree serves) and come back
// once it slows down; the candidates are the tree's throughout.
TEST(Detector, KeptPairsSitOutWhileContactMovesFastAndComeBack) {
  KeptAgainstTree scene;
  auto& [with, without] = scene.detectors;
  auto& [large, tool0, tool_rest, body_tool, body_large] = scene.objects;
  int kept_fast = 0, kept_slow = 0;
  const int fast = 40, slow = 120;
  double x = 0.3;
  for (int frame = 0; frame < fast + slow; ++frame) {
    SCOPED_TRACE(frame);
    if (frame > 0) body_large.reuse_positions();
    x += frame < fast ? (frame % 2 == 0 ? 0.02 : -0.015) : 1e-5;  // 1-2 cm a frame, then 10 um
    const Object tool(moved(tool0, Matrix3d::Identity(), Vector3d(x, 0.45, 0.29)));
    body_tool.set_positions(tool.mesh.positions);
    DetectStats st, st_without;
    expect_same_detection(with, without, body_tool, body_large, st, st_without);
    (frame < fast ? kept_fast : kept_slow) += st.pairs_kept ? 1 : 0;
  }
  EXPECT_LT(kept_fast, fast / 2) << "kept pairs should sit out fast contact";
  EXPECT_GT(kept_slow, slow / 4) << "and serve again once it is slow";
}

// A tool dragged steadily (1 mm a frame along x, 0.25 mm along y, while it sinks 0.02 mm:
// a hand at 1 m/s at 1 kHz, far beyond the margin of tets 2-6 cm across), with the
// direction turned back halfway: kept pairs made along the motion serve most frames, and
// the candidates are the tree's throughout (as A and as B).
TEST(Detector, KeptPairsFollowSteadilyDraggedContact) {
  for (const bool tool_is_a : {true, false}) {
    SCOPED_TRACE(tool_is_a ? "tool=a" : "tool=b");
    KeptAgainstTree scene;
    auto& [with, without] = scene.detectors;
    auto& [large, tool0, tool_rest, body_tool, body_large] = scene.objects;
    int kept = 0, rebuilt = 0;
    std::size_t hinted = 0, candidates = 0;
    const int frames = 200;
    for (int frame = 0; frame < frames; ++frame) {
      SCOPED_TRACE(frame);
      if (frame > 0) body_large.reuse_positions();
      const int along = frame < frames / 2 ? frame : frames - frame;  // back from the middle
      const Object tool(moved(
          tool0, Matrix3d::Identity(),
          Vector3d(0.35 + 1e-3 * along, 0.4 + 2.5e-4 * along, 0.25 + 0.06 - 0.02 - 2e-5 * frame)));
      body_tool.set_positions(tool.mesh.positions);
      DetectStats st, st_without;
      expect_same_detection(with, without, tool_is_a ? body_tool : body_large,
                            tool_is_a ? body_large : body_tool, st, st_without);
      kept += st.pairs_kept ? 1 : 0;
      rebuilt += st.pairs_rebuilt ? 1 : 0;
      hinted += st.hinted;
      candidates += st.candidates;
    }
    EXPECT_GT(kept, frames * 3 / 4) << kept << " frames served, lists made " << rebuilt;
    // Overlap hints decide most candidates even so (75% here: a hint goes stale when its
    // pair's gap or depth changes by more than the margin).
    EXPECT_GT(hinted, candidates * 2 / 3) << hinted << " of " << candidates;
  }
}

// One Detector over several object pairs in turn (as the pipeline runs it): each pair
// keeps its own pairs, and every call gives the tree's candidates.
TEST(Detector, KeptPairsOfSeveralObjectPairsOnOneDetector) {
  const Object large(test::structured_box(12, 12, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25)));
  const TetMesh tool0 = test::ball_mesh(3, 0.06);
  const Object tool_rest(tool0);
  CollisionBody body_large(large.mesh.tets, large.topo);
  std::vector<std::unique_ptr<CollisionBody>> tools;
  for (int t = 0; t < 3; ++t)
    tools.push_back(std::make_unique<CollisionBody>(tool_rest.mesh.tets, tool_rest.topo));
  body_large.set_positions(large.mesh.positions);
  DetectOptions off;
  off.keep_pairs = false;
  Detector with, without(off);
  std::vector<Object> posed;
  int kept = 0, calls = 0;
  for (int frame = 0; frame < 30; ++frame) {
    SCOPED_TRACE(frame);
    if (frame > 0) body_large.reuse_positions();
    posed.clear();
    for (int t = 0; t < 3; ++t)  // the second and third tools overlap each other too
      posed.emplace_back(moved(tool0, Matrix3d::Identity(),
                               Vector3d(0.2 + 0.3 * (t > 0 ? 1 : 0) + 0.08 * (t == 2 ? 1 : 0),
                                        0.4 + 1e-4 * frame, 0.29)));
    for (int t = 0; t < 3; ++t) tools[t]->set_positions(posed[t].mesh.positions);
    const std::array<std::pair<CollisionBody*, CollisionBody*>, 4> pairs = {
        {{tools[0].get(), &body_large},
         {tools[1].get(), &body_large},
         {&body_large, tools[2].get()},
         {tools[1].get(), tools[2].get()}}};
    for (const auto& [a, b] : pairs) {
      DetectStats st, st_without;
      expect_same_detection(with, without, *a, *b, st, st_without);
      kept += st.pairs_kept ? 1 : 0;
      ++calls;
    }
  }
  EXPECT_GT(kept, calls * 3 / 4);
}

TEST(Detect, NonFiniteNodesAreIgnored) {
  const Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  Object b(test::structured_box(3, 3, 3, Vector3d(0.5, 0.5, 0.5), Vector3d(1.5, 1.5, 1.5)));
  b.mesh.positions(0, 21) = std::numeric_limits<double>::quiet_NaN();
  b.mesh.positions(2, 5) = std::numeric_limits<double>::infinity();
  const PairContacts c = run(a, b);
  expect_well_formed(c);
  EXPECT_FALSE(c.empty());
  for (const auto& p : c.overlapping)
    for (const Index v : b.mesh.tets[p.tet_b]) EXPECT_TRUE(v != 21 && v != 5);
  for (const auto& n : c.nodes_b_in_a) EXPECT_TRUE(n.node != 21 && n.node != 5);
}

TEST(Detect, DegenerateTetsDoNotBreakAnything) {
  Object a(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  // Collapse a few nodes onto their neighbours: zero-volume and inverted tets appear.
  a.mesh.positions.col(21) = a.mesh.positions.col(22);
  a.mesh.positions.col(26) = 0.5 * (a.mesh.positions.col(25) + a.mesh.positions.col(27));
  a.mesh.positions.col(37) = a.mesh.positions.col(38) + Vector3d(0.0, 0.0, 1e-14);
  const Object b(moved(test::structured_box(3, 3, 3, Vector3d(0, 0, 0), Vector3d(1, 1, 1)),
                       Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
                       Vector3d(0.4, 0.3, 0.2)));
  const PairContacts c = run(a, b);
  expect_well_formed(c);
  expect_identical(c, brute_force(a, b));
}

// The pipeline's degraded mode (issue 48, item 6): tets left out of a body
// (CollisionBody::set_left_out_tets) take part in no contact: no overlapping pair, no
// node or edge of the other object in them. The overlaps of the other tets stay, and a
// body whose list is emptied again gives the full contacts.
TEST(Detect, LeftOutTetsTakePartInNothing) {
  const Object a(test::structured_box(6, 6, 6, Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  const Object b(moved(test::structured_box(5, 5, 5, Vector3d(0, 0, 0), Vector3d(0.8, 0.8, 0.8)),
                       Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()).toRotationMatrix(),
                       Vector3d(0.6, 0.1, 0.15)));
  const PairContacts full = run(a, b);
  ASSERT_FALSE(full.nodes_a_in_b.empty());
  ASSERT_FALSE(full.nodes_b_in_a.empty());
  // Left out: the tets holding the first intruding nodes of each direction.
  std::vector<Index> out_a, out_b;
  for (std::size_t k = 0; k < 3 && k < full.nodes_b_in_a.size(); ++k)
    out_a.push_back(full.nodes_b_in_a[k].tet);
  for (std::size_t k = 0; k < 3 && k < full.nodes_a_in_b.size(); ++k)
    out_b.push_back(full.nodes_a_in_b[k].tet);
  for (auto* list : {&out_a, &out_b}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  const auto in = [](const std::vector<Index>& list, Index t) {
    return std::binary_search(list.begin(), list.end(), t);
  };
  for (const auto kind : {BroadPhaseKind::kBvh, BroadPhaseKind::kSap}) {
    DetectOptions opt;
    opt.broad_phase = kind;
    CollisionBody ba(a.mesh.tets, a.topo), bb(b.mesh.tets, b.topo);
    Detector detector(opt);
    ba.set_positions(a.mesh.positions);
    bb.set_positions(b.mesh.positions);
    ba.set_left_out_tets(out_a);
    bb.set_left_out_tets(out_b);
    PairContacts got;
    detector.detect(ba, bb, got);
    expect_well_formed(got);
    std::vector<TetPair> kept;
    for (const TetPair& p : full.overlapping)
      if (!in(out_a, p.tet_a) && !in(out_b, p.tet_b)) kept.push_back(p);
    EXPECT_EQ(got.overlapping, kept);
    for (const Index t : got.marked_a) EXPECT_FALSE(in(out_a, t)) << t;
    for (const Index t : got.marked_b) EXPECT_FALSE(in(out_b, t)) << t;
    for (const IntrudingNode& n : got.nodes_a_in_b) EXPECT_FALSE(in(out_b, n.tet)) << n.node;
    for (const IntrudingNode& n : got.nodes_b_in_a) EXPECT_FALSE(in(out_a, n.tet)) << n.node;
    for (const IntrudingEdge& e : got.edges_a_in_b) EXPECT_FALSE(in(out_b, e.tet)) << e.edge;
    for (const IntrudingEdge& e : got.edges_b_in_a) EXPECT_FALSE(in(out_a, e.tet)) << e.edge;
    EXPECT_FALSE(got.nodes_a_in_b.empty());
    // Nothing left out any more: the full contacts, with the same detector and bodies.
    ba.set_left_out_tets({});
    bb.set_left_out_tets({});
    ba.reuse_positions();
    bb.reuse_positions();
    detector.detect(ba, bb, got);
    expect_identical(got, full);
  }
}

// The tables of the tets' edges (about 50 bytes a tet) are made on a body's first edge
// scan, never for an object only answered by points: the load test's 8 organs of 329k tets
// held 140 MB of them. Made late, they give the edges that tables made up front give.
TEST(CollisionBody, EdgeTablesAreMadeForTheFirstEdgeScanOnly) {
  const CornerBoxes boxes;
  const Object& a = boxes.a;
  const Object& b = boxes.b;
  CollisionBody ba = CornerBoxes::body(a), bb = CornerBoxes::body(b);
  DetectOptions points;
  points.intruding_edges = false;
  Detector by_points(points);
  PairContacts c;
  by_points.detect(ba, bb, c);
  ASSERT_FALSE(c.nodes_a_in_b.empty());
  EXPECT_FALSE(ba.edges_prepared());
  EXPECT_FALSE(bb.edges_prepared());
  Detector detector;
  detector.detect(ba, bb, c, nullptr, [](const PairContacts&) {
    return std::array<bool, 2>{true, false};
  });
  EXPECT_TRUE(ba.edges_prepared());
  EXPECT_FALSE(bb.edges_prepared());
  detector.detect(ba, bb, c);
  EXPECT_TRUE(bb.edges_prepared());
  CollisionBody ready_a = CornerBoxes::body(a), ready_b = CornerBoxes::body(b);
  ready_a.prepare_edges();
  ready_b.prepare_edges();
  PairContacts want;
  Detector().detect(ready_a, ready_b, want);
  ASSERT_FALSE(want.edges_a_in_b.empty());
  ASSERT_FALSE(want.edges_b_in_a.empty());
  expect_identical(c, want);
}

// A topology without node->tet incidence (one made by hand): the body makes its own, and a
// body moved elsewhere still reads it (the incidence is not a pointer into the old place).
TEST(CollisionBody, MadeIncidenceSurvivesAMove) {
  const CornerBoxes boxes;
  const Object& a = boxes.a;
  const Object& b = boxes.b;
  Topology bare = a.topo;
  bare.node_tets = Csr{};
  auto first = std::make_unique<CollisionBody>(a.mesh.tets, bare);
  CollisionBody moved(std::move(*first));
  first.reset();
  moved.set_positions(a.mesh.positions);
  CollisionBody ba = CornerBoxes::body(a), bb = CornerBoxes::body(b);
  PairContacts want, got;
  Detector().detect(ba, bb, want);
  ASSERT_FALSE(want.nodes_a_in_b.empty());
  Detector().detect(moved, bb, got);
  expect_identical(got, want);
}

TEST(CollisionBody, RejectsMismatchedInput) {
  const TetMesh m = test::cube_five_tets();
  const Topology t = build_topology(m.tets, m.num_nodes());
  const TetMesh other = test::cube_six_tets();
  EXPECT_THROW(CollisionBody(other.tets, t), std::invalid_argument);
  {
    Topology missing = t;  // one tet edge not among the topology's edges
    missing.edges.erase(missing.edges.begin() + 3);
    try {
      CollisionBody body(m.tets, missing);
      ADD_FAILURE() << "a topology without a tet's edge was taken";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("is not in the topology"), std::string::npos)
          << e.what();
    }
  }
  CollisionBody body(m.tets, t);
  EXPECT_THROW(body.set_positions(Positions::Zero(3, 3)), std::invalid_argument);
  EXPECT_THROW(body.prepare(BroadPhaseKind::kGrid), std::logic_error);
  EXPECT_THROW(body.reuse_positions(), std::logic_error);
  body.set_positions(m.positions);
  EXPECT_EQ(body.box().lo, Vector3d::Zero());
  EXPECT_EQ(body.box().hi, Vector3d::Ones());
}

// The body's box is that of its finite nodes, with the bits of Aabb::extend over them in
// node order: a node with one NaN or infinite coordinate is left out whole (its finite
// coordinates too), and a tie between -0 and +0 keeps the first. Also over more nodes
// than one chunk of the parallel pass.
TEST(CollisionBody, BoxIsTheBoxOfTheFiniteNodesBitForBit) {
  const TetMesh m = test::structured_box(24, 24, 20, Vector3d(0, 0, 0), Vector3d(1, 1, 1));
  const Topology t = build_topology(m.tets, m.num_nodes());
  ASSERT_GT(m.num_nodes(), 8192);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<Positions> states;
  Positions p = m.positions;
  p.col(0) = Vector3d(-0.0, -0.0, -0.0);  // before the +0 corners of the other nodes
  states.push_back(p);
  p.col(7) = Vector3d(nan, -5.0, 7.0);  // only x is bad: y and z would widen the box
  p.col(9000) = Vector3d(3.0, inf, 0.5);
  p.col(12) = Vector3d(-2.0, 0.5, -inf);
  states.push_back(p);
  p.col(5) = Vector3d(-1.0, 2.0, 3.0);  // and the finite extremes still count
  states.push_back(p);
  CollisionBody body(m.tets, t);
  for (std::size_t s = 0; s < states.size(); ++s) {
    SCOPED_TRACE(s);
    Aabb want;
    for (Eigen::Index i = 0; i < states[s].cols(); ++i)
      if (states[s].col(i).allFinite()) want.extend(Vector3d(states[s].col(i)));
    body.set_positions(states[s]);
    const Aabb& got = body.box();
    EXPECT_EQ(std::memcmp(got.lo.data(), want.lo.data(), sizeof(double) * 3), 0) << got.lo;
    EXPECT_EQ(std::memcmp(got.hi.data(), want.hi.data(), sizeof(double) * 3), 0) << got.hi;
  }
  EXPECT_TRUE(std::signbit(body.box().lo.y()));  // -0 came first
  EXPECT_EQ(body.box().lo, Vector3d(-1.0, -0.0, -0.0));
  EXPECT_EQ(body.box().hi, Vector3d(1.0, 2.0, 3.0));
}

TEST(TouchingObjectPairs, BoxesAndEnableFlag) {
  const std::vector<Aabb> boxes = {{Vector3d(0, 0, 0), Vector3d(1, 1, 1)},
                                   {Vector3d(1, 0, 0), Vector3d(2, 1, 1)},  // touches 0
                                   {Vector3d(0.5, 0.5, 0.5), Vector3d(3, 3, 3)},
                                   {Vector3d(5, 5, 5), Vector3d(6, 6, 6)}};  // alone
  using P = std::pair<Index, Index>;
  EXPECT_EQ(touching_object_pairs(boxes), (std::vector<P>{{0, 1}, {0, 2}, {1, 2}}));
  // Objects 0 and 1 static: never tested against each other.
  const auto enabled = [](Index i, Index j) { return !(i <= 1 && j <= 1); };
  EXPECT_EQ(touching_object_pairs(boxes, enabled), (std::vector<P>{{0, 2}, {1, 2}}));
}

}  // namespace
}  // namespace tc
