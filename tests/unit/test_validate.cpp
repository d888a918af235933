// service/core/mesh/validate: defects are found, counted, listed, never fixed.
#include "core/mesh/validate.hpp"

#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include "core/mesh/geometry.hpp"
#include "kernel_copies.hpp"
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
  const TetMesh m = test::regular_tet();
  EXPECT_NEAR(tet_quality(m.positions, m.tets[0]), 1.0, 1e-14);
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

// The per-frame check without the smallest quality (compute_min_quality = false) skips
// tet_quality() for tets that are surely not slivers; it must find the same defects. Loose
// tets, randomly placed, scaled and oriented, with qualities just around every threshold
// (within the fast test's margin and outside it), well-shaped ones, and a multiple of the
// lane width plus a remainder.
using test::BothKernels;

TEST_P(BothKernels, WithoutTheSmallestQualityTheDefectsAreTheSame) {
  const ValidationOptions exact_opt = [] {
    ValidationOptions o;
    o.max_listed = 100000;
    return o;
  }();
  ValidationOptions fast_opt = exact_opt;
  fast_opt.compute_min_quality = false;
  const double s = exact_opt.sliver_quality, d = exact_opt.degenerate_quality;
  std::vector<double> targets = {0.5, 0.9, 0.02, -0.3, -s, -d * 2, 0.0};
  for (const double rel : {1e-13, 1e-10, 1e-7, 4e-6, 6e-6, 1e-4})
    for (const double t : {s, d, -d})
      for (const double sign : {-1.0, 1.0}) targets.push_back(t * (1.0 + sign * rel));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  TetMesh m;
  std::vector<Eigen::Vector3d> nodes;
  for (int copy = 0; copy < 9; ++copy)
    for (const double target : targets) {
      // A right-angled base in the xy plane and an apex above (0.3, 0.3): quality grows
      // with the height h on [0, 0.05] (a tenth of the maximum's height); bisect for
      // |target| there, then flip the apex below the base for a negative target.
      const auto quality = [](double h) {
        Positions p(3, 4);
        p << 0, 1, 0, 0.3, 0, 0, 1, 0.3, 0, 0, 0, h;
        return tet_quality(p, Tet{0, 1, 2, 3});
      };
      double lo = 0.0, hi = 0.05;
      const double goal = std::abs(target);
      for (int it = 0; it < 200 && std::abs(target) < 0.05; ++it)
        (quality(0.5 * (lo + hi)) < goal ? lo : hi) = 0.5 * (lo + hi);
      double h = std::abs(target) < 0.05 ? 0.5 * (lo + hi) : 0.5 + 2.0 * std::abs(target);
      if (target < 0.0) h = -h;
      const Eigen::Matrix3d rot =
          Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized())
              .toRotationMatrix();
      const double scale = std::pow(10.0, 3.0 * u(rng));
      const Eigen::Vector3d offset(1e3 * u(rng), 1e3 * u(rng), 1e3 * u(rng));
      const Eigen::Vector3d base[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, h}};
      const auto first = static_cast<Index>(nodes.size());
      for (const auto& x : base) nodes.push_back(offset + scale * (rot * x));
      m.tets.push_back({first, first + 1, first + 2, first + 3});
    }
  m.positions.resize(3, static_cast<Index>(nodes.size()));
  for (std::size_t i = 0; i < nodes.size(); ++i) m.positions.col(static_cast<Index>(i)) = nodes[i];
  ASSERT_GT(m.tets.size() % 8, 0u);

  const ValidationReport exact = validate_positions(m.positions, m.tets, exact_opt);
  EXPECT_GT(exact.sliver.count, 0u);
  EXPECT_GT(exact.degenerate.count, 0u);
  EXPECT_GT(exact.inverted.count, 0u);
  EXPECT_LT(exact.sliver.count + exact.degenerate.count + exact.inverted.count, m.tets.size());
  for (const int threads : {1, 2}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const ValidationReport fast = validate_positions(m.positions, m.tets, fast_opt);
    EXPECT_EQ(fast.degenerate.first, exact.degenerate.first);
    EXPECT_EQ(fast.inverted.first, exact.inverted.first);
    EXPECT_EQ(fast.sliver.first, exact.sliver.first);
    EXPECT_EQ(fast.degenerate.count, exact.degenerate.count);
    EXPECT_EQ(fast.inverted.count, exact.inverted.count);
    EXPECT_EQ(fast.sliver.count, exact.sliver.count);
    EXPECT_TRUE(std::isnan(fast.min_quality));
  }
}

