// service/core/detect/broad_phase: every method against brute force over all pairs.
#include "core/detect/broad_phase.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <tuple>

#include "core/mesh/geometry.hpp"
#include "kernel_copies.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

/// A soup of m random tets: centres in [0, 1]^3, sizes log-uniform in [size/10, size],
/// with a few outsized, flat and non-finite tets mixed in.
TetMesh soup(std::mt19937& rng, int m, double size, bool oddities) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  TetMesh mesh;
  mesh.positions.resize(3, 4 * m);
  for (int t = 0; t < m; ++t) {
    const Vector3d c(u(rng), u(rng), u(rng));
    double s = size * std::pow(10.0, -u(rng));
    if (oddities && t % 97 == 5) s = 0.6;  // outsized
    for (int k = 0; k < 4; ++k) {
      Vector3d p = c + s * Vector3d(u(rng) - 0.5, u(rng) - 0.5, u(rng) - 0.5);
      if (oddities && t % 89 == 7) p.z() = c.z();  // flat
      mesh.positions.col(4 * t + k) = p;
    }
    if (oddities && t % 101 == 11) mesh.positions(1, 4 * t + 2) = std::nan("");
    mesh.tets.push_back({4 * t, 4 * t + 1, 4 * t + 2, 4 * t + 3});
  }
  return mesh;
}

TetMesh transformed(TetMesh m, double scale, const Vector3d& offset) {
  for (Eigen::Index i = 0; i < m.positions.cols(); ++i)
    m.positions.col(i) = m.positions.col(i) * scale + offset;
  return m;
}

bool sphere_overlap(const BoundingSphere& a, const BoundingSphere& b) {
  return a.radius >= 0 && b.radius >= 0 && (a.center - b.center).norm() <= a.radius + b.radius;
}

/// Boxes of `tets` clipped to `clip` (empty when outside).
std::vector<Aabb> clipped(const TetBounds& bounds, std::span<const Index> tets, const Aabb& clip) {
  std::vector<Aabb> boxes;
  for (const Index t : tets) boxes.push_back(bounds.boxes[t].intersection(clip));
  return boxes;
}

