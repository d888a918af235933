// Depth maps (service/core/depth/depth_solver): analytic cases, the ordering
// exact <= CFFM, CPFM, lazy == full, components, orphans, degenerate tets, determinism
// across runs and TBB thread counts, robustness, and the 2D case.
#include "core/depth/depth_solver.hpp"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <string>

#include "core/depth/point_simplex_distance.hpp"
#include "core/io/mesh_io.hpp"
#include "core/mesh/geometry.hpp"
#include "sanitizer.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using Eigen::Vector3d;

std::vector<double> solve(const TetMesh& m, const Topology& topo, DepthSolverOptions o) {
  DepthSolver s(m.tets, topo, o);
  EXPECT_TRUE(s.compute(m.positions).ok());
  return {s.depth().begin(), s.depth().end()};
}

std::vector<double> exact_of(const TetMesh& m, const Topology& topo) {
  return solve(m, topo, {.method = DepthMethod::kExact});
}

/// Moves interior nodes by up to `amount` times the cell size, randomly (seeded).
void jitter_interior(TetMesh& m, const Topology& topo, double amount, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-amount, amount);
  for (Index i = 0; i < m.num_nodes(); ++i)
    if (!topo.is_boundary_node[i])
      for (int k = 0; k < 3; ++k) m.positions(k, i) += u(rng);
}

/// Renumbers the nodes randomly (seeded): the solver must not depend on file order.
void shuffle_nodes(TetMesh& m, unsigned seed) {
  std::vector<Index> p(static_cast<std::size_t>(m.num_nodes()));
  std::iota(p.begin(), p.end(), 0);
  std::shuffle(p.begin(), p.end(), std::mt19937(seed));
  Positions q(3, m.num_nodes());
  for (Index i = 0; i < m.num_nodes(); ++i) q.col(p[i]) = m.positions.col(i);
  m.positions = q;
  for (Tet& t : m.tets)
    for (Index& v : t) v = p[v];
}

double max_boundary_edge(const TetMesh& m, const Topology& topo) {
  double h = 0.0;
  for (const auto& e : topo.boundary_edges)
    h = std::max(h, (m.positions.col(e[0]) - m.positions.col(e[1])).norm());
  return h;
}

struct ErrorStats {
  double max = 0.0;   ///< largest (approx - exact)
  double mean = 0.0;  ///< mean |approx - exact| over used nodes
  double min = 0.0;   ///< smallest (approx - exact): >= 0 when approx never undershoots
};

ErrorStats error_stats(const std::vector<double>& approx, const std::vector<double>& exact) {
  ErrorStats s;
  std::size_t count = 0;
  for (std::size_t i = 0; i < exact.size(); ++i) {
    if (!std::isfinite(exact[i])) continue;
    const double e = approx[i] - exact[i];
    s.max = std::max(s.max, e);
    s.min = std::min(s.min, e);
    s.mean += std::abs(e);
    ++count;
  }
  s.mean /= static_cast<double>(std::max<std::size_t>(count, 1));
  return s;
}

// ---------------------------------------------------------------------------
// Exact reference.

TEST(DepthExact, BoxEqualsDistanceToNearestFace) {
  const Eigen::Vector3d lo(-1.0, 0.5, 2.0), hi(1.0, 2.0, 2.75);
  TetMesh m = test::structured_box(8, 6, 3, lo, hi);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  jitter_interior(m, topo, 0.08, 1);  // interior nodes stay inside the box
  const auto exact = exact_of(m, topo);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Eigen::Vector3d x = m.positions.col(i);
    const double want = std::min((x - lo).minCoeff(), (hi - x).minCoeff());
    EXPECT_NEAR(exact[i], want, 1e-12) << "node " << i;
  }
}

class DepthExactBruteForce : public ::testing::TestWithParam<unsigned> {};

TEST_P(DepthExactBruteForce, BvhEqualsMinimumOverAllTriangles) {
  TetMesh m = test::ball_mesh(6, 1.3);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  jitter_interior(m, topo, 0.05, GetParam());
  const auto exact = exact_of(m, topo);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const double best =
        test::brute_force_sq_distance_to_boundary(m, topo, Eigen::Vector3d(m.positions.col(i)));
    EXPECT_EQ(exact[i], std::sqrt(best)) << "node " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, DepthExactBruteForce, ::testing::Values(1u, 2u, 3u));

// ---------------------------------------------------------------------------
// Analytic cases.

// The boundary of ball_mesh is inscribed in the sphere of radius r, so for an interior
// point r - |x| - gap <= exact <= r - |x|, gap = r - (smallest distance from the centre
// to a boundary triangle) (docs/DEPTH_MAPS.md, "Tests").
TEST(DepthAnalytic, BallExactWithinChordGapOfRadiusMinusNorm) {
  const double r = 2.0;
  const TetMesh m = test::ball_mesh(10, r);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  double gap = 0.0;
  for (const auto& f : topo.boundary_faces) {
    const double d = std::sqrt(point_triangle_distance(Eigen::Vector3d::Zero().eval(),
                                                       Eigen::Vector3d(m.positions.col(f[0])),
                                                       Eigen::Vector3d(m.positions.col(f[1])),
                                                       Eigen::Vector3d(m.positions.col(f[2])))
                                   .sq_dist);
    gap = std::max(gap, r - d);
  }
  EXPECT_LT(gap, 0.05 * r);
  const auto exact = exact_of(m, topo);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const double analytic = r - m.positions.col(i).norm();
    EXPECT_LE(exact[i], analytic + 1e-12) << "node " << i;
    EXPECT_GE(exact[i], analytic - gap - 1e-12) << "node " << i;
  }
  // The marches are upper bounds; a sanity bound: within one boundary edge.
  const double h = max_boundary_edge(m, topo);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    const ErrorStats e = error_stats(solve(m, topo, {.method = method}), exact);
    EXPECT_GE(e.min, 0.0);
    EXPECT_LT(e.max, h) << depth_method_name(method);
  }
}

