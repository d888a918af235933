// What an object of a scene is registered with: its contact parameters, which pick the
// depth map (core/depth) and the response (core/response) of its pairs. The daemon
// maps the DDS samples' parameters to these; the CLI and the tests build them directly.
// The per-frame output (ObjectForces) is the response's type (core/response/response.hpp).
#pragma once

#include "core/depth/depth_solver.hpp"
#include "core/response/penalty.hpp"

namespace tc {

/// Per-object parameters, sent with the object's topology.
struct ObjectParams {
  double stiffness = 1e4;  ///< penalty stiffness k, N/m^2: N per metre of depth per metre
                           ///< of intruding edge (docs/RESPONSE.md, ForceMeasure)
  double damping = 0.0;    ///< penalty damping on the penetration rate, N s/m^2
  double max_force = 0.0;  ///< cap on one node's force magnitude, N; 0 = no cap
  bool is_static = false;  ///< static objects never move: fields are cached, and two
                           ///< static objects are never tested against each other
  DepthMethod depth = DepthMethod::kCpfm;
  ResponseKind response = ResponseKind::kAuto;
  /// Coulomb friction coefficient mu >= 0 (dimensionless); 0 = frictionless. A pair uses
  /// sqrt(mu_a mu_b) (pair_options), so an object without friction makes its pairs
  /// frictionless (docs/RESPONSE.md, "Friction").
  double friction = 0.0;
  /// Relative tangential speed below which friction is regularised (sticks viscously),
  /// m/s, >= 0; 0 = kDefaultFrictionVelocity. A pair uses the larger of the two.
  double friction_velocity = 0.0;
  /// Return this object's 3x3 blocks df/dx and df/dv with its forces (PipelineConfig::
  /// compute_stiffness returns them for every object).
  bool blocks = false;
  /// Return the contacts behind this object's forces (FrameOutput::contacts): for
  /// position-based and constraint solvers that build their own constraints.
  bool contacts = false;
  /// Contact of the object with itself (docs/DETECTION.md, "Self-contact"): a fold, or
  /// the fragments of a cut object. Tet objects only; off, a frame costs what it did.
  bool self_contact = false;
};

}  // namespace tc
