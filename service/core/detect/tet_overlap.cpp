#include "core/detect/tet_overlap.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

#include "core/common/cpu_dispatch.hpp"
#include "core/common/target_clones.hpp"
#include "core/detect/exact_vec3.hpp"
#include "core/detect/lanes.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kInf = std::numeric_limits<double>::infinity();
/// 6|V| <= kFlat * L^3: the tet is flat up to rounding.
constexpr double kFlat = 32.0 * kEps;
/// Two edges with sin(angle) at most this are treated as parallel: their cross product
/// is still tested, and so is the offset direction between their lines.
constexpr double kParallelSin = 1e-12;

/// The two faces adjacent to each edge (kTetEdges order): the faces opposite the two
/// corners the edge does not use.
constexpr int kEdgeFaces[6][2] = {{2, 3}, {1, 3}, {1, 2}, {0, 3}, {0, 2}, {0, 1}};
/// Gauss-map arc tests closer to zero than this count as "may intersect".
constexpr double kArcEps = 1e-9;

/// True when the Gauss-map arcs of an edge of A and an edge of -B certainly do not
/// cross, i.e. the edge pair spans no face of the Minkowski difference A - B, so its
/// cross product cannot be the separating (or the penetration-depth) axis. s1, s2: the
/// normals of -B's edge against A's arc plane; s3, s4: A's normals against -B's.
inline bool arcs_disjoint(double s1, double s2, double s3, double s4) {
  const auto clear = [](double u, double v) {
    return std::abs(u) > kArcEps && std::abs(v) > kArcEps;
  };
  return (s1 * s2 > 0.0 && clear(s1, s2)) || (s3 * s4 > 0.0 && clear(s3, s4)) ||
         (s1 * s4 < 0.0 && clear(s1, s4));
}

using detail::any_perpendicular;
using detail::cross3;
using detail::dot3;

/// The extent of 4 points (an array of Vector3d, C or std::) along n.
template <typename Corners>
inline void project(const Corners& v, const Vector3d& n, double& lo, double& hi) {
  const double p0 = dot3(n, v[0]), p1 = dot3(n, v[1]), p2 = dot3(n, v[2]), p3 = dot3(n, v[3]);
  lo = std::min(std::min(p0, p1), std::min(p2, p3));
  hi = std::max(std::max(p0, p1), std::max(p2, p3));
}

/// Walks the separating-axis candidates of two tets, in coordinates relative to the
/// first corner of A. In early-exit mode it answers "overlap by more than tol?" and
/// stops at the first separating axis (or at a corner deeper than tol inside the other
/// tet); otherwise it returns the minimum penetration over all axes.
template <bool kEarly>
class Sat {
 public:
  Sat(const TetGeometry& a, const TetGeometry& b, double tol) : ga_(a), gb_(b), tol_(tol) {
    const Vector3d o = a.v[0];
    for (int i = 0; i < 4; ++i) {
      a_[i] = a.v[i] - o;
      b_[i] = b.v[i] - o;
    }
  }

