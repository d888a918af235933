// A stand-in for systemd's notification socket (sd_notify(3)): an abstract-namespace
// unix datagram socket, unique per instance (no file to clean up), whose address goes
// into NOTIFY_SOCKET of a process under test. Each datagram is one notification: lines
// of VARIABLE=value assignments ("READY=1\nSTATUS=ready").
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tc::test {

class FakeNotifySocket {
 public:
  /// Binds the socket. Throws std::runtime_error (naming the call and errno) on failure.
  FakeNotifySocket();
  ~FakeNotifySocket();
  FakeNotifySocket(const FakeNotifySocket&) = delete;
  FakeNotifySocket& operator=(const FakeNotifySocket&) = delete;

  /// The NOTIFY_SOCKET value: "@" + the abstract name.
  [[nodiscard]] const std::string& address() const { return address_; }

  /// The next notification, or nullopt when none arrives within `timeout`. Every message
  /// received is also kept in messages().
  std::optional<std::string> receive(std::chrono::milliseconds timeout);

  /// Receives until a notification holds the line `assignment` ("READY=1") and returns
  /// that notification; nullopt on timeout. Messages received before it stay in
  /// messages().
  std::optional<std::string> wait_for(std::string_view assignment,
                                      std::chrono::milliseconds timeout);

  /// Every notification received so far, in arrival order.
  [[nodiscard]] const std::vector<std::string>& messages() const { return messages_; }

 private:
  int fd_ = -1;
  std::string address_;
  std::vector<std::string> messages_;
};

/// True when `message` has the line `assignment` ("READY=1", "STOPPING=1").
bool has_assignment(std::string_view message, std::string_view assignment);

/// The value of `variable` ("STATUS") in `message`, or nullopt.
std::optional<std::string> assignment_value(std::string_view message, std::string_view variable);

}  // namespace tc::test
