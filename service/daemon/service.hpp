// tetcollided's service: the DDS participant, the readers of MeshTopology and
// MeshState, the reader loop (one thread, waitset) feeding the Router, the Scheduler
// running the scenes' pipelines on TBB, and the Outbox writing the answers.
#pragma once

#include <memory>

#include "config.hpp"
#include "core/common/result.hpp"

namespace tc::daemon {

class Service {
 public:
  explicit Service(DaemonConfig config);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  /// Creates the DDS entities and publishes STARTING. Errors name the failing DDS call.
  Status start();

  /// Announces READY (ServiceStatus sample, the log line "tetcollided ready" and, when
  /// started by systemd, READY=1), then serves until stop() is called, sending systemd a
  /// STATUS= line every status period and WATCHDOG=1 when it asks for them; announces
  /// STOPPING (and STOPPING=1), lets running frames finish and deletes the DDS entities.
  /// Returns the first unrecoverable DDS error, if any.
  Status run();

  /// Asks run() to return. Thread-safe; not async-signal-safe (call it from a thread
  /// that waits for signals, not from a signal handler).
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "tetcollided-<hostname>-<pid>".
std::string default_service_id();

}  // namespace tc::daemon