  /// kEarly: true when the tets overlap by more than tol. Else: see best().
  bool run() {
    // Coordinate axes (the boxes) first: cheapest.
    for (int d = 0; d < 3; ++d)
      if (record(std::min(ga_.hi[d] - gb_.lo[d], gb_.hi[d] - ga_.lo[d]), 1.0)) return false;
    // Face normals of the larger tet first: they separate most pairs.
    const bool b_first = gb_.scale > ga_.scale;
    if (b_first ? faces(gb_, b_, a_) : faces(ga_, a_, b_)) return kEarly ? accepted_ : false;
    if (b_first ? faces(ga_, a_, b_) : faces(gb_, b_, a_)) return kEarly ? accepted_ : false;
    if (!ga_.flat && !gb_.flat) {
      // Only edge pairs whose Gauss-map arcs cross span faces of the Minkowski
      // difference; the other cross products can neither separate the tets when these
      // do not, nor give a smaller penetration (Gregorius, GDC 2013).
      double da[4][6], db[4][6];  // da[f][j] = unit normal f of A . arc j of B
      for (int f = 0; f < 4; ++f) {
        const Vector3d ua = ga_.normal(f) * ga_.n_inv[f];
        const Vector3d ub = gb_.normal(f) * gb_.n_inv[f];
        for (int k = 0; k < 6; ++k) {
          da[f][k] = dot3(ua, gb_.arc(k));
          db[f][k] = dot3(ub, ga_.arc(k));
        }
      }
      for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
          const double s1 = -db[kEdgeFaces[j][0]][i], s2 = -db[kEdgeFaces[j][1]][i];
          const double s3 = da[kEdgeFaces[i][0]][j], s4 = da[kEdgeFaces[i][1]][j];
          if (arcs_disjoint(s1, s2, s3, s4)) continue;
          if (axis(cross3(ga_.edge(i), gb_.edge(j)))) return false;
        }
      return true;
    }
    // A flat tet has no proper Gauss map: every edge pair, with fallbacks for parallel
    // and zero-length edges, and the centroid direction (the only axis left when both
    // tets collapse to points).
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        if (edge_pair(i, j)) return false;
    const Vector3d d = (b_[0] + b_[1] + b_[2] + b_[3]) - (a_[0] + a_[1] + a_[2] + a_[3]);
    return !axis(d);
  }

  [[nodiscard]] double best() const { return best_; }

 private:
  /// Records the penetration `pen` along an axis of length `len`; true to stop.
  bool record(double pen, double len) {
    if constexpr (kEarly) {
      return !(pen > tol_ * len);
    } else {
      best_ = std::min(best_, pen / len);
      return false;
    }
  }

  bool axis(const Vector3d& n) {
    const double nn = dot3(n, n);
    if (!(nn > 0.0) || !std::isfinite(nn)) return false;
    double alo, ahi, blo, bhi;
    project(a_, n, alo, ahi);
    project(b_, n, blo, bhi);
    return record(std::min(ahi - blo, bhi - alo), std::sqrt(nn));
  }

  /// Face normals of tet `g` (local corners `f`) against the local corners `o` of the
  /// other tet. Returns true to stop: separated, or (kEarly) a corner of the other tet
  /// lies deeper than tol inside `g` (then accepted_ is set).
  bool faces(const TetGeometry& g, const Vector3d (&f)[4], const Vector3d (&o)[4]) {
    bool deep[4] = {!g.flat, !g.flat, !g.flat, !g.flat};
    for (int k = 0; k < 4; ++k) {
      const Vector3d n = g.normal(k);
      const double len = g.n_len[k];
      if (!(len > 0.0) || !std::isfinite(len)) {
        deep[0] = deep[1] = deep[2] = deep[3] = false;
        continue;
      }
      const double c = dot3(n, f[kTetFaces[k][0]]);
      const double opp = dot3(n, f[k]);
      const double p0 = dot3(n, o[0]), p1 = dot3(n, o[1]), p2 = dot3(n, o[2]), p3 = dot3(n, o[3]);
      const double olo = std::min(std::min(p0, p1), std::min(p2, p3));
      const double ohi = std::max(std::max(p0, p1), std::max(p2, p3));
      if (record(std::min(std::max(c, opp) - olo, ohi - std::min(c, opp)), len)) return true;
      if constexpr (kEarly) {
        const double depth = c - tol_ * len;  // outward normal: inside means below c
        deep[0] = deep[0] && p0 < depth;
        deep[1] = deep[1] && p1 < depth;
        deep[2] = deep[2] && p2 < depth;
        deep[3] = deep[3] && p3 < depth;
      }
    }
    if constexpr (kEarly) {
      if (deep[0] || deep[1] || deep[2] || deep[3]) {
        accepted_ = true;
        return true;
      }
    }
    return false;
  }

  bool edge_pair(int i, int j) {
    const Vector3d ea = ga_.edge(i);
    const Vector3d eb = gb_.edge(j);
    const Vector3d n = ea.cross(eb);
    if (axis(n)) return true;
    const double ea2 = ea.squaredNorm(), eb2 = eb.squaredNorm();
    const double limit = kParallelSin * kParallelSin * ea2 * eb2;
    if (n.squaredNorm() > limit) return false;
    // Parallel (or zero-length) edges: the direction from one line to the other,
    // perpendicular to the longer edge.
    const Vector3d d = b_[kTetEdges[j][0]] - a_[kTetEdges[i][0]];
    const bool a_longer = ea2 >= eb2;
    const Vector3d& e = a_longer ? ea : eb;
    const double e2 = a_longer ? ea2 : eb2;
    if (!(e2 > 0.0)) return axis(d);
    const Vector3d perp = d - (d.dot(e) / e2) * e;
    if (perp.squaredNorm() > kEps * kEps * d.squaredNorm() && axis(perp)) return true;
    return axis(any_perpendicular(e));
  }

  const TetGeometry& ga_;
  const TetGeometry& gb_;
  Vector3d a_[4], b_[4];
  double tol_;
  double best_ = kInf;
  bool accepted_ = false;
};

