// tetcollided configuration: the struct the daemon runs on, its embedded defaults and
// the YAML reader (config/tetcollided.yaml documents every key with its default).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/result.hpp"
#include "core/pipeline/pipeline.hpp"

namespace tc::daemon {

/// Size limits checked on every sample before anything is built from it.
struct Limits {
  std::int64_t max_nodes = 1'000'000;        ///< nodes of one object (IDL bound 1,000,000)
  std::int64_t max_tets = 6'000'000;         ///< tets of one object (IDL bound 6,000,000)
  std::int64_t max_objects_per_scene = 256;  ///< registered objects in one scene
  std::int64_t max_scenes = 256;             ///< scenes served at once
};

struct DaemonConfig {
  // dds:
  std::uint32_t domain = 0;         ///< DDS domain id, 0..232
  std::string service_id;           ///< "" = tetcollided-<host>-<pid>
  std::string partition;            ///< DDS partition of every reader/writer, "" = default
  std::vector<std::string> scenes;  ///< scene name patterns served (fnmatch); empty = all
  std::string cyclonedds_config;    ///< Cyclone config (XML or file://), "" = CYCLONEDDS_URI
  double status_period_s = 1.0;     ///< ServiceStatus heartbeat period, seconds
  /// Ownership strength of the answer writers (ContactForces, FrameStats: EXCLUSIVE):
  /// clients see the answers of the strongest live daemon serving a scene. 0..2^31-1.
  std::int32_t ownership_strength = 0;
  /// Per-shard strengths (dds.shard_strengths): (scene pattern, strength) in the file's
  /// order; a scene takes the strength of the first pattern it matches, else
  /// ownership_strength. One daemon can so be the primary of one shard and the standby of
  /// another (one answer writer per distinct strength).
  std::vector<std::pair<std::string, std::int32_t>> shard_strengths;
  /// Liveliness lease of those answer writers, ms (10..1000): how long after this daemon
  /// stopped a client's reader takes a standby's answers. Shorter than the protocol's 1 s
  /// lease of every other writer, which a client's readers request.
  double answer_lease_ms = 1000.0;

  // threads:
  int threads = 0;  ///< worker threads running scene pipelines; 0 = one per core

  // frames:
  double assembly_wait_ms = 10.0;          ///< wait for the scene's missing states, ms
  double unknown_object_grace_ms = 200.0;  ///< hold a state whose topology is not in yet, ms
  int max_queued_frames = 2;               ///< assembled frames waiting per scene; older drop

  // pipeline:
  PipelineConfig pipeline;

  // limits:
  Limits limits;

  // log:
  std::string log_level = "info";         ///< trace | debug | info | warn | error | off
  std::string log_file;                   ///< "" = stderr only
  double timing_summary_period_s = 10.0;  ///< info line with frame-time percentiles; 0 = off

  // metrics:
  /// Prometheus endpoint GET /metrics, "HOST:PORT" (parse_listen_address); "" = off.
  std::string metrics_listen;
};

/// metrics.listen, parsed: where the metrics endpoint listens.
struct ListenAddress {
  std::string host;        ///< "127.0.0.1", "[::1]": a numeric address, IPv6 in brackets
  std::uint16_t port = 0;  ///< 0: any free port (logged at the start)
  bool loopback = false;   ///< 127.0.0.0/8 or ::1: reachable from this host only
};

/// Parses "HOST:PORT": HOST a numeric IPv4 address, a bracketed IPv6 address or
/// `localhost` (127.0.0.1), PORT 0..65535. The error message names metrics.listen.
Expected<ListenAddress> parse_listen_address(std::string_view text);

/// Parses a configuration document. Keys not given keep their defaults; unknown keys,
/// wrong types and out-of-range values are errors (kParse / kInvalidArgument) whose
/// message is "<name>:<line>:<column>: ..." (1-based). `version: 1` is required.
Expected<DaemonConfig> parse_config(std::string_view text, const std::string& name);

/// Reads and parses a configuration file (kIo when it cannot be read).
Expected<DaemonConfig> load_config(const std::filesystem::path& path);

/// Checks the cross-field and range rules parse_config applies (used after command-line
/// overrides too). The message names the key.
Status check_config(const DaemonConfig& config);

/// True when `scene` is served by a daemon with these scene patterns.
bool scene_selected(const std::vector<std::string>& patterns, std::string_view scene);

/// The ownership strength of `scene`'s answers: that of the first pattern of `shards`
/// (DaemonConfig::shard_strengths) it matches, else `fallback` (ownership_strength).
std::int32_t scene_strength(const std::vector<std::pair<std::string, std::int32_t>>& shards,
                            std::int32_t fallback, std::string_view scene);

}  // namespace tc::daemon
