#include "core/detect/tet_overlap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kEps = std::numeric_limits<double>::epsilon();
/// 6|V| <= kFlat * L^3: the tet is flat up to rounding.
constexpr double kFlat = 32.0 * kEps;
/// Two edges with sin(angle) at most this are treated as parallel: their cross product
/// is still tested, and so is the offset direction between their lines.
constexpr double kParallelSin = 1e-12;

/// A tet in coordinates relative to a shared origin, with its edges and face normals.
struct LocalTet {
  Vector3d v[4];
  Vector3d e[6];     ///< kTetEdges order
  double e2[6];      ///< squared edge lengths
  Vector3d n[4];     ///< face normals (kTetFaces order), outward unless flat
  double n_len[4];   ///< |n|
  bool flat = true;  ///< zero volume up to rounding: normals unoriented
};

double extent(const Vector3d& lo, const Vector3d& hi) {
  return (hi - lo).maxCoeff();
}

LocalTet make_local(const TetCorners& t, const Vector3d& origin) {
  LocalTet l;
  Vector3d lo = t[0], hi = t[0];
  for (int i = 0; i < 4; ++i) {
    l.v[i] = t[i] - origin;
    lo = lo.cwiseMin(t[i]);
    hi = hi.cwiseMax(t[i]);
  }
  for (int k = 0; k < 6; ++k) {
    l.e[k] = l.v[kTetEdges[k][1]] - l.v[kTetEdges[k][0]];
    l.e2[k] = l.e[k].squaredNorm();
  }
  const double det = l.e[0].dot(l.e[1].cross(l.e[2]));
  const double scale = extent(lo, hi);
  l.flat = !(std::abs(det) > kFlat * scale * scale * scale);
  const double sign = det < 0.0 ? -1.0 : 1.0;
  for (int k = 0; k < 4; ++k) {
    const auto& f = kTetFaces[k];
    l.n[k] = sign * (l.v[f[1]] - l.v[f[0]]).cross(l.v[f[2]] - l.v[f[0]]);
    l.n_len[k] = l.n[k].norm();
  }
  return l;
}

inline void project(const Vector3d (&v)[4], const Vector3d& n, double& lo, double& hi) {
  const double p0 = n.dot(v[0]), p1 = n.dot(v[1]), p2 = n.dot(v[2]), p3 = n.dot(v[3]);
  lo = std::min(std::min(p0, p1), std::min(p2, p3));
  hi = std::max(std::max(p0, p1), std::max(p2, p3));
}

/// Any unit-free direction perpendicular to a non-zero e.
Vector3d any_perpendicular(const Vector3d& e) {
  const Vector3d a = e.cwiseAbs();
  Vector3d axis = Vector3d::Zero();
  if (a.x() <= a.y() && a.x() <= a.z())
    axis.x() = 1.0;
  else if (a.y() <= a.z())
    axis.y() = 1.0;
  else
    axis.z() = 1.0;
  return e.cross(axis);
}

/// Walks the separating-axis candidates of two local tets. In early-exit mode it
/// answers "overlap by more than tol?" and stops at the first separating axis (or at a
/// corner deeper than tol inside the other tet); otherwise it returns the minimum
/// penetration over all axes.
template <bool kEarly>
class Sat {
 public:
  Sat(const LocalTet& a, const LocalTet& b, double tol) : a_(a), b_(b), tol_(tol) {}

