// One child process: started with arguments and its output in files, waited for with a
// timeout, signalled, and killed (SIGKILL, then reaped) when its owner goes away. Used by
// `tetcollide demo`, the integration and reliability tests and the service benchmarks;
// each wraps it with its own policy (which signal stops the child, how long it may take).
#pragma once

#include <signal.h>
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/common/result.hpp"

namespace tc::process {

struct SpawnOptions {
  /// The arguments; argv[0] is also the program run (a path: no PATH search) unless
  /// `program` is set.
  std::vector<std::string> argv{};
  /// The program run instead of argv[0] (e.g. /proc/self/exe with argv[0] a name).
  std::filesystem::path program{};
  /// Where stdout and stderr go, the files created when missing; empty: inherited. The
  /// same path for both: one file written through one descriptor.
  std::filesystem::path out{};
  std::filesystem::path err{};
  bool truncate = false;  ///< empty the files first instead of appending to them
  /// The signal the child gets when this process dies (PR_SET_PDEATHSIG).
  int parent_death_signal = SIGKILL;
  /// Default SIGINT and SIGTERM dispositions and no blocked signal in the child, whatever
  /// this process set up for itself.
  bool reset_signals = false;
  /// The child leads a process group of its own, so Ctrl-C in a terminal reaches this
  /// process only (which then stops the child).
  bool own_process_group = false;
};

/// The exit code of a waitpid status, or -1 when the child ended on a signal.
int exit_code(int status);

class Child {
 public:
  Child() = default;
  /// A child still running is SIGKILLed and reaped.
  ~Child();
  Child(Child&& other) noexcept;
  Child& operator=(Child&& other) noexcept;
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  /// Starts the program (the files are opened here, so an error names them). A child
  /// that is already running is SIGKILLed and reaped first. The error is returned when
  /// a file cannot be opened or fork fails; a program that cannot be executed exits 127.
  Status start(const SpawnOptions& options);

  /// True until the child has been seen to exit (by exited(), wait_for(), wait(), stop()).
  [[nodiscard]] bool running() const { return pid_ > 0; }
  /// Process id while running, else -1.
  [[nodiscard]] pid_t pid() const { return pid_; }
  /// The waitpid status of the last child reaped (0 before).
  [[nodiscard]] int status() const { return status_; }

  /// Reaps the child if it has exited, without waiting: true when it has (or none runs).
  bool exited();
  /// Waits up to `timeout` for the exit: its waitpid status, or nothing when the child
  /// still runs (it is left running) or could not be waited for.
  std::optional<int> wait_for(std::chrono::milliseconds timeout);
  /// Waits for the exit without a bound; its waitpid status (-1 when none runs).
  int wait();
  /// Sends `sig` to a running child.
  void signal(int sig) const;
  /// Sends `sig` and waits up to `timeout`; a child still running then is SIGKILLed and
  /// reaped. The waitpid status of an exit within the timeout, else nothing.
  std::optional<int> stop(int sig, std::chrono::milliseconds timeout);

 private:
  void kill_and_reap();

  pid_t pid_ = -1;
  int status_ = 0;
};

}  // namespace tc::process