TEST(DepthAnalytic, TorusExactWithinChordGap) {
  const double big_r = 3.0, a = 1.0;
  const TetMesh m = test::torus_mesh(48, 8, big_r, a);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  EXPECT_EQ(boundary_euler_characteristic(topo), 0);
  const auto exact = exact_of(m, topo);
  // Inscribed again: exact <= a - |(rho - R, z)|, and the gap is small.
  double worst_below = 0.0;
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Eigen::Vector3d x = m.positions.col(i);
    const double rho = std::hypot(x.x(), x.y());
    const double analytic = a - std::hypot(rho - big_r, x.z());
    EXPECT_LE(exact[i], analytic + 1e-12) << "node " << i;
    worst_below = std::max(worst_below, analytic - exact[i]);
  }
  EXPECT_LT(worst_below, 0.06 * a);
}

// ---------------------------------------------------------------------------
// Ordering properties on several meshes, node orders and queues.

struct MeshCase {
  const char* name;
  TetMesh mesh;
};

std::vector<MeshCase> property_meshes() {
  std::vector<MeshCase> cases;
  cases.push_back({"ball", test::ball_mesh(8, 1.0)});
  cases.push_back({"torus", test::torus_mesh(40, 6, 2.0, 0.7)});
  {
    TetMesh box = test::structured_box(9, 7, 5, {0, 0, 0}, {1.8, 1.4, 1.0});
    const Topology t = build_topology(box.tets, box.num_nodes());
    jitter_interior(box, t, 0.06, 7);
    shuffle_nodes(box, 11);
    cases.push_back({"jittered shuffled box", std::move(box)});
  }
  return cases;
}

class DepthOrdering : public ::testing::TestWithParam<QueueKind> {};

