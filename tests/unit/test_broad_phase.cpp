// service/core/detect/broad_phase: every method against brute force over all pairs.
#include "core/detect/broad_phase.hpp"

#include <gtest/gtest.h>

#include <random>
#include <tuple>

#include "core/mesh/geometry.hpp"
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

std::vector<TetPair> brute_force(BroadPhaseKind kind, const TetBounds& a,
                                 std::span<const Index> subset_a, const TetBounds& b,
                                 std::span<const Index> subset_b, const Aabb& clip) {
  std::vector<TetPair> out;
  for (const Index ta : subset_a)
    for (const Index tb : subset_b)
      if (a.boxes[ta].intersection(clip).overlaps(b.boxes[tb]) &&
          (kind != BroadPhaseKind::kGrid || sphere_overlap(a.spheres[ta], b.spheres[tb])))
        out.push_back({ta, tb});
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

/// cull: restrict to the tets in the overlap box of the objects and clip to it (what
/// detection does; it loses no pair). Else: every tet, clipped to `region`.
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
  AabbTree tree;
  tree.build(b.boxes);
  BroadPhase bp;
  std::vector<TetPair> got;
  bp.find_pairs(kind, a, sa, b, sb, &tree, clip, got);
  // The tree covers every tet of B; with culling that loses nothing (a pair of
  // overlapping boxes lies in both object boxes).
  const std::vector<Index> sb_ref = kind == BroadPhaseKind::kBvh ? all_tets(mb) : sb;
  const std::vector<TetPair> want = brute_force(kind, a, sa, b, sb_ref, clip);
  EXPECT_EQ(got, want) << broad_phase_name(kind) << ": " << got.size() << " vs " << want.size();
  // Reuse of the buffers gives the same answer.
  std::vector<TetPair> again;
  bp.find_pairs(kind, a, sa, b, sb, &tree, clip, again);
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

}  // namespace
}  // namespace tc
