// Scalar dot and cross products of 3-vectors in a fixed operation order ((x X + y Y) + z Z),
// for the exact overlap tests (tet_overlap.cpp, tri_tet_overlap.cpp, both built with
// -ffp-contract=off): the vectorised and reference paths must see the same bits, and
// Eigen's packet code for unaligned 3-vectors spends more time shuffling than multiplying
// in these small hot loops.
#pragma once

#include <Eigen/Core>

namespace tc::detail {

inline double dot3(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return a.x() * b.x() + a.y() * b.y() + a.z() * b.z();
}

inline Eigen::Vector3d cross3(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return {a.y() * b.z() - a.z() * b.y(), a.z() * b.x() - a.x() * b.z(),
          a.x() * b.y() - a.y() * b.x()};
}

/// A direction perpendicular to a non-zero e: e crossed with the coordinate axis of e's
/// smallest coordinate (products with 0 and 1 only: exact).
inline Eigen::Vector3d any_perpendicular(const Eigen::Vector3d& e) {
  const Eigen::Vector3d a = e.cwiseAbs();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  if (a.x() <= a.y() && a.x() <= a.z())
    axis.x() = 1.0;
  else if (a.y() <= a.z())
    axis.y() = 1.0;
  else
    axis.z() = 1.0;
  return cross3(e, axis);
}

}  // namespace tc::detail
