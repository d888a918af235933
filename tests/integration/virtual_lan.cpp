#include "virtual_lan.hpp"

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>

#include "daemon_process.hpp"

namespace tc::itest {
namespace {

using namespace std::chrono_literals;

/// Absolute path of `ip` (run_program execs without a PATH search), "" when absent.
std::string ip_program() {
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"})
    if (access(p, X_OK) == 0) return p;
  return {};
}

std::string joined(const std::vector<std::string>& argv) {
  std::string s;
  for (const auto& a : argv) {
    if (!s.empty()) s.push_back(' ');
    s.append(a);
  }
  return s;
}

}  // namespace

std::string VirtualLan::unavailable_reason() {
  if (geteuid() != 0) return "network namespace tests need root (ip netns add, veth pairs)";
  const std::string ip = ip_program();
  if (ip.empty()) return "no ip program (iproute2) found";
  const std::string probe = "tcns-" + std::to_string(getpid()) + "-probe";
  const RunResult add = run_program({ip, "netns", "add", probe}, 20s);
  if (add.exit_code != 0) return "ip netns add is not allowed here: " + add.err;
  const RunResult del = run_program({ip, "netns", "del", probe}, 20s);
  if (del.exit_code != 0) return "ip netns del " + probe + " failed: " + del.err;
  return {};
}

std::string VirtualLan::address(int host) {
  return "169.254.77." + std::to_string(host + 1);
}

bool VirtualLan::run(const std::vector<std::string>& argv) {
  if (!error_.empty()) return false;
  const RunResult r = run_program(argv, 20s);
  if (r.exit_code != 0) {
    error_ = joined(argv);
    error_.append(" failed: ").append(r.out).append(r.err);
  }
  return error_.empty();
}

VirtualLan::VirtualLan(int hosts) {
  static std::atomic<int> lans{0};
  const std::string ip = ip_program();
  if (ip.empty()) {
    error_ = "no ip program (iproute2) found";
    return;
  }
  if (hosts < 2) {
    error_ = "a VirtualLan needs at least 2 hosts, got " + std::to_string(hosts);
    return;
  }
  prefix_ = "tcns-" + std::to_string(getpid()) + "-" + std::to_string(lans++) + "-";
  original_ns_fd_ = open("/proc/self/ns/net", O_RDONLY | O_CLOEXEC);
  if (original_ns_fd_ < 0) {
    error_ = "cannot open /proc/self/ns/net";
    return;
  }
  const std::string dev = kInterface;
  if (hosts > 2) {
    switch_ns_ = prefix_ + "sw";
    if (!run({ip, "netns", "add", switch_ns_})) return;
    run({ip, "-n", switch_ns_, "link", "add", "br0", "type", "bridge"});
    run({ip, "-n", switch_ns_, "link", "set", "br0", "up"});
  }
  for (int i = 0; i < hosts; ++i) {
    const std::string ns = prefix_ + "h" + std::to_string(i);
    if (!run({ip, "netns", "add", ns})) return;
    hosts_.push_back(ns);
    run({ip, "-n", ns, "link", "set", "lo", "up"});
  }
  if (hosts == 2) {
    // Both ends are made inside their namespaces, so both may be called tc0.
    run({ip, "link", "add", dev, "netns", hosts_[0], "type", "veth", "peer", "name", dev, "netns",
         hosts_[1]});
  } else {
    for (int i = 0; i < hosts; ++i) {
      const std::string port = "p" + std::to_string(i);
      run({ip, "link", "add", dev, "netns", hosts_[static_cast<std::size_t>(i)], "type", "veth",
           "peer", "name", port, "netns", switch_ns_});
      run({ip, "-n", switch_ns_, "link", "set", port, "master", "br0"});
      run({ip, "-n", switch_ns_, "link", "set", port, "up"});
    }
  }
  for (int i = 0; i < hosts; ++i) {
    const std::string& ns = hosts_[static_cast<std::size_t>(i)];
    run({ip, "-n", ns, "addr", "add", address(i) + "/24", "dev", dev});
    run({ip, "-n", ns, "link", "set", dev, "up"});
  }
}

VirtualLan::~VirtualLan() {
  if (original_ns_fd_ >= 0) {
    setns(original_ns_fd_, CLONE_NEWNET);
    close(original_ns_fd_);
  }
  const std::string ip = ip_program();
  // Deleting a namespace deletes the veth ends in it (and so their peers).
  for (const auto& ns : hosts_) run_program({ip, "netns", "del", ns}, 20s);
  if (!switch_ns_.empty()) run_program({ip, "netns", "del", switch_ns_}, 20s);
}

std::vector<std::string> VirtualLan::exec_prefix(int host,
                                                 const std::vector<std::string>& extra_env) const {
  std::vector<std::string> argv{ip_program(),   "netns",
                                "exec",         ns(host),
                                "/usr/bin/env", std::string("TC_DDS_INTERFACE=") + kInterface};
  argv.insert(argv.end(), extra_env.begin(), extra_env.end());
  return argv;
}

bool VirtualLan::enter(int host) {
  const std::string path = "/run/netns/" + ns(host);
  const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    error_ = "cannot open " + path;
    return false;
  }
  const bool ok = setns(fd, CLONE_NEWNET) == 0;
  close(fd);
  if (!ok) error_ = "setns(" + path + ") failed";
  return ok;
}

}  // namespace tc::itest