// clip_segment_tet(): the 4 faces as lanes, each with the reference's operations (dot3 of n with p
// - f, times 1/|n|, the tol snap). Why the result is the reference's bit for bit: (1) it returns
// "no hit" as soon as one face has both ends outside, so any face order gives the same "no hit";
// (2) lambda_in is the max of 0 and the entering ratios d0 / (d0 - d1) > 0 (NaN ignored, as
// std::max(lambda_in, NaN) does), a maximum of positive values, the same in any order; (3)
// lambda_out is the min of 1 and the leaving ratios, which are positive or zero; the order can only
// change the sign of a zero result, and a zero lambda_out is never a hit (it needs lambda_out >
// lambda_in >= 0), so the returned values are the same.
// `length` is (p1 - p0).norm(), computed by the caller (once for many tets).
TC_INLINE SegmentClip clip_lanes(const Vector3d& p0, const Vector3d& p1, double length,
                                 const TetGeometry& t, double tolerance) {
  SegmentClip out;
  const double tol = std::max(tolerance, 0.0);
  if (!(length > tol) || !std::isfinite(length) || t.flat) return out;
  // Face k's plane passes through corner kTetFaces[k][0] = 1, 0, 0, 0.
  const Vector3d& f0 = t.v[0];
  const Vector3d& f1 = t.v[1];
  const V4 fx{f1.x(), f0.x(), f0.x(), f0.x()}, fy{f1.y(), f0.y(), f0.y(), f0.y()},
      fz{f1.z(), f0.z(), f0.z(), f0.z()};
  const V4 nx = load4(t.nx.data()), ny = load4(t.ny.data()), nz = load4(t.nz.data());
  const V4 inv = load4(t.n_inv.data());
  const V4 zero = splat(0.0), lo = splat(-tol), hi = splat(tol);
  V4 d0 = vdot(nx, ny, nz, splat(p0.x()) - fx, splat(p0.y()) - fy, splat(p0.z()) - fz) * inv;
  V4 d1 = vdot(nx, ny, nz, splat(p1.x()) - fx, splat(p1.y()) - fy, splat(p1.z()) - fz) * inv;
  const M4 on0 = (d0 >= lo) & (d0 <= hi), on1 = (d1 >= lo) & (d1 <= hi);
  d0 = on0 ? zero : d0;  // |d| <= tol counts as on the plane
  d1 = on1 ? zero : d1;
  if (lanes((d0 <= zero) | (d1 <= zero)) != 15) return out;  // both ends outside a face
  const V4 ratio = d0 / (d0 - d1);
  const M4 entering = (d0 > zero) & (ratio == ratio);
  const M4 leaving = ~(d0 > zero) & (d1 > zero) & (ratio == ratio);
  const V4 in = entering ? ratio : zero, out4 = leaving ? ratio : splat(1.0);
  const double lambda_in = std::max(std::max(in[0], in[1]), std::max(in[2], in[3]));
  const double lambda_out = std::min(std::min(out4[0], out4[1]), std::min(out4[2], out4[3]));
  if (!((lambda_out - lambda_in) * length > tol)) return out;
  out.hit = true;
  out.lambda_in = lambda_in;
  out.lambda_out = lambda_out;
  return out;
}

/// Lane j of r[0..3] becomes row j: out[j] = (r[0][j], r[1][j], r[2][j], r[3][j]).
TC_INLINE void transpose4(const V4 (&r)[4], V4 (&out)[4]) {
  const V4 t0 = __builtin_shufflevector(r[0], r[1], 0, 4, 2, 6);
  const V4 t1 = __builtin_shufflevector(r[0], r[1], 1, 5, 3, 7);
  const V4 t2 = __builtin_shufflevector(r[2], r[3], 0, 4, 2, 6);
  const V4 t3 = __builtin_shufflevector(r[2], r[3], 1, 5, 3, 7);
  out[0] = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
  out[1] = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
  out[2] = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
  out[3] = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
}

/// Writes field values r[k] (lane j = tet j) as entries k = 0..3 of each tet's array.
template <typename Field>
TC_INLINE void store_rows(const V4 (&r)[4], const std::array<TetGeometry*, 4>& g, Field field) {
  V4 rows[4];
  transpose4(r, rows);
#pragma GCC unroll 8
  for (int j = 0; j < 4; ++j) std::memcpy((g[j]->*field).data(), &rows[j], sizeof(V4));
}

/// The same for the 6 entries of an edge array: r[0..5]; entries 6 and 7 (when the array
/// has them) get 0.
template <typename Field>
TC_INLINE void store_rows6(const V4 (&r)[6], const std::array<TetGeometry*, 4>& g, Field field) {
  V4 rows[4], tail[4];
  transpose4({r[0], r[1], r[2], r[3]}, rows);
  transpose4({r[4], r[5], splat(0.0), splat(0.0)}, tail);
#pragma GCC unroll 8
  for (int j = 0; j < 4; ++j) {
    auto& a = g[j]->*field;
    std::memcpy(a.data(), &rows[j], sizeof(V4));
    std::memcpy(a.data() + 4, &tail[j], (a.size() - 4) * sizeof(double));
  }
}

/// cross3 lane by lane: (a.y b.z - a.z b.y, a.z b.x - a.x b.z, a.x b.y - a.y b.x).
TC_INLINE void vcross(V4 ax, V4 ay, V4 az, V4 bx, V4 by, V4 bz, V4& cx, V4& cy, V4& cz) {
  cx = ay * bz - az * by;
  cy = az * bx - ax * bz;
  cz = ax * by - ay * bx;
}

namespace baseline {
#define TC_FAST_SAT_AVX2 0
#include "core/detect/fast_sat.inc"
#undef TC_FAST_SAT_AVX2
}  // namespace baseline

}  // namespace

#if TC_HAS_AVX2_REGION
TC_AVX2_REGION_BEGIN
namespace {
namespace avx2 {
#define TC_FAST_SAT_AVX2 1
#include "core/detect/fast_sat.inc"
#undef TC_FAST_SAT_AVX2
}  // namespace avx2
}  // namespace
TC_AVX2_REGION_END
#endif

namespace {

/// FastSat(a, b, tolerance).run() of the copy this CPU runs.
bool overlap_fast(const TetGeometry& a, const TetGeometry& b, double tolerance) {
#if TC_HAS_AVX2_REGION
  if (use_avx2_kernels()) return avx2::overlap(a, b, tolerance);
#endif
  return baseline::overlap(a, b, tolerance);
}
}  // namespace

