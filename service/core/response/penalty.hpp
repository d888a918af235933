// Penalty forces of one contact (paper Section 5): a node of an intruding object X inside
// a tet of the penetrated object Y (point-in-object, 5.1), or the part of an edge of X
// inside a tet of Y (segment-in-object, 5.2). The force pushes X's node(s) out of Y along
// the depth gradient of Y; the equal and opposite reaction goes to the four nodes of Y's
// tet with the barycentric weights of the point(s) of application, so every contact has
// zero net force and zero net moment. Derivations: docs/RESPONSE.md.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/depth/self_depth.hpp"
#include "core/detect/contacts.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/mesh/topology.hpp"

namespace tc {

/// Which penalty response an object pair uses: point-in-object (5.1), segment-in-object
/// (5.2), or kAuto, by mesh density (docs/RESPONSE.md section 6).
enum class ResponseKind { kPoint, kSegment, kAuto };

/// Short name of a response kind ("point", "segment", "auto").
const char* response_kind_name(ResponseKind kind);
/// The kind of a short name (response_kind_name's inverse); nullopt for any other text.
std::optional<ResponseKind> parse_response_kind(std::string_view name);

/// What a unit of penetration is measured against.
enum class ForceMeasure {
  /// Default. The penalty is a force per metre of the intruding object's edges:
  /// stiffness k in N/m^2 (N per metre of depth per metre of edge), damping in N s/m^2.
  /// The segment response integrates k d along the clipped edge in arc length; the point
  /// response lumps the same integral on the node: weight w = half the summed length of
  /// the node's edges. Both are quadratures of one functional (docs/RESPONSE.md).
  kEdgeLength,
  /// The paper's plain penalty spring: f = k d n per intruding node, k in N/m, damping
  /// in N s/m; the segment response integrates over the edge parameter lambda in [0, 1].
  kUnit,
};

/// Which 3x3 blocks df/dx (N/m) come with the forces. They are the diagonal blocks of
/// the Jacobian: node i's force against node i's own position; node-to-node coupling is
/// not returned (ObjectForces has one block per node).
enum class StiffnessMode {
  kNone,
  /// Default when blocks are wanted: the dominant term -k w |grad d| n n^T, lumped per
  /// object by row sums (the intruding node gets its own block, the penetrated tet's
  /// node k gets beta_k times it; segment ends get the integral of their hat function).
  /// Symmetric, negative semi-definite, and never softer than the coupled contact
  /// stiffness of either object, so a block-diagonal implicit solve stays stable.
  kLumped,
  /// The exact diagonal blocks of the elastic force with the depth values held fixed
  /// (depth, direction, barycentric-weight, edge-length and clip-limit terms; not
  /// symmetric). Contacts on the fallback path get the kLumped blocks.
  kExact,
};

/// Where a contact's depth and push-out direction come from (docs/RESPONSE.md,
/// "Depth and direction").
enum class DepthEvaluation : std::uint8_t {
  /// Default. The distance from the point to the nearest boundary face of the penetrated
  /// object among the faces around the tet's four nodes and around their anchors (the
  /// boundary nodes the depth map measured them to, ResponseObject::anchor); the
  /// direction points to that face's closest point. Never below the exact depth.
  kNearestFace,
  /// The paper's 5.1: the node depths interpolated linearly in the tet, the direction
  /// from their gradient. Far off near faces the tet does not touch (10% of the point
  /// contacts of a coarse face-on-face contact off by more than 10%, RESPONSE.md).
  kInterpolate,
};

/// The relative tangential speed below which friction is regularised when no object
/// asks for another (ObjectParams::friction_velocity = 0), m/s: a body held by friction
/// creeps at most at about this speed times tan(theta) / mu (docs/RESPONSE.md, "Friction").
inline constexpr double kDefaultFrictionVelocity = 1e-3;

/// Settings of the response of one object pair.
struct ResponseOptions {
  ResponseKind kind = ResponseKind::kAuto;  ///< point, segment, or by mesh density
  /// Set: the kinds {A's features in B, B's features in A} already decided by
  /// response_kinds() on the same contacts (the pipeline decides before detection's edge
  /// scans); `kind` is then not read. Each must be kPoint or kSegment.
  std::optional<std::array<ResponseKind, 2>> decided_kinds;
  double stiffness = 1e4;  ///< k >= 0; units per `measure`
  double damping = 0.0;    ///< c >= 0 on the penetration rate; units per `measure`
  /// Coulomb coefficient mu >= 0: each contact's tangential force opposes the relative
  /// tangential velocity with magnitude mu |normal push| f1(|v_t| / friction_velocity),
  /// f1(y) = 2y - y^2 below 1, 1 above (smoothed Coulomb; docs/RESPONSE.md "Friction").
  double friction = 0.0;
  double friction_velocity = kDefaultFrictionVelocity;  ///< eps_v > 0, m/s
  ForceMeasure measure = ForceMeasure::kEdgeLength;
  StiffnessMode stiffness_mode = StiffnessMode::kNone;
  /// The paper's behaviour: push the intruding node(s) only, no reaction on the
  /// penetrated object (net force no longer zero).
  bool push_point_only = false;
  /// kAuto picks the segment response for the features of X entering Y when the RMS
  /// edge length of X's contact tets exceeds this fraction of the contact extent (the
  /// diagonal of the overlap of the two objects' contact-tet boxes). Dimensionless.
  double auto_threshold = 0.25;
  DepthEvaluation evaluation = DepthEvaluation::kNearestFace;
  /// Fill PairResponse::point_contacts (an audit of depths and directions).
  bool record_contacts = false;
  /// Fill PairResponse::contacts: the contacts behind the forces, for clients that build
  /// their own constraints (ObjectParams::contacts, docs/PROTOCOL.md "Contacts").
  bool report_contacts = false;
  /// A pair whose summed per-node forces fall below this fraction of the summed pushes
  /// on the intruding nodes, with pushes both ways, is a symmetric overlap and is
  /// answered along one separating direction (docs/RESPONSE.md); 0 = never.
  double symmetric_ratio = 0.1;
  /// Every contact pushes along the pair direction given to the kernel (its depth as
  /// usual): the separating pass of a symmetric overlap.
  bool along_pair_direction = false;
  /// Depth gradients are trusted when min_gradient <= |grad d| <= max_gradient
  /// (dimensionless: a distance field has |grad d| = 1); otherwise the fallback
  /// direction is used (equal node depths, four boundary nodes, slivers, flat tets).
  double min_gradient = 1e-6;
  double max_gradient = 10.0;
  /// Point or segment contacts per direction above which the per-contact work runs in
  /// parallel (TBB); the forces are summed in contact order either way.
  std::size_t parallel_threshold = 64;
};

/// What the response reads of an object to answer its self-contact (docs/RESPONSE.md,
/// "Self-contact"): a node pushed out of a tet of its own object is pushed through the
/// nearest boundary face of the penetrated part that is not of the node's own
/// neighbourhood. A face of another component is never of it; a face of the node's own
/// component is when one of its corners lies within `rings` mesh edges of the node (of
/// either end of an intruding edge).
struct SelfContactView {
  std::span<const Index> node_component;  ///< n: component of each node (-1: no tet)
  int rings = kSelfContactRings;
};

/// The face-connected component of each node's first tet (-1 for a node of no tet): the
/// SelfContactView's node_component, built once per topology.
std::vector<Index> node_components(const Topology& topology);

/// Read-only view of one object in a pair. Every pointer must outlive the call.
struct ResponseObject {
  const Positions* positions = nullptr;   ///< 3 x n node positions, metres
  std::span<const Tet> tets;              ///< m tets, indices into positions
  const Topology* topology = nullptr;     ///< topology of `tets` (edges, node_adjacency,
                                          ///< node_tets, tet_neighbors)
  std::span<const double> depth;          ///< n depth values, metres: 0 on the boundary,
                                          ///< > 0 inside; must be finite on the nodes of
                                          ///< the tets named by the contacts
  const Positions* velocities = nullptr;  ///< optional 3 x n, m/s (damping only)
  std::span<const Index> anchor;          ///< n anchors (DepthSolver::anchor()), or empty:
                                          ///< then only the faces around the tet's own
                                          ///< nodes are nearest-face candidates
  /// A surface object (docs/SURFACES.md): its k triangles, with `tets`, `depth` and
  /// `anchor` empty and `topology` = build_edge_topology() of its edges. A surface has no
  /// depth map, so it only intrudes: its vertices and edges are pushed out of the tet
  /// object, nothing of the tet object is pushed out of it.
  std::span<const Triangle> triangles;
  /// Self-contact (a pair whose two sides are this same object): the neighbourhood the
  /// nearest-face search leaves out. Null: every face is a candidate.
  const SelfContactView* self = nullptr;

