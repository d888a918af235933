#include "core/pipeline/pipeline.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iterator>
#include <map>
#include <optional>
#include <stdexcept>

#include "core/common/log.hpp"
#include "core/depth/boundary_bvh.hpp"
#include "core/depth/depth_solver.hpp"
#include "core/depth/self_depth.hpp"
#include "core/detect/detect.hpp"
#include "core/detect/self_detect.hpp"
#include "core/detect/surface_detect.hpp"
#include "core/mesh/shape_check.hpp"
#include "core/mesh/topology.hpp"
#include "core/mesh/validate.hpp"
#include "core/response/response.hpp"

namespace tc {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// How many defects of each kind a rejection names (the validation's default).
constexpr std::size_t kListedInMessage = ValidationOptions{}.max_listed;

/// The per-frame state check: the same defects as at registration, without the smallest
/// quality (nothing reads it per frame), so well-shaped tets skip tet_quality(). It lists
/// up to max_inverted_tets defects of a kind, so a state accepted in the degraded mode
/// has all its inverted and degenerate tets listed.
ValidationOptions frame_validation(const PipelineConfig& config) {
  ValidationOptions o;
  o.compute_min_quality = false;
  o.max_listed = std::max(o.max_listed, config.max_inverted_tets);
  return o;
}

/// The rejection of a state whose report is not clean, naming at most kListedInMessage
/// defects of a kind, as the registration's check does.
Status reject_state(ValidationReport report, const std::string& who) {
  for (DefectList* list : {&report.nonfinite_node, &report.degenerate, &report.inverted})
    if (list->first.size() > kListedInMessage) list->first.resize(kListedInMessage);
  return require_valid(report, who);
}

/// Removes from an object's self-contacts every overlap, intruding node and edge with a
/// tet in `out` (sorted: the tets a degraded state leaves out of contact), and makes the
/// marked lists again from the overlaps left (for a part of one component with itself,
/// both lists hold every tet of the part, as SelfCollider makes them).
void drop_left_out(SelfContacts& contacts, std::span<const Index> out) {
  const auto left_out = [&](Index t) { return std::binary_search(out.begin(), out.end(), t); };
  const auto sorted = [](std::vector<Index>& v) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  };
  std::vector<SelfContactPart> kept;
  contacts.marked.clear();
  for (SelfContactPart& part : contacts.parts) {
    PairContacts& c = part.contacts;
    std::erase_if(c.overlapping,
                  [&](const TetPair& p) { return left_out(p.tet_a) || left_out(p.tet_b); });
    if (c.overlapping.empty()) continue;
    for (auto* nodes : {&c.nodes_a_in_b, &c.nodes_b_in_a})
      std::erase_if(*nodes, [&](const IntrudingNode& n) { return left_out(n.tet); });
    for (auto* edges : {&c.edges_a_in_b, &c.edges_b_in_a})
      std::erase_if(*edges, [&](const IntrudingEdge& e) { return left_out(e.tet); });
    c.marked_a.clear();
    c.marked_b.clear();
    for (const TetPair& p : c.overlapping) {
      c.marked_a.push_back(p.tet_a);
      c.marked_b.push_back(p.tet_b);
    }
    if (part.component_a == part.component_b) {
      c.marked_a.insert(c.marked_a.end(), c.marked_b.begin(), c.marked_b.end());
      sorted(c.marked_a);
      c.marked_b = c.marked_a;
    } else {
      sorted(c.marked_a);
      sorted(c.marked_b);
    }
    contacts.marked.insert(contacts.marked.end(), c.marked_a.begin(), c.marked_a.end());
    contacts.marked.insert(contacts.marked.end(), c.marked_b.begin(), c.marked_b.end());
    kept.push_back(std::move(part));
  }
  sorted(contacts.marked);
  contacts.parts = std::move(kept);
}

}  // namespace

/// Self-contact of one object (ObjectParams::self_contact, tet objects): its detector, what
/// the response leaves out of a node's face search, and this frame's contacts. At namespace
/// scope, not nested in SceneObject: clang decides std::optional of a nested class with
/// default member initializers is not default-constructible while the outer class is open.
struct SelfContactState {
  std::unique_ptr<SelfCollider> collider;
  std::vector<Index> node_component;
  SelfContactView view;
  SelfContacts contacts;
  bool stale = true;  ///< positions changed since `contacts` were found
};

