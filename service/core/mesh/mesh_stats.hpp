// Summary numbers of a mesh, as printed by `tetcollide mesh info`.
#pragma once

#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"

namespace tc {

struct MeshStats {
  Index nodes = 0;  ///< all nodes in the file, orphans included
  Index tets = 0;
  Index boundary_faces = 0;
  Index boundary_edges = 0;
  Index boundary_nodes = 0;
  Index components = 0;  ///< face-connected components of tets
  Index orphan_nodes = 0;
  std::size_t degenerate_tets = 0;
  std::size_t inverted_tets = 0;
  std::size_t sliver_tets = 0;
  double volume = 0.0;            ///< sum of |tet volume|, m^3
  double bbox_diagonal = 0.0;     ///< of all finite node positions, m
  double mean_edge_length = 0.0;  ///< over unique tet edges, m
  double min_quality = 0.0;       ///< smallest tet_quality()
};

/// Computes the statistics of a mesh whose indices are in range.
MeshStats compute_mesh_stats(const TetMesh& mesh, const Topology& topo,
                             const ValidationReport& report);

}  // namespace tc
