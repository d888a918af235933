// service/core/detect/surface_detect: a triangle surface against a tet mesh. Every list is
// compared with brute force over all (triangle, tet) pairs, for every broad phase and for
// 1 to 4 threads (bit for bit); node and edge intrusions are also checked against what
// the geometry says independently (nodes inside the box, edge pieces covering each edge
// once).
#include "core/detect/surface_detect.hpp"

#include <gtest/gtest.h>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <set>

#include "core/detect/tri_tet_overlap.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr BroadPhaseKind kKinds[] = {BroadPhaseKind::kGrid, BroadPhaseKind::kHash,
                                     BroadPhaseKind::kSap, BroadPhaseKind::kBvh};

struct Case {
  SurfaceMesh surface;
  TetMesh tets;
};

SurfaceContacts detect(const Case& c, const DetectOptions& options = {},
                       SurfaceDetectStats* stats = nullptr) {
  return detect_surface_tets(c.surface.positions, c.surface.triangles,
                             build_surface_edges(c.surface.triangles), c.tets.positions,
                             c.tets.tets, options, stats);
}

/// The definition in docs/DETECTION.md, evaluated over every (triangle, tet) pair.
SurfaceContacts brute_force(const Case& c, double rel = kDefaultRelativeTolerance) {
  SurfaceContacts out;
  const SurfaceEdges edges = build_surface_edges(c.surface.triangles);
  const Positions& ps = c.surface.positions;
  const Positions& pt = c.tets.positions;
  std::vector<TetGeometry> geom(c.tets.tets.size());
  for (std::size_t k = 0; k < geom.size(); ++k)
    make_tet_geometry(tet_corners(pt, c.tets.tets[k]), geom[k]);
  for (Index t = 0; t < c.surface.num_triangles(); ++t) {
    const Triangle& tri = c.surface.triangles[static_cast<std::size_t>(t)];
    const TriangleCorners corners = {ps.col(tri[0]), ps.col(tri[1]), ps.col(tri[2])};
    for (Index k = 0; k < c.tets.num_tets(); ++k) {
      const TetGeometry& g = geom[static_cast<std::size_t>(k)];
      if (triangle_tet_overlap(corners, g, rel * pair_scale(corners, g.v)))
        out.overlapping.push_back({t, k});
    }
  }
  std::set<Index> marked_t, marked_k;
  // tets_of[t]: the tets triangle t overlaps, in order.
  std::vector<std::vector<Index>> tets_of(c.surface.triangles.size());
  for (const TriTetPair& p : out.overlapping) {
    marked_t.insert(p.triangle);
    marked_k.insert(p.tet);
    tets_of[static_cast<std::size_t>(p.triangle)].push_back(p.tet);
  }
  out.marked_triangles.assign(marked_t.begin(), marked_t.end());
  out.marked_tets.assign(marked_k.begin(), marked_k.end());
  std::vector<std::set<Index>> near_node(static_cast<std::size_t>(c.surface.num_nodes()));
  std::vector<std::set<Index>> near_edge(edges.edges.size());
  for (const Index t : marked_t) {
    const auto& tets = tets_of[static_cast<std::size_t>(t)];
    for (const Index v : c.surface.triangles[static_cast<std::size_t>(t)])
      near_node[static_cast<std::size_t>(v)].insert(tets.begin(), tets.end());
    for (const Index e : edges.triangle_edges[static_cast<std::size_t>(t)])
      near_edge[static_cast<std::size_t>(e)].insert(tets.begin(), tets.end());
  }
  const auto geometry = [&](Index k) -> const TetGeometry& {
    return geom[static_cast<std::size_t>(k)];
  };
  for (Index v = 0; v < c.surface.num_nodes(); ++v)
    for (const Index k : near_node[static_cast<std::size_t>(v)]) {
      const TetGeometry& g = geometry(k);
      const PointInTet hit = point_in_tet(ps.col(v), g, rel * g.scale);
      if (hit.inside) {
        out.nodes_in_tets.push_back({v, k, hit.bary});
        break;
      }
    }
  for (Index e = 0; e < static_cast<Index>(edges.edges.size()); ++e) {
    const Vector3d p0 = ps.col(edges.edges[static_cast<std::size_t>(e)][0]);
    const Vector3d p1 = ps.col(edges.edges[static_cast<std::size_t>(e)][1]);
    const double length = (p1 - p0).norm();
    const std::size_t first = out.edges_in_tets.size();
    for (const Index k : near_edge[static_cast<std::size_t>(e)]) {
      const TetGeometry& g = geometry(k);
      const double tol = rel * std::max(g.scale, length);
      const SegmentClip clip = clip_segment_tet(p0, p1, g, tol);
      if (!clip.hit) continue;
      bool repeated = false;
      for (std::size_t i = first; i < out.edges_in_tets.size(); ++i)
        repeated = repeated ||
                   (std::abs(out.edges_in_tets[i].lambda_in - clip.lambda_in) <= tol / length &&
                    std::abs(out.edges_in_tets[i].lambda_out - clip.lambda_out) <= tol / length);
      if (!repeated) out.edges_in_tets.push_back({e, k, clip.lambda_in, clip.lambda_out});
    }
  }
  return out;
}