TEST_P(DepthOrdering, ExactLeCffmAndCpfmWithCffmMoreAccurate) {
  for (const MeshCase& c : property_meshes()) {
    SCOPED_TRACE(c.name);
    const Topology topo = build_topology(c.mesh.tets, c.mesh.num_nodes());
    const auto exact = exact_of(c.mesh, topo);
    const auto cpfm = solve(c.mesh, topo, {.method = DepthMethod::kCpfm, .queue = GetParam()});
    const ErrorStats ep = error_stats(cpfm, exact);
    // CPFM returns |x - p| for a boundary node p: a point of the boundary, so never
    // below the distance to the boundary (up to the last bit of the two computations).
    EXPECT_GE(ep.min, -1e-15);
    for (const CffmVariant v :
         {CffmVariant::kPaper, CffmVariant::kDescent, CffmVariant::kPaperDescent,
          CffmVariant::kMultiStart, CffmVariant::kNearStarts}) {
      const auto cffm =
          solve(c.mesh, topo, {.method = DepthMethod::kCffm, .cffm = v, .queue = GetParam()});
      const ErrorStats ef = error_stats(cffm, exact);
      EXPECT_GE(ef.min, -1e-15) << static_cast<int>(v);  // distance to a boundary triangle
      EXPECT_LE(ef.mean, ep.mean) << static_cast<int>(v);
      EXPECT_LE(ef.max, ep.max * 1.05) << static_cast<int>(v);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Queues, DepthOrdering,
                         ::testing::Values(QueueKind::kBucket, QueueKind::kRadix,
                                           QueueKind::kBinaryHeap));

TEST(DepthOrdering, CffmVariantsOnTorusRankAsMeasured) {
  // docs/DEPTH_MAPS.md, "CFFM variants": the descent cuts the paper's mean error by
  // an order of magnitude; the multi-start walk also removes the local minima.
  const TetMesh m = test::torus_mesh(64, 10, 3.0, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  const auto exact = exact_of(m, topo);
  const double deepest = *std::max_element(exact.begin(), exact.end());
  const auto stats = [&](CffmVariant v) {
    return error_stats(solve(m, topo, {.method = DepthMethod::kCffm, .cffm = v}), exact);
  };
  const ErrorStats paper = stats(CffmVariant::kPaper);
  const ErrorStats descent = stats(CffmVariant::kDescent);
  const ErrorStats multi = stats(CffmVariant::kMultiStart);
  EXPECT_LT(descent.mean, 0.2 * paper.mean);
  EXPECT_LT(descent.max, 0.5 * paper.max);
  EXPECT_LE(multi.max, 0.005 * deepest);
  EXPECT_LE(multi.mean, 1e-4 * deepest);
  EXPECT_LE(multi.mean, descent.mean);
}

TEST(DepthOrdering, CffmNearStartsMeetsTheAccuracyTargetOnTheDemoMeshes) {
  // Issue 3's CFFM accuracy target: max error <= 0.5% of the object's largest depth and
  // mean error <= 0.01% on the torus and the ball (docs/BENCHMARKS.md, "Depth maps";
  // measured 0.47% / 0.00044% and 0 / 0). The default kDescent misses it on the torus
  // (2.02% / 0.011%), so this also checks that kNearStarts is no worse than kDescent
  // on every demo mesh.
  for (const char* name : {"torus.msh", "ball.msh", "box.msh"}) {
    SCOPED_TRACE(name);
    auto m = read_mesh(test::mesh_path(name));
    ASSERT_TRUE(m) << m.error().message;
    const Topology topo = build_topology(m->tets, m->num_nodes());
    const auto exact = exact_of(*m, topo);
    const double deepest = *std::max_element(exact.begin(), exact.end());
    const auto stats = [&](CffmVariant v) {
      return error_stats(solve(*m, topo, {.method = DepthMethod::kCffm, .cffm = v}), exact);
    };
    const ErrorStats near = stats(CffmVariant::kNearStarts);
    const ErrorStats descent = stats(CffmVariant::kDescent);
    if (std::string(name) != "box.msh") {
      EXPECT_LE(near.max, 0.005 * deepest);
      EXPECT_LE(near.mean, 1e-4 * deepest);
    }
    EXPECT_GE(near.min, -1e-15);
    EXPECT_LE(near.max, descent.max);
    EXPECT_LE(near.mean, descent.mean);
  }
}

// ---------------------------------------------------------------------------
// Lazy update.

struct LazyCase {
  DepthMethod method;
  CffmVariant cffm;
  QueueKind queue;
};

class DepthLazy : public ::testing::TestWithParam<LazyCase> {};

TEST_P(DepthLazy, SettledValuesEqualTheFullRunBitForBit) {
  const LazyCase p = GetParam();
  TetMesh m = test::torus_mesh(32, 6, 2.0, 0.8);
  shuffle_nodes(m, 5);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  DepthSolver solver(m.tets, topo,
                     {.method = p.method,
                      .cffm = p.cffm,
                      .queue = p.queue,
                      .lazy_region = LazyRegion::kWholeBoundary});
  ASSERT_TRUE(solver.compute(m.positions).ok());
  const std::vector<double> full(solver.depth().begin(), solver.depth().end());
  EXPECT_EQ(solver.settled_count(), static_cast<std::size_t>(m.num_nodes()));

  std::mt19937 rng(1234);
  for (int sweep = 0; sweep < 60; ++sweep) {
    std::vector<Index> marked;
    if (sweep % 3 == 2) {
      // A shallow contact: the tets with a node above a plane near the top.
      const double z = 0.8 * (0.6 + 0.02 * (sweep % 10));
      for (Index t = 0; t < m.num_tets(); ++t)
        for (const Index v : m.tets[t])
          if (m.positions(2, v) > z) {
            marked.push_back(t);
            break;
          }
    } else {
      const int count = 1 + static_cast<int>(rng() % (sweep % 3 == 0 ? 4 : 200));
      for (int k = 0; k < count; ++k) marked.push_back(static_cast<Index>(rng() % m.num_tets()));
    }
    auto settled = solver.compute_lazy(m.positions, marked);
    ASSERT_TRUE(settled) << settled.error().message;
    EXPECT_EQ(*settled, solver.settled_count());
    std::size_t finite = 0;
    for (Index i = 0; i < m.num_nodes(); ++i) {
      if (solver.settled(i)) {
        ++finite;
        // Every settled value, not only the marked ones, is the full run's.
        EXPECT_EQ(solver.depth()[i], full[i]) << "sweep " << sweep << " node " << i;
      } else {
        EXPECT_EQ(solver.depth()[i], kInf);
      }
    }
    EXPECT_EQ(finite, *settled);
    for (const Index t : marked)
      for (const Index v : m.tets[t]) ASSERT_TRUE(solver.settled(v)) << "sweep " << sweep;
  }
  // The solver is reusable: a full run after lazy ones is the same again.
  ASSERT_TRUE(solver.compute(m.positions).ok());
  EXPECT_EQ(std::vector<double>(solver.depth().begin(), solver.depth().end()), full);
}

INSTANTIATE_TEST_SUITE_P(
    Methods, DepthLazy,
    ::testing::Values(LazyCase{DepthMethod::kCpfm, CffmVariant::kDescent, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCpfm, CffmVariant::kDescent, QueueKind::kRadix},
                      LazyCase{DepthMethod::kCpfm, CffmVariant::kDescent, QueueKind::kBinaryHeap},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kDescent, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kPaper, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kPaperDescent, QueueKind::kRadix},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kMultiStart, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kNearStarts, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kNearStarts, QueueKind::kRadix},
                      LazyCase{DepthMethod::kExact, CffmVariant::kDescent, QueueKind::kBucket}));

TEST(DepthLazy, ShallowContactSettlesFewNodes) {
  const TetMesh m = test::torus_mesh(48, 8, 3.0, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  std::vector<Index> marked;
  for (Index t = 0; t < m.num_tets(); ++t)
    for (const Index v : m.tets[t])
      if (m.positions(2, v) > 0.8) {  // 10% of the thickness 2a below the top
        marked.push_back(t);
        break;
      }
  // The paper's lazy run: every boundary node seeds it.
  DepthSolver solver(m.tets, topo, {.lazy_region = LazyRegion::kWholeBoundary});
  const auto settled = solver.compute_lazy(m.positions, marked);
  ASSERT_TRUE(settled);
  EXPECT_LT(*settled, static_cast<std::size_t>(m.num_nodes()) * 3 / 4);
  EXPECT_GE(*settled, topo.boundary_nodes.size());
}

// Local lazy runs (LazyRegion::kLocal, issue 13): the tets near a small tool pressed
// `press` metres into the top face of a wide slab, or deep into its middle.
std::vector<Index> tets_near(const TetMesh& m, const Vector3d& centre, double r) {
  std::vector<Index> out;
  for (Index t = 0; t < m.num_tets(); ++t)
    for (const Index v : m.tets[t])
      if ((m.positions.col(v) - centre).norm() < r) {
        out.push_back(t);
        break;
      }
  return out;
}

class DepthLazyLocal : public ::testing::TestWithParam<LazyCase> {};

// Every depth a local run gives is a true boundary distance (>= exact), the region
// holds the ball of radius depth around every marked node (cell side >= depth), only a
// few per cent of the nodes are settled for a shallow press, and the marked nodes'
// depths are those of the whole-boundary run (within 2% where they differ at all).
TEST_P(DepthLazyLocal, ShallowPressSettlesFewNodesWithTheWholeRunsDepths) {
  const LazyCase p = GetParam();
  const int n = 32;  // the same mesh under the sanitizers: the 5% bound depends on it
  TetMesh m = test::structured_box(n, n, n / 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25));
  shuffle_nodes(m, 3);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  const auto exact = compute_depth_exact(m, topo);
  ASSERT_TRUE(exact);
  DepthSolver local(m.tets, topo, {.method = p.method, .cffm = p.cffm, .queue = p.queue});
  DepthSolver whole(m.tets, topo,
                    {.method = p.method,
                     .cffm = p.cffm,
                     .queue = p.queue,
                     .lazy_region = LazyRegion::kWholeBoundary});
  const double h = 1.0 / n;
  struct Press {
    Vector3d centre;
    double r;
    bool shallow;
  };
  for (const Press& press : {Press{{0.4, 0.55, 0.25}, 0.05, true},   // 2-3 cells under it
                             Press{{0.02, 0.5, 0.25}, 0.04, true},   // at the side face
                             Press{{0.5, 0.5, 0.125}, 0.03, false},  // in the middle
                             Press{{0.7, 0.3, 0.25}, 0.75 * h, true}}) {
    SCOPED_TRACE(testing::Message() << press.centre.transpose() << " r " << press.r);
    const std::vector<Index> marked = tets_near(m, press.centre, press.r);
    ASSERT_FALSE(marked.empty());
    const auto nl = local.compute_lazy(m.positions, marked);
    const auto nw = whole.compute_lazy(m.positions, marked);
    ASSERT_TRUE(nl && nw);
    EXPECT_EQ(*nl, local.settled_count());
    const LazyStats& st = local.lazy_stats();
    EXPECT_FALSE(st.whole);
    EXPECT_GE(st.rounds, 1);
    if (press.shallow) {
      EXPECT_LT(*nl * 20, static_cast<std::size_t>(m.num_nodes())) << *nl;  // <= 5%
      EXPECT_LT(*nl * 4, *nw);
    }
    std::size_t finite = 0, differ = 0;
    for (Index i = 0; i < m.num_nodes(); ++i) {
      if (!local.settled(i)) {
        EXPECT_EQ(local.depth()[i], kInf);
        EXPECT_EQ(local.anchor()[i], -1);
        continue;
      }
      ++finite;
      EXPECT_GE(local.depth()[i], (*exact)[i] - 1e-12) << i;
      EXPECT_GE(local.anchor()[i], 0);
    }
    EXPECT_EQ(finite, *nl);
    for (const Index t : marked)
      for (const Index v : m.tets[t]) {
        ASSERT_TRUE(local.settled(v));
        EXPECT_LE(local.depth()[v], st.cell_side) << v;
        if (local.depth()[v] != whole.depth()[v]) ++differ;
        EXPECT_LE(local.depth()[v], 1.02 * whole.depth()[v] + 1e-12) << v;
        EXPECT_GE(local.depth()[v], (*exact)[v] - 1e-12) << v;
      }
    // Nearly all marked nodes get exactly the whole run's value.
    EXPECT_LE(differ * 20, marked.size()) << differ;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Methods, DepthLazyLocal,
    ::testing::Values(LazyCase{DepthMethod::kCpfm, CffmVariant::kDescent, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCpfm, CffmVariant::kDescent, QueueKind::kRadix},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kDescent, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kPaper, QueueKind::kBinaryHeap},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kNearStarts, QueueKind::kBucket},
                      LazyCase{DepthMethod::kCffm, CffmVariant::kMultiStart, QueueKind::kRadix}));