std::vector<TetPair> brute_force(BroadPhaseKind kind, const TetBounds& a, std::span<const Index> sa,
                                 std::span<const Aabb> ba, const TetBounds& b,
                                 std::span<const Index> sb, std::span<const Aabb> bb) {
  std::vector<TetPair> out;
  for (std::size_t i = 0; i < sa.size(); ++i)
    for (std::size_t j = 0; j < sb.size(); ++j)
      if (ba[i].overlaps(bb[j]) &&
          (kind != BroadPhaseKind::kGrid || sphere_overlap(a.spheres[sa[i]], b.spheres[sb[j]])))
        out.push_back({sa[i], sb[j]});
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Index> all_tets(const TetMesh& m) {
  std::vector<Index> v(static_cast<std::size_t>(m.num_tets()));
  std::iota(v.begin(), v.end(), 0);
  return v;
}

/// Tets whose box meets `box`.
std::vector<Index> in_box(const TetBounds& bounds, const Aabb& box) {
  std::vector<Index> v;
  for (std::size_t t = 0; t < bounds.boxes.size(); ++t)
    if (bounds.boxes[t].overlaps(box)) v.push_back(static_cast<Index>(t));
  return v;
}

/// cull: restrict to the tets in the overlap box of the objects and clip their boxes to
/// it (what detection does, loosely). Else: every tet, boxes clipped to `region`.
void expect_matches_brute_force(BroadPhaseKind kind, const TetMesh& ma, const TetMesh& mb,
                                bool cull,
                                const Aabb& region = {Vector3d::Constant(-1e300),
                                                      Vector3d::Constant(1e300)}) {
  TetBounds a, b;
  a.compute(ma.positions, ma.tets);
  b.compute(mb.positions, mb.tets);
  std::vector<Index> sa = all_tets(ma), sb = all_tets(mb);
  Aabb clip = region;
  if (cull) {
    Aabb box_a, box_b;
    for (const Aabb& x : a.boxes)
      if (!x.empty()) box_a.extend(x);
    for (const Aabb& x : b.boxes)
      if (!x.empty()) box_b.extend(x);
    clip = box_a.intersection(box_b);
    sa = in_box(a, clip);
    sb = in_box(b, clip);
  }
  const std::vector<Aabb> ba = clipped(a, sa, clip), bb = clipped(b, sb, clip);
  AabbTree tree;
  tree.build(b.boxes);
  std::vector<Index> slot(b.boxes.size(), -1);
  for (std::size_t k = 0; k < sb.size(); ++k) slot[sb[k]] = static_cast<Index>(k);
  const BvhSide bvh{&tree, b.boxes, slot};
  BroadPhase bp;
  std::vector<TetPair> got;
  bp.find_pairs(kind, {sa, ba, a.spheres}, {sb, bb, b.spheres}, bvh, got);
  const std::vector<TetPair> want = brute_force(kind, a, sa, ba, b, sb, bb);
  EXPECT_EQ(got, want) << broad_phase_name(kind) << ": " << got.size() << " vs " << want.size();
  // Reuse of the buffers gives the same answer.
  std::vector<TetPair> again;
  bp.find_pairs(kind, {sa, ba, a.spheres}, {sb, bb, b.spheres}, bvh, again);
  EXPECT_EQ(again, got);
}

const auto kAllKinds = ::testing::Values(BroadPhaseKind::kGrid, BroadPhaseKind::kHash,
                                         BroadPhaseKind::kSap, BroadPhaseKind::kBvh);

std::string kind_name(const ::testing::TestParamInfo<BroadPhaseKind>& info) {
  return std::string(broad_phase_name(info.param));
}

class EveryBroadPhase : public ::testing::TestWithParam<BroadPhaseKind> {};

TEST_P(EveryBroadPhase, RandomSoupsMatchBruteForce) {
  std::mt19937 rng(1234);
  for (int round = 0; round < 6; ++round) {
    const bool oddities = round % 2 == 1;
    const TetMesh a = soup(rng, 300 + 50 * round, 0.08, oddities);
    const TetMesh b =
        transformed(soup(rng, 250, 0.12, oddities), 1.0, Vector3d(0.3 * round / 6.0, -0.1, 0.05));
    expect_matches_brute_force(GetParam(), a, b, round % 3 == 0);
  }
}

TEST_P(EveryBroadPhase, ClipRegionsMatchBruteForce) {
  std::mt19937 rng(4321);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const TetMesh a = soup(rng, 300, 0.1, true);
  const TetMesh b = soup(rng, 300, 0.1, true);
  for (int round = 0; round < 5; ++round) {
    const Vector3d lo(u(rng), u(rng), u(rng));
    const Aabb clip{lo, lo + Vector3d(0.05, 0.3, 0.6) * u(rng)};
    expect_matches_brute_force(GetParam(), a, b, false, clip);
  }
  expect_matches_brute_force(GetParam(), a, b, false, Aabb{});  // empty region
}

TEST_P(EveryBroadPhase, OverlappingStructuredBoxesMatchBruteForce) {
  // Aligned grids: many boxes touch exactly (closed tests must keep them).
  const TetMesh a = test::structured_box(6, 5, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 1));
  const TetMesh b = test::structured_box(4, 4, 4, Vector3d(0.5, 0.5, 0.5), Vector3d(1.5, 1.5, 1.5));
  expect_matches_brute_force(GetParam(), a, b, true);
  expect_matches_brute_force(GetParam(), a, b, false);
  const TetMesh c = test::structured_box(5, 5, 5, Vector3d(0, 0, 1), Vector3d(1, 1, 2));
  expect_matches_brute_force(GetParam(), a, c, true);  // stacked: face contact only
}

TEST_P(EveryBroadPhase, LargeOffsetsAndTinyScales) {
  std::mt19937 rng(77);
  const TetMesh a = soup(rng, 200, 0.1, false);
  const TetMesh b = soup(rng, 200, 0.1, false);
  for (const auto& [scale, offset] :
       {std::pair{1e-6, 0.0}, std::pair{1.0, 1e6}, std::pair{1e-3, 1e6}, std::pair{1e4, -1e6}}) {
    const Vector3d o(offset, 0.5 * offset, -offset);
    expect_matches_brute_force(GetParam(), transformed(a, scale, o), transformed(b, scale, o),
                               true);
  }
}

TEST_P(EveryBroadPhase, EmptyAndDisjointInputs) {
  std::mt19937 rng(5);
  const TetMesh a = soup(rng, 50, 0.1, false);
  const TetMesh far = transformed(soup(rng, 50, 0.1, false), 1.0, Vector3d(10, 0, 0));
  expect_matches_brute_force(GetParam(), a, far, false);
  TetMesh empty;
  empty.positions.resize(3, 0);
  expect_matches_brute_force(GetParam(), a, empty, false);
  expect_matches_brute_force(GetParam(), empty, a, false);
  // Every tet of B non-finite.
  TetMesh nan = a;
  nan.positions.setConstant(std::nan(""));
  expect_matches_brute_force(GetParam(), a, nan, false);
}