TetGeometry make_tet_geometry(const TetCorners& t) {
  TetGeometry g;
  make_tet_geometry(t, g);
  return g;
}

namespace {

// make_tet_geometry() of 4 tets, one per lane, each lane with the scalar function's
// operations in its order (Eigen's 3-vector dot and squared norm are (x X + y Y) + z Z,
// its cross product is cross3's, cwiseMin/Max are std::min/max, a vector times a scalar
// is per coordinate), so every field has the scalar function's bits; the unit tests
// compare the two field by field.
// (Kept apart from the multiversioned entry point: a call that passes a 4-double vector
// from that function's baseline copy is an ABI error for clang.)
TC_INLINE void geometry_lanes(const std::array<TetCorners, 4>& t,
                              const std::array<TetGeometry*, 4>& out) {
  // Each group of fields is computed and written before the next one starts, so that few
  // vectors are live at once (the whole tet in registers would spill most of them).
  V4 X[4], Y[4], Z[4];  // corner i by coordinate, lane j = tet j
#pragma GCC unroll 8
  for (int i = 0; i < 4; ++i) {
    X[i] = V4{t[0][i].x(), t[1][i].x(), t[2][i].x(), t[3][i].x()};
    Y[i] = V4{t[0][i].y(), t[1][i].y(), t[2][i].y(), t[3][i].y()};
    Z[i] = V4{t[0][i].z(), t[1][i].z(), t[2][i].z(), t[3][i].z()};
  }
  const V4 zero = splat(0.0);
  V4 scale;
  M4 finite;
  {
    V4 lox = X[0], loy = Y[0], loz = Z[0], hix = X[0], hiy = Y[0], hiz = Z[0];
    finite = (X[0] - X[0] == zero) & (Y[0] - Y[0] == zero) & (Z[0] - Z[0] == zero);
#pragma GCC unroll 8
    for (int i = 1; i < 4; ++i) {
      lox = vmin(lox, X[i]), loy = vmin(loy, Y[i]), loz = vmin(loz, Z[i]);
      hix = vmax(hix, X[i]), hiy = vmax(hiy, Y[i]), hiz = vmax(hiz, Z[i]);
      finite &= (X[i] - X[i] == zero) & (Y[i] - Y[i] == zero) & (Z[i] - Z[i] == zero);
    }
    // (hi - lo).maxCoeff(): extents of finite corners are >= +0 and not NaN, so any order
    // of the maxima gives the same value (other tets are overwritten at the end).
    scale = vmax(vmax(hix - lox, hiy - loy), hiz - loz);
#pragma GCC unroll 8
    for (int j = 0; j < 4; ++j) {
      out[j]->lo = Vector3d(lox[j], loy[j], loz[j]);
      out[j]->hi = Vector3d(hix[j], hiy[j], hiz[j]);
      out[j]->scale = scale[j];
      out[j]->v = t[j];
    }
  }
  // Edges (kTetEdges order), then 6V and the orientation from the first three.
  M4 flat;
  V4 sign;
  {
    V4 e[6];
#pragma GCC unroll 8
    for (int k = 0; k < 6; ++k) e[k] = X[kTetEdges[k][1]] - X[kTetEdges[k][0]];
    store_rows6(e, out, &TetGeometry::ex);
#pragma GCC unroll 8
    for (int k = 0; k < 6; ++k) e[k] = Y[kTetEdges[k][1]] - Y[kTetEdges[k][0]];
    store_rows6(e, out, &TetGeometry::ey);
#pragma GCC unroll 8
    for (int k = 0; k < 6; ++k) e[k] = Z[kTetEdges[k][1]] - Z[kTetEdges[k][0]];
    store_rows6(e, out, &TetGeometry::ez);
    // kTetEdges[0..2] = (0,1), (0,2), (0,3).
    V4 cx, cy, cz;
    vcross(X[2] - X[0], Y[2] - Y[0], Z[2] - Z[0], X[3] - X[0], Y[3] - Y[0], Z[3] - Z[0], cx, cy,
           cz);
    const V4 det = vdot(X[1] - X[0], Y[1] - Y[0], Z[1] - Z[0], cx, cy, cz);
    const V4 abs_det = det < zero ? -det : det;
    flat = ~(abs_det > splat(kFlat) * scale * scale * scale);
    sign = det < zero ? splat(-1.0) : splat(1.0);
  }
  // Corners relative to the first.
  V4 lx[4], ly[4], lz[4];
#pragma GCC unroll 8
  for (int i = 0; i < 4; ++i) lx[i] = X[i] - X[0], ly[i] = Y[i] - Y[0], lz[i] = Z[i] - Z[0];
  store_rows(lx, out, &TetGeometry::lx);
  store_rows(ly, out, &TetGeometry::ly);
  store_rows(lz, out, &TetGeometry::lz);
  // Face normals, their lengths and inverses; the planes and apexes they give.
  V4 nx[4], ny[4], nz[4], inv[4];
  {
    V4 len[4], plane[4], apex[4];
#pragma GCC unroll 8
    for (int k = 0; k < 4; ++k) {
      const auto& f = kTetFaces[k];
      V4 cx, cy, cz;
      vcross(X[f[1]] - X[f[0]], Y[f[1]] - Y[f[0]], Z[f[1]] - Z[f[0]], X[f[2]] - X[f[0]],
             Y[f[2]] - Y[f[0]], Z[f[2]] - Z[f[0]], cx, cy, cz);
      nx[k] = sign * cx, ny[k] = sign * cy, nz[k] = sign * cz;
      const V4 squared = vdot(nx[k], ny[k], nz[k], nx[k], ny[k], nz[k]);
#pragma GCC unroll 8
      for (int j = 0; j < 4; ++j) len[k][j] = std::sqrt(squared[j]);
      const M4 positive = len[k] > zero;
      inv[k] = positive ? splat(1.0) / len[k] : zero;
      flat |= ~positive | ~(len[k] < splat(kInf));  // !(|n| > 0) || !isfinite(|n|)
      const int c = f[0];
      plane[k] = vdot(nx[k], ny[k], nz[k], lx[c], ly[c], lz[c]);
      apex[k] = vdot(nx[k], ny[k], nz[k], lx[k], ly[k], lz[k]);
    }
    store_rows(len, out, &TetGeometry::n_len);
    store_rows(nx, out, &TetGeometry::nx);
    store_rows(ny, out, &TetGeometry::ny);
    store_rows(nz, out, &TetGeometry::nz);
    store_rows(inv, out, &TetGeometry::n_inv);
    store_rows(plane, out, &TetGeometry::plane);
    store_rows(apex, out, &TetGeometry::apex);
  }
  // Gauss-map arcs: (unit normal p) x (unit normal q) for the faces beside each edge.
  {
    V4 ux[4], uy[4], uz[4];
#pragma GCC unroll 8
    for (int k = 0; k < 4; ++k)
      ux[k] = nx[k] * inv[k], uy[k] = ny[k] * inv[k], uz[k] = nz[k] * inv[k];
    // One coordinate of cross3(u_p, u_q) for the 6 edges: s_p w_q - w_p s_q with (s, w) =
    // (y, z), (z, x), (x, y).
    const auto arc_coordinate = [&](const V4(&s)[4], const V4(&w)[4], auto field) {
      V4 a[6];
#pragma GCC unroll 8
      for (int k = 0; k < 6; ++k) {
        const int p = kEdgeFaces[k][0], q = kEdgeFaces[k][1];
        a[k] = s[p] * w[q] - w[p] * s[q];
      }
      store_rows6(a, out, field);
    };
    arc_coordinate(uy, uz, &TetGeometry::ax);
    arc_coordinate(uz, ux, &TetGeometry::ay);
    arc_coordinate(ux, uy, &TetGeometry::az);
  }
#pragma GCC unroll 8
  for (int j = 0; j < 4; ++j) {
    TetGeometry& g = *out[j];
    g.flat = flat[j] != 0;
    if (finite[j] == 0) {  // as make_tet_geometry(): an empty box, separated from all
      g.lo.setConstant(kInf);
      g.hi.setConstant(-kInf);
      g.scale = 0.0;
      g.flat = true;
    }
  }
}

}  // namespace