// One registered object: its topology-derived data (built in set_topology or
// set_surface) and its per-frame state. A surface object has `surface` set, an empty
// `mesh`, an edge topology and no body, check order or depth solver.
struct SceneObject {
  std::string name;
  std::uint32_t version = 0;
  ObjectParams params;
  TetMesh mesh;  ///< tets, node ids, rest positions
  Topology topology;
  /// A surface object: its triangles and their edges (nullopt for a tet object).
  struct Surface {
    SurfaceMesh mesh;
    SurfaceEdges edges;
  };
  std::optional<Surface> surface;
  /// The tets along a Morton curve of their rest centroids, for the per-frame shape check.
  TetCheckOrder check_order;
  /// The per-frame shape check (tet objects): reads check_order and topology.node_tets.
  std::unique_ptr<ShapeCheck> shape_check;
  Positions positions;   ///< current frame's positions
  Positions velocities;  ///< current frame's velocities, or empty (at rest)
  std::unique_ptr<CollisionBody> body;
  std::unique_ptr<DepthSolver> depth;
  std::optional<SelfContactState> self;  ///< ObjectParams::self_contact, tet objects
  bool static_depth_ready = false;       ///< static objects: full map computed once
  /// A state of this version was applied: until then a moving object's positions are its
  /// rest positions, which are not a state, and it takes no part in contact.
  bool has_state = false;
  /// `positions` changed since the body last read them (a state was applied, or the
  /// object is new): else the body keeps its bounds and trees (CollisionBody::reuse_positions).
  bool moved = true;
  /// The box of `positions` when the state's shape check made it (every node read, every
  /// node finite): the body then need not read the nodes again for it.
  std::optional<Aabb> state_box;
  /// `positions` are the state the shape check accepted last (this frame): its bound
  /// goes to the body with them.
  bool state_checked = false;
  /// The inverted and degenerate tets of `positions`, sorted (a state accepted in the
  /// degraded mode, PipelineConfig::max_inverted_tets): left out of every contact.
  std::vector<Index> left_out_tets;
  // Per-frame scratch.
  std::vector<Index> marked;
  bool involved = false;

  [[nodiscard]] Index num_nodes() const {
    return surface ? surface->mesh.num_nodes() : mesh.num_nodes();
  }
  [[nodiscard]] Aabb box() const;
  [[nodiscard]] ResponseObject response_view() const;
};

Aabb SceneObject::box() const {
  if (!surface) return body->box();
  Aabb box;  // the used nodes' box: unused nodes take part in nothing
  for (const Triangle& t : surface->mesh.triangles)
    for (const Index v : t) box.extend(positions.col(v));
  return box;
}

ResponseObject SceneObject::response_view() const {
  ResponseObject o;
  o.positions = &positions;
  o.topology = &topology;
  o.velocities =
      velocities.cols() == positions.cols() && velocities.size() != 0 ? &velocities : nullptr;
  if (surface) {
    o.triangles = surface->mesh.triangles;
  } else {
    o.tets = mesh.tets;
    o.depth = depth->depth();
    o.anchor = depth->anchor();
    if (self) o.self = &self->view;
  }
  return o;
}

struct Pipeline::Impl {
  PipelineConfig config;
  std::map<std::string, std::unique_ptr<SceneObject>> objects;  // sorted by name
  Detector detector;
  DetectOptions detect_options;  // the surface pairs' (the detector keeps its own)
  ResponseAccumulator accumulator;
  std::vector<PairContacts> contacts;  // per touching pair, reused
  PairResponse pair_response;
  ValidationOptions frame_checks;  // the per-frame shape check's (frame_validation())

  static Status check_params(const std::string& object, const ObjectParams& params);

  // The steps of one frame (run_frame), in the order they run.

  /// The most inverted and degenerate tets a state of `obj` may have and still be
  /// accepted (PipelineConfig::max_inverted_tets and max_inverted_fraction).
  [[nodiscard]] std::size_t allowed_bad_tets(const SceneObject& obj) const;