TEST_P(EveryBroadPhase, OneHugeTetAmongTinyOnes) {
  std::mt19937 rng(6);
  TetMesh a = soup(rng, 400, 0.01, false);
  a.positions.col(0) = Vector3d(-5, -5, -5);
  a.positions.col(1) = Vector3d(6, -5, -5);
  a.positions.col(2) = Vector3d(-5, 6, -5);
  a.positions.col(3) = Vector3d(-5, -5, 6);
  const TetMesh b = soup(rng, 400, 0.01, false);
  expect_matches_brute_force(GetParam(), a, b, false);
  expect_matches_brute_force(GetParam(), b, a, false);
}

INSTANTIATE_TEST_SUITE_P(BroadPhase, EveryBroadPhase, kAllKinds, kind_name);

TEST(BroadPhase, NamesRoundTrip) {
  for (const auto k :
       {BroadPhaseKind::kGrid, BroadPhaseKind::kHash, BroadPhaseKind::kSap, BroadPhaseKind::kBvh})
    EXPECT_EQ(parse_broad_phase(broad_phase_name(k)), k);
  EXPECT_FALSE(parse_broad_phase("octree").has_value());
  EXPECT_FALSE(parse_broad_phase("").has_value());
}

TEST(TetBounds, ANonFiniteCornerGivesAnEmptyBoxAndNoSphere) {
  // One tet per case, corner 2 changed in one coordinate: finite (the exact box), +inf,
  // -inf, NaN, and the largest finite values (whose sums would overflow).
  const double inf = std::numeric_limits<double>::infinity();
  const double big = std::numeric_limits<double>::max();
  for (const double bad : {0.5, inf, -inf, std::numeric_limits<double>::quiet_NaN(), big}) {
    for (int c = 0; c < 3; ++c) {
      Positions p(3, 4);
      p << 0, 1, 0, 0,  //
          0, 0, 1, 0,   //
          0, 0, 0, 1;
      p(c, 2) = bad;
      if (bad == big) p(c, 1) = big;  // two corners at the largest double
      const std::vector<Tet> tets = {Tet{0, 1, 2, 3}};
      TetBounds b;
      b.compute(p, tets, true);
      const bool finite = std::isfinite(bad);
      EXPECT_EQ(b.boxes[0].empty(), !finite) << "coordinate " << c << " value " << bad;
      EXPECT_EQ(b.spheres[0].radius >= 0.0, finite) << "coordinate " << c << " value " << bad;
      if (finite) {
        EXPECT_EQ(b.boxes[0].lo, p.rowwise().minCoeff()) << c;
        EXPECT_EQ(b.boxes[0].hi, p.rowwise().maxCoeff()) << c;
      }
    }
  }
}

TEST(TetBounds, BoxesAndSpheresHoldTheCorners) {
  std::mt19937 rng(8);
  const TetMesh m = transformed(soup(rng, 300, 0.2, true), 1e-3, Vector3d(1e6, 0, 0));
  TetBounds b;
  b.compute(m.positions, m.tets);
  for (std::size_t t = 0; t < m.tets.size(); ++t) {
    bool finite = true;
    for (const Index v : m.tets[t]) finite = finite && m.positions.col(v).allFinite();
    EXPECT_EQ(b.boxes[t].empty(), !finite);
    EXPECT_EQ(b.spheres[t].radius < 0, !finite);
    if (!finite) continue;
    for (const Index v : m.tets[t]) {
      const Vector3d p = m.positions.col(v);
      EXPECT_TRUE((p.array() >= b.boxes[t].lo.array()).all());
      EXPECT_TRUE((p.array() <= b.boxes[t].hi.array()).all());
      EXPECT_LE((p - b.spheres[t].center).norm(), b.spheres[t].radius);
    }
  }
}

