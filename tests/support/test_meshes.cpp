#include "test_meshes.hpp"

#include <cstdlib>

#include "core/mesh/geometry.hpp"

namespace tc::test {
namespace {

TetMesh from_points(const std::vector<Eigen::Vector3d>& points, std::vector<Tet> tets) {
  TetMesh mesh;
  mesh.positions.resize(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    mesh.positions.col(static_cast<Eigen::Index>(i)) = points[i];
    mesh.node_ids.push_back(static_cast<std::int64_t>(i) + 1);
  }
  mesh.tets = std::move(tets);
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

TetMesh single_tet() {
  return from_points({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 1, 2, 3}});
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

std::filesystem::path data_path(const std::string& name) {
  if (const char* dir = std::getenv("TC_TEST_DATA")) return std::filesystem::path(dir) / name;
  return std::filesystem::path(TC_SOURCE_TEST_DATA) / name;
}

std::filesystem::path mesh_path(const std::string& name) {
  return std::filesystem::path(TC_SOURCE_MESHES) / name;
}

}  // namespace tc::test