  /// 1. States: checked object by object; a bad one is rejected, the rest run.
  /// Velocities hold for the frame they came with: an object without a state counts as
  /// at rest. `take` non-empty: the states' matrices are swapped in, not copied.
  void apply_states(std::int64_t frame, std::span<const FrameObjectInput> states,
                    std::span<FrameObjectInput> take, FrameOutput& out);
  /// 2. Broad phase over objects: the objects that take part (frame_objects, bodies told
  /// their positions), their boxes, and the pairs that touch and are enabled (frame_pairs).
  void object_pairs(FrameOutput& out);
  /// The response settings of a pair: the two objects' and the service's.
  [[nodiscard]] ResponseOptions response_options(const SceneObject& a, const SceneObject& b) const;
  /// 3. Detection per pair (the detector's inner loops run on TBB): contacts[p], the
  ///    marked tets of the involved objects, and the response kinds decided on the way.
  void detect_pairs(FrameOutput& out);
  /// 3b. Self-contact of the objects that ask for it (their contacts stay while they do
  ///     not move).
  void detect_self(FrameOutput& out);
  /// 4. Lazy depth maps of the involved objects, in parallel across objects. Static
  ///    objects compute their full map once and keep it.
  void update_depth_maps(FrameOutput& out);
  /// 5. Response per pair, summed per object in pair order (deterministic); the forces,
  ///    contact rows and the per-object force cap.
  void respond(FrameOutput& out);

  // Per-frame scratch of the steps above.
  std::vector<SceneObject*> frame_objects;
  std::vector<std::pair<Index, Index>> frame_pairs;                 // into frame_objects
  std::vector<std::optional<std::array<ResponseKind, 2>>> decided;  // per pair
};

Status Pipeline::Impl::check_params(const std::string& object, const ObjectParams& params) {
  const auto bad = [](double v) { return !(v >= 0.0) || !std::isfinite(v); };
  if (bad(params.stiffness) || bad(params.damping) || bad(params.max_force))
    return Error{
        ErrorCode::kInvalidArgument,
        "object '" + object + "': stiffness, damping and max_force must be finite and >= 0"};
  if (bad(params.friction) || bad(params.friction_velocity))
    return Error{ErrorCode::kInvalidArgument,
                 "object '" + object + "': friction (" + std::to_string(params.friction) +
                     ") and friction_velocity (" + std::to_string(params.friction_velocity) +
                     ") must be finite and >= 0"};
  return {};
}

ResponseOptions pair_options(const ObjectParams& a, const ObjectParams& b) {
  ResponseOptions o;
  if (a.response == b.response)
    o.kind = a.response;
  else if (a.response == ResponseKind::kAuto)
    o.kind = b.response;
  else if (b.response == ResponseKind::kAuto)
    o.kind = a.response;
  else
    o.kind = ResponseKind::kSegment;
  o.stiffness = std::min(a.stiffness, b.stiffness);
  o.damping = std::max(a.damping, b.damping);
  o.friction = std::sqrt(a.friction * b.friction);
  const auto eps = [](double v) { return v > 0.0 ? v : kDefaultFrictionVelocity; };
  o.friction_velocity = std::max(eps(a.friction_velocity), eps(b.friction_velocity));
  if (a.blocks || b.blocks) o.stiffness_mode = StiffnessMode::kLumped;
  o.report_contacts = a.contacts || b.contacts;
  return o;
}

Pipeline::Pipeline(PipelineConfig config) : impl_(std::make_unique<Impl>()) {
  impl_->config = std::move(config);
  if (!(impl_->config.max_inverted_fraction >= 0.0 && impl_->config.max_inverted_fraction <= 1.0))
    throw std::invalid_argument("max_inverted_fraction " +
                                std::to_string(impl_->config.max_inverted_fraction) +
                                " is not in [0, 1]");
  impl_->frame_checks = frame_validation(impl_->config);
  DetectOptions options;
  if (!impl_->config.broad_phase.empty()) {
    const auto kind = parse_broad_phase(impl_->config.broad_phase);
    if (!kind)
      throw std::invalid_argument("unknown broad phase '" + impl_->config.broad_phase +
                                  "' (expected grid, hash, sap or bvh)");
    options.broad_phase = *kind;
  }
  impl_->detector.set_options(options);
  impl_->detect_options = options;
}

Pipeline::~Pipeline() = default;

