// service/core/detect/tet_overlap: exact tet-tet overlap, point-in-tet, segment clipping.
// Checked against an independent sampling oracle (clearance of sample points gives a
// lower bound of the penetration depth; point-to-tet distances of samples give a lower
// bound of the distance), against known contacts, and under offsets and scales.
#include "core/detect/tet_overlap.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <random>
#include <span>
#include <tuple>
#include <vector>

#include "core/common/cpu_dispatch.hpp"
#include "core/mesh/geometry.hpp"
#include "kernel_copies.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kTol = 1e-9;  // relative tolerance used throughout

TetCorners unit_tet() {
  return {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0), Vector3d(0, 0, 1)};
}

TetCorners transform(const TetCorners& t, double scale, const Vector3d& offset) {
  TetCorners out;
  for (int i = 0; i < 4; ++i) out[i] = t[i] * scale + offset;
  return out;
}

bool overlap(const TetCorners& a, const TetCorners& b) {
  return tets_overlap(a, b, kTol * pair_scale(a, b));
}

// ------------------------------------------------------------------ independent oracle

double diameter_of(const TetCorners& t) {
  double d = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) d = std::max(d, (t[i] - t[j]).norm());
  return d;
}

/// Signed clearance of p inside t: min over faces of the distance to the face plane,
/// positive inside (computed from each face and its opposite corner, no shared code).
double clearance(const Vector3d& p, const TetCorners& t) {
  // A flat tet has no interior (and its face planes coincide).
  const double size = diameter_of(t);
  if (std::abs((t[1] - t[0]).dot((t[2] - t[0]).cross(t[3] - t[0]))) <= 1e-12 * size * size * size)
    return -std::numeric_limits<double>::infinity();
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    const Vector3d& a = t[(k + 1) % 4];
    const Vector3d& b = t[(k + 2) % 4];
    const Vector3d& c = t[(k + 3) % 4];
    Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    if (len == 0.0) return -std::numeric_limits<double>::infinity();
    n /= len;
    if (n.dot(t[k] - a) < 0.0) n = -n;  // point inwards
    best = std::min(best, n.dot(p - a));
  }
  return best;
}

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection 5.1.5).
Vector3d closest_on_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b,
                             const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// Distance from p to the closed tet t (0 inside).
double distance_to_tet(const Vector3d& p, const TetCorners& t) {
  if (clearance(p, t) >= 0.0) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k)
    best = std::min(
        best, (p - closest_on_triangle(p, t[(k + 1) % 4], t[(k + 2) % 4], t[(k + 3) % 4])).norm());
  return best;
}

/// Barycentric lattice of N divisions over a tet.
std::vector<Vector3d> samples(const TetCorners& t, int n) {
  std::vector<Vector3d> s;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j)
      for (int k = 0; i + j + k <= n; ++k) {
        const int l = n - i - j - k;
        s.push_back((i * t[0] + j * t[1] + k * t[2] + l * t[3]) / n);
      }
  return s;
}

struct Oracle {
  double depth_lower = 0.0;     ///< penetration depth >= this
  double distance_lower = 0.0;  ///< distance >= this (when > 0: disjoint)
};

Oracle oracle(const TetCorners& a, const TetCorners& b, int n = 12) {
  Oracle o;
  o.depth_lower = -std::numeric_limits<double>::infinity();
  double dist = std::numeric_limits<double>::infinity();
  for (const Vector3d& s : samples(a, n)) {
    o.depth_lower = std::max(o.depth_lower, clearance(s, b));
    dist = std::min(dist, distance_to_tet(s, b));
  }
  for (const Vector3d& s : samples(b, n)) o.depth_lower = std::max(o.depth_lower, clearance(s, a));
  o.distance_lower = dist - diameter_of(a) / n;
  return o;
}

TetCorners random_tet(std::mt19937& rng, double min_quality) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (;;) {
    TetCorners t;
    for (auto& p : t) p = Vector3d(u(rng), u(rng), u(rng));
    if (signed_volume(t[0], t[1], t[2], t[3]) < 0) std::swap(t[2], t[3]);
    Positions p(3, 4);
    for (int i = 0; i < 4; ++i) p.col(i) = t[i];
    if (tet_quality(p, Tet{0, 1, 2, 3}) >= min_quality) return t;
  }
}

/// Reference SAT without any shortcut: every coordinate axis, face normal and edge-edge
/// cross product (written out here, independently of the library).
double full_sat_penetration(const TetCorners& a, const TetCorners& b) {
  std::vector<Vector3d> axes = {Vector3d::UnitX(), Vector3d::UnitY(), Vector3d::UnitZ()};
  const int faces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  for (const TetCorners* t : {&a, &b})
    for (const auto& f : faces)
      axes.push_back(((*t)[f[1]] - (*t)[f[0]]).cross((*t)[f[2]] - (*t)[f[0]]));
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      for (int k = 0; k < 4; ++k)
        for (int l = k + 1; l < 4; ++l) axes.push_back((a[j] - a[i]).cross(b[l] - b[k]));
  double best = std::numeric_limits<double>::infinity();
  for (const Vector3d& u : axes) {
    if (u.norm() < 1e-14) continue;
    const Vector3d n = u.normalized();
    double alo = 1e300, ahi = -1e300, blo = 1e300, bhi = -1e300;
    for (int i = 0; i < 4; ++i) {
      alo = std::min(alo, n.dot(a[i]));
      ahi = std::max(ahi, n.dot(a[i]));
      blo = std::min(blo, n.dot(b[i]));
      bhi = std::max(bhi, n.dot(b[i]));
    }
    best = std::min(best, std::min(ahi - blo, bhi - alo));
  }
  return best;
}

// ---------------------------------------------------------------------- random vs oracle

