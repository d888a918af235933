#include "dds_outbox.hpp"

#include <spdlog/spdlog.h>

#include <memory>
#include <vector>

#include "protocol.hpp"
#include "tetcollide.h"

namespace tc::daemon {
namespace {

tetcollide_ServiceState to_wire(ServiceState s) {
  switch (s) {
    case ServiceState::kStarting:
      return tetcollide_STATE_STARTING;
    case ServiceState::kReady:
      return tetcollide_STATE_READY;
    case ServiceState::kStopping:
      return tetcollide_STATE_STOPPING;
  }
  return tetcollide_STATE_STARTING;
}

tetcollide_StatusKind to_wire(StatusKind k) {
  switch (k) {
    case StatusKind::kHeartbeat:
      return tetcollide_KIND_HEARTBEAT;
    case StatusKind::kStateChange:
      return tetcollide_KIND_STATE_CHANGE;
    case StatusKind::kRegistered:
      return tetcollide_KIND_REGISTERED;
    case StatusKind::kRemoved:
      return tetcollide_KIND_REMOVED;
    case StatusKind::kError:
      return tetcollide_KIND_ERROR;
  }
  return tetcollide_KIND_ERROR;
}

/// Copies a name into a bounded field, cutting it when too long (names are validated
/// before they get here; this only guards the status topic against odd input).
template <std::size_t N>
void copy_cut(char (&field)[N], std::string_view text) {
  if (text.size() >= N) text = text.substr(0, N - 1);
  if (!protocol::copy_bounded(field, text)) field[0] = '\0';
}

/// An element of ContactForces.left_out: a sequence of char[MAX_OBJECT_NAME + 1].
struct WireObjectName {
  using Text = char[tetcollide_MAX_OBJECT_NAME + 1];
  Text text;
};
static_assert(sizeof(WireObjectName) == sizeof(WireObjectName::Text) &&
                  alignof(WireObjectName) == 1,
              "a vector of WireObjectName must be laid out as the wire's array of names");

Status create_writer(dds_entity_t publisher, dds_entity_t participant, protocol::Topic topic,
                     std::int32_t strength, dds_duration_t answer_lease, dds_entity_t& out) {
  const auto qos = protocol::topic_qos(topic);
  const dds_entity_t t = dds_create_topic(participant, protocol::topic_descriptor(topic),
                                          protocol::topic_name(topic), qos.get(), nullptr);
  if (t < 0)
    return Error{ErrorCode::kIo, std::string("dds_create_topic(") + protocol::topic_name(topic) +
                                     "): " + protocol::dds_error(t)};
  const auto wqos = protocol::writer_qos(topic, strength, answer_lease);
  out = dds_create_writer(publisher, t, wqos.get(), nullptr);
  if (out < 0)
    return Error{ErrorCode::kIo, std::string("dds_create_writer(") + protocol::topic_name(topic) +
                                     "): " + protocol::dds_error(out)};
  return {};
}

}  // namespace

DdsOutbox::DdsOutbox(std::string service_id, const DaemonConfig& config)
    : service_id_(std::move(service_id)),
      partition_(config.partition),
      ownership_strength_(config.ownership_strength),
      shard_strengths_(config.shard_strengths),
      answer_lease_(static_cast<dds_duration_t>(config.answer_lease_ms * 1e6)) {}

Status DdsOutbox::create(dds_entity_t participant) {
  const auto pqos = protocol::partition_qos(partition_);
  const dds_entity_t publisher = dds_create_publisher(participant, pqos.get(), nullptr);
  if (publisher < 0)
    return Error{ErrorCode::kIo, "dds_create_publisher: " + protocol::dds_error(publisher)};
  std::vector<std::int32_t> strengths{ownership_strength_};
  for (const auto& shard : shard_strengths_) strengths.push_back(shard.second);
  for (const std::int32_t strength : strengths) {
    if (answer_writers_.count(strength) != 0) continue;
    AnswerWriters& w = answer_writers_[strength];
    if (Status st = create_writer(publisher, participant, protocol::Topic::kForces, strength,
                                  answer_lease_, w.forces);
        !st)
      return st;
    if (Status st = create_writer(publisher, participant, protocol::Topic::kStats, strength,
                                  answer_lease_, w.stats);
        !st)
      return st;
    if (const dds_return_t rc = dds_get_instance_handle(w.stats, &w.stats_handle); rc < 0)
      return Error{ErrorCode::kIo,
                   "dds_get_instance_handle(FrameStats writer): " + protocol::dds_error(rc)};
  }
  return create_writer(publisher, participant, protocol::Topic::kStatus, ownership_strength_,
                       protocol::kLivelinessLease, status_writer_);
}

void DdsOutbox::watch(IncompatibleQosMonitor& monitor) const {
  for (const auto& [strength, w] : answer_writers_) {
    monitor.add_writer(w.forces, protocol::Topic::kForces);
    monitor.add_writer(w.stats, protocol::Topic::kStats);
  }
  monitor.add_writer(status_writer_, protocol::Topic::kStatus);
}

const DdsOutbox::AnswerWriters& DdsOutbox::answer_writers(std::string_view scene) const {
  // Every strength scene_strength() can return has its writers (create()).
  return answer_writers_.at(scene_strength(shard_strengths_, ownership_strength_, scene));
}

bool DdsOutbox::own_stats_writer(dds_instance_handle_t writer) const {
  for (const auto& [strength, w] : answer_writers_)
    if (w.stats_handle == writer) return true;
  return false;
}

void DdsOutbox::write_failed(const char* topic, dds_return_t rc) {
  const auto n = ++write_errors_;
  // Log the first few failures and then every 1000th: a dead link must not flood the log.
  if (n <= 10 || n % 1000 == 0)
    spdlog::error("dds_write({}) failed: {} ({} write errors so far)", topic,
                  protocol::dds_error(rc), n);
}

void DdsOutbox::publish_forces(const ForcesMessage& m) {
  tetcollide_ContactForces s{};
  copy_cut(s.scene, m.scene);
  copy_cut(s.object, m.object);
  s.frame = m.frame;
  s.topology_version = m.topology_version;
  s.status = m.status;
  s.state_frame = m.state_frame;
  s.answer_id = m.answer_id;
  protocol::borrow(s.nodes, const_cast<Index*>(m.nodes.data()), m.nodes.size());
  protocol::borrow(s.forces, const_cast<double*>(m.forces.data()), m.forces.size());
  protocol::borrow(s.stiffness, const_cast<double*>(m.stiffness.data()), m.stiffness.size());
  protocol::borrow(s.damping, const_cast<double*>(m.damping.data()), m.damping.size());
  // One wire name per left-out object; the names were checked on input (at most
  // MAX_OBJECT_NAME bytes), so none is cut here.
  std::vector<WireObjectName> left_out(m.left_out.size());
  for (std::size_t i = 0; i < left_out.size(); ++i) copy_cut(left_out[i].text, m.left_out[i]);
  protocol::borrow(s.left_out, reinterpret_cast<WireObjectName::Text*>(left_out.data()),
                   left_out.size());
  // The contacts behind the forces, for an object that asked (docs/PROTOCOL.md "Contacts").
  const std::size_t rows = m.contacts != nullptr ? m.contacts->rows.size() : 0;
  std::vector<WireObjectName> others(m.contacts != nullptr ? m.contacts->others.size() : 0);
  std::vector<std::int32_t> other(rows), nodes(2 * rows), tets(rows);
  std::unique_ptr<bool[]> intrudes;
  if (rows > 0) intrudes = std::make_unique<bool[]>(rows);
  std::vector<double> weights(2 * rows), bary(4 * rows), depths(rows), normals(3 * rows);
  for (std::size_t i = 0; i < others.size(); ++i) copy_cut(others[i].text, m.contacts->others[i]);
  for (std::size_t r = 0; r < rows; ++r) {
    const ObjectContacts::Row& row = m.contacts->rows[r];
    const ContactRow& c = row.contact;
    other[r] = static_cast<std::int32_t>(row.other);
    intrudes[r] = row.intrudes;
    for (int k = 0; k < 2; ++k) {
      nodes[2 * r + k] = static_cast<std::int32_t>(c.nodes[k]);
      weights[2 * r + k] = c.weights[k];
    }
    tets[r] = static_cast<std::int32_t>(c.tet);
    for (int k = 0; k < 4; ++k) bary[4 * r + k] = c.bary[k];
    depths[r] = c.depth;
    for (int k = 0; k < 3; ++k) normals[3 * r + k] = c.normal[k];
  }
  protocol::borrow(s.contact_objects, reinterpret_cast<WireObjectName::Text*>(others.data()),
                   others.size());
  protocol::borrow(s.contact_other, other.data(), rows);
  protocol::borrow(s.contact_intrudes, intrudes.get(), rows);
  protocol::borrow(s.contact_nodes, nodes.data(), nodes.size());
  protocol::borrow(s.contact_weights, weights.data(), weights.size());
  protocol::borrow(s.contact_tets, tets.data(), rows);
  protocol::borrow(s.contact_barycentric, bary.data(), bary.size());
  protocol::borrow(s.contact_depths, depths.data(), rows);
  protocol::borrow(s.contact_normals, normals.data(), normals.size());
  if (const dds_return_t rc = dds_write(answer_writers(m.scene).forces, &s); rc < 0)
    write_failed("ContactForces", rc);
}

void DdsOutbox::publish_stats(const StatsMessage& m) {
  tetcollide_FrameStats s{};
  copy_cut(s.scene, m.scene);
  s.frame = m.frame;
  s.assembly_ms = m.assembly_ms;
  s.queue_ms = m.queue_ms;
  s.broad_ms = m.core.broad_ms;
  s.narrow_ms = m.core.narrow_ms;
  s.depth_ms = m.core.depth_ms;
  s.response_ms = m.core.response_ms;
  s.compute_ms = m.core.total_ms;
  s.publish_ms = m.publish_ms;
  s.objects = m.objects;
  s.states = m.states;
  s.rejected = m.rejected;
  s.candidate_pairs = m.core.candidate_pairs;
  s.overlapping_pairs = m.core.overlapping_pairs;
  s.settled_nodes = m.core.settled_nodes;
  s.contacts = m.core.contacts;
  s.max_depth = m.core.max_depth;
  s.dropped_frames = m.dropped_frames;
  if (const dds_return_t rc = dds_write(answer_writers(m.scene).stats, &s); rc < 0)
    write_failed("FrameStats", rc);
}

void DdsOutbox::publish_status(const StatusMessage& m) {
  tetcollide_ServiceStatus s{};
  copy_cut(s.service_id, service_id_);
  s.sequence_number = ++sequence_;
  s.state = to_wire(static_cast<ServiceState>(state_.load()));
  s.kind = to_wire(m.kind);
  s.code = m.code;
  copy_cut(s.scene, m.scene);
  copy_cut(s.object, m.object);
  s.topology_version = m.topology_version;
  s.frame = m.frame;
  copy_cut(s.message, m.message);
  s.protocol_version = tetcollide_PROTOCOL_VERSION;
  s.topology_timestamp = m.topology_timestamp;
  s.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  s.ownership_strength = ownership_strength_;
  if (const dds_return_t rc = dds_write(status_writer_, &s); rc < 0)
    write_failed("ServiceStatus", rc);
}

void DdsOutbox::set_state(ServiceState state, const std::string& message) {
  state_.store(static_cast<int>(state));
  StatusMessage m;
  m.kind = StatusKind::kStateChange;
  m.code = tetcollide_STATUS_OK;
  m.message = message;
  publish_status(m);
}

}  // namespace tc::daemon