Status Pipeline::set_topology(const std::string& object, std::uint32_t version, TetMesh mesh,
                              const ObjectParams& params) {
  const ValidationReport report = validate_mesh(mesh);
  if (Status st = require_valid(report, "object '" + object + "'"); !st) return st;
  if (mesh.tets.empty()) return Error{ErrorCode::kInvalidMesh, "object '" + object + "': no tets"};
  if (Status st = Impl::check_params(object, params); !st) return st;
  if (report.sliver.count > 0) {
    // Slivers are accepted (a cut or a coarse mesher makes them); say so once per version.
    ValidationReport slivers;
    slivers.sliver = report.sliver;
    log(LogLevel::kWarn, "object '" + object + "' version " + std::to_string(version) + ": " +
                             slivers.summary() +
                             " (quality below 0.01), kept: contacts in them are less accurate");
  }
  auto slot = std::make_unique<SceneObject>();
  slot->name = object;
  slot->version = version;
  slot->params = params;
  slot->topology = build_topology(mesh.tets, mesh.num_nodes());
  slot->positions = mesh.positions;
  slot->mesh = std::move(mesh);
  // The detection body and the depth solver only read the mesh and the topology:
  // built side by side.
  DepthSolverOptions depth_options;
  depth_options.method = params.depth;
  depth_options.lazy_region = impl_->config.lazy_region;
  tbb::parallel_invoke(
      [&] {
        slot->body = std::make_unique<CollisionBody>(slot->mesh.tets, slot->topology);
        slot->check_order = make_tet_check_order(slot->mesh.positions, slot->mesh.tets);
      },
      [&] {
        slot->depth = std::make_unique<DepthSolver>(std::span<const Tet>(slot->mesh.tets),
                                                    slot->topology, depth_options);
      });
  slot->shape_check = std::make_unique<ShapeCheck>(slot->check_order, slot->topology.node_tets,
                                                   slot->mesh.num_nodes(), impl_->frame_checks);
  if (params.self_contact) {
    auto& self = slot->self.emplace();
    self.collider = std::make_unique<SelfCollider>(std::span<const Tet>(slot->mesh.tets),
                                                   slot->topology, slot->mesh.positions);
    self.node_component = node_components(slot->topology);
    self.view.node_component = self.node_component;
  }
  impl_->objects[object] = std::move(slot);
  return {};
}

Status Pipeline::set_surface(const std::string& object, std::uint32_t version, SurfaceMesh mesh,
                             const ObjectParams& params) {
  const SurfaceValidationReport report = validate_surface(mesh);
  if (Status st = require_valid_surface(report, "object '" + object + "'"); !st) return st;
  if (mesh.triangles.empty())
    return Error{ErrorCode::kInvalidMesh, "object '" + object + "': no triangles"};
  if (Status st = Impl::check_params(object, params); !st) return st;
  if (params.self_contact)
    return Error{ErrorCode::kUnsupported,
                 "object '" + object +
                     "': params.self_contact: a surface object has no depth map, so nothing "
                     "can be pushed out of it (self-contact is for tet objects)"};
  auto slot = std::make_unique<SceneObject>();
  slot->name = object;
  slot->version = version;
  slot->params = params;
  slot->surface.emplace();
  slot->surface->edges = build_surface_edges(mesh.triangles);
  slot->topology = build_edge_topology(slot->surface->edges.edges, mesh.num_nodes());
  slot->positions = mesh.positions;
  slot->surface->mesh = std::move(mesh);
  impl_->objects[object] = std::move(slot);
  return {};
}

bool Pipeline::is_surface(const std::string& object) const {
  const auto it = impl_->objects.find(object);
  return it != impl_->objects.end() && it->second->surface.has_value();
}

void Pipeline::remove_object(const std::string& object) {
  impl_->objects.erase(object);
}

bool Pipeline::has_object(const std::string& object) const {
  return impl_->objects.count(object) > 0;
}

const ObjectParams* Pipeline::params(const std::string& object) const {
  const auto it = impl_->objects.find(object);
  return it == impl_->objects.end() ? nullptr : &it->second->params;
}

Pipeline::StiffnessCaps Pipeline::stiffness_caps(const std::string& object) const {
  StiffnessCaps out;
  const ObjectParams* own = params(object);
  if (own == nullptr) return out;
  for (const auto& [name, other] : impl_->objects) {
    if (name == object || (own->is_static && other->params.is_static)) continue;
    if (other->params.stiffness < own->stiffness)
      out.capped_by.emplace_back(name, other->params.stiffness);
    else if (other->params.stiffness > own->stiffness)
      out.caps.emplace_back(name, other->params.stiffness);
  }
  return out;
}

FrameOutput Pipeline::run_frame(std::int64_t frame, std::span<const FrameObjectInput> states) {
  return run_frame(frame, states, {});
}

FrameOutput Pipeline::run_frame_taking(std::int64_t frame, std::span<FrameObjectInput> states) {
  return run_frame(frame, states, states);
}

