// libtetcollide_client: the C++ API a simulator uses to talk to tetcollided over DDS.
//
//   using namespace std::chrono_literals;
//   tc::client::Options options;
//   options.domain = 0;
//   options.scene = "surgery";
//   options.resend_after = 20ms;  // re-publish a frame's states when its answer is late
//   auto client = tc::client::Client::connect(options);
//   if (!client->wait_for_service(5s)) ...;                   // a READY service
//   const tc::client::Mesh mesh = tc::client::read_mesh("liver.msh");  // tetcollide/mesh.hpp
//   client->register_object("liver", mesh, params);           // topology, version 1
//   client->wait_registered("liver", 5s).ok;                  // the service built it
//   client->wait_for_readers(1, 5s);                          // states now reach it
//   for (frame = 0;; ++frame) {                               // at 1 kHz:
//     client->publish_states(frame, {{"liver", positions, velocities}});  // 3n each
//     auto forces = client->wait_forces(frame, 5ms);  // p50 about 0.5-1 ms for a small
//   }                                                 // scene; nullopt: no answer in time
//
// Which parameters and answers an explicit, an implicit or a position-based integrator
// uses, and the stable stiffness of an explicit step: docs/INTEGRATORS.md
// (tetcollide/integration.hpp). A pair of objects uses the smaller stiffness and the
// larger damping of the two (a static box at the default 1e4 caps a stiffer ball; the
// service says so in the registration's status message).
//
// Depends on Cyclone DDS and the generated protocol types only. The protocol itself is
// documented in docs/PROTOCOL.md; this library is one implementation of its client side.
//
// Threading: one Client may be used from one simulation thread; wait_* calls read DDS
// on the calling thread. A forces callback, when set, runs on a thread of the client.
// Errors: DDS failures throw tc::client::ClientError; expected outcomes (a timeout, an
// object the service rejected) are return values.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

// Symbols of the shared library that are part of the API; everything else is hidden.
#if defined(__GNUC__)
#define TC_CLIENT_API __attribute__((visibility("default")))
#else
#define TC_CLIENT_API
#endif