// A region that cannot certify its depths grows; a contact spanning the object ends in
// the whole run, whose values are the whole-boundary run's bit for bit; the next small
// press is local again and leaves nothing of the whole run behind.
TEST(DepthLazyLocal, GrowsUntilCertifiedOrWhole) {
  // The middle of a 24 x 24 x 6 slab: 3 elements deep; the first cell side (twice the
  // largest marked element, about 1.5 elements) cannot hold it, a larger one can.
  const TetMesh m = test::structured_box(24, 24, 6, Vector3d(0, 0, 0), Vector3d(1, 1, 0.25));
  const Topology topo = build_topology(m.tets, m.num_nodes());
  DepthSolver local(m.tets, topo);
  DepthSolver whole(m.tets, topo, {.lazy_region = LazyRegion::kWholeBoundary});
  const std::vector<Index> deep = tets_near(m, Vector3d(0.5, 0.5, 0.125), 0.01);
  const auto nl = local.compute_lazy(m.positions, deep);
  const auto nw = whole.compute_lazy(m.positions, deep);
  ASSERT_TRUE(nl && nw);
  EXPECT_GE(local.lazy_stats().rounds, 2);
  EXPECT_FALSE(local.lazy_stats().whole);
  EXPECT_LT(*nl * 2, *nw);
  for (const Index t : deep)
    for (const Index v : m.tets[t]) {
      EXPECT_LE(local.depth()[v], local.lazy_stats().cell_side);
      EXPECT_NEAR(local.depth()[v], whole.depth()[v], 1e-12);
    }
  // Every tet marked: the whole object.
  std::vector<Index> all(static_cast<std::size_t>(m.num_tets()));
  std::iota(all.begin(), all.end(), Index{0});
  ASSERT_TRUE(local.compute_lazy(m.positions, all));
  ASSERT_TRUE(whole.compute_lazy(m.positions, all));
  EXPECT_TRUE(local.lazy_stats().whole);
  for (Index i = 0; i < m.num_nodes(); ++i) EXPECT_EQ(local.depth()[i], whole.depth()[i]);
  // Most of the top face: more than a third of the nodes would be in the region, so
  // the whole run does it, with the whole run's values.
  const std::vector<Index> wide = tets_near(m, Vector3d(0.5, 0.5, 0.25), 0.45);
  ASSERT_TRUE(local.compute_lazy(m.positions, wide));
  ASSERT_TRUE(whole.compute_lazy(m.positions, wide));
  EXPECT_TRUE(local.lazy_stats().whole);
  for (Index i = 0; i < m.num_nodes(); ++i) EXPECT_EQ(local.depth()[i], whole.depth()[i]);
  // Then a small press again: local, and nothing of the whole run is left.
  const std::vector<Index> small = tets_near(m, Vector3d(0.5, 0.5, 0.25), 0.03);
  const auto ns = local.compute_lazy(m.positions, small);
  ASSERT_TRUE(ns);
  EXPECT_FALSE(local.lazy_stats().whole);
  std::size_t finite = 0;
  for (const double d : local.depth()) finite += std::isfinite(d) ? 1 : 0;
  EXPECT_EQ(finite, *ns);
}

