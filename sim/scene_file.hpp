// Demo scene files (config/scenes/*.yaml, format version 1): which meshes, where, made
// of what, for how long, what to render. docs/DEMO.md documents every key. Parsing
// errors name the file, the line and the key at fault.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "body.hpp"
#include "core/common/result.hpp"
#include "shell_body.hpp"

namespace tc::sim {

/// Contact parameters sent to the service with the topology (mirror of
/// tc::client::ObjectParams, kept free of DDS here).
struct ContactSpec {
  double stiffness = 1e5;  ///< N/m^2
  double damping = 0.0;
  double max_force = 0.0;
  std::string depth = "cpfm";      ///< cpfm | cffm | exact
  std::string response = "auto";   ///< point | segment | auto
  double friction = 0.0;           ///< Coulomb coefficient mu (a pair: sqrt(mu_a mu_b))
  double friction_velocity = 0.0;  ///< m/s; 0 = the service's default (1e-3)
  bool self_contact = false;       ///< contact of the object with itself (tet objects)
};

struct ObjectSpec {
  std::string name;
  std::filesystem::path mesh;  ///< resolved path
  bool is_static = false;
  Eigen::Vector3d translate = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotate_deg = Eigen::Vector3d::Zero();  ///< about x, then y, then z
  double scale = 1.0;
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Material material;
  /// Set: the object is a triangle-based body (ShellBody, docs/DEMO.md) read from a
  /// surface file (STL, OBJ, .msh with triangles) and registered as a surface object.
  std::optional<ShellMaterial> shell;
  ContactSpec contact;
  /// Pin the nodes with |x| >= limit or |y| >= limit at rest (a slab's border); 0 = none.
  double fix_border = 0.0;
  /// Tear (remove tets) where the principal strain exceeds this; 0 = never tears.
  double tear_strain = 0.0;
  Eigen::Vector3d color{0.8, 0.8, 0.8};
};

/// Several copies of one object at random places (the rain).
struct RainSpec {
  ObjectSpec object;  ///< name is the prefix: <name>_000, <name>_001, ...
  int count = 0;
  Eigen::Vector3d region_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d region_max = Eigen::Vector3d::Zero();
  std::uint64_t seed = 1;
  /// Bounding radius of the (scaled) mesh about its origin, m: drops closer than twice
  /// this are rejected, so no two copies start overlapping.
  double radius = 0.0;
};

/// An analytic check of a friction scene (docs/DEMO.md, "Friction scenes"): what the
/// mass-weighted centre of `object` must do on `support`, from the scene's gravity, the
/// support's tilt (its rotate_deg turns its +z, the face it rests on) and the pair's
/// coefficient sqrt(mu_object mu_support).
struct FrictionCheck {
  /// "stick": tan(theta) < mu; the centre moves at most max_drift_m in the last window_s.
  /// "slide": tan(theta) > mu; from rest, its acceleration along the slope (a quadratic
  ///          fit of its position from from_s on) is g (sin theta - mu cos theta).
  /// "skid":  launched along the support at its `velocity` v0, it stops after
  ///          v0^2 / (2 g (mu cos theta - sin theta cos phi)) (phi: between v0 and downhill)
  ///          and then stays (max_drift_m in the last window_s).
  std::string kind;
  std::string object;
  std::string support;
  double from_s = 0.0;
  double window_s = 1.0;
  double max_drift_m = 1e-3;
  double tolerance = 0.05;  ///< slide, skid: relative
};

struct CameraSpec {
  bool set = false;  ///< false: fit the camera to the scene
  Eigen::Vector3d eye{2.0, -2.0, 1.5};
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d up{0.0, 0.0, 1.0};
  double fov_deg = 35.0;
};

struct SceneSpec {
  std::string name;  ///< DDS scene name and output folder name
  std::string description;
  double dt = 1e-3;  ///< frame time step, s (one service round trip per frame)
  /// "implicit" (backward Euler with the service's stiffness blocks, implicit_step.hpp)
  /// or "explicit" (symplectic Euler in `substeps`, contact forces held over the frame).
  std::string integrator = "implicit";
  int substeps = 8;                  ///< explicit only: elastic substeps per frame
  int newton_iterations = 4;         ///< implicit only: at most this many Newton steps per frame
  std::string linear_solver = "cg";  ///< implicit only: "cg" or "ldlt" (implicit_step.hpp)
  int frames = 500;
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};
  int output_every = 10;           ///< a VTU every this many frames (and the last)
  std::vector<int> render_frames;  ///< frames drawn as PNG (clamped to the run)
  int image_width = 640;
  int image_height = 480;
  CameraSpec camera;
  std::vector<ObjectSpec> objects;  ///< rain copies expanded here
  std::optional<RainSpec> rain;
  std::optional<FrictionCheck> check;
  /// The run fails when the mechanical energy rises more than this fraction above its
  /// initial value.
  double max_energy_rise = 0.05;
  /// Measure every moving tet object's self-penetration (summary.json
  /// self_penetration_m), not only those with contact.self_contact.
  bool self_penetration_probe = false;
  /// The run fails when the deepest self-penetration exceeds this, m (0: no limit).
  double max_self_penetration = 0.0;
};

/// Parses a scene from YAML text. `where` names the source in errors; relative mesh
/// paths are resolved against `search` (first existing wins). kParse / kInvalidArgument
/// with "where:line: message", kIo for a missing mesh.
Expected<SceneSpec> parse_scene(const std::string& text, const std::string& where,
                                const std::vector<std::filesystem::path>& search);

/// Reads a scene file (search path: the file's directory, its grandparent, then
/// `extra_search`).
Expected<SceneSpec> load_scene_file(const std::filesystem::path& path,
                                    const std::vector<std::filesystem::path>& extra_search);

/// The torus-on-box scene built into the program (`tetcollide demo torus_on_box` works
/// without config/scenes); the same text as config/scenes/torus_on_box.yaml.
const std::string& embedded_torus_on_box();

}  // namespace tc::sim

namespace tc::sim {

/// The object's rotation: about x, then y, then z by rotate_deg (degrees).
Eigen::Matrix3d object_rotation(const ObjectSpec& object);

/// Reads the object's mesh and places it: scaled, rotated (x, then y, then z, degrees),
/// translated. kIo / kParse from the reader.
Expected<TetMesh> load_object_mesh(const ObjectSpec& object);
/// The same for a shell object's surface (core/io/surface_io.hpp readers).
Expected<SurfaceMesh> load_object_surface(const ObjectSpec& object);

}  // namespace tc::sim