TEST(TetOverlap, RandomPairsAgreeWithSamplingOracle) {
  std::mt19937 rng(20040827);
  std::uniform_real_distribution<double> shift(-0.6, 0.6);
  int overlapping = 0, disjoint = 0, ambiguous = 0;
  for (int iter = 0; iter < 1500; ++iter) {
    const TetCorners a = random_tet(rng, 0.05);
    TetCorners b = random_tet(rng, 0.05);
    const Vector3d s(shift(rng), shift(rng), shift(rng));
    for (auto& p : b) p += s;
    const Oracle o = oracle(a, b);
    const double pen = sat_penetration(a, b);
    const double tol = kTol * pair_scale(a, b);
    // Every SAT axis is a true direction, so the minimum over them is never below the
    // penetration depth, hence never below a positive clearance found by sampling.
    if (o.depth_lower > 0.0) {
      EXPECT_GE(pen, o.depth_lower - 1e-12) << "iteration " << iter;
    }
    EXPECT_EQ(tets_overlap(a, b, tol), pen > tol) << "iteration " << iter;
    if (o.depth_lower > 1e-6) {
      ++overlapping;
      EXPECT_TRUE(overlap(a, b)) << "iteration " << iter;
    } else if (o.distance_lower > 1e-6) {
      ++disjoint;
      EXPECT_FALSE(overlap(a, b)) << "iteration " << iter;
      EXPECT_LE(pen, 0.0) << "iteration " << iter;
    } else {
      ++ambiguous;
    }
  }
  EXPECT_GT(overlapping, 200);
  EXPECT_GT(disjoint, 200);
}

TEST(TetOverlap, GaussMapFilterKeepsTheExactPenetration) {
  // The library skips edge pairs whose Gauss-map arcs do not cross; the minimum over the
  // remaining axes must still be the full SAT minimum, overlapping or not, slivers too.
  std::mt19937 rng(555);
  std::uniform_real_distribution<double> shift(-0.6, 0.6);
  int overlapping = 0;
  for (int iter = 0; iter < 3000; ++iter) {
    const TetCorners a = random_tet(rng, iter % 3 == 0 ? 0.001 : 0.05);
    TetCorners b = random_tet(rng, 0.05);
    const Vector3d s(shift(rng), shift(rng), shift(rng));
    for (auto& p : b) p += s;
    // Positive values (penetration depth) are exact; negative ones are only "some gap"
    // (a separated pair's largest gap over the axes tried), so only their sign counts.
    const double want = full_sat_penetration(a, b);
    for (const double got : {sat_penetration(a, b), sat_penetration(b, a)}) {
      if (want > 1e-9) {
        ++overlapping;
        EXPECT_NEAR(got, want, 1e-9) << "iteration " << iter;
      } else {
        EXPECT_LE(got, 1e-9) << "iteration " << iter;
      }
    }
  }
  EXPECT_GT(overlapping, 1000);
}

TEST(TetOverlap, SliversAndFlatTetsAgreeWithOracle) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_real_distribution<double> shift(-0.6, 0.6);
  int decided = 0;
  for (int iter = 0; iter < 800; ++iter) {
    TetCorners a = random_tet(rng, 0.0);
    // Squash A towards the plane of its first face: quality 1e-3 .. exactly flat.
    const double squash = iter % 4 == 0 ? 0.0 : std::pow(10.0, -1.0 - 12.0 * u(rng));
    const Vector3d c = (a[1] + a[2] + a[3]) / 3.0;
    a[0] = c + squash * (a[0] - c) + 0.3 * u(rng) * (a[1] - a[2]);
    TetCorners b = random_tet(rng, 0.05);
    const Vector3d s(shift(rng), shift(rng), shift(rng));
    for (auto& p : b) p += s;
    const Oracle o = oracle(a, b);
    const double pen = sat_penetration(a, b);
    ASSERT_FALSE(std::isnan(pen));
    if (o.depth_lower > 0.0) {
      EXPECT_GE(pen, o.depth_lower - 1e-12) << "iteration " << iter;
    }
    if (o.depth_lower > 1e-6) {
      ++decided;
      EXPECT_TRUE(overlap(a, b)) << "iteration " << iter;
    } else if (o.distance_lower > 1e-6) {
      ++decided;
      EXPECT_FALSE(overlap(a, b)) << "iteration " << iter;
    }
  }
  EXPECT_GT(decided, 400);
}

// ------------------------------------------------------------------------ known contacts

TEST(TetOverlap, KnownPenetrationDepth) {
  // A above z = 0, B below z = delta: they must move delta apart along z.
  const TetCorners a = unit_tet();
  for (const double delta : {1e-6, 1e-3, 0.01, 0.05}) {
    const TetCorners b = {Vector3d(0, 0, delta), Vector3d(1, 0, delta), Vector3d(0, 1, delta),
                          Vector3d(0, 0, delta - 1)};
    EXPECT_NEAR(sat_penetration(a, b), delta, 1e-12 + 1e-9 * delta);
  }
}

TEST(TetOverlap, IdenticalAndNestedTetsOverlap) {
  const TetCorners a = unit_tet();
  EXPECT_TRUE(overlap(a, a));
  const Vector3d c = (a[0] + a[1] + a[2] + a[3]) / 4.0;
  TetCorners small;
  for (int i = 0; i < 4; ++i) small[i] = c + 0.1 * (a[i] - c);
  EXPECT_TRUE(overlap(a, small));
  EXPECT_TRUE(overlap(small, a));
}

TEST(TetOverlap, SharedFaceOfAMeshIsNotAnOverlap) {
  const TetMesh m = test::two_tets_sharing_face();
  const TetCorners a = tet_corners(m.positions, m.tets[0]);
  const TetCorners b = tet_corners(m.positions, m.tets[1]);
  EXPECT_FALSE(overlap(a, b));
  EXPECT_LE(sat_penetration(a, b), 1e-15);
}

TEST(TetOverlap, NaNCornersNeverOverlap) {
  TetCorners a = unit_tet();
  a[2].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(overlap(a, unit_tet()));
  EXPECT_FALSE(overlap(unit_tet(), a));
  a[2].y() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(overlap(a, unit_tet()));
}

