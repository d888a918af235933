#include "notify_socket.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace tc::test {
namespace {

std::runtime_error sys_error(const std::string& call) {
  return std::runtime_error(call + ": " + std::strerror(errno));
}

std::vector<std::string_view> lines(std::string_view message) {
  std::vector<std::string_view> out;
  while (!message.empty()) {
    const std::size_t end = message.find('\n');
    out.push_back(message.substr(0, end));
    if (end == std::string_view::npos) break;
    message.remove_prefix(end + 1);
  }
  return out;
}

}  // namespace

FakeNotifySocket::FakeNotifySocket() {
  static std::atomic<int> counter{0};
  const std::string name = "tetcollide-test-notify-" + std::to_string(getpid()) + "-" +
                           std::to_string(counter.fetch_add(1));
  fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw sys_error("socket(AF_UNIX, SOCK_DGRAM)");
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  // Abstract namespace: sun_path starts with a NUL byte, the length counts the name only.
  std::memcpy(addr.sun_path + 1, name.data(), name.size());
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  if (bind(fd_, reinterpret_cast<const sockaddr*>(&addr), len) != 0) {
    const auto e = sys_error("bind(@" + name + ")");
    close(fd_);
    throw e;
  }
  address_ = "@" + name;
}

FakeNotifySocket::~FakeNotifySocket() {
  if (fd_ >= 0) close(fd_);
}

std::optional<std::string> FakeNotifySocket::receive(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    pollfd p{fd_, POLLIN, 0};
    const int r = poll(&p, 1, static_cast<int>(std::max<std::int64_t>(0, left.count())));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return std::nullopt;
    std::array<char, 4096> buffer{};
    const ssize_t n = recv(fd_, buffer.data(), buffer.size(), 0);
    if (n < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    if (n < 0) throw sys_error("recv(notify socket)");
    messages_.emplace_back(buffer.data(), static_cast<std::size_t>(n));
    return messages_.back();
  }
}

std::optional<std::string> FakeNotifySocket::wait_for(std::string_view assignment,
                                                      std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() < 0) return std::nullopt;
    auto m = receive(left);
    if (!m) return std::nullopt;
    if (has_assignment(*m, assignment)) return m;
  }
}

bool has_assignment(std::string_view message, std::string_view assignment) {
  for (const auto line : lines(message))
    if (line == assignment) return true;
  return false;
}

std::optional<std::string> assignment_value(std::string_view message, std::string_view variable) {
  for (const auto line : lines(message))
    if (line.size() > variable.size() && line.substr(0, variable.size()) == variable &&
        line[variable.size()] == '=')
      return std::string(line.substr(variable.size() + 1));
  return std::nullopt;
}

}  // namespace tc::test