namespace {
/// geometry_lanes() built for AVX2.
TC_AVX2_TARGET void geometry_avx2(const std::array<TetCorners, 4>& t,
                                  const std::array<TetGeometry*, 4>& out) {
  geometry_lanes(t, out);
}
}  // namespace

void make_tet_geometry4(const std::array<TetCorners, 4>& t,
                        const std::array<TetGeometry*, 4>& out) {
  if (use_avx2_kernels()) return geometry_avx2(t, out);
  geometry_lanes(t, out);
}

void make_tet_geometry(const TetCorners& t, TetGeometry& g) {
  g.v = t;
  g.lo = g.hi = t[0];
  for (int i = 1; i < 4; ++i) {
    g.lo = g.lo.cwiseMin(t[i]);
    g.hi = g.hi.cwiseMax(t[i]);
  }
  g.scale = (g.hi - g.lo).maxCoeff();
  std::array<Vector3d, 6> e;
  for (int k = 0; k < 6; ++k) {
    e[k] = t[kTetEdges[k][1]] - t[kTetEdges[k][0]];
    g.ex[k] = e[k].x(), g.ey[k] = e[k].y(), g.ez[k] = e[k].z();
  }
  // kTetEdges[0..2] = (0,1), (0,2), (0,3).
  const double det = e[0].dot(e[1].cross(e[2]));
  g.flat = !(std::abs(det) > kFlat * g.scale * g.scale * g.scale);
  const double sign = det < 0.0 ? -1.0 : 1.0;
  std::array<Vector3d, 4> n;
  for (int k = 0; k < 4; ++k) {
    const auto& f = kTetFaces[k];
    n[k] = sign * (t[f[1]] - t[f[0]]).cross(t[f[2]] - t[f[0]]);
    g.n_len[k] = n[k].norm();
    g.n_inv[k] = g.n_len[k] > 0.0 ? 1.0 / g.n_len[k] : 0.0;
    if (!(g.n_len[k] > 0.0) || !std::isfinite(g.n_len[k])) g.flat = true;
  }
  for (int k = 0; k < 6; ++k) {
    const int p = kEdgeFaces[k][0], q = kEdgeFaces[k][1];
    const Vector3d arc = (n[p] * g.n_inv[p]).cross(n[q] * g.n_inv[q]);
    g.ax[k] = arc.x(), g.ay[k] = arc.y(), g.az[k] = arc.z();
  }
  g.ax[6] = g.ax[7] = g.ay[6] = g.ay[7] = g.az[6] = g.az[7] = 0.0;
  // By coordinate, with the expressions Sat uses (a_[i] = v[i] - v[0], dot3), so the
  // vectorised test sees the same bits.
  TetCorners local;
  for (int i = 0; i < 4; ++i) local[i] = t[i] - t[0];
  for (int k = 0; k < 4; ++k) {
    g.nx[k] = n[k].x(), g.ny[k] = n[k].y(), g.nz[k] = n[k].z();
    g.lx[k] = local[k].x(), g.ly[k] = local[k].y(), g.lz[k] = local[k].z();
    g.plane[k] = dot3(n[k], local[kTetFaces[k][0]]);
    g.apex[k] = dot3(n[k], local[k]);
  }
  if (!(t[0].allFinite() && t[1].allFinite() && t[2].allFinite() && t[3].allFinite())) {
    // An empty box: separated from everything on the first axis.
    g.lo.setConstant(kInf);
    g.hi.setConstant(-kInf);
    g.scale = 0.0;
    g.flat = true;
  }
}