TEST(TetOverlap, FlatTetInsideATetOverlapsAndOnItsFaceDoesNot) {
  const TetCorners big = transform(unit_tet(), 4.0, Vector3d(-1, -1, -1));
  // A zero-volume tet (all in z = 0) well inside the big one: it has to move to get out.
  const TetCorners flat = {Vector3d(0, 0, 0), Vector3d(0.5, 0, 0), Vector3d(0, 0.5, 0),
                           Vector3d(0.2, 0.2, 0)};
  EXPECT_TRUE(overlap(flat, big));
  EXPECT_TRUE(overlap(big, flat));
  // The same flat tet lying on the bottom face z = -1 of the big tet: touching.
  const TetCorners on_face = transform(flat, 1.0, Vector3d(0, 0, -1));
  EXPECT_FALSE(overlap(on_face, big));
  EXPECT_FALSE(overlap(big, on_face));
  // Collinear and point-like tets.
  const TetCorners needle = {Vector3d(0, 0, 0), Vector3d(0.2, 0, 0), Vector3d(0.4, 0, 0),
                             Vector3d(0.6, 0, 0)};
  EXPECT_TRUE(overlap(needle, big));
  EXPECT_FALSE(overlap(transform(needle, 1.0, Vector3d(0, 0, -1.5)), big));
  const TetCorners point = {Vector3d(0.1, 0.1, 0.1), Vector3d(0.1, 0.1, 0.1),
                            Vector3d(0.1, 0.1, 0.1), Vector3d(0.1, 0.1, 0.1)};
  EXPECT_TRUE(overlap(point, big));
  EXPECT_FALSE(overlap(point, transform(point, 1.0, Vector3d(1e-3, 0, 0))));
  EXPECT_FALSE(overlap(transform(point, 1.0, Vector3d(3, 3, 3)), big));
}

/// A contact configuration: B touches A; pushing B by `push` along `dir` makes them
/// overlap by about `push` (push < 0 separates).
struct Contact {
  const char* name;
  TetCorners b;
  Vector3d dir;  ///< unit direction that pushes B into A
};

std::vector<Contact> contacts() {
  const Vector3d down(0, 0, -1);
  return {
      // Face to face, B's bottom face on A's top... A's face x+y+z=1 against B's face.
      {"face-face",
       {Vector3d(1, 0, 0), Vector3d(0, 1, 0), Vector3d(0, 0, 1), Vector3d(1, 1, 1)},
       Vector3d(-1, -1, -1).normalized()},
      // Coplanar faces partly overlapping, tets on opposite sides of z = 0.
      {"coplanar-offset",
       {Vector3d(0.3, 0.3, 0), Vector3d(1.3, 0.3, 0), Vector3d(0.3, 1.3, 0),
        Vector3d(0.3, 0.3, -1)},
       Vector3d(0, 0, 1)},
      // Vertex of B on the interior of A's face x + y + z = 1.
      {"vertex-face",
       {Vector3d(0.3, 0.3, 0.4), Vector3d(1.3, 0.8, 0.9), Vector3d(0.8, 1.3, 0.9),
        Vector3d(0.8, 0.8, 1.4)},
       Vector3d(-1, -1, -1).normalized()},
      // Vertex to vertex at (0, 0, 1).
      {"vertex-vertex",
       {Vector3d(0, 0, 1), Vector3d(0.5, 0.5, 2), Vector3d(-0.5, 0.5, 2), Vector3d(0, -0.6, 2)},
       down},
      // Edge of B crossing edge (0,0,1)-(1,0,0) of A at its midpoint, skew.
      {"edge-edge",
       {Vector3d(0.5, -0.5, 0.5), Vector3d(0.5, 0.5, 0.5), Vector3d(1.5, 0, 1.5),
        Vector3d(1.2, 0.3, 1.6)},
       Vector3d(-1, 0, -1).normalized()},
  };
}

/// (scale, offset) pairs. Input coordinates carry a rounding of |offset| * eps, so touching
/// is decidable when |offset| * eps is below the tolerance (1e-9 * scale): offsets up to
/// about 1e6 times the object size (docs/DETECTION.md).
const auto kFrames = ::testing::Values(std::make_tuple(1e-6, 0.0), std::make_tuple(1.0, 0.0),
                                       std::make_tuple(1e3, 0.0), std::make_tuple(1.0, 1e6),
                                       std::make_tuple(1e3, 1e6), std::make_tuple(1e-3, 1e3));

using ContactParam = std::tuple<int, double, std::tuple<double, double>>;

class ContactSweep : public ::testing::TestWithParam<ContactParam> {};

TEST_P(ContactSweep, OverlapIffPushedBeyondTolerance) {
  const auto [which, push, frame] = GetParam();
  const auto [scale, offset] = frame;
  const Contact c = contacts()[static_cast<std::size_t>(which)];
  const Vector3d o = Vector3d(1.0, -0.7, 0.3) * offset;
  const TetCorners a = transform(unit_tet(), scale, o);
  TetCorners b = transform(c.b, scale, o);
  // Sanity: the unpushed configuration touches (oracle: no clear overlap, no clear gap).
  const Oracle touching = oracle(unit_tet(), c.b);
  ASSERT_LE(touching.depth_lower, 1e-12) << c.name;
  ASSERT_LE(touching.distance_lower, 0.0) << c.name;
  for (auto& p : b) p += push * scale * c.dir;
  const bool expect = push > 0.0;
  EXPECT_EQ(overlap(a, b), expect) << c.name << " push " << push;
  EXPECT_EQ(overlap(b, a), expect) << c.name << " push " << push;
}

INSTANTIATE_TEST_SUITE_P(TetOverlap, ContactSweep,
                         ::testing::Combine(::testing::Range(0, 5),
                                            ::testing::Values(-1e-3, -1e-6, 0.0, 1e-7, 1e-4, 1e-2),
                                            kFrames));

