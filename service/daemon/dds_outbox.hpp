// The daemon's Outbox over DDS: one writer per output topic (ContactForces, FrameStats,
// ServiceStatus). Every ServiceStatus sample is stamped with the service id, the
// current life-cycle state and a sequence number. Thread-safe (dds_write is).
#pragma once

#include <dds/dds.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "config.hpp"
#include "core/common/result.hpp"
#include "outbox.hpp"
#include "qos_check.hpp"

namespace tc::daemon {

class DdsOutbox final : public Outbox {
 public:
  /// `config.ownership_strength` and `config.shard_strengths`: of the ContactForces and
  /// FrameStats writers (EXCLUSIVE ownership), one pair of writers per distinct strength,
  /// each scene's answers written by the pair of its strength; `config.answer_lease_ms`:
  /// the liveliness lease those writers offer (at most the protocol's 1 s);
  /// `config.partition`: the DDS partition of every writer.
  DdsOutbox(std::string service_id, const DaemonConfig& config);

  /// Creates the topics' writers under `participant`. Errors name the DDS call.
  Status create(dds_entity_t participant);

  void publish_forces(const ForcesMessage& message) override;
  void publish_stats(const StatsMessage& message) override;
  void publish_status(const StatusMessage& message) override;

  /// Adds this outbox's writers to `monitor` (after create()).
  void watch(IncompatibleQosMonitor& monitor) const;

  /// Sets the state stamped on status samples and publishes a kStateChange sample.
  void set_state(ServiceState state, const std::string& message);

  [[nodiscard]] const std::string& service_id() const { return service_id_; }
  /// Whether `writer` (a sample's publication handle) is one of this outbox's FrameStats
  /// writers (after create()).
  [[nodiscard]] bool own_stats_writer(dds_instance_handle_t writer) const;
  /// Failed writes so far (each is logged).
  [[nodiscard]] std::uint64_t write_errors() const { return write_errors_.load(); }

 private:
  void write_failed(const char* topic, dds_return_t rc);

  std::string service_id_;
  std::string partition_;
  /// The answer writers of the scenes of one ownership strength.
  struct AnswerWriters {
    dds_entity_t forces = 0;
    dds_entity_t stats = 0;
    dds_instance_handle_t stats_handle = 0;
  };
  [[nodiscard]] const AnswerWriters& answer_writers(std::string_view scene) const;

  std::int32_t ownership_strength_ = 0;
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
  std::vector<std::pair<std::string, std::int32_t>> shard_strengths_;
  dds_duration_t answer_lease_ = 0;
  std::map<std::int32_t, AnswerWriters> answer_writers_;  // by strength; made in create()
  dds_entity_t status_writer_ = 0;
  std::atomic<int> state_{0};
  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<std::uint64_t> write_errors_{0};
};

}  // namespace tc::daemon
