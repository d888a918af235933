#include "samples.hpp"

#include <cmath>
#include <sstream>

#include "protocol.hpp"

namespace tc::daemon {
namespace {

template <typename T>
std::span<const T> span_of(const T* data, std::uint32_t length) noexcept {
  if (data == nullptr || length == 0) return {};
  return {data, length};
}

std::string label(std::string_view scene, std::string_view object) {
  std::string out;
  out.reserve(scene.size() + object.size() + 1);
  out.append(scene).append("/").append(object);
  return out;
}

Error fail(ErrorCode code, std::string_view scene, std::string_view object,
           const std::string& what) {
  return Error{code, label(scene, object) + ": " + what};
}

/// Index of the first non-finite value, or -1.
std::int64_t first_nonfinite(std::span<const double> values) noexcept {
  for (std::size_t i = 0; i < values.size(); ++i)
    if (!std::isfinite(values[i])) return static_cast<std::int64_t>(i);
  return -1;
}

Status check_names(std::string_view scene, std::string_view object) {
  if (Status st = validate_name(scene, tetcollide_MAX_SCENE_NAME, "scene"); !st) return st;
  return validate_name(object, tetcollide_MAX_OBJECT_NAME, "object");
}

}  // namespace

TopologyView view_of(const tetcollide_MeshTopology& s) noexcept {
  TopologyView v;
  v.scene = protocol::bounded_view(s.scene);
  v.object = protocol::bounded_view(s.object);
  v.version = s.version;
  v.node_ids = span_of(s.node_ids._buffer, s.node_ids._length);
  v.rest_positions = span_of(s.rest_positions._buffer, s.rest_positions._length);
  v.tets = span_of(s.tets._buffer, s.tets._length);
  v.triangles = span_of(s.triangles._buffer, s.triangles._length);
  v.params.stiffness = s.params.stiffness;
  v.params.damping = s.params.damping;
  v.params.max_force = s.params.max_force;
  v.params.is_static = s.params.is_static;
  v.params.depth = static_cast<std::int64_t>(s.params.depth);
  v.params.response = static_cast<std::int64_t>(s.params.response);
  v.params.friction = s.params.friction;
  v.params.friction_velocity = s.params.friction_velocity;
  v.params.blocks = s.params.blocks;
  v.params.contacts = s.params.contacts;
  v.params.self_contact = s.params.self_contact;
  return v;
}

StateView view_of(const tetcollide_MeshState& s) noexcept {
  StateView v;
  v.scene = protocol::bounded_view(s.scene);
  v.object = protocol::bounded_view(s.object);
  v.frame = s.frame;
  v.topology_version = s.topology_version;
  v.positions = span_of(s.positions._buffer, s.positions._length);
  v.velocities = span_of(s.velocities._buffer, s.velocities._length);
  return v;
}

Status validate_name(std::string_view name, std::size_t max_length, const char* what) {
  if (name.empty())
    return Error{ErrorCode::kInvalidArgument, std::string("empty ") + what + " name"};
  if (name.size() > max_length)
    return Error{ErrorCode::kInvalidArgument,
                 std::string(what) + " name longer than " + std::to_string(max_length) + " bytes"};
  for (std::size_t i = 0; i < name.size(); ++i) {
    const auto c = static_cast<unsigned char>(name[i]);
    if (c < 0x20 || c == 0x7f)
      return Error{
          ErrorCode::kInvalidArgument,
          std::string(what) + " name has a control character at byte " + std::to_string(i)};
  }
  return {};
}

Status validate_topology(const TopologyView& t, const Limits& limits) {
  if (Status st = check_names(t.scene, t.object); !st) return st;
  const std::size_t coords = t.rest_positions.size();
  const std::size_t indices = t.tets.size();
  const std::size_t corners = t.triangles.size();
  // Sizes first: nothing below walks an array longer than the limits allow.
  if (coords > 3 * static_cast<std::size_t>(limits.max_nodes))
    return fail(ErrorCode::kOversized, t.scene, t.object,
                std::to_string(coords / 3) +
                    " nodes exceed limits.max_nodes = " + std::to_string(limits.max_nodes));
  if (indices > 4 * static_cast<std::size_t>(limits.max_tets))
    return fail(ErrorCode::kOversized, t.scene, t.object,
                std::to_string(indices / 4) +
                    " tets exceed limits.max_tets = " + std::to_string(limits.max_tets));
  if (corners > 3 * static_cast<std::size_t>(limits.max_tets))
    return fail(ErrorCode::kOversized, t.scene, t.object,
                std::to_string(corners / 3) + " triangles exceed limits.max_tets = " +
                    std::to_string(limits.max_tets) + " (surfaces count triangles against it)");
  if (t.node_ids.size() > static_cast<std::size_t>(limits.max_nodes))
    return fail(ErrorCode::kOversized, t.scene, t.object,
                std::to_string(t.node_ids.size()) + " node ids exceed limits.max_nodes");
  if (t.version == 0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object, "topology version must be > 0");
  if (coords % 3 != 0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "rest_positions has " + std::to_string(coords) + " values, not a multiple of 3");
  if (indices % 4 != 0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "tets has " + std::to_string(indices) + " indices, not a multiple of 4");
  if (corners % 3 != 0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "triangles has " + std::to_string(corners) + " indices, not a multiple of 3");
  const std::size_t n = coords / 3;
  if (indices != 0 && corners != 0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "a topology has tets or triangles (a surface), not both: got " +
                    std::to_string(indices / 4) + " tets and " + std::to_string(corners / 3) +
                    " triangles");
  if (corners != 0 && n < 3)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "a surface needs at least 3 nodes, got " + std::to_string(n));
  if (corners == 0 && (n < 4 || indices == 0))
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "a topology needs at least 4 nodes and 1 tet (or triangles: a surface), got " +
                    std::to_string(n) + " nodes and " + std::to_string(indices / 4) + " tets");
  if (!t.node_ids.empty() && t.node_ids.size() != n)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "node_ids has " + std::to_string(t.node_ids.size()) + " entries for " +
                    std::to_string(n) + " nodes");
  if (const auto bad = first_nonfinite(t.rest_positions); bad >= 0)
    return fail(ErrorCode::kInvalidMesh, t.scene, t.object,
                "node " + std::to_string(bad / 3) + " has a non-finite rest coordinate");
  const auto n32 = static_cast<std::int64_t>(n);
  for (std::size_t k = 0; k < indices; k += 4) {
    const std::int32_t* tet = &t.tets[k];
    for (int a = 0; a < 4; ++a) {
      if (tet[a] < 0 || tet[a] >= n32)
        return fail(ErrorCode::kInvalidMesh, t.scene, t.object,
                    "tet " + std::to_string(k / 4) + " has node index " + std::to_string(tet[a]) +
                        " outside [0, " + std::to_string(n) + ")");
      for (int b = 0; b < a; ++b)
        if (tet[a] == tet[b])
          return fail(
              ErrorCode::kInvalidMesh, t.scene, t.object,
              "tet " + std::to_string(k / 4) + " uses node " + std::to_string(tet[a]) + " twice");
    }
  }
  for (std::size_t k = 0; k < corners; k += 3) {
    const std::int32_t* tri = &t.triangles[k];
    for (int a = 0; a < 3; ++a) {
      if (tri[a] < 0 || tri[a] >= n32)
        return fail(ErrorCode::kInvalidMesh, t.scene, t.object,
                    "triangle " + std::to_string(k / 3) + " has node index " +
                        std::to_string(tri[a]) + " outside [0, " + std::to_string(n) + ")");
      for (int b = 0; b < a; ++b)
        if (tri[a] == tri[b])
          return fail(ErrorCode::kInvalidMesh, t.scene, t.object,
                      "triangle " + std::to_string(k / 3) + " uses node " + std::to_string(tri[a]) +
                          " twice");
    }
  }
  const WireParams& p = t.params;
  if (!std::isfinite(p.stiffness) || !(p.stiffness > 0.0))
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.stiffness must be finite and > 0");
  if (!std::isfinite(p.damping) || p.damping < 0.0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.damping must be finite and >= 0");
  if (!std::isfinite(p.max_force) || p.max_force < 0.0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.max_force must be finite and >= 0");
  if (p.depth < tetcollide_DEPTH_CPFM || p.depth > tetcollide_DEPTH_EXACT)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.depth " + std::to_string(p.depth) + " is not a DepthMethod");
  if (p.response < tetcollide_RESPONSE_POINT || p.response > tetcollide_RESPONSE_AUTO)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.response " + std::to_string(p.response) + " is not a ResponseKind");
  if (!std::isfinite(p.friction) || p.friction < 0.0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.friction must be finite and >= 0");
  if (!std::isfinite(p.friction_velocity) || p.friction_velocity < 0.0)
    return fail(ErrorCode::kInvalidArgument, t.scene, t.object,
                "params.friction_velocity must be finite and >= 0");
  return {};
}

Status validate_state_header(const StateView& s, const Limits& limits) {
  if (Status st = check_names(s.scene, s.object); !st) return st;
  if (s.positions.size() > 3 * static_cast<std::size_t>(limits.max_nodes) ||
      s.velocities.size() > 3 * static_cast<std::size_t>(limits.max_nodes))
    return fail(ErrorCode::kOversized, s.scene, s.object,
                "state of " + std::to_string(s.positions.size() / 3) +
                    " nodes exceeds limits.max_nodes = " + std::to_string(limits.max_nodes));
  if (s.frame < 0)
    return fail(ErrorCode::kInvalidArgument, s.scene, s.object,
                "frame " + std::to_string(s.frame) + " is negative");
  if (s.positions.size() % 3 != 0)
    return fail(ErrorCode::kInvalidArgument, s.scene, s.object,
                "frame " + std::to_string(s.frame) + ": positions has " +
                    std::to_string(s.positions.size()) + " values, not a multiple of 3");
  return {};
}

Status validate_state(const StateView& s, const Limits& limits, Index registered_nodes) {
  if (Status st = validate_state_header(s, limits); !st) return st;
  const std::size_t expected = 3 * static_cast<std::size_t>(registered_nodes);
  if (s.positions.size() != expected)
    return fail(ErrorCode::kInvalidArgument, s.scene, s.object,
                "frame " + std::to_string(s.frame) + ": positions has " +
                    std::to_string(s.positions.size()) + " values, topology version " +
                    std::to_string(s.topology_version) + " has " +
                    std::to_string(registered_nodes) + " nodes (" + std::to_string(expected) +
                    " values)");
  if (!s.velocities.empty() && s.velocities.size() != expected)
    return fail(ErrorCode::kInvalidArgument, s.scene, s.object,
                "frame " + std::to_string(s.frame) + ": velocities has " +
                    std::to_string(s.velocities.size()) + " values, expected 0 or " +
                    std::to_string(expected));
  if (const auto bad = first_nonfinite(s.positions); bad >= 0)
    return fail(ErrorCode::kInvalidMesh, s.scene, s.object,
                "frame " + std::to_string(s.frame) + ": node " + std::to_string(bad / 3) +
                    " has a non-finite position");
  if (const auto bad = first_nonfinite(s.velocities); bad >= 0)
    return fail(ErrorCode::kInvalidMesh, s.scene, s.object,
                "frame " + std::to_string(s.frame) + ": node " + std::to_string(bad / 3) +
                    " has a non-finite velocity");
  return {};
}

ObjectMesh to_mesh(const TopologyView& t) {
  const auto n = static_cast<Eigen::Index>(t.rest_positions.size() / 3);
  std::vector<std::int64_t> ids(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i)
    ids[static_cast<std::size_t>(i)] =
        t.node_ids.empty() ? i + 1 : t.node_ids[static_cast<std::size_t>(i)];
  if (!t.triangles.empty()) {
    SurfaceMesh surface;
    surface.positions = to_positions(t.rest_positions);
    surface.node_ids = std::move(ids);
    surface.triangles.resize(t.triangles.size() / 3);
    for (std::size_t k = 0; k < surface.triangles.size(); ++k)
      surface.triangles[k] = {t.triangles[3 * k], t.triangles[3 * k + 1], t.triangles[3 * k + 2]};
    return surface;
  }
  TetMesh mesh;
  mesh.positions = to_positions(t.rest_positions);
  mesh.node_ids = std::move(ids);
  mesh.tets.resize(t.tets.size() / 4);
  for (std::size_t k = 0; k < mesh.tets.size(); ++k)
    mesh.tets[k] = {t.tets[4 * k], t.tets[4 * k + 1], t.tets[4 * k + 2], t.tets[4 * k + 3]};
  return mesh;
}

ObjectParams to_params(const WireParams& p) {
  ObjectParams out;
  out.stiffness = p.stiffness;
  out.damping = p.damping;
  out.max_force = p.max_force;
  out.is_static = p.is_static;
  out.friction = p.friction;
  out.friction_velocity = p.friction_velocity;
  out.blocks = p.blocks;
  out.contacts = p.contacts;
  out.self_contact = p.self_contact;
  switch (p.depth) {
    case tetcollide_DEPTH_CFFM:
      out.depth = DepthMethod::kCffm;
      break;
    case tetcollide_DEPTH_EXACT:
      out.depth = DepthMethod::kExact;
      break;
    default:
      out.depth = DepthMethod::kCpfm;
      break;
  }
  switch (p.response) {
    case tetcollide_RESPONSE_POINT:
      out.response = ResponseKind::kPoint;
      break;
    case tetcollide_RESPONSE_SEGMENT:
      out.response = ResponseKind::kSegment;
      break;
    default:
      out.response = ResponseKind::kAuto;
      break;
  }
  return out;
}

Positions to_positions(std::span<const double> flat) {
  const auto n = static_cast<Eigen::Index>(flat.size() / 3);
  Positions p(3, n);
  if (n > 0) p = Eigen::Map<const Positions>(flat.data(), 3, n);
  return p;
}

std::int32_t status_code(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::kIo:
      return tetcollide_STATUS_IO;
    case ErrorCode::kParse:
      return tetcollide_STATUS_PARSE;
    case ErrorCode::kUnsupported:
      return tetcollide_STATUS_UNSUPPORTED;
    case ErrorCode::kInvalidMesh:
      return tetcollide_STATUS_INVALID_MESH;
    case ErrorCode::kInvalidArgument:
      return tetcollide_STATUS_INVALID_ARGUMENT;
    case ErrorCode::kUnknownObject:
      return tetcollide_STATUS_UNKNOWN_OBJECT;
    case ErrorCode::kStaleVersion:
      return tetcollide_STATUS_STALE_VERSION;
    case ErrorCode::kOversized:
      return tetcollide_STATUS_OVERSIZED;
  }
  return tetcollide_STATUS_INTERNAL;
}

}  // namespace tc::daemon