FrameOutput Pipeline::run_frame(std::int64_t frame, std::span<const FrameObjectInput> states,
                                std::span<FrameObjectInput> take) {
  const auto frame_start = Clock::now();
  FrameOutput out;
  out.frame = frame;
  impl_->apply_states(frame, states, take, out);
  impl_->object_pairs(out);
  impl_->detect_pairs(out);
  impl_->detect_self(out);
  impl_->update_depth_maps(out);
  impl_->respond(out);
  out.stats.total_ms = ms_since(frame_start);
  return out;
}

std::size_t Pipeline::Impl::allowed_bad_tets(const SceneObject& obj) const {
  const auto by_fraction = static_cast<std::size_t>(
      std::floor(config.max_inverted_fraction * static_cast<double>(obj.mesh.tets.size())));
  return std::min(config.max_inverted_tets, by_fraction);
}

void Pipeline::Impl::apply_states(std::int64_t frame, std::span<const FrameObjectInput> states,
                                  std::span<FrameObjectInput> take, FrameOutput& out) {
  for (auto& [name, obj] : objects) obj->velocities.resize(3, 0);
  for (std::size_t k = 0; k < states.size(); ++k) {
    const FrameObjectInput& state = states[k];
    const auto it = objects.find(state.object);
    const std::string who = "object '" + state.object + "' frame " + std::to_string(frame);
    if (it == objects.end()) {
      out.errors.push_back({state.object, {ErrorCode::kUnknownObject, who + ": unknown object"}});
      continue;
    }
    SceneObject& obj = *it->second;
    if (state.topology_version != obj.version) {
      out.errors.push_back({state.object,
                            {ErrorCode::kStaleVersion,
                             who + ": topology version " + std::to_string(state.topology_version) +
                                 " is not the registered version " + std::to_string(obj.version)}});
      continue;
    }
    if (state.positions.cols() != obj.num_nodes()) {
      out.errors.push_back({state.object,
                            {ErrorCode::kInvalidArgument,
                             who + ": " + std::to_string(state.positions.cols()) +
                                 " positions for " + std::to_string(obj.num_nodes()) + " nodes"}});
      continue;
    }
    if (state.velocities.size() != 0 &&
        (state.velocities.cols() != obj.num_nodes() || !state.velocities.allFinite())) {
      out.errors.push_back(
          {state.object,
           {ErrorCode::kInvalidArgument,
            who + ": velocities must be empty or " + std::to_string(obj.num_nodes()) +
                " finite columns (got " + std::to_string(state.velocities.cols()) + ")"}});
      continue;
    }
    // The registration's checks on the new positions: NaN, and inverted or degenerate
    // tets (degenerate triangles for a surface). A few inverted or degenerate tets are
    // accepted, left out of contact (the degraded mode); more are rejected.
    std::vector<Index> left_out;
    if (obj.surface) {
      const Status shape = require_valid_surface(
          validate_surface(state.positions, obj.surface->mesh.triangles), who);
      if (!shape) {
        out.errors.push_back({state.object, shape.error()});
        continue;
      }
    } else {
      const ValidationReport report = obj.shape_check->check(state.positions);
      const std::size_t bad = report.inverted.count + report.degenerate.count;
      const std::size_t allowed = allowed_bad_tets(obj);
      if (report.structurally_invalid() || bad > allowed) {
        out.errors.push_back({state.object, reject_state(report, who).error()});
        continue;
      }
      if (bad > 0) {  // (bad <= max_inverted_tets <= max_listed: every one is listed)
        std::merge(report.inverted.first.begin(), report.inverted.first.end(),
                   report.degenerate.first.begin(), report.degenerate.first.end(),
                   std::back_inserter(left_out));
        out.degraded.push_back(
            {state.object, report.inverted.count, report.degenerate.count, allowed, left_out});
      }
    }
    if (obj.params.is_static && obj.static_depth_ready && state.positions != obj.positions)
      obj.static_depth_ready = false;  // a "static" object moved: recompute once
    if (take.empty()) {
      obj.positions = state.positions;
      obj.velocities = state.velocities;
    } else {  // the same states: swapped in, the state gets the object's old matrices
      obj.positions.swap(take[k].positions);
      obj.velocities.swap(take[k].velocities);
    }
    obj.has_state = true;
    obj.moved = true;
    if (!obj.surface && (!left_out.empty() || !obj.left_out_tets.empty())) {
      obj.left_out_tets = std::move(left_out);
      obj.body->set_left_out_tets(obj.left_out_tets);
    }
    if (obj.self) obj.self->stale = true;
    obj.state_box.reset();
    obj.state_checked = !obj.surface;
    if (!obj.surface && obj.shape_check->last().has_box)
      obj.state_box = Aabb{obj.shape_check->last().box_lo, obj.shape_check->last().box_hi};
  }
}