// The fast test decides only where tet_quality() computes without overflow or underflow;
// elsewhere the report is tet_quality()'s. Before, a node at 1e231 m (squared lengths
// infinite: quality 0, degenerate) and a sliver 1e-105 m across (6V and l2^3 below the
// smallest number: 0 >= 0) passed the fast test in a block of eight, and were reported
// only when they fell in the remainder (found by the fuzz target `mesh`).
TEST_P(BothKernels, TetsOfExtremeSizesGetTheReportOfTheirQuality) {
  ValidationOptions exact_opt;
  exact_opt.max_listed = 100000;
  ValidationOptions fast_opt = exact_opt;
  fast_opt.compute_min_quality = false;
  const Eigen::Vector3d regular[4] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.866, 0}, {0.5, 0.289, 0.816}};
  const Eigen::Vector3d sliver[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 0.004}};
  const Eigen::Vector3d far[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 1e231}};
  struct Case {
    const Eigen::Vector3d* shape;
    double scale;
  };
  const Case cases[] = {{regular, 1.0},    {far, 1.0},       {sliver, 1e-105},  {regular, 1e-105},
                        {regular, 1e-150}, {sliver, 1e-150}, {regular, 1e103},  {sliver, 1e103},
                        {regular, 1e150},  {sliver, 1.0},    {regular, 1e-300}, {far, 1e-200}};
  TetMesh m;
  std::vector<Eigen::Vector3d> nodes;
  for (int copy = 0; copy < 3; ++copy)  // each case in lanes of every kind, and alone
    for (const Case& c : cases) {
      const auto first = static_cast<Index>(nodes.size());
      for (int k = 0; k < 4; ++k) nodes.push_back(c.scale * c.shape[k]);
      m.tets.push_back({first, first + 1, first + 2, first + 3});
    }
  m.positions.resize(3, static_cast<Index>(nodes.size()));
  for (std::size_t i = 0; i < nodes.size(); ++i) m.positions.col(static_cast<Index>(i)) = nodes[i];
  ASSERT_GT(m.tets.size() % 8, 0u);
  const ValidationReport exact = validate_positions(m.positions, m.tets, exact_opt);
  EXPECT_GT(exact.degenerate.count, 0u);  // the far node's tets at least
  EXPECT_GT(exact.sliver.count, 0u);
  for (std::size_t skip = 0; skip < 8; ++skip) {  // every tet in every lane
    SCOPED_TRACE(skip);
    TetCheckOrder order;  // the tets from `skip` on, then the first `skip`
    for (std::size_t k = 0; k < m.tets.size(); ++k) {
      const std::size_t t = (k + skip) % m.tets.size();
      order.index.push_back(static_cast<Index>(t));
      order.tets.push_back(m.tets[t]);
    }
    const ValidationReport fast = validate_positions(m.positions, order, fast_opt);
    EXPECT_EQ(fast.degenerate.first, exact.degenerate.first);
    EXPECT_EQ(fast.inverted.first, exact.inverted.first);
    EXPECT_EQ(fast.sliver.first, exact.sliver.first);
    EXPECT_EQ(fast.degenerate.count, exact.degenerate.count);
    EXPECT_EQ(fast.sliver.count, exact.sliver.count);
  }
}

// A tet whose quality is not finite (6V and l2^1.5 both infinite, or both 0, or only the
// latter 0) had no class at all, so a mesh of such tets was clean: now it is degenerate,
// and refused.
TEST(Validate, ATetWhoseQualityIsNotFiniteIsDegenerate) {
  TetMesh m = test::regular_tet();
  const Positions unit = m.positions;
  for (const double scale : {1e160, 1e103, 1e-110, 1e-150}) {
    SCOPED_TRACE(scale);
    m.positions = scale * unit;
    ASSERT_FALSE(std::isfinite(tet_quality(m.positions, m.tets[0])));
    const ValidationReport report = validate_mesh(m);
    EXPECT_EQ(report.degenerate.count, 1u);
    EXPECT_FALSE(report.clean());
    EXPECT_EQ(validate_positions(m.positions, m.tets, ValidationOptions{}).degenerate.count, 1u);
  }
  m.positions = 1e100 * unit;  // large, but computed: still a good tet
  EXPECT_TRUE(validate_mesh(m).clean());
}

