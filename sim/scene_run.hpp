// The demo's frame loop without DDS: a running scene (its bodies, static objects and
// integrators) that exchanges one round trip per frame with a collision service given as
// an interface (`tetcollide demo` implements it over DDS with libtetcollide_client), unpacks
// the forces and stiffness blocks, probes the penetration, integrates, tears and
// re-registers cut bodies, and keeps the run's books: mechanical energy, inverted tets,
// rejected states, tears. docs/DEMO.md, "The simulator".
//
//   auto run = tc::sim::SceneRun::create(scene);          // meshes, bodies, integrators
//   for (frame ...) {
//     auto st = run->exchange(service, frame, probe_due);  // publish, wait, unpack, probe
//     ... write outputs from run->objects(), run->depth() ...
//     st = run->advance(service, frame);                   // integrate, tear, re-register
//   }
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "body.hpp"
#include "core/common/result.hpp"
#include "implicit_step.hpp"
#include "penetration.hpp"
#include "scene_file.hpp"
#include "shell_body.hpp"

namespace tc::sim {

/// The service's answer for one object and frame (libtetcollide_client's ObjectForces
/// without DDS types).
struct ContactAnswer {
  std::int32_t status = 0;  ///< 0 = ok; otherwise the state was rejected
  std::string status_name;
  std::vector<std::int32_t> nodes;  ///< k node indices
  std::vector<double> forces;       ///< 3k, newtons
  std::vector<double> stiffness;    ///< 9k row-major df/dx blocks (N/m), or empty
  std::vector<double> damping;      ///< 9k row-major df/dv blocks (N s/m), or empty
};

/// One moving object's state for a frame (views into the body).
struct StateView {
  const std::string* object = nullptr;
  const Eigen::Matrix3Xd* positions = nullptr;   ///< 3 x n, metres
  const Eigen::Matrix3Xd* velocities = nullptr;  ///< 3 x n, m/s
};

/// What a frame needs from the collision service.
class ContactService {
 public:
  virtual ~ContactService() = default;
  /// Publishes `frame`'s states and waits for the answers (by object name). An error when
  /// the frame is not answered (the run stops; exit 1).
  virtual Expected<std::map<std::string, ContactAnswer>> exchange(
      std::int64_t frame, const std::vector<StateView>& states) = 0;
  /// Registers the next topology version of `object` (after a tear) and waits for the
  /// service's verdict.
  virtual Status reregister(const std::string& object, const TetMesh& mesh) = 0;
};

/// One object of the running scene.
struct SimObject {
  ObjectSpec spec;
  std::optional<Body> body;        ///< moving tet objects
  std::optional<ShellBody> shell;  ///< moving triangle-based objects (surface objects)
  TetMesh fixed;                   ///< static objects (empty for a shell)
  std::optional<ImplicitStepper> stepper;
  Eigen::Matrix3Xd contact;  ///< this frame's forces, 3 x n, newtons
  Eigen::Matrix3Xd blocks;   ///< this frame's df/dx blocks, 3 x 3n (N/m), or empty
  Eigen::Matrix3Xd damping;  ///< this frame's df/dv blocks, 3 x 3n (N s/m), or empty
  Eigen::Matrix3Xd zero_velocity;
  std::vector<bool> inverted_seen;  ///< per tet: counted in the books already

