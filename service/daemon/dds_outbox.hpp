// The daemon's Outbox over DDS: one writer per output topic (ContactForces, FrameStats,
// ServiceStatus). Every ServiceStatus sample is stamped with the service id, the
// current life-cycle state and a sequence number. Thread-safe (dds_write is).
#pragma once

#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <string>

#include "core/common/result.hpp"
#include "outbox.hpp"

namespace tc::daemon {

class DdsOutbox final : public Outbox {
 public:
  /// `ownership_strength`: of the ContactForces and FrameStats writers (EXCLUSIVE
  /// ownership; dds.ownership_strength); `answer_lease_ms`: the liveliness lease those
  /// writers offer (dds.answer_lease_ms, at most the protocol's 1 s).
  DdsOutbox(std::string service_id, std::string partition, std::int32_t ownership_strength,
            double answer_lease_ms);

  /// Creates the topics' writers under `participant`. Errors name the DDS call.
  Status create(dds_entity_t participant);

  void publish_forces(const ForcesMessage& message) override;
  void publish_stats(const StatsMessage& message) override;
  void publish_status(const StatusMessage& message) override;

  /// Sets the state stamped on status samples and publishes a kStateChange sample.
  void set_state(ServiceState state, const std::string& message);

  [[nodiscard]] const std::string& service_id() const { return service_id_; }
  /// Failed writes so far (each is logged).
  [[nodiscard]] std::uint64_t write_errors() const { return write_errors_.load(); }

 private:
  void write_failed(const char* topic, dds_return_t rc);

  std::string service_id_;
  std::string partition_;
  std::int32_t ownership_strength_ = 0;
  dds_duration_t answer_lease_ = 0;
  dds_entity_t forces_writer_ = 0;
  dds_entity_t stats_writer_ = 0;
  dds_entity_t status_writer_ = 0;
  std::atomic<int> state_{0};
  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<std::uint64_t> write_errors_{0};
};

}  // namespace tc::daemon
