// Meshes and motions the integration tests stream: small structured boxes (from the
// shared test fixtures) converted to the client library's flat arrays.
#pragma once

#include <Eigen/Core>
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

/// Rest positions moved by `offset` (rigid translation), flat.
inline std::vector<double> translated(const client::Mesh& mesh, const Eigen::Vector3d& offset) {
  std::vector<double> p = mesh.rest_positions;
  for (std::size_t i = 0; i < p.size(); ++i) p[i] += offset[static_cast<int>(i % 3)];
  return p;
}

}  // namespace tc::itest