/// Bits of a double, with every NaN alike (no caller looks at a NaN's payload).
std::uint64_t bits(double x) {
  return std::isnan(x) ? 0x7ff8000000000000ULL : std::bit_cast<std::uint64_t>(x);
}

/// Every field of `got` has the bits of `want`'s (NaNs alike).
void expect_same_geometry(const TetGeometry& got, const TetGeometry& want, int iter, int lane) {
  const auto same = [&](std::span<const double> g, std::span<const double> w, const char* name) {
    ASSERT_EQ(g.size(), w.size());
    for (std::size_t k = 0; k < g.size(); ++k)
      ASSERT_EQ(bits(g[k]), bits(w[k]))
          << name << "[" << k << "] iteration " << iter << " lane " << lane;
  };
  same({got.lo.data(), 3}, {want.lo.data(), 3}, "lo");
  same({got.hi.data(), 3}, {want.hi.data(), 3}, "hi");
  same({&got.scale, 1}, {&want.scale, 1}, "scale");
  ASSERT_EQ(got.flat, want.flat) << "flat, iteration " << iter << " lane " << lane;
  same(got.n_len, want.n_len, "n_len");
  same(got.nx, want.nx, "nx");
  same(got.ny, want.ny, "ny");
  same(got.nz, want.nz, "nz");
  same(got.n_inv, want.n_inv, "n_inv");
  for (int i = 0; i < 4; ++i) same({got.v[i].data(), 3}, {want.v[i].data(), 3}, "v");
  same(got.lx, want.lx, "lx");
  same(got.ly, want.ly, "ly");
  same(got.lz, want.lz, "lz");
  same(got.plane, want.plane, "plane");
  same(got.apex, want.apex, "apex");
  same(got.ax, want.ax, "ax");
  same(got.ay, want.ay, "ay");
  same(got.az, want.az, "az");
  same(got.ex, want.ex, "ex");
  same(got.ey, want.ey, "ey");
  same(got.ez, want.ez, "ez");
}

// With each copy of the kernel (AVX2, baseline).
class TetGeometryCopies : public test::BothKernels {};

TEST_P(TetGeometryCopies, FourAtOnceHasTheBitsOfOneAtATime) {
  // Random tets of any quality (slivers and flat ones included), both orientations,
  // repeated corners, 1e6 offsets and 1e-6 scales, and corners that are NaN or infinite.
  std::mt19937 rng(31337);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  int flat = 0, nonfinite = 0;
  for (int iter = 0; iter < 5000; ++iter) {
    std::array<TetCorners, 4> t;
    for (int j = 0; j < 4; ++j) {
      const int kind = (iter + j) % 8;
      TetCorners c = random_tet(rng, kind == 0 ? 0.0 : 0.05);
      if (kind == 1) std::swap(c[0], c[1]);                                          // inverted
      if (kind == 2) c[3] = c[0] + u(rng) * (c[1] - c[0]) + u(rng) * (c[2] - c[0]);  // flat
      if (kind == 3) c[2] = c[1];                                                    // repeated
      const double scale = iter % 3 == 0 ? 1e-6 : 1.0;
      const Vector3d offset = iter % 5 == 0 ? Vector3d(1e6, -5e5, 2e5) : Vector3d::Zero();
      c = transform(c, scale, offset);
      if (kind == 4 && iter % 4 == 0) c[iter % 4][(iter / 4) % 3] = (iter % 8 == 0) ? nan : inf;
      if (kind == 5 && iter % 7 == 0) c[1].x() = -inf;
      t[j] = c;
    }
    std::array<TetGeometry, 4> got;
    make_tet_geometry4(t, {&got[0], &got[1], &got[2], &got[3]});
    for (int j = 0; j < 4; ++j) {
      const TetGeometry want = make_tet_geometry(t[j]);
      expect_same_geometry(got[j], want, iter, j);
      if (HasFatalFailure()) return;
      flat += want.flat ? 1 : 0;
      nonfinite += want.scale == 0.0 && want.lo.x() == inf ? 1 : 0;
    }
  }
  EXPECT_GT(flat, 2000);  // the flat, repeated and non-finite kinds
  EXPECT_GT(nonfinite, 100);
}

INSTANTIATE_TEST_SUITE_P(Kernels, TetGeometryCopies, ::testing::Bool(), test::kernel_copy_name);

TEST(TetOverlap, TranslationAndScaleInvariantOnRandomPairs) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> shift(-0.7, 0.7);
  int checked = 0;
  for (int iter = 0; iter < 400; ++iter) {
    const TetCorners a = random_tet(rng, 0.05);
    TetCorners b = random_tet(rng, 0.05);
    const Vector3d s(shift(rng), shift(rng), shift(rng));
    for (auto& p : b) p += s;
    const double pen = sat_penetration(a, b);
    if (std::abs(pen) < 1e-6) continue;  // too close to touching to compare across scales
    ++checked;
    for (const auto& [scale, offset] :
         {std::pair{1e-6, 0.0}, std::pair{1e-3, 0.0}, std::pair{1e3, 0.0}, std::pair{1.0, 1e6},
          std::pair{1e3, 1e6}, std::pair{1e-3, 1e3}}) {
      const Vector3d o(offset, -offset, 0.5 * offset);
      const TetCorners as = transform(a, scale, o), bs = transform(b, scale, o);
      EXPECT_EQ(overlap(as, bs), pen > 0) << iter << " scale " << scale << " offset " << offset;
    }
  }
  EXPECT_GT(checked, 300);
}

// ------------------------------------------------- vectorised test against the reference

/// tets_overlap() (4 axes at a time) must answer exactly as tets_overlap_reference() (the
/// scalar walk) for every input: both orders, several tolerances, and the inputs where the
/// answer hangs on rounding (pairs moved to the reference's own overlap boundary).
class VectorisedOverlap : public ::testing::Test {
 protected:
  std::mt19937 rng_{20261203};
  std::uniform_real_distribution<double> u_{0.0, 1.0};
  int checked_ = 0, overlapping_ = 0;

