// The paper's grid baseline ("FM 20x20", "FM 100x100"; here also N^3 in 3D): first-order
// fast marching (Sethian's upwind Eikonal update) on a regular grid of N points per
// axis spanning the bounding box of the object's nodes, seeded with exact distances in
// a band around the boundary, then read at the nodes by multilinear interpolation.
// A baseline for docs/DEPTH_MAPS.md, not a production method.
#pragma once

#include <Eigen/Core>
#include <array>
#include <span>
#include <utility>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/mesh2d.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

struct Topology2;

/// Grid fast marching in D = 2 or 3 dimensions, keeping its buffers across frames.
template <int D>
class GridFastMarching {
 public:
  using Points = Eigen::Matrix<double, D, Eigen::Dynamic>;

  /// @param[in] simplices   k boundary features (triangles for D = 3, segments for
  ///                        D = 2), node indices.
  /// @param[in] resolution  N >= 2 grid points per axis.
  GridFastMarching(std::vector<std::array<Index, D>> simplices, int resolution);

  /// Distance to the boundary at the given nodes.
  ///
  /// @param[in]  positions  D x n node positions, metres (finite).
  /// @param[in]  nodes      the nodes to evaluate (the grid spans their bounding box).
  /// @param[out] depth      n values, metres: written at `nodes`, untouched elsewhere.
  void compute(const Points& positions, std::span<const Index> nodes, std::span<double> depth);

  /// N.
  [[nodiscard]] int resolution() const { return n_; }
  /// The grid values of the last compute (N^D, x fastest), metres.
  [[nodiscard]] const std::vector<double>& grid() const { return value_; }
  /// Position of grid point 0 and the spacing per axis (metres) of the last compute;
  /// point (i, j, k) is at origin + (i, j, k) .* spacing.
  [[nodiscard]] const Eigen::Matrix<double, D, 1>& origin() const { return lo_; }
  [[nodiscard]] const Eigen::Matrix<double, D, 1>& spacing() const { return h_; }
  /// Grid points seeded with an exact distance in the last compute.
  [[nodiscard]] std::size_t seeded_points() const { return seeded_; }

 private:
  void seed_band(const Points& positions);
  void march();
  [[nodiscard]] double upwind(std::size_t p) const;

  std::vector<std::array<Index, D>> simplices_;
  int n_;
  Eigen::Matrix<double, D, 1> lo_, h_;
  std::size_t stride_[D];
  std::vector<double> value_;
  std::vector<std::uint8_t> state_;  ///< 0 far, 1 trial, 2 alive
  std::size_t seeded_ = 0;
  std::vector<std::pair<double, std::size_t>> heap_;
};

extern template class GridFastMarching<2>;
extern template class GridFastMarching<3>;

/// One-off grid fast marching depth map of a tet mesh (n values, +infinity at orphans).
Expected<std::vector<double>> compute_depth_grid_fm(const TetMesh& mesh, const Topology& topo,
                                                    int resolution);
/// Same for a 2D triangle mesh.
Expected<std::vector<double>> compute_depth_grid_fm(const TriMesh2& mesh, const Topology2& topo,
                                                    int resolution);

}  // namespace tc
