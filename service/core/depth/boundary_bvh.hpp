// Bounding volume hierarchy over the boundary features (triangles in 3D, segments in
// 2D) for exact nearest-feature queries: the exact depth reference and the grid fast
// marching baseline's seeding. Rebuilt whenever positions change (a few ms for 10^4
// triangles); queries are const and may run concurrently.
#pragma once

#include <Eigen/Core>
#include <array>
#include <limits>
#include <span>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

template <int D>
class BoundaryBvh {
 public:
  using Vec = Eigen::Matrix<double, D, 1>;
  using Points = Eigen::Matrix<double, D, Eigen::Dynamic>;

  /// Result of a nearest query: squared distance (m^2) and the feature index (into the
  /// simplices given to build(); one of the nearest on ties), or -1 and +inf when
  /// nothing is nearer than the bound.
  struct Hit {
    double sq_dist = std::numeric_limits<double>::infinity();
    Index simplex = -1;
  };

  /// Builds the hierarchy (median split on the longest axis, up to 4 features a leaf).
  ///
  /// @param[in] simplices  k features, D node indices each (triangles for D = 3,
  ///                       segments for D = 2), indices into positions.
  /// @param[in] positions  D x n node positions, metres.
  void build(std::span<const std::array<Index, D>> simplices, const Points& positions);

  /// Nearest feature to p with squared distance below `bound_sq` (m^2).
  ///
  /// @param[in] p         D-vector, metres.
  /// @param[in] bound_sq  only features strictly nearer than this count; +inf = all.
  [[nodiscard]] Hit nearest(const Vec& p,
                            double bound_sq = std::numeric_limits<double>::infinity()) const;

  /// Calls visit(simplex) for every feature whose box is within distance `radius` of p
  /// (a superset of the features within `radius`). Used to rasterize a band.
  template <typename Visit>
  void for_each_near(const Vec& p, double radius, Visit&& visit) const;

  [[nodiscard]] Index size() const { return static_cast<Index>(order_.size()); }

 private:
  struct Node {
    Vec lo, hi;
    Index first;  ///< leaf: first slot in order_; inner: index of the left child
    Index count;  ///< leaf: number of features (> 0); inner: 0
    Index right;  ///< inner: index of the right child; leaf: -1
  };
  static double box_sq_dist(const Node& n, const Vec& p) {
    double d = 0.0;
    for (int i = 0; i < D; ++i) {
      const double e = std::max({n.lo[i] - p[i], 0.0, p[i] - n.hi[i]});
      d += e * e;
    }
    return d;
  }
  Index build_node(Index first, Index count, std::vector<Vec>& centroids);
  [[nodiscard]] double feature_sq_dist(Index slot, const Vec& p) const;

  std::vector<Node> nodes_;
  std::vector<Index> order_;  ///< feature ids in leaf order
  std::vector<Vec> corners_;  ///< D corners per slot, in leaf order
};

template <int D>
template <typename Visit>
void BoundaryBvh<D>::for_each_near(const Vec& p, double radius, Visit&& visit) const {
  if (nodes_.empty()) return;
  const double r2 = radius * radius;
  Index stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (box_sq_dist(n, p) > r2) continue;
    if (n.count > 0) {
      for (Index s = n.first; s < n.first + n.count; ++s) visit(order_[s]);
    } else if (top + 2 <= 128) {
      stack[top++] = n.right;
      stack[top++] = n.first;
    }
  }
}

extern template class BoundaryBvh<2>;
extern template class BoundaryBvh<3>;

}  // namespace tc
