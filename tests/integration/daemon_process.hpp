// Integration-test harness: a private DDS domain per test process, the real tetcollided
// started as a child process (killed with the test if the test dies), and readiness
// waits with bounded timeouts. Nothing here sleeps for a fixed time to "let things
// settle": every wait is for an observable event.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "child_process.hpp"

namespace tc::itest {

/// A domain id no other test process uses at the same time: derived from the pid, in
/// [10, 229]. Tests also run in their own network namespace when run_isolated.sh could
/// create one (then only loopback exists and no other process can see the traffic).
std::uint32_t private_domain();

/// A fresh directory under the build tree's Testing/tmp (or /tmp), removed by the caller.
std::filesystem::path make_temp_dir(const std::string& prefix);

/// Path of a built program given by an environment variable set by CTest (TC_DAEMON,
/// TC_CLI); fails the test when missing.
std::string program_from_env(const char* variable);

/// The committed recordings' folder (TC_RECORDINGS, set by CTest; empty and a test
/// failure when missing).
std::filesystem::path recordings_dir();

/// The committed recordings (`*.jsonl` directly in recordings_dir()), sorted by name.
std::vector<std::filesystem::path> committed_recordings();

class DaemonProcess {
 public:
  /// `config_yaml` is written to a file in `dir` and passed with --config.
  DaemonProcess(std::filesystem::path dir, std::uint32_t domain, std::string config_yaml);
  ~DaemonProcess();
  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;

  /// Programs the daemon runs under from the next start() on, e.g. `ip netns exec <ns>
  /// env VAR=value` (VirtualLan::exec_prefix): they must exec it, so that pid() is the
  /// daemon's.
  void set_command_prefix(std::vector<std::string> prefix) { prefix_ = std::move(prefix); }

  /// Starts the daemon and waits for its "tetcollided ready" log line. False on timeout
  /// or early exit (the log is in log_text()).
  bool start(std::chrono::milliseconds timeout = std::chrono::seconds(20));

  /// Sends `sig` and waits for the exit. Returns the exit status as from waitpid, or -1
  /// when it did not exit within `timeout` (it is then SIGKILLed).
  int stop(int sig, std::chrono::milliseconds timeout = std::chrono::seconds(20));

  /// SIGKILL, no clean-up by the daemon.
  void kill_hard();

  [[nodiscard]] bool running() const { return child_.running(); }
  /// Process id while running (to signal or to read /proc), else -1.
  [[nodiscard]] pid_t pid() const { return child_.pid(); }
  [[nodiscard]] std::string log_text() const;
  [[nodiscard]] std::filesystem::path log_path() const { return log_; }
  /// Waits until the log contains `text`. False on timeout.
  bool wait_for_log(const std::string& text, std::chrono::milliseconds timeout) const;

 private:
  std::filesystem::path dir_;
  std::filesystem::path config_;
  std::filesystem::path log_;
  std::uint32_t domain_;
  std::vector<std::string> prefix_;
  process::Child child_;  ///< SIGKILLed with this object
  int starts_ = 0;
};

/// Any program run in the background (the recorder), killed with the test.
class ChildProcess {
 public:
  /// Starts `argv` with stdout and stderr appended to the given files.
  bool start(const std::vector<std::string>& argv, const std::filesystem::path& out,
             const std::filesystem::path& err);
  /// Sends `sig`, waits for the exit; returns the exit code, or -1 (killed, timeout).
  int stop(int sig, std::chrono::milliseconds timeout = std::chrono::seconds(20));
  /// Process id while running, else -1.
  [[nodiscard]] pid_t pid() const { return child_.pid(); }

 private:
  process::Child child_;  ///< SIGKILLed with this object
};

/// Waits until the file contains `text`. False on timeout.
bool wait_for_file_text(const std::filesystem::path& path, const std::string& text,
                        std::chrono::milliseconds timeout);

/// Runs a program with arguments, stdout and stderr captured, killed after `timeout`.
struct RunResult {
  int exit_code = -1;  ///< -1 when killed by the timeout or a signal
  std::string out;
  std::string err;
};
RunResult run_program(const std::vector<std::string>& argv, std::chrono::milliseconds timeout);

}  // namespace tc::itest