double tet_scale(const TetCorners& t) {
  Vector3d lo = t[0], hi = t[0];
  for (int i = 1; i < 4; ++i) {
    lo = lo.cwiseMin(t[i]);
    hi = hi.cwiseMax(t[i]);
  }
  return (hi - lo).maxCoeff();
}

double pair_scale(const TetCorners& a, const TetCorners& b) {
  Vector3d lo = a[0], hi = a[0];
  for (int i = 0; i < 4; ++i) {
    lo = lo.cwiseMin(a[i]).cwiseMin(b[i]);
    hi = hi.cwiseMax(a[i]).cwiseMax(b[i]);
  }
  return (hi - lo).maxCoeff();
}

double sat_penetration(const TetCorners& a, const TetCorners& b) {
  const TetGeometry ga = make_tet_geometry(a), gb = make_tet_geometry(b);
  Sat<false> sat(ga, gb, 0.0);
  sat.run();
  return sat.best();
}

bool tets_overlap_reference(const TetGeometry& a, const TetGeometry& b, double tolerance) {
  Sat<true> sat(a, b, std::max(tolerance, 0.0));
  return sat.run();
}

namespace {

// Overlap hints (check_overlap_hint(), find_overlap_hint()). Every figure is in coordinates
// relative to the first tet's first corner, as Sat's.
/// The margins of the hints are the tolerance: below this fraction of the pair's scale (the
/// relative tolerance) it would no longer dwarf rounding (detection's is 10^-9).
constexpr double kHintMinRelativeTolerance = 1e-12;
/// Points of a tet other than its corners, as barycentric weights in quarters: the points
/// of the grid of step 1/4 over the tet (edge, face and inner points), the overlap
/// certificates of pairs where no corner of either tet lies deep in the other.
constexpr std::array<std::array<int, 4>, 31> kGridPoints = [] {
  std::array<std::array<int, 4>, 31> points{};
  std::size_t n = 0;
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; i + j <= 4; ++j)
      for (int k = 0; i + j + k <= 4; ++k) {
        const int l = 4 - i - j - k;
        if (i == 4 || j == 4 || k == 4 || l == 4) continue;  // a corner
        points[n++] = {i, j, k, l};
      }
  return points;
}();
constexpr int kGridCount = static_cast<int>(kGridPoints.size());
constexpr int kHintFaceA = 1, kHintFaceB = 5, kHintEdge = 9, kHintDeepB = 45, kHintDeepA = 49,
              kHintGridB = 53, kHintGridA = kHintGridB + kGridCount,
              kHintEnd = kHintGridA + kGridCount;
static_assert(kHintEnd < 255, "hint codes fit a byte below kOverlapHintNone");

/// True when face k of tet g (whose corners span [min(plane, apex), max(plane, apex)] along
/// its normal, relative to its first corner) and the points q (relative to the same corner)
/// lie more than `tolerance` apart along that normal.
bool face_apart(const TetGeometry& g, int k, const std::array<Vector3d, 4>& q, double tolerance) {
  const auto f = static_cast<std::size_t>(k);
  double lo, hi;
  project(q, g.normal(k), lo, hi);
  const double c = g.plane[f], opp = g.apex[f];
  return std::min(std::max(c, opp) - lo, hi - std::min(c, opp)) < -tolerance * g.n_len[f];
}

/// True when the corners pa and pb of two tets (relative to one origin) lie more than
/// `tolerance` apart along axis n.
bool apart_along(const Vector3d& n, const std::array<Vector3d, 4>& pa,
                 const std::array<Vector3d, 4>& pb, double tolerance) {
  const double nn = dot3(n, n);
  if (!(nn > 0.0) || !std::isfinite(nn)) return false;
  double alo, ahi, blo, bhi;
  project(pa, n, alo, ahi);
  project(pb, n, blo, bhi);
  return std::min(ahi - blo, bhi - alo) < -tolerance * std::sqrt(nn);
}