  // A failed assertion leaves check() with the baseline copy switched on: later tests run
  // the copy this CPU picks again.
  void TearDown() override { detail::use_baseline_kernels(false); }

  Vector3d random_unit() {
    std::normal_distribution<double> g;
    return Vector3d(g(rng_), g(rng_), g(rng_)).normalized();
  }

  /// Compares the two functions on (a, b) and (b, a) under offset/scale transforms and
  /// tolerances 0, the detection one, and a large one.
  void check(const TetCorners& a, const TetCorners& b) {
    for (const auto& [scale, offset] :
         {std::pair{1.0, 0.0}, std::pair{1e-6, 0.0}, std::pair{1.0, 1e6}, std::pair{1e-6, 1e6}}) {
      const Vector3d o(offset, -0.7 * offset, 0.3 * offset);
      const TetGeometry ga = make_tet_geometry(transform(a, scale, o));
      const TetGeometry gb = make_tet_geometry(transform(b, scale, o));
      const double s = pair_scale(ga, gb);
      // Both copies of the vectorised test: the one this CPU runs, then the x86-64 baseline.
      for (const bool baseline : {false, true}) {
        detail::use_baseline_kernels(baseline);
        for (const double tol : {0.0, kTol * s, 1e-3 * s, -1.0}) {
          const bool want = tets_overlap_reference(ga, gb, tol);
          ASSERT_EQ(tets_overlap(ga, gb, tol), want)
              << "check " << checked_ << " scale " << scale << " offset " << offset << " tol "
              << tol << " baseline " << baseline;
          ASSERT_EQ(tets_overlap(gb, ga, tol), tets_overlap_reference(gb, ga, tol))
              << "check " << checked_ << " (swapped) scale " << scale << " offset " << offset
              << " baseline " << baseline;
          if (!baseline) overlapping_ += want ? 1 : 0;
        }
        if (!baseline) check_hints(ga, gb, s);
        // The narrow phase's batch: tolerance relative to each pair's scale, as detection.
        const std::array<GeometryPair, 2> pairs = {GeometryPair{&ga, &gb}, GeometryPair{&gb, &ga}};
        std::array<bool, 2> hits = {!tets_overlap_reference(ga, gb, kTol * s),
                                    !tets_overlap_reference(gb, ga, kTol * s)};
        tets_overlap_pairs(pairs, kTol, hits);
        ASSERT_EQ(hits[0], tets_overlap_reference(ga, gb, kTol * s))
            << "check " << checked_ << " batch, baseline " << baseline;
        ASSERT_EQ(hits[1], tets_overlap_reference(gb, ga, kTol * s))
            << "check " << checked_ << " batch (swapped), baseline " << baseline;
      }
      detail::use_baseline_kernels(false);
      if (scale == 1.0 && offset == 0.0) {
        batch_.push_back(ga);
        batch_.push_back(gb);
      }
    }
    ++checked_;
  }

  /// Every pair check() saw (at scale 1, offset 0), both ways round, in one call of
  /// tets_overlap_pairs(): runs of pairs of every kind (flat ones among them), many blocks
  /// of them, each against the reference, on both copies of the test.
  void check_batch() {
    std::vector<GeometryPair> pairs;
    for (std::size_t i = 0; i + 1 < batch_.size(); i += 2) {
      pairs.push_back({&batch_[i], &batch_[i + 1]});
      pairs.push_back({&batch_[i + 1], &batch_[i]});
    }
    std::vector<char> want(pairs.size());
    for (std::size_t i = 0; i < pairs.size(); ++i)
      want[i] = tets_overlap_reference(*pairs[i].a, *pairs[i].b,
                                       kTol * pair_scale(*pairs[i].a, *pairs[i].b))
                    ? 1
                    : 0;
    for (const bool baseline : {false, true}) {
      detail::use_baseline_kernels(baseline);
      std::unique_ptr<bool[]> hits(new bool[pairs.size()]);
      for (std::size_t i = 0; i < pairs.size(); ++i) hits[i] = want[i] == 0;  // all wrong
      tets_overlap_pairs(pairs, kTol, {hits.get(), pairs.size()});
      std::size_t wrong = 0, first = pairs.size();
      for (std::size_t i = 0; i < pairs.size(); ++i)
        if (hits[i] != (want[i] != 0)) {
          ++wrong;
          first = std::min(first, i);
        }
      EXPECT_EQ(wrong, 0U) << "first at pair " << first << " of " << pairs.size() << ", baseline "
                           << baseline;
    }
    detail::use_baseline_kernels(false);
    EXPECT_GT(pairs.size(), 20000U);
  }

  std::deque<TetGeometry> batch_;  ///< pairs of tets, in the order check() saw them
  int hints_found_ = 0, hint_answers_ = 0, grid_answers_ = 0;

  /// Overlap hints on (a, b) and (b, a), pair scale s: whatever hint holds answers as the
  /// reference (every code tried, at the detection tolerance and a large one), and a hint
  /// found for a pair holds on it. Relative tolerances below 10^-12 get none.
  void check_hints(const TetGeometry& a, const TetGeometry& b, double s) {
    for (const auto& [x, y] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
      for (const double rel : {kTol, 1e-3}) {
        const bool want = tets_overlap_reference(*x, *y, rel * s);
        for (int code = 0; code < 256; ++code) {
          const int r = check_overlap_hint(*x, *y, rel, static_cast<OverlapHint>(code));
          if (r < 0) continue;
          ASSERT_EQ(r == 1, want) << "check " << checked_ << " hint " << code << " rel " << rel;
          ++hint_answers_;
          grid_answers_ += code >= 53 ? 1 : 0;  // a grid point (not a corner) deep inside
        }
        const OverlapHint h = find_overlap_hint(*x, *y, rel, want);
        if (h != kOverlapHintNone) {
          ASSERT_EQ(check_overlap_hint(*x, *y, rel, h), want ? 1 : 0)
              << "check " << checked_ << " found hint " << int{h};
          ++hints_found_;
        }
      }
      EXPECT_EQ(find_overlap_hint(*x, *y, 1e-13, true), kOverlapHintNone);
      EXPECT_EQ(find_overlap_hint(*x, *y, 1e-13, false), kOverlapHintNone);
    }
  }

