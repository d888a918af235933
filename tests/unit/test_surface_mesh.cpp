// service/core/mesh/surface_mesh: the triangle-surface model, its validation (defects
// found, counted, listed, never fixed), its edges and its statistics.
#include "core/mesh/surface_mesh.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

using test::cube_surface;
using test::square_surface;

SurfaceStats stats_of(const SurfaceMesh& m) {
  const SurfaceValidationReport r = validate_surface(m);
  EXPECT_FALSE(r.structurally_invalid()) << r.summary();
  return compute_surface_stats(m, build_surface_edges(m.triangles), r);
}

TEST(TriangleQuality, EquilateralIsOneCollinearIsZeroAtAnyScaleAndOffset) {
  for (const double scale : {1e-6, 1.0, 1e3})
    for (const double offset : {0.0, 1e6}) {
      const Vector3d o = Vector3d::Constant(offset);
      const Vector3d a = o, b = o + scale * Vector3d(1, 0, 0),
                     c = o + scale * Vector3d(0.5, std::sqrt(3.0) / 2, 0);
      EXPECT_NEAR(triangle_quality(a, b, c), 1.0, offset > 0 && scale < 1 ? 1e-4 : 1e-12);
      EXPECT_EQ(triangle_quality(o, o + scale * Vector3d(1, 1, 1), o + scale * Vector3d(2, 2, 2)),
                0.0);
    }
  EXPECT_EQ(triangle_quality(Vector3d::Ones(), Vector3d::Ones(), Vector3d::Ones()), 0.0);
  // A right isosceles triangle: 4 sqrt(3) (1/2) / (1 + 1 + 2).
  EXPECT_NEAR(triangle_quality(Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0)),
              std::sqrt(3.0) / 2, 1e-15);
}

TEST(SurfaceValidate, CleanSurfacesPass) {
  for (const SurfaceMesh& m :
       {cube_surface(), cube_surface(1e-6, Vector3d::Constant(1e6)), square_surface()}) {
    const SurfaceValidationReport r = validate_surface(m);
    EXPECT_TRUE(r.clean()) << r.summary();
    EXPECT_TRUE(r.summary().empty());
    EXPECT_TRUE(require_valid_surface(r, "s").ok());
    EXPECT_GT(r.min_quality, 0.5);
  }
}

TEST(SurfaceValidate, IndicesOutOfRangeAndRepeatedNodesNameTheTriangles) {
  SurfaceMesh m = cube_surface();
  m.triangles[3][1] = 8;  // n == 8
  m.triangles[5][0] = -1;
  m.triangles[7][2] = m.triangles[7][0];
  const SurfaceValidationReport r = validate_surface(m);
  EXPECT_EQ(r.index_out_of_range.count, 2u);
  EXPECT_EQ(r.index_out_of_range.first, (std::vector<Index>{3, 5}));
  EXPECT_EQ(r.repeated_node.count, 1u);
  EXPECT_EQ(r.repeated_node.first, (std::vector<Index>{7}));
  EXPECT_EQ(r.degenerate.count, 0u);  // the repeated-node triangle is not counted twice
  EXPECT_TRUE(r.structurally_invalid());
  const Status st = require_valid_surface(r, "tool.stl");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kInvalidMesh);
  EXPECT_EQ(st.error().message,
            "tool.stl: 2 triangles with a node index out of range (first: 3, 5); "
            "1 triangles with a repeated node (first: 7)");
}

TEST(SurfaceValidate, NonFiniteCoordinatesNameTheNodes) {
  for (const double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity()}) {
    SurfaceMesh m = cube_surface();
    m.positions(1, 6) = bad;
    const SurfaceValidationReport r = validate_surface(m);
    EXPECT_EQ(r.nonfinite_node.count, 1u);
    EXPECT_EQ(r.nonfinite_node.first, (std::vector<Index>{6}));
    EXPECT_EQ(r.degenerate.count, 0u);  // triangles on node 6 are not judged
    const Status st = require_valid_surface(r, "s");
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error().message, "s: 1 nodes with non-finite coordinates (first: 6)");
  }
}