/// True when point q (relative to g's first corner) lies deeper than `depth` inside tet g
/// (outward normals: below every face plane by more than depth |n|).
bool deep_inside(const TetGeometry& g, const Vector3d& q, double depth) {
  bool deep = true;
  for (int k = 0; k < 4; ++k) {
    const auto f = static_cast<std::size_t>(k);
    deep = deep && dot3(g.normal(k), q) < g.plane[f] - depth * g.n_len[f];
  }
  return deep;
}

/// The corners of `g` relative to `origin`.
std::array<Vector3d, 4> corners_from(const TetGeometry& g, const Vector3d& origin) {
  return {g.v[0] - origin, g.v[1] - origin, g.v[2] - origin, g.v[3] - origin};
}

/// Grid point g (kGridPoints) of the tet with corners c.
Vector3d grid_point(const std::array<Vector3d, 4>& c, int g) {
  const auto& w = kGridPoints[static_cast<std::size_t>(g)];
  return 0.25 * (w[0] * c[0] + w[1] * c[1] + w[2] * c[2] + w[3] * c[3]);
}

/// Whether hint h (kHintFaceA <= h < kHintEnd) holds for tets a and b.
bool hint_holds(const TetGeometry& a, const TetGeometry& b, double tolerance, int h) {
  if (h < kHintFaceB) return face_apart(a, h - kHintFaceA, corners_from(b, a.v[0]), tolerance);
  if (h < kHintEdge) return face_apart(b, h - kHintFaceB, corners_from(a, b.v[0]), tolerance);
  if (h < kHintDeepB) {
    const int i = (h - kHintEdge) / 6, j = (h - kHintEdge) % 6;
    return apart_along(cross3(a.edge(i), b.edge(j)), corners_from(a, a.v[0]),
                       corners_from(b, a.v[0]), tolerance);
  }
  if (h < kHintDeepA)
    return deep_inside(a, b.v[static_cast<std::size_t>(h - kHintDeepB)] - a.v[0], 2.0 * tolerance);
  if (h < kHintGridB)
    return deep_inside(b, a.v[static_cast<std::size_t>(h - kHintDeepA)] - b.v[0], 2.0 * tolerance);
  if (h < kHintGridA)
    return deep_inside(a, grid_point(corners_from(b, a.v[0]), h - kHintGridB), 2.0 * tolerance);
  return deep_inside(b, grid_point(corners_from(a, b.v[0]), h - kHintGridA), 2.0 * tolerance);
}

}  // namespace

int check_overlap_hint(const TetGeometry& a, const TetGeometry& b, double relative_tolerance,
                       OverlapHint hint) {
  const int h = hint;
  if (h < kHintFaceA || h >= kHintEnd || a.flat || b.flat) return -1;
  if (!(relative_tolerance >= kHintMinRelativeTolerance)) return -1;
  if (!hint_holds(a, b, relative_tolerance * pair_scale(a, b), h)) return -1;
  return h >= kHintDeepB ? 1 : 0;
}

OverlapHint find_overlap_hint(const TetGeometry& a, const TetGeometry& b, double relative_tolerance,
                              bool overlap) {
  if (a.flat || b.flat || !(relative_tolerance >= kHintMinRelativeTolerance))
    return kOverlapHintNone;
  const double tolerance = relative_tolerance * pair_scale(a, b);
  if (overlap) {
    for (int h = kHintDeepB; h < kHintGridB; ++h)
      if (hint_holds(a, b, tolerance, h)) return static_cast<OverlapHint>(h);
    const auto pb = corners_from(b, a.v[0]), qa = corners_from(a, b.v[0]);
    for (int g = 0; g < kGridCount; ++g) {
      if (deep_inside(a, grid_point(pb, g), 2.0 * tolerance))
        return static_cast<OverlapHint>(kHintGridB + g);
      if (deep_inside(b, grid_point(qa, g), 2.0 * tolerance))
        return static_cast<OverlapHint>(kHintGridA + g);
    }
    return kOverlapHintNone;
  }
  const auto pb = corners_from(b, a.v[0]);
  for (int k = 0; k < 4; ++k)
    if (face_apart(a, k, pb, tolerance)) return static_cast<OverlapHint>(kHintFaceA + k);
  const auto qa = corners_from(a, b.v[0]);
  for (int k = 0; k < 4; ++k)
    if (face_apart(b, k, qa, tolerance)) return static_cast<OverlapHint>(kHintFaceB + k);
  const auto pa = corners_from(a, a.v[0]);
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j)
      if (apart_along(cross3(a.edge(i), b.edge(j)), pa, pb, tolerance))
        return static_cast<OverlapHint>(kHintEdge + 6 * i + j);
  return kOverlapHintNone;
}

// One copy for AVX2 and one for the x86-64 baseline (use_avx2_kernels()); both give the
// same bits (the same IEEE operations per lane, no FMA: "avx2" does not enable it).
bool tets_overlap(const TetGeometry& a, const TetGeometry& b, double tolerance) {
  // Flat (or non-finite) tets take the reference's every-edge-pair path.
  if (a.flat || b.flat) return tets_overlap_reference(a, b, tolerance);
  return overlap_fast(a, b, std::max(tolerance, 0.0));
}

