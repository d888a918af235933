#include "test_meshes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "core/depth/point_simplex_distance.hpp"
#include "core/mesh/geometry.hpp"
#include "core/mesh/topology.hpp"

namespace tc::test {
namespace {

TetMesh from_points(const std::vector<Eigen::Vector3d>& points, std::vector<Tet> tets) {
  TetMesh mesh = mesh_from(points, std::move(tets));
  // Orient every tet positively so the fixtures match the Gmsh convention.
  for (Tet& t : mesh.tets)
    if (signed_volume(mesh.positions, t) < 0.0) std::swap(t[2], t[3]);
  return mesh;
}

std::vector<Eigen::Vector3d> cube_corners(double s) {
  std::vector<Eigen::Vector3d> p;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) p.emplace_back(i * s, j * s, k * s);
  return p;  // index = i + 2j + 4k
}

}  // namespace

double brute_force_sq_distance_to_boundary(const TetMesh& m, const Topology& topology,
                                           const Eigen::Vector3d& p) {
  double best = INFINITY;
  for (const auto& f : topology.boundary_faces)
    best = std::min(best, point_triangle_distance(p, Eigen::Vector3d(m.positions.col(f[0])),
                                                  Eigen::Vector3d(m.positions.col(f[1])),
                                                  Eigen::Vector3d(m.positions.col(f[2])))
                              .sq_dist);
  return best;
}

TetMesh mesh_from(const std::vector<Eigen::Vector3d>& points, std::vector<Tet> tets) {
  TetMesh mesh;
  mesh.positions.resize(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    mesh.positions.col(static_cast<Eigen::Index>(i)) = points[i];
    mesh.node_ids.push_back(static_cast<std::int64_t>(i) + 1);
  }
  mesh.tets = std::move(tets);
  return mesh;
}

TetMesh single_tet() {
  return from_points({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 1, 2, 3}});
}

TetMesh regular_tet() {
  return from_points({{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}}, {{1, 0, 2, 3}});
}

TetMesh two_tets_sharing_face() {
  return from_points({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}},
                     {{0, 1, 2, 3}, {4, 1, 3, 2}});
}

TetMesh cube_five_tets(double s) {
  // Corners 0..7 with index i + 2j + 4k; the central tet uses 1, 2, 4, 7.
  return from_points(cube_corners(s),
                     {{0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}, {1, 2, 4, 7}});
}

TetMesh cube_six_tets(double s) {
  // Six tets around the diagonal 0-7.
  return from_points(
      cube_corners(s),
      {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7}, {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}});
}

TetMesh structured_box(int nx, int ny, int nz, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi) {
  std::vector<Eigen::Vector3d> points;
  const auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i)
        points.emplace_back(lo.x() + (hi.x() - lo.x()) * i / nx,
                            lo.y() + (hi.y() - lo.y()) * j / ny,
                            lo.z() + (hi.z() - lo.z()) * k / nz);
  std::vector<Tet> tets;
  const int cube_tets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                               {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        Index c[8];
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + ((b >> 1) & 1), k + (b >> 2));
        for (const auto& t : cube_tets) tets.push_back({c[t[0]], c[t[1]], c[t[2]], c[t[3]]});
      }
  return from_points(points, std::move(tets));
}

TetMesh ball_mesh(int n, double r) {
  TetMesh mesh = structured_box(n, n, n, {-1, -1, -1}, {1, 1, 1});
  for (Eigen::Index i = 0; i < mesh.positions.cols(); ++i) {
    const double x = mesh.positions(0, i), y = mesh.positions(1, i), z = mesh.positions(2, i);
    const double x2 = x * x, y2 = y * y, z2 = z * z;
    mesh.positions(0, i) = r * x * std::sqrt(1 - y2 / 2 - z2 / 2 + y2 * z2 / 3);
    mesh.positions(1, i) = r * y * std::sqrt(1 - z2 / 2 - x2 / 2 + z2 * x2 / 3);
    mesh.positions(2, i) = r * z * std::sqrt(1 - x2 / 2 - y2 / 2 + x2 * y2 / 3);
  }
  for (Tet& t : mesh.tets)
    if (signed_volume(mesh.positions, t) < 0.0) std::swap(t[2], t[3]);
  return mesh;
}