TEST(ClippedTetBox, HoldsTheClippedTetAndNoMore) {
  std::mt19937 rng(10);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int nonempty = 0;
  for (int iter = 0; iter < 300; ++iter) {
    TetCorners t;
    for (auto& p : t) p = Vector3d(u(rng), u(rng), u(rng));
    const int axis = iter % 3;
    Vector3d lo = Vector3d::Constant(-0.2), hi = Vector3d::Constant(1.2);
    lo[axis] = 0.8 * u(rng);
    hi[axis] = lo[axis] + 0.1 * u(rng);
    lo[(axis + 1) % 3] = 0.5 * u(rng);
    const Aabb region{lo, hi};
    const Aabb box = clipped_tet_box(t, region, axis, 0.0);
    // Oracle: the vertices of tet x slab are the feasible intersections of three of its
    // six planes (4 faces, 2 slab planes); their box, cut to the region, is the answer.
    std::vector<std::pair<Vector3d, double>> planes;  // n . x <= c
    for (int f = 0; f < 4; ++f) {
      const Vector3d& p0 = t[(f + 1) % 4];
      Vector3d nrm = (t[(f + 2) % 4] - p0).cross(t[(f + 3) % 4] - p0);
      if (nrm.dot(t[f] - p0) > 0) nrm = -nrm;
      planes.emplace_back(nrm, nrm.dot(p0));
    }
    planes.emplace_back(Vector3d::Unit(axis), hi[axis]);
    planes.emplace_back(-Vector3d::Unit(axis), -lo[axis]);
    Aabb want;
    for (std::size_t i = 0; i < 6; ++i)
      for (std::size_t j = i + 1; j < 6; ++j)
        for (std::size_t k = j + 1; k < 6; ++k) {
          Eigen::Matrix3d m;
          m << planes[i].first.transpose(), planes[j].first.transpose(),
              planes[k].first.transpose();
          if (std::abs(m.determinant()) < 1e-12) continue;
          const Vector3d x =
              m.inverse() * Vector3d(planes[i].second, planes[j].second, planes[k].second);
          bool inside = true;
          for (const auto& [nrm, c] : planes) inside = inside && nrm.dot(x) <= c + 1e-9;
          if (inside) want.extend(x);
        }
    want = want.intersection(region);
    if (want.empty()) {
      EXPECT_TRUE(box.empty() || (box.hi - box.lo).maxCoeff() < 1e-9) << iter;
      continue;
    }
    ++nonempty;
    ASSERT_FALSE(box.empty()) << iter;
    EXPECT_LT((box.lo - want.lo).cwiseAbs().maxCoeff(), 1e-9) << iter;
    EXPECT_LT((box.hi - want.hi).cwiseAbs().maxCoeff(), 1e-9) << iter;
  }
  EXPECT_GT(nonempty, 100);
  // A tet beside the slab: empty; the pad grows the box.
  const TetCorners t = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0), Vector3d(0, 0, 1)};
  EXPECT_TRUE(clipped_tet_box(t, Aabb{Vector3d(-1, -1, 2), Vector3d(2, 2, 3)}, 2, 0.0).empty());
  const Aabb padded = clipped_tet_box(t, Aabb{Vector3d(-1, -1, 0.5), Vector3d(2, 2, 0.6)}, 2, 0.01);
  EXPECT_NEAR(padded.lo.z(), 0.49, 1e-12);
  EXPECT_NEAR(padded.hi.x(), 0.51, 1e-12);
}

/// Bits of a double, with every NaN alike.
std::uint64_t bits_of(double x) {
  return std::isnan(x) ? 0x7ff8000000000000ULL : std::bit_cast<std::uint64_t>(x);
}

// With each copy of the kernel (AVX2, baseline).
class ClippedTetBoxCopies : public test::BothKernels {};

TEST_P(ClippedTetBoxCopies, FourAtOnceHaveTheBitsOfOneAtATime) {
  // Random tets against thin slabs on each axis: corners inside, outside and exactly on
  // the slab planes, edges along a plane, flat and repeated-corner tets, 1e6 offsets and
  // 1e-6 scales, NaN and infinite corners, pads 0, tiny and large.
  std::mt19937 rng(2718);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  int nonempty = 0, empty = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    const int axis = iter % 3;
    const double scale = iter % 5 == 0 ? 1e-6 : 1.0;
    const Vector3d offset = iter % 7 == 0 ? Vector3d(1e6, -2e6, 5e5) : Vector3d::Zero();
    Vector3d lo = Vector3d::Constant(-0.2), hi = Vector3d::Constant(1.2);
    lo[axis] = 0.8 * u(rng);
    hi[axis] = lo[axis] + (iter % 11 == 0 ? 0.0 : 0.1 * u(rng));
    lo[(axis + 1) % 3] = 0.5 * u(rng);
    const Aabb region{lo * scale + offset, hi * scale + offset};
    std::array<TetCorners, 4> t;
    std::array<double, 4> pad;
    for (int j = 0; j < 4; ++j) {
      for (auto& p : t[j]) p = Vector3d(u(rng), u(rng), u(rng));
      const int kind = (iter + j) % 9;
      if (kind == 1) t[j][0][axis] = lo[axis];                       // a corner on a plane
      if (kind == 2) t[j][1][axis] = t[j][2][axis] = hi[axis];       // an edge in a plane
      if (kind == 3) t[j][3] = t[j][0] + 0.5 * (t[j][1] - t[j][0]);  // flat
      if (kind == 4) t[j][2] = t[j][1];                              // repeated corner
      for (auto& p : t[j]) p = p * scale + offset;
      if (kind == 5 && iter % 2 == 0) t[j][iter % 4][(iter / 4) % 3] = nan;
      if (kind == 6 && iter % 3 == 0) t[j][1][(axis + 1) % 3] = -inf;
      pad[j] = kind == 7 ? 0.0 : (kind == 8 ? 0.05 * scale : 1e-9 * scale);
    }
    std::array<Aabb, 4> got;
    clipped_tet_boxes4(t, region, axis, pad, got);
    for (int j = 0; j < 4; ++j) {
      const Aabb want = clipped_tet_box(t[j], region, axis, pad[j]);
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(bits_of(got[j].lo[c]), bits_of(want.lo[c]))
            << "iteration " << iter << " tet " << j;
        ASSERT_EQ(bits_of(got[j].hi[c]), bits_of(want.hi[c]))
            << "iteration " << iter << " tet " << j;
      }
      (want.empty() ? empty : nonempty) += 1;
    }
  }
  EXPECT_GT(nonempty, 20000);
  EXPECT_GT(empty, 5000);
}