void tets_overlap_pairs(std::span<const GeometryPair> pairs, double relative_tolerance,
                        std::span<bool> out) {
#if TC_HAS_AVX2_REGION
  if (use_avx2_kernels()) return avx2::overlap_pairs(pairs, relative_tolerance, out);
#endif
  baseline::overlap_pairs(pairs, relative_tolerance, out);
}

bool tets_overlap(const TetCorners& a, const TetCorners& b, double tolerance) {
  return tets_overlap(make_tet_geometry(a), make_tet_geometry(b), tolerance);
}

PointInTet point_in_tet(const Eigen::Vector3d& p, const TetGeometry& t, double tolerance) {
  PointInTet out;
  if (t.flat) return out;
  // w_k = 6 x volume of the tet with corner k replaced by p (sign of a positive tet):
  // -n_k . (p - face_k) with outward n_k.
  Eigen::Vector4d w;
  const double tol = std::max(tolerance, 0.0);
  for (int k = 0; k < 4; ++k) w[k] = -dot3(t.normal(k), p - t.v[kTetFaces[k][0]]);
  // Outside a face (or NaN): all four tests, then one branch (the detection's node scan
  // makes ~500 calls a frame, and a test per face that goes either way mispredicts more
  // than the three products it would skip).
  unsigned within = 1;  // 0/1, not bool: & of bools reads as a typo for && to clang
  for (int k = 0; k < 4; ++k) within &= static_cast<unsigned>(w[k] >= -tol * t.n_len[k]);
  if (within == 0) return out;
  const double total = w.sum();
  if (!(total > 0.0)) return out;
  out.inside = true;
  out.bary = w / total;
  return out;
}

PointInTet point_in_tet(const Eigen::Vector3d& p, const TetCorners& t, double tolerance) {
  return point_in_tet(p, make_tet_geometry(t), tolerance);
}

SegmentClip clip_segment_tet_reference(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                       const TetGeometry& t, double tolerance) {
  SegmentClip out;
  const double tol = std::max(tolerance, 0.0);
  const double length = (p1 - p0).norm();
  if (!(length > tol) || !std::isfinite(length) || t.flat) return out;
  double lambda_in = 0.0, lambda_out = 1.0;
  for (int k = 0; k < 4; ++k) {
    // Signed distances outside face k, metres; within tol of the plane counts as on it.
    const Vector3d& f = t.v[kTetFaces[k][0]];
    const Vector3d n = t.normal(k);
    double d0 = dot3(n, p0 - f) * t.n_inv[k];
    double d1 = dot3(n, p1 - f) * t.n_inv[k];
    if (std::abs(d0) <= tol) d0 = 0.0;
    if (std::abs(d1) <= tol) d1 = 0.0;
    if (!(d0 <= 0.0 || d1 <= 0.0)) return out;  // both outside (or NaN)
    if (d0 > 0.0) {
      lambda_in = std::max(lambda_in, d0 / (d0 - d1));  // entering: d0 > 0 >= d1
    } else if (d1 > 0.0) {
      lambda_out = std::min(lambda_out, d0 / (d0 - d1));  // leaving: d0 <= 0 < d1
    }
  }
  if (!((lambda_out - lambda_in) * length > tol)) return out;
  out.hit = true;
  out.lambda_in = lambda_in;
  out.lambda_out = lambda_out;
  return out;
}

namespace {

/// clip_segment_tets() of one copy (clip_lanes() inlined).
TC_INLINE void clip_targets(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                            std::span<const ClipTarget> targets, std::span<SegmentClip> out) {
  const double length = (p1 - p0).norm();
  for (std::size_t i = 0; i < targets.size(); ++i)
    out[i] = clip_lanes(p0, p1, length, *targets[i].tet, targets[i].tolerance);
}

/// clip_lanes() and clip_targets() built for AVX2.
TC_AVX2_TARGET SegmentClip clip_avx2(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                     const TetGeometry& t, double tolerance) {
  return clip_lanes(p0, p1, (p1 - p0).norm(), t, tolerance);
}
TC_AVX2_TARGET void clip_targets_avx2(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                                      std::span<const ClipTarget> targets,
                                      std::span<SegmentClip> out) {
  clip_targets(p0, p1, targets, out);
}

}  // namespace

SegmentClip clip_segment_tet(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                             const TetGeometry& t, double tolerance) {
  if (use_avx2_kernels()) return clip_avx2(p0, p1, t, tolerance);
  return clip_lanes(p0, p1, (p1 - p0).norm(), t, tolerance);
}

void clip_segment_tets(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                       std::span<const ClipTarget> targets, std::span<SegmentClip> out) {
  if (use_avx2_kernels()) return clip_targets_avx2(p0, p1, targets, out);
  clip_targets(p0, p1, targets, out);
}

SegmentClip clip_segment_tet(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                             const TetCorners& t, double tolerance) {
  return clip_segment_tet(p0, p1, make_tet_geometry(t), tolerance);
}

}  // namespace tc
