// The parts of the wire protocol that are code rather than types: topic names, QoS,
// status code names and bounded-string helpers. Shared by tetcollided and the client
// library so both sides always agree. docs/PROTOCOL.md is the human-readable contract.
#pragma once

#include <dds/dds.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "tetcollide.h"

namespace tc::protocol {

/// The five topics of the protocol.
enum class Topic { kTopology, kState, kForces, kStats, kStatus };

/// DDS topic name, e.g. "tetcollide/MeshTopology".
const char* topic_name(Topic topic) noexcept;

/// Generated type descriptor of the topic's type.
const dds_topic_descriptor_t* topic_descriptor(Topic topic) noexcept;

/// History depth per instance of each topic (see docs/PROTOCOL.md, "QoS").
inline constexpr std::int32_t kTopologyDepth = 1;
inline constexpr std::int32_t kStateDepth = 1;
inline constexpr std::int32_t kForcesDepth = 8;
inline constexpr std::int32_t kStatsDepth = 16;
inline constexpr std::int32_t kStatusDepth = 32;
/// Liveliness lease of every writer (AUTOMATIC): a writer whose process stopped
/// asserting it for this long is declared dead (docs/PROTOCOL.md).
inline constexpr dds_duration_t kLivelinessLease = DDS_SECS(1);

struct QosDeleter {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

/// QoS of a topic; readers and writers are created with the same QoS so they always
/// match. ContactForces and FrameStats have EXCLUSIVE ownership (a service's writers add
/// their ownership strength, see writer_qos); the other topics SHARED. Never null
/// (dds_create_qos aborts on out-of-memory).
QosPtr topic_qos(Topic topic);

/// QoS of a service's writer of `topic`: topic_qos plus, for the EXCLUSIVE topics, the
/// ownership `strength` (the strongest live writer's samples are the ones readers see).
/// `answer_lease`: the liveliness lease the EXCLUSIVE writers offer (at most
/// kLivelinessLease, which readers request): the time a client's reader waits before it
/// takes the next strongest service's answers once the owner stopped (dds.answer_lease_ms).
QosPtr writer_qos(Topic topic, std::int32_t strength,
                  dds_duration_t answer_lease = kLivelinessLease);

/// Publisher/subscriber QoS selecting a DDS partition; null when `partition` is empty
/// (the default partition).
QosPtr partition_qos(const std::string& partition);

/// Stable lower-case name of a STATUS_* code ("ok", "invalid_mesh", ...), "unknown"
/// for a number the protocol does not define.
std::string_view status_name(std::int32_t code) noexcept;

/// "<dds_strretcode> (<rc>)" for a negative DDS return code.
std::string dds_error(dds_return_t rc);

/// Copies `text` into a bounded IDL string field of `capacity` bytes (bound + 1 for
/// the terminator). Returns false, leaving an empty string, when it does not fit or
/// contains a NUL byte.
bool copy_bounded(char* field, std::size_t capacity, std::string_view text) noexcept;
template <std::size_t N>
bool copy_bounded(char (&field)[N], std::string_view text) noexcept {
  return copy_bounded(field, N, text);
}

/// The text of a bounded IDL string field; never reads past `capacity` even when the
/// terminator is missing.
std::string_view bounded_view(const char* field, std::size_t capacity) noexcept;
template <std::size_t N>
std::string_view bounded_view(const char (&field)[N]) noexcept {
  return bounded_view(field, N);
}

/// Sequence view of a generated DDS_SEQUENCE over caller-owned memory (no copy, the
/// sequence does not free it).
template <typename Seq, typename T>
void borrow(Seq& seq, T* data, std::size_t length) noexcept {
  seq._buffer = data;
  seq._length = static_cast<std::uint32_t>(length);
  seq._maximum = static_cast<std::uint32_t>(length);
  seq._release = false;
}

}  // namespace tc::protocol
