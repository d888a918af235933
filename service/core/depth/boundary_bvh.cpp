#include "core/depth/boundary_bvh.hpp"

#include <algorithm>
#include <numeric>

#include "core/depth/point_simplex_distance.hpp"

namespace tc {
namespace {

constexpr Index kLeafSize = 4;

}  // namespace

template <int D>
void BoundaryBvh<D>::build(std::span<const std::array<Index, D>> simplices,
                           const Points& positions) {
  nodes_.clear();
  const auto k = static_cast<Index>(simplices.size());
  order_.resize(static_cast<std::size_t>(k));
  std::iota(order_.begin(), order_.end(), 0);
  std::vector<Vec> centroids(static_cast<std::size_t>(k));
  for (Index s = 0; s < k; ++s) {
    Vec c = Vec::Zero();
    for (int j = 0; j < D; ++j) c += positions.col(simplices[s][j]);
    centroids[s] = c / D;
  }
  // Keep corners by feature id while building; reorder into leaf order at the end.
  corners_.resize(static_cast<std::size_t>(k) * D);
  for (Index s = 0; s < k; ++s)
    for (int j = 0; j < D; ++j) corners_[s * D + j] = positions.col(simplices[s][j]);
  if (k == 0) return;
  nodes_.reserve(static_cast<std::size_t>(2 * (k / kLeafSize + 1)));
  build_node(0, k, centroids);
  std::vector<Vec> by_slot(corners_.size());
  for (Index slot = 0; slot < k; ++slot)
    for (int j = 0; j < D; ++j) by_slot[slot * D + j] = corners_[order_[slot] * D + j];
  corners_.swap(by_slot);
}

template <int D>
Index BoundaryBvh<D>::build_node(Index first, Index count, std::vector<Vec>& centroids) {
  const auto self = static_cast<Index>(nodes_.size());
  nodes_.push_back(Node{Vec::Zero(), Vec::Zero(), 0, 0, -1});
  Vec lo = Vec::Constant(std::numeric_limits<double>::infinity());
  Vec hi = -lo;
  for (Index s = first; s < first + count; ++s)
    for (int j = 0; j < D; ++j) {
      lo = lo.cwiseMin(corners_[order_[s] * D + j]);
      hi = hi.cwiseMax(corners_[order_[s] * D + j]);
    }
  nodes_[self].lo = lo;
  nodes_[self].hi = hi;
  if (count <= kLeafSize) {
    nodes_[self].first = first;
    nodes_[self].count = count;
    nodes_[self].right = -1;
    return self;
  }
  int axis = 0;
  (hi - lo).maxCoeff(&axis);
  const Index half = count / 2;
  auto begin = order_.begin() + first;
  // Ties broken by feature id so the tree does not depend on the sort implementation.
  std::nth_element(begin, begin + half, begin + count, [&](Index a, Index b) {
    return centroids[a][axis] != centroids[b][axis] ? centroids[a][axis] < centroids[b][axis]
                                                    : a < b;
  });
  const Index left = build_node(first, half, centroids);
  const Index right = build_node(first + half, count - half, centroids);
  nodes_[self].first = left;
  nodes_[self].count = 0;
  nodes_[self].right = right;
  return self;
}

template <int D>
double BoundaryBvh<D>::feature_sq_dist(Index slot, const Vec& p) const {
  const Vec* c = &corners_[static_cast<std::size_t>(slot) * D];
  if constexpr (D == 3) {
    return point_triangle_distance(p, c[0], c[1], c[2]).sq_dist;
  } else {
    return point_segment_distance(p, c[0], c[1]).sq_dist;
  }
}

template <int D>
typename BoundaryBvh<D>::Hit BoundaryBvh<D>::nearest(const Vec& p, double bound_sq) const {
  Hit hit;
  hit.sq_dist = bound_sq;
  if (nodes_.empty()) return {};
  Index stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (!(box_sq_dist(n, p) < hit.sq_dist)) continue;
    if (n.count > 0) {
      for (Index s = n.first; s < n.first + n.count; ++s) {
        const double d = feature_sq_dist(s, p);
        if (d < hit.sq_dist) {
          hit.sq_dist = d;
          hit.simplex = order_[s];
        }
      }
      continue;
    }
    if (top + 2 > 128) continue;  // unreachable for a median split of < 2^60 features
    // Visit the nearer child first: push it last.
    const double dl = box_sq_dist(nodes_[n.first], p);
    const double dr = box_sq_dist(nodes_[n.right], p);
    if (dl <= dr) {
      stack[top++] = n.right;
      stack[top++] = n.first;
    } else {
      stack[top++] = n.first;
      stack[top++] = n.right;
    }
  }
  if (hit.simplex < 0) return {};
  return hit;
}

template class BoundaryBvh<2>;
template class BoundaryBvh<3>;

}  // namespace tc