// A non-finite coordinate the local run reads is an error naming the node; one it does
// not read is not looked at (the pipeline validates every state before).
TEST(DepthLazyLocal, NonFiniteNodeInTheRegionIsAnError) {
  const TetMesh m0 = test::structured_box(10, 10, 4, Vector3d(0, 0, 0), Vector3d(1, 1, 0.4));
  const Topology topo = build_topology(m0.tets, m0.num_nodes());
  const std::vector<Index> marked = tets_near(m0, Vector3d(0.5, 0.5, 0.4), 0.06);
  ASSERT_FALSE(marked.empty());
  const Index in_region = m0.tets[marked[0]][0];
  Index far = -1;
  for (Index v = 0; v < m0.num_nodes(); ++v)
    if ((m0.positions.col(v) - Vector3d(1.0, 1.0, 0.0)).norm() < 1e-9) far = v;
  ASSERT_GE(far, 0);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    DepthSolver s(m0.tets, topo, {.method = method});
    Positions p = m0.positions;
    p(2, in_region) = std::numeric_limits<double>::quiet_NaN();
    const auto bad = s.compute_lazy(p, marked);
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("node " + std::to_string(in_region)), std::string::npos)
        << bad.error().message;
    for (const double d : s.depth()) EXPECT_FALSE(std::isnan(d));
    p = m0.positions;
    p(0, far) = std::numeric_limits<double>::infinity();
    EXPECT_TRUE(s.compute_lazy(p, marked));
  }
}

// 2D: a local run on the disc gives true boundary distances and settles few nodes.
TEST(Depth2d, LocalLazyIsAnUpperBoundOfTheExactDepth) {
  const TriMesh2 m = test::disc_mesh_2d(40, 1.0);
  const Topology2 topo = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  const auto exact = compute_depth_exact(m, topo);
  ASSERT_TRUE(exact);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    DepthSolver2 s(m.triangles, topo, {.method = method});
    std::vector<Index> marked;
    for (std::size_t t = 0; t < m.triangles.size(); ++t)
      for (const Index v : m.triangles[t])
        if ((m.positions.col(v) - Eigen::Vector2d(0.97, 0.0)).norm() < 0.06) {
          marked.push_back(static_cast<Index>(t));
          break;
        }
    const auto settled = s.compute_lazy(m.positions, marked);
    ASSERT_TRUE(settled);
    EXPECT_LT(*settled * 10, static_cast<std::size_t>(m.positions.cols()));
    for (Index i = 0; i < m.positions.cols(); ++i)
      if (s.settled(i)) {
        EXPECT_GE(s.depth()[i], (*exact)[i] - 1e-12);
      }
  }
}

