// One scene's per-frame collision pipeline:
//   object boxes -> broad phase -> narrow phase (TBB over candidate pairs)
//   -> lazy depth map per involved object (TBB across objects)
//   -> penalty response per object pair -> per-node forces, summed in a fixed order.
// Topology work happens in set_topology() only; run_frame() touches positions.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/common/result.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/mesh/surface_mesh.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/pipeline/scene.hpp"
#include "core/response/penalty.hpp"
#include "core/response/response.hpp"

namespace tc {

/// Scene-wide settings (the daemon reads them from its config file).
struct PipelineConfig {
  /// grid | hash | sap | bvh; empty: detection's default (bvh, chosen by bench_detect).
  /// The Pipeline constructor throws std::invalid_argument on any other name.
  std::string broad_phase;
  /// Return 3x3 df/dx and df/dv blocks for every object (ObjectParams::blocks asks per
  /// object).
  bool compute_stiffness = false;
  /// kAuto: segment response when the intruder's RMS contact-tet edge length exceeds this
  /// fraction of the contact extent (ResponseOptions::auto_threshold); 0 = default 0.25.
  double density_threshold = 0.0;
  /// Also list every point contact (FrameOutput::point_contacts): an audit of the depths
  /// and directions the response used.
  bool record_contacts = false;
  /// Where contact depths and directions come from (ResponseOptions::evaluation).
  DepthEvaluation evaluation = DepthEvaluation::kNearestFace;
  /// Where the lazy depth maps march (DepthSolverOptions::lazy_region): a region around
  /// the contact (default), or from the whole boundary as in the paper's 4.4.
  LazyRegion lazy_region = LazyRegion::kLocal;
  /// The degraded mode for a few inverted tets (docs/PROTOCOL.md, "A few inverted
  /// tets"): a tet object's state with inverted or degenerate (zero-volume) tets is
  /// accepted when they number at most max_inverted_tets and at most
  /// max_inverted_fraction of the object's tets (both must hold). Those tets are then
  /// left out of contact while the object holds that state (FrameOutput::degraded); any
  /// more is rejected as before. max_inverted_tets = 0 rejects every such state. The
  /// Pipeline constructor throws std::invalid_argument for a fraction outside [0, 1].
  std::size_t max_inverted_tets = 16;
  double max_inverted_fraction = 0.01;
};

/// One object's state in a frame.
struct FrameObjectInput {
  std::string object;
  std::uint32_t topology_version = 0;
  Positions positions;     ///< 3 x n, metres, n = the registered topology's node count
  Positions velocities{};  ///< 3 x n, m/s, or empty: contact damping and friction read them
                           ///< (ObjectParams::damping; an object without them counts as
                           ///< at rest)
};

/// Per-stage timings and counts of one frame.
struct FrameStats {
  double broad_ms = 0.0;
  double narrow_ms = 0.0;
  double depth_ms = 0.0;
  double response_ms = 0.0;
  double total_ms = 0.0;
  std::size_t objects = 0;
  std::size_t candidate_pairs = 0;    ///< tet (or triangle-tet) pairs out of the broad phase
  std::size_t overlapping_pairs = 0;  ///< tet (or triangle-tet) pairs out of the narrow phase
  std::size_t settled_nodes = 0;      ///< depth values computed (lazy)
  std::size_t contacts = 0;           ///< point + segment contacts that produced a force
  /// Object pairs whose pushes cancelled node by node (coincident or mirror-symmetric
  /// overlaps), answered along one separating direction (docs/RESPONSE.md).
  std::size_t symmetric_pairs = 0;
  double max_depth = 0.0;  ///< deepest interpolated penetration, metres
};

/// An object whose input was rejected this frame (it gets no forces; others do).
struct ObjectError {
  std::string object;
  Error error;
};

/// One point contact of a frame: a node of `object` inside `penetrated`, the depth its
/// force used and its unit push-out direction. Where a direction used the segment
/// response, its intruding nodes are evaluated as point contacts for this list only.
struct FramePointContact {
  std::string object;
  std::string penetrated;
  Index node = -1;  ///< node index in `object` (0-based, file order)
  Index tet = -1;   ///< the tet of `penetrated` containing it
  double depth = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

/// The contacts behind one object's forces (ObjectParams::contacts): every contact point
/// in which the object is the intruding or the penetrated one, in pair order (pairs by
/// object name) and within a pair in the response's order.
struct ObjectContacts {
  std::string object;
  std::vector<std::string> others;  ///< the other objects of the rows, by first appearance
  struct Row {
    std::uint32_t other = 0;  ///< index into `others`
    bool intrudes = true;     ///< this object's point is inside the other's tet
    ContactRow contact;       ///< nodes of the intruder, tet of the penetrated object
  };
  std::vector<Row> rows;
};

/// A state accepted in the degraded mode (PipelineConfig::max_inverted_tets): its inverted
/// and degenerate tets take part in no contact while the object holds it.
struct DegradedState {
  std::string object;
  std::size_t inverted = 0;    ///< inverted tets of the state
  std::size_t degenerate = 0;  ///< degenerate (zero-volume) tets of the state
  std::size_t allowed = 0;     ///< the most this object may have (limit and fraction)
  std::vector<Index> tets;     ///< the tets left out (both kinds), sorted
};

struct FrameOutput {
  std::int64_t frame = 0;
  std::vector<ObjectForces> forces;  ///< one entry per object with a non-zero force, by name
  FrameStats stats;
  std::vector<ObjectError> errors;
  /// States accepted with a few inverted or degenerate tets left out of contact, in the
  /// order of the states (each object gets its forces; PipelineConfig::max_inverted_tets).
  std::vector<DegradedState> degraded;
  /// Moving (not static) objects that got no valid state of their current topology
  /// version yet (since set_topology), by name: left out of the frame, no pair with them
  /// is tested. Rest positions are not a state.
  std::vector<std::string> left_out;
  /// With PipelineConfig::record_contacts: pairs in order, A's nodes in B first.
  std::vector<FramePointContact> point_contacts;
  /// One entry per object that asked for its contacts (ObjectParams::contacts) and has
  /// any this frame, by name.
  std::vector<ObjectContacts> contacts;
  /// Nodes whose depth this frame's depth maps settled, per object in contact (by name;
  /// a static object's full map counts on the frame that computes it, else 0).
  std::vector<std::pair<std::string, std::size_t>> settled_by_object;
};

/// Options of a pair from the two objects' parameters: the kind asked by either object
/// (an explicit kind beats kAuto, kSegment beats kPoint), the smaller stiffness (the
/// softer object sets the contact), the larger damping, the friction coefficient
/// sqrt(mu_a mu_b) (a frictionless object makes the pair frictionless), the larger
/// friction velocity (0 counts as kDefaultFrictionVelocity), and lumped blocks when either
/// object asks for them. max_force stays per object (cap_object_forces). The other fields
/// keep their defaults.
ResponseOptions pair_options(const ObjectParams& a, const ObjectParams& b);

class Pipeline {
 public:
  explicit Pipeline(PipelineConfig config = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Registers or replaces (a cut) an object's topology. The mesh is validated
  /// (structure, inverted and degenerate tets at its rest positions); on error the
  /// previous version, if any, stays in place. Sliver tets are kept, with a warning
  /// through the core's log facade (core/common/log.hpp). Topology-derived data is built
  /// here.
  Status set_topology(const std::string& object, std::uint32_t version, TetMesh mesh,
                      const ObjectParams& params);

  /// Registers or replaces a surface object (docs/SURFACES.md): triangles, closed or
  /// open, validated like tets (counts, indices, NaN, degenerate triangles). It meets tet
  /// objects only (never another surface): its vertices and edges in their tets get the
  /// point or segment response and the tets' nodes the reactions; it has no depth map.
  /// On error the previous version, if any, stays in place.
  Status set_surface(const std::string& object, std::uint32_t version, SurfaceMesh mesh,
                     const ObjectParams& params);

  /// True when the object is registered as a surface.
  [[nodiscard]] bool is_surface(const std::string& object) const;

  /// Drops an object; unknown names are ignored.
  void remove_object(const std::string& object);

  /// True when the object is registered (any version).
  [[nodiscard]] bool has_object(const std::string& object) const;

  /// The parameters an object is registered with, or null for an unknown object.
  [[nodiscard]] const ObjectParams* params(const std::string& object) const;

  /// Where the pair rule (the smaller stiffness, pair_options) overrides what `object`
  /// asked: the registered objects that can meet it (not both static) whose stiffness is
  /// below its own ("capped by"), and those whose stiffness it caps, by name.
  struct StiffnessCaps {
    std::vector<std::pair<std::string, double>> capped_by;
    std::vector<std::pair<std::string, double>> caps;
  };
  [[nodiscard]] StiffnessCaps stiffness_caps(const std::string& object) const;

  /// Runs one frame on the given states. Objects of the scene without a state this
  /// frame keep their last positions; a moving object that never got a valid state of
  /// its current topology version is left out (FrameOutput::left_out), a static one uses
  /// its rest positions. A state that names an unknown object, a stale
  /// topology version, a wrong node count, non-finite positions or more inverted or
  /// degenerate tets than PipelineConfig::max_inverted_tets allows is rejected into
  /// FrameOutput::errors; the rest of the frame runs. A state with fewer is accepted with
  /// those tets left out of contact (FrameOutput::degraded).
  FrameOutput run_frame(std::int64_t frame, std::span<const FrameObjectInput> states);

  /// run_frame(), taking each accepted state's positions and velocities instead of
  /// copying them: they are swapped with the matrices the object held, which the state
  /// then holds (a rejected state keeps its own). The same output, bit for bit; saves a
  /// copy of every new state (for a caller that made the states for this frame, as the
  /// daemon does from its samples).
  FrameOutput run_frame_taking(std::int64_t frame, std::span<FrameObjectInput> states);

  /// The exact reference for an audit: the distance from each contact's node, at the
  /// positions of the last frame, to the boundary of the object it penetrates (a BVH
  /// over that object's boundary triangles), metres. For a self-contact (object ==
  /// penetrated), to the boundary of the penetrated tet's component outside the node's
  /// neighbourhood (exact_self_depth()).
  /// @return kUnknownObject naming an object that is not registered; kInvalidArgument
  ///         for a node index out of range.
  Expected<std::vector<double>> exact_depths(std::span<const FramePointContact> contacts) const;

 private:
  struct Impl;
  /// run_frame() on `states`; `take` is empty or the same states, whose matrices are
  /// then swapped in rather than copied.
  FrameOutput run_frame(std::int64_t frame, std::span<const FrameObjectInput> states,
                        std::span<FrameObjectInput> take);
  std::unique_ptr<Impl> impl_;
};

}  // namespace tc
