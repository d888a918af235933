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
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/scene/scene.hpp"

namespace tc {

/// Scene-wide settings (the daemon reads them from its config file).
struct PipelineConfig {
  /// grid | hash | sap | bvh; empty: detection's default (bvh, chosen by bench_detect).
  /// The Pipeline constructor throws std::invalid_argument on any other name.
  std::string broad_phase;
  bool compute_stiffness = false;  ///< also return 3x3 df/dx blocks
  /// kAuto: segment response when the intruder's RMS contact-tet edge length exceeds this
  /// fraction of the contact extent (ResponseOptions::auto_threshold); 0 = default 0.25.
  double density_threshold = 0.0;
};

/// One object's state in a frame.
struct FrameObjectInput {
  std::string object;
  std::uint32_t topology_version = 0;
  Positions positions;  ///< 3 x n, metres, n = the registered topology's node count
};

/// Per-stage timings and counts of one frame.
struct FrameStats {
  double broad_ms = 0.0;
  double narrow_ms = 0.0;
  double depth_ms = 0.0;
  double response_ms = 0.0;
  double total_ms = 0.0;
  std::size_t objects = 0;
  std::size_t candidate_pairs = 0;    ///< tet pairs out of the broad phase
  std::size_t overlapping_pairs = 0;  ///< tet pairs out of the narrow phase
  std::size_t settled_nodes = 0;      ///< depth values computed (lazy)
  std::size_t contacts = 0;           ///< point + segment contacts that produced a force
  double max_depth = 0.0;             ///< deepest interpolated penetration, metres
};

/// An object whose input was rejected this frame (it gets no forces; others do).
struct ObjectError {
  std::string object;
  Error error;
};

struct FrameOutput {
  std::int64_t frame = 0;
  std::vector<ObjectForces> forces;  ///< one entry per object with a non-zero force, by name
  FrameStats stats;
  std::vector<ObjectError> errors;
};

class Pipeline {
 public:
  explicit Pipeline(PipelineConfig config = {});
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Registers or replaces (a cut) an object's topology. The mesh is validated
  /// (structure, inverted and degenerate tets at its rest positions); on error the
  /// previous version, if any, stays in place. Topology-derived data is built here.
  Status set_topology(const std::string& object, std::uint32_t version, TetMesh mesh,
                      const ObjectParams& params);

  /// Drops an object; unknown names are ignored.
  void remove_object(const std::string& object);

  /// True when the object is registered (any version).
  [[nodiscard]] bool has_object(const std::string& object) const;

  /// Runs one frame on the given states. Objects of the scene without a state this
  /// frame keep their last positions. A state that names an unknown object, a stale
  /// topology version, a wrong node count or non-finite or inverted positions is
  /// rejected into FrameOutput::errors; the rest of the frame runs.
  FrameOutput run_frame(std::int64_t frame, std::span<const FrameObjectInput> states);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tc
