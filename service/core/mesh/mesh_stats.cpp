#include "core/mesh/mesh_stats.hpp"

#include <cmath>

#include "core/mesh/geometry.hpp"

namespace tc {

MeshStats compute_mesh_stats(const TetMesh& mesh, const Topology& topo,
                             const ValidationReport& report) {
  MeshStats s;
  s.nodes = mesh.num_nodes();
  s.tets = mesh.num_tets();
  s.boundary_faces = static_cast<Index>(topo.boundary_faces.size());
  s.boundary_edges = static_cast<Index>(topo.boundary_edges.size());
  s.boundary_nodes = static_cast<Index>(topo.boundary_nodes.size());
  s.components = topo.num_components;
  s.orphan_nodes = static_cast<Index>(topo.orphan_nodes.size());
  s.degenerate_tets = report.degenerate.count;
  s.inverted_tets = report.inverted.count;
  s.sliver_tets = report.sliver.count;
  s.min_quality = mesh.tets.empty() ? 0.0 : report.min_quality;
  for (const Tet& t : mesh.tets) s.volume += std::abs(signed_volume(mesh.positions, t));
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-INFINITY);
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    if (!mesh.positions.col(i).allFinite()) continue;
    lo = lo.cwiseMin(mesh.positions.col(i));
    hi = hi.cwiseMax(mesh.positions.col(i));
  }
  if ((hi - lo).allFinite()) s.bbox_diagonal = (hi - lo).norm();
  double sum = 0.0;
  for (const auto& e : topo.edges)
    sum += (mesh.positions.col(e[0]) - mesh.positions.col(e[1])).norm();
  if (!topo.edges.empty()) s.mean_edge_length = sum / static_cast<double>(topo.edges.size());
  return s;
}

}  // namespace tc