TEST(DepthLazy, EmptyTargetSetSettlesNothing) {
  const TetMesh m = test::cube_six_tets();
  const Topology topo = build_topology(m.tets, m.num_nodes());
  DepthSolver solver(m.tets, topo);
  const auto settled = solver.compute_lazy(m.positions, {});
  ASSERT_TRUE(settled);
  EXPECT_EQ(*settled, 0u);
  for (const double d : solver.depth()) EXPECT_EQ(d, kInf);
}

TEST(DepthLazy, OutOfRangeTetIsAnErrorNamingIt) {
  const TetMesh m = test::cube_six_tets();
  const Topology topo = build_topology(m.tets, m.num_nodes());
  DepthSolver solver(m.tets, topo);
  const std::vector<Index> marked = {0, 6};
  const auto settled = solver.compute_lazy(m.positions, marked);
  ASSERT_FALSE(settled);
  EXPECT_EQ(settled.error().code, ErrorCode::kInvalidArgument);
  EXPECT_NE(settled.error().message.find("#1 = 6"), std::string::npos);
}

// ---------------------------------------------------------------------------
// Cut objects, orphans, degenerate tets.

TetMesh merge(const TetMesh& a, const TetMesh& b) {
  TetMesh m;
  m.positions.resize(3, a.num_nodes() + b.num_nodes());
  m.positions << a.positions, b.positions;
  m.node_ids = a.node_ids;
  for (const auto id : b.node_ids) m.node_ids.push_back(id + 100000);
  m.tets = a.tets;
  for (Tet t : b.tets) {
    for (Index& v : t) v += a.num_nodes();
    m.tets.push_back(t);
  }
  return m;
}

TEST(DepthComponents, TwoDisconnectedPiecesEachGetTheirOwnDepth) {
  // Two boxes side by side with a thin gap, as after a cut.
  const TetMesh left = test::structured_box(6, 6, 6, {0, 0, 0}, {1, 1, 1});
  const TetMesh right = test::structured_box(6, 6, 6, {1.02, 0, 0}, {2.02, 1, 1});
  const TetMesh m = merge(left, right);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  EXPECT_EQ(topo.num_components, 2);
  const auto exact = exact_of(m, topo);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact}) {
    const auto d = solve(m, topo, {.method = method});
    for (Index i = 0; i < m.num_nodes(); ++i) {
      const Eigen::Vector3d x = m.positions.col(i);
      const Eigen::Vector3d lo =
          i < left.num_nodes() ? Eigen::Vector3d(0, 0, 0) : Eigen::Vector3d(1.02, 0, 0);
      const double want =
          std::min((x - lo).minCoeff(), (lo + Eigen::Vector3d::Ones() - x).minCoeff());
      EXPECT_NEAR(d[i], want, 1e-12) << depth_method_name(method) << " node " << i;
    }
  }
}

TEST(DepthOrphans, OrphanNodesGetInfinityAndAreNeverSettled) {
  TetMesh m = test::structured_box(3, 3, 3, {0, 0, 0}, {1, 1, 1});
  const Index used = m.num_nodes();
  m.positions.conservativeResize(3, used + 2);
  m.positions.col(used) = Eigen::Vector3d(0.5, 0.5, 0.5);
  m.positions.col(used + 1).setConstant(std::numeric_limits<double>::quiet_NaN());
  m.node_ids.push_back(9001);
  m.node_ids.push_back(9002);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  ASSERT_EQ(topo.orphan_nodes.size(), 2u);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact}) {
    DepthSolver s(m.tets, topo, {.method = method});
    ASSERT_TRUE(s.compute(m.positions).ok()) << depth_method_name(method);
    EXPECT_EQ(s.settled_count(), static_cast<std::size_t>(used));
    for (const Index o : topo.orphan_nodes) {
      EXPECT_EQ(s.depth()[o], kInf);
      EXPECT_FALSE(s.settled(o));
    }
    for (Index i = 0; i < used; ++i) EXPECT_TRUE(std::isfinite(s.depth()[i]));
  }
}

