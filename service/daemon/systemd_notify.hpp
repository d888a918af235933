// systemd's service notification protocol (sd_notify(3)) for tetcollided, so that a
// `Type=notify` unit knows when the service is ready and what it is doing:
//   READY=1 + STATUS=   once the readers and writers are up ("tetcollided ready")
//   STATUS=             now and then: scenes, objects, frames/s
//   WATCHDOG=1          from the reader loop, every half of WatchdogSec (WATCHDOG_USEC)
//   STOPPING=1          when the service starts to stop (SIGTERM, SIGINT)
// Not started by systemd (no NOTIFY_SOCKET in the environment) every call does nothing,
// so the daemon behaves the same from a shell, a test or a unit. DDS-free; time is passed
// in, so the watchdog schedule is tested with a fake clock.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include "frame_assembler.hpp"  // Clock

namespace tc::daemon {

class SystemdNotifier {
 public:
  /// Reads NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID (through libsystemd). `now`
  /// starts the watchdog schedule: the first WATCHDOG=1 is due half a period later.
  explicit SystemdNotifier(Clock::time_point now);

  /// True when NOTIFY_SOCKET is set (started by systemd, or by a test posing as it).
  [[nodiscard]] bool enabled() const { return enabled_; }

  /// "READY=1" and "STATUS=<status>" in one message.
  void ready(std::string_view status);
  /// "STATUS=<status>" (one line: newlines are replaced by spaces).
  void status(std::string_view status);
  /// "STOPPING=1" and "STATUS=<status>".
  void stopping(std::string_view status);

  /// Sends "WATCHDOG=1" when a ping is due at `now`; the next is due half a watchdog
  /// period later. Does nothing when systemd set no watchdog for this process.
  void watchdog(Clock::time_point now);
  /// When watchdog() has to be called next at the latest; nullopt without a watchdog.
  [[nodiscard]] std::optional<Clock::time_point> next_watchdog() const;
  /// Half the watchdog period systemd gave this process, or nullopt.
  [[nodiscard]] std::optional<Clock::duration> watchdog_interval() const { return interval_; }

 private:
  void send(const std::string& state);

  bool enabled_ = false;
  bool warned_ = false;  // a failed send is logged once, not every second
  std::optional<Clock::duration> interval_;
  Clock::time_point next_ping_{};
};

/// The STATUS= line of the daemon: "2 scenes, 5 objects, 59.8 frames/s".
/// frames_per_s: frames dispatched to the scenes' pipelines per second, >= 0.
std::string status_line(std::size_t scenes, std::size_t objects, double frames_per_s);

}  // namespace tc::daemon