TEST(SurfaceValidate, DegenerateIsRelativeToTheTriangleSize) {
  // Collinear, coincident, and a needle thinner than the tolerance at any scale and
  // offset; a thin but valid triangle (quality ~1e-5) passes.
  for (const double scale : {1e-6, 1.0, 1e3})
    for (const double offset : {0.0, 1e6}) {
      if (offset > 0 && scale < 1) continue;  // 1e-6 objects 1e6 away: rounding dominates
      SurfaceMesh m = square_surface();
      const Vector3d o = Vector3d::Constant(offset);
      m.positions.resize(3, 9);
      const Vector3d pts[9] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0},    {2, 0, 0},   {0.5, 0, 0},
                               {1, 1, 1}, {1, 1, 1}, {1, 1e-9, 0}, {1, 1e-5, 0}};
      for (int i = 0; i < 9; ++i) m.positions.col(i) = o + scale * pts[i];
      m.node_ids.resize(9);
      m.triangles = {{0, 1, 2}, {0, 3, 4}, {0, 5, 6}, {0, 3, 7}, {0, 3, 8}};
      const SurfaceValidationReport r = validate_surface(m);
      EXPECT_EQ(r.degenerate.first, (std::vector<Index>{1, 2, 3})) << scale << " " << offset;
      EXPECT_EQ(r.degenerate.count, 3u);
      EXPECT_FALSE(r.structurally_invalid());
      EXPECT_FALSE(r.clean());
      const Status st = require_valid_surface(r, "shell");
      ASSERT_FALSE(st.ok());
      EXPECT_EQ(st.error().code, ErrorCode::kInvalidMesh);
      EXPECT_EQ(st.error().message, "shell: 3 degenerate (zero-area) triangles (first: 1, 2, 3)");
    }
}

TEST(SurfaceValidate, OversizedCountsAreKOversizedAndStopTheCheck) {
  SurfaceMesh m = cube_surface();
  m.triangles[0][0] = 99;  // not reported: the size check comes first
  SurfaceValidationOptions opt;
  opt.max_nodes = 7;
  SurfaceValidationReport r = validate_surface(m, opt);
  EXPECT_TRUE(r.too_many_nodes);
  EXPECT_FALSE(r.too_many_triangles);
  EXPECT_EQ(r.index_out_of_range.count, 0u);
  Status st = require_valid_surface(r, "big.stl");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kOversized);
  EXPECT_EQ(st.error().message, "big.stl: 8 nodes, more than the limit");
  opt = {};
  opt.max_triangles = 11;
  r = validate_surface(m, opt);
  EXPECT_TRUE(r.too_many_triangles);
  st = require_valid_surface(r, "big.stl");
  EXPECT_EQ(st.error().message, "big.stl: 12 triangles, more than the limit");
  opt.max_triangles = 12;
  EXPECT_FALSE(validate_surface(m, opt).oversized());
}

TEST(SurfaceValidate, EmptySurfaceIsCleanAndHasNoStats) {
  const SurfaceMesh m;
  const SurfaceValidationReport r = validate_surface(m);
  EXPECT_TRUE(r.clean());
  const SurfaceStats s = compute_surface_stats(m, build_surface_edges(m.triangles), r);
  EXPECT_EQ(s.triangles, 0);
  EXPECT_FALSE(s.closed);
  EXPECT_EQ(s.components, 0);
}

TEST(SurfaceEdges, CubeEdgesAreSortedUniqueAndEachTriangleKnowsItsOwn) {
  const SurfaceMesh m = cube_surface();
  const SurfaceEdges e = build_surface_edges(m.triangles);
  ASSERT_EQ(e.edges.size(), 18u);  // 12 cube edges + 6 face diagonals
  for (std::size_t i = 0; i < e.edges.size(); ++i) {
    EXPECT_LT(e.edges[i][0], e.edges[i][1]);
    if (i > 0) {
      EXPECT_LT(e.edges[i - 1], e.edges[i]);
    }
    EXPECT_EQ(e.triangle_count[i], 2);
    EXPECT_EQ(e.forward_count[i], 1);
  }
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index u = m.triangles[t][static_cast<std::size_t>(k)];
      const Index v = m.triangles[t][static_cast<std::size_t>((k + 1) % 3)];
      const auto& edge = e.edges[static_cast<std::size_t>(e.triangle_edges[t][k])];
      EXPECT_EQ(edge, (std::array<Index, 2>{std::min(u, v), std::max(u, v)}));
    }
}