  /// kEarly: true when the tets overlap by more than tol. Else: true always; see best().
  bool run() {
    // Coordinate axes (the boxes) first: cheapest, and they reject most candidates.
    for (int d = 0; d < 3; ++d) {
      double alo = a_.v[0][d], ahi = alo, blo = b_.v[0][d], bhi = blo;
      for (int i = 1; i < 4; ++i) {
        alo = std::min(alo, a_.v[i][d]);
        ahi = std::max(ahi, a_.v[i][d]);
        blo = std::min(blo, b_.v[i][d]);
        bhi = std::max(bhi, b_.v[i][d]);
      }
      if (record(std::min(ahi - blo, bhi - alo), 1.0)) return false;
    }
    if (faces(a_, b_)) return kEarly ? accepted_ : false;
    if (faces(b_, a_)) return kEarly ? accepted_ : false;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j)
        if (edge_pair(i, j)) return false;
    // Centroid direction: the only axis left when both tets collapse to points.
    Vector3d ca = Vector3d::Zero(), cb = Vector3d::Zero();
    for (int i = 0; i < 4; ++i) {
      ca += a_.v[i];
      cb += b_.v[i];
    }
    if (axis(cb - ca)) return false;
    return true;
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
    const double nn = n.squaredNorm();
    if (!(nn > 0.0) || !std::isfinite(nn)) return false;
    double alo, ahi, blo, bhi;
    project(a_.v, n, alo, ahi);
    project(b_.v, n, blo, bhi);
    return record(std::min(ahi - blo, bhi - alo), std::sqrt(nn));
  }

  /// Face normals of `f` against the corners of `o`. Returns true to stop: separated, or
  /// (kEarly) a corner of `o` lies deeper than tol inside `f` (then accepted_ is set).
  bool faces(const LocalTet& f, const LocalTet& o) {
    bool deep[4] = {!f.flat, !f.flat, !f.flat, !f.flat};
    for (int k = 0; k < 4; ++k) {
      const Vector3d& n = f.n[k];
      const double len = f.n_len[k];
      if (!(len > 0.0) || !std::isfinite(len)) {
        deep[0] = deep[1] = deep[2] = deep[3] = false;
        continue;
      }
      const double c = n.dot(f.v[kTetFaces[k][0]]);
      const double opp = n.dot(f.v[k]);
      const double flo = std::min(c, opp), fhi = std::max(c, opp);
      double p[4];
      double olo = std::numeric_limits<double>::infinity(), ohi = -olo;
      for (int j = 0; j < 4; ++j) {
        p[j] = n.dot(o.v[j]);
        olo = std::min(olo, p[j]);
        ohi = std::max(ohi, p[j]);
      }
      if (record(std::min(fhi - olo, ohi - flo), len)) return true;
      const double depth = tol_ * len;
      for (int j = 0; j < 4; ++j) deep[j] = deep[j] && (c - p[j] > depth);
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
    const Vector3d& ea = a_.e[i];
    const Vector3d& eb = b_.e[j];
    const Vector3d n = ea.cross(eb);
    const double nn = n.squaredNorm();
    if (axis(n)) return true;
    const double limit = kParallelSin * kParallelSin * a_.e2[i] * b_.e2[j];
    if (nn > limit) return false;
    // Parallel (or zero-length) edges: the direction from one line to the other,
    // perpendicular to the longer edge.
    const Vector3d d = b_.v[kTetEdges[j][0]] - a_.v[kTetEdges[i][0]];
    const bool a_longer = a_.e2[i] >= b_.e2[j];
    const Vector3d& e = a_longer ? ea : eb;
    const double e2 = a_longer ? a_.e2[i] : b_.e2[j];
    if (!(e2 > 0.0)) return axis(d);
    const Vector3d perp = d - (d.dot(e) / e2) * e;
    if (perp.squaredNorm() > kEps * kEps * d.squaredNorm() && axis(perp)) return true;
    return axis(any_perpendicular(e));
  }

  const LocalTet& a_;
  const LocalTet& b_;
  double tol_;
  double best_ = std::numeric_limits<double>::infinity();
  bool accepted_ = false;
};

/// Face planes of one tet relative to its first corner, for the point and segment tests.
struct Planes {
  Vector3d origin;
  Vector3d n[4];      ///< raw normals (outward for a positively oriented tet)
  Vector3d p[4];      ///< a point of each face plane, relative to origin
  double n_len[4];    ///< |n|
  double sign = 1.0;  ///< orientation of the tet
  bool flat = true;
};