  /// B moved along d to the reference's overlap boundary (bisection), then checked at and
  /// around it: the pairs where a different rounding would flip the answer.
  void check_boundary(const TetCorners& a, const TetCorners& b, const Vector3d& d) {
    const auto moved = [&](double t) {
      TetCorners c = b;
      for (auto& p : c) p += t * d;
      return c;
    };
    const auto ref = [&](double t) {
      const TetCorners c = moved(t);
      return tets_overlap_reference(make_tet_geometry(a), make_tet_geometry(c),
                                    kTol * pair_scale(a, c));
    };
    double lo = 0.0, hi = 4.0;
    if (!ref(lo) || ref(hi)) return;
    for (int k = 0; k < 80; ++k) (ref(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
    double t = lo;
    for (int k = 0; k < 6; ++k, t = std::nextafter(t, 4.0)) check(a, moved(t));
  }
};

TEST_F(VectorisedOverlap, RandomPairsOfEveryKindAgreeBitForBit) {
  for (int iter = 0; iter < 6000; ++iter) {
    const int kind = iter % 8;
    TetCorners a = random_tet(rng_, kind == 6 ? 0.0 : 0.05);
    TetCorners b = random_tet(rng_, 0.05);
    const Vector3d shift = (1.2 * u_(rng_)) * random_unit();
    switch (kind) {
      case 0:  // anything from deep to far apart
        for (auto& p : b) p += shift;
        break;
      case 1:  // small tet in, across or near a large one (corner-deep accepts)
        for (auto& p : b) p = 0.1 * p + Vector3d(u_(rng_), u_(rng_), u_(rng_)) * 0.5;
        break;
      case 2:  // shared face: B's fourth corner on either side of the face
        b = {a[1], a[3], a[2], a[1] + (u_(rng_) - 0.5) * 2.0 * random_unit()};
        break;
      case 3:  // coplanar faces: B = A mirrored through its face 0, slid along it
        for (int i = 0; i < 4; ++i) {
          const Vector3d n = (a[2] - a[1]).cross(a[3] - a[1]).normalized();
          b[i] = a[i] - 2.0 * n.dot(a[i] - a[1]) * n + 0.3 * u_(rng_) * (a[2] - a[1]);
        }
        break;
      case 4:  // shared edge or corner
        b[0] = a[0];
        if (u_(rng_) < 0.5) b[1] = a[1];
        break;
      case 5:  // flat A (the reference's path), B nearby
        a[0] = (a[1] + a[2] + a[3]) / 3.0 + 0.2 * (a[1] - a[2]);
        for (auto& p : b) p += 0.3 * shift;
        break;
      case 6:  // sliver A (needle or wedge), B nearby
        a[0] = (a[1] + a[2] + a[3]) / 3.0 + std::pow(10.0, -3.0 - 9.0 * u_(rng_)) * random_unit();
        for (auto& p : b) p += 0.3 * shift;
        break;
      default:  // both on each other's overlap boundary along a random direction
        check_boundary(a, b, random_unit());
        continue;
    }
    check(a, b);
    if (kind < 3) check_boundary(a, b, random_unit());
  }
  EXPECT_GT(checked_, 10000);
  EXPECT_GT(overlapping_, 20000);
  EXPECT_GT(hints_found_, 40000);
  EXPECT_GT(hint_answers_, 100000);
  EXPECT_GT(grid_answers_, 100000);
  check_batch();
}

// ----------------------------------------------------------------------------- point-in-tet

TEST(PointInTet, BarycentricsReproduceThePointAndSumToOne) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int iter = 0; iter < 500; ++iter) {
    TetCorners t = random_tet(rng, 0.02);
    if (iter % 2) std::swap(t[1], t[2]);  // inverted tets work too
    Eigen::Vector4d w(u(rng), u(rng), u(rng), u(rng));
    w /= w.sum();
    const Vector3d p = w[0] * t[0] + w[1] * t[1] + w[2] * t[2] + w[3] * t[3];
    const PointInTet r = point_in_tet(p, t, kTol * tet_scale(t));
    ASSERT_TRUE(r.inside) << iter;
    EXPECT_NEAR(r.bary.sum(), 1.0, 1e-12);
    EXPECT_LT((r.bary - w).cwiseAbs().maxCoeff(), 1e-9) << iter;
  }
}

TEST(PointInTet, OutsidePointsAreOutside) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 2.0);
  int outside = 0;
  for (int iter = 0; iter < 2000; ++iter) {
    const TetCorners t = random_tet(rng, 0.02);
    const Vector3d p(u(rng), u(rng), u(rng));
    const double cl = clearance(p, t);
    const PointInTet r = point_in_tet(p, t, kTol * tet_scale(t));
    if (cl < -1e-9) {
      ++outside;
      EXPECT_FALSE(r.inside) << iter;
    } else if (cl > 1e-9) {
      EXPECT_TRUE(r.inside) << iter;
      EXPECT_GE(r.bary.minCoeff(), 0.0);
    }
  }
  EXPECT_GT(outside, 1000);
}

/// Dyadic scales and offsets (exact coordinates), so points exactly on faces stay exactly
/// on them even at a 2^20 offset with a 2^-20 scale.
const auto kDyadicFrames =
    ::testing::Combine(::testing::Values(0x1p-20, 1.0, 0x1p13), ::testing::Values(0.0, 0x1p20));

