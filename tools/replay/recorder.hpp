// Captures a live session for `tetcollide record`: every MeshTopology, MeshState,
// ContactForces and ServiceStatus sample on a domain (all scenes), time-stamped on
// arrival, written to a recording.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>

#include "core/common/result.hpp"

namespace tc::replay {

struct RecordOptions {
  std::uint32_t domain = 0;
  std::string partition;
  std::filesystem::path out;
  std::chrono::milliseconds duration{0};  ///< 0 = until `stop` becomes true
};

struct RecordSummary {
  std::size_t topologies = 0;
  std::size_t removals = 0;
  std::size_t states = 0;
  std::size_t forces = 0;
  std::size_t status = 0;
};

/// Records until the duration elapsed or `stop` is set (checked every 50 ms). kIo for
/// DDS or file errors.
Expected<RecordSummary> record(const RecordOptions& options, const std::atomic<bool>& stop);

}  // namespace tc::replay
