// Self-contact of one tet object (docs/DETECTION.md, "Self-contact"): two tets of the
// object that share no node and whose interiors overlap, and the nodes and edges of the
// object inside tets of the same object that do not contain them. The fragments of a cut
// object (several connected components) and a fold of one component are both covered.
//
// Two stages a frame:
//   1. The surface gate. A BVH over the boundary triangles (built once, refitted every
//      frame) is traversed against itself; a node whose triangles form one connected patch
//      with normals inside a cone of half-angle below 90 degrees cannot intersect itself
//      and is skipped (normal-cone culling). Two triangles that share no node are tested
//      for crossing. In a mesh without inverted tets, two tets overlap only where the
//      boundary crosses itself, so a frame without a crossing stops here.
//   2. The tets. Where the boundary crosses, the boundary nodes inside tets of the object
//      that do not contain them are flooded from the crossing triangles; the region is
//      the box of those triangles and nodes, and every tet pair that can overlap meets it.
//      Tets there are tested exactly (tets_overlap, the detection tolerance), then their
//      nodes and edges (point_in_tet, clip_segment_tet), as between two objects.
// The contacts are grouped by pair of components (ca <= cb) in the PairContacts form of
// two objects, A being component ca's side: two components of one object get exactly the
// contacts that the same two meshes get as two objects. Every list is sorted, so the
// output is bit-identical whatever the thread count.
// Not found: a component lying entirely inside another one without any boundary crossing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/detect/broad_phase.hpp"
#include "core/detect/contacts.hpp"
#include "core/detect/tet_overlap.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// The self-contacts between two components of one object (or of one component with
/// itself, ca == cb). Tet, node and edge indices are the object's. For ca < cb, A is the
/// side of component ca: overlapping (tet of ca, tet of cb), nodes_a_in_b the nodes of ca in
/// tets of cb, and so on. For ca == cb, every overlapping pair is (lower tet, higher tet),
/// marked_a and marked_b both hold every tet of the part, and every intruding node and edge
/// is in nodes_a_in_b / edges_a_in_b (the b_in_a lists are empty).
struct SelfContactPart {
  Index component_a = 0;
  Index component_b = 0;
  PairContacts contacts;
};

/// A frame's self-contacts of one object.
struct SelfContacts {
  std::vector<SelfContactPart> parts;  ///< by (component_a, component_b)
  std::vector<Index> marked;           ///< every tet of a self-overlap, sorted
  [[nodiscard]] bool empty() const { return parts.empty(); }
  void clear() {
    parts.clear();
    marked.clear();
  }
};

/// What one SelfCollider::detect() call did.
struct SelfDetectStats {
  /// The boundary moved less than the last gate's certificate allows: no crossing, and
  /// nothing else ran (SelfCollider::detect).
  bool certified = false;
  /// ... told by the shape check's MotionBound, without a pass over the boundary nodes.
  bool certified_by_bound = false;
  /// The certificate a gate that found no crossing left: how far each boundary node may
  /// move (after a common translation) before the next gate runs, metres.
  double certificate = 0.0;
  std::size_t surface_pairs = 0;   ///< boundary triangle pairs tested for crossing
  std::size_t crossing_pairs = 0;  ///< ... that cross (0: the frame stopped at the gate)
  std::size_t flooded_nodes = 0;   ///< boundary nodes found inside another tet of the object
  std::size_t region_tets = 0;     ///< tets whose box meets the region
  std::size_t candidates = 0;      ///< tet pairs tested exactly
  std::size_t overlapping = 0;     ///< tet pairs that overlap
  double surface_ms = 0.0;         ///< stage 1
  double tets_ms = 0.0;            ///< stage 2
};

/// Self-contact detection of one tet object. Built once per topology; detect() per frame.
/// Not thread-safe for one instance (its loops use TBB).
class SelfCollider {
 public:
  /// @param[in] tets      m tets (validated), indices into the object's n nodes; kept by
  ///                      reference: it must outlive the collider, unchanged
  /// @param[in] topology  build_topology() of the same tets; kept by reference too
  /// @param[in] rest      3 x n rest positions: they shape the surface BVH (any positions
  ///                      work; these only decide its cost)
  SelfCollider(std::span<const Tet> tets, const Topology& topology, const Positions& rest);
  ~SelfCollider();
  SelfCollider(const SelfCollider&) = delete;
  SelfCollider& operator=(const SelfCollider&) = delete;