Planes make_planes(const TetCorners& t) {
  Planes pl;
  pl.origin = t[0];
  Vector3d v[4];
  Vector3d lo = t[0], hi = t[0];
  for (int i = 0; i < 4; ++i) {
    v[i] = t[i] - pl.origin;
    lo = lo.cwiseMin(t[i]);
    hi = hi.cwiseMax(t[i]);
  }
  const double det = v[1].dot(v[2].cross(v[3]));
  const double scale = extent(lo, hi);
  pl.flat = !(std::abs(det) > kFlat * scale * scale * scale);
  pl.sign = det < 0.0 ? -1.0 : 1.0;
  for (int k = 0; k < 4; ++k) {
    const auto& f = kTetFaces[k];
    pl.p[k] = v[f[0]];
    pl.n[k] = (v[f[1]] - v[f[0]]).cross(v[f[2]] - v[f[0]]);
    pl.n_len[k] = pl.n[k].norm();
    if (!(pl.n_len[k] > 0.0) || !std::isfinite(pl.n_len[k])) pl.flat = true;
  }
  return pl;
}

}  // namespace

double tet_scale(const TetCorners& t) {
  Vector3d lo = t[0], hi = t[0];
  for (int i = 1; i < 4; ++i) {
    lo = lo.cwiseMin(t[i]);
    hi = hi.cwiseMax(t[i]);
  }
  return extent(lo, hi);
}

double pair_scale(const TetCorners& a, const TetCorners& b) {
  Vector3d lo = a[0], hi = a[0];
  for (int i = 0; i < 4; ++i) {
    lo = lo.cwiseMin(a[i]).cwiseMin(b[i]);
    hi = hi.cwiseMax(a[i]).cwiseMax(b[i]);
  }
  return extent(lo, hi);
}

double sat_penetration(const TetCorners& a, const TetCorners& b) {
  const LocalTet la = make_local(a, a[0]);
  const LocalTet lb = make_local(b, a[0]);
  Sat<false> sat(la, lb, 0.0);
  sat.run();
  return sat.best();
}

bool tets_overlap(const TetCorners& a, const TetCorners& b, double tolerance) {
  const LocalTet la = make_local(a, a[0]);
  const LocalTet lb = make_local(b, a[0]);
  Sat<true> sat(la, lb, std::max(tolerance, 0.0));
  return sat.run();
}

PointInTet point_in_tet(const Eigen::Vector3d& p, const TetCorners& t, double tolerance) {
  PointInTet out;
  const Planes pl = make_planes(t);
  if (pl.flat) return out;
  const Vector3d q = p - pl.origin;
  // D_k = 6 x signed volume of the tet with corner k replaced by p = -n_k . (p - face_k).
  Eigen::Vector4d d;
  for (int k = 0; k < 4; ++k) d[k] = -pl.n[k].dot(q - pl.p[k]);
  const double tol = std::max(tolerance, 0.0);
  for (int k = 0; k < 4; ++k)
    if (!(pl.sign * d[k] >= -tol * pl.n_len[k])) return out;
  const double total = d.sum();
  if (!(std::abs(total) > 0.0)) return out;
  out.inside = true;
  out.bary = d / total;
  return out;
}

SegmentClip clip_segment_tet(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                             const TetCorners& t, double tolerance) {
  SegmentClip out;
  const double tol = std::max(tolerance, 0.0);
  const double length = (p1 - p0).norm();
  if (!(length > tol) || !std::isfinite(length)) return out;
  const Planes pl = make_planes(t);
  if (pl.flat) return out;
  const Vector3d q0 = p0 - pl.origin, q1 = p1 - pl.origin;
  double lambda_in = 0.0, lambda_out = 1.0;
  for (int k = 0; k < 4; ++k) {
    // Signed distances outside face k, metres; within tol of the plane counts as on it.
    const double s = pl.sign / pl.n_len[k];
    double d0 = s * pl.n[k].dot(q0 - pl.p[k]);
    double d1 = s * pl.n[k].dot(q1 - pl.p[k]);
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

}  // namespace tc