  [[nodiscard]] bool moving() const { return body || shell; }
  [[nodiscard]] const Eigen::Matrix3Xd& positions() const {
    return body ? body->positions() : shell ? shell->positions() : fixed.positions;
  }
  /// The tets (rest positions); a shell has none: its triangles are surface().
  [[nodiscard]] const TetMesh& mesh() const { return body ? body->rest_mesh() : fixed; }
  /// A shell's triangles (rest positions), or nullptr for a tet object.
  [[nodiscard]] const SurfaceMesh* surface() const {
    return shell ? &shell->rest_surface() : nullptr;
  }
  [[nodiscard]] const Eigen::Matrix3Xd& velocities() const {
    return body ? body->velocities() : shell ? shell->velocities() : zero_velocity;
  }
};

/// The run's books (summary.json, docs/DEMO.md).
struct RunBooks {
  /// Mechanical energy (kinetic + elastic + gravity) of the moving bodies, J. A tear takes
  /// the removed tets' energy out of the system; it is added back here (`torn_energy`)
  /// so the figures stay comparable with the initial value (re-baselined at each tear).
  double energy_initial = 0.0;
  double energy_max = 0.0;
  double energy_final = 0.0;
  double torn_energy = 0.0;  ///< energy the tears removed, J
  double kinetic_max = 0.0;
  double kinetic_final = 0.0;  ///< kinetic energy after the last step, J (at rest: ~0)
  double dissipated = 0.0;     ///< removed by the material damping, J
  std::int64_t first_non_finite_frame = -1;  ///< first step giving NaN/Inf positions
  std::size_t inverted_tets = 0;             ///< distinct tets found inverted after a step
  std::int64_t first_inverted_frame = -1;
  std::size_t rejected = 0;
  std::string first_rejection;
  std::size_t tears = 0;
  std::size_t torn_tets = 0;
  std::int64_t first_tear = -1;
  double max_penetration = 0.0;
  std::int64_t max_penetration_frame = -1;
  double last_penetration = 0.0;  ///< deepest node at the last probed frame
  /// Self-penetration (PenetrationProbe::self_depth) of the objects that ask for
  /// self-contact, or of every moving tet object with SceneSpec::self_penetration_probe:
  /// the deepest over the probed frames, where, and at the last probed frame, m.
  double max_self_penetration = 0.0;
  std::int64_t max_self_penetration_frame = -1;
  double last_self_penetration = 0.0;
  std::int64_t last_probe_frame = -1;
  std::size_t contacts = 0;  ///< contact nodes of the last frame
  /// Per moving object: its mass-weighted centre (m) and velocity (m/s) after each step,
  /// and at the start (`com_start`).
  std::map<std::string, Eigen::Vector3d> com_start;
  std::map<std::string, std::vector<Eigen::Vector3d>> com;
  std::map<std::string, Eigen::Vector3d> com_velocity;
  /// Per object: the largest |sum of its contact forces| over the frames, N. The
  /// service's forces balance (a tet pair's and a surface pair's), so the two objects of
  /// a lone contact show the same figure.
  std::map<std::string, double> peak_contact_force;
  std::size_t newton_iterations = 0;
  /// Implicit steps whose linear solve or line search failed (0 on a healthy run).
  std::size_t step_failures = 0;
  std::size_t frames = 0;
};

/// (max - initial) / |initial| of the books' mechanical energy (+inf when it went
/// non-finite).
double energy_rise(const RunBooks& books);

/// Why a run fails its physics checks (empty: it passes): a state the service rejected, a
/// NaN/Inf state, an inverted tet, mechanical energy more than `max_rise` (relative)
/// above its initial value, or a self-penetration deeper than `max_self_penetration` (m;
/// 0: no limit). `tetcollide demo` exits 1 for any of them.
std::vector<std::string> run_failures(const RunBooks& books, double max_rise = 0.05,
                                      double max_self_penetration = 0.0);

class SceneRun {
 public:
  /// Loads the meshes, makes the bodies (pins, initial velocities) and their integrators.
  /// Errors name the object.
  static Expected<SceneRun> create(const SceneSpec& scene);

  /// When exchange() measures the penetration: never, when the answer holds contacts, or
  /// always.
  enum class Probe { kNo, kIfContact, kYes };

  /// Publishes the frame's states, waits for the answers, unpacks forces and blocks, and
  /// measures the penetration (depth()) as `probe` says. Rejected states are booked (their
  /// objects get no force). With the implicit integrator an answer with contact forces
  /// but no stiffness blocks is an error (the service must run with
  /// `pipeline.compute_stiffness: true`).
  Status exchange(ContactService& service, std::int64_t frame, Probe probe);
  /// Integrates every body over one frame, books energy and inverted tets, tears
  /// over-stretched bodies and re-registers them. Returns the objects re-registered.
  Expected<std::vector<std::size_t>> advance(ContactService& service, std::int64_t frame);

  [[nodiscard]] const std::vector<SimObject>& objects() const { return objects_; }
  [[nodiscard]] const SceneSpec& scene() const { return scene_; }
  /// The last probe's depths (per object, per node, metres); empty when not probed.
  [[nodiscard]] const std::vector<std::vector<double>>& depth() const { return depth_; }
  [[nodiscard]] const RunBooks& books() const { return books_; }
  /// Mechanical energy of the moving bodies now, plus what the tears removed, J.
  [[nodiscard]] double mechanical_energy() const;

 private:
  SceneSpec scene_;
  std::vector<SimObject> objects_;
  PenetrationProbe probe_;
  std::vector<std::vector<double>> depth_;
  RunBooks books_;
};

}  // namespace tc::sim