TEST(SurfaceStats, ClosedCubeHasItsVolumeAreaAndOrientation) {
  for (const double scale : {1e-3, 1.0, 2.0})
    for (const double offset : {0.0, 1e6}) {
      const SurfaceStats s = stats_of(cube_surface(scale, Vector3d::Constant(offset)));
      EXPECT_EQ(s.nodes, 8);
      EXPECT_EQ(s.triangles, 12);
      EXPECT_EQ(s.edges, 18);
      EXPECT_EQ(s.boundary_edges, 0);
      EXPECT_EQ(s.nonmanifold_edges, 0);
      EXPECT_EQ(s.misoriented_edges, 0);
      EXPECT_EQ(s.components, 1);
      EXPECT_EQ(s.unused_nodes, 0);
      EXPECT_TRUE(s.closed);
      EXPECT_TRUE(s.oriented);
      EXPECT_TRUE(s.outward);
      // The corners themselves carry a rounding of offset * eps / scale (relative).
      const double rel = 1e-12 + 8 * offset * std::numeric_limits<double>::epsilon() / scale;
      EXPECT_NEAR(s.enclosed_volume, scale * scale * scale, rel * scale * scale * scale);
      EXPECT_NEAR(s.area, 6 * scale * scale, rel * scale * scale);
      EXPECT_EQ(s.bbox_lo, Vector3d::Constant(offset));
      EXPECT_EQ(s.bbox_hi, Vector3d::Constant(offset + scale * 1.0));
    }
}

TEST(SurfaceStats, InwardCubeAndOneFlippedTriangle) {
  SurfaceMesh inward = cube_surface();
  for (Triangle& t : inward.triangles) std::swap(t[1], t[2]);
  SurfaceStats s = stats_of(inward);
  EXPECT_TRUE(s.oriented);
  EXPECT_FALSE(s.outward);
  EXPECT_NEAR(s.enclosed_volume, 1.0, 1e-14);

  SurfaceMesh flipped = cube_surface();
  std::swap(flipped.triangles[4][1], flipped.triangles[4][2]);
  s = stats_of(flipped);
  EXPECT_TRUE(s.closed);
  EXPECT_EQ(s.misoriented_edges, 3);
  EXPECT_FALSE(s.oriented);
  EXPECT_EQ(s.enclosed_volume, 0.0);  // unknown, not guessed
}

TEST(SurfaceStats, OpenSquareNonManifoldFinAndUnusedNode) {
  SurfaceStats s = stats_of(square_surface());
  EXPECT_FALSE(s.closed);
  EXPECT_EQ(s.boundary_edges, 4);
  EXPECT_EQ(s.edges, 5);
  EXPECT_NEAR(s.area, 1.0, 1e-15);
  EXPECT_EQ(s.enclosed_volume, 0.0);

  // A fin: a third triangle on the diagonal (0, 3), and an unused node, a second
  // component (a lone triangle).
  SurfaceMesh m = square_surface();
  m.positions.conservativeResize(3, 9);
  m.positions.col(4) << 0.5, 0.5, 1;
  m.positions.col(5) << 5, 5, 5;  // unused
  m.positions.col(6) << 3, 0, 0;
  m.positions.col(7) << 4, 0, 0;
  m.positions.col(8) << 3, 1, 0;
  m.node_ids.resize(9);
  m.triangles.push_back({0, 3, 4});
  m.triangles.push_back({6, 7, 8});
  s = stats_of(m);
  EXPECT_EQ(s.nonmanifold_edges, 1);
  EXPECT_EQ(s.boundary_edges, 4 + 2 + 3);
  EXPECT_EQ(s.unused_nodes, 1);
  EXPECT_EQ(s.components, 2);
  EXPECT_FALSE(s.closed);
  EXPECT_EQ(s.bbox_hi, Vector3d(4, 1, 1));  // the unused node is not in the box
}

}  // namespace
}  // namespace tc
