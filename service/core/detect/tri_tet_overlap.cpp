#include "core/detect/tri_tet_overlap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/detect/exact_vec3.hpp"
#include "core/mesh/geometry.hpp"

namespace tc {
namespace {

using Eigen::Vector3d;

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kInf = std::numeric_limits<double>::infinity();
/// |n| <= kFlat L^2: the triangle is degenerate up to rounding (as tets: 6|V| <= kFlat L^3).
constexpr double kFlat = 32.0 * kEps;

using detail::any_perpendicular;
using detail::cross3;
using detail::dot3;

/// The separating-axis walk of a triangle against a tet, in coordinates relative to the
/// tet's first corner. kEarly: answers "overlap by more than tol?", stopping at the first
/// separating axis or at a triangle corner deeper than tol in the tet. Otherwise: the
/// minimum penetration over every axis (best()).
template <bool kEarly>
class TriSat {
 public:
  TriSat(const TriangleCorners& t, const TetGeometry& k, double tol) : t_(t), k_(k), tol_(tol) {
    const Vector3d& o = k.v[0];
    for (int i = 0; i < 3; ++i) a_[i] = t[i] - o;
    for (int j = 0; j < 4; ++j) b_[j] = k.v[j] - o;
  }

  bool run() {
    const bool finite = t_[0].allFinite() && t_[1].allFinite() && t_[2].allFinite();
    // make_tet_geometry() gives a tet with a non-finite corner an empty box.
    if (!finite || !(k_.lo.array() <= k_.hi.array()).all()) {
      best_ = -kInf;
      return false;
    }
    // Coordinate axes (the boxes).
    const Vector3d lo = t_[0].cwiseMin(t_[1]).cwiseMin(t_[2]);
    const Vector3d hi = t_[0].cwiseMax(t_[1]).cwiseMax(t_[2]);
    for (int d = 0; d < 3; ++d)
      if (record(std::min(hi[d] - k_.lo[d], k_.hi[d] - lo[d]), 1.0)) return false;
    // The tet's face normals; a triangle corner deep inside every face is an overlap.
    bool deep[3] = {!k_.flat, !k_.flat, !k_.flat};
    for (int f = 0; f < 4; ++f) {
      const Vector3d n = k_.normal(f);
      const double len = k_.n_len[f];
      if (!(len > 0.0) || !std::isfinite(len)) {
        deep[0] = deep[1] = deep[2] = false;
        continue;
      }
      const double c = dot3(n, b_[kTetFaces[f][0]]);
      const double opp = dot3(n, b_[f]);
      const double p0 = dot3(n, a_[0]), p1 = dot3(n, a_[1]), p2 = dot3(n, a_[2]);
      const double tlo = std::min(std::min(p0, p1), p2);
      const double thi = std::max(std::max(p0, p1), p2);
      if (record(std::min(std::max(c, opp) - tlo, thi - std::min(c, opp)), len)) return false;
      const double depth = c - tol_ * len;  // outward normal: inside means below c
      deep[0] = deep[0] && p0 < depth;
      deep[1] = deep[1] && p1 < depth;
      deep[2] = deep[2] && p2 < depth;
    }
    if constexpr (kEarly) {
      if (deep[0] || deep[1] || deep[2]) return true;
    }
    // The triangle's normal, then every triangle edge against every tet edge.
    const Vector3d te[3] = {a_[1] - a_[0], a_[2] - a_[1], a_[0] - a_[2]};
    const Vector3d normal = cross3(te[0], a_[2] - a_[0]);
    if (axis(normal)) return false;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 6; ++j)
        if (axis(cross3(te[i], k_.edge(j)))) return false;
    const double scale = (hi - lo).maxCoeff();
    const bool degenerate = !(std::sqrt(dot3(normal, normal)) > kFlat * scale * scale);
    if (!degenerate && !k_.flat) return true;
    // Degenerate shapes: the Minkowski difference may have facets (or, when it is flat,
    // the separating directions) that no normal or edge cross above gives.
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 6; ++j) {
        if (axis(perpendicular(a_[i], b_[kTetEdges[j][0]], k_.edge(j)))) return false;
        if (i < 3 && j < 4 && axis(a_[i] - b_[j])) return false;
      }
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 3; ++i)
        if (axis(perpendicular(b_[j], a_[i], te[i]))) return false;
    for (int i = 0; i < 9; ++i) {
      const Vector3d e = i < 3 ? te[i] : k_.edge(i - 3);
      if (!(dot3(e, e) > 0.0)) continue;
      const Vector3d p = any_perpendicular(e);
      if (axis(p) || axis(cross3(e, p))) return false;
    }
    return true;
  }

  [[nodiscard]] double best() const { return best_; }

 private:
  /// The component of (x - p) perpendicular to e: from the line (p, e) to the point x.
  static Vector3d perpendicular(const Vector3d& x, const Vector3d& p, const Vector3d& e) {
    const Vector3d d = x - p;
    const double e2 = dot3(e, e);
    if (!(e2 > 0.0)) return d;
    return d - (dot3(d, e) / e2) * e;
  }

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
    const double p0 = dot3(n, a_[0]), p1 = dot3(n, a_[1]), p2 = dot3(n, a_[2]);
    const double q0 = dot3(n, b_[0]), q1 = dot3(n, b_[1]), q2 = dot3(n, b_[2]), q3 = dot3(n, b_[3]);
    const double alo = std::min(std::min(p0, p1), p2), ahi = std::max(std::max(p0, p1), p2);
    const double blo = std::min(std::min(q0, q1), std::min(q2, q3));
    const double bhi = std::max(std::max(q0, q1), std::max(q2, q3));
    return record(std::min(ahi - blo, bhi - alo), std::sqrt(nn));
  }

  const TriangleCorners& t_;
  const TetGeometry& k_;
  Vector3d a_[3], b_[4];
  double tol_;
  double best_ = kInf;
};

}  // namespace

double pair_scale(const TriangleCorners& t, const TetCorners& k) {
  Vector3d lo = k[0], hi = k[0];
  for (int i = 1; i < 4; ++i) {
    lo = lo.cwiseMin(k[i]);
    hi = hi.cwiseMax(k[i]);
  }
  for (int i = 0; i < 3; ++i) {
    lo = lo.cwiseMin(t[i]);
    hi = hi.cwiseMax(t[i]);
  }
  return (hi - lo).maxCoeff();
}

double triangle_tet_penetration(const TriangleCorners& t, const TetCorners& k) {
  const TetGeometry g = make_tet_geometry(k);
  TriSat<false> sat(t, g, 0.0);
  sat.run();
  return sat.best();
}

bool triangle_tet_overlap(const TriangleCorners& t, const TetGeometry& k, double tolerance) {
  TriSat<true> sat(t, k, std::max(tolerance, 0.0));
  return sat.run();
}

bool triangle_tet_overlap(const TriangleCorners& t, const TetCorners& k, double tolerance) {
  return triangle_tet_overlap(t, make_tet_geometry(k), tolerance);
}

}  // namespace tc