void Pipeline::Impl::object_pairs(FrameOutput& out) {
  const auto t0 = Clock::now();
  std::vector<SceneObject*>& list = frame_objects;
  list.clear();
  list.reserve(objects.size());
  for (auto& [name, obj] : objects) {
    if (!obj->has_state && !obj->params.is_static) {
      out.left_out.push_back(name);  // no state of its version yet: no pair with it
      continue;
    }
    if (obj->body) {
      if (obj->moved && obj->state_checked)  // the shape check's bound (and box) of the state
        obj->body->set_positions(obj->positions, obj->shape_check->bound(),
                                 obj->state_box ? &*obj->state_box : nullptr);
      else if (obj->moved)  // rest positions (a static object), no check
        obj->body->set_positions(obj->positions);
      else
        obj->body->reuse_positions();  // at rest: its bounds and trees still hold
      obj->moved = false;
    }
    obj->state_checked = false;
    obj->marked.clear();
    obj->involved = false;
    list.push_back(obj.get());
  }
  out.stats.objects = list.size();
  std::vector<Aabb> boxes;
  boxes.reserve(list.size());
  for (const SceneObject* obj : list) boxes.push_back(obj->box());
  // Two static objects never meet; two surfaces are never tested (neither has a depth map
  // to push the other out of).
  frame_pairs = touching_object_pairs(boxes, [&](Index i, Index j) {
    return !(list[i]->params.is_static && list[j]->params.is_static) &&
           !(list[i]->surface && list[j]->surface);
  });
  out.stats.broad_ms += ms_since(t0);
}

ResponseOptions Pipeline::Impl::response_options(const SceneObject& a, const SceneObject& b) const {
  ResponseOptions options = pair_options(a.params, b.params);
  if (config.compute_stiffness) options.stiffness_mode = StiffnessMode::kLumped;
  if (config.density_threshold > 0.0) options.auto_threshold = config.density_threshold;
  options.record_contacts = config.record_contacts;
  options.evaluation = config.evaluation;
  return options;
}

void Pipeline::Impl::detect_pairs(FrameOutput& out) {
  const auto& list = frame_objects;
  const auto& pairs = frame_pairs;
  if (contacts.size() < pairs.size()) contacts.resize(pairs.size());
  decided.assign(pairs.size(), std::nullopt);
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    DetectStats ds;
    SceneObject& a = *list[pairs[p].first];
    SceneObject& b = *list[pairs[p].second];
    if (a.surface || b.surface) {
      // Surface against tets: one-off detection (its broad phase included), timed as the
      // narrow phase.
      const auto start = Clock::now();
      const SceneObject& s = a.surface ? a : b;
      const SceneObject& t = a.surface ? b : a;
      SurfaceDetectStats ss;
      contacts[p] = to_pair_contacts(
          detect_surface_tets(s.positions, s.surface->mesh.triangles, s.surface->edges, t.positions,
                              t.mesh.tets, detect_options, &ss, t.left_out_tets),
          a.surface.has_value());
      ds.narrow_ms = ms_since(start);
      ds.candidates = ss.candidates;
      ds.overlapping = ss.overlapping;
    } else {
      // A direction answered by points reads the nodes inside the other object only: its
      // intruding edges (the segment response's input, the largest part of the narrow
      // phase) are left out. The response makes the same choice from the same marked
      // tets, so the forces are the same bits either way.
      // The choice is kept for the response stage, which does not measure again.
      const ResponseObject ra = a.response_view();
      const ResponseObject rb = b.response_view();
      const ResponseOptions options = response_options(a, b);
      detector.detect(
          *a.body, *b.body, contacts[p], &ds, [&](const PairContacts& c) -> std::array<bool, 2> {
            const auto kinds = response_kinds(ra, c.marked_a, rb, c.marked_b, options);
            decided[p] = kinds;
            return {kinds[0] == ResponseKind::kSegment, kinds[1] == ResponseKind::kSegment};
          });
    }
    out.stats.broad_ms += ds.broad_ms;
    out.stats.narrow_ms += ds.narrow_ms;
    out.stats.candidate_pairs += ds.candidates;
    out.stats.overlapping_pairs += ds.overlapping;
    if (contacts[p].empty()) continue;
    a.involved = b.involved = true;
    a.marked.insert(a.marked.end(), contacts[p].marked_a.begin(), contacts[p].marked_a.end());
    b.marked.insert(b.marked.end(), contacts[p].marked_b.begin(), contacts[p].marked_b.end());
  }
}

