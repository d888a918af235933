// Several "hosts" on one machine for multi-host DDS tests: network namespaces the test
// creates, joined by veth pairs (two hosts: one pair; more: each host's veth to a bridge
// in a namespace of its own), with link-local addresses 169.254.77.x on the veth only.
// Nothing outside these namespaces is touched, and the destructor removes them (also
// when the test fails; a SIGKILLed test leaves them: `ip netns list | grep tcns-`).
// Needs root (CAP_SYS_ADMIN and CAP_NET_ADMIN in the initial namespaces): tests skip
// with unavailable_reason() elsewhere.
#pragma once

#include <string>
#include <vector>

namespace tc::itest {

class VirtualLan {
 public:
  /// Name of the DDS interface in every host namespace (config/cyclonedds-network.xml
  /// picks it from TC_DDS_INTERFACE).
  static constexpr const char* kInterface = "tc0";

  /// Why namespaces cannot be made here ("" when they can): not root, no `ip`, or
  /// `ip netns add` refused (a container without CAP_SYS_ADMIN).
  static std::string unavailable_reason();

  /// Creates `hosts` (>= 2) namespaces tcns-<pid>-h<i> joined as described above. Check
  /// ok() before use; error() says which command failed.
  explicit VirtualLan(int hosts);
  /// Returns this thread to its original namespace and deletes every namespace made.
  ~VirtualLan();
  VirtualLan(const VirtualLan&) = delete;
  VirtualLan& operator=(const VirtualLan&) = delete;

  [[nodiscard]] bool ok() const { return error_.empty(); }
  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] int hosts() const { return static_cast<int>(hosts_.size()); }
  /// Namespace name of host i.
  [[nodiscard]] const std::string& ns(int host) const { return hosts_.at(host); }
  /// IPv4 link-local address of host i's interface, 169.254.77.(i + 1).
  [[nodiscard]] static std::string address(int host);

  /// argv prefix running a program on host i: {ip, netns, exec, <ns>, env,
  /// TC_DDS_INTERFACE=tc0, extra_env...}; the program follows.
  [[nodiscard]] std::vector<std::string> exec_prefix(
      int host, const std::vector<std::string>& extra_env = {}) const;

  /// Moves the calling thread into host i's namespace (setns), so DDS participants it
  /// creates afterwards live on that host. Call before any DDS entity exists in the
  /// process (Cyclone's threads inherit the namespace of the thread that creates them).
  /// False with error() set on failure.
  bool enter(int host);

 private:
  bool run(const std::vector<std::string>& argv);

  std::string prefix_;
  std::string switch_ns_;
  std::vector<std::string> hosts_;
  std::string error_;
  int original_ns_fd_ = -1;
};

}  // namespace tc::itest