class PointOnBoundary : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(PointOnBoundary, CornersEdgesAndFacesAreInsideJustOutsideIsNot) {
  const auto [scale, offset] = GetParam();
  const Vector3d o(offset, 2 * offset, -offset);
  const TetCorners t = transform(unit_tet(), scale, o);
  const double tol = kTol * tet_scale(t);
  const std::vector<Vector3d> on = {Vector3d(0, 0, 0),         Vector3d(1, 0, 0),
                                    Vector3d(0.5, 0.5, 0),     Vector3d(0.25, 0.375, 0),
                                    Vector3d(0.25, 0.25, 0.5), Vector3d(0, 0.5, 0.5)};
  for (const Vector3d& q : on) {
    const PointInTet r = point_in_tet(q * scale + o, t, tol);
    EXPECT_TRUE(r.inside) << q.transpose();
    EXPECT_GE(r.bary.minCoeff(), -1e-6);
    EXPECT_NEAR(r.bary.sum(), 1.0, 1e-12);
  }
  // Just outside: 2^-20 of the size (2^-10 when that is below the coordinate rounding).
  const double e = (scale < 1e-3 && offset > 0.0) ? 0x1p-10 : 0x1p-20;
  const std::vector<Vector3d> out = {Vector3d(-e, 0.25, 0.25), Vector3d(0.25, 0.25, 0.5 + e),
                                     Vector3d(1 + e, 0, 0), Vector3d(0.25, 0.25, -e)};
  for (const Vector3d& q : out)
    EXPECT_FALSE(point_in_tet(q * scale + o, t, tol).inside) << q.transpose();
}

INSTANTIATE_TEST_SUITE_P(TetOverlap, PointOnBoundary, kDyadicFrames);

TEST(PointInTet, FlatTetsContainNothingAndNeverNaN) {
  const TetCorners flat = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0),
                           Vector3d(0.3, 0.3, 0)};
  const PointInTet r = point_in_tet(Vector3d(0.2, 0.2, 0), flat, 1e-9);
  EXPECT_FALSE(r.inside);
  EXPECT_FALSE(r.bary.hasNaN());
  const TetCorners point = {Vector3d(1, 1, 1), Vector3d(1, 1, 1), Vector3d(1, 1, 1),
                            Vector3d(1, 1, 1)};
  EXPECT_FALSE(point_in_tet(Vector3d(1, 1, 1), point, 0.0).inside);
  EXPECT_FALSE(point_in_tet(Vector3d(std::nan(""), 0, 0), unit_tet(), 1e-9).inside);
}

// --------------------------------------------------------------------------- clipping

TEST(ClipSegment, IntervalMatchesDenseSampling) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 1.3);
  int hits = 0;
  constexpr int kSamples = 2000;
  for (int iter = 0; iter < 1000; ++iter) {
    const TetCorners t = random_tet(rng, 0.05);
    const Vector3d p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng));
    const SegmentClip c = clip_segment_tet(p0, p1, t, kTol);
    // Oracle: samples whose clearance is clearly positive lie in [in, out]; the
    // extreme inside samples bracket the ends.
    double first = 2, last = -1;
    for (int s = 0; s <= kSamples; ++s) {
      const double l = double(s) / kSamples;
      if (clearance(p0 + l * (p1 - p0), t) > 1e-9) {
        first = std::min(first, l);
        last = std::max(last, l);
      }
    }
    if (last - first > 2.0 / kSamples) {
      ++hits;
      ASSERT_TRUE(c.hit) << iter;
      EXPECT_LE(c.lambda_in, first + 1e-12);
      EXPECT_GE(c.lambda_out, last - 1e-12);
      EXPECT_GE(c.lambda_in, first - 1.0 / kSamples - 1e-9);
      EXPECT_LE(c.lambda_out, last + 1.0 / kSamples + 1e-9);
    } else if (last < first) {
      // No sample inside: either a miss or a stretch shorter than the sample spacing.
      if (c.hit) {
        EXPECT_LT(c.lambda_out - c.lambda_in, 1.0 / kSamples + 1e-9);
      }
    }
    if (c.hit) {
      EXPECT_LE(0.0, c.lambda_in);
      EXPECT_LT(c.lambda_in, c.lambda_out);
      EXPECT_LE(c.lambda_out, 1.0);
    }
  }
  EXPECT_GT(hits, 100);
}

class ClipCases : public ::testing::TestWithParam<std::tuple<double, double>> {};

TEST_P(ClipCases, ThroughInsideInFaceTouchingAndOutside) {
  // Plain variables, not a structured binding: clang 14 cannot capture bindings in lambdas.
  const double scale = std::get<0>(GetParam());
  const double offset = std::get<1>(GetParam());
  const Vector3d o(-offset, offset, 3 * offset);
  const TetCorners t = transform(unit_tet(), scale, o);
  const auto clip = [&](const Vector3d& a, const Vector3d& b) {
    return clip_segment_tet(a * scale + o, b * scale + o, t,
                            kTol * std::max(tet_scale(t), (b - a).norm() * scale));
  };
  // Through: along x at y = z = 1/8, inside for x in [0, 3/4].
  SegmentClip c = clip(Vector3d(-1, 0.125, 0.125), Vector3d(1, 0.125, 0.125));
  ASSERT_TRUE(c.hit);
  EXPECT_NEAR(c.lambda_in, 0.5, 1e-9);
  EXPECT_NEAR(c.lambda_out, 0.875, 1e-9);
  // Fully inside.
  c = clip(Vector3d(0.125, 0.125, 0.125), Vector3d(0.25, 0.375, 0.125));
  ASSERT_TRUE(c.hit);
  EXPECT_EQ(c.lambda_in, 0.0);
  EXPECT_EQ(c.lambda_out, 1.0);
  // Lying in the face z = 0, crossing it.
  c = clip(Vector3d(-0.5, 0.25, 0), Vector3d(1.5, 0.25, 0));
  ASSERT_TRUE(c.hit);
  EXPECT_NEAR(c.lambda_in, 0.25, 1e-9);
  EXPECT_NEAR(c.lambda_out, 0.625, 1e-9);
  // Along an edge of the tet.
  c = clip(Vector3d(-1, 0, 0), Vector3d(2, 0, 0));
  ASSERT_TRUE(c.hit);
  EXPECT_NEAR(c.lambda_in, 1.0 / 3, 1e-9);
  EXPECT_NEAR(c.lambda_out, 2.0 / 3, 1e-9);
  // Touching a corner only, and passing just outside a face.
  EXPECT_FALSE(clip(Vector3d(-1, 1, 1), Vector3d(1, -1, -1)).hit);
  const double e = (scale < 1e-3 && offset > 0.0) ? 0x1p-10 : 0x1p-20;
  EXPECT_FALSE(clip(Vector3d(-1, 0.25, -e), Vector3d(1, 0.25, -e)).hit);
  // Outside entirely, and zero length.
  EXPECT_FALSE(clip(Vector3d(2, 2, 2), Vector3d(3, 2, 2)).hit);
  EXPECT_FALSE(clip(Vector3d(0.125, 0.125, 0.125), Vector3d(0.125, 0.125, 0.125)).hit);
}

