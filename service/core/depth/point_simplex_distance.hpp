// Exact distance from a point to a boundary feature: a segment (2D boundaries, and the
// edges of 3D ones) or a triangle, with the place of the closest point (a vertex, an
// edge, or the interior). Used by the exact reference, by CFFM and by the tests.
//
// All functions return SQUARED distances (m^2): comparisons need no sqrt. They are
// templates on the vector type: plain fixed-size Eigen vectors of double (reference,
// exact depth) or float (the marches' compact per-node records).
// Degenerate features (zero-length segments, zero-area or collinear triangles) are
// handled: the result is the distance to the degenerate set, never NaN for finite input.
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace tc {

/// Where on a feature the closest point lies. For a segment (a, b): kV0 = a, kV1 = b,
/// kE01 = interior. For a triangle (a, b, c): vertices kV0..kV2, edges kE01 (a-b),
/// kE12 (b-c), kE20 (c-a), kInterior = inside the face. For triangles, edge j joins
/// local vertices j and (j + 1) % 3, and its code is kE01 + j.
enum class FeatureLoc : std::uint8_t { kV0 = 0, kV1, kV2, kE01, kE12, kE20, kInterior };

/// Squared distance and where the closest point lies.
template <typename Scalar>
struct BasicFeatureDistance {
  Scalar sq_dist;
  FeatureLoc loc;
};
using FeatureDistance = BasicFeatureDistance<double>;

/// Closest point of a feature and where it lies.
template <typename Vec>
struct ClosestPoint {
  Vec point;
  FeatureLoc loc;
};

/// Closest point to p on the segment [a, b], any dimension D (2 or 3).
///
/// @param p, a, b  D-vectors (Eigen::Matrix<Scalar, D, 1>), metres.
/// @return the point (metres) and kV0 / kV1 / kE01.
template <typename Vec>
inline ClosestPoint<Vec> closest_point_segment(const Vec& p, const Vec& a, const Vec& b) {
  using Scalar = typename Vec::Scalar;
  const Vec ab = b - a;
  const Scalar t = ab.dot(p - a);
  if (t <= Scalar(0)) return {a, FeatureLoc::kV0};
  const Scalar len2 = ab.squaredNorm();
  if (t >= len2) return {b, FeatureLoc::kV1};
  // 0 < t < len2 implies len2 > 0.
  return {a + (t / len2) * ab, FeatureLoc::kE01};
}

/// Closest point to p on the triangle (a, b, c) in 3D (Ericson, Real-Time Collision
/// Detection 5.1.5, with guards for degenerate triangles).
///
/// @param p, a, b, c  3-vectors (Eigen::Matrix<Scalar, 3, 1>), metres.
/// @return the point (metres) and its place on the triangle.
template <typename Vec>
inline ClosestPoint<Vec> closest_point_triangle(const Vec& p, const Vec& a, const Vec& b,
                                                const Vec& c) {
  using Scalar = typename Vec::Scalar;
  constexpr Scalar kZero(0);
  const Vec ab = b - a;
  const Vec ac = c - a;
  const Vec ap = p - a;
  const Scalar d1 = ab.dot(ap);
  const Scalar d2 = ac.dot(ap);
  if (d1 <= kZero && d2 <= kZero) return {a, FeatureLoc::kV0};

  const Vec bp = p - b;
  const Scalar d3 = ab.dot(bp);
  const Scalar d4 = ac.dot(bp);
  if (d3 >= kZero && d4 <= d3) return {b, FeatureLoc::kV1};

  const Scalar vc = d1 * d4 - d3 * d2;
  if (vc <= kZero && d1 >= kZero && d3 <= kZero) {
    const Scalar den = d1 - d3;  // |ab|^2
    if (den > kZero) return {a + (d1 / den) * ab, FeatureLoc::kE01};
  }

  const Vec cp = p - c;
  const Scalar d5 = ab.dot(cp);
  const Scalar d6 = ac.dot(cp);
  if (d6 >= kZero && d5 <= d6) return {c, FeatureLoc::kV2};

  const Scalar vb = d5 * d2 - d1 * d6;
  if (vb <= kZero && d2 >= kZero && d6 <= kZero) {
    const Scalar den = d2 - d6;  // |ac|^2
    if (den > kZero) return {a + (d2 / den) * ac, FeatureLoc::kE20};
  }

  const Scalar va = d3 * d6 - d5 * d4;
  if (va <= kZero && (d4 - d3) >= kZero && (d5 - d6) >= kZero) {
    const Scalar den = (d4 - d3) + (d5 - d6);  // |bc|^2
    if (den > kZero) return {b + ((d4 - d3) / den) * (c - b), FeatureLoc::kE12};
  }

  const Scalar sum = va + vb + vc;  // |ab x ac|^2 up to rounding
  if (sum > kZero) {
    const Scalar v = vb / sum;
    const Scalar w = vc / sum;
    if (v >= kZero && w >= kZero && v + w <= Scalar(1))
      return {a + v * ab + w * ac, FeatureLoc::kInterior};
  }
  // Degenerate (collinear or coincident vertices) or rounding at a region border: the
  // closest point lies on one of the three edges.
  auto best = closest_point_segment(p, a, b);
  auto e12 = closest_point_segment(p, b, c);
  auto e20 = closest_point_segment(p, c, a);
  // Map segment-local codes to triangle codes.
  const auto map = [](FeatureLoc seg, FeatureLoc v0, FeatureLoc v1, FeatureLoc e) {
    return seg == FeatureLoc::kV0 ? v0 : (seg == FeatureLoc::kV1 ? v1 : e);
  };
  best.loc = map(best.loc, FeatureLoc::kV0, FeatureLoc::kV1, FeatureLoc::kE01);
  e12.loc = map(e12.loc, FeatureLoc::kV1, FeatureLoc::kV2, FeatureLoc::kE12);
  e20.loc = map(e20.loc, FeatureLoc::kV2, FeatureLoc::kV0, FeatureLoc::kE20);
  Scalar best_d = (p - best.point).squaredNorm();
  if (const Scalar d = (p - e12.point).squaredNorm(); d < best_d) {
    best = e12;
    best_d = d;
  }
  if ((p - e20.point).squaredNorm() < best_d) best = e20;
  return best;
}

/// Squared distance from p to the segment [a, b] (m^2) and where the closest point lies.
template <typename Vec>
inline BasicFeatureDistance<typename Vec::Scalar> point_segment_distance(const Vec& p, const Vec& a,
                                                                         const Vec& b) {
  const ClosestPoint<Vec> c = closest_point_segment(p, a, b);
  return {(p - c.point).squaredNorm(), c.loc};
}

/// Squared distance from p to the triangle (a, b, c) (m^2) and where the closest point
/// lies.
template <typename Vec>
inline BasicFeatureDistance<typename Vec::Scalar> point_triangle_distance(const Vec& p,
                                                                          const Vec& a,
                                                                          const Vec& b,
                                                                          const Vec& c) {
  const ClosestPoint<Vec> q = closest_point_triangle(p, a, b, c);
  return {(p - q.point).squaredNorm(), q.loc};
}

}  // namespace tc