  /// The self-contacts at `positions` (3 x n, finite, no inverted tet: the pipeline's
  /// state check). `relative_tolerance` as DetectOptions::relative_tolerance.
  ///
  /// A gate that finds no crossing also measures how far every boundary node could move
  /// (after one common translation) before any of its decisions could change: a box gap, a
  /// triangle pair's separation, a normal cone's slack to 90 degrees (docs/DETECTION.md,
  /// "Self-contact"). While the boundary stays that close to those positions, later calls
  /// answer "no self-contact" from one pass over the boundary nodes; or from none, given
  /// `bound`: what the shape check (ShapeCheck::bound) proved of these same positions, in
  /// every call since the certificate (its versions tell): every node within
  /// MotionBound::motion of its reference after a shift, which with how far the references
  /// lie from the certificate's positions bounds every node's motion.
  void detect(const Positions& positions, double relative_tolerance, SelfContacts& out,
              SelfDetectStats* stats = nullptr, const MotionBound* bound = nullptr);

 private:
  struct SurfaceNode;
  struct Frame;
  void build_surface_tree(const Positions& rest);
  bool surface_gate(const Positions& x, double relative_tolerance, SelfDetectStats& st);
  // The steps of surface_gate().
  /// Each boundary face's box, unit normal (zero when degenerate) and reach at `x`
  /// (face_boxes_, face_normals_, face_reach_).
  void measure_faces(const Positions& x);
  /// The surface tree's boxes, normal cones and reaches from the faces', bottom-up.
  void refit_surface_tree();
  /// The tree against itself: the crossing face pairs into crossing_ (unsorted), and the
  /// returned certificate, how far every corner may move (after a common translation) with
  /// every decision unchanged (infinity when nothing bounds it).
  double traverse_surface(const Positions& x, double relative_tolerance, SelfDetectStats& st);
  /// Keeps `cert` as cert_ with the boundary nodes' positions (cert_x_) when nothing
  /// crosses; else no certificate.
  void keep_certificate(const Positions& x, double cert, SelfDetectStats& st);
  /// True when the boundary nodes of `x` lie within cert_ of cert_x_ after removing one
  /// common translation: by `bound` (within_bound), else after removing their mean
  /// displacement.
  [[nodiscard]] bool within_certificate(const Positions& x, const MotionBound* bound,
                                        SelfDetectStats& st);
  /// The bound's part of within_certificate(): true when it proves it; keeps offset_.
  [[nodiscard]] bool within_bound(const MotionBound* bound);
  /// Starts keeping offset_ from `bound` (of positions within the certificate); `pass`:
  /// measure it over the boundary nodes, else the certificate was taken at these positions.
  void sync_bound(const MotionBound* bound, bool pass);
  Aabb flood_region(const Positions& x, double relative_tolerance, SelfDetectStats& st);
  void tet_stage(const Positions& x, const Aabb& region, double relative_tolerance,
                 SelfContacts& out, SelfDetectStats& st);

  std::span<const Tet> tets_;
  const Topology& topology_;
  // The surface BVH: nodes in pre-order (left child = next node), item ranges contiguous.
  std::vector<SurfaceNode> nodes_;
  std::vector<Index> items_;  ///< boundary faces in tree order
  /// Per tree node, its border: the corners of its faces that are corners of faces outside
  /// it too, sorted. Two nodes share a corner only on both their borders.
  Csr borders_;
  [[nodiscard]] bool adjacent(Index a, Index b) const;
  // Tet edges (the segment response's features): each tet's 6 edge ids (kTetEdges order,
  // ids into topology.edges) and each edge's tets.
  std::vector<std::array<Index, 6>> tet_edges_;
  Csr edge_tets_;
  // Per-frame buffers.
  // The certificate of the last gate that found no crossing: the boundary nodes'
  // positions then (by Topology::boundary_nodes) and how far each may move, metres (0:
  // none).
  std::vector<Eigen::Vector3d> cert_x_;
  double cert_ = 0.0;
  double cert_scale_ = 0.0;  ///< the largest coordinate of cert_x_ (for rounding)
  // The certificate by the shape check's bound (within_bound): while synced_, every
  // boundary node's reference (MotionBound::reference, version sync_version_) plus
  // sync_shift_ lies within offset_ of its cert_x_.
  bool synced_ = false;
  std::uint64_t sync_version_ = 0;
  Eigen::Vector3d sync_shift_ = Eigen::Vector3d::Zero();
  double offset_ = 0.0;
  /// Node or triangle boxes nearer than this (a twentieth of the mean boundary edge at
  /// rest) are looked into, not certified by their gap alone.
  double near_gap_ = 0.0;
  std::vector<double> face_reach_;  ///< per face: displacement that turns its normal <= slack
  std::vector<Aabb> face_boxes_;
  std::vector<Eigen::Vector3d> face_normals_;
  std::vector<std::array<Index, 2>> crossing_;  ///< boundary face pairs that cross
  std::vector<Aabb> tet_boxes_;
  AabbTree tet_tree_;
  bool tet_tree_built_ = false;
};

}  // namespace tc
