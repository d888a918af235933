// Meshes and motions the integration tests stream: small structured boxes (from the
// shared test fixtures) converted to the client library's flat arrays.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <vector>

#include "test_meshes.hpp"
#include "tetcollide/client.hpp"

namespace tc::itest {

/// Flat-array mesh of a structured box over [lo, hi] with n^3 cells.
inline client::Mesh box_mesh(int n, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const TetMesh m = test::structured_box(n, n, n, lo, hi);
  client::Mesh out;
  out.node_ids = m.node_ids;
  out.rest_positions.assign(m.positions.data(), m.positions.data() + m.positions.size());
  for (const Tet& t : m.tets) out.tets.insert(out.tets.end(), t.begin(), t.end());
  return out;
}

/// Flat-array surface object (issue 19): the square [x0, x0 + w] x [y0, y0 + w] at
/// height z in n x n cells, two triangles each (test::square_surface moved).
inline client::Mesh plate_mesh(int n, double w, const Eigen::Vector3d& corner) {
  SurfaceMesh m = test::square_surface(n, w, corner.z());
  client::Mesh out;
  out.node_ids = m.node_ids;
  for (Eigen::Index i = 0; i < m.positions.cols(); ++i)
    for (int k = 0; k < 3; ++k)
      out.rest_positions.push_back(m.positions(k, i) + (k < 2 ? corner[k] : 0.0));
  for (const Triangle& t : m.triangles)
    out.triangles.insert(out.triangles.end(), t.begin(), t.end());
  return out;
}

/// Rest positions moved by `offset` (rigid translation), flat.
inline std::vector<double> translated(const client::Mesh& mesh, const Eigen::Vector3d& offset) {
  std::vector<double> p = mesh.rest_positions;
  for (std::size_t i = 0; i < p.size(); ++i) p[i] += offset[static_cast<int>(i % 3)];
  return p;
}

/// Two overlapping boxes that also reach below z = 0, moving a little every frame.
struct TwoBoxes {
  client::Mesh a = box_mesh(3, {-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5});
  client::Mesh b = box_mesh(3, {0.3, -0.4, -0.4}, {1.3, 0.6, 0.6});
  [[nodiscard]] std::vector<double> pos_a(std::int64_t f) const {
    return translated(a, {0.0, 0.0, 0.001 * static_cast<double>(f % 50)});
  }
  [[nodiscard]] std::vector<double> pos_b(std::int64_t f) const {
    return translated(b, {-0.002 * static_cast<double>(f % 50), 0.0, 0.0});
  }
  /// Registers both as "a" and "b" (default parameters) and waits up to 10 s for each,
  /// then for a reader of the states (a state written before the service's reader is
  /// matched reaches nobody: client.hpp's first example); true when all three came.
  bool register_with(client::Client& c) const {
    c.register_object("a", a, {});
    c.register_object("b", b, {});
    return c.wait_registered("a", std::chrono::seconds(10)).ok &&
           c.wait_registered("b", std::chrono::seconds(10)).ok &&
           c.wait_for_readers(1, std::chrono::seconds(10));
  }
};

}  // namespace tc::itest