void expect_identical(const SurfaceContacts& a, const SurfaceContacts& b, const std::string& what) {
  EXPECT_EQ(a.overlapping, b.overlapping) << what;
  EXPECT_EQ(a.marked_triangles, b.marked_triangles) << what;
  EXPECT_EQ(a.marked_tets, b.marked_tets) << what;
  ASSERT_EQ(a.nodes_in_tets.size(), b.nodes_in_tets.size()) << what;
  for (std::size_t i = 0; i < a.nodes_in_tets.size(); ++i) {
    EXPECT_EQ(a.nodes_in_tets[i].node, b.nodes_in_tets[i].node) << what;
    EXPECT_EQ(a.nodes_in_tets[i].tet, b.nodes_in_tets[i].tet) << what;
    for (int k = 0; k < 4; ++k)
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a.nodes_in_tets[i].bary[k]),
                std::bit_cast<std::uint64_t>(b.nodes_in_tets[i].bary[k]))
          << what;
  }
  ASSERT_EQ(a.edges_in_tets.size(), b.edges_in_tets.size()) << what;
  for (std::size_t i = 0; i < a.edges_in_tets.size(); ++i) {
    EXPECT_EQ(a.edges_in_tets[i].edge, b.edges_in_tets[i].edge) << what;
    EXPECT_EQ(a.edges_in_tets[i].tet, b.edges_in_tets[i].tet) << what;
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a.edges_in_tets[i].lambda_in),
              std::bit_cast<std::uint64_t>(b.edges_in_tets[i].lambda_in))
        << what;
    EXPECT_EQ(std::bit_cast<std::uint64_t>(a.edges_in_tets[i].lambda_out),
              std::bit_cast<std::uint64_t>(b.edges_in_tets[i].lambda_out))
        << what;
  }
}

/// A 4 x 4 x 4 box [0, 1]^3 (384 tets) and a flat 8 x 8 square at z = 0.3 over [0, 1]^2:
/// its edges lie in the box's vertical grid planes (faces shared by two tets) or cross
/// tets; every node is in the box, some on its boundary.
Case plate_in_box() {
  return {test::square_surface(8, 1.0, 0.3), test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1})};
}

/// The boundary of a ball (radius 0.35) pushed half-way through the top of the box.
Case ball_surface_into_box() {
  Case c{test::boundary_surface_of(test::ball_mesh(3, 0.35)),
         test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1})};
  for (Eigen::Index i = 0; i < c.surface.positions.cols(); ++i)
    c.surface.positions.col(i) += Vector3d(0.47, 0.52, 1.0);
  return c;
}

