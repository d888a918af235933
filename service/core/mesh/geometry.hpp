// Small geometric helpers on tets shared by every stage.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// Signed volume of the tet (x0, x1, x2, x3); positive when x3 lies on the side of
/// triangle (x0, x1, x2) its right-hand normal points to.
inline double signed_volume(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                            const Eigen::Vector3d& x2, const Eigen::Vector3d& x3) {
  return (x1 - x0).dot((x2 - x0).cross(x3 - x0)) / 6.0;
}

inline double signed_volume(const Positions& positions, const Tet& t) {
  return signed_volume(positions.col(t[0]), positions.col(t[1]), positions.col(t[2]),
                       positions.col(t[3]));
}

/// The box of points added one at a time, kept in registers (x and y in one two-lane
/// vector, z apart): lo = std::min(lo, p) and hi = std::max(hi, p) coordinate by
/// coordinate, so the bits an Aabb extended point by point gets (Eigen's cwiseMin /
/// cwiseMax, operand for operand), signed zeros included. A NaN coordinate compares false
/// and leaves that coordinate of the box as it was. The node passes of the shape check and
/// of the detection's boxes run on it.
class PointBox {
 public:
  using V2 = double __attribute__((vector_size(16)));

  /// The empty box.
  PointBox() = default;
  /// The box with corners lo and hi (3 coordinates each), as given.
  PointBox(const double* lo, const double* hi)
      : lo_{lo[0], lo[1]}, hi_{hi[0], hi[1]}, lo_z_(lo[2]), hi_z_(hi[2]) {}

  /// x and y of the point at p.
  static V2 xy_of(const double* p) {
    V2 xy;
    std::memcpy(&xy, p, sizeof xy);
    return xy;
  }
  void add(V2 xy, double z) {
    lo_ = xy < lo_ ? xy : lo_;  // std::min(lo, xy) lane by lane
    hi_ = hi_ < xy ? xy : hi_;  // std::max(hi, xy)
    lo_z_ = std::min(lo_z_, z);
    hi_z_ = std::max(hi_z_, z);
  }
  void add(const double* p) { add(xy_of(p), p[2]); }
  /// Adds the points of `later` (boxes of consecutive runs of points, added in order, give
  /// the bits of adding the points one by one: an extreme is replaced only by one strictly
  /// beyond it).
  void add(const PointBox& later) {
    lo_ = later.lo_ < lo_ ? later.lo_ : lo_;
    hi_ = hi_ < later.hi_ ? later.hi_ : hi_;
    lo_z_ = std::min(lo_z_, later.lo_z_);
    hi_z_ = std::max(hi_z_, later.hi_z_);
  }
  [[nodiscard]] Eigen::Vector3d lo() const { return {lo_[0], lo_[1], lo_z_}; }
  [[nodiscard]] Eigen::Vector3d hi() const { return {hi_[0], hi_[1], hi_z_}; }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  V2 lo_ = {kInf, kInf}, hi_ = {-kInf, -kInf};
  double lo_z_ = kInf, hi_z_ = -kInf;
};

/// Mean squared length of the six edges of a tet.
inline double mean_squared_edge_length(const Positions& p, const Tet& t) {
  double sum = 0.0;
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) sum += (p.col(t[i]) - p.col(t[j])).squaredNorm();
  return sum / 6.0;
}

/// Scale-free shape quality 6*sqrt(2)*V / l_rms^3: 1 for the regular tet, 0 for a flat
/// one, negative for an inverted one. Returns 0 when every edge has zero length.
inline double tet_quality(const Positions& p, const Tet& t) {
  const double l2 = mean_squared_edge_length(p, t);
  if (!(l2 > 0.0)) return 0.0;
  return 6.0 * std::sqrt(2.0) * signed_volume(p, t) / (l2 * std::sqrt(l2));
}

/// The face opposite local node i, ordered so that its right-hand normal points out of
/// a positively oriented tet.
inline constexpr std::array<std::array<int, 3>, 4> kTetFaces = {
    {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}};

/// The six edges of a tet as pairs of local node indices.
inline constexpr std::array<std::array<int, 2>, 6> kTetEdges = {
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

}  // namespace tc
