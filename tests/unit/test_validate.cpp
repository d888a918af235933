// service/core/mesh/validate: defects are found, counted, listed, never fixed.
#include "core/mesh/validate.hpp"

#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/mesh/geometry.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

TEST(Validate, CleanMeshes) {
  for (const TetMesh& m : {test::single_tet(), test::cube_five_tets(), test::cube_six_tets(),
                           test::structured_box(2, 3, 2, {0, 0, 0}, {1, 1, 1})}) {
    const ValidationReport r = validate_mesh(m);
    EXPECT_TRUE(r.clean()) << r.summary();
    EXPECT_TRUE(r.summary().empty());
    EXPECT_GT(r.min_quality, 0.1);
    EXPECT_TRUE(require_valid(r, "mesh").ok());
  }
}

TEST(Validate, RegularTetHasQualityOne) {
  TetMesh m = test::single_tet();
  m.positions.col(0) << 1, 1, 1;
  m.positions.col(1) << 1, -1, -1;
  m.positions.col(2) << -1, 1, -1;
  m.positions.col(3) << -1, -1, 1;
  EXPECT_NEAR(std::abs(tet_quality(m.positions, m.tets[0])), 1.0, 1e-14);
}

TEST(Validate, InvertedTetIsReportedNotFlipped) {
  TetMesh m = test::cube_six_tets();
  std::swap(m.tets[3][0], m.tets[3][1]);
  const Tet before = m.tets[3];
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.inverted.count, 1u);
  ASSERT_EQ(r.inverted.first.size(), 1u);
  EXPECT_EQ(r.inverted.first[0], 3);
  EXPECT_EQ(m.tets[3], before);
  EXPECT_FALSE(r.clean());
  const Status st = require_valid(r, "obj");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kInvalidMesh);
  EXPECT_NE(st.error().message.find("obj: 1 inverted tets (first: 3)"), std::string::npos)
      << st.error().message;
}

TEST(Validate, OutOfRangeAndRepeatedIndices) {
  TetMesh m = test::cube_five_tets();
  m.tets[1][2] = 8;  // n == 8
  m.tets[2][0] = -1;
  m.tets[4][3] = m.tets[4][0];
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.index_out_of_range.count, 2u);
  EXPECT_EQ(r.index_out_of_range.first, (std::vector<Index>{1, 2}));
  EXPECT_EQ(r.repeated_node.count, 1u);
  EXPECT_TRUE(r.structurally_invalid());
  // A repeated node is not also counted as a degenerate shape.
  EXPECT_EQ(r.degenerate.count, 0u);
}

TEST(Validate, NonFiniteCoordinates) {
  TetMesh m = test::cube_six_tets();
  m.positions(1, 5) = std::numeric_limits<double>::quiet_NaN();
  m.positions(0, 6) = std::numeric_limits<double>::infinity();
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.nonfinite_node.count, 2u);
  EXPECT_EQ(r.nonfinite_node.first, (std::vector<Index>{5, 6}));
  EXPECT_TRUE(r.structurally_invalid());
  EXPECT_TRUE(std::isfinite(r.min_quality));
  EXPECT_TRUE(validate_positions(m.positions, m.tets).structurally_invalid());
}

TEST(Validate, ListsAreCappedButCountsAreNot) {
  TetMesh m = test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1});
  for (Tet& t : m.tets) std::swap(t[0], t[1]);
  ValidationOptions opt;
  opt.max_listed = 3;
  const ValidationReport r = validate_mesh(m, opt);
  EXPECT_EQ(r.inverted.count, m.tets.size());
  EXPECT_EQ(r.inverted.first.size(), 3u);
}

// Flattening a tet by moving its apex toward the base plane: degenerate below the
// tolerance, a sliver above it, valid beyond the sliver threshold; at any scale and
// offset (the tolerance is relative to the tet's own size).
struct FlatCase {
  double height;
  double scale;
  double offset;
};

class Flattening : public ::testing::TestWithParam<FlatCase> {};

TEST_P(Flattening, ClassifiedByRelativeVolume) {
  const auto [h, s, off] = GetParam();
  TetMesh m = test::single_tet();
  m.positions.col(3) << 0.3, 0.3, h;
  m.positions = (m.positions.array() * s + off).matrix();
  const ValidationReport r = validate_mesh(m);
  const double q = tet_quality(m.positions, m.tets[0]);
  if (std::abs(q) < 1e-6) {
    EXPECT_EQ(r.degenerate.count, 1u) << "q=" << q;
  } else if (q < 0) {
    EXPECT_EQ(r.inverted.count, 1u) << "q=" << q;
  } else if (q < 1e-2) {
    EXPECT_EQ(r.sliver.count, 1u) << "q=" << q;
    EXPECT_TRUE(r.clean());
  } else {
    EXPECT_TRUE(r.clean());
    EXPECT_EQ(r.sliver.count, 0u);
  }
  EXPECT_EQ(r.degenerate.count + r.inverted.count + r.sliver.count, h == 1.0 ? 0u : 1u);
}

INSTANTIATE_TEST_SUITE_P(HeightsScalesOffsets, Flattening,
                         ::testing::Values(FlatCase{0.0, 1.0, 0.0}, FlatCase{1e-9, 1.0, 0.0},
                                           FlatCase{-1e-9, 1.0, 0.0}, FlatCase{1e-3, 1.0, 0.0},
                                           FlatCase{-0.5, 1.0, 0.0}, FlatCase{1.0, 1.0, 0.0},
                                           FlatCase{0.0, 1e-6, 0.0}, FlatCase{1e-3, 1e-6, 0.0},
                                           FlatCase{1.0, 1e-6, 0.0}, FlatCase{1e-3, 1.0, 1e6},
                                           FlatCase{1.0, 1.0, 1e6}, FlatCase{-0.5, 1e-6, 1e6}));

// The shape check runs in parallel chunks: on a mesh of many chunks with defects spread
// over them, the counts, the first listed indices (the smallest, in order) and the
// smallest quality are those of a serial scan, with 1 and 2 threads.
TEST(Validate, ParallelChunksReportLikeASerialScan) {
  TetMesh m = test::structured_box(24, 24, 12, {0, 0, 0}, {1, 1, 0.5});
  ASSERT_GT(m.tets.size(), 30000u);
  std::mt19937 rng(17);
  std::vector<Index> inverted;
  for (int k = 0; k < 40; ++k) {
    const auto t = static_cast<Index>(rng() % m.tets.size());
    if (std::find(inverted.begin(), inverted.end(), t) != inverted.end()) continue;
    std::swap(m.tets[t][0], m.tets[t][1]);  // same nodes, opposite orientation
    inverted.push_back(t);
  }
  std::sort(inverted.begin(), inverted.end());
  double min_q = 1.0;
  for (const Tet& t : m.tets) min_q = std::min(min_q, tet_quality(m.positions, t));
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const ValidationReport r = validate_positions(m.positions, m.tets);
    EXPECT_EQ(r.inverted.count, inverted.size());
    EXPECT_EQ(r.inverted.first, std::vector<Index>(inverted.begin(), inverted.begin() + 8));
    EXPECT_EQ(r.degenerate.count, 0u);
    EXPECT_EQ(r.min_quality, min_q);
  }
}

TEST(Validate, AllNodesCoincidentIsDegenerate) {
  TetMesh m = test::single_tet();
  for (int i = 0; i < 4; ++i) m.positions.col(i) << 2, 2, 2;
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.degenerate.count, 1u);
}

}  // namespace
}  // namespace tc
