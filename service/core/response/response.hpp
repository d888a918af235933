// Penalty response of object pairs (paper Section 5): turns detection's contacts and the
// objects' depth maps into per-node forces (and optional 3x3 stiffness blocks) on both
// objects, summed in a fixed order so the output is bit-identical whatever the thread
// count. Derivations and decisions: docs/RESPONSE.md.
//
//   compute_pair_response()   one-off: one pair -> sparse forces on A and on B
//   ResponseAccumulator       the same, keeping its buffers across pairs and frames
//   add_object_forces()       sums one pair's forces into an object's total (sorted merge)
//   cap_object_forces()       the per-node force cap (an object's max_force)
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/detect/contacts.hpp"
#include "core/response/penalty.hpp"

namespace tc {

/// Sparse per-node forces on one object for one frame.
struct ObjectForces {
  std::string object;
  std::vector<Index> nodes;                ///< sorted node indices (0-based, file order)
  std::vector<Eigen::Vector3d> forces;     ///< one per entry of nodes, N
  std::vector<Eigen::Matrix3d> stiffness;  ///< empty, or one df/dx block per entry, N/m
  std::vector<Eigen::Matrix3d> damping;    ///< empty, or one df/dv block per entry, N s/m
                                           ///< (present with the stiffness blocks)
};

/// Counts of one or more pair responses.
struct ResponseStats {
  std::size_t point_contacts = 0;         ///< point contacts that produced a force
  std::size_t segment_contacts = 0;       ///< (edge, tet) pieces that produced a force
  std::size_t inactive = 0;               ///< contacts with no force (zero depth, separating)
  std::size_t skipped = 0;                ///< contacts skipped for non-finite input
  std::size_t inverted = 0;               ///< contacts in inverted tets (processed)
  std::size_t fallback_nearest_face = 0;  ///< interpolation's gradient unusable: nearest face
  std::size_t fallback_gradient = 0;      ///< no candidate face: interpolated depth
  /// Pairs answered along one separating direction because their pushes cancelled node
  /// by node (coincident or mirror-symmetric overlaps; ResponseOptions::symmetric_ratio).
  std::size_t symmetric_pairs = 0;
  std::size_t fallback_pair = 0;  ///< ... from the pair's contact centres
  std::size_t fallback_axis = 0;  ///< ... +z
  double max_depth = 0.0;         ///< deepest penetration of an active contact, m

