#include "core/mesh/spatial_order.hpp"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>

namespace tc {
namespace {

/// The low 21 bits of v spread to every third bit.
std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1fffffULL;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

}  // namespace

std::vector<Index> tets_in_morton_order(const Positions& positions, std::span<const Tet> tets,
                                        const Eigen::Vector3d& lo, double extent) {
  constexpr double kTop = double((1 << 21) - 1);
  const double to_grid = extent > 0.0 ? kTop / extent : 0.0;
  const std::size_t m = tets.size();
  std::vector<std::pair<std::uint64_t, Index>> keys(m);
  for (std::size_t t = 0; t < m; ++t) {
    const Tet& tet = tets[t];
    const Eigen::Vector3d p = 0.25 * (positions.col(tet[0]) + positions.col(tet[1]) +
                                      positions.col(tet[2]) + positions.col(tet[3]));
    std::uint64_t code = ~std::uint64_t{0};
    if (p.allFinite()) {
      const Eigen::Vector3d q = ((p - lo) * to_grid).cwiseMax(0.0).cwiseMin(kTop);
      code = spread_bits(static_cast<std::uint64_t>(q.x())) |
             spread_bits(static_cast<std::uint64_t>(q.y())) << 1 |
             spread_bits(static_cast<std::uint64_t>(q.z())) << 2;
    }
    keys[t] = {code, static_cast<Index>(t)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<Index> order(m);
  for (std::size_t k = 0; k < m; ++k) order[k] = keys[k].second;
  return order;
}

std::vector<Index> tets_in_morton_order(const Positions& positions, std::span<const Tet> tets) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (Eigen::Index i = 0; i < positions.cols(); ++i)
    if (positions.col(i).allFinite()) {
      lo = lo.cwiseMin(positions.col(i));
      hi = hi.cwiseMax(positions.col(i));
    }
  if (!(lo.x() <= hi.x()))
    return tets_in_morton_order(positions, tets, Eigen::Vector3d::Zero(), 0.0);
  return tets_in_morton_order(positions, tets, lo, (hi - lo).maxCoeff());
}

}  // namespace tc