namespace tc::client {

/// Thrown when a DDS call fails (the message names the call and the DDS error).
class TC_CLIENT_API ClientError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Status codes of the protocol (ContactForces.status, ServiceStatus.code).
enum class StatusCode : std::int32_t {
  kOk = 0,
  kIo = 1,
  kParse = 2,
  kUnsupported = 3,
  kInvalidMesh = 4,
  kInvalidArgument = 5,
  kUnknownObject = 6,
  kStaleVersion = 7,
  kOversized = 8,
  kInternal = 9,
};

/// Lower-case name of a status code ("ok", "invalid_mesh", ...).
TC_CLIENT_API const char* status_name(std::int32_t code) noexcept;

enum class DepthMethod { kCpfm = 0, kCffm = 1, kExact = 2 };
enum class ResponseKind { kPoint = 0, kSegment = 1, kAuto = 2 };

/// Lower-case names as scene files, recordings and the Python module spell them:
/// "cpfm", "cffm", "exact"; "point", "segment", "auto". The parsers return nullopt for
/// any other text.
TC_CLIENT_API const char* depth_method_name(DepthMethod method) noexcept;
TC_CLIENT_API std::optional<DepthMethod> parse_depth_method(std::string_view name) noexcept;
TC_CLIENT_API const char* response_kind_name(ResponseKind kind) noexcept;
TC_CLIENT_API std::optional<ResponseKind> parse_response_kind(std::string_view name) noexcept;

/// Per-object contact parameters, sent with the topology.
struct ObjectParams {
  double stiffness = 1e4;  ///< penalty stiffness, N/m^2
  double damping = 0.0;    ///< penalty damping c, N s/m^2 (per metre of edge, like stiffness)
  double max_force = 0.0;  ///< cap on one node's force, N; 0 = none
  bool is_static = false;  ///< never moves; the service does not wait for its states
  DepthMethod depth = DepthMethod::kCpfm;
  ResponseKind response = ResponseKind::kAuto;
  // Protocol version 3 (a version-2 service ignores them: it sends no friction and no
  // blocks unless its pipeline.compute_stiffness is set).
  /// Coulomb friction coefficient mu >= 0; a pair uses sqrt(mu_a mu_b); 0 = frictionless.
  double friction = 0.0;
  /// Relative tangential speed below which friction is regularised (a viscous stick),
  /// m/s; 0 = the service's default, 1e-3 m/s (docs/RESPONSE.md "Friction").
  double friction_velocity = 0.0;
  /// Answers carry this object's df/dx (`stiffness`) and df/dv (`damping`) blocks, for an
  /// implicit integrator.
  bool blocks = false;
  /// Answers carry the contacts behind this object's forces (ObjectForces::contacts), for
  /// position-based and constraint solvers (docs/PROTOCOL.md "Contacts").
  bool contacts = false;
  /// Contact of the object with itself: a fold, or the fragments of a cut (tet objects;
  /// docs/RESPONSE.md "Self-contact"). Its contacts name the object itself as `other`.
  bool self_contact = false;
};

/// One point of a contact behind the forces (ObjectParams::contacts): the point
/// weights[0] x[nodes[0]] + weights[1] x[nodes[1]] of the intruding object lies inside
/// tet `tet` of the penetrated object at barycentric coordinates `barycentric`, `depth`
/// metres deep; `normal` is the unit direction that pushes the intruder out. A point
/// contact has nodes {node, -1} and weights {1, 0}; a piece of an intruding edge (segment
/// response) gives two such points, its ends on the edge. The forces of the answer are the
/// penalty response to these points (docs/RESPONSE.md).
struct Contact {
  std::string other;     ///< the other object of the contact
  bool intrudes = true;  ///< true: this object's point is in `other`; false: other's point in this
  std::array<std::int32_t, 2> nodes{-1, -1};  ///< the intruding object's nodes
  std::array<double, 2> weights{1.0, 0.0};
  std::int32_t tet = -1;  ///< the penetrated object's tet
  std::array<double, 4> barycentric{};
  double depth = 0.0;  ///< metres, >= 0
  std::array<double, 3> normal{};
};

/// A tetrahedral mesh as flat arrays.
struct Mesh {
  std::vector<std::int64_t> node_ids;  ///< n ids (reported back only), or empty
  std::vector<double> rest_positions;  ///< 3n, metres, x0 y0 z0 x1 ...
  std::vector<std::int32_t> tets;      ///< 4m 0-based node indices, positively oriented
  /// A surface object (docs/SURFACES.md): 3k 0-based node indices of its triangles, with
  /// `tets` empty. It meets tet objects only; its vertices and edges in their tets get
  /// forces. Needs a service of protocol version 2 or later (an older one rejects it).
  std::vector<std::int32_t> triangles;
};

/// One object's positions for a frame (views: the data is copied when published).
struct ObjectState {
  std::string object;
  std::span<const double> positions;        ///< 3n, metres
  std::span<const double> velocities = {};  ///< 3n m/s, or empty
  std::uint32_t topology_version = 0;       ///< 0 = the version last registered
};

/// The service's answer for one object and frame.
struct ObjectForces {
  std::string object;
  std::int64_t frame = 0;
  std::uint32_t topology_version = 0;
  std::int32_t status = 0;          ///< StatusCode; not kOk = this object's state was rejected
  std::vector<std::int32_t> nodes;  ///< k sorted node indices
  std::vector<double> forces;       ///< 3k, newtons
  std::vector<double> stiffness;    ///< 9k row-major df/dx blocks (N/m), or empty
  /// 9k row-major df/dv blocks (N s/m): the contact damping's and friction's; present
  /// with `stiffness` (protocol version 3; empty from older services).
  std::vector<double> damping;
  /// The contacts behind the forces when this object asked (ObjectParams::contacts),
  /// in the service's order; empty otherwise.
  std::vector<Contact> contacts;
  /// Frame of this object's state the forces were computed from (== frame for answers
  /// this client waits for; -1: rest positions). See ContactForces.state_frame.
  std::int64_t state_frame = -1;
  /// The service's computation this answer comes from (ContactForces.answer_id): the
  /// answers of one FrameForces all come from one computation; 0 from older services
  /// and in rejected answers.
  std::uint64_t answer_id = 0;
  /// Objects of the scene the computation left out because the service holds no state of
  /// their current topology version (ContactForces.left_out): these forces lack contact
  /// with them. Sorted; empty in rejected answers and from older services.
  std::vector<std::string> left_out;
};

/// Every answer of one frame for this client's objects, sorted by object name.
struct TC_CLIENT_API FrameForces {
  std::int64_t frame = 0;
  std::vector<ObjectForces> objects;
  /// Answer for `object`, or null.
  [[nodiscard]] const ObjectForces* find(const std::string& object) const;
  /// True when every object's status is kOk.
  [[nodiscard]] bool ok() const;
};

/// A ServiceStatus sample.
struct StatusEvent {
  enum class State { kStarting = 0, kReady = 1, kStopping = 2 };
  enum class Kind { kHeartbeat = 0, kStateChange = 1, kRegistered = 2, kRemoved = 3, kError = 4 };
  std::string service_id;
  std::uint64_t sequence_number = 0;
  State state = State::kStarting;
  Kind kind = Kind::kHeartbeat;
  std::int32_t code = 0;
  std::string scene;
  std::string object;
  std::uint32_t topology_version = 0;
  std::int64_t frame = -1;
  std::string message;
  /// Verdicts on a topology: the source timestamp of the MeshTopology sample judged.
  std::int64_t topology_timestamp = 0;
};

/// A FrameStats sample of this client's scene: the service's timings (milliseconds) and
/// counts of one answered frame (docs/PROTOCOL.md, "FrameStats").
struct FrameStatsEvent {
  std::string scene;
  std::int64_t frame = 0;
  double assembly_ms = 0.0;
  double queue_ms = 0.0;
  double broad_ms = 0.0;
  double narrow_ms = 0.0;
  double depth_ms = 0.0;
  double response_ms = 0.0;
  double compute_ms = 0.0;
  double publish_ms = 0.0;
  std::uint32_t objects = 0;
  std::uint32_t states = 0;
  std::uint32_t rejected = 0;
  std::uint64_t candidate_pairs = 0;
  std::uint64_t overlapping_pairs = 0;
  std::uint64_t settled_nodes = 0;
  std::uint64_t contacts = 0;
  double max_depth = 0.0;  ///< metres
  std::uint64_t dropped_frames = 0;
};

/// Outcome of a registration as the service reported it.
struct Registration {
  bool done = false;      ///< false: no verdict before the timeout
  bool ok = false;        ///< the service built the object
  std::int32_t code = 0;  ///< StatusCode of a rejection
  std::string message;
};

struct Options {
  std::uint32_t domain = 0;
  std::string scene;              ///< every object of this client lives in this scene
  std::string partition;          ///< DDS partition, "" = default (must match the service)
  std::string cyclonedds_config;  ///< XML or file:// for this domain; "" = CYCLONEDDS_URI
  /// wait_forces re-publishes the frame's states when no answer came for this long
  /// (a restarted service, a lost sample); 0 = never.
  std::chrono::milliseconds resend_after{0};
};

class TC_CLIENT_API Client {
 public:
  /// Creates the participant, writers and readers. Throws ClientError.
  static std::unique_ptr<Client> connect(const Options& options);
  /// Same, with the default options for everything but the domain and the scene.
  static std::unique_ptr<Client> connect(std::uint32_t domain, const std::string& scene);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// Waits for a service announcing READY. False on timeout.
  bool wait_for_service(std::chrono::milliseconds timeout);

