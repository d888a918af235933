#include "systemd_notify.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

namespace tc::daemon {
namespace {

/// One line, so that a status cannot inject another assignment ("READY=1").
std::string one_line(std::string_view text) {
  std::string s(text);
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

}  // namespace

SystemdNotifier::SystemdNotifier(Clock::time_point now) {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && *socket != '\0';
  std::uint64_t usec = 0;
  const int r = sd_watchdog_enabled(0, &usec);
  if (r < 0) {
    spdlog::warn("systemd watchdog: invalid WATCHDOG_USEC/WATCHDOG_PID ({}); no watchdog pings",
                 std::strerror(-r));
  } else if (r > 0 && usec > 0) {
    interval_ = std::chrono::duration_cast<Clock::duration>(std::chrono::microseconds(usec / 2));
    next_ping_ = now + *interval_;
    spdlog::info("systemd watchdog: WATCHDOG=1 every {} ms", usec / 2000);
  }
}

void SystemdNotifier::ready(std::string_view status) {
  send("READY=1\nSTATUS=" + one_line(status));
}

void SystemdNotifier::status(std::string_view status) {
  send("STATUS=" + one_line(status));
}

void SystemdNotifier::stopping(std::string_view status) {
  send("STOPPING=1\nSTATUS=" + one_line(status));
}

void SystemdNotifier::watchdog(Clock::time_point now) {
  if (!interval_ || now < next_ping_) return;
  send("WATCHDOG=1");
  next_ping_ = now + *interval_;
}

std::optional<Clock::time_point> SystemdNotifier::next_watchdog() const {
  if (!interval_) return std::nullopt;
  return next_ping_;
}

void SystemdNotifier::send(const std::string& state) {
  if (!enabled_) return;
  const int r = sd_notify(0, state.c_str());
  if (r < 0 && !warned_) {
    warned_ = true;
    spdlog::warn(
        "sd_notify to NOTIFY_SOCKET failed: {} (systemd will not see this service's "
        "state; further failures are not logged)",
        std::strerror(-r));
  }
}

std::string status_line(std::size_t scenes, std::size_t objects, double frames_per_s) {
  return fmt::format("{} scene{}, {} object{}, {:.1f} frames/s", scenes, scenes == 1 ? "" : "s",
                     objects, objects == 1 ? "" : "s", std::max(0.0, frames_per_s));
}

}  // namespace tc::daemon