TEST(DepthDegenerate, FlatAndCollapsedTetsNeitherCrashNorProduceNaN) {
  TetMesh m = test::structured_box(4, 4, 4, {0, 0, 0}, {1, 1, 1});
  const Index n = m.num_nodes();
  // A flat tet glued on the top face (its 4th node in the face's plane), and a tet
  // whose nodes all coincide but one, hanging off a corner.
  m.positions.conservativeResize(3, n + 3);
  m.positions.col(n) = Eigen::Vector3d(0.3, 0.3, 1.0);
  m.positions.col(n + 1) = Eigen::Vector3d(1.0, 1.0, 1.0);
  m.positions.col(n + 2) = Eigen::Vector3d(1.0, 1.0, 1.0);
  const Index top = 4 * 5 * 5;  // first node of the top layer k = 4
  m.tets.push_back({top, top + 1, top + 5, n});
  m.tets.push_back({n + 1, n + 2, n + 1 + 0, top + 24});
  m.tets.back()[2] = top + 23;
  for (int k = 0; k < 3; ++k) m.node_ids.push_back(5000 + k);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  const auto exact = exact_of(m, topo);
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    for (const CffmVariant v :
         {CffmVariant::kPaper, CffmVariant::kDescent, CffmVariant::kPaperDescent,
          CffmVariant::kMultiStart, CffmVariant::kNearStarts}) {
      const auto d = solve(m, topo, {.method = method, .cffm = v});
      for (Index i = 0; i < m.num_nodes(); ++i) {
        ASSERT_FALSE(std::isnan(d[i]));
        EXPECT_TRUE(std::isfinite(d[i]));
        EXPECT_GE(d[i], exact[i] - 1e-15);
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Determinism and robustness.

TEST(DepthDeterminism, SameResultAcrossRunsAndThreadCounts) {
  TetMesh m = test::ball_mesh(8, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  jitter_interior(m, topo, 0.03, 3);
  for (const auto method : {DepthMethod::kExact, DepthMethod::kCpfm, DepthMethod::kCffm}) {
    std::vector<double> first;
    for (const int threads : {1, 2, 4, 1}) {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(threads));
      DepthSolver s(m.tets, topo, {.method = method});
      for (int run = 0; run < 2; ++run) {
        ASSERT_TRUE(s.compute(m.positions).ok());
        const std::vector<double> d(s.depth().begin(), s.depth().end());
        if (first.empty()) first = d;
        EXPECT_EQ(d, first) << depth_method_name(method) << " threads " << threads;
      }
    }
  }
}

TEST(DepthDeterminism, ReusedSolverMatchesAFreshOneAfterOtherPositions) {
  TetMesh m = test::torus_mesh(24, 5, 2.0, 0.6);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    DepthSolver reused(m.tets, topo, {.method = method});
    TetMesh other = m;
    other.positions *= 1.7;
    other.positions.row(0).array() += 0.3;
    ASSERT_TRUE(reused.compute(other.positions).ok());
    ASSERT_TRUE(reused.compute(m.positions).ok());
    EXPECT_EQ(std::vector<double>(reused.depth().begin(), reused.depth().end()),
              solve(m, topo, {.method = method}));
  }
}

class DepthScale : public ::testing::TestWithParam<std::pair<double, double>> {};

TEST_P(DepthScale, OffsetAndScaleKeepTheRelativeError) {
  const auto [scale, offset] = GetParam();
  TetMesh m = test::ball_mesh(7, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  jitter_interior(m, topo, 0.04, 9);
  const auto reference_exact = exact_of(m, topo);
  const auto reference_cpfm = solve(m, topo, {.method = DepthMethod::kCpfm});
  const auto reference_cffm = solve(m, topo, {.method = DepthMethod::kCffm});
  TetMesh moved = m;
  moved.positions = (m.positions * scale).array() + offset;
  const auto exact = exact_of(moved, topo);
  const auto cpfm = solve(moved, topo, {.method = DepthMethod::kCpfm});
  const auto cffm = solve(moved, topo, {.method = DepthMethod::kCffm});
  // Relative to the ball's size; an offset of 1e6 costs the double coordinates ~1e-10.
  const double tol = 1e-9 * (1.0 + std::abs(offset) / scale) * scale;
  for (Index i = 0; i < m.num_nodes(); ++i) {
    EXPECT_NEAR(exact[i], scale * reference_exact[i], tol);
    EXPECT_GE(cpfm[i], exact[i] - tol);
    EXPECT_GE(cffm[i], exact[i] - tol);
  }
  const ErrorStats a = error_stats(cpfm, exact), b = error_stats(reference_cpfm, reference_exact);
  EXPECT_NEAR(a.mean, scale * b.mean, 1e-3 * scale);
  const ErrorStats c = error_stats(cffm, exact), d = error_stats(reference_cffm, reference_exact);
  EXPECT_NEAR(c.mean, scale * d.mean, 1e-3 * scale);
}

INSTANTIATE_TEST_SUITE_P(ScalesAndOffsets, DepthScale,
                         ::testing::Values(std::pair{1.0, 1e6}, std::pair{1e-6, 0.0},
                                           std::pair{1e-6, 1.0}, std::pair{1e3, -250.0}));

TEST(DepthRobustness, NonFiniteOrMisSizedPositionsAreErrorsNamingTheNode) {
  TetMesh m = test::structured_box(3, 3, 3, {0, 0, 0}, {1, 1, 1});
  const Topology topo = build_topology(m.tets, m.num_nodes());
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact}) {
    DepthSolver s(m.tets, topo, {.method = method});
    Positions bad = m.positions;
    bad(1, 17) = std::numeric_limits<double>::quiet_NaN();
    const Status st = s.compute(bad);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("node 17"), std::string::npos) << st.error().message;
    for (const double d : s.depth()) EXPECT_FALSE(std::isnan(d));
    bad(1, 17) = std::numeric_limits<double>::infinity();
    EXPECT_FALSE(s.compute(bad).ok());
    const Positions short_positions = m.positions.leftCols(10);
    EXPECT_FALSE(s.compute(short_positions).ok());
    const std::vector<Index> marked = {0};
    EXPECT_FALSE(s.compute_lazy(short_positions, marked));
  }
}

TEST(DepthRobustness, SingleTetAndPointsOnTheBoundary) {
  // Every node is a boundary node: all depths are 0.
  const TetMesh m = test::single_tet();
  const Topology topo = build_topology(m.tets, m.num_nodes());
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact})
    for (const double d : solve(m, topo, {.method = method})) EXPECT_EQ(d, 0.0);
}