INSTANTIATE_TEST_SUITE_P(Validate, BothKernels, ::testing::Bool(), test::kernel_copy_name);

// The per-frame check visits the tets in a spatial order (make_tet_check_order); the
// report must be that of index order for any order: counts, the smallest indices listed,
// the smallest quality; with and without the smallest quality, on 1 and 2 threads.
TEST(Validate, AnyCheckOrderGivesTheSameReport) {
  TetMesh m = test::structured_box(24, 24, 12, {0, 0, 0}, {1, 1, 0.5});
  std::mt19937 rng(29);
  for (int k = 0; k < 600; ++k) {  // tens per chunk of 8192 tets: more than max_listed
    Tet& t = m.tets[rng() % m.tets.size()];
    if (k % 3 == 0) {
      std::swap(t[0], t[1]);  // inverted
    } else {
      // Flattened: a fresh node on the plane of the other three (degenerate), or near it.
      const Index apex = m.num_nodes();
      m.positions.conservativeResize(3, apex + 1);
      m.positions.col(apex) =
          (m.positions.col(t[0]) + m.positions.col(t[1]) + m.positions.col(t[2])) / 3.0 +
          (k % 3 == 1 ? 0.0 : 1e-3) * (m.positions.col(t[3]) - m.positions.col(t[0]));
      t[3] = apex;
    }
  }
  for (const std::size_t listed : {std::size_t{8}, std::size_t{1000}}) {
    ValidationOptions exact_opt;
    exact_opt.max_listed = listed;
    ValidationOptions fast_opt = exact_opt;
    fast_opt.compute_min_quality = false;
    for (const ValidationOptions& opt : {exact_opt, fast_opt}) {
      const ValidationReport ref = validate_positions(m.positions, m.tets, opt);
      ASSERT_GT(ref.inverted.count, 100u);
      ASSERT_GT(ref.degenerate.count, 100u);
      ASSERT_GT(ref.sliver.count, 100u);
      std::vector<Index> shuffled(m.tets.size());
      std::iota(shuffled.begin(), shuffled.end(), Index{0});
      std::shuffle(shuffled.begin(), shuffled.end(), rng);
      std::vector<Index> reversed(shuffled.size());
      std::iota(reversed.rbegin(), reversed.rend(), Index{0});
      TetCheckOrder morton = make_tet_check_order(m.positions, m.tets);
      ASSERT_EQ(morton.index.size(), m.tets.size());
      for (const std::vector<Index>& order : {morton.index, shuffled, reversed})
        for (const int threads : {1, 2}) {
          tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
          TetCheckOrder check;
          check.index = order;
          for (const Index t : order) check.tets.push_back(m.tets[static_cast<std::size_t>(t)]);
          const ValidationReport r = validate_positions(m.positions, check, opt);
          EXPECT_EQ(r.inverted.count, ref.inverted.count);
          EXPECT_EQ(r.degenerate.count, ref.degenerate.count);
          EXPECT_EQ(r.sliver.count, ref.sliver.count);
          EXPECT_EQ(r.inverted.first, ref.inverted.first);
          EXPECT_EQ(r.degenerate.first, ref.degenerate.first);
          EXPECT_EQ(r.sliver.first, ref.sliver.first);
          if (opt.compute_min_quality) {
            EXPECT_EQ(r.min_quality, ref.min_quality);
          } else {
            EXPECT_TRUE(std::isnan(r.min_quality));
          }
        }
    }
  }
  TetCheckOrder bad = make_tet_check_order(m.positions, m.tets);
  bad.index.pop_back();
  EXPECT_THROW(validate_positions(m.positions, bad), std::invalid_argument);
}

TEST(Validate, AllNodesCoincidentIsDegenerate) {
  TetMesh m = test::single_tet();
  for (int i = 0; i < 4; ++i) m.positions.col(i) << 2, 2, 2;
  const ValidationReport r = validate_mesh(m);
  EXPECT_EQ(r.degenerate.count, 1u);
}

}  // namespace
}  // namespace tc