/// A tilted cube surface (12 triangles) crossing a corner of the box.
Case tilted_cube_at_a_corner() {
  Case c{test::cube_surface(0.5), test::structured_box(3, 3, 3, {0, 0, 0}, {1, 1, 1})};
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(0.3, Vector3d(1, 2, 3).normalized()).toRotationMatrix());
  for (Eigen::Index i = 0; i < c.surface.positions.cols(); ++i)
    c.surface.positions.col(i) = r * c.surface.positions.col(i) + Vector3d(0.75, 0.7, 0.8);
  return c;
}

TEST(SurfaceDetect, EveryBroadPhaseEqualsBruteForce) {
  for (const Case& c : {plate_in_box(), ball_surface_into_box(), tilted_cube_at_a_corner()}) {
    const SurfaceContacts want = brute_force(c);
    ASSERT_FALSE(want.overlapping.empty());
    ASSERT_FALSE(want.nodes_in_tets.empty());
    ASSERT_FALSE(want.edges_in_tets.empty());
    for (const BroadPhaseKind kind : kKinds) {
      DetectOptions options;
      options.broad_phase = kind;
      SurfaceDetectStats stats;
      const SurfaceContacts got = detect(c, options, &stats);
      expect_identical(got, want, std::string(broad_phase_name(kind)));
      EXPECT_TRUE(stats.boxes_overlap);
      EXPECT_GE(stats.candidates, stats.overlapping);
      EXPECT_EQ(stats.overlapping, want.overlapping.size());
    }
  }
}

TEST(SurfaceDetect, PlateInBoxEveryNodeIsInsideAndEveryEdgeIsCoveredOnce) {
  const Case c = plate_in_box();
  const SurfaceContacts got = detect(c);
  // Each of the 81 nodes is in the box (closed), so in some tet its triangles overlap.
  ASSERT_EQ(got.nodes_in_tets.size(), 81u);
  for (const IntrudingNode& n : got.nodes_in_tets) {
    const Tet& t = c.tets.tets[static_cast<std::size_t>(n.tet)];
    Vector3d x = Vector3d::Zero();
    for (int k = 0; k < 4; ++k) x += n.bary[k] * c.tets.positions.col(t[k]);
    EXPECT_LT((x - c.surface.positions.col(n.node)).norm(), 1e-14);
    EXPECT_GE(n.bary.minCoeff(), -1e-12);
  }
  // The pieces of each edge cover it exactly once (edges in shared faces listed once).
  const SurfaceEdges edges = build_surface_edges(c.surface.triangles);
  std::vector<double> covered(edges.edges.size(), 0.0);
  for (const IntrudingEdge& e : got.edges_in_tets)
    covered[static_cast<std::size_t>(e.edge)] += e.lambda_out - e.lambda_in;
  for (std::size_t e = 0; e < covered.size(); ++e)
    EXPECT_NEAR(covered[e], 1.0, 1e-12) << "edge " << e;
}

TEST(SurfaceDetect, BallSurfaceNodesInsideTheBoxAreFoundAndNoOthers) {
  const Case c = ball_surface_into_box();
  const SurfaceContacts got = detect(c);
  std::set<Index> found;
  for (const IntrudingNode& n : got.nodes_in_tets) found.insert(n.node);
  std::set<Index> used;
  for (const Triangle& t : c.surface.triangles) used.insert(t.begin(), t.end());
  int inside = 0;
  for (const Index v : used) {
    const double z = c.surface.positions(2, v);
    // The box is [0, 1]^3 and the ball sits well inside it in x and y.
    if (z < 1.0 - 1e-9) {
      ++inside;
      EXPECT_TRUE(found.count(v)) << "node " << v << " at z " << z;
    } else if (z > 1.0 + 1e-9) {
      EXPECT_FALSE(found.count(v)) << "node " << v << " at z " << z;
    }
  }
  EXPECT_GT(inside, 10);
}