TetMesh torus_mesh(int ring_cells, int tube_cells, double big_r, double a) {
  const int m = tube_cells;
  const auto id = [&](int i, int j, int k) {
    return ((i % ring_cells) * (m + 1) + j) * (m + 1) + k;
  };
  std::vector<Eigen::Vector3d> points;
  const double pi = std::acos(-1.0);
  for (int i = 0; i < ring_cells; ++i)
    for (int j = 0; j <= m; ++j)
      for (int k = 0; k <= m; ++k) {
        const double x = -1.0 + 2.0 * j / m, y = -1.0 + 2.0 * k / m;
        const double u = a * x * std::sqrt(1 - y * y / 2), v = a * y * std::sqrt(1 - x * x / 2);
        const double theta = 2 * pi * i / ring_cells;
        points.emplace_back((big_r + u) * std::cos(theta), (big_r + u) * std::sin(theta), v);
      }
  std::vector<Tet> tets;
  const int cube_tets[6][4] = {{0, 1, 3, 7}, {0, 3, 2, 7}, {0, 2, 6, 7},
                               {0, 6, 4, 7}, {0, 4, 5, 7}, {0, 5, 1, 7}};
  for (int i = 0; i < ring_cells; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k) {
        Index c[8];
        for (int b = 0; b < 8; ++b) c[b] = id(i + (b & 1), j + ((b >> 1) & 1), k + (b >> 2));
        for (const auto& t : cube_tets) tets.push_back({c[t[0]], c[t[1]], c[t[2]], c[t[3]]});
      }
  return from_points(points, std::move(tets));
}

TriMesh2 rect_mesh_2d(int nx, int ny, double w, double h) {
  TriMesh2 mesh;
  mesh.positions.resize(2, (nx + 1) * (ny + 1));
  const auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      mesh.positions.col(id(i, j)) = Eigen::Vector2d(w * i / nx, h * j / ny);
      mesh.node_ids.push_back(id(i, j) + 1);
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      mesh.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      mesh.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return mesh;
}

SurfaceMesh cube_surface(double s, const Eigen::Vector3d& o) {
  SurfaceMesh m;
  m.positions.resize(3, 8);
  for (int i = 0; i < 8; ++i) {
    m.positions.col(i) = o + s * Eigen::Vector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    m.node_ids.push_back(i + 1);
  }
  // Each face as a quad (a, b, c, d), counter-clockwise seen from outside.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
  }
  return m;
}

SurfaceMesh square_surface(int n, double w, double z) {
  SurfaceMesh m;
  m.positions.resize(3, (n + 1) * (n + 1));
  const auto id = [&](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      m.positions.col(id(i, j)) = Eigen::Vector3d(w * i / n, w * j / n, z);
      m.node_ids.push_back(id(i, j) + 1);
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

SurfaceMesh boundary_surface_of(const TetMesh& mesh) {
  const Topology topo = build_topology(mesh.tets, mesh.num_nodes());
  SurfaceMesh s;
  s.node_ids = mesh.node_ids;
  s.positions = mesh.positions;
  s.triangles.assign(topo.boundary_faces.begin(), topo.boundary_faces.end());
  return s;
}

TriMesh2 disc_mesh_2d(int n, double r) {
  TriMesh2 mesh = rect_mesh_2d(n, n, 2.0, 2.0);
  for (Eigen::Index i = 0; i < mesh.positions.cols(); ++i) {
    const double x = mesh.positions(0, i) - 1.0, y = mesh.positions(1, i) - 1.0;
    mesh.positions(0, i) = r * x * std::sqrt(1 - y * y / 2);
    mesh.positions(1, i) = r * y * std::sqrt(1 - x * x / 2);
  }
  return mesh;
}

std::filesystem::path data_path(const std::string& name) {
  if (const char* dir = std::getenv("TC_TEST_DATA")) return std::filesystem::path(dir) / name;
  return std::filesystem::path(TC_SOURCE_TEST_DATA) / name;
}

std::filesystem::path mesh_path(const std::string& name) {
  return std::filesystem::path(TC_SOURCE_MESHES) / name;
}

}  // namespace tc::test