void Pipeline::Impl::detect_self(FrameOutput& out) {
  for (SceneObject* obj : frame_objects) {
    if (!obj->self) continue;
    SelfContactState& self = *obj->self;
    if (self.stale) {
      SelfDetectStats st;
      // The shape check's bound is of these positions (or not bounded: a rejected or
      // degraded state, none yet); its versions tell the collider what it missed.
      const MotionBound bound = obj->shape_check->bound();
      self.collider->detect(obj->positions, detect_options.relative_tolerance, self.contacts, &st,
                            &bound);
      if (!obj->left_out_tets.empty()) drop_left_out(self.contacts, obj->left_out_tets);
      self.stale = false;
      out.stats.broad_ms += st.surface_ms;
      out.stats.narrow_ms += st.tets_ms;
      out.stats.candidate_pairs += st.candidates;
      out.stats.overlapping_pairs += st.overlapping;
    } else {
      for (const SelfContactPart& part : self.contacts.parts)
        out.stats.overlapping_pairs += part.contacts.overlapping.size();
    }
    if (self.contacts.empty()) continue;
    obj->involved = true;
    obj->marked.insert(obj->marked.end(), self.contacts.marked.begin(), self.contacts.marked.end());
  }
}

void Pipeline::Impl::update_depth_maps(FrameOutput& out) {
  const auto& list = frame_objects;
  const auto t0 = Clock::now();
  std::vector<SceneObject*> involved;
  for (SceneObject* obj : list)
    if (obj->involved && !obj->surface) involved.push_back(obj);  // a surface has no map
  std::vector<std::size_t> settled(involved.size(), 0);
  std::vector<std::string> depth_errors(involved.size());
  tbb::parallel_for(std::size_t{0}, involved.size(), [&](std::size_t i) {
    SceneObject& obj = *involved[i];
    std::sort(obj.marked.begin(), obj.marked.end());
    obj.marked.erase(std::unique(obj.marked.begin(), obj.marked.end()), obj.marked.end());
    if (obj.params.is_static) {
      if (!obj.static_depth_ready) {
        const Status st = obj.depth->compute(obj.positions);
        if (!st) depth_errors[i] = st.error().message;
        obj.static_depth_ready = st.ok();
        settled[i] = obj.depth->settled_count();
      }
      return;
    }
    auto n = obj.depth->compute_lazy(obj.positions, obj.marked);
    if (n) {
      settled[i] = *n;
    } else {
      depth_errors[i] = n.error().message;
    }
  });
  for (std::size_t i = 0; i < involved.size(); ++i) {
    out.stats.settled_nodes += settled[i];
    out.settled_by_object.emplace_back(involved[i]->name, settled[i]);
    if (!depth_errors[i].empty())
      out.errors.push_back({involved[i]->name, {ErrorCode::kInvalidArgument, depth_errors[i]}});
  }
  out.stats.depth_ms = ms_since(t0);
}