TEST(SurfaceDetect, DeterministicForOneToFourThreads) {
  // Big enough for several chunks of every parallel loop (256 items each).
  Case big{test::square_surface(16, 1.0, 0.3), test::structured_box(5, 5, 5, {0, 0, 0}, {1, 1, 1})};
  for (Eigen::Index i = 0; i < big.surface.positions.cols(); ++i)
    big.surface.positions(2, i) += 0.2 * big.surface.positions(0, i);  // tilted
  const std::vector<Case> cases = {ball_surface_into_box(), big};
  std::vector<std::vector<SurfaceContacts>> results(cases.size());
  for (const int threads : {1, 2, 3, 4}) {
    tbb::task_arena arena(threads);
    for (std::size_t c = 0; c < cases.size(); ++c)
      arena.execute([&] { results[c].push_back(detect(cases[c])); });
  }
  {
    // Last: TBB keeps a global limit's effect on its worker pool for a while.
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    for (std::size_t c = 0; c < cases.size(); ++c) results[c].push_back(detect(cases[c]));
  }
  for (std::size_t c = 0; c < cases.size(); ++c) {
    ASSERT_FALSE(results[c][0].edges_in_tets.empty());
    for (std::size_t i = 1; i < results[c].size(); ++i)
      expect_identical(results[c][i], results[c][0],
                       "case " + std::to_string(c) + " run " + std::to_string(i));
  }
  const SurfaceContacts got = detect(big);
  EXPECT_GT(got.nodes_in_tets.size(), 256u);
  EXPECT_GT(got.overlapping.size(), 1024u);
  EXPECT_GT(got.edges_in_tets.size(), 1024u);
}

TEST(SurfaceDetect, ApartEmptyAndNonFiniteNodesTakePartInNothing) {
  Case c = plate_in_box();
  for (Eigen::Index i = 0; i < c.surface.positions.cols(); ++i) c.surface.positions(2, i) += 5.0;
  SurfaceDetectStats stats;
  EXPECT_TRUE(detect(c, {}, &stats).empty());
  EXPECT_FALSE(stats.boxes_overlap);
  EXPECT_EQ(stats.candidates, 0u);

  // Resting exactly on the top face of the box: touching only.
  c = plate_in_box();
  for (Eigen::Index i = 0; i < c.surface.positions.cols(); ++i) c.surface.positions(2, i) = 1.0;
  EXPECT_TRUE(detect(c).empty());

  // A NaN node: its triangles and edges are skipped, the rest is as brute force says.
  c = plate_in_box();
  c.surface.positions(1, 40) = std::numeric_limits<double>::quiet_NaN();
  const SurfaceContacts got = detect(c);
  expect_identical(got, brute_force(c), "NaN node");
  for (const IntrudingNode& n : got.nodes_in_tets) EXPECT_NE(n.node, 40);
  for (const TriTetPair& p : got.overlapping)
    for (const Index v : c.surface.triangles[static_cast<std::size_t>(p.triangle)])
      EXPECT_NE(v, 40);
}

TEST(SurfaceDetect, SwitchesAndEdgesFromOtherTrianglesAreRefused) {
  const Case c = plate_in_box();
  DetectOptions options;
  options.intruding_nodes = false;
  options.intruding_edges = false;
  const SurfaceContacts got = detect(c, options);
  EXPECT_FALSE(got.overlapping.empty());
  EXPECT_TRUE(got.nodes_in_tets.empty());
  EXPECT_TRUE(got.edges_in_tets.empty());
  const SurfaceEdges other = build_surface_edges(test::cube_surface().triangles);
  EXPECT_THROW(detect_surface_tets(c.surface.positions, c.surface.triangles, other,
                                   c.tets.positions, c.tets.tets),
               std::invalid_argument);
}

}  // namespace
}  // namespace tc
