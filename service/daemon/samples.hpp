// Topic samples as the daemon sees them: DDS-free views over a sample's fields, the pure
// validation every sample goes through before anything is built from it, and the
// conversions to the core's types. Validation only reads the view (fuzzable: a view can
// be made from any bytes), checks sizes against the limits before it walks any array,
// and reports the first fault with the object and index it concerns.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "config.hpp"
#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"
#include "core/pipeline/scene.hpp"
#include "tetcollide.h"

namespace tc::daemon {

/// Object parameters exactly as they arrive (enums as raw integers).
struct WireParams {
  double stiffness = 0.0;
  double damping = 0.0;
  double max_force = 0.0;
  bool is_static = false;
  std::int64_t depth = 0;
  std::int64_t response = 0;
  // Version 3 (0 / false from version-2 clients).
  double friction = 0.0;
  double friction_velocity = 0.0;
  bool blocks = false;
  bool contacts = false;
  bool self_contact = false;
};

/// A MeshTopology sample.
struct TopologyView {
  std::string_view scene;
  std::string_view object;
  std::uint32_t version = 0;
  std::span<const std::int64_t> node_ids;  ///< n, or empty
  std::span<const double> rest_positions;  ///< 3n, metres, x0 y0 z0 x1 ...
  std::span<const std::int32_t> tets;      ///< 4m, 0-based node indices
  WireParams params;
  /// The sample's source timestamp (ns, writer's clock), echoed in the verdict; 0 = none.
  std::int64_t source_timestamp = 0;
  std::span<const std::int32_t> triangles = {};  ///< 3k of a surface object (tets empty), or empty
};

/// A MeshState sample.
struct StateView {
  std::string_view scene;
  std::string_view object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::span<const double> positions;   ///< 3n, metres
  std::span<const double> velocities;  ///< 3n m/s, or empty
};

TopologyView view_of(const tetcollide_MeshTopology& sample) noexcept;
StateView view_of(const tetcollide_MeshState& sample) noexcept;

/// Checks a scene or object name: 1..max_length bytes, printable ASCII or UTF-8, no
/// control characters. `what` is "scene" or "object" for the message.
Status validate_name(std::string_view name, std::size_t max_length, const char* what);

/// Checks a topology sample on its own: names, version > 0, sizes against `limits`
/// (kOversized, checked first; a surface's triangles count against limits.max_tets),
/// array lengths and tets or triangles, not both (kInvalidArgument), tet or triangle
/// indices in range and distinct and finite rest positions (kInvalidMesh), parameters
/// (kInvalidArgument). Shape defects (degenerate, inverted tets, degenerate triangles)
/// are the pipeline's to find when it builds the object.
Status validate_topology(const TopologyView& topology, const Limits& limits);

/// Checks a state sample against the registered topology's node count: names,
/// frame >= 0, size against `limits` (kOversized, first), lengths (kInvalidArgument),
/// finite positions and velocities (kInvalidMesh).
Status validate_state(const StateView& state, const Limits& limits, Index registered_nodes);

/// Checks only what a state carries by itself (names, frame, size against the limits,
/// length a multiple of 3): used before the object is known.
Status validate_state_header(const StateView& state, const Limits& limits);

/// Mesh of a validated topology: node ids (1..n when the sample has none), rest
/// positions, tets, or the triangles of a surface object.
ObjectMesh to_mesh(const TopologyView& topology);

/// Parameters of a validated topology.
ObjectParams to_params(const WireParams& params);

/// Positions (3 x n) of a validated state.
Positions to_positions(std::span<const double> flat);

/// STATUS_* code of the protocol for a core error code.
std::int32_t status_code(ErrorCode code) noexcept;

}  // namespace tc::daemon