  /// Waits until at least `count` readers (services, recorders) are matched with this
  /// client's MeshState writer, i.e. until states published now reach them. False on
  /// timeout.
  bool wait_for_readers(std::size_t count, std::chrono::milliseconds timeout);

  /// Publishes (or, after a cut, replaces) an object's topology. `version` 0 means the
  /// previous version + 1 (1 the first time). Returns the version sent. The sample stays
  /// available to services that start later (transient-local), so a restarted service
  /// gets it back without the simulator doing anything. The client keeps a copy of the
  /// mesh: when a service reports the object lost while this client still holds it (an
  /// unknown_object answer or a KIND_REMOVED event, e.g. after the service was stopped
  /// for longer than the 1 s lease), the client writes it again, unchanged, at most once
  /// per second, while it reads DDS (docs/PROTOCOL.md, "Liveliness lease").
  std::uint32_t register_object(const std::string& object, const Mesh& mesh,
                                const ObjectParams& params, std::uint32_t version = 0);

  /// Waits for the service's verdict on the object's current version.
  Registration wait_registered(const std::string& object, std::chrono::milliseconds timeout);

  /// Removes an object from the scene (disposes its topology instance).
  void remove_object(const std::string& object);

  /// The version last sent for an object (0 when unknown).
  [[nodiscard]] std::uint32_t version(const std::string& object) const;

  /// Publishes the objects' states of one frame (each with its current version).
  void publish_states(std::int64_t frame, std::span<const ObjectState> states);
  void publish_states(std::int64_t frame, std::initializer_list<ObjectState> states) {
    publish_states(frame, std::span<const ObjectState>(states.begin(), states.size()));
  }

  /// Waits for the answer to `frame`: one ObjectForces per object published in that frame
  /// (per registered object when this client did not publish it). When the service
  /// skipped the frame (a newer one superseded it), the first newer complete answer is
  /// returned instead (check FrameForces::frame). nullopt on timeout.
  std::optional<FrameForces> wait_forces(std::int64_t frame, std::chrono::milliseconds timeout);

  /// Calls `callback` with each complete answered frame, on a thread of the client,
  /// instead of (or as well as) wait_forces. Pass nullptr to stop.
  void set_forces_callback(std::function<void(const FrameForces&)> callback);

  /// ServiceStatus samples received since the last call (all services, all scenes).
  std::vector<StatusEvent> take_status_events();

  /// FrameStats samples of this client's scene received since the last call, in arrival
  /// order (the reader keeps 16 per scene between two reads of DDS: a client that waits
  /// for every frame's forces sees every frame's statistics).
  std::vector<FrameStatsEvent> take_frame_stats();

  /// Reads whatever DDS has delivered, waiting at most `timeout` for the first sample.
  void poll(std::chrono::milliseconds timeout);

  [[nodiscard]] const Options& options() const;

 private:
  Client();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tc::client
