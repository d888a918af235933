// service/core/depth/grid_fast_marching: exact seeds in the band, convergence with
// the resolution in 2D and 3D, axis-aligned fields, degenerate input.
#include "core/depth/grid_fast_marching.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/depth/boundary_surface.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/depth/point_simplex_distance.hpp"
#include "test_meshes.hpp"

namespace tc {
namespace {

double mean_abs_error(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += std::abs(a[i] - b[i]);
  return sum / static_cast<double>(a.size());
}

TEST(GridFastMarching, SeedsInTheBandAreExactDistances) {
  const TetMesh m = test::ball_mesh(6, 1.0);
  const Topology topo = build_topology(m.tets, m.num_nodes());
  GridFastMarching<3> fm(topo.boundary_faces, 20);
  std::vector<Index> nodes(static_cast<std::size_t>(m.num_nodes()));
  for (Index i = 0; i < m.num_nodes(); ++i) nodes[i] = i;
  std::vector<double> depth(nodes.size());
  fm.compute(m.positions, nodes, depth);
  EXPECT_GT(fm.seeded_points(), 0u);
  const int n = fm.resolution();
  const double band = fm.spacing().norm();
  std::size_t checked = 0;
  for (int k = 0; k < n; k += 3)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector3d x = fm.origin() + Eigen::Vector3d(i, j, k).cwiseProduct(fm.spacing());
        const double best = test::brute_force_sq_distance_to_boundary(m, topo, x);
        const double v = fm.grid()[static_cast<std::size_t>(i + n * (j + n * k))];
        if (std::sqrt(best) <= band) {
          EXPECT_NEAR(v, std::sqrt(best), 1e-12);
          ++checked;
        } else {
          // Outside the band: first-order accurate, within a few cells.
          EXPECT_NEAR(v, std::sqrt(best), 3 * band);
        }
      }
  EXPECT_GT(checked, 100u);
}

/// The grid's mean error against the exact depth at a coarse and a fine resolution: the
/// fine one at most half the coarse one and below `fine_limit`.
template <typename Mesh, typename Topo>
void expect_error_shrinks(const Mesh& m, const Topo& topo, int coarse_cells, int fine_cells,
                          double fine_limit) {
  const auto exact = *compute_depth_exact(m, topo);
  const double coarse = mean_abs_error(*compute_depth_grid_fm(m, topo, coarse_cells), exact);
  const double fine = mean_abs_error(*compute_depth_grid_fm(m, topo, fine_cells), exact);
  EXPECT_LT(fine, 0.5 * coarse);
  EXPECT_LT(fine, fine_limit);
}

TEST(GridFastMarching, ErrorShrinksWithResolution3d) {
  const TetMesh m = test::ball_mesh(8, 1.0);
  expect_error_shrinks(m, build_topology(m.tets, m.num_nodes()), 12, 48, 0.02);
}

TEST(GridFastMarching, ErrorShrinksWithResolution2d) {
  const TriMesh2 m = test::disc_mesh_2d(20, 1.0);
  expect_error_shrinks(m, build_topology_2d(m.triangles, static_cast<Index>(m.positions.cols())),
                       20, 100, 0.01);
}

TEST(GridFastMarching, SlabDepthIsExactAwayFromTheSides) {
  // A thin wide slab: the field is |z - z_face| except near the sides; first-order fast
  // marching along an axis is exact and multilinear interpolation of a linear field too.
  const TetMesh m = test::structured_box(20, 20, 4, {0, 0, 0}, {1, 1, 0.1});
  const Topology topo = build_topology(m.tets, m.num_nodes());
  const auto fm = *compute_depth_grid_fm(m, topo, 41);
  for (Index i = 0; i < m.num_nodes(); ++i) {
    const Eigen::Vector3d x = m.positions.col(i);
    if (std::min({x.x(), x.y(), 1 - x.x(), 1 - x.y()}) < 0.3) continue;
    EXPECT_NEAR(fm[i], std::min(x.z(), 0.1 - x.z()), 1e-9) << x.transpose();
  }
}

TEST(GridFastMarching, FlatAndTinyInputStayFinite) {
  const TetMesh t = test::single_tet();
  const Topology topo = build_topology(t.tets, t.num_nodes());
  for (const int n : {2, 3, 16}) {
    const auto d = *compute_depth_grid_fm(t, topo, n);
    for (const double v : d) {
      EXPECT_TRUE(std::isfinite(v));
      EXPECT_NEAR(v, 0.0, 1e-12);  // every node is on the boundary (a grid corner)
    }
  }
  TetMesh tiny = test::ball_mesh(4, 1e-6);
  tiny.positions.array() += 1e6;
  const Topology tt = build_topology(tiny.tets, tiny.num_nodes());
  const auto far_and_tiny = compute_depth_grid_fm(tiny, tt, 16);
  ASSERT_TRUE(far_and_tiny);
  for (const double v : *far_and_tiny) EXPECT_TRUE(std::isfinite(v));
}

}  // namespace
}  // namespace tc
