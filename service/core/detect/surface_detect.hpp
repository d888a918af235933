// Detection between a triangle surface and a tet mesh (paper Fig. 14: "point-in-
// tetrahedron and segment-in-tetrahedron response when triangles intersect
// tetrahedrons"): object boxes, the broad phase of tet-tet detection on triangle and
// tet boxes, exact triangle-tet overlap, then the surface's vertices inside tets and its
// edges clipped by tets. Two surfaces are never tested against each other. Units:
// metres. See docs/DETECTION.md, "Surface against tets".
#pragma once

#include <span>
#include <vector>

#include "core/detect/contacts.hpp"
#include "core/detect/detect.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// A triangle of the surface overlapping a tet of the tet object (0-based, file order).
struct TriTetPair {
  Index triangle;
  Index tet;
  friend bool operator==(const TriTetPair&, const TriTetPair&) = default;
  friend auto operator<=>(const TriTetPair&, const TriTetPair&) = default;
};

/// Detection result for one (surface, tet object) pair. Every list is sorted and free of
/// duplicates, bit-identical whatever the thread count.
struct SurfaceContacts {
  std::vector<TriTetPair> overlapping;  ///< sorted by (triangle, tet)
  std::vector<Index> marked_triangles;  ///< triangles in some overlap, sorted
  std::vector<Index> marked_tets;       ///< tets in some overlap, sorted (the depth map's input)
  /// Surface nodes inside a tet (point-in-tet): for each node of a marked triangle, the
  /// first tet in tet order, among those its marked triangles overlap, that contains it
  /// (closed test), with its barycentric coordinates. Sorted by node.
  std::vector<IntrudingNode> nodes_in_tets;
  /// Surface edges crossing tets (segment-in-tet): `edge` indexes SurfaceEdges::edges;
  /// for each edge of a marked triangle, each tet its marked triangles overlap, clipped;
  /// an edge lying in a face (or along an edge) shared by several tets is listed for the
  /// first of them only. Sorted by (edge, tet).
  std::vector<IntrudingEdge> edges_in_tets;

  [[nodiscard]] bool empty() const { return overlapping.empty(); }
};

/// What one call did.
struct SurfaceDetectStats {
  bool boxes_overlap = false;        ///< object boxes touch (else nothing else ran)
  std::size_t triangles_in_box = 0;  ///< triangles whose box meets the overlap box
  std::size_t tets_in_box = 0;       ///< tets whose box meets the overlap box
  std::size_t candidates = 0;        ///< (triangle, tet) pairs out of the broad phase
  std::size_t overlapping = 0;       ///< pairs out of the exact test
};

/// Contacts between a surface (positions 3 x n_s metres, k triangles, their edges from
/// build_surface_edges) and a tet object (positions 3 x n_t metres, m tets), for one
/// frame. Indices must be in range (validate first). Uses options.broad_phase (all four
/// methods give the same candidates; `grid` rounds triangles by spheres too),
/// options.relative_tolerance (times the pair's, tet's, or tet-and-edge's largest box
/// extent, as for tet pairs), options.intruding_nodes and options.intruding_edges.
/// Triangles or tets with a non-finite corner take part in nothing, nor do the tets in
/// `left_out_tets` (sorted; CollisionBody::set_left_out_tets()).
///
/// Cost: one box test per triangle and per tet (the cull to the two objects' overlap
/// box), then work and memory that follow the contact: the tables it reads (node ->
/// marked triangles, edge -> marked triangles, the geometry of the candidate tets) are
/// built from the contact alone, never as arrays over all nodes, edges or tets.
/// @throws std::invalid_argument when `edges` was not built from `triangles`
SurfaceContacts detect_surface_tets(const Positions& surface_positions,
                                    std::span<const Triangle> triangles, const SurfaceEdges& edges,
                                    const Positions& tet_positions, std::span<const Tet> tets,
                                    const DetectOptions& options = {},
                                    SurfaceDetectStats* stats = nullptr,
                                    std::span<const Index> left_out_tets = {});

/// The contacts of a (surface, tet object) pair in the form the response reads
/// (ResponseAccumulator::compute): the surface is A when surface_is_a, else B. Its nodes
/// and edges in tets become nodes_a_in_b / edges_a_in_b (or the b_in_a lists), its
/// marked triangles marked_a (or marked_b), and the overlapping pairs are
/// (triangle, tet) (or (tet, triangle)), sorted; the other direction's lists stay empty.
PairContacts to_pair_contacts(SurfaceContacts contacts, bool surface_is_a);

}  // namespace tc