TEST(DepthFreeFunctions, MatchTheSolver) {
  const TetMesh m = test::ball_mesh(5, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  EXPECT_EQ(*compute_depth_cpfm(m, topo), solve(m, topo, {.method = DepthMethod::kCpfm}));
  EXPECT_EQ(*compute_depth_cffm(m, topo), solve(m, topo, {.method = DepthMethod::kCffm}));
  EXPECT_EQ(*compute_depth_exact(m, topo), exact_of(m, topo));
  TetMesh bad = m;
  bad.positions(0, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(compute_depth_cpfm(bad, topo));
}

// ---------------------------------------------------------------------------
// 2D (the paper's Fig. 9 and 10 case).

std::vector<double> solve_2d(const TriMesh2& m, const Topology2& topo, DepthSolverOptions o) {
  DepthSolver2 s(m.triangles, topo, o);
  EXPECT_TRUE(s.compute(m.positions).ok());
  return {s.depth().begin(), s.depth().end()};
}

TEST(Depth2d, RectangleExactIsDistanceToNearestSide) {
  TriMesh2 m = test::rect_mesh_2d(12, 7, 3.0, 1.5);
  const Topology2 topo = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  EXPECT_EQ(topo.boundary_segments.size(), 2u * (12 + 7));
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  for (Index i = 0; i < m.positions.cols(); ++i)
    if (!topo.is_boundary_node[i]) m.positions.col(i) += Eigen::Vector2d(u(rng), u(rng));
  const auto exact = solve_2d(m, topo, {.method = DepthMethod::kExact});
  const auto cpfm = solve_2d(m, topo, {.method = DepthMethod::kCpfm});
  const auto cffm = solve_2d(m, topo, {.method = DepthMethod::kCffm});
  for (Index i = 0; i < m.positions.cols(); ++i) {
    const Eigen::Vector2d x = m.positions.col(i);
    const double want = std::min({x.x(), x.y(), 3.0 - x.x(), 1.5 - x.y()});
    EXPECT_NEAR(exact[i], want, 1e-12);
    EXPECT_GE(cpfm[i], exact[i] - 1e-15);
    EXPECT_GE(cffm[i], exact[i] - 1e-15);
    EXPECT_LE(cffm[i], cpfm[i] + 1e-12);
  }
}

TEST(Depth2d, DiscMarchesAreUpperBoundsAndCffmIsCloser) {
  const double r = 1.0;
  const TriMesh2 m = test::disc_mesh_2d(24, r);
  const Topology2 topo = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  const auto exact = solve_2d(m, topo, {.method = DepthMethod::kExact});
  double h = 0.0;
  for (const auto& s : topo.boundary_segments)
    h = std::max(h, (m.positions.col(s[0]) - m.positions.col(s[1])).norm());
  const double gap = h * h / (8 * r) * 1.01;  // sagitta of the longest chord
  for (Index i = 0; i < m.positions.cols(); ++i) {
    const double analytic = r - m.positions.col(i).norm();
    EXPECT_LE(exact[i], analytic + 1e-12);
    EXPECT_GE(exact[i], analytic - gap);
  }
  const ErrorStats ep = error_stats(solve_2d(m, topo, {.method = DepthMethod::kCpfm}), exact);
  const ErrorStats ef = error_stats(solve_2d(m, topo, {.method = DepthMethod::kCffm}), exact);
  EXPECT_GE(ep.min, -1e-15);
  EXPECT_GE(ef.min, -1e-15);
  EXPECT_LT(ef.max, ep.max);
  EXPECT_LT(ef.mean, ep.mean);
  EXPECT_LT(ep.max, 3 * h);
}

TEST(Depth2d, LazyEqualsFull) {
  const TriMesh2 m = test::disc_mesh_2d(16, 1.0);
  const Topology2 topo = build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols()));
  for (const auto method : {DepthMethod::kCpfm, DepthMethod::kCffm}) {
    DepthSolver2 s(m.triangles, topo,
                   {.method = method, .lazy_region = LazyRegion::kWholeBoundary});
    ASSERT_TRUE(s.compute(m.positions).ok());
    const std::vector<double> full(s.depth().begin(), s.depth().end());
    std::mt19937 rng(8);
    for (int sweep = 0; sweep < 30; ++sweep) {
      std::vector<Index> marked;
      for (int k = 0; k < 1 + sweep; ++k)
        marked.push_back(static_cast<Index>(rng() % m.triangles.size()));
      const auto settled = s.compute_lazy(m.positions, marked);
      ASSERT_TRUE(settled);
      for (Index i = 0; i < m.positions.cols(); ++i)
        if (s.settled(i)) {
          EXPECT_EQ(s.depth()[i], full[i]);
        }
      for (const Index t : marked)
        for (const Index v : m.triangles[t]) EXPECT_TRUE(s.settled(v));
    }
  }
}

// One spelling of the depth methods everywhere (scene files, the CLI, recordings).
TEST(DepthMethodNames, ParseIsTheInverseOfTheName) {
  for (const DepthMethod m : {DepthMethod::kCpfm, DepthMethod::kCffm, DepthMethod::kExact})
    EXPECT_EQ(parse_depth_method(depth_method_name(m)), m);
  EXPECT_EQ(parse_depth_method("cpfm"), DepthMethod::kCpfm);
  EXPECT_FALSE(parse_depth_method("CPFM").has_value());
  EXPECT_FALSE(parse_depth_method("").has_value());
  EXPECT_FALSE(parse_depth_method("cffm:descent").has_value());
}

}  // namespace
}  // namespace tc