INSTANTIATE_TEST_SUITE_P(TetOverlap, ClipCases, kDyadicFrames);

// With each copy of the kernel (AVX2, baseline).
class ClipSegmentCopies : public test::BothKernels {};

TEST_P(ClipSegmentCopies, VectorisedAgreesWithReferenceBitForBit) {
  // Segments through, into, along faces and edges of, and near random tets (corners,
  // points on faces, mirrored copies), under 1e6 offsets and 1e-6 scales, 3 tolerances.
  std::mt19937 rng(8128);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int hits = 0, checked = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    TetCorners t = random_tet(rng, iter % 5 == 0 ? 0.0 : 0.05);
    const auto on_tet = [&](int kind) -> Vector3d {
      const int i = static_cast<int>(4 * u(rng)) % 4, j = (i + 1 + iter % 3) % 4;
      switch (kind) {
        case 0:
          return t[i];  // a corner
        case 1:
          return t[i] + u(rng) * (t[j] - t[i]);  // on an edge
        case 2: {                                // on a face
          const double a = u(rng), b = u(rng) * (1.0 - a);
          return t[i] + a * (t[j] - t[i]) +
                 b * (t[(j + 1) % 4 == i ? (j + 2) % 4 : (j + 1) % 4] - t[i]);
        }
        default:  // anywhere around
          return Vector3d(u(rng), u(rng), u(rng)) * 1.4 - Vector3d::Constant(0.2);
      }
    };
    const Vector3d p0 = on_tet(iter % 4), p1 = on_tet((iter / 4) % 4);
    for (const auto& [scale, offset] :
         {std::pair{1.0, 0.0}, std::pair{1e-6, 0.0}, std::pair{1.0, 1e6}, std::pair{1e-6, 1e6}}) {
      const Vector3d o(offset, 0.5 * offset, -offset);
      const TetGeometry g = make_tet_geometry(transform(t, scale, o));
      const Vector3d q0 = p0 * scale + o, q1 = p1 * scale + o;
      // The batched form over the same tet at the three tolerances, and the mirrored
      // tet (another geometry in the same batch), must give each single call's bits.
      const TetGeometry gm = make_tet_geometry(transform({t[1], t[0], t[2], t[3]}, scale, o));
      std::vector<ClipTarget> targets;
      std::vector<SegmentClip> wants;
      for (const double tol : {0.0, kTol * scale, 1e-3 * scale}) {
        const SegmentClip want = clip_segment_tet_reference(q0, q1, g, tol);
        const SegmentClip got = clip_segment_tet(q0, q1, g, tol);
        ASSERT_EQ(got.hit, want.hit) << "iteration " << iter << " scale " << scale;
        ASSERT_EQ(std::bit_cast<std::uint64_t>(got.lambda_in),
                  std::bit_cast<std::uint64_t>(want.lambda_in))
            << "iteration " << iter;
        ASSERT_EQ(std::bit_cast<std::uint64_t>(got.lambda_out),
                  std::bit_cast<std::uint64_t>(want.lambda_out))
            << "iteration " << iter;
        hits += want.hit ? 1 : 0;
        ++checked;
        targets.push_back({&g, tol});
        wants.push_back(want);
        targets.push_back({&gm, tol});
        wants.push_back(clip_segment_tet_reference(q0, q1, gm, tol));
      }
      std::vector<SegmentClip> batch(targets.size() + 1);  // longer than needed: allowed
      clip_segment_tets(q0, q1, targets, batch);
      for (std::size_t k = 0; k < targets.size(); ++k) {
        ASSERT_EQ(batch[k].hit, wants[k].hit) << "iteration " << iter << " target " << k;
        ASSERT_EQ(std::bit_cast<std::uint64_t>(batch[k].lambda_in),
                  std::bit_cast<std::uint64_t>(wants[k].lambda_in))
            << "iteration " << iter << " target " << k;
        ASSERT_EQ(std::bit_cast<std::uint64_t>(batch[k].lambda_out),
                  std::bit_cast<std::uint64_t>(wants[k].lambda_out))
            << "iteration " << iter << " target " << k;
      }
    }
  }
  EXPECT_GT(hits, 50000);
  EXPECT_EQ(checked, 240000);
}

INSTANTIATE_TEST_SUITE_P(Kernels, ClipSegmentCopies, ::testing::Bool(), test::kernel_copy_name);

TEST(ClipSegment, FlatTetsAndNaNNeverHit) {
  const TetCorners flat = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(0, 1, 0),
                           Vector3d(0.3, 0.3, 0)};
  EXPECT_FALSE(clip_segment_tet(Vector3d(0.1, 0.1, -1), Vector3d(0.1, 0.1, 1), flat, 1e-9).hit);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(clip_segment_tet(Vector3d(nan, 0, 0), Vector3d(1, 0, 0), unit_tet(), 1e-9).hit);
}

}  // namespace
}  // namespace tc
