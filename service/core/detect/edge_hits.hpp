// Internal to service/core/detect: the pieces of one edge clipped by the tets around it,
// as tet-tet detection (detect.cpp) and surface-tet detection (surface_detect.cpp) both
// collect them, and the rule that keeps a piece lying in a shared face once.
#pragma once

#include <cmath>
#include <cstddef>
#include <span>
#include <vector>

#include "core/detect/contacts.hpp"

namespace tc::detail {

/// One tet's piece of an edge, with the detection tolerance in lambda units.
struct EdgeHit {
  IntrudingEdge edge;
  double dl;
};

/// Appends the hits of one edge, in the given (tet) order, to `out`, except a hit whose
/// interval equals (within its dl) one already appended for this edge: an edge lying in a
/// face (or along an edge) shared by several tets is inside each over the same interval,
/// and only the first tet keeps it, so the response does not count that stretch twice.
inline void append_edge_hits(std::span<const EdgeHit> hits, std::vector<IntrudingEdge>& out) {
  const std::size_t first = out.size();
  for (const EdgeHit& h : hits) {
    bool repeated = false;
    for (std::size_t k = first; k < out.size() && !repeated; ++k)
      repeated = std::abs(out[k].lambda_in - h.edge.lambda_in) <= h.dl &&
                 std::abs(out[k].lambda_out - h.edge.lambda_out) <= h.dl;
    if (!repeated) out.push_back(h.edge);
  }
}

}  // namespace tc::detail
