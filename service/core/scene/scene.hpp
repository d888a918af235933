// The data a frame of a scene carries in and out of the core pipeline. The daemon maps
// DDS samples to and from these types; the CLI and the tests build them directly.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/result.hpp"
#include "core/mesh/tet_mesh.hpp"

namespace tc {

/// How the depth map of an object is computed.
enum class DepthMethod { kCpfm, kCffm, kExact };

/// Which penalty response an object pair uses. kAuto picks by mesh density.
enum class ResponseKind { kPoint, kSegment, kAuto };

/// Per-object parameters, sent with the object's topology.
struct ObjectParams {
  double stiffness = 1e4;  ///< penalty stiffness k, N/m^2 (force = k * depth * area scale)
  double damping = 0.0;    ///< penalty damping, N s/m per unit depth rate
  double max_force = 0.0;  ///< cap on one node's force magnitude, N; 0 = no cap
  bool is_static = false;  ///< static objects never move: fields are cached, and two
                           ///< static objects are never tested against each other
  DepthMethod depth = DepthMethod::kCpfm;
  ResponseKind response = ResponseKind::kAuto;
};

/// Sparse per-node forces on one object for one frame.
struct ObjectForces {
  std::string object;
  std::vector<Index> nodes;                ///< sorted node indices (0-based, file order)
  std::vector<Eigen::Vector3d> forces;     ///< one per entry of nodes, N
  std::vector<Eigen::Matrix3d> stiffness;  ///< empty, or one df/dx block per entry, N/m
};

}  // namespace tc