INSTANTIATE_TEST_SUITE_P(Kernels, ClippedTetBoxCopies, ::testing::Bool(), test::kernel_copy_name);

TEST(AabbTree, RefitAfterDeformationQueriesLikeBruteForce) {
  std::mt19937 rng(9);
  TetMesh m = soup(rng, 1000, 0.05, true);
  TetBounds b;
  b.compute(m.positions, m.tets);
  AabbTree tree;
  tree.build(b.boxes);
  std::normal_distribution<double> jitter(0.0, 0.05);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int frame = 0; frame < 5; ++frame) {
    // Deform: every node moves, so the build-time layout no longer fits well.
    for (Eigen::Index i = 0; i < m.positions.cols(); ++i)
      m.positions.col(i) += Vector3d(jitter(rng), jitter(rng), 0.2 * frame * m.positions(0, i));
    b.compute(m.positions, m.tets);
    tree.refit(b.boxes);
    for (int q = 0; q < 50; ++q) {
      const Vector3d c(u(rng), u(rng), u(rng));
      const Aabb box{c.array() - 0.1, c.array() + 0.1};
      std::vector<Index> got, want;
      tree.query(box, b.boxes, got);
      std::sort(got.begin(), got.end());
      for (std::size_t t = 0; t < b.boxes.size(); ++t)
        if (b.boxes[t].overlaps(box)) want.push_back(static_cast<Index>(t));
      EXPECT_EQ(got, want) << "frame " << frame << " query " << q;
    }
  }
}

TEST(AabbTree, EverySizeBuildsTheSameTreeWithAnyThreadCount) {
  // build() places each subtree by its size and builds large halves concurrently: for
  // every size (leaf splits, the fork threshold around 512) the query answers are brute
  // force's and come in the same tree order with 1 and 4 threads.
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::size_t> sizes;
  for (std::size_t n = 0; n <= 40; ++n) sizes.push_back(n);
  for (const std::size_t n : {511, 512, 513, 1023, 1024, 1025, 3001}) sizes.push_back(n);
  for (const std::size_t n : sizes) {
    std::vector<Aabb> boxes(n);
    for (Aabb& b : boxes) {
      const Vector3d c(u(rng), u(rng), u(rng));
      b = Aabb{c.array() - 0.03 * u(rng), c.array() + 0.03 * u(rng)};
    }
    const auto answers = [&](std::size_t threads) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
      AabbTree tree;
      tree.build(boxes);
      std::vector<std::vector<Index>> out;
      std::mt19937 qrng(5);
      for (int q = 0; q < 20; ++q) {
        const Vector3d c(u(qrng), u(qrng), u(qrng));
        out.emplace_back();
        tree.query(Aabb{c.array() - 0.1, c.array() + 0.1}, boxes, out.back());
      }
      return out;
    };
    const auto one = answers(1), four = answers(4);
    ASSERT_EQ(one, four) << n << " boxes";
    std::mt19937 qrng(5);
    for (int q = 0; q < 20; ++q) {
      const Vector3d c(u(qrng), u(qrng), u(qrng));
      const Aabb box{c.array() - 0.1, c.array() + 0.1};
      std::vector<Index> got = one[static_cast<std::size_t>(q)], want;
      std::sort(got.begin(), got.end());
      for (std::size_t t = 0; t < n; ++t)
        if (boxes[t].overlaps(box)) want.push_back(static_cast<Index>(t));
      EXPECT_EQ(got, want) << n << " boxes, query " << q;
    }
  }
}

}  // namespace
}  // namespace tc
