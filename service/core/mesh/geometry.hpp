// Small geometric helpers on tets shared by every stage.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

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
