// What detection hands to the depth map and the response, for one ordered object pair
// (A, B). Every list is sorted and free of duplicates, so the output is bit-identical
// whatever the thread count.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// Two overlapping tets: tet_a of object A, tet_b of object B (0-based, file order).
struct TetPair {
  Index tet_a;
  Index tet_b;
  friend bool operator==(const TetPair&, const TetPair&) = default;
  friend auto operator<=>(const TetPair&, const TetPair&) = default;
};

/// A node of one object inside a tet of the other, with its barycentric coordinates
/// in that tet (bary[k] weights the tet's k-th node; they sum to 1, all >= 0 up to the
/// detection tolerance). Listed once per node: the first containing tet in tet order.
struct IntrudingNode {
  Index node;
  Index tet;
  Eigen::Vector4d bary;
};

/// An edge of one object crossing a tet of the other. `edge` indexes the owner's
/// Topology::edges (a, b) with a < b; the part inside the tet is
/// x = a + lambda (b - a) for lambda in [lambda_in, lambda_out], 0 <= in <= out <= 1.
/// Listed once per (edge, tet) pair, however many tets share the edge.
struct IntrudingEdge {
  Index edge;
  Index tet;
  double lambda_in;
  double lambda_out;
};

/// Detection result for one object pair (A, B).
struct PairContacts {
  std::vector<TetPair> overlapping;         ///< sorted by (tet_a, tet_b)
  std::vector<Index> marked_a;              ///< tets of A in some overlap, sorted
  std::vector<Index> marked_b;              ///< tets of B in some overlap, sorted
  std::vector<IntrudingNode> nodes_a_in_b;  ///< nodes of A inside tets of B, by node
  std::vector<IntrudingNode> nodes_b_in_a;  ///< nodes of B inside tets of A, by node
  std::vector<IntrudingEdge> edges_a_in_b;  ///< edges of A crossing tets of B, by (edge, tet)
  std::vector<IntrudingEdge> edges_b_in_a;  ///< edges of B crossing tets of A, by (edge, tet)

  [[nodiscard]] bool empty() const { return overlapping.empty(); }
};

}  // namespace tc
