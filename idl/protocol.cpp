#include "protocol.hpp"

#include <cstring>

namespace tc::protocol {

const char* topic_name(Topic topic) noexcept {
  switch (topic) {
    case Topic::kTopology:
      return "tetcollide/MeshTopology";
    case Topic::kState:
      return "tetcollide/MeshState";
    case Topic::kForces:
      return "tetcollide/ContactForces";
    case Topic::kStats:
      return "tetcollide/FrameStats";
    case Topic::kStatus:
      return "tetcollide/ServiceStatus";
  }
  return "";
}

const dds_topic_descriptor_t* topic_descriptor(Topic topic) noexcept {
  switch (topic) {
    case Topic::kTopology:
      return &tetcollide_MeshTopology_desc;
    case Topic::kState:
      return &tetcollide_MeshState_desc;
    case Topic::kForces:
      return &tetcollide_ContactForces_desc;
    case Topic::kStats:
      return &tetcollide_FrameStats_desc;
    case Topic::kStatus:
      return &tetcollide_ServiceStatus_desc;
  }
  return nullptr;
}

QosPtr topic_qos(Topic topic) {
  QosPtr qos(dds_create_qos());
  // Writers block at most this long when the reliable protocol's buffers are full
  // (a large topology on a slow link); the write then fails with a timeout.
  const dds_duration_t max_blocking = DDS_SECS(10);
  switch (topic) {
    case Topic::kTopology:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, max_blocking);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kTopologyDepth);
      // Late readers (a restarted service) get the same depth (durability_service).
      dds_qset_durability_service(qos.get(), 0, DDS_HISTORY_KEEP_LAST, kTopologyDepth,
                                  DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
      break;
    case Topic::kState:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, max_blocking);
      dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kStateDepth);
      break;
    case Topic::kForces:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, max_blocking);
      dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kForcesDepth);
      // Answers: a client sees only those of the strongest live service of the scene's
      // shard (ownership strength, dds.ownership_strength); the standbys' are dropped by
      // the client's reader until the owner's liveliness lease expires.
      dds_qset_ownership(qos.get(), DDS_OWNERSHIP_EXCLUSIVE);
      break;
    case Topic::kStats:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, max_blocking);
      dds_qset_durability(qos.get(), DDS_DURABILITY_VOLATILE);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kStatsDepth);
      dds_qset_ownership(qos.get(), DDS_OWNERSHIP_EXCLUSIVE);  // one set of answers, as forces
      break;
    case Topic::kStatus:
      dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, max_blocking);
      dds_qset_durability(qos.get(), DDS_DURABILITY_TRANSIENT_LOCAL);
      dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, kStatusDepth);
      // What a transient-local writer keeps for readers that join later is its
      // durability_service history, not its history: without this, Cyclone (default
      // KEEP_LAST 1) gave a late reader only the newest status sample (issue 14).
      dds_qset_durability_service(qos.get(), 0, DDS_HISTORY_KEEP_LAST, kStatusDepth,
                                  DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
      break;
  }
  // Every writer asserts its liveliness automatically (its participant does, while the
  // process runs) and is declared dead kLivelinessLease after it stopped: a killed
  // simulator's objects leave the scene about 1 s later instead of after Cyclone's 10 s
  // participant lease.
  dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC, kLivelinessLease);
  return qos;
}

QosPtr writer_qos(Topic topic, std::int32_t strength, dds_duration_t answer_lease) {
  QosPtr qos = topic_qos(topic);
  if (topic == Topic::kForces || topic == Topic::kStats) {
    dds_qset_ownership_strength(qos.get(), strength);
    // A writer may offer a shorter lease than the readers request (never a longer one).
    dds_qset_liveliness(qos.get(), DDS_LIVELINESS_AUTOMATIC,
                        answer_lease < kLivelinessLease ? answer_lease : kLivelinessLease);
  }
  return qos;
}

QosPtr partition_qos(const std::string& partition) {
  if (partition.empty()) return nullptr;
  QosPtr qos(dds_create_qos());
  dds_qset_partition1(qos.get(), partition.c_str());
  return qos;
}

std::string_view status_name(std::int32_t code) noexcept {
  switch (code) {
    case tetcollide_STATUS_OK:
      return "ok";
    case tetcollide_STATUS_IO:
      return "io";
    case tetcollide_STATUS_PARSE:
      return "parse";
    case tetcollide_STATUS_UNSUPPORTED:
      return "unsupported";
    case tetcollide_STATUS_INVALID_MESH:
      return "invalid_mesh";
    case tetcollide_STATUS_INVALID_ARGUMENT:
      return "invalid_argument";
    case tetcollide_STATUS_UNKNOWN_OBJECT:
      return "unknown_object";
    case tetcollide_STATUS_STALE_VERSION:
      return "stale_version";
    case tetcollide_STATUS_OVERSIZED:
      return "oversized";
    case tetcollide_STATUS_INTERNAL:
      return "internal";
    default:
      return "unknown";
  }
}

std::string dds_error(dds_return_t rc) {
  return std::string(dds_strretcode(-rc)) + " (" + std::to_string(rc) + ")";
}

bool copy_bounded(char* field, std::size_t capacity, std::string_view text) noexcept {
  if (capacity == 0) return false;
  if (text.size() >= capacity || text.find('\0') != std::string_view::npos) {
    field[0] = '\0';
    return false;
  }
  std::memcpy(field, text.data(), text.size());
  field[text.size()] = '\0';
  return true;
}

std::string_view bounded_view(const char* field, std::size_t capacity) noexcept {
  return {field, strnlen(field, capacity)};
}

}  // namespace tc::protocol