  void add(const ResponseStats& other);
};

/// One point contact as the response saw it (ResponseOptions::record_contacts): the
/// intruding node, the depth its force used and the unit push-out direction.
struct PointContactRecord {
  bool intruder_is_a = true;  ///< the node belongs to A (inside B), else to B (inside A)
  Index node = -1;            ///< node index in its object (0-based, file order)
  Index tet = -1;             ///< the penetrated object's tet containing it
  double depth = 0.0;         ///< metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit push-out direction
  Fallback fallback = Fallback::kNone;
};

/// One point of a contact behind the forces (ResponseOptions::report_contacts): a point
/// of the intruding object, wa x_a + wb x_b over its nodes (a point contact: its node,
/// weights (1, 0), b = -1; a segment piece: two rows, the piece's ends on edge (a, b)),
/// lying at barycentric coordinates `bary` in tet `tet` of the penetrated object, `depth`
/// metres deep, pushed out along the unit `normal`.
struct ContactRow {
  bool intruder_is_a = true;  ///< the point belongs to A (inside B), else to B (inside A)
  std::array<Index, 2> nodes{-1, -1};
  std::array<double, 2> weights{1.0, 0.0};
  Index tet = -1;
  Eigen::Vector4d bary = Eigen::Vector4d::Zero();
  double depth = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

/// The response of one pair (A, B).
struct PairResponse {
  ObjectForces a;  ///< forces on A's nodes, sorted by node (object name: the caller's)
  ObjectForces b;  ///< forces on B's nodes
  ResponseKind used_a_in_b = ResponseKind::kPoint;  ///< kPoint or kSegment (A's features in B)
  ResponseKind used_b_in_a = ResponseKind::kPoint;  ///< kPoint or kSegment (B's features in A)
  ResponseStats stats;
  /// With ResponseOptions::record_contacts: every active point contact, A's nodes in B
  /// first, by node. Where the segment response was used for a direction, the point
  /// contacts of that direction's intruding nodes are evaluated for the record only
  /// (they add no force): the rows are the same for either response.
  std::vector<PointContactRecord> point_contacts;
  /// With ResponseOptions::report_contacts: a row per active point contact and two per
  /// active segment piece, A's features in B first, in contact order.
  std::vector<ContactRow> contacts;
};

/// What kAuto measures for the features of X entering Y.
struct ContactDensity {
  double rms_edge = 0.0;        ///< RMS edge length of X's contact cells (6 per tet, 3 per
                                ///< triangle of a surface), m
  double contact_extent = 0.0;  ///< diagonal of bbox(X's contact cells) & bbox(Y's), m
};

/// Measures ContactDensity for X entering Y.
///
/// @param[in] x, y              the objects (positions and tets are read).
/// @param[in] marked_x, marked_y  contact tets of X and of Y (PairContacts::marked_*),
///                              indices into x.tets / y.tets.
ContactDensity measure_contact_density(const ResponseObject& x, std::span<const Index> marked_x,
                                       const ResponseObject& y, std::span<const Index> marked_y);

/// The paper picks the response "with respect to the mesh density": kPoint and
/// kSegment are returned as asked; kAuto gives kSegment when X's mesh is coarse
/// relative to the contact, rms_edge > threshold * contact_extent, else kPoint.
ResponseKind choose_response_kind(ResponseKind requested, const ContactDensity& density,
                                  double threshold);

/// The kinds the response of (A, B) uses: {A's features in B, B's features in A}.
/// options.kind for both unless it is kAuto; then choose_response_kind() of each
/// direction's contact density (measured on the marked tets). ResponseAccumulator uses
/// it; the pipeline asks it before the intrusion scans, so that a direction answered by
/// points skips its intruding edges.
std::array<ResponseKind, 2> response_kinds(const ResponseObject& a, std::span<const Index> marked_a,
                                           const ResponseObject& b, std::span<const Index> marked_b,
                                           const ResponseOptions& options);

/// Computes and reuses buffers for pair responses. Not thread-safe: one per thread.
class ResponseAccumulator {
 public:
  /// The response of the pair (A, B) to its contacts.
  ///
  /// Forces on A: pushes of A's nodes/edges out of B and reactions of B's nodes/edges
  /// inside A; the same for B. A pair without overlap costs nothing. Contacts are
  /// processed A-in-B points or segments first, then B-in-A, each in list order.
  ///
  /// @param[in]  a, b      the objects; positions 3 x n, metres; depth n values, metres.
  /// @param[in]  contacts  detection output for (A, B); lists sorted as documented there.
  /// @param[in]  options   response settings (validated: finite, non-negative).
  /// @param[out] out       overwritten (its vectors keep their capacity; object names are
  ///                       left as they are); blocks present iff stiffness_mode != kNone.
  /// Either object may be a surface (ResponseObject::is_surface(), docs/SURFACES.md): it
  /// has no depth map, so only its own nodes or edges in the other's tets are answered
  /// (the lists of the other direction must be empty); its marked list holds triangles.
  ///
  /// @return kInvalidArgument naming the array or the contact at fault (sizes that do
  ///         not match, indices out of range, lambda outside [0, 1], contacts pushing
  ///         out of a surface, two surfaces); out is then empty.
  Status compute(const ResponseObject& a, const ResponseObject& b, const PairContacts& contacts,
                 const ResponseOptions& options, PairResponse& out);

 private:
  struct NodeSums {
    std::vector<Eigen::Vector3d> force;
    std::vector<Eigen::Matrix3d> stiffness;
    std::vector<Eigen::Matrix3d> damping;
    std::vector<std::uint8_t> used;
    std::vector<Index> touched;
    void prepare(Index n, bool blocks);
    /// k and d (df/dx, df/dv) both null or both set.
    void add(Index node, const Eigen::Vector3d& f, const Eigen::Matrix3d* k,
             const Eigen::Matrix3d* d);
    void extract(ObjectForces& out, bool blocks);
    void clear();                            ///< forgets the sums (buffers kept)
    [[nodiscard]] double magnitude() const;  ///< sum over nodes of |force|, N
  };
  NodeSums sums_a_;
  NodeSums sums_b_;
  std::vector<ContactResult> results_;  ///< per-contact results of the parallel path
};

/// One-off form of ResponseAccumulator::compute.
Expected<PairResponse> compute_pair_response(const ResponseObject& a, const ResponseObject& b,
                                             const PairContacts& contacts,
                                             const ResponseOptions& options);

/// total += part, node by node (sorted merge; part's nodes sorted and unique). Blocks
/// (stiffness and damping) are summed when both carry them; a total without blocks takes
/// none.
void add_object_forces(ObjectForces& total, const ObjectForces& part);

/// Caps each node's force magnitude at max_force (N; <= 0: no cap). A capped force is
/// scaled to the cap and its blocks B (df/dx and df/dv) become (max_force / |f|)
/// (I - f^ f^T) B, the derivatives of the capped force. A capped node breaks the zero-sum of its
/// contacts.
/// @return the number of capped nodes.
std::size_t cap_object_forces(ObjectForces& forces, double max_force);

}  // namespace tc