void Pipeline::Impl::respond(FrameOutput& out) {
  const auto& list = frame_objects;
  const auto& pairs = frame_pairs;
  const auto t0 = Clock::now();
  std::map<std::string, ObjectForces> totals;
  std::map<std::string, ObjectContacts> contact_rows;  // objects that asked for them
  // The rows of a pair for object `self` (one of the pair), if it asked for them.
  const auto add_rows = [&](const SceneObject& self, const SceneObject& other, bool self_is_a,
                            const std::vector<ContactRow>& rows) {
    if (!self.params.contacts || rows.empty()) return;
    ObjectContacts& oc = contact_rows[self.name];
    oc.object = self.name;
    const auto at = std::find(oc.others.begin(), oc.others.end(), other.name);
    const auto index = static_cast<std::uint32_t>(at - oc.others.begin());
    if (at == oc.others.end()) oc.others.push_back(other.name);
    for (const ContactRow& row : rows)
      oc.rows.push_back({index, row.intruder_is_a == self_is_a, row});
  };
  // One pair's response (a self-contact part: a and b the same object), summed in.
  const auto answer = [&](const SceneObject& a, const SceneObject& b,
                          const PairContacts& pair_contacts,
                          const std::optional<std::array<ResponseKind, 2>>& kinds) {
    const ResponseObject ra = a.response_view();
    const ResponseObject rb = b.response_view();
    ResponseOptions options = response_options(a, b);
    options.decided_kinds = kinds;
    PairResponse& response = pair_response;
    const Status st = accumulator.compute(ra, rb, pair_contacts, options, response);
    if (!st) {
      out.errors.push_back({&a == &b ? a.name : a.name + "/" + b.name, st.error()});
      return;
    }
    out.stats.contacts += response.stats.point_contacts + response.stats.segment_contacts;
    out.stats.symmetric_pairs += response.stats.symmetric_pairs;
    out.stats.max_depth = std::max(out.stats.max_depth, response.stats.max_depth);
    for (const PointContactRecord& c : response.point_contacts)
      out.point_contacts.push_back({c.intruder_is_a ? a.name : b.name,
                                    c.intruder_is_a ? b.name : a.name, c.node, c.tet, c.depth,
                                    c.normal});
    if (!response.a.nodes.empty()) add_object_forces(totals[a.name], response.a);
    if (!response.b.nodes.empty()) add_object_forces(totals[b.name], response.b);
    if (&a == &b) {  // the object is both sides: each row once, as its own intrusion
      if (!a.params.contacts || response.contacts.empty()) return;
      std::vector<ContactRow> rows = response.contacts;
      for (ContactRow& row : rows) row.intruder_is_a = true;
      add_rows(a, a, true, rows);
      return;
    }
    add_rows(a, b, true, response.contacts);
    add_rows(b, a, false, response.contacts);
  };
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    if (contacts[p].empty()) continue;
    answer(*list[pairs[p].first], *list[pairs[p].second], contacts[p], decided[p]);
  }
  for (const SceneObject* obj : list) {
    if (!obj->self) continue;
    for (const SelfContactPart& part : obj->self->contacts.parts)
      answer(*obj, *obj, part.contacts, std::nullopt);
  }
  for (auto& [name, rows] : contact_rows) out.contacts.push_back(std::move(rows));
  for (auto& [name, forces] : totals) {
    const ObjectParams& params = objects.at(name)->params;
    if (!params.blocks && !config.compute_stiffness) {  // made for the other object
      forces.stiffness.clear();
      forces.damping.clear();
    }
    cap_object_forces(forces, params.max_force);
    forces.object = name;
    out.forces.push_back(std::move(forces));
  }
  out.stats.response_ms = ms_since(t0);
}

Expected<std::vector<double>> Pipeline::exact_depths(
    std::span<const FramePointContact> contacts) const {
  std::map<std::string, BoundaryBvh<3>> bvhs;
  std::vector<double> out;
  out.reserve(contacts.size());
  for (const FramePointContact& c : contacts) {
    const auto intruder = impl_->objects.find(c.object);
    const auto target = impl_->objects.find(c.penetrated);
    if (intruder == impl_->objects.end() || target == impl_->objects.end())
      return Error{ErrorCode::kUnknownObject,
                   "exact_depths: unknown object '" +
                       (intruder == impl_->objects.end() ? c.object : c.penetrated) + "'"};
    const Positions& x = intruder->second->positions;
    if (c.node < 0 || c.node >= x.cols())
      return Error{ErrorCode::kInvalidArgument, "exact_depths: node " + std::to_string(c.node) +
                                                    " of '" + c.object + "' out of range"};
    auto [it, fresh] = bvhs.try_emplace(c.penetrated);
    const SceneObject& y = *target->second;
    if (fresh) it->second.build(y.topology.boundary_faces, y.positions);
    if (intruder == target && y.self) {
      if (c.tet < 0 || c.tet >= static_cast<Index>(y.mesh.tets.size()))
        return Error{ErrorCode::kInvalidArgument, "exact_depths: tet " + std::to_string(c.tet) +
                                                      " of '" + c.penetrated + "' out of range"};
      out.push_back(exact_self_depth(it->second, y.topology, y.self->node_component, y.positions,
                                     c.node, c.tet));
      continue;
    }
    out.push_back(std::sqrt(it->second.nearest(x.col(c.node)).sq_dist));
  }
  return out;
}

}  // namespace tc