  [[nodiscard]] bool is_surface() const { return tets.empty() && !triangles.empty(); }
};

/// How a contact's push-out direction was found.
enum class Fallback : std::uint8_t {
  kNone,           ///< the evaluation asked for (ResponseOptions::evaluation) worked
  kNearestFace,    ///< kInterpolate's gradient was unusable: the nearest boundary face
                   ///< gave the depth and direction (kNearestFace's own path)
  kGradient,       ///< kNearestFace found no candidate face: the interpolated depth and
                   ///< its gradient (kInterpolate's path)
  kPairDirection,  ///< from the centre of Y's contact tets to the centre of X's
  kAxis,           ///< +z: nothing else was defined
};

/// Forces of one contact on at most six nodes.
struct ContactResult {
  ContactResult() {
    force.fill(Eigen::Vector3d::Zero());
    stiffness.fill(Eigen::Matrix3d::Zero());
    damping.fill(Eigen::Matrix3d::Zero());
  }
  bool active = false;    ///< produced a non-zero force
  bool skipped = false;   ///< non-finite position, depth or weight: no force
  bool inverted = false;  ///< the penetrated tet has negative volume (still processed)
  Fallback fallback = Fallback::kNone;
  int intruder_nodes = 0;  ///< 1 (point) or 2 (segment: edge ends a, b)
  int target_nodes = 0;    ///< 4 reactions, or 0 with push_point_only
  /// node[0 .. intruder_nodes): nodes of X; then target_nodes nodes of Y's tet.
  std::array<Index, 6> node{};
  std::array<Eigen::Vector3d, 6> force;      ///< N, per node entry
  std::array<Eigen::Matrix3d, 6> stiffness;  ///< df/dx, N/m, per node entry (if asked)
  /// df/dv, N s/m, per node entry (with the stiffness blocks): the damping's and the
  /// friction's derivatives with the normal push held fixed, lumped like kLumped (node k
  /// of the penetrated tet gets beta_k times the intruder's). Symmetric, negative
  /// semi-definite.
  std::array<Eigen::Matrix3d, 6> damping;
  /// Magnitude of the normal push on node[i] (i < intruder_nodes), N: the force without
  /// its friction.
  std::array<double, 2> push{};
  /// The points behind the push, for reports (ResponseOptions::report_contacts): one for
  /// a point contact, the two clip points of a segment piece. Point i lies at
  /// edge parameter lambda[i] on the intruding edge (x = a + lambda (b - a); 0 for a
  /// point contact) and at barycentric coordinates bary[i] in the penetrated tet (clamped
  /// to >= 0 and normalised, as the reactions use them), depth[i] metres deep.
  int points = 0;
  std::array<double, 2> lambda{};
  std::array<Eigen::Vector4d, 2> bary{Eigen::Vector4d::Zero(), Eigen::Vector4d::Zero()};
  std::array<double, 2> point_depth{};
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit push-out direction of X
  double depth = 0.0;                                ///< deepest penetration used, metres
};

/// Point-in-object: node c.node of X inside tet c.tet of Y (paper 5.1).
///
/// depth = sum_k beta_k d_k with the detection's barycentric weights beta (clamped to
/// >= 0 and renormalised), n = -grad d / |grad d| of Y's linear depth in the tet,
/// f = (k w depth - c w n.v_rel)^+ n + friction on the node, -beta_k f on the tet's node k,
/// v_rel = v_node - sum_k beta_k v_k; friction = -mu |push| f1(|v_t| / eps_v) v_t / |v_t|
/// with v_t the tangential part of v_rel (ResponseOptions::friction).
///
/// @param[in] intruder        X (positions, topology for the node weight, velocities).
/// @param[in] target          Y (positions, tets, topology for fallbacks, depth, velocities).
/// @param[in] c               the contact; indices must be in range (compute_pair_response
///                            checks them).
/// @param[in] options         stiffness, damping, measure, blocks, gradient limits.
/// @param[in] pair_direction  unit push-out direction for kPairDirection, or zero.
ContactResult point_contact(const ResponseObject& intruder, const ResponseObject& target,
                            const IntrudingNode& c, const ResponseOptions& options,
                            const Eigen::Vector3d& pair_direction);

/// Segment-in-object: the part [lambda_in, lambda_out] of edge c.edge of X (a, b) =
/// intruder.topology->edges[c.edge] inside tet c.tet of Y (paper 5.2).
///
/// The linear penalty density k d(x(lambda)) n along the clipped part is replaced by
/// its statically equivalent forces at the clip points x1, x2 (L = clipped length):
///     f1 = L (2 m1 + m2) / 6 n,  f2 = L (m1 + 2 m2) / 6 n,  m_i = (k d_i - c n.v_rel_i)^+,
/// moved to the edge ends with the weights of x = a + lambda (b - a):
///     f_a = (1 - l1) f1 + (1 - l2) f2,  f_b = l1 f1 + l2 f2,
/// and the reactions -(beta_k(x1) f1 + beta_k(x2) f2) to the tet's nodes. This is the
/// exact integral of the density against the edge's linear shape functions. Friction
/// /// acts at each clip point on its own push |f_i| with that point's relative velocity.
ContactResult segment_contact(const ResponseObject& intruder, const ResponseObject& target,
                              const IntrudingEdge& c, const ResponseOptions& options,
                              const Eigen::Vector3d& pair_direction);

/// The point response's lumped length weight of a node, metres: half the summed length
/// of the node's edges (intruder.topology->node_adjacency) at the current positions.
double node_length_weight(const ResponseObject& object, Index node);

}  // namespace tc
